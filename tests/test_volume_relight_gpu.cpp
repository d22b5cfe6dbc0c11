// relight_volume.comp (gpu/volume_relighter.h) against relightVolume (scene/volume_bake.h) on
// lavapipe with the validation layer on: a volume baked with its transfer in a Cornell box open to
// the sky, and volumes of every order filled with values that all differ, invalid probes among them.
#include "gpu/volume_relighter.h"
#include "gpu_test.h"
#include "image/environment.h"
#include "scene/probe_grid.h"
#include "scene/volume_bake.h"
#include "scene_fixtures.h"
#include "sh/basis.h"
#include "sh/projection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace shprobe {
namespace {

using testing::GpuTest;

class VolumeRelightTest : public GpuTest {};

struct Agreement {
    double worst = 0.0;   // largest |GPU - CPU| over every coefficient and channel
    double largest = 0.0; // largest |E| of the CPU's
};

// The GPU's irradiance against the CPU's relight of the same volume; its validity in w exactly.
Agreement relightOnBoth(const Context& context, const ProbeVolume& volume, const ShCoefficients& sky) {
    VolumeRelighter relighter = createVolumeRelighter(context, volume.order);
    const std::vector<glm::vec4> gpu = relightVolumeOnGpu(context, relighter, volume, sky);
    destroyVolumeRelighter(context, relighter);
    ProbeVolume cpu = volume;
    relightVolume(cpu, sky);
    const size_t perProbe = size_t(coefficientCount(volume.order));
    EXPECT_EQ(gpu.size(), cpu.irradiance.size());
    Agreement agreement;
    for (size_t k = 0; k < std::min(gpu.size(), cpu.irradiance.size()); ++k) {
        EXPECT_EQ(gpu[k].w, float(volume.valid[k / perProbe])) << k;
        for (int c = 0; c < 3; ++c) {
            agreement.worst =
                std::max(agreement.worst, std::abs(double(gpu[k][c]) - double(cpu.irradiance[k][c])));
            agreement.largest = std::max(agreement.largest, std::abs(double(cpu.irradiance[k][c])));
        }
    }
    return agreement;
}

// The GPU sums order^2 float products where the CPU sums in double and rounds once: at most order^2
// roundings of terms no larger than the largest |E| / A_l's scale, about 64 x 6e-8 at order 8.
// 1e-5 of the largest |E| leaves room for that and catches any value taken from the wrong place.
constexpr double kTolerance = 1e-5;

TEST_F(VolumeRelightTest, BakedVolumeRelitOnTheDeviceEqualsTheCpu) {
    const World world = testing::loadCornellBoxWorld({.innerBoxes = true});
    const ProbeGrid grid = probeGridInWorld({3, 2, 2}, world);
    VolumeBakeReport report;
    const ProbeVolume volume = bakeVolumeTransfer(
        world, 16, {.rays = {.order = 3, .faceSize = 8, .raysPerTexel = 4, .bounces = 1, .gatherRays = 16}},
        grid, {0, grid.probeCount()}, report);
    const Agreement agreement = relightOnBoth(context(), volume, projectCubemap(makeDefaultSky(32), 3));
    std::printf("baked Cornell box, order 3: worst %.3g of the largest |E| %.3g\n",
                agreement.worst / agreement.largest, agreement.largest);
    EXPECT_GT(agreement.largest, 0.1);
    EXPECT_LT(agreement.worst, kTolerance * agreement.largest);
}

// Every order, 7 probes (not a multiple of four: the last validity word is partial), probes 2 and 5
// invalid (zeros, as a file has them), every value distinct.
TEST_F(VolumeRelightTest, EveryOrderAndLayoutMatches) {
    for (int order = 1; order <= kMaxOrder; ++order) {
        const size_t perProbe = size_t(order) * size_t(order);
        ProbeVolume volume{.grid = {{7, 1, 1}, {0.0, 0.0, 0.0}, {6.0, 0.0, 0.0}}, .order = order, .end = 7};
        volume.valid = {1, 1, 0, 1, 1, 0, 1};
        for (size_t k = 0; k < 7 * perProbe; ++k) {
            const float v = volume.valid[k / perProbe] ? std::sin(1.7f * float(k) + 0.3f) : 0.0f;
            volume.staticRadiance.emplace_back(v, 0.5f * v, -0.25f * v);
        }
        for (size_t k = 0; k < 7 * perProbe * perProbe; ++k) {
            const float v = volume.valid[k / (perProbe * perProbe)] ? std::cos(0.37f * float(k)) : 0.0f;
            volume.transfer.emplace_back(v, -v, 2.0f * v);
        }
        ShCoefficients sky = makeCoefficients(order, Quantity::Radiance);
        for (size_t j = 0; j < perProbe; ++j)
            sky.rgb[j] = glm::dvec3(1.0 + 0.1 * double(j), -0.3, 0.05 * double(j));
        const Agreement agreement = relightOnBoth(context(), volume, sky);
        std::printf("order %d: worst %.3g of the largest |E| %.3g\n", order,
                    agreement.worst / agreement.largest, agreement.largest);
        EXPECT_LT(agreement.worst, kTolerance * agreement.largest) << order;
    }
}

} // namespace
} // namespace shprobe
