// Relightable probe volumes (scene/volume_bake.h): a volume baked with its transfer and relit by a
// sky equals the volume baked under that sky band-limited to the transfer's order, turned skies
// included; closed forms where nothing is around (the sky itself) and where nothing gets out (no
// transfer at all).
#include "common/error.h"
#include "image/environment.h"
#include "scene/probe_grid.h"
#include "scene/volume_bake.h"
#include "scene_fixtures.h"
#include "sh/irradiance.h"
#include "sh/projection.h"
#include "sh/rotation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace shprobe {
namespace {

// Faces 8 with 2 x 2 rays a texel: the sky is read at the rays' footprint, faces 16.
constexpr int kFaceSize = 8;
constexpr int kFootprintFaceSize = 16;

// The options asked of bakeVolumeTransfer, which turns the strata's rays towards a bright sky off
// (RayBakeOptions::skyThroughStrata: they follow the sky, so a bake under another sky would cast
// other rays); directBake's bakes turn them off too, to cast the transfer's rays.
VolumeBakeOptions bakeOptions(const ProbeGrid& grid, int bounces) {
    const double cell = smallestCellEdge(grid);
    return {.rays = {.order = 3,
                     .faceSize = kFaceSize,
                     .raysPerTexel = 4,
                     .bounces = bounces,
                     .gatherRays = 16,
                     .relocation = {.limit = 0.45 * cell, .minFrontDistance = 0.1 * cell}},
            .dilate = true};
}

ProbeVolume directBake(const World& world, const Cubemap& sky, const ProbeGrid& grid, int bounces) {
    VolumeBakeOptions options = bakeOptions(grid, bounces);
    options.rays.skyThroughStrata = false;
    VolumeBakeReport report;
    return bakeVolumeByRays(world, {sky, {}}, options, grid, {0, grid.probeCount()}, report);
}

// A sky with every band present and no symmetry: the built-in sky's projection at order 3.
ShCoefficients testSky() {
    return projectCubemap(makeDefaultSky(32), 3);
}

double meanL00(const ProbeVolume& volume) {
    double sum = 0.0;
    size_t valid = 0;
    for (size_t p = 0; p < volume.probeCount(); ++p) {
        if (!volume.valid[p]) continue;
        sum += double(volume.radiance[p * 9].g);
        ++valid;
    }
    return sum / double(std::max<size_t>(valid, 1));
}

// The largest difference of any coefficient, channel and quantity, over the mean L00 of `expected`.
double worstDifference(const ProbeVolume& relit, const ProbeVolume& expected) {
    EXPECT_EQ(relit.valid, expected.valid);
    double worst = 0.0;
    for (const auto& [a, b] :
         {std::pair(&relit.radiance, &expected.radiance), std::pair(&relit.irradiance, &expected.irradiance)})
        for (size_t i = 0; i < a->size(); ++i)
            for (int c = 0; c < 3; ++c)
                worst = std::max(worst, std::abs(double((*a)[i][c]) - double((*b)[i][c])));
    return worst / meanL00(expected);
}

// The open Cornell box with its blocks, its emissive square (static) and a sun through the opening
// (static), the sky seen through the open front.
World openRoom() {
    return testing::loadCornellBoxWorld(
        {.innerBoxes = true,
         .sun = testing::FixtureSun{.towardsLight = {0.3f, 0.6f, 1.0f}, .intensity = 3.0f}});
}

// The bake is linear in its sky's light, so relighting by S is the bake under the sky S (drawn at
// the rays' footprint, as the transfer's basis is) up to float rounding: sums of order^2 + 1 terms
// in another order. 1e-4 of the mean L00 is what relighting must meet; measured: 1.1e-5 at most.
TEST(VolumeTransfer, RelitEqualsTheBakeUnderTheBandLimitedSky) {
    const World world = openRoom();
    const ProbeGrid grid = probeGridInWorld({3, 3, 3}, world);
    const ProbeRange range{0, grid.probeCount()};
    const ShCoefficients sky = testSky();
    for (int bounces : {0, 2}) {
        VolumeBakeReport report;
        ProbeVolume relit =
            bakeVolumeTransfer(world, kFootprintFaceSize, bakeOptions(grid, bounces), grid, range, report);
        relightVolume(relit, sky);
        const ProbeVolume direct = directBake(world, evaluateCubemap(sky, kFootprintFaceSize), grid, bounces);
        const double worst = worstDifference(relit, direct);
        std::printf("bounces %d: relit against baked, worst %.2e of the mean L00\n", bounces, worst);
        EXPECT_LT(worst, 1e-4) << bounces;
    }
}

// Turning the light: relit by the sky's coefficients rotated (sh/rotation.h) equals the bake under
// the sky turned texel by texel, L'(w) = L(R^T w) with R = lightRotation(yaw, pitch) (a light from d
// then comes from R d), drawn here without the SH rotation. The rotation's own error is far below
// float's; the bound is the one above.
TEST(VolumeTransfer, TurnedSkyEqualsTheBakeUnderTheTurnedSky) {
    const World world = openRoom();
    const ProbeGrid grid = probeGridInWorld({2, 2, 3}, world);
    const ProbeRange range{0, grid.probeCount()};
    const ShCoefficients sky = testSky();
    const glm::dmat3 R = lightRotation(70.0, 25.0);
    Cubemap turned = makeCubemap(kFootprintFaceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < kFootprintFaceSize; ++j)
            for (int i = 0; i < kFootprintFaceSize; ++i) {
                const glm::dvec3 d = texelDirection(face, i, j, kFootprintFaceSize);
                turned.at(face, i, j) = glm::vec4(glm::vec3(evaluate(sky, glm::transpose(R) * d)), 1.0f);
            }
    VolumeBakeReport report;
    ProbeVolume relit =
        bakeVolumeTransfer(world, kFootprintFaceSize, bakeOptions(grid, 1), grid, range, report);
    relightVolume(relit, rotate(makeShRotation(R, 3), sky));
    const ProbeVolume direct = directBake(world, turned, grid, 1);
    const double worst = worstDifference(relit, direct);
    std::printf("turned yaw 70, pitch 25: relit against baked, worst %.2e of the mean L00\n", worst);
    EXPECT_LT(worst, 1e-4);
}

// Nothing around the probes: each sees the sky alone, so its transfer is the cube map's quadrature
// of the basis' orthonormality, T_ij = sum y_i(w) y_j(w) dw -> delta_ij, and relit by S it is S.
// One ray through each texel centre of faces 16, the sky drawn at the same centres: the quadrature's
// error at order 3 is a few 1e-3 (measured below); 1e-2 would catch a basis function in the wrong
// column, a sign or a transposed matrix (entries of size 1).
TEST(VolumeTransfer, WithNothingAroundTheTransferIsTheIdentity) {
    const World empty;
    const ProbeGrid grid = makeProbeGrid({2, 1, 1}, {{-1.0, 0.0, 0.0}, {1.0, 0.0, 0.0}});
    VolumeBakeOptions options = bakeOptions(grid, 1);
    options.rays.faceSize = kFootprintFaceSize;
    options.rays.raysPerTexel = 1;
    VolumeBakeReport report;
    const ProbeVolume volume = bakeVolumeTransfer(empty, kFootprintFaceSize, options, grid, {0, 2}, report);
    double worst = 0.0;
    for (size_t p = 0; p < 2; ++p)
        for (size_t i = 0; i < 9; ++i)
            for (size_t j = 0; j < 9; ++j)
                worst = std::max(worst, std::abs(double(volume.transfer[(p * 9 + i) * 9 + j].b) - (i == j)));
    std::printf("empty world: transfer off the identity by %.2e at most\n", worst);
    EXPECT_LT(worst, 1e-2);
    for (const glm::vec3& value : volume.staticRadiance)
        EXPECT_EQ(value, glm::vec3(0.0f));
}

// A closed room: no ray from inside reaches the sky, so every transfer entry is exactly 0 and the
// volume is its static part (the emissive square, bounced), whatever the sky.
TEST(VolumeTransfer, ClosedRoomHasNoTransfer) {
    const World world = testing::loadCornellBoxWorld({.closed = true, .innerBoxes = true});
    const ProbeGrid grid = probeGridInWorld({2, 2, 2}, world);
    VolumeBakeReport report;
    ProbeVolume volume =
        bakeVolumeTransfer(world, kFootprintFaceSize, bakeOptions(grid, 1), grid, {0, 8}, report);
    for (const glm::vec3& value : volume.transfer)
        ASSERT_EQ(value, glm::vec3(0.0f));
    relightVolume(volume, testSky());
    EXPECT_EQ(volume.radiance, volume.staticRadiance);
    EXPECT_GT(meanL00(volume), 0.0);
}

// Options whose bake is not linear in the sky are refused, and so is relighting what has no transfer.
TEST(VolumeTransfer, RefusesWhatCannotBeRelit) {
    const World world = testing::loadCornellBoxWorld({.closed = true});
    const ProbeGrid grid = probeGridInWorld({1, 1, 1}, world);
    VolumeBakeOptions options = bakeOptions(grid, 1);
    options.rays.cacheRefinement = 2;
    VolumeBakeReport report;
    EXPECT_THROW(bakeVolumeTransfer(world, kFootprintFaceSize, options, grid, {0, 1}, report), Error);
    options = bakeOptions(grid, 1);
    options.rays.bounceLight = BounceLight::Paths; // its sky samples follow the sky's brightness
    EXPECT_THROW(bakeVolumeTransfer(world, kFootprintFaceSize, options, grid, {0, 1}, report), Error);
    options = bakeOptions(grid, 1);
    ProbeVolume plain = bakeVolumeByRays(world, {makeDefaultSky(8), {}}, options, grid, {0, 1}, report);
    EXPECT_THROW(relightVolume(plain, testSky()), Error);
    ProbeVolume relightable = bakeVolumeTransfer(world, kFootprintFaceSize, options, grid, {0, 1}, report);
    EXPECT_THROW(relightVolume(relightable, makeCoefficients(2, Quantity::Radiance)), Error);
}

} // namespace
} // namespace shprobe
