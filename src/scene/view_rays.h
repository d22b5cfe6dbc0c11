// The rays of a probe's view, as the cpu casts them (scene/ray_bake.h) and the gpu reads its rays'
// distances back (gpu/ray_capture.h, whose capture_rays.comp casts the same): s x s through each
// texel of a 6 x N x N cube map, through its centre where s is 1, else one jittered in each stratum
// of the texel (glsl/texel_geometry.h stratumCoord) by the texel's own random numbers (the same for
// every probe), drawn as a device draws them (glsl/random_words.h).
#pragma once
#include "glsl/texel_geometry.h"
#include "scene/sampling.h"
#include "sh/cubemap.h"

#include <cstdint>

namespace shprobe {

// The stream of texel t, (face N + j) N + i, is (seed, kViewStream, t).
constexpr uint64_t kViewStream = ~uint64_t(0);

// The state texel t's stream starts from is mix64(viewStreamBase(seed) + t): a device adds t itself.
inline uint64_t viewStreamBase(uint64_t seed) {
    return mix64(mix64(seed) + kViewStream);
}

// Calls ray(direction) for each ray of a view of faces `faceSize` with s x s rays per texel (faces,
// rows, columns, then the texel's strata row by row, in order), and texel(face, i, j) after each
// texel's.
template <typename Ray, typename Texel>
void forEachViewRay(int faceSize, int s, uint64_t seed, Ray&& ray, Texel&& texel) {
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
                texel(face, int(i), int(j));
            }
}

} // namespace shprobe
