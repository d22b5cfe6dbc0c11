// The random numbers of the gpu's paths (gpu/ray_capture.h, glsl/ray_paths.glsl), named by a probe's
// place in the world (view_rays.h placeIndex), as the cpu's are (scene/ray_bake.cpp): the gpu starts
// each probe's stream from the state and shift this gives.
#pragma once
#include "scene/sampling.h"
#include "scene/view_rays.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>

namespace shprobe {

// The stream of a probe's paths, (seed, kProbePathStream, its view's placeIndex): one no view's is.
constexpr uint64_t kProbePathStream = kSphereViewStream - 1;

// The step between points of the R2 sequence (Roberts, "The Unreasonable Effectiveness of
// Quasirandom Sequences", 2018): (1 / g, 1 / g^2), g the plastic number, x^3 = x + 1.
constexpr double kPlasticNumber = 1.32471795724474602596;
constexpr glm::dvec2 kR2Step(1.0 / kPlasticNumber, 1.0 / (kPlasticNumber * kPlasticNumber));

// The first bounce of the probe's ray k leaves by point k of the R2 sequence shifted by the probe's
// own random offset (a Cranley-Patterson rotation: each point stays uniform, so the estimate stays
// unbiased): neighbouring rays' bounces spread over the hemisphere instead of clumping, which halves
// the bounce's error on the engine (docs/scene-probes.md). Deeper bounces draw from the stream; the
// device continues it by the ray's index, a stream per ray.
class DeviceProbePaths {
  public:
    DeviceProbePaths(uint64_t seed, uint64_t viewIndex)
        : random_(seed, kProbePathStream, viewIndex), shift_(random_.next(), random_.next()) {}
    // The probe ray whose path is traced next.
    void startRay(uint64_t ray) { ray_ = ray; }
    // The unit square's point for the first bounce of that ray.
    glm::dvec2 firstBounce() const {
        const glm::dvec2 point = shift_ + double(ray_) * kR2Step;
        return point - glm::floor(point);
    }
    glm::dvec2 deeperBounce() {
        const double u1 = random_.next();
        return {u1, random_.next()};
    }
    // Three numbers for a point on the emitters (EmitterSampler::sample).
    glm::dvec3 emitterPoint() {
        const double u0 = random_.next();
        const double u1 = random_.next();
        return {u0, u1, random_.next()};
    }
    // The R2 sequence's shift, and the stream's state before its next draw.
    glm::dvec2 shift() const { return shift_; }
    uint64_t state() const { return random_.state(); }

  private:
    RandomStream random_;
    glm::dvec2 shift_;
    uint64_t ray_ = 0;
};

} // namespace shprobe
