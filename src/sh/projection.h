// Double-precision reference projection of environments onto SH: L_lm = sum L(w) y_lm(w) dOmega,
// each texel weighted by its exact solid angle (Sloan, "Stupid Spherical Harmonics (SH) Tricks",
// projection from cube maps).
#pragma once
#include "sh/coefficients.h"
#include "sh/cubemap.h"

namespace shprobe {

ShCoefficients projectCubemap(const Cubemap& cubemap, int order);
ShCoefficients projectEquirect(const Image& equirect, int order);

} // namespace shprobe
