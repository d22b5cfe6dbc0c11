// The paths' light samplers (scene/emitters.h): each sample's density is the one its sampler states,
// and their estimates of known integrals converge to them, so that next-event estimation weighted
// against the cosine rays is unbiased.
#include "scene/bvh.h"
#include "scene/emitters.h"
#include "scene/ray_caster.h"
#include "scene/sampling.h"
#include "scene/surface_shading.h"
#include "scene_fixtures.h"
#include "sh/cubemap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <vector>

namespace shprobe {
namespace {

constexpr int kSamples = 1000000;

// A sky of faces 8 whose texels' radiance spans three decades, a quarter of them black.
Cubemap unevenSky() {
    Cubemap sky = makeCubemap(8);
    RandomStream random(7, 0, 0);
    for (glm::vec4& texel : sky.texels) {
        const double u = random.next();
        texel =
            u < 0.25 ? glm::vec4(0.0f) : glm::vec4(glm::vec3(float(std::pow(1000.0, random.next()))), 0.0f);
    }
    return sky;
}

// A Monte-Carlo mean and its standard error.
struct Estimate {
    double sum = 0.0, squares = 0.0;
    int count = 0;
    void add(double x) {
        sum += x;
        squares += x * x;
        ++count;
    }
    double mean() const { return sum / count; }
    double standardError() const { return std::sqrt((squares / count - mean() * mean()) / (count - 1)); }
};

// Over the sky's lit texels, the mean of 1 / p is their solid angle and the mean of L / p their
// integral, sum L_t Omega_t: each estimate within four of its standard errors (from 10^6
// samples) of the exact sum, and those errors below 1% of it, so that a density off by 1% shows. A
// direction's density read back from the direction equals the one it was drawn with (to rounding:
// 1e-9). A sky with no texel of 4 times the mean texel's power is not sampled.
TEST(Emitters, SkyDirectionsHaveTheDensityTheyState) {
    const Cubemap sky = unevenSky();
    const SkySampler sampler(sky);
    double litSolidAngle = 0.0, integral = 0.0;
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < sky.faceSize; ++j)
            for (int i = 0; i < sky.faceSize; ++i) {
                const double radiance = sky.at(face, i, j).r;
                if (radiance == 0.0) continue;
                litSolidAngle += texelSolidAngle(i, j, sky.faceSize);
                integral += radiance * texelSolidAngle(i, j, sky.faceSize);
            }
    const auto texel = [&](double c) {
        return std::min(int((c + 1.0) * 0.5 * sky.faceSize), sky.faceSize - 1);
    };
    RandomStream random(1, 2, 3);
    Estimate solidAngle, radiance;
    for (int k = 0; k < kSamples; ++k) {
        const double u0 = random.next(), u1 = random.next();
        const SkyDirection sample = sampler.sample(u0, u1, random.next());
        ASSERT_NEAR(sampler.density(sample.direction), sample.density, 1e-9 * sample.density);
        const FacePoint point = directionToFace(sample.direction);
        solidAngle.add(1.0 / sample.density);
        radiance.add(sky.at(point.face, texel(point.a), texel(point.b)).r / sample.density);
    }
    std::printf("solid angle %.5f +- %.5f (exact %.5f), integral %.3f +- %.3f (exact %.3f)\n",
                solidAngle.mean(), solidAngle.standardError(), litSolidAngle, radiance.mean(),
                radiance.standardError(), integral);
    EXPECT_NEAR(solidAngle.mean(), litSolidAngle, 4.0 * solidAngle.standardError());
    EXPECT_LT(solidAngle.standardError(), 0.01 * litSolidAngle);
    EXPECT_NEAR(radiance.mean(), integral, 4.0 * radiance.standardError());
    EXPECT_LT(radiance.standardError(), 0.01 * integral);
    EXPECT_TRUE(SkySampler(makeCubemap(4)).empty());
    Cubemap smooth = makeCubemap(8); // 1 to 3: no texel's power reaches 4 times the mean
    for (size_t t = 0; t < smooth.texels.size(); ++t)
        smooth.texels[t] = glm::vec4(glm::vec3(1.0f + 2.0f * float(t % 8) / 7.0f), 1.0f);
    EXPECT_TRUE(SkySampler(smooth).empty());
}

// The Cornell box's 0.5 m light (two triangles) and nothing else emits: every point lies on it, and
// the mean of 1 / p is its area, 0.25 m^2 (10^6 samples; the density is uniform over the light,
// so the estimate is exact to rounding: 1e-9).
TEST(Emitters, EmitterPointsCoverTheEmissiveArea) {
    const World world = testing::loadCornellBoxWorld();
    const EmitterSampler sampler(world);
    ASSERT_FALSE(sampler.empty());
    RandomStream random(4, 5, 6);
    double area = 0.0;
    for (int k = 0; k < kSamples; ++k) {
        const double u0 = random.next(), u1 = random.next();
        const EmitterPoint point = sampler.sample(u0, u1, random.next());
        const SceneMaterial& material = world.materials[world.triangleMaterials[point.triangle]];
        ASSERT_GT(material.emission.r, 0.0f);
        ASSERT_EQ(sampler.areaDensity(point.triangle), point.areaDensity);
        ASSERT_NEAR(point.position.y, 1.998, 1e-6); // the light hangs just under the ceiling
        area += 1.0 / point.areaDensity / kSamples;
    }
    EXPECT_NEAR(area, 0.25, 1e-9);
}

// Irradiance at `position` (normal n) from a Lambertian polygon of radiance 1 (Lambert's formula:
// (1/2) sum over its edges of the angle they subtend times n . the unit normal of their plane).
double polygonIrradiance(const glm::dvec3& position, const glm::dvec3& n,
                         const std::vector<glm::dvec3>& corners) {
    double sum = 0.0;
    for (size_t k = 0; k < corners.size(); ++k) {
        const glm::dvec3 a = glm::normalize(corners[k] - position),
                         b = glm::normalize(corners[(k + 1) % corners.size()] - position);
        sum +=
            std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)) * glm::dot(n, glm::normalize(glm::cross(a, b)));
    }
    return 0.5 * std::abs(sum);
}

// What SunlitPointsGiveTheLitPatchsIrradiance checks of the lit room in `world`.
void checkLitPatchIrradiance(const World& world, const char* what) {
    ASSERT_EQ(world.suns.size(), 1u);
    const SceneShading shading(world, makeCubemap(4));
    const Bvh bvh = buildBvh(world);
    const BvhRayCaster caster(bvh);
    const SunlitSampler sampler(shading, caster);
    ASSERT_FALSE(sampler.empty());
    const glm::dvec3 toSun(world.suns[0].direction);
    std::vector<glm::dvec3> patch;
    for (const glm::dvec2 corner : {glm::dvec2(-1.25, -0.25), glm::dvec2(-0.75, -0.25),
                                    glm::dvec2(-0.75, 0.25), glm::dvec2(-1.25, 0.25)})
        patch.push_back(glm::dvec3(corner.x, 2.0, corner.y) - toSun * (2.0 / toSun.y));
    const glm::dvec3 normal(0.0, 0.0, 1.0), position(-1.5, 1.0, -1.0);
    const double radiance = 0.7 * std::numbers::inv_pi * double(world.suns[0].irradiance.g) * toSun.y;
    const double exact = radiance * polygonIrradiance(position, normal, patch);
    SurfaceHit at;
    at.position = position;
    at.normal = at.shadingNormal = normal;
    at.offset = kSurfaceOffsetScale * 1.5; // as far off as a triangle reaching 1.5 starts its rays
    at.rayOrigin = position + at.offset * normal;
    RandomStream random(8, 9, 10);
    Estimate estimate;
    uint64_t rays = 0;
    int readBack = 0;
    for (int k = 0; k < (1 << 20); ++k) {
        const double u0 = random.next(), u1 = random.next(), u2 = random.next();
        const SunlitLight light = sampler.reflectedTo(at, u0, u1, u2, rays);
        estimate.add(light.irradiance.g);
        if (k % 64 != 0) continue;
        const SunRay ray = sampler.sample(u0, u1, u2);
        const std::optional<RayHit> hit =
            caster.closestHit({glm::vec3(ray.origin), glm::vec3(ray.direction)});
        if (!hit) continue;
        const SurfaceHit met = shading.describe(hit->triangle, {hit->hit.u, hit->hit.v}, ray.direction);
        const double stated = ray.planeDensity * std::abs(glm::dot(met.normal, toSun));
        readBack += std::abs(sampler.areaDensity(ray.sun, met.position, met.normal) / stated - 1.0) < 1e-6;
    }
    std::printf("%s: irradiance %.6f (standard error %.6f) against %.6f; %d of %d densities read back\n",
                what, estimate.mean(), estimate.standardError(), exact, readBack, (1 << 20) / 64);
    EXPECT_NEAR(estimate.mean(), exact, 4.0 * estimate.standardError());
    EXPECT_LT(estimate.standardError(), 0.005 * exact);
    EXPECT_GE(readBack, (1 << 20) / 64 - 16);
}

// The lit room of the two rooms (scene_fixtures.h): its glTF sun shines through the ceiling's 0.5 m
// opening onto a 0.5 m square of the floor. That square, of radiance albedo / pi E n.l, lights a
// point on the back wall with the closed form of Lambert's polygon formula; the mean of what the
// sunlit points reflect there (2^20 samples, unweighted) is within four of its standard errors of
// it, and that error below 0.5% of it, so that a density off by 1% shows. Twice: one-sided, the roof
// shows the sun its back; double-sided, the sunlit roof's light goes to the sky alone and must not
// be sampled (12 m^2 of roof to the patch's 0.25: sampled, it would leave the patch 2% of the
// samples, and counted as lit, the sun would not be sampled at all). A drawn point's density read
// back from its position (sunShare's) is the one it was drawn with.
TEST(Emitters, SunlitPointsGiveTheLitPatchsIrradiance) {
    for (const bool doubleSided : {false, true}) {
        testing::FixtureScene rooms = testing::twoRoomsScene();
        rooms.materials[0].doubleSided = doubleSided;
        checkLitPatchIrradiance(testing::loadFixtureWorld(rooms), doubleSided ? "double-sided" : "one-sided");
    }
}

// The power heuristic's weights of one sample under two techniques sum to one.
TEST(Emitters, PowerHeuristicWeightsSumToOne) {
    for (const double a : {0.0, 0.1, 1.0, 7.5})
        for (const double b : {0.2, 1.0, 30.0})
            EXPECT_NEAR(powerHeuristic(a, b) + powerHeuristic(b, a), 1.0, 1e-15);
}

// A texel view's paths take every number below 6 N^2 s^2 exactly once where N is a power of two
// (firstTexelPath), so that each aligned block of Sobol' points is used whole; with N not a power
// of two the numbers stay distinct. Numbering each texel from a multiple of the power of two at
// least s^2 (the rule before) left 7 of every 16 points unused at 9 rays a texel, and its paths'
// bounces were noisier than at 4 rays (2CylinderEngine 8^3: 3.6% of L00 worst against 1.3%).
TEST(Emitters, TexelPathsTakeEveryNumberOnce) {
    for (const uint32_t n : {8u, 6u}) {
        for (const uint32_t perTexel : {1u, 4u, 9u, 16u}) {
            const uint32_t side = glsl::powerOfTwoAtLeast(n);
            std::vector<int> uses(size_t(6 * side * side * perTexel), 0);
            for (uint32_t face = 0; face < 6; ++face)
                for (uint32_t j = 0; j < n; ++j)
                    for (uint32_t i = 0; i < n; ++i)
                        for (uint32_t k = 0; k < perTexel; ++k)
                            ++uses.at(firstTexelPath(face, i, j, n, perTexel) + k);
            EXPECT_LE(*std::max_element(uses.begin(), uses.end()), 1) << n << " " << perTexel;
            const size_t used = size_t(std::count(uses.begin(), uses.end(), 1));
            EXPECT_EQ(used, size_t(6 * n * n * perTexel)) << n << " " << perTexel;
            if (n == side) {
                EXPECT_EQ(used, uses.size()) << perTexel;
            }
        }
    }
}

} // namespace
} // namespace shprobe
