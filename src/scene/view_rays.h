// The rays of a probe's view, as the cpu casts them (scene/ray_bake.h) and the gpu reads its rays'
// distances back (gpu/ray_capture.h, whose capture_rays.comp casts the same): s x s through each
// texel of a 6 x N x N cube map, through its centre where s is 1, else one jittered in each stratum
// of the texel (glsl/texel_geometry.h stratumCoord) by the texel's own random numbers (the same for
// every probe), drawn as a device draws them (glsl/random_words.h).
#pragma once
#include "glsl/texel_geometry.h"
#include "scene/sampling.h"
#include "sh/cubemap.h"

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace shprobe {

// The stream of texel t, (face N + j) N + i, is (seed, kViewStream, t).
constexpr uint64_t kViewStream = ~uint64_t(0);

// The state texel t's stream starts from is mix64(viewStreamBase(seed) + t): a device adds t itself.
inline uint64_t viewStreamBase(uint64_t seed) {
    return mix64(mix64(seed) + kViewStream);
}

// Calls ray(direction) for each ray of a view of faces `faceSize` with s x s rays per texel (faces,
// rows, columns, then the texel's strata row by row, in order).
template <typename Ray> void forEachViewRay(int faceSize, int s, uint64_t seed, Ray&& ray) {
    const uint32_t n = uint32_t(faceSize), side = uint32_t(s);
    for (int face = 0; face < kFaceCount; ++face)
        for (uint32_t j = 0; j < n; ++j)
            for (uint32_t i = 0; i < n; ++i) {
                RandomStream random(seed, kViewStream, (uint64_t(face) * n + j) * n + i);
                for (uint32_t sb = 0; sb < side; ++sb)
                    for (uint32_t sa = 0; sa < side; ++sa) {
                        const float ja = side == 1 ? 0.5f : random.nextFloat();
                        const float jb = side == 1 ? 0.5f : random.nextFloat();
                        ray(faceDirection(face, glsl::stratumCoord(i, sa, side, ja, n),
                                          glsl::stratumCoord(j, sb, side, jb, n)));
                    }
            }
}

// The stream of a sphere view's rotation, (seed, kSphereViewStream, the view's placeIndex): one no
// texel's stream is.
constexpr uint64_t kSphereViewStream = ~uint64_t(0) - 1;

// The index of the streams of a view from `position` in a world whose box starts at `boundsMin` and
// whose diagonal is `size`: its place in that box, (position - boundsMin) / size rounded to 2^-16,
// mixed. A probe at the same place in a scaled scene draws the same random numbers, so that scenes
// scaled about the origin bake to the same volume (docs/scene-probes.md, "Scale"). A world without
// triangles has no box (its bounds are not finite): there every place is the same.
inline uint64_t placeIndex(const glm::dvec3& position, const glm::dvec3& boundsMin, double size) {
    uint64_t index = 0;
    for (int axis = 0; axis < 3; ++axis) {
        const double place = std::nearbyint((position[axis] - boundsMin[axis]) / size * 0x1p16);
        const double bounded = std::isfinite(place) ? std::clamp(place, -0x1p62, 0x1p62) : 0.0;
        index = mix64(index + uint64_t(int64_t(bounded)));
    }
    return index;
}

// The stream of a probe's paths, (seed, kProbePathStream, its view's placeIndex): one no view's is.
constexpr uint64_t kProbePathStream = kSphereViewStream - 1;

// The seed of the Owen-scrambled Sobol' sets a probe's paths draw from, set `use` named by
// mix64(probePathSeed + use) (scene/ray_bake.cpp ProbePaths, glsl/ray_paths.glsl).
inline uint64_t probePathSeed(uint64_t seed, uint64_t viewIndex) {
    return mix64(mix64(seed) + kProbePathStream) + viewIndex;
}

// Calls ray(direction) for each of `count` directions stratified over the sphere: the spherical
// Fibonacci set (sampling.h) under a uniformly random rotation of its own for each view (named by its
// placeIndex), so that each direction is uniform on the sphere and (4 pi / count) sum L(w) y_lm(w) is
// an unbiased projection whose error falls faster than independent directions' (Marques et al.).
template <typename Ray> void forEachSphereRay(int count, uint64_t seed, uint64_t viewIndex, Ray&& ray) {
    RandomStream random(seed, kSphereViewStream, viewIndex);
    const glm::dmat3 rotation = randomRotation(random);
    for (int k = 0; k < count; ++k)
        ray(rotation * fibonacciDirection(k, count));
}

} // namespace shprobe
