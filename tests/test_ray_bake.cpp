// Scene probes by rays on the CPU (scene/ray_bake.h): the furnace's closed form, darkness where no
// light is, the Embree reference's texels at bounce 0, and the path-traced transport at bounces 0, 1
// and 2 on the Cornell box, through texels and over the sphere.
#include "image/environment.h"
#include "scene/bvh.h"
#include "scene/emitters.h"
#include "scene/gltf_scene.h"
#include "scene/probe_grid.h"
#include "scene/ray_bake.h"
#include "scene/ray_caster.h"
#include "scene/reference_tracer.h"
#include "scene/surface_cache.h"
#include "scene/volume_sampling.h"
#include "scene_fixtures.h"
#include "sh/cubemap.h"
#include "sh/lights.h"
#include "sh/projection.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <set>

namespace shprobe {
namespace {

// A closed box of uniform emission E and albedo a, probes inside: every ray meets a wall leaving
// E (1 + a + ... + a^k) at bounce k, so every gathered point and every probe sees exactly that,
// whatever the cache's spacing or rays; L00 = 2 sqrt(pi) times it. Float rounding only: 1e-5. The
// same beside a ground 2e5 across: rays leaving the walls started 3 units off them (256 float steps
// of the scene's largest coordinate), outside the box, and bounce 1 and 2 saw nothing (L00 at bounce
// 2 was that of bounce 0); off each triangle by its own coordinates they stay inside.
TEST(RayBake, FurnaceFollowsTheGeometricSeries) {
    const std::vector<glm::dvec3> positions{{0.0, 1.0, 0.0}, {0.5, 0.3, -0.7}};
    for (const World& furnace : {testing::furnaceWorld(), testing::furnaceBesideAFarGround()})
        for (int bounces : {0, 1, 2}) {
            RayBaker baker(furnace, testing::directionalSky(4),
                           {.order = 2, .faceSize = 8, .bounces = bounces, .gatherRays = 16});
            const std::vector<RayBakedProbe> probes = baker.bakeProbes(positions);
            const double series = 2.0 - std::pow(0.5, bounces); // 1 + 1/2 + ... + 1/2^k
            for (const RayBakedProbe& probe : probes) {
                EXPECT_NEAR(probe.radiance.rgb[0].g, 2.0 * std::sqrt(std::numbers::pi) * series, 1e-5)
                    << bounces;
                for (size_t i = 1; i < probe.radiance.rgb.size(); ++i)
                    EXPECT_NEAR(probe.radiance.rgb[i].g, 0.0, 1e-5) << bounces;
            }
        }
}

// The same furnace with bounces by paths: each hit's emission is found both by the path's cosine ray
// and by a point sampled on the emitters (every wall emits), the two weighted by the power heuristic,
// so the estimate is exact only on average: a weight or density wrong by a factor would put it off
// by tens of per cent. Measured: within 0.12% of the series, 6,144 rays a probe. Bound: 0.5% of L00.
TEST(RayBake, FurnaceByPathsFollowsTheGeometricSeries) {
    const World furnace = testing::furnaceWorld();
    const std::vector<glm::dvec3> positions{{0.0, 1.0, 0.0}, {0.5, 0.3, -0.7}};
    for (int bounces : {1, 2, 3}) {
        RayBaker baker(furnace, testing::directionalSky(4),
                       {.order = 2,
                        .faceSize = 16,
                        .raysPerTexel = 4,
                        .bounces = bounces,
                        .bounceLight = BounceLight::Paths});
        const double l00 = 2.0 * std::sqrt(std::numbers::pi) * (2.0 - std::pow(0.5, bounces));
        for (const RayBakedProbe& probe : baker.bakeProbes(positions)) {
            std::printf("bounces %d: L00 %.5f against %.5f (%.2e off)\n", bounces, probe.radiance.rgb[0].g,
                        l00, std::abs(probe.radiance.rgb[0].g / l00 - 1.0));
            EXPECT_NEAR(probe.radiance.rgb[0].g, l00, 0.005 * l00) << bounces;
        }
    }
}

// auto's choice (docs/scene-probes.md): paths until the grid's probe rays (at 2 x 2 a texel at most)
// pass four times the cache's gather rays (every lattice point's 64), then the cache; the threshold
// from the lattices' size.
TEST(RayBake, AutoTakesPathsUnlessTheCacheCastsUnderAQuarterOfTheirRays) {
    const World world = testing::loadCornellBoxWorld({.closed = true, .innerBoxes = true});
    const RayBakeOptions options{.faceSize = 8, .raysPerTexel = 4, .bounces = 1};
    const double cacheRays = double(cachePointCount(world, cacheSpacingFor(world, 0.0))) * 64.0;
    const uint64_t last = uint64_t(std::floor(4.0 * cacheRays / (6.0 * 8 * 8 * 4)));
    ASSERT_GT(last, 1u);
    EXPECT_EQ(autoBounceLight(world, options, 1), BounceLight::Paths);
    EXPECT_EQ(autoBounceLight(world, options, last), BounceLight::Paths);
    EXPECT_EQ(autoBounceLight(world, options, last + 1), BounceLight::Cache);
    // More rays a texel lower only the paths' error: the cache is not taken at fewer probes.
    RayBakeOptions finer = options;
    finer.raysPerTexel = kDefaultRaysPerTexel;
    EXPECT_EQ(autoBounceLight(world, finer, last), BounceLight::Paths);
    EXPECT_EQ(autoBounceLight(world, finer, last + 1), BounceLight::Cache);
}

// The closed Cornell box with its light off and a bright sky outside: no light reaches a probe at
// any bounce, from the cache or by paths (whose sky samples all meet the walls), and none may be
// made up.
TEST(RayBake, NoLightGivesNone) {
    const World world = testing::loadCornellBoxWorld({.lightEmission = glm::vec3(0.0f), .closed = true});
    for (BounceLight light : {BounceLight::Cache, BounceLight::Paths}) {
        RayBaker baker(world, testing::directionalSky(4),
                       {.order = 3, .faceSize = 8, .bounces = 2, .bounceLight = light});
        for (const RayBakedProbe& probe :
             baker.bakeProbes(std::vector<glm::dvec3>{{0.0, 1.0, 0.0}, {0.6, 0.4, 0.6}}))
            for (const glm::dvec3& coefficient : probe.radiance.rgb)
                EXPECT_EQ(coefficient, glm::dvec3(0.0));
    }
}

// A small bright patch of sky partly behind an edge (stratumSkyRays): a sky black but for one texel
// of +Z at the strata's resolution (faces 8, 2 x 2 rays a texel: 16), a wall at z = 1 in front of
// the probe covering the directions whose face coordinate a lies below 40% of the way across that
// texel. The probe then sees the patch's radiance times 60% of its stratum's face area, so its L00
// is Y00 L 0.6 Omega_t / 4 (Omega_t the texel's solid angle; the projection weighs the texel's mean
// of its 4 strata by it). The stratum gets a quarter of the view's 1,536 rays as shadow rays (384),
// at Sobol' points: measured 0.43% low; bound 2%. Its one view ray alone gives 0 or all of it
// (60% or 40% off).
TEST(RayBake, ABrightPatchOfSkyPartlyBehindAnEdgeIsMeasuredByManyRays) {
    constexpr int kFace = 8, kSide = 2, kStrata = kFace * kSide, kPatchI = 9, kPatchJ = 6;
    constexpr int kPositiveZ = 4;
    constexpr float kRadiance = 1000.0f;
    Cubemap sky = makeCubemap(kStrata);
    for (glm::vec4& texel : sky.texels)
        texel = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
    sky.at(kPositiveZ, kPatchI, kPatchJ) = glm::vec4(kRadiance, kRadiance, kRadiance, 1.0f);
    const double a0 = 2.0 * kPatchI / kStrata - 1.0, a1 = 2.0 * (kPatchI + 1) / kStrata - 1.0;
    const double cut = a0 + 0.4 * (a1 - a0);
    ASSERT_EQ(faceDirection(kPositiveZ, 0.5, 0.0), glm::normalize(glm::dvec3(0.5, 0.0, 1.0)));
    testing::FixtureScene scene;
    scene.materials.push_back({.albedo = glm::vec3(0.0f)});
    testing::FixtureMesh wall;
    wall.material = 0;
    const float left = -10.0f, right = float(cut);
    testing::addQuad(wall, {0.5f * (left + right), 0.0f, 1.0f}, {0.0f, 10.0f, 0.0f},
                     {0.5f * (right - left), 0.0f, 0.0f}); // facing -z, the probe
    scene.meshes.push_back(wall);
    scene.nodes.push_back({.mesh = 0});
    scene.roots = {0};
    const World world = testing::loadFixtureWorld(scene);
    RayBaker baker(world, sky, {.order = 1, .faceSize = kFace, .raysPerTexel = kSide * kSide, .bounces = 0});
    const RayBakedProbe probe = baker.bakeProbes(std::vector<glm::dvec3>{glm::dvec3(0.0)})[0];
    const double expected = 0.5 / std::sqrt(std::numbers::pi) * kRadiance * 0.6 *
                            texelSolidAngle(kPatchI / kSide, kPatchJ / kSide, kFace) / 4.0;
    std::printf("patch behind an edge: L00 %.6g, expected %.6g (%.3f%% off)\n", probe.radiance.rgb[0].r,
                expected, 100.0 * (probe.radiance.rgb[0].r / expected - 1.0));
    EXPECT_NEAR(probe.radiance.rgb[0].r, expected, 0.02 * expected);
}

// With one ray through each texel centre, bounce 0 is what the reference's Embree rays through the
// same centres see (the view the GPU capture rasterizes): the sun's shadow rays included. The two
// casters may disagree only for a ray through an edge within float rounding: at most 1 texel in
// 500 (measured: 2 of 4608).
TEST(RayBake, CentreRaysSeeWhatTheReferenceRaysSee) {
    const World world = testing::loadCornellBoxWorld(
        {.innerBoxes = true,
         .sun = testing::FixtureSun{.towardsLight = {0.3f, 1.0f, 0.6f}, .intensity = 3.0f}});
    const Cubemap sky = testing::directionalSky(8);
    const ReferenceTracer tracer(world, sky);
    RayBaker baker(world, sky, {.faceSize = 16, .raysPerTexel = 1, .bounces = 0});
    size_t differing = 0, texels = 0;
    for (const glm::dvec3 position :
         {glm::dvec3(0.0, 1.0, 0.0), glm::dvec3(-0.5, 0.4, 0.5), glm::dvec3(0.7, 1.6, -0.2)}) {
        const Cubemap seen = baker.traceProbe(position);
        const ProbeTexels traced = traceProbeTexels(tracer, position, 16);
        for (size_t t = 0; t < seen.texels.size(); ++t) {
            const glm::dvec3 ours(glm::vec3(seen.texels[t])), reference(glm::vec3(traced.radiance.texels[t]));
            differing += glm::length(ours - reference) > 1e-5 * std::max(1.0, glm::length(reference));
        }
        texels += seen.texels.size();
    }
    std::printf("%zu of %zu texels differ from the reference rays\n", differing, texels);
    EXPECT_LE(differing, texels / 500);
}

// A probe's result depends on its position alone: baked alone or among others, the same bits, with
// the cache's cells halved or not (which cells are halved depends on their corners alone) or with
// bounces by paths (whose random numbers are named by the probe's position), through texels or over
// the sphere (whose rotation is named by the probe's position too), moved out of the tall block or
// not (the last probe lies inside it: ProbesInsideGeometryAreMovedOut). So bricks merge into exactly
// the whole bake, and two runs give the same bytes.
TEST(RayBake, ProbesDoNotDependOnTheirCompany) {
    const World world = testing::loadCornellBoxWorld({.closed = true, .innerBoxes = true});
    const std::vector<glm::dvec3> positions{
        {0.0, 1.0, 0.0}, {-0.5, 0.4, 0.5}, {0.7, 1.6, -0.2}, {-0.1, 1.0, -0.3}};
    struct Bounces {
        BounceLight light;
        int refinement;
        const char* name;
    };
    for (ProbeDirections directions : {ProbeDirections::Texels, ProbeDirections::Sphere})
        for (const Bounces bounces :
             {Bounces{BounceLight::Cache, 0, "cache"}, Bounces{BounceLight::Cache, 3, "cache, refinement 3"},
              Bounces{BounceLight::Paths, 0, "paths"}}) {
            RayBakeOptions options{
                .faceSize = 8, .bounces = 2, .gatherRays = 16, .cacheRefinement = bounces.refinement};
            options.relocation = {.limit = 0.108, .minFrontDistance = 0.024};
            options.directions = directions;
            options.bounceLight = bounces.light;
            const std::string name =
                (directions == ProbeDirections::Sphere ? "sphere, " : "texels, ") + std::string(bounces.name);
            RayBaker together(world, testing::directionalSky(4), options);
            const std::vector<RayBakedProbe> all = together.bakeProbes(positions);
            RayBaker alone(world, testing::directionalSky(4), options);
            const std::vector<RayBakedProbe> last = alone.bakeProbes(std::span(positions).subspan(2));
            for (size_t p = 0; p < last.size(); ++p) {
                const RayBakedProbe& whole = all[p + 2];
                EXPECT_EQ(last[p].radiance.rgb, whole.radiance.rgb) << name;
                EXPECT_EQ(last[p].irradiance.rgb, whole.irradiance.rgb) << name;
                EXPECT_EQ(last[p].backFaceTexels, whole.backFaceTexels) << name;
                EXPECT_EQ(last[p].visibility, whole.visibility) << name;
                EXPECT_EQ(last[p].offset, whole.offset) << name;
            }
            EXPECT_GT(glm::length(all[3].offset), 0.06f) << name;
            if (bounces.refinement > 0) {
                EXPECT_GT(together.counts().halvedCells, 0u);
            }
            if (bounces.light == BounceLight::Paths) {
                EXPECT_EQ(together.counts().cachePoints, 0u);
            }
        }
}

// The probes of a grid (faces 32^2) baked, and those of them with less than half of their view on
// back faces (not inside something), with their positions.
struct ValidProbes {
    std::vector<RayBakedProbe> probes;
    std::vector<glm::dvec3> positions;
};

ValidProbes validProbes(RayBaker& baker, const ProbeGrid& grid) {
    std::vector<glm::dvec3> all;
    for (uint32_t p = 0; p < grid.probeCount(); ++p)
        all.push_back(probePosition(grid, probeCell(grid, p)));
    const std::vector<RayBakedProbe> probes = baker.bakeProbes(all);
    ValidProbes valid;
    for (size_t p = 0; p < probes.size(); ++p) {
        if (insideGeometry(probes[p].backFaceTexels, 32, 0.5)) continue;
        valid.probes.push_back(probes[p]);
        valid.positions.push_back(all[p]);
    }
    return valid;
}

// |L00 error| over the valid probes as a fraction of their mean L00 (green), and every
// coefficient's error in the same units.
struct Agreement {
    double worstL00 = 0.0;
    double meanL00 = 0.0;
    double worstCoefficient = 0.0;
    double referenceError = 0.0; // the reference's largest standard error of L00, in the same units
};

Agreement compare(const std::vector<RayBakedProbe>& baked, const std::vector<PathTracedProbe>& reference) {
    double meanL00 = 0.0;
    for (const PathTracedProbe& probe : reference)
        meanL00 += probe.radiance.rgb[0].g / double(reference.size());
    Agreement agreement;
    for (size_t p = 0; p < baked.size(); ++p) {
        const double error = std::abs(baked[p].radiance.rgb[0].g - reference[p].radiance.rgb[0].g) / meanL00;
        agreement.worstL00 = std::max(agreement.worstL00, error);
        agreement.meanL00 += error / double(baked.size());
        agreement.referenceError =
            std::max(agreement.referenceError, reference[p].standardError[0].g / meanL00);
        for (size_t i = 0; i < baked[p].radiance.rgb.size(); ++i) {
            const double coefficient = std::abs(baked[p].radiance.rgb[i].g - reference[p].radiance.rgb[i].g);
            agreement.worstCoefficient = std::max(agreement.worstCoefficient, coefficient / meanL00);
        }
    }
    return agreement;
}

// The closed Cornell box with its blocks and a 1 m light, 4^3 probes, faces 32^2 with 2 x 2 rays
// per texel's worth, against the path tracer with as many bounces at `samples` directions per probe.
Agreement cornellBoxAgreement(ProbeDirections directions, int bounces, BounceLight light = BounceLight::Cache,
                              int samples = 65536) {
    const World world = testing::loadCornellBoxWorld({.lightSide = 1.0f, .closed = true, .innerBoxes = true});
    const Cubemap sky = testing::directionalSky(4);
    const ProbeGrid grid = probeGridInWorld(glm::ivec3(4), world);
    const ReferenceTracer tracer(world, sky);
    RayBaker baker(world, sky,
                   {.faceSize = 32,
                    .raysPerTexel = 4,
                    .bounces = bounces,
                    .directions = directions,
                    .bounceLight = light});
    const auto [baked, positions] = validProbes(baker, grid);
    // The blocks hold 3 of the 64 probes (measured); with fewer valid the bounds below would check
    // less than they say, and with none nothing.
    EXPECT_EQ(baked.size(), size_t(61)) << "valid probes";
    const std::vector<PathTracedProbe> reference =
        pathTraceProbes(tracer, positions, {.order = 3, .bounces = bounces, .samples = samples});
    const Agreement agreement = compare(baked, reference);
    const RayBakeCounts counts = baker.counts();
    std::printf("%s, %s, bounces %d, %zu valid probes: L00 error mean %.4f worst %.4f, any coefficient %.4f "
                "(reference's standard error %.4f); %.3g rays, %llu cache points\n",
                directions == ProbeDirections::Sphere ? "sphere" : "texels",
                light == BounceLight::Paths ? "paths" : "cache", bounces, baked.size(), agreement.meanL00,
                agreement.worstL00, agreement.worstCoefficient, agreement.referenceError,
                double(counts.probeRays + counts.cacheRays), (unsigned long long)counts.cachePoints);
    return agreement;
}

// The Cornell box's grid (cornellBoxAgreement) through texels, 2 x 2 jittered rays in each, with the
// default cache and gather rays, against the path tracer with as many bounces at 65,536 directions
// per probe (the standard error of its L00 reaches 1.2% of the mean L00 at the probes nearest the
// light, 0.15% on average). Measured (mean / worst L00 error, worst coefficient): bounce 0 0.44% /
// 1.4% / 2.2%, bounce 1 0.58% / 5.1% / 5.6%, bounce 2 0.58% / 1.8% / 2.8%; the GPU capture through the probe
// grid is 7.7% / 26% at bounce 1 (test_scene_capture). Bounds: 1% mean, 7% worst, 8% for any coefficient,
// room for another compiler's rounding.
TEST(RayBake, CornellBoxApproachesThePathTracer) {
    for (int bounces : {0, 1, 2}) {
        const Agreement agreement = cornellBoxAgreement(ProbeDirections::Texels, bounces);
        EXPECT_LT(agreement.meanL00, 0.01) << "bounces " << bounces;
        EXPECT_LT(agreement.worstL00, 0.07) << "bounces " << bounces;
        EXPECT_LT(agreement.worstCoefficient, 0.08) << "bounces " << bounces;
    }
}

// The same grid, bounces by paths from the probes' hits, the light also sampled where it is (next-event
// estimation, weighted by the power heuristic): unbiased, so that only noise is left. Against the
// path tracer at 262,144 directions (standard error of L00 up to 0.58% of the mean). Measured (mean /
// worst L00 error, worst coefficient): bounce 1 0.37% / 1.5% / 1.7%, bounce 2 0.39% / 1.4% / 1.7%,
// where the cache leaves 5.1% worst at bounce 1. Now (the paths' numbers Owen-scrambled Sobol'):
// 0.39% / 1.3% / 1.5% and 0.38% / 1.4% / 1.5%. Bounds: the 0.5% mean and 2% worst asked of a bake.
TEST(RayBake, CornellBoxBouncesByPathsApproachThePathTracer) {
    for (int bounces : {1, 2}) {
        const Agreement agreement =
            cornellBoxAgreement(ProbeDirections::Texels, bounces, BounceLight::Paths, 262144);
        EXPECT_LT(agreement.meanL00, 0.005) << "bounces " << bounces;
        EXPECT_LT(agreement.worstL00, 0.02) << "bounces " << bounces;
        EXPECT_LT(agreement.worstCoefficient, 0.02) << "bounces " << bounces;
    }
}

// The same grid at bounce 0 with as many directions stratified over the sphere (6 x 32^2 x 4 per
// probe, spherical Fibonacci under a rotation per probe), each projected with the weight 4 pi / R:
// what a probe sees directly, so that only the view's projection differs from the texels'. Measured
// (mean / worst L00 error, any coefficient): 0.26% / 0.92% / 1.4%, the texels' 0.44% / 1.4% / 2.2%;
// the reference's standard error of L00 reaches 0.47% of the mean L00. Bounds: 0.5% mean, 2% worst
// (the measured worst plus twice the reference's largest standard error), 3% for any coefficient.
TEST(RayBake, SphereViewApproachesThePathTracer) {
    const Agreement agreement = cornellBoxAgreement(ProbeDirections::Sphere, 0);
    EXPECT_LT(agreement.meanL00, 0.005);
    EXPECT_LT(agreement.worstL00, 0.02);
    EXPECT_LT(agreement.worstCoefficient, 0.03);
}

// Probe relocation in the closed Cornell box: at (-0.1, 1, -0.3) a probe lies inside the tall block
// (x from -0.64 to -0.04), 0.06 from its +x face; at (-0.34, 0.6, -0.3), its centre, 0.3 from every
// side face. With cells of 0.24 (a limit of 0.45 cells, 0.108; a front distance of 0.1 cells), the
// first leaves through the +x face, 0.012 past it, and is pushed on to 0.024 off it: an offset of
// about (0.084, 0, 0), at most the limit, and it is no longer inside. The second's nearest exit is
// beyond the limit: it stays, inside, offset 0. The moved probe is exactly (same rays from the same
// float position: no tolerance) a probe baked there without relocation, and agrees with the path
// tracer there at bounce 0 as the grid's probes do: measured 0.57% of L00, the tracer's standard
// error at 65,536 directions 0.26%; bound 3%, the grid probes' worst error at bounce 0
// (CornellBoxApproachesThePathTracer: 1.4%) plus four of the tracer's standard errors, rounded up.
TEST(RayBake, ProbesInsideGeometryAreMovedOut) {
    const World world = testing::loadCornellBoxWorld({.lightSide = 1.0f, .closed = true, .innerBoxes = true});
    const Cubemap sky = testing::directionalSky(4);
    const double cell = 0.24;
    RayBakeOptions options{.faceSize = 32, .raysPerTexel = 4, .bounces = 0};
    options.relocation = {.limit = 0.45 * cell, .minFrontDistance = 0.1 * cell};
    RayBaker baker(world, sky, options);
    const std::vector<glm::dvec3> positions{{-0.1, 1.0, -0.3}, {-0.34, 0.6, -0.3}};
    const std::vector<RayBakedProbe> probes = baker.bakeProbes(positions);
    const glm::dvec3 offset(probes[0].offset);
    std::printf("moved by (%.4f, %.4f, %.4f), %zu of %d texels on back faces there\n", offset.x, offset.y,
                offset.z, size_t(probes[0].backFaceTexels), 6 * 32 * 32);
    EXPECT_GT(offset.x, 0.06);
    EXPECT_LE(glm::length(offset), 0.45 * cell);
    EXPECT_FALSE(insideGeometry(probes[0].backFaceTexels, 32, 0.5));
    EXPECT_EQ(probes[1].offset, glm::vec3(0.0f));
    EXPECT_TRUE(insideGeometry(probes[1].backFaceTexels, 32, 0.5));

    const glm::dvec3 moved = positions[0] + offset;
    RayBaker fixed(world, sky, {.faceSize = 32, .raysPerTexel = 4, .bounces = 0});
    const RayBakedProbe there = fixed.bakeProbes(std::vector<glm::dvec3>{moved})[0];
    EXPECT_EQ(there.radiance.rgb, probes[0].radiance.rgb);
    EXPECT_EQ(there.visibility, probes[0].visibility);

    const ReferenceTracer tracer(world, sky);
    const PathTracedProbe reference = pathTraceProbes(tracer, std::vector<glm::dvec3>{moved},
                                                      {.order = 3, .bounces = 0, .samples = 65536})[0];
    const double l00 = reference.radiance.rgb[0].g;
    const double error = std::abs(probes[0].radiance.rgb[0].g - l00) / l00;
    std::printf("moved probe's L00 against the path tracer: %.4f (standard error %.4f)\n", error,
                reference.standardError[0].g / l00);
    EXPECT_LT(error, 0.03);
}

// A sampler weighs a moved probe's visibility from where it was captured: a probe at the grid's
// origin, captured 0.3 along x, whose maps say a surface 0.25 away in every direction (variance
// 1e-4), shades a point whose biased position lies 0.22 from where it was captured and 0.51 from its
// grid position. With the offset the probe counts as its neighbour does (half the weight: Chebyshev's
// bound is 1 within the mean); without it, the bound 0.26 past the mean, (1e-4 / (1e-4 + 0.26^2))^3 =
// 3e-9, leaves it none.
TEST(RayBake, SamplersLookFromTheCapturePosition) {
    ProbeVolume volume;
    volume.grid = {glm::ivec3(2, 1, 1), glm::dvec3(0.0), glm::dvec3(1.0, 0.0, 0.0)};
    volume.order = 1;
    volume.end = 2;
    volume.irradiance = {glm::vec3(1.0f), glm::vec3(2.0f)};
    volume.valid = {1, 1};
    volume.visibilitySize = 4;
    volume.visibility.assign(2 * 16, glm::vec2(0.25f, 0.25f * 0.25f + 1e-4f));
    std::fill(volume.visibility.begin() + 16, volume.visibility.end(), glm::vec2(5.0f, 25.0f));
    const glm::dvec3 point(0.5, 0.0, 0.0), normal(0.0, 1.0, 0.0); // biased 0.1 up: 0.2 from (0.3, 0, 0)
    const double without = surfaceProbeWeights(volume, point, normal).weights[0];
    volume.offsets = {glm::vec3(0.3f, 0.0f, 0.0f), glm::vec3(0.0f)};
    const double with = surfaceProbeWeights(volume, point, normal).weights[0];
    std::printf("the moved probe's weight: %.3g from where it was captured, %.3g from its grid position\n",
                with, without);
    EXPECT_GT(with, 0.3);
    EXPECT_LT(without, 1e-6);
}

// The volume of a bake: the probes' irradiance, valid where less than half of a probe's view is
// back faces.
ProbeVolume volumeOf(const ProbeGrid& grid, const std::vector<RayBakedProbe>& probes, int faceSize) {
    ProbeVolume volume;
    volume.grid = grid;
    volume.order = 3;
    volume.end = grid.probeCount();
    for (const RayBakedProbe& probe : probes) {
        for (const glm::dvec3& c : probe.irradiance.rgb)
            volume.irradiance.push_back(glm::vec3(c));
        volume.valid.push_back(2 * probe.backFaceTexels <= 6u * uint32_t(faceSize * faceSize));
        volume.visibility.insert(volume.visibility.end(), probe.visibility.begin(), probe.visibility.end());
    }
    return volume;
}

// A world under the built-in sky with its sun taken out (sh/lights.h): the world the bake sees, the
// world lit by that sun (the path tracer's), the residual sky and the sun.
struct UnderTheSky {
    World world;
    World lit;
    Cubemap sky;
    std::vector<SceneSun> suns;
};

UnderTheSky underTheBuiltInSky(World world) {
    UnderTheSky scene{std::move(world), {}, makeDefaultSky(128), {}};
    const SunExtraction sun = extractSun(scene.sky);
    if (sun.found) scene.suns.push_back({glm::vec3(sun.direction), glm::vec3(sun.power)});
    scene.lit = scene.world;
    scene.lit.suns.insert(scene.lit.suns.end(), scene.suns.begin(), scene.suns.end());
    return scene;
}

UnderTheSky engineUnderTheBuiltInSky() {
    return underTheBuiltInSky(
        loadGltfScene(SHPROBE_GLTF_MODELS_DIR "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"));
}

// A scene's grid baked with the defaults (faces 32^2, kDefaultRaysPerTexel), the bounces from the
// cache and by paths, each against the path tracer at 262,144 directions, the errors printed.
struct CacheAndPaths {
    Agreement cache;
    Agreement paths;
    size_t validProbes = 0;
};

struct Sampling {
    int raysPerTexel = kDefaultRaysPerTexel;
    int referenceSamples = 262144;
};

CacheAndPaths agreementsUnderTheSky(const UnderTheSky& scene, const ProbeGrid& grid, int bounces,
                                    const char* name, const Sampling& sampling = {}) {
    const ReferenceTracer tracer(scene.lit, scene.sky);
    PathTraceOptions traced{.order = 3, .bounces = bounces, .samples = sampling.referenceSamples};
    traced.seenSuns = scene.suns;
    std::vector<PathTracedProbe> reference;
    CacheAndPaths agreements;
    for (BounceLight light : {BounceLight::Cache, BounceLight::Paths}) {
        RayBakeOptions options{
            .raysPerTexel = sampling.raysPerTexel, .bounces = bounces, .bounceLight = light};
        options.skySuns = scene.suns;
        RayBaker baker(scene.world, scene.sky, options);
        const auto [baked, positions] = validProbes(baker, grid);
        if (reference.empty()) reference = pathTraceProbes(tracer, positions, traced);
        const Agreement agreement = compare(baked, reference);
        std::printf("%s, %s, bounces %d, %zu valid probes: L00 error mean %.4f worst %.4f, any coefficient "
                    "%.4f (reference's standard error %.4f)\n",
                    name, light == BounceLight::Paths ? "paths" : "cache", bounces, baked.size(),
                    agreement.meanL00, agreement.worstL00, agreement.worstCoefficient,
                    agreement.referenceError);
        (light == BounceLight::Paths ? agreements.paths : agreements.cache) = agreement;
        agreements.validProbes = baked.size();
    }
    return agreements;
}

// 2CylinderEngine.glb (121,496 triangles) in the open under the built-in sky, whose sun covers
// about 1e-3 sr: taken out of the sky as a directional sun (sh/lights.h) and sampled explicitly by
// the bake and by the path tracer alike (uniform directions alone, without the sun taken out,
// differed by 137% between 6,144 and 65,536 directions), 3^3 probes, one bounce. Against the path
// tracer at 262,144 directions (standard error of L00 up to 0.18% of the mean). Measured (mean /
// worst L00, any coefficient): the cache 0.16% / 0.91% / 1.2%, paths 0.05% / 0.21% / 0.54% (0.09% /
// 0.39% / 0.85% at 2 x 2 rays a texel). Bounds: the cache 0.5% / 2% / 4%, paths the 0.5% / 2% / 2%
// asked of a bake.
TEST(RayBake, EngineUnderTheBuiltInSkyApproachesThePathTracer) {
    const UnderTheSky scene = engineUnderTheBuiltInSky();
    ASSERT_EQ(scene.suns.size(), 1u);
    const CacheAndPaths agreements =
        agreementsUnderTheSky(scene, probeGridInWorld(glm::ivec3(3), scene.world), 1, "engine");
    EXPECT_GT(agreements.validProbes, 10u);
    EXPECT_LT(agreements.cache.meanL00, 0.005);
    EXPECT_LT(agreements.cache.worstL00, 0.02);
    EXPECT_LT(agreements.cache.worstCoefficient, 0.04);
    EXPECT_LT(agreements.paths.meanL00, 0.005);
    EXPECT_LT(agreements.paths.worstL00, 0.02);
    EXPECT_LT(agreements.paths.worstCoefficient, 0.02);
}

// The engine's 8^3 grid (438 valid probes) holds probes in the open that see the sun and the sunlit
// engine close by, the brightest of the grid (L00 3 to 4 times the mean): their coefficients are the
// furthest off. At 2 x 2 rays a texel the four worst (probes 122, 53, 51 and 189) were 2.1%, 1.5%,
// 1.5% and 1.3% of the grid's mean L00 off the path tracer at 2^20 directions, past the 2% asked of
// any coefficient; here at the defaults (kDefaultRaysPerTexel), against the path tracer at 2^20
// directions (its standard error of L00 at most 0.1% of the mean), the mean L00 the grid's valid
// probes' from a coarse bake of the whole grid (faces 8, a ray a texel: its noise averages out over
// the 438). Measured (worst coefficient, each probe): 0.75%, 0.71%, 0.62% and 0.58%; 2 x 2 rays here
// 2.09%, 1.51%, 1.49% and 1.26%. Bound: the 2% asked of a bake.
TEST(RayBake, SunlitProbesOfADenseGridMeetTheBoundAtTheDefaults) {
    const UnderTheSky scene = engineUnderTheBuiltInSky();
    const ProbeGrid grid = probeGridInWorld(glm::ivec3(8), scene.world);
    std::vector<glm::dvec3> all;
    for (uint32_t p = 0; p < grid.probeCount(); ++p)
        all.push_back(probePosition(grid, probeCell(grid, p)));
    RayBakeOptions coarse{.faceSize = 8, .bounces = 1, .bounceLight = BounceLight::Paths};
    coarse.skySuns = scene.suns;
    double meanL00 = 0.0;
    size_t valid = 0;
    for (const RayBakedProbe& probe : RayBaker(scene.world, scene.sky, coarse).bakeProbes(all)) {
        if (insideGeometry(probe.backFaceTexels, coarse.faceSize, 0.5)) continue;
        meanL00 += probe.radiance.rgb[0].g;
        ++valid;
    }
    meanL00 /= double(valid);
    EXPECT_GT(valid, 400u);

    const std::vector<glm::dvec3> sunlit{all[122], all[53], all[51], all[189]};
    RayBakeOptions defaults{
        .raysPerTexel = kDefaultRaysPerTexel, .bounces = 1, .bounceLight = BounceLight::Paths};
    defaults.skySuns = scene.suns;
    const std::vector<RayBakedProbe> baked = RayBaker(scene.world, scene.sky, defaults).bakeProbes(sunlit);
    PathTraceOptions traced{.order = 3, .bounces = 1, .samples = 1 << 20};
    traced.seenSuns = scene.suns;
    const std::vector<PathTracedProbe> reference =
        pathTraceProbes(ReferenceTracer(scene.lit, scene.sky), sunlit, traced);
    for (size_t p = 0; p < sunlit.size(); ++p) {
        double worst = 0.0;
        for (size_t i = 0; i < baked[p].radiance.rgb.size(); ++i)
            worst = std::max(worst,
                             double(std::abs(baked[p].radiance.rgb[i].g - reference[p].radiance.rgb[i].g)));
        std::printf(
            "engine 8^3, sunlit probe %zu (L00 %.2f, the grid's mean %.2f): worst coefficient %.4f of the "
            "mean L00 (reference's standard error of L00 %.4f)\n",
            p, reference[p].radiance.rgb[0].g, meanL00, worst / meanL00,
            reference[p].standardError[0].g / meanL00);
        EXPECT_LT(worst / meanL00, 0.02) << p;
    }
}

// The lit room of the two rooms (scene_fixtures.h): closed but for a 0.5 m square opening in its
// ceiling, under the built-in sky with its sun and the room's glTF sun, 3^3 probes, bounces 1 and 2,
// the defaults (3 x 3 rays a texel): light that enters through a small opening and reaches most
// probes only after a bounce off the sunlit patch of floor, where the probe grid's bounces were 47%
// and 54% off. Paths sample the sunlit patch (SunlitSampler); with cosine rays alone finding it they
// were 0.71% / 3.2% / 4.1% off at bounce 1 and needed 4 x 4 rays a texel for the bounds. Against the
// path tracer at 2^20 directions (standard error of L00 up to 0.28% of the mean). Measured (mean /
// worst L00, any coefficient): bounce 1 cache 0.53% / 1.6% / 2.0%, paths 0.19% / 0.65% / 1.4%;
// bounce 2 cache 0.32% / 1.5% / 1.9%, paths 0.19% / 0.67% / 1.3% (at 2 x 2 rays a texel 0.29% /
// 1.2% / 1.3% and 0.28% / 1.1% / 1.4%). Bounds: paths the 0.5% / 2% / 2%
// asked of a bake.
TEST(RayBake, RoomLitThroughAnOpeningApproachesThePathTracer) {
    const UnderTheSky scene = underTheBuiltInSky(testing::loadFixtureWorld(testing::twoRoomsScene()));
    const ProbeGrid grid = makeProbeGrid(glm::ivec3(3), {{-1.8, 0.2, -0.8}, {-0.2, 1.8, 0.8}});
    for (int bounces : {1, 2}) {
        const CacheAndPaths agreements =
            agreementsUnderTheSky(scene, grid, bounces, "room", {.referenceSamples = 1 << 20});
        EXPECT_EQ(agreements.validProbes, 27u);
        EXPECT_LT(agreements.paths.meanL00, 0.005) << bounces;
        EXPECT_LT(agreements.paths.worstL00, 0.02) << bounces;
        EXPECT_LT(agreements.paths.worstCoefficient, 0.02) << bounces;
    }
}

// Which suns the paths sample (SunlitSampler; emitters.cpp kMostLitShare, 4%): the lit room's glTF
// sun and the built-in sky's, let in through a 0.5 m opening, light what they reach from about 1%
// of their planes, and both are sampled, with the walls one-sided or double-sided (the sunlit roof
// lights nothing but the sky); the built-in sky's sun on 2CylinderEngine lights what it reaches from
// 11%, where the cosine rays meet that light often enough and sampling it took 1.3 to 1.6 times as
// long for no lower error, and is not.
TEST(RayBake, SunsAreSampledWhereTheyComeInThroughAnOpening) {
    struct Case {
        const char* name;
        UnderTheSky scene;
        size_t sampledSuns;
    };
    testing::FixtureScene doubleSided = testing::twoRoomsScene();
    doubleSided.materials[0].doubleSided = true;
    const Case cases[] = {
        {"rooms", underTheBuiltInSky(testing::loadFixtureWorld(testing::twoRoomsScene())), 2},
        {"rooms, double-sided", underTheBuiltInSky(testing::loadFixtureWorld(doubleSided)), 2},
        {"2CylinderEngine", engineUnderTheBuiltInSky(), 0},
    };
    for (const Case& c : cases) {
        const SceneShading shading(c.scene.lit, c.scene.sky);
        const Bvh bvh = buildBvh(c.scene.world);
        const BvhRayCaster caster(bvh);
        const SunlitSampler sampler(shading, caster);
        std::set<uint32_t> sampled; // the suns of the cells it picks
        for (const uint32_t cell : sampler.cells().picked())
            sampled.insert(cell / uint32_t(SunlitSampler::kCells * SunlitSampler::kCells));
        std::printf("%s: %zu of %zu suns sampled\n", c.name, sampled.size(), c.scene.lit.suns.size());
        EXPECT_EQ(sampled.size(), c.sampledSuns) << c.name;
    }
}

// The probe of 2CylinderEngine's 8^3 grid (built-in sky, its sun taken out, one bounce) that the
// lattice alone bakes worst: in the sun's shade, above large triangles whose cache points, 8.8
// apart, straddle an overhang's edge, so that interpolation carries the bright side's bounce light
// over the dark. Measured against the path tracer at 65,536 directions (standard error 0.23% of its
// L00): 8.93 against 9.86, 9.4% off, with the lattice alone; 9.72, 1.4% off, with cells halved
// three times where their corners' irradiance differs by half; by paths, which read no cache, 0.12%
// off. Bounds: 6%, 3% and 2%, the first so that the check shows the fault, the others its cures
// with room for another compiler's rounding.
TEST(RayBake, HalvedCacheCellsFollowAnOverhangsEdge) {
    const auto [world, lit, sky, suns] = engineUnderTheBuiltInSky();
    ASSERT_EQ(suns.size(), 1u);
    const ProbeGrid grid = probeGridInWorld(glm::ivec3(8), world);
    const std::vector<glm::dvec3> position{probePosition(grid, probeCell(grid, 446))};
    const ReferenceTracer tracer(lit, sky);
    PathTraceOptions traced{.order = 3, .bounces = 1, .samples = 65536};
    traced.seenSuns = suns;
    const PathTracedProbe reference = pathTraceProbes(tracer, position, traced)[0];
    const double l00 = reference.radiance.rgb[0].g;
    double errors[2] = {};
    for (int refinement : {0, 3}) {
        RayBakeOptions options{.raysPerTexel = 4, .bounces = 1, .cacheRefinement = refinement};
        options.skySuns = suns;
        RayBaker baker(world, sky, options);
        const RayBakedProbe probe = baker.bakeProbes(position)[0];
        errors[refinement > 0] = std::abs(probe.radiance.rgb[0].g - l00) / l00;
        std::printf(
            "refinement %d: L00 %.4f against %.4f (standard error %.4f): %.4f off, %llu cache points\n",
            refinement, probe.radiance.rgb[0].g, l00, reference.standardError[0].g / l00,
            errors[refinement > 0], (unsigned long long)baker.counts().cachePoints);
    }
    EXPECT_GT(errors[0], 0.06);
    EXPECT_LT(errors[1], 0.03);
    RayBakeOptions options{.raysPerTexel = 4, .bounces = 1, .bounceLight = BounceLight::Paths};
    options.skySuns = suns;
    RayBaker baker(world, sky, options);
    const double paths = std::abs(baker.bakeProbes(position)[0].radiance.rgb[0].g - l00) / l00;
    std::printf("paths: %.4f off\n", paths);
    EXPECT_LT(paths, 0.02);
}

// Two rooms and a 2 cm wall between them (scene_fixtures.h), the lit one open to the sky and the
// sun, the other closed: no light reaches the closed room, yet its surfaces near the wall share grid
// cells with probes in the lit room (5^3 probes, x at -1.9, -1.0, -0.1, 0.8 and 1.7, none in the
// wall). Sampled without visibility, the closed room's floor, back wall and ceiling receive 16% of
// what the lit room's do (measured: 0.163 from the cache, 0.159 by paths); with the probes' depth
// moments, 0.19% and below 0.01%. The bound is the 1% a renderer cannot see; the first check shows the
// scene does leak without them. The closed room's own probes see no light by paths either.
TEST(RayBake, LightDoesNotLeakThroughAThinWall) {
    const World world = testing::loadFixtureWorld(testing::twoRoomsScene());
    const ProbeGrid grid = makeProbeGrid(glm::ivec3(5), {{-1.9, 0.2, -0.8}, {1.7, 1.8, 0.8}});
    std::vector<glm::dvec3> positions;
    for (uint32_t p = 0; p < grid.probeCount(); ++p)
        positions.push_back(probePosition(grid, probeCell(grid, p)));
    for (BounceLight light : {BounceLight::Cache, BounceLight::Paths}) {
        RayBaker baker(world, testing::directionalSky(8),
                       {.faceSize = 16, .bounces = 1, .bounceLight = light});
        const std::vector<RayBakedProbe> probes = baker.bakeProbes(positions);
        ProbeVolume volume = volumeOf(grid, probes, 16);
        const std::vector<glm::vec2> visibility = std::move(volume.visibility);
        volume.visibility.clear();
        const double leakWithout =
            testing::twoRoomsIrradiance(volume, 0.01, 2.0) / testing::twoRoomsIrradiance(volume, -2.0, -0.01);
        volume.visibilitySize = 16;
        volume.visibility = visibility;
        const double lit = testing::twoRoomsIrradiance(volume, -2.0, -0.01);
        const double leak = testing::twoRoomsIrradiance(volume, 0.01, 2.0) / lit;
        const char* name = light == BounceLight::Paths ? "paths" : "cache";
        std::printf(
            "%s: the closed room receives %.4f of the lit room's irradiance (%.4f without visibility)\n",
            name, leak, leakWithout);
        EXPECT_GT(lit, 0.05) << name;
        EXPECT_GT(leakWithout, 0.05) << name;
        EXPECT_LT(leak, 0.01) << name;
        if (light == BounceLight::Cache) continue;
        for (size_t p = 0; p < positions.size(); ++p)
            if (positions[p].x > 0.0) {
                EXPECT_EQ(probes[p].radiance.rgb[0], glm::dvec3(0.0)) << p;
            }
    }
}

} // namespace
} // namespace shprobe
