// Stands for the part of Filament's IndirectLight (and math::float3) that docs/exports.md's
// Filament snippet uses, only so that it compiles and runs in test_engine_exports: the light
// build() makes holds the values given to irradiance(), which the test evaluates with Filament's
// shader formula.
#pragma once

#include <algorithm>

namespace filament {
namespace math {
struct float3 {
    float r, g, b;
};
} // namespace math

class Engine;

struct IndirectLight {
    class Builder {
      public:
        Builder& irradiance(int bands, const math::float3* sh) {
            bands_ = bands;
            std::copy_n(sh, std::min(bands * bands, 9), sh_);
            return *this;
        }
        IndirectLight* build(Engine&) {
            auto* light = new IndirectLight{bands_, {}};
            std::copy_n(sh_, 9, light->sh);
            return light;
        }

      private:
        int bands_ = 0;
        math::float3 sh_[9] = {};
    };
    int bands = 0;
    math::float3 sh[9] = {};
};
} // namespace filament
