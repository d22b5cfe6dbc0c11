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
#include "sh/irradiance.h"

#include <glm/vector_relational.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
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

// Visits the probes of the 3 x 3 x 3 block around `index` (not itself) with their distance in cells.
template <typename Visit> void forEachNeighbour(const ProbeGrid& grid, uint32_t index, const Visit& visit) {
    const glm::ivec3 cell = probeCell(grid, index);
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const glm::ivec3 next = cell + glm::ivec3(dx, dy, dz);
                if ((dx | dy | dz) == 0 || glm::any(glm::lessThan(next, glm::ivec3(0))) ||
                    glm::any(glm::greaterThanEqual(next, grid.counts)))
                    continue;
                visit(probeIndex(grid, next), std::sqrt(double(dx * dx + dy * dy + dz * dz)));
            }
}

// Fills the probes [range.begin, range.end) of `probes` still inside geometry (as volumeOfProbes
// tells) from their valid neighbours, as Unity's dilation does: the mean of the valid probes of its
// 3 x 3 x 3 block weighed by the inverse of their distance in cells. bake(positions) gives the
// neighbours beyond the range (a brick's), so that a brick is exactly its part of the whole bake.
// Probe as volumeOfProbes's; returns the flat indices of those filled, in order.
template <typename Probe, typename Bake>
std::vector<uint32_t> dilateInvalidProbes(std::vector<Probe>& probes, int faceSize, double invalidBackFaces,
                                          const ProbeGrid& grid, ProbeRange range, const Bake& bake) {
    auto invalid = [&](const Probe& probe) {
        return insideGeometry(probe.backFaceTexels, faceSize, invalidBackFaces);
    };
    std::map<uint32_t, size_t> beyond; // neighbours beyond the range, by flat index
    std::vector<glm::dvec3> beyondPositions;
    for (uint32_t p = range.begin; p < range.end; ++p) {
        if (!invalid(probes[p - range.begin])) continue;
        forEachNeighbour(grid, p, [&](uint32_t q, double) {
            if ((q >= range.begin && q < range.end) || beyond.count(q)) return;
            beyond[q] = beyondPositions.size();
            beyondPositions.push_back(probePosition(grid, probeCell(grid, q)));
        });
    }
    const std::vector<Probe> extra = beyondPositions.empty() ? std::vector<Probe>{} : bake(beyondPositions);
    auto probeAt = [&](uint32_t q) -> const Probe& {
        return q >= range.begin && q < range.end ? probes[q - range.begin] : extra[beyond.at(q)];
    };
    std::vector<Probe> filled = probes;
    std::vector<uint32_t> filledIndices;
    for (uint32_t p = range.begin; p < range.end; ++p) {
        Probe& probe = filled[p - range.begin];
        if (!invalid(probe)) continue;
        double weights = 0.0;
        ShCoefficients radiance = makeCoefficients(probe.radiance.order, Quantity::Radiance);
        forEachNeighbour(grid, p, [&](uint32_t q, double distance) {
            const Probe& neighbour = probeAt(q);
            if (invalid(neighbour)) return;
            for (size_t i = 0; i < radiance.rgb.size(); ++i)
                radiance.rgb[i] += neighbour.radiance.rgb[i] / distance;
            weights += 1.0 / distance;
        });
        if (weights == 0.0) continue;
        for (glm::dvec3& coefficient : radiance.rgb)
            coefficient /= weights;
        probe.radiance = radiance;
        probe.irradiance = convolveIrradiance(radiance);
        filledIndices.push_back(p);
    }
    probes = std::move(filled);
    return filledIndices;
}

// Makes the probes of `filled` (dilateInvalidProbes's, flat indices) valid in a volume of
// volumeOfProbes, with their coefficients and a visibility map that hides nothing: every texel
// (far, far^2), far the range the maps record.
template <typename Probe>
void storeFilledProbes(ProbeVolume& volume, std::span<const Probe> probes, std::span<const uint32_t> filled,
                       float far) {
    const size_t texels = size_t(volume.visibilitySize) * size_t(volume.visibilitySize);
    const size_t perProbe = size_t(volume.order) * size_t(volume.order);
    for (uint32_t p : filled) {
        const size_t k = p - volume.begin;
        volume.valid[k] = 1;
        for (size_t i = 0; i < perProbe; ++i) {
            volume.radiance[k * perProbe + i] = glm::vec3(probes[k].radiance.rgb[i]);
            volume.irradiance[k * perProbe + i] = glm::vec3(probes[k].irradiance.rgb[i]);
        }
        std::fill_n(volume.visibility.begin() + ptrdiff_t(k * texels), texels, glm::vec2(far, far * far));
    }
}

// Called with the probes done so far (of as many as the bake reports), and the rays cast.
using VolumeProgress = std::function<void(uint64_t probesDone, uint64_t rays)>;

// The probes bakeVolumeTransfer bakes for a range: order^2 + 1 times its probes.
uint64_t transferProbeCount(int order, ProbeRange range);

// Probes [range.begin, range.end) of the grid, every bounce, into a volume (grid, order, range,
// radiance, irradiance, validity, visibility, capture offsets where options.rays.relocation moves
// probes, bounces; source and settings are the caller's). A probe still inside geometry is filled
// from its valid neighbours (options.dilate: dilateInvalidProbes, storeFilledProbes).
ProbeVolume bakeVolumeByRays(const World& world, const ProbeSky& sky, const VolumeBakeOptions& options,
                             const ProbeGrid& grid, ProbeRange range, VolumeBakeReport& report,
                             const VolumeProgress& progress = {});

// The same probes' static radiance and transfer (formats/probe_volume.h), the sky's basis functions
// drawn at `skyFaceSize` (the footprint of the probes' rays); radiance and irradiance hold the static
// part. Throws Error(Input) for options whose bake is not linear in the sky (cache refinement, which
// halves cells where their light differs; suns taken out of a sky; bounces by paths, which sample
// the sky where it is bright).
ProbeVolume bakeVolumeTransfer(const World& world, int skyFaceSize, const VolumeBakeOptions& options,
                               const ProbeGrid& grid, ProbeRange range, VolumeBakeReport& report,
                               const VolumeProgress& progress = {});

// Sets a volume's radiance and irradiance to those under the sky of radiance coefficients `sky`, of
// the volume's order, from its transfer: L_i = static_i + sum_j T_ij S_j, E_i = A_l L_i. Invalid
// probes stay zero. Throws Error(Input) for a volume without transfer or a sky of another order.
void relightVolume(ProbeVolume& volume, const ShCoefficients& sky);

} // namespace shprobe
