#include "scene/volume_bake.h"

#include "common/error.h"
#include "common/parallel.h"
#include "sh/irradiance.h"
#include "sh/projection.h"

#include <algorithm>
#include <cmath>

namespace shprobe {

namespace {

// The world lit by nothing but its sky: no emission, no suns.
World skyLitOnly(const World& world) {
    World dark = world;
    for (SceneMaterial& material : dark.materials)
        material.emission = glm::vec3(0.0f);
    dark.suns.clear();
    return dark;
}

// Copies the radiance of one of bakeVolumeTransfer's bakes into the transfer's column `column`.
void storeTransferColumn(ProbeVolume& relightable, const ProbeVolume& bake, size_t column) {
    const size_t perProbe = size_t(relightable.order) * size_t(relightable.order);
    for (size_t p = 0; p < relightable.probeCount(); ++p)
        for (size_t i = 0; i < perProbe; ++i)
            relightable.transfer[(p * perProbe + i) * perProbe + column] = bake.radiance[p * perProbe + i];
}

} // namespace

uint64_t transferProbeCount(int order, ProbeRange range) {
    return uint64_t(order * order + 1) * (range.end - range.begin);
}

ProbeVolume bakeVolumeByRays(const World& world, const ProbeSky& sky, const VolumeBakeOptions& options,
                             const ProbeGrid& grid, ProbeRange range, VolumeBakeReport& report,
                             const VolumeProgress& progress) {
    RayBakeOptions rays = options.rays;
    rays.skySuns = sky.suns;
    RayBaker baker(world, sky.cubemap, rays);
    std::vector<RayBakedProbe> probes = baker.bakeProbes(probePositions(grid, range), [&](size_t done) {
        if (!progress) return;
        const RayBakeCounts sofar = baker.counts();
        progress(done, sofar.probeRays + sofar.cacheRays);
    });
    const std::vector<uint32_t> filled =
        options.dilate ? dilateInvalidProbes(
                             probes, rays.faceSize, rays.relocation.invalidBackFaces, grid, range,
                             [&](std::span<const glm::dvec3> beyond) { return baker.bakeProbes(beyond); })
                       : std::vector<uint32_t>{};
    report = {
        baker.counts(),
        size_t(std::count_if(probes.begin(), probes.end(),
                             [](const RayBakedProbe& probe) { return probe.offset != glm::vec3(0.0f); })),
        filled.size()};

    const std::span<const RayBakedProbe> baked(probes);
    ProbeVolume volume =
        volumeOfProbes(baked, rays.order, rays.faceSize, rays.relocation.invalidBackFaces, grid, range);
    if (rays.relocation.limit > 0.0)
        for (const RayBakedProbe& probe : probes)
            volume.offsets.push_back(probe.offset);
    volume.bounces = rays.bounces;
    volume.visibilitySize = rays.visibilitySize;
    for (const RayBakedProbe& probe : probes)
        volume.visibility.insert(volume.visibility.end(), probe.visibility.begin(), probe.visibility.end());
    storeFilledProbes(volume, baked, filled, float(baker.visibilityRange()));
    return volume;
}

ProbeVolume bakeVolumeTransfer(const World& world, int skyFaceSize, const VolumeBakeOptions& options,
                               const ProbeGrid& grid, ProbeRange range, VolumeBakeReport& report,
                               const VolumeProgress& progress) {
    if (options.rays.cacheRefinement > 0)
        throw Error(ErrorKind::Input, "transfer: cache refinement halves cells where their light differs, so "
                                      "its bake is not linear in the sky; bake transfer without it");
    if (!options.rays.skySuns.empty())
        throw Error(ErrorKind::Input, "transfer: a sun taken out of the sky would not turn with it");
    if (options.rays.bounceLight == BounceLight::Paths)
        throw Error(ErrorKind::Input,
                    "transfer: bounces by paths sample the sky where it is bright, so their "
                    "bake is not linear in the sky; bake transfer from the cache");
    const int order = options.rays.order;
    const size_t columns = size_t(order) * size_t(order);
    const uint64_t probes = range.end - range.begin;
    uint64_t probesBefore = 0, raysBefore = 0;
    VolumeBakeOptions linear = options; // the same rays under every sky
    linear.rays.skyThroughStrata = false;
    auto bake = [&](const World& lit, const ShCoefficients& sky) {
        VolumeBakeReport part;
        ProbeVolume volume = bakeVolumeByRays(lit, {evaluateCubemap(sky, skyFaceSize), {}}, linear, grid,
                                              range, part, [&](uint64_t done, uint64_t rays) {
                                                  if (progress)
                                                      progress(probesBefore + done, raysBefore + rays);
                                              });
        probesBefore += probes;
        raysBefore += part.counts.probeRays + part.counts.cacheRays;
        report.counts.probeRays += part.counts.probeRays;
        report.counts.cacheRays += part.counts.cacheRays;
        report.counts.cachePoints += part.counts.cachePoints;
        report.relocated = part.relocated;
        report.filled = part.filled;
        return volume;
    };

    report = {};
    ProbeVolume relightable = bake(world, makeCoefficients(order, Quantity::Radiance));
    relightable.staticRadiance = relightable.radiance;
    relightable.transfer.assign(relightable.radiance.size() * columns, glm::vec3(0.0f));
    const World skyLit = skyLitOnly(world);
    for (size_t j = 0; j < columns; ++j) {
        ShCoefficients basis = makeCoefficients(order, Quantity::Radiance);
        basis.rgb[j] = glm::dvec3(1.0);
        storeTransferColumn(relightable, bake(skyLit, basis), j);
    }
    return relightable;
}

void relightVolume(ProbeVolume& volume, const ShCoefficients& sky) {
    if (volume.transfer.empty())
        throw Error(ErrorKind::Input,
                    "the volume holds no transfer (bake it with `shprobe scene --transfer`)");
    if (sky.order != volume.order)
        throw Error(ErrorKind::Input, "a sky of order " + std::to_string(sky.order) +
                                          " for a volume of order " + std::to_string(volume.order));
    const size_t perProbe = size_t(volume.order) * size_t(volume.order);
    std::vector<glm::dvec3> bandFactors(perProbe);
    for (int l = 0; l < volume.order; ++l)
        for (int m = -l; m <= l; ++m)
            bandFactors[size_t(l * (l + 1) + m)] = glm::dvec3(irradianceBandFactor(l));
    volume.radiance.resize(volume.staticRadiance.size());
    volume.irradiance.resize(volume.staticRadiance.size());
    const int probes = int(volume.probeCount());
    forEachItem(probes, threadCount(volume.transfer.size(), 1 << 16), [&](int p) {
        const size_t first = size_t(p) * perProbe;
        for (size_t i = 0; i < perProbe; ++i) {
            const glm::vec3* row = &volume.transfer[(first + i) * perProbe];
            glm::dvec3 radiance(volume.staticRadiance[first + i]);
            for (size_t j = 0; j < perProbe; ++j)
                radiance += glm::dvec3(row[j]) * sky.rgb[j];
            volume.radiance[first + i] = glm::vec3(radiance);
            volume.irradiance[first + i] = glm::vec3(radiance * bandFactors[i]);
        }
    });
}

} // namespace shprobe
