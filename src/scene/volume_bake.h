// Probe volumes baked by rays (scene/ray_bake.h) over a grid or a brick of it, and their radiance
// transfer, by which a volume is relit under another sky without a capture:
//
//   ProbeVolume volume = bakeVolumeByRays(world, sky, options, grid, range, report);
//   ProbeVolume relightable = bakeVolumeTransfer(world, skyFaceSize, options, grid, range, report);
//   relightVolume(relightable, projectCubemap(otherSky, relightable.order));
//
// A bake is linear in the light of its sky: the probes' rays, the cache points the surfaces gather
// bounces with and their random numbers depend on the geometry alone, and nothing is clamped. So
// the volume under a sky of SH coefficients S_j is the volume under none (emission and the scene's
// suns: the static part) plus sum_j S_j times the volume under the sky y_j(w) with neither emission
// nor suns (Sloan, Kautz and Snyder, "Precomputed Radiance Transfer for Real-Time Rendering in
// Dynamic, Low-Frequency Lighting Environments", 2002, for probes rather than vertices; probe volumes
// relit so for the time of day as in Far Cry 3). bakeVolumeTransfer bakes those order^2 + 1 volumes with
// the same rays: relit with S, it is the bake under the sky evaluateCubemap(S) to float rounding.
#pragma once
#include "formats/probe_volume.h"
#include "scene/probe_grid.h"
#include "scene/ray_bake.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace shprobe {

// A sky as the probes' rays see it: its texels, and suns taken out of it (RayBakeOptions::skySuns).
struct ProbeSky {
    Cubemap cubemap;
    std::vector<SceneSun> suns;
};

struct VolumeBakeOptions {
    RayBakeOptions rays; // the probes and bounces; relocation lengths in world units
    bool dilate = true;  // probes still inside geometry are filled from their valid neighbours
};

struct VolumeBakeReport {
    RayBakeCounts counts;
    size_t relocated = 0; // probes moved out of geometry, valid where they were captured
    size_t filled = 0;    // invalid probes filled from their neighbours
};

// Probes [range.begin, range.end) into a volume: the coefficients of valid probes, zeros for those
// inside geometry (more than `invalidBackFaces` of their view on back faces). Probe is any type with
// radiance and irradiance coefficients and backFaceTexels (RayBakedProbe, the GPU capture's probes).
template <typename Probe>
ProbeVolume volumeOfProbes(std::span<const Probe> probes, int order, int faceSize, double invalidBackFaces,
                           const ProbeGrid& grid, ProbeRange range) {
    ProbeVolume volume{.grid = grid, .order = order, .begin = range.begin, .end = range.end};
    const size_t perProbe = size_t(order) * size_t(order);
    volume.radiance.assign(probes.size() * perProbe, glm::vec3(0.0f));
    volume.irradiance.assign(probes.size() * perProbe, glm::vec3(0.0f));
    volume.valid.assign(probes.size(), 0);
    for (size_t p = 0; p < probes.size(); ++p) {
        if (insideGeometry(probes[p].backFaceTexels, faceSize, invalidBackFaces)) continue;
        volume.valid[p] = 1;
        for (size_t i = 0; i < perProbe; ++i) {
            volume.radiance[p * perProbe + i] = glm::vec3(probes[p].radiance.rgb[i]);
            volume.irradiance[p * perProbe + i] = glm::vec3(probes[p].irradiance.rgb[i]);
        }
    }
    return volume;
}

// Called with the probes done so far (of as many as the bake reports), and the rays cast.
using VolumeProgress = std::function<void(uint64_t probesDone, uint64_t rays)>;

// The probes bakeVolumeTransfer bakes for a range: order^2 + 1 times its probes.
uint64_t transferProbeCount(int order, ProbeRange range);

// Probes [range.begin, range.end) of the grid, every bounce, into a volume (grid, order, range,
// radiance, irradiance, validity, visibility, capture offsets where options.rays.relocation moves
// probes, bounces; source and settings are the caller's). A probe still inside geometry is filled
// from its valid neighbours (options.dilate), as Unity's dilation does: the mean of the valid probes
// of its 3 x 3 x 3 block weighed by the inverse of their distance in cells, made valid, with a
// visibility map that hides nothing. A brick bakes the neighbours it lacks, so that it is exactly its
// part of the whole bake.
ProbeVolume bakeVolumeByRays(const World& world, const ProbeSky& sky, const VolumeBakeOptions& options,
                             const ProbeGrid& grid, ProbeRange range, VolumeBakeReport& report,
                             const VolumeProgress& progress = {});

// The same probes' static radiance and transfer (formats/probe_volume.h), the sky's basis functions
// drawn at `skyFaceSize` (the footprint of the probes' rays); radiance and irradiance hold the static
// part. Throws Error(Input) for options whose bake is not linear in the sky (cache refinement, which
// halves cells where their light differs; suns taken out of a sky).
ProbeVolume bakeVolumeTransfer(const World& world, int skyFaceSize, const VolumeBakeOptions& options,
                               const ProbeGrid& grid, ProbeRange range, VolumeBakeReport& report,
                               const VolumeProgress& progress = {});

// Sets a volume's radiance and irradiance to those under the sky of radiance coefficients `sky`, of
// the volume's order, from its transfer: L_i = static_i + sum_j T_ij S_j, E_i = A_l L_i. Invalid
// probes stay zero. Throws Error(Input) for a volume without transfer or a sky of another order.
void relightVolume(ProbeVolume& volume, const ShCoefficients& sky);

} // namespace shprobe
