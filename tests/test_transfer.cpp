// Per-vertex transfer (scene/transfer.h) against closed forms, and `shprobe transfer`'s files
// (scene/transfer_gltf.h): refusals, the attributes read back from the .glb, the binary file, and the
// Khronos glTF validator's report.
#include "common/error.h"
#include "scene/bvh.h"
#include "scene/gltf_scene.h"
#include "scene/sampling.h"
#include "scene/transfer.h"
#include "scene/transfer_gltf.h"
#include "scene_fixtures.h"
#include "sh/basis.h"
#include "sh/irradiance.h"
#include "sh/rotation.h"
#include "terminal_run.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <set>
#include <sstream>

namespace shprobe {
namespace {

namespace fs = std::filesystem;
using testing::FixtureMesh;
using testing::FixtureScene;
using testing::Glb;
using testing::readGlb;

constexpr double kPi = std::numbers::pi;

// ---- Scenes ----------------------------------------------------------------------------------------

// A horizontal square of half-side `half` at the origin, facing +y, fanned about a centre vertex
// (vertex 0 of the mesh), so that one vertex sits where the closed forms put it.
void addFannedSquare(FixtureMesh& mesh, float half) {
    const uint32_t first = uint32_t(mesh.positions.size());
    mesh.positions.push_back(glm::vec3(0.0f));
    const glm::vec3 corners[4] = {{-half, 0, -half}, {-half, 0, half}, {half, 0, half}, {half, 0, -half}};
    for (const glm::vec3& c : corners)
        mesh.positions.push_back(c);
    mesh.normals.assign(mesh.positions.size(), glm::vec3(0, 1, 0));
    for (uint32_t k = 0; k < 4; ++k) // counter-clockwise seen from +y
        mesh.indices.insert(mesh.indices.end(), {first, first + 1 + k, first + 1 + (k + 1) % 4});
}

// A regular M-gon of circumradius r at height h, centred above the origin, facing down.
void addDisc(FixtureMesh& mesh, float r, float h, int segments) {
    const uint32_t centre = uint32_t(mesh.positions.size());
    mesh.positions.push_back({0.0f, h, 0.0f});
    for (int k = 0; k < segments; ++k) {
        const double a = 2.0 * kPi * k / segments;
        mesh.positions.push_back({float(r * std::cos(a)), h, float(r * std::sin(a))});
    }
    mesh.normals.resize(mesh.positions.size(), glm::vec3(0, -1, 0));
    for (uint32_t k = 0; k < uint32_t(segments); ++k) // counter-clockwise seen from -y
        mesh.indices.insert(mesh.indices.end(),
                            {centre, centre + 1 + k, centre + 1 + (k + 1) % uint32_t(segments)});
}

// The inside of a unit sphere with the cap of half-angle `cap` about +y cut away: rings of latitude
// from the cap's rim down to the south pole, faces and normals inward.
void addOpenSphere(FixtureMesh& mesh, double cap, int rings, int segments) {
    for (int i = 0; i <= rings; ++i) {
        const double theta = cap + (kPi - cap) * i / rings;
        for (int k = 0; k < segments; ++k) {
            const double phi = 2.0 * kPi * k / segments;
            const glm::vec3 p(float(std::sin(theta) * std::cos(phi)), float(std::cos(theta)),
                              float(std::sin(theta) * std::sin(phi)));
            mesh.positions.push_back(p);
            mesh.normals.push_back(-p);
        }
    }
    for (uint32_t i = 0; i < uint32_t(rings); ++i)
        for (uint32_t k = 0; k < uint32_t(segments); ++k) {
            const uint32_t n = uint32_t(segments), a = i * n + k, b = i * n + (k + 1) % n;
            // seen from the centre (inside), a, a + n, b + n, b runs counter-clockwise
            mesh.indices.insert(mesh.indices.end(), {a, a + n, b + n, a, b + n, b});
        }
}

FixtureScene sceneOf(std::vector<FixtureMesh> meshes, std::vector<testing::FixtureMaterial> materials,
                     const glm::quat& rotation = glm::quat(1, 0, 0, 0)) {
    FixtureScene scene;
    scene.materials = std::move(materials);
    for (size_t m = 0; m < meshes.size(); ++m) {
        if (meshes[m].material < 0) meshes[m].material = 0;
        scene.nodes.push_back({.mesh = int(m), .rotation = rotation});
        scene.roots.push_back(int(m));
    }
    scene.meshes = std::move(meshes);
    return scene;
}

// ---- Closed forms --------------------------------------------------------------------------------

// P_l(t) by Bonnet's recurrence.
double legendre(int l, double t) {
    double previous = 1.0, current = t;
    if (l == 0) return 1.0;
    for (int k = 1; k < l; ++k) {
        const double next = ((2 * k + 1) * t * current - k * previous) / (k + 1);
        previous = current;
        current = next;
    }
    return current;
}

// integral over [a, b] of t P_l(t) dt by 8-point Gauss-Legendre, exact for polynomials of degree up
// to 15 (t P_l has degree l + 1 <= 8).
double integralOfTPl(int l, double a, double b) {
    static const double x[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                0.9602898564975363};
    static const double w[4] = {0.3626837833783620, 0.3137066238569540, 0.2223810344533745,
                                0.1012285362903763};
    double sum = 0.0;
    for (int i = 0; i < 4; ++i)
        for (double s : {-x[i], x[i]}) {
            const double t = 0.5 * (b - a) * s + 0.5 * (a + b);
            sum += w[i] * t * legendre(l, t);
        }
    return 0.5 * (b - a) * sum;
}

// Shadowed transfer of albedo rho at normal n where the sky is seen only outside the cone of
// half-angle alpha about n: the zonal coefficients z_l = 2 pi K_l integral_0^cos(alpha) t P_l(t) dt
// rotated to n, sqrt(4 pi / (2l + 1)) z_l y_lm(n) = 2 pi integral(...) y_lm(n).
std::vector<double> coneTransfer(int order, double rho, const glm::dvec3& n, double alpha) {
    std::vector<double> basis(size_t(coefficientCount(order)));
    evalBasis(order, n, basis);
    for (int l = 0; l < order; ++l)
        for (int m = -l; m <= l; ++m)
            basis[size_t(shIndex(l, m))] *= rho / kPi * 2.0 * kPi * integralOfTPl(l, 0.0, std::cos(alpha));
    return basis;
}

double greenAt(const VertexTransfer& transfer, uint32_t vertex, int i) {
    return transfer.coefficients[size_t(vertex) * size_t(coefficientCount(transfer.order)) + size_t(i)].g;
}

// A square of half-side `half` at the origin, facing +y, as an n x n grid of vertices.
void addGridSquare(FixtureMesh& mesh, float half, uint32_t n) {
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = 0; j < n; ++j)
            mesh.positions.push_back({half * (2.0f * float(i) / float(n - 1) - 1.0f), 0.0f,
                                      half * (2.0f * float(j) / float(n - 1) - 1.0f)});
    mesh.normals.assign(mesh.positions.size(), glm::vec3(0, 1, 0));
    for (uint32_t i = 0; i + 1 < n; ++i)
        for (uint32_t j = 0; j + 1 < n; ++j) { // counter-clockwise seen from +y
            const uint32_t a = i * n + j, b = a + 1, c = a + n, d = c + 1;
            mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
        }
}

// Root mean square and largest difference of the green transfer of two runs over every coefficient.
std::pair<double, double> rmsAndWorst(const VertexTransfer& a, const VertexTransfer& b) {
    double squares = 0.0, worst = 0.0;
    for (size_t k = 0; k < a.coefficients.size(); ++k) {
        const double d = double(a.coefficients[k].g) - double(b.coefficients[k].g);
        squares += d * d;
        worst = std::max(worst, std::abs(d));
    }
    return {std::sqrt(squares / double(a.coefficients.size())), worst};
}

// The stratified cosine directions that transfer and the cache's gathers cast
// (StratifiedCosineDirections) are cosineDirection's for the same numbers: exactly below 8 x 8
// strata, from 8 x 8 up to 2e-15 (a few units of the last place of an azimuth near 2 pi, 8.9e-16,
// which rounds in either), where the azimuth comes by angle addition and a Taylor series
// (smallAngleCosSin, itself within 2.3e-16 of cos and sin over [-pi/4, pi/4]).
TEST(Transfer, StratifiedDirectionsAreCosineDirections) {
    double worstSeries = 0.0;
    for (int i = -1000; i <= 1000; ++i) {
        const double x = std::numbers::pi / 4.0 * i / 1000.0;
        const glm::dvec2 cosSin = smallAngleCosSin(x);
        worstSeries =
            std::max({worstSeries, std::abs(cosSin.x - std::cos(x)), std::abs(cosSin.y - std::sin(x))});
    }
    EXPECT_LT(worstSeries, 2.3e-16);
    for (const glm::dvec3& n :
         {glm::dvec3(0, 0, 1), glm::dvec3(0, 0, -1), glm::normalize(glm::dvec3(0.3, -0.8, 0.2))}) {
        for (int g : {1, 2, 7, 8, 9, 16, 33}) {
            RandomStream random(5, 6, uint64_t(g)), again(5, 6, uint64_t(g));
            double worst = 0.0;
            int a = 0, b = 0;
            StratifiedCosineDirections(g).forEach(n, random, [&](const glm::dvec3& direction) {
                const double u1 = (a + again.next()) / g, u2 = (b + again.next()) / g;
                const glm::dvec3 expected = cosineDirection(n, u1, u2);
                worst = std::max(worst, glm::length(direction - expected));
                if (++b == g) b = 0, ++a;
            });
            EXPECT_EQ(a, g) << "g " << g;
            if (g < 8)
                EXPECT_EQ(worst, 0.0) << "g " << g;
            else
                EXPECT_LT(worst, 2e-15) << "g " << g;
        }
    }
}

// Unshadowed transfer is rho / pi A_l y_lm(n), exact: at n = +y, by the hand values of
// docs/conventions.md (y00 = 0.282094792, y1-1 = -0.488602512 y, A_0 = pi, A_1 = 2 pi / 3,
// A_2 = pi / 4, y20 = 0.315391565 (3 z^2 - 1) with z = 0), to float's rounding.
TEST(Transfer, UnshadowedHandValues) {
    const double rho = 0.6;
    FixtureMesh plane;
    addFannedSquare(plane, 1.0f);
    const World world = testing::loadFixtureWorld(sceneOf({plane}, {{glm::vec3(float(rho))}}));
    const VertexTransfer exact = computeTransfer(world, {.model = TransferModel::Unshadowed, .order = 8});
    constexpr double kExact = 1e-6; // float storage of values below 1
    for (uint32_t v = 0; v < 5; ++v) {
        EXPECT_NEAR(greenAt(exact, v, 0), rho * 0.282094792, kExact);
        EXPECT_NEAR(greenAt(exact, v, shIndex(1, -1)), rho * (2.0 / 3.0) * -0.488602512, kExact);
        EXPECT_NEAR(greenAt(exact, v, shIndex(1, 0)), 0.0, kExact);
        EXPECT_NEAR(greenAt(exact, v, shIndex(2, 0)), rho * 0.25 * 0.315391565 * -1.0, kExact);
        EXPECT_NEAR(greenAt(exact, v, shIndex(3, 0)), 0.0, kExact); // A_3 = 0
    }
}

// A vertex on a plane that nothing lies above sees the whole hemisphere: its shadowed transfer is
// the unshadowed integral, estimated by g x g jittered stratified cosine rays. That estimate is
// unbiased, and for a smooth integrand of the unit square one jittered sample per stratum leaves a
// variance of mean |grad f|^2 / (12 g^4) (each stratum's h^2/12 |grad f|^2, h = 1/g): its error
// falls as 1/R, R = g^2 rays. The Malley map's sqrt(u1) at the axis and sqrt(1 - u1) at the horizon
// only add a factor sqrt(log R). So the root mean square error over a 12 x 12 grid of vertices
// (144 independent streams, rho = 0.6) must fall by at least 3 from 256 to 1024 rays (measured:
// 3.9 at order 3, 3.8 at order 8; R^-1 gives 4, R^-0.5 gives 2). At 1024 rays it must stay within
// 1.25 times its measured value, 3.2e-4 at order 3 and 9.0e-4 at order 8 (a deterministic seed:
// the margin covers the arithmetic of another compiler), and the largest of the 1296 (order 3) or
// 9216 (order 8) differences within 5 root mean squares (measured: 4.5 and 4.8).
TEST(Transfer, OpenPlaneShadowedConvergesAsOneOverRays) {
    const double rho = 0.6;
    FixtureMesh plane;
    addGridSquare(plane, 0.5f, 12);
    const World world = testing::loadFixtureWorld(sceneOf({plane}, {{glm::vec3(float(rho))}}));
    for (auto [order, kRms] : {std::pair{3, 3.2e-4}, std::pair{8, 9.0e-4}}) {
        const VertexTransfer unshadowed =
            computeTransfer(world, {.model = TransferModel::Unshadowed, .order = order});
        const auto [coarse, coarseWorst] = rmsAndWorst(
            computeTransfer(world, {.model = TransferModel::Shadowed, .order = order, .rays = 256}),
            unshadowed);
        const auto [fine, worst] = rmsAndWorst(
            computeTransfer(world, {.model = TransferModel::Shadowed, .order = order, .rays = 1024}),
            unshadowed);
        EXPECT_GE(coarse / fine, 3.0) << "order " << order;
        EXPECT_LE(fine, 1.25 * kRms) << "order " << order;
        EXPECT_LE(worst, 5.0 * 1.25 * kRms) << "order " << order;
        std::printf("open plane, order %d: rms %.3g (256 rays), %.3g (1024), largest %.3g\n", order, coarse,
                    fine, worst);
    }
}

// A vertex under a disc of radius r at height h sees the sky outside the cone of half-angle
// atan(r / h): its transfer has the closed form of coneTransfer. The configuration is turned so that
// the normal is not an axis (the zonal rotation is exercised). The disc is a 512-gon (its rim within
// 2e-5 r of the circle: a change below 1e-5 in any coefficient). 64 x 64 jittered stratified rays
// estimate the coefficients within 4.9e-4 (order 3) and 1.2e-3 (order 8, whose integrands jump at
// the cone's rim), measured with rho = 0.8; the tolerance, 3e-3, is 2.5 times the larger.
TEST(Transfer, DiscAboveAPlaneMatchesTheConeClosedForm) {
    const double rho = 0.8, r = 1.0, h = 1.5;
    FixtureMesh plane, disc;
    addFannedSquare(plane, 4.0f);
    addDisc(disc, float(r), float(h), 512);
    const glm::quat turn = glm::angleAxis(0.7f, glm::normalize(glm::vec3(1.0f, 0.2f, -0.5f)));
    const World world = testing::loadFixtureWorld(sceneOf({plane, disc}, {{glm::vec3(float(rho))}}, turn));
    const glm::dvec3 n = glm::normalize(glm::dvec3(turn * glm::vec3(0, 1, 0)));
    for (int order : {3, 8}) {
        const VertexTransfer transfer =
            computeTransfer(world, {.model = TransferModel::Shadowed, .order = order, .rays = 4096});
        const std::vector<double> expected = coneTransfer(order, rho, n, std::atan(r / h));
        double worst = 0.0;
        for (int i = 0; i < coefficientCount(order); ++i) {
            EXPECT_NEAR(greenAt(transfer, 0, i), expected[size_t(i)], 3e-3)
                << "order " << order << ", i " << i;
            worst = std::max(worst, std::abs(greenAt(transfer, 0, i) - expected[size_t(i)]));
        }
        std::printf("disc, order %d: largest difference %.3g\n", order, worst);
    }
}

// Inside a closed box no ray reaches the sky: the shadowed and the interreflected transfer (every
// bounce made of that sky) are exactly 0, of a triangle floating inside and of the walls.
TEST(Transfer, InsideAClosedBoxIsExactlyZero) {
    FixtureMesh box, triangle;
    testing::addBox(box, glm::vec3(0.0f), glm::vec3(2.0f), true);
    testing::addQuad(triangle, glm::vec3(0.0f), {0.0f, 0.0f, 0.1f}, {0.1f, 0.0f, 0.0f});
    const World world = testing::loadFixtureWorld(sceneOf({box, triangle}, {{glm::vec3(0.9f)}}));
    for (TransferModel model : {TransferModel::Shadowed, TransferModel::Interreflected}) {
        const VertexTransfer transfer = computeTransfer(world, {.model = model, .rays = 64, .bounces = 2});
        for (const glm::vec3& c : transfer.coefficients)
            ASSERT_EQ(c, glm::vec3(0.0f)) << transferModelName(model);
    }
}

// The open sphere: from any point inside a sphere, a piece of it of area a takes a / (4 pi) of the
// cosine-weighted hemisphere (its form factor), wherever the point is. With the cap of half-angle c
// cut away, each point sees the sky through f = (1 - cos c) / 2 and the sphere through 1 - f, so
// under a uniform sky (L00 only) every bounce is the one before times rho (1 - f):
//   T_00 = rho f y00 sum_{k=0..K} (rho (1 - f))^k.
// The sphere is faceted (48 rings of 96 segments: the facets fall short of it by up to 1.6e-3 of
// the radius and the rim is a 96-gon), which moves f by about 1e-3 relative; the mean over the
// vertices of the stratified estimate (64 rays) errs by less: measured, the mean is within 0.1% of
// the series for K = 0 to 3. 1% of T_00 is the tolerance of the mean. Each bounce adds energy: T_00 never
// falls as K grows, at every vertex.
TEST(Transfer, OpenSphereFollowsTheBounceSeries) {
    const double rho = 0.7, cap = kPi / 3.0, f = (1.0 - std::cos(cap)) / 2.0;
    FixtureMesh sphere;
    addOpenSphere(sphere, cap, 48, 96);
    const World world = testing::loadFixtureWorld(sceneOf({sphere}, {{glm::vec3(float(rho))}}));
    std::vector<double> previous(world.positions.size(), 0.0);
    double series = 0.0;
    for (int bounces = 0; bounces <= 3; ++bounces) {
        series += rho * f * 0.282094792 * std::pow(rho * (1.0 - f), bounces);
        const VertexTransfer transfer = computeTransfer(
            world, {.model = TransferModel::Interreflected, .order = 1, .rays = 64, .bounces = bounces});
        double mean = 0.0;
        for (uint32_t v = 0; v < world.positions.size(); ++v) {
            const double t00 = greenAt(transfer, v, 0);
            mean += t00 / double(world.positions.size());
            EXPECT_GE(t00, previous[v]) << "vertex " << v << ", bounces " << bounces;
            previous[v] = t00;
        }
        EXPECT_NEAR(mean, series, 0.01 * series) << "bounces " << bounces;
        std::printf("open sphere, %d bounces: mean T00 %.6f, series %.6f\n", bounces, mean, series);
    }
}

// A smooth coloured sky of order n: every coefficient set, L_00 the largest.
ShCoefficients smoothSkyOfOrder(int order) {
    ShCoefficients sky = makeCoefficients(order, Quantity::Radiance);
    for (int i = 0; i < coefficientCount(order); ++i)
        sky.rgb[size_t(i)] =
            i == 0 ? glm::dvec3(2.0, 1.8, 1.5)
                   : 0.3 * glm::dvec3(std::sin(1.7 * i), std::sin(1.7 * i + 1.0), std::cos(0.9 * i));
    return sky;
}

// The largest difference between sum_i T_i L_i and the direct radiance, over the mean |radiance|.
double relitAgainstDirect(const VertexTransfer& transfer, const ShCoefficients& light,
                          const std::vector<glm::vec3>& direct) {
    const size_t count = size_t(coefficientCount(transfer.order));
    double worst = 0.0, mean = 0.0;
    for (size_t v = 0; v < direct.size(); ++v) {
        glm::dvec3 relit(0.0);
        for (size_t i = 0; i < count; ++i)
            relit += glm::dvec3(transfer.coefficients[v * count + i]) * light.rgb[i];
        const glm::dvec3 d = glm::abs(relit - glm::dvec3(direct[v]));
        worst = std::max({worst, d.r, d.g, d.b});
        mean += (std::abs(direct[v].r) + std::abs(direct[v].g) + std::abs(direct[v].b)) / 3.0;
    }
    return worst / (mean / double(direct.size()));
}

// Relighting is baking: under a sky band-limited to the transfer's order, sum_i T_i L_i is the
// radiance the same rays gather with the sky in place of the basis (computeVertexRadiance), as
// transfer is linear in the sky. And turning the light turns the sky: T . rotate(L, R) is the
// radiance under the sky f(R^T w) (sh/rotation.h's convention), evaluated as the unturned sky's
// function, not through the rotated coefficients. On the open Cornell box with its blocks,
// interreflected with 2 bounces, orders 3 and 5: both estimates add the same terms, the transfer's
// in float per coefficient, so they differ by float rounding (measured: at most 3.1e-7 of the mean
// radiance); the bound is 1e-4 of the mean.
TEST(Transfer, RelightingEqualsBakingUnderABandLimitedSky) {
    const World& world = testing::openCornellBoxWithBlocks();
    const glm::dmat3 turn =
        glm::dmat3(glm::mat3_cast(glm::angleAxis(1.1f, glm::normalize(glm::vec3(0.3f, 1.0f, -0.4f)))));
    for (int order : {3, 5}) {
        const TransferOptions options{
            .model = TransferModel::Interreflected, .order = order, .rays = 64, .bounces = 2};
        const VertexTransfer transfer = computeTransfer(world, options);
        const ShCoefficients sky = smoothSkyOfOrder(order);
        const double still = relitAgainstDirect(
            transfer, sky,
            computeVertexRadiance(world, options, [&](const glm::dvec3& w) { return evaluate(sky, w); }));
        const ShCoefficients turned = rotate(makeShRotation(turn, order), sky);
        const double rotated = relitAgainstDirect(
            transfer, turned, computeVertexRadiance(world, options, [&](const glm::dvec3& w) {
                return evaluate(sky, glm::transpose(turn) * w);
            }));
        EXPECT_LE(still, 1e-4) << "order " << order;
        EXPECT_LE(rotated, 1e-4) << "order " << order;
        std::printf("relit against direct, order %d: %.3g of the mean, turned %.3g\n", order, still, rotated);
    }
}

// The same bits for the same inputs, and a coloured albedo gives coloured transfer.
TEST(Transfer, DeterministicAndColoured) {
    FixtureMesh box, plane;
    testing::addBox(box, glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.5f), false);
    addFannedSquare(plane, 2.0f);
    box.material = 1;
    const World world =
        testing::loadFixtureWorld(sceneOf({plane, box}, {{glm::vec3(0.5f)}, {{0.8f, 0.2f, 0.1f}}}));
    const TransferOptions options{
        .model = TransferModel::Interreflected, .order = 3, .rays = 64, .bounces = 1};
    const VertexTransfer a = computeTransfer(world, options), b = computeTransfer(world, options);
    ASSERT_EQ(a.coefficients.size(), b.coefficients.size());
    EXPECT_EQ(
        std::memcmp(a.coefficients.data(), b.coefficients.data(), a.coefficients.size() * sizeof(glm::vec3)),
        0);
    EXPECT_TRUE(a.coloured());
    EXPECT_EQ(transferChannels(a), 3);
}

// Another occlusion test on the same rays (what shprobe-reference --transfer-rate times the GPU's
// hierarchy with): answered by scene/bvh.h's hierarchy it is computeTransfer (Embree) bit for bit
// here, a box and a plane where no ray grazes an edge (docs/scene-probes.md, "On the CPU"); a test that
// blocks every ray leaves nothing; one that blocks none gives the plane's vertices what the unshadowed model
// gives a plane under nothing (the same closed form as above, to the rays' noise: 64 rays, 3e-2); and only
// the shadowed model takes one.
TEST(Transfer, AnotherOcclusionTestAnswersTheSameRays) {
    FixtureMesh box, plane;
    testing::addBox(box, glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.5f), false);
    addFannedSquare(plane, 2.0f);
    const World world = testing::loadFixtureWorld(sceneOf({plane, box}, {{glm::vec3(0.5f)}}));
    const TransferOptions options{.model = TransferModel::Shadowed, .order = 3, .rays = 64};
    const Bvh bvh = buildBvh(world);
    const VertexTransfer own =
        computeShadowedTransfer(world, options, [&](const glm::vec3& o, const glm::vec3& d) {
            return anyHit(bvh, {o, d});
        });
    const VertexTransfer reference = computeTransfer(world, options);
    ASSERT_EQ(own.coefficients.size(), reference.coefficients.size());
    EXPECT_EQ(std::memcmp(own.coefficients.data(), reference.coefficients.data(),
                          own.coefficients.size() * sizeof(glm::vec3)),
              0);
    const VertexTransfer dark =
        computeShadowedTransfer(world, options, [](const glm::vec3&, const glm::vec3&) { return true; });
    for (const glm::vec3& value : dark.coefficients)
        ASSERT_EQ(value, glm::vec3(0.0f));
    const VertexTransfer open =
        computeShadowedTransfer(world, options, [](const glm::vec3&, const glm::vec3&) { return false; });
    const VertexTransfer unshadowed =
        computeTransfer(world, {.model = TransferModel::Unshadowed, .order = 3});
    double worst = 0.0;
    for (size_t i = 0; i < open.coefficients.size(); ++i)
        worst = std::max(worst, double(std::abs(open.coefficients[i].g - unshadowed.coefficients[i].g)));
    EXPECT_LT(worst, 3e-2);
    EXPECT_GT(worst, 0.0); // noise: the rays are random, the closed form is not
    EXPECT_THROW(computeShadowedTransfer(world, {.model = TransferModel::Interreflected, .order = 3},
                                         [](const glm::vec3&, const glm::vec3&) { return false; }),
                 Error);
}

// ---- The program ---------------------------------------------------------------------------------

class TransferProgram : public ::testing::Test {
  protected:
    void SetUp() override {
        folder_ = fs::temp_directory_path() /
                  ("shprobe-transfer-" +
                   std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
        fs::remove_all(folder_);
        fs::create_directories(folder_);
        // Two nodes draw one mesh (a square under a box), the second turned: each gets its own copy.
        FixtureMesh ground, block;
        addFannedSquare(ground, 2.0f);
        testing::addBox(block, glm::vec3(0.0f, 0.6f, 0.0f), glm::vec3(0.5f), false);
        block.material = 1;
        FixtureScene scene = sceneOf({ground, block}, {{glm::vec3(0.6f)}, {{0.7f, 0.3f, 0.2f}}});
        scene.nodes.push_back({.mesh = 1, .translation = {1.0f, 0.0f, 1.0f}});
        scene.roots.push_back(2);
        testing::writeGltf(path("scene.glb"), scene, testing::GltfContainer::Glb);
    }
    void TearDown() override { fs::remove_all(folder_); }

    std::string path(const std::string& name) const { return (folder_ / name).string(); }

    // Runs `shprobe ARGS`; its exit code, stdout and stderr in out_ and err_.
    int run(const std::string& args) {
        const std::string command =
            std::string(SHPROBE_EXECUTABLE) + " " + args + " > " + path("out.txt") + " 2> " + path("err.txt");
        const int status = std::system(command.c_str());
        out_ = read(path("out.txt"));
        err_ = read(path("err.txt"));
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    static std::string read(const std::string& file) {
        std::ifstream in(file, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), {}};
    }

    fs::path folder_;
    std::string out_, err_;
};

// Each refusal is one line "shprobe: error: ..." (or CLI11's for an option out of range), a non-zero
// exit, and no output file; among them the options of rays given to the unshadowed model, which
// casts none (they were ignored, --device 7 too).
TEST_F(TransferProgram, BadInputsAreRefusedWithOneLine) {
    const std::string scene = path("scene.glb"), output = path("bad.glb");
    for (const std::string& args :
         {"transfer " + path("missing.glb") + " -o " + output,
          "transfer " + scene + " --order 9 -o " + output, "transfer " + scene + " --order 0 -o " + output,
          "transfer " + scene + " --model glossy -o " + output,
          "transfer " + scene + " --rays 0 -o " + output, "transfer " + scene + " --bounces 2 -o " + output,
          "transfer " + scene + " --model unshadowed --rays 64 -o " + output,
          "transfer " + scene + " --model unshadowed --backend gpu -o " + output,
          "transfer " + scene + " --model unshadowed --device 0 -o " + output,
          "transfer " + scene + " -o " + scene}) {
        const std::string before = read(scene);
        EXPECT_NE(run(args), 0) << args;
        EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << args << ": " << err_;
        EXPECT_FALSE(fs::exists(output)) << args;
        EXPECT_EQ(read(scene), before) << args;
    }
}

// What -o names is what is written: a .glb name with --format binary, a .shpt name with --format
// glb, a .gltf name (readers expect JSON there; transfer writes binary glTF) and a name of another
// kind (a .png would have held a .glb) are refused in one line that says so, nothing written.
TEST_F(TransferProgram, OutputNamesAgreeWithTheFormat) {
    const std::string scene = path("scene.glb");
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"--format binary -o " + path("t.glb"), "names a file of --format glb, but --format is binary"},
        {"--format glb -o " + path("t.shpt"), "names a file of --format binary, but --format is glb"},
        {"-o " + path("t.gltf"), "names a JSON glTF file"},
        {"-o " + path("t.png"), "names neither a .glb nor a .shpt file"},
    };
    for (const auto& [args, says] : cases) {
        EXPECT_EQ(run("transfer " + scene + " --model unshadowed " + args), 2) << args;
        EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << args << ": " << err_;
        EXPECT_NE(err_.find(says), std::string::npos) << args << ": " << err_;
    }
    for (const char* name : {"t.glb", "t.shpt", "t.gltf", "t.png"})
        EXPECT_FALSE(fs::exists(path(name))) << name;
}

// The floats of attribute `name` of a primitive, read by the specification (tightly packed VEC4).
std::vector<float> attributeFloats(const Glb& glb, const nlohmann::json& primitive, const std::string& name) {
    const nlohmann::json& accessor = glb.json["accessors"][primitive["attributes"][name].get<size_t>()];
    const nlohmann::json& view = glb.json["bufferViews"][accessor["bufferView"].get<size_t>()];
    EXPECT_EQ(accessor["type"], "VEC4");
    EXPECT_EQ(accessor["componentType"], 5126);
    std::vector<float> values(accessor["count"].get<size_t>() * 4);
    std::memcpy(values.data(), glb.bin.data() + view.value("byteOffset", 0) + accessor.value("byteOffset", 0),
                values.size() * sizeof(float));
    return values;
}

// What the program writes is what computeTransfer gives for the scene, placed primitive by placed
// primitive, bit for bit; the same in the binary file; the same bytes from a second run.
// A transfer draws a progress line on a terminal ("vertex passes 12/40, ... s left"), erased at the
// end; nothing with -q, and the file is the same either way.
TEST_F(TransferProgram, ProgressLineOnlyOnATerminal) {
    const std::vector<std::string> transfer = {
        "transfer", path("scene.glb"), "--model", "interreflected", "--bounces", "1", "--rays", "64"};
    auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = transfer;
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    const testing::TerminalRun shown =
        testing::runOnTerminal(with({"-o", path("shown.glb")}), path("shown.out"));
    ASSERT_EQ(shown.exitCode, 0) << shown.terminal;
    EXPECT_NE(shown.terminal.find("\rvertex passes "), std::string::npos) << shown.terminal;
    EXPECT_TRUE(shown.terminal.ends_with("\r\033[K")) << "the line is erased at the end: " << shown.terminal;
    const testing::TerminalRun quiet =
        testing::runOnTerminal(with({"-q", "-o", path("quiet.glb")}), path("quiet.out"));
    EXPECT_EQ(quiet.exitCode, 0) << quiet.terminal;
    EXPECT_EQ(quiet.terminal, "");
    EXPECT_EQ(read(path("shown.glb")), read(path("quiet.glb")));
}

TEST_F(TransferProgram, AttributesAndBinaryFileRoundTrip) {
    ASSERT_EQ(run("transfer " + path("scene.glb") + " --model interreflected --bounces 1 --rays 64 -o " +
                  path("out.glb")),
              0)
        << err_;
    ASSERT_EQ(run("transfer " + path("scene.glb") + " --model interreflected --bounces 1 --rays 64 -o " +
                  path("again.glb")),
              0);
    ASSERT_EQ(run("transfer " + path("scene.glb") + " --model interreflected --bounces 1 --rays 64 -o " +
                  path("out.shpt")),
              0);
    const std::string bytes = read(path("out.glb"));
    EXPECT_EQ(bytes, read(path("again.glb")));

    const GltfSceneSource source = loadGltfSceneSource(path("scene.glb"));
    const VertexTransfer transfer = computeTransfer(
        source.world, {.model = TransferModel::Interreflected, .order = 3, .rays = 64, .bounces = 1});
    const std::vector<PrimitiveTransfer> expected = primitiveTransfers(source, transfer);
    const int channels = transferChannels(transfer);
    ASSERT_EQ(channels, 3);
    const size_t floats = size_t(9 * channels);

    const Glb glb = readGlb(bytes);
    const nlohmann::json& extras = glb.json["asset"]["extras"]["shTransfer"];
    EXPECT_EQ(extras["order"], 3);
    EXPECT_EQ(extras["model"], "interreflected");
    EXPECT_EQ(extras["channels"], 3);
    EXPECT_EQ(extras["attributes"].size(), size_t(transferAttributeCount(3, 3)));
    EXPECT_EQ(glb.json["meshes"].size(), 3u); // the block's mesh copied for its second node
    std::set<int> meshes;
    for (const PrimitiveTransfer& p : expected) {
        const int mesh = glb.json["nodes"][size_t(p.node)]["mesh"];
        EXPECT_TRUE(meshes.insert(mesh).second) << "node " << p.node << " shares mesh " << mesh;
        const nlohmann::json& primitive = glb.json["meshes"][size_t(mesh)]["primitives"][size_t(p.primitive)];
        std::vector<std::vector<float>> columns;
        for (int a = 0; a < transferAttributeCount(3, channels); ++a)
            columns.push_back(
                attributeFloats(glb, primitive, std::string(kTransferAttributePrefix) + std::to_string(a)));
        for (size_t v = 0; v < p.vertexCount; ++v)
            for (size_t f = 0; f < floats; ++f)
                ASSERT_EQ(columns[f / 4][v * 4 + f % 4], p.values[v * floats + f])
                    << "vertex " << v << ", float " << f;
    }

    const std::string binary = read(path("out.shpt"));
    ASSERT_GE(binary.size(), 32u);
    EXPECT_EQ(binary.substr(0, 4), "SHPT");
    uint32_t header[8];
    std::memcpy(header, binary.data(), 32);
    EXPECT_EQ(header[1], 1u);
    EXPECT_EQ(header[2], 3u);
    EXPECT_EQ(header[3], 3u);
    EXPECT_EQ(header[4], 2u);
    EXPECT_EQ(header[5], 1u);
    EXPECT_EQ(header[6], 64u);
    ASSERT_EQ(header[7], expected.size());
    size_t at = 32 + 16 * expected.size();
    for (const PrimitiveTransfer& p : expected) {
        ASSERT_LE(at + p.values.size() * 4, binary.size());
        EXPECT_EQ(std::memcmp(binary.data() + at, p.values.data(), p.values.size() * 4), 0);
        at += p.values.size() * 4;
    }
    EXPECT_EQ(at, binary.size());
}

// Transfer run on its own output replaces the earlier transfer, attributes, accessors, views and
// bytes: the file is byte for byte the one baked from the scene, where the old bytes stayed in it
// (9.6 MB a run on a large scene) and the validator called their accessors unused. Baked first at
// order 5 (more attributes than order 3's) so that none of the earlier one could be kept in place.
TEST_F(TransferProgram, TransferOfItsOwnOutputReplacesTheEarlierOne) {
    const std::string rays = " --model interreflected --bounces 1 --rays 64 -o ";
    ASSERT_EQ(run("transfer " + path("scene.glb") + rays + path("out.glb")), 0) << err_;
    ASSERT_EQ(run("transfer " + path("scene.glb") + " --order 5" + rays + path("order5.glb")), 0) << err_;
    ASSERT_EQ(run("transfer " + path("order5.glb") + rays + path("again.glb")), 0) << err_;
    ASSERT_EQ(run("transfer " + path("again.glb") + rays + path("thrice.glb")), 0) << err_;
    const std::string bytes = read(path("out.glb"));
    EXPECT_EQ(read(path("again.glb")).size(), bytes.size());
    EXPECT_EQ(read(path("again.glb")), bytes);
    EXPECT_EQ(read(path("thrice.glb")), bytes);

    // A view of the earlier transfer that something else names (here an extension, as another tool
    // might add) is kept, and what names it still finds it: the old transfer stays, unused.
    Glb edited = readGlb(bytes);
    const size_t views = edited.json["bufferViews"].size();
    edited.json["extensions"]["VENDOR_view"] = {{"bufferView", views - 1}};
    edited.json["extensionsUsed"] = {"VENDOR_view"};
    std::ofstream(path("named.glb"), std::ios::binary) << glbOf(edited);
    ASSERT_EQ(run("transfer " + path("named.glb") + rays + path("renamed.glb")), 0) << err_;
    const Glb renamed = readGlb(read(path("renamed.glb")));
    EXPECT_EQ(renamed.json["extensions"]["VENDOR_view"]["bufferView"], views - 1);
    EXPECT_GT(renamed.json["bufferViews"].size(), views);
    EXPECT_EQ(renamed.json["bufferViews"][views - 1], edited.json["bufferViews"][views - 1]);
}

// A primitive without normals gets a World vertex per triangle corner, and each POSITION element
// the mean of its copies. A zero-area triangle (no normal, met by no ray) has no transfer, so its
// copies count for nothing: on an open plane every element keeps rho Y_00 exactly (each ray sees
// the sky, so the L_00 sum is g^2 Y_00 whatever the directions), for both models, in the values
// both files are written from (primitiveTransfers; AttributesAndBinaryFileRoundTrip checks that they
// are written as they are).
TEST_F(TransferProgram, ZeroAreaTrianglesLeaveTheirCornersAlone) {
    FixtureMesh plane;
    addFannedSquare(plane, 1.0f);
    plane.normals.clear();
    plane.indices.insert(plane.indices.end(), {0, 1, 1});
    const float rho = 0.5f;
    testing::writeGltf(path("flat.glb"), sceneOf({plane}, {{glm::vec3(rho)}}), testing::GltfContainer::Glb);
    const GltfSceneSource source = loadGltfSceneSource(path("flat.glb"));
    for (TransferModel model : {TransferModel::Unshadowed, TransferModel::Shadowed}) {
        const VertexTransfer transfer =
            computeTransfer(source.world, {.model = model, .order = 3, .rays = 16});
        const std::vector<PrimitiveTransfer> primitives = primitiveTransfers(source, transfer);
        ASSERT_EQ(primitives.size(), 1u);
        ASSERT_EQ(primitives[0].vertexCount, 5u);
        for (uint32_t v = 0; v < 5; ++v) // grey: one channel, coefficient 0 first
            EXPECT_NEAR(primitives[0].values[v * 9], rho * 0.282094792, 1e-6)
                << transferModelName(model) << ", element " << v;
    }
}

// The scene's extras and extensions are written as its JSON has them: integers past 32 bits,
// empty objects and arrays, and nulls (tinygltf's own values wrap the first and drop the others),
// on the scene, a node, a material's extension and a mesh that two nodes draw (and its copy).
// An asset.extras that is not an object cannot take the transfer's description: refused in one
// line, before any ray, nothing written.
TEST_F(TransferProgram, ExtrasAndExtensionsAreKeptAsWritten) {
    FixtureMesh ground;
    addFannedSquare(ground, 2.0f);
    FixtureScene scene = sceneOf({ground}, {{glm::vec3(0.6f)}});
    scene.nodes.push_back({.mesh = 0, .translation = {5.0f, 0.0f, 0.0f}});
    scene.roots.push_back(1);
    nlohmann::json document = nlohmann::json::parse(testing::gltfText(scene));
    const nlohmann::json extras = {{"id", 3000000000u},
                                   {"ms", 1700000000123u},
                                   {"big", 9007199254740993u},
                                   {"empty", nlohmann::json::object()},
                                   {"none", nullptr},
                                   {"list", {nullptr, nlohmann::json::object(), nlohmann::json::array(), 1}}};
    document["extras"] = extras;
    document["nodes"][0]["extras"] = extras;
    document["meshes"][0]["extras"] = extras;
    document["materials"][0]["extensions"] = {{"VENDOR_thing", {{"id", 4294967296u}}}};
    document["asset"]["extras"] = {{"author", extras}};
    testing::writeText(path("extras.gltf"), document.dump());
    ASSERT_EQ(run("transfer " + path("extras.gltf") + " --model unshadowed -o " + path("out.glb")), 0)
        << err_;
    const Glb glb = readGlb(read(path("out.glb")));
    EXPECT_EQ(glb.json["extras"], extras);
    EXPECT_EQ(glb.json["nodes"][0]["extras"], extras);
    ASSERT_EQ(glb.json["meshes"].size(), 2u); // the second node's copy
    EXPECT_EQ(glb.json["meshes"][0]["extras"], extras);
    EXPECT_EQ(glb.json["meshes"][1]["extras"], extras);
    EXPECT_EQ(glb.json["materials"][0]["extensions"]["VENDOR_thing"]["id"], 4294967296u);
    EXPECT_EQ(glb.json["asset"]["extras"]["author"], extras);
    EXPECT_EQ(glb.json["asset"]["extras"]["shTransfer"]["model"], "unshadowed");

    // tinygltf takes [] for no extras: the JSON tells.
    for (const nlohmann::json& note : {nlohmann::json("a note"), nlohmann::json::array()}) {
        document["asset"]["extras"] = note;
        testing::writeText(path("note.gltf"), document.dump());
        EXPECT_EQ(run("transfer " + path("note.gltf") + " -o " + path("note.glb")), 2) << note;
        EXPECT_EQ(std::count(err_.begin(), err_.end(), '\n'), 1) << err_;
        EXPECT_NE(err_.find("asset.extras is not an object"), std::string::npos) << err_;
        EXPECT_FALSE(fs::exists(path("note.glb")));
    }
}

// The Khronos glTF validator (npm's gltf-validator, installed by scripts/test.sh) finds no error in
// the .glb: the attributes' names, accessors, buffer views and the joined buffer are valid glTF 2.0.
TEST_F(TransferProgram, ValidatorFindsNoError) {
    const char* override = std::getenv("SHPROBE_NODE_MODULES");
    const std::string modules = override ? override : SHPROBE_NODE_MODULES;
    if (std::system("node --version > /dev/null 2>&1") != 0 ||
        !fs::exists(fs::path(modules) / "gltf-validator"))
        GTEST_SKIP() << "validator check skipped: node or " << modules << "/gltf-validator missing";
    ASSERT_EQ(run("transfer " + path("scene.glb") + " --rays 16 -o " + path("out.glb")), 0) << err_;
    ASSERT_EQ(run("transfer " + std::string(SHPROBE_GLTF_MODELS_DIR) +
                  "/BoxTextured-glTF/BoxTextured.gltf --rays 16 -o " + path("textured.glb")),
              0)
        << err_;
    for (const std::string& file : {path("out.glb"), path("textured.glb")}) {
        const std::string command = "SHPROBE_NODE_MODULES=" + modules + " node " + SHPROBE_ENGINE_SCRIPTS +
                                    "/gltf_validate.mjs " + file + " > " + path("report.json");
        ASSERT_EQ(std::system(command.c_str()), 0) << file;
        const nlohmann::json report = nlohmann::json::parse(read(path("report.json")));
        EXPECT_EQ(report["numErrors"], 0) << report.dump();
        EXPECT_EQ(report["numWarnings"], 0) << report.dump();
    }
}

} // namespace
} // namespace shprobe
