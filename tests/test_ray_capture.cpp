// Scene probes by rays on the GPU (gpu/ray_capture.h) against the cpu backend (scene/ray_bake.h),
// whose transport they follow: the texels one ray through each centre sees, the furnace's closed
// form, the bounces gathered at the surfaces, and the path tracer. Lavapipe, validation layer on.
#include "gpu_test.h"

#include "gpu/ray_capture.h"
#include "scene/gltf_scene.h"
#include "scene/probe_grid.h"
#include "scene/ray_bake.h"
#include "scene/reference_tracer.h"
#include "scene_fixtures.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace shprobe {
namespace {

using testing::GpuTest;

class RayCaptureTest : public GpuTest {
  protected:
    // The GPU's probes at `positions`, faces n, one ray per texel, `bounces` gathered as options say.
    std::vector<SceneProbe> bakeOnGpu(const World& world, const Cubemap& sky,
                                      std::span<const glm::dvec3> positions, int faceSize,
                                      const RayCaptureOptions& options) {
        SceneCapture capture =
            createSceneCapture(context(), world, sky, {.faceSize = faceSize, .shadowMapSize = 1});
        RayCapture rays = createRayCapture(context(), capture, SceneShading(world, sky), options);
        std::vector<SceneProbe> probes = bakeRayProbes(context(), capture, rays, positions, {.order = 3});
        destroyRayCapture(context(), rays);
        destroySceneCapture(context(), capture);
        return probes;
    }
};

std::vector<glm::dvec3> gridPositions(const ProbeGrid& grid) {
    std::vector<glm::dvec3> positions;
    for (uint32_t p = 0; p < grid.probeCount(); ++p)
        positions.push_back(probePosition(grid, probeCell(grid, p)));
    return positions;
}

// Texels whose radiance or back-face mark differs between two views by more than `tolerance` of
// max(1, |b|).
size_t differingTexels(const Cubemap& a, const Cubemap& b, double tolerance) {
    size_t differing = 0;
    for (size_t t = 0; t < a.texels.size(); ++t) {
        const glm::dvec3 x(glm::vec3(a.texels[t])), y(glm::vec3(b.texels[t]));
        differing += glm::length(x - y) > tolerance * std::max(1.0, glm::length(y)) ||
                     (a.texels[t].a > 0.5f) != (b.texels[t].a > 0.5f);
    }
    return differing;
}

// Through every texel centre the GPU casts the ray the cpu casts with one ray per texel, on the
// same hierarchy (bit for bit, test_bvh_gpu), and shades the hit alike, in float where the cpu
// uses double: the texels agree to 1e-5 except where a ray passes within rounding of an edge (the
// direction's float normalization differs) or a shadow ray grazes one. Three scenes: the open
// Cornell box with its blocks and a sun (shadow rays now, not maps), the closed one with its light,
// and 2CylinderEngine.glb's valid probes of 2^3 (121k triangles). Measured: 1 of 4,608 texels (a
// shadow ray's), 0 of 4,608 and 0 of 9,216; bound 1 texel in 1,000, below the 1 in 500 the cpu's
// rays are held to against Embree's (test_ray_bake).
TEST_F(RayCaptureTest, CentreRaysSeeWhatTheCpuRaysSee) {
    const Cubemap sky = testing::directionalSky(8);
    const int n = 16;
    const World sunlit = testing::loadCornellBoxWorld(
        {.innerBoxes = true,
         .sun = testing::FixtureSun{.towardsLight = {0.3f, 1.0f, 0.6f}, .intensity = 3.0f}});
    const World closed = testing::loadCornellBoxWorld({.closed = true, .innerBoxes = true});
    const World& engine = testing::engineWorld(SHPROBE_GLTF_MODELS_DIR);
    for (const World* world : {&sunlit, &closed, &engine}) {
        const std::vector<glm::dvec3> positions =
            world == &engine ? gridPositions(probeGridInWorld(glm::ivec3(2), *world))
                             : std::vector<glm::dvec3>{{0.0, 1.0, 0.0}, {-0.5, 0.4, 0.5}, {0.7, 1.6, -0.2}};
        SceneCapture capture =
            createSceneCapture(context(), *world, sky, {.faceSize = n, .shadowMapSize = 1});
        RayCapture rays = createRayCapture(context(), capture, SceneShading(*world, sky), {});
        RayBaker baker(*world, sky, {.faceSize = n, .raysPerTexel = 1, .bounces = 0, .visibilitySize = 0});
        size_t differing = 0, texels = 0;
        for (const glm::dvec3& position : positions) {
            const Cubemap cpu = baker.traceProbe(position);
            if (std::count_if(cpu.texels.begin(), cpu.texels.end(),
                              [](const glm::vec4& t) { return t.a > 0.5f; }) > long(cpu.texels.size() / 2))
                continue; // inside a part
            differing += differingTexels(traceRayCubemap(context(), capture, rays, position), cpu, 1e-5);
            texels += cpu.texels.size();
        }
        destroyRayCapture(context(), rays);
        destroySceneCapture(context(), capture);
        std::printf("%s: %zu of %zu texels differ from the cpu's rays\n", world->description.c_str(),
                    differing, texels);
        EXPECT_GT(texels, 0u);
        EXPECT_LE(differing, texels / 1000) << world->description;
    }
}

// The visibility maps (16^2 octahedral texels of the mean and mean square hit distance) gather
// each texel-centre ray's distance as the cpu gathers its one ray per texel: the same rays, t in
// float against the cpu's distance in double, so every texel agrees to float rounding of the
// distances on the closed Cornell box with its blocks, probes inside the blocks included (measured:
// 1.0e-7 of the range, the world's diagonal, and 1.2e-7 of its square; bound 1e-5).
TEST_F(RayCaptureTest, VisibilityMapsEqualTheCpus) {
    const World world = testing::loadCornellBoxWorld({.closed = true, .innerBoxes = true});
    const Cubemap sky = testing::directionalSky(4);
    const std::vector<glm::dvec3> positions = gridPositions(probeGridInWorld(glm::ivec3(3), world));
    const std::vector<SceneProbe> gpu = bakeOnGpu(world, sky, positions, 16, {});
    RayBaker baker(world, sky, {.faceSize = 16, .raysPerTexel = 1, .bounces = 0});
    const std::vector<RayBakedProbe> cpu = baker.bakeProbes(positions);
    const double range = baker.visibilityRange();
    double worstMean = 0.0, worstSquare = 0.0;
    for (size_t p = 0; p < positions.size(); ++p) {
        ASSERT_EQ(gpu[p].visibility.size(), cpu[p].visibility.size());
        for (size_t t = 0; t < cpu[p].visibility.size(); ++t) {
            const glm::dvec2 difference =
                glm::abs(glm::dvec2(gpu[p].visibility[t]) - glm::dvec2(cpu[p].visibility[t]));
            worstMean = std::max(worstMean, difference.x / range);
            worstSquare = std::max(worstSquare, difference.y / (range * range));
        }
    }
    std::printf("visibility of %zu probes: worst difference %.3g of the range (mean), %.3g of its square "
                "(mean square)\n",
                positions.size(), worstMean, worstSquare);
    EXPECT_LT(worstMean, 1e-5);
    EXPECT_LT(worstSquare, 1e-5);
}

// Probes inside geometry are moved out as the cpu moves them (ProbeRelocation, scene/ray_bake.h):
// in the closed Cornell box with its blocks, with cells of 0.24 (a limit of 0.108, a front distance
// of 0.024), a probe at (-0.1, 1, -0.3), inside the tall block 0.06 from its +x face, leaves through
// that face and is pushed off it; one at the block's centre (-0.34, 0.6, -0.3), 0.3 from any face,
// stays. Both backends cast one ray per texel here, so they meet the same nearest faces along the
// same texel directions; distances differ by float rounding (the gpu's hierarchy against the cpu's
// Embree), and the four texel rays about the face's normal that meet it at the same distance keep
// the first (NearestHits): the offsets agree to 1e-6, float rounding (measured: (0.083907, 0.00375,
// 0.005244) on both). The moved probe is, bit for bit, a probe baked there.
TEST_F(RayCaptureTest, ProbesInsideGeometryAreMovedOutAsOnTheCpu) {
    const World world = testing::loadCornellBoxWorld({.lightSide = 1.0f, .closed = true, .innerBoxes = true});
    const Cubemap sky = testing::directionalSky(4);
    const ProbeRelocation rule{.limit = 0.108, .minFrontDistance = 0.024};
    const std::vector<glm::dvec3> positions{{-0.1, 1.0, -0.3}, {-0.34, 0.6, -0.3}};
    const std::vector<SceneProbe> gpu = bakeOnGpu(world, sky, positions, 16, {.relocation = rule});
    RayBaker baker(world, sky, {.faceSize = 16, .raysPerTexel = 1, .bounces = 0, .relocation = rule});
    const std::vector<RayBakedProbe> cpu = baker.bakeProbes(positions);
    for (size_t p = 0; p < positions.size(); ++p) {
        std::printf("probe %zu: gpu offset (%.6f, %.6f, %.6f), cpu (%.6f, %.6f, %.6f)\n", p, gpu[p].offset.x,
                    gpu[p].offset.y, gpu[p].offset.z, cpu[p].offset.x, cpu[p].offset.y, cpu[p].offset.z);
        for (int a = 0; a < 3; ++a)
            EXPECT_NEAR(gpu[p].offset[a], cpu[p].offset[a], 1e-6) << "probe " << p;
    }
    EXPECT_GT(glm::length(gpu[0].offset), 0.05f);
    EXPECT_EQ(gpu[1].offset, glm::vec3(0.0f));
    const glm::dvec3 moved = positions[0] + glm::dvec3(gpu[0].offset);
    const std::vector<SceneProbe> there = bakeOnGpu(world, sky, {&moved, 1}, 16, {});
    EXPECT_EQ(there[0].radiance.rgb, gpu[0].radiance.rgb);
    EXPECT_EQ(there[0].backFaceTexels, gpu[0].backFaceTexels);
}

// A closed box of uniform emission E = 1 and albedo 1/2, double-sided: every ray meets a wall
// leaving E (1 + a + ... + a^k) at bounce k, whatever the cache's points or rays, so L00 is
// 2 sqrt(pi) times that and the other coefficients 0, to float sums over 6 N^2 texels and g^2 rays
// (1e-4 of L00's 3.5 to 5.3).
TEST_F(RayCaptureTest, FurnaceFollowsTheGeometricSeries) {
    World furnace = testing::loadCornellBoxWorld({.closed = true});
    for (SceneMaterial& material : furnace.materials) {
        material.albedo = glm::vec3(0.5f);
        material.emission = glm::vec3(1.0f);
        material.doubleSided = true;
    }
    const std::vector<glm::dvec3> positions{{0.0, 1.0, 0.0}, {0.5, 0.3, -0.7}};
    for (int bounces : {0, 1, 2}) {
        const std::vector<SceneProbe> probes = bakeOnGpu(furnace, testing::directionalSky(4), positions, 8,
                                                         {.bounces = bounces, .gatherRays = 16});
        const double series = 2.0 - std::pow(0.5, bounces);
        for (const SceneProbe& probe : probes) {
            EXPECT_NEAR(probe.radiance.rgb[0].g, 2.0 * std::sqrt(std::numbers::pi) * series, 1e-4) << bounces;
            for (size_t i = 1; i < probe.radiance.rgb.size(); ++i)
                EXPECT_NEAR(probe.radiance.rgb[i].g, 0.0, 1e-4) << bounces;
        }
    }
}

// |L00 difference| (green) over the probes `a` holds valid, as a fraction of b's mean L00.
struct L00Agreement {
    double mean = 0.0;
    double worst = 0.0;
    size_t probes = 0;
};

template <typename A, typename B>
L00Agreement compareL00(const std::vector<A>& a, const std::vector<B>& b, int faceSize) {
    double meanL00 = 0.0;
    L00Agreement agreement;
    for (size_t p = 0; p < a.size(); ++p) {
        if (2 * a[p].backFaceTexels > 6u * uint32_t(faceSize * faceSize)) continue;
        meanL00 += b[p].radiance.rgb[0].g;
        ++agreement.probes;
    }
    meanL00 /= double(agreement.probes);
    for (size_t p = 0; p < a.size(); ++p) {
        if (2 * a[p].backFaceTexels > 6u * uint32_t(faceSize * faceSize)) continue;
        const double error = std::abs(a[p].radiance.rgb[0].g - b[p].radiance.rgb[0].g) / meanL00;
        agreement.worst = std::max(agreement.worst, error);
        agreement.mean += error / double(agreement.probes);
    }
    return agreement;
}

// The closed Cornell box with its blocks and a 1 m light, 4^3 probes, faces 32^2, one ray per
// texel, the default cache (the diagonal / 64) and 64 gather rays, against the cpu with the same
// options, bounce after bounce, as fractions of the cpu's mean L00. Bounce 0 is the same rays
// (CentreRaysSeeWhatTheCpuRaysSee): equal but for float sums (measured: below 1e-5; bound 1e-4).
// Bounces 1 and 2 gather the same points with other random numbers, so they differ by the noise
// of 64 gather rays, largest at the probes nearest the light, where a few points see it (measured:
// mean 0.33% and 0.29%, worst 3.9% and 1.4%; the cpu's own worst error against the path tracer at
// bounce 1, 5.1% in test_ray_bake, is mostly this noise). Bounds: 1% mean, 6% worst.
TEST_F(RayCaptureTest, BouncesAgreeWithTheCpu) {
    const World world = testing::loadCornellBoxWorld({.lightSide = 1.0f, .closed = true, .innerBoxes = true});
    const Cubemap sky = testing::directionalSky(4);
    const std::vector<glm::dvec3> positions = gridPositions(probeGridInWorld(glm::ivec3(4), world));
    const std::array<double, 3> meanBound{1e-4, 0.01, 0.01};
    const std::array<double, 3> worstBound{1e-4, 0.06, 0.06};
    for (int bounces : {0, 1, 2}) {
        const std::vector<SceneProbe> gpu = bakeOnGpu(world, sky, positions, 32, {.bounces = bounces});
        RayBaker baker(world, sky,
                       {.faceSize = 32, .raysPerTexel = 1, .bounces = bounces, .visibilitySize = 0});
        const std::vector<RayBakedProbe> cpu = baker.bakeProbes(positions);
        const L00Agreement agreement = compareL00(gpu, cpu, 32);
        std::printf("bounces %d, %zu valid probes: gpu against cpu L00 mean %.5f worst %.5f\n", bounces,
                    agreement.probes, agreement.mean, agreement.worst);
        EXPECT_LT(agreement.mean, meanBound[size_t(bounces)]) << "bounces " << bounces;
        EXPECT_LT(agreement.worst, worstBound[size_t(bounces)]) << "bounces " << bounces;
    }
}

// The same box against the path tracer with as many bounces (16,384 stratified samples per probe:
// standard error 0.3% of L00 on average): the raster capture through the probe grid was 7.7% mean
// and 26% worst at bounce 1 (test_scene_capture), the cpu with 2 x 2 rays per texel 0.58% / 5.1%
// (test_ray_bake). One ray per texel adds the texels' aliasing of the light's edge, 2.4% / 7.3% at
// bounce 0. Measured: bounce 1 1.9% / 6.1%, bounce 2 1.8% / 5.3%; bounds 3% and 8%.
TEST_F(RayCaptureTest, CornellBoxApproachesThePathTracer) {
    const World world = testing::loadCornellBoxWorld({.lightSide = 1.0f, .closed = true, .innerBoxes = true});
    const Cubemap sky = testing::directionalSky(4);
    const std::vector<glm::dvec3> all = gridPositions(probeGridInWorld(glm::ivec3(4), world));
    const ReferenceTracer tracer(world, sky);
    for (int bounces : {1, 2}) {
        const std::vector<SceneProbe> probes = bakeOnGpu(world, sky, all, 32, {.bounces = bounces});
        std::vector<SceneProbe> valid;
        std::vector<glm::dvec3> positions;
        for (size_t p = 0; p < probes.size(); ++p) {
            if (2 * probes[p].backFaceTexels > 6u * 32u * 32u) continue;
            valid.push_back(probes[p]);
            positions.push_back(all[p]);
        }
        const std::vector<PathTracedProbe> reference =
            pathTraceProbes(tracer, positions, {.order = 3, .bounces = bounces, .samples = 16384});
        const L00Agreement agreement = compareL00(valid, reference, 32);
        std::printf("bounces %d, %zu valid probes: L00 against the path tracer mean %.4f worst %.4f\n",
                    bounces, agreement.probes, agreement.mean, agreement.worst);
        EXPECT_LT(agreement.mean, 0.03) << "bounces " << bounces;
        EXPECT_LT(agreement.worst, 0.08) << "bounces " << bounces;
    }
}

} // namespace
} // namespace shprobe
