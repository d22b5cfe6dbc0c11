// The ray-traced reference for scene probes (scene/reference_tracer.h) against closed forms: open sky,
// emissive and furnace boxes, sun light with shadows, textures, back faces, sky light bounced off a
// floor, and determinism. Scenes are built here from quads (two triangles each).
#include "test_support.h"

#include "scene/reference_tracer.h"
#include "sh/basis.h"
#include "sh/projection.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <vector>

namespace shprobe {
namespace {

constexpr double kPi = std::numbers::pi;
const double kY00 = 0.5 / std::sqrt(kPi); // y_00 = 1 / sqrt(4 pi)

// Sums of a few thousand double terms of order 1, where the result is exact in exact arithmetic
// (every sample sees the same radiance): rounding only.
constexpr double kRoundingError = 1e-12;
// A path-traced coefficient may be this many standard errors off its exact value. The estimate is the
// mean of 16 independent replicas, so (estimate - exact) / standard error follows Student's t with 15
// degrees of freedom: |t| > 5 has probability 1.6e-4 per coefficient and channel.
constexpr double kStandardErrors = 5.0;

// --- Scenes ------------------------------------------------------------------------------------

uint32_t addMaterial(World& world, const SceneMaterial& material) {
    world.materials.push_back(material);
    return uint32_t(world.materials.size() - 1);
}

// The parallelogram corner + s u + t v, s and t in [0, 1], at texture coordinates (s, t), facing
// cross(u, v) (counter-clockwise seen from there), flat-shaded.
void addQuad(World& world, glm::vec3 corner, glm::vec3 u, glm::vec3 v, uint32_t material) {
    const auto first = uint32_t(world.positions.size());
    const glm::vec3 normal = glm::normalize(glm::cross(u, v));
    const glm::vec3 corners[] = {corner, corner + u, corner + u + v, corner + v};
    const glm::vec2 uvs[] = {{0.0f, 0.0f}, {1.0f, 0.0f}, {1.0f, 1.0f}, {0.0f, 1.0f}};
    for (int k = 0; k < 4; ++k) {
        world.positions.push_back(corners[k]);
        world.normals.push_back(normal);
        world.uvs.push_back(uvs[k]);
    }
    for (uint32_t index : {0u, 1u, 2u, 0u, 2u, 3u})
        world.indices.push_back(first + index);
    world.triangleMaterials.insert(world.triangleMaterials.end(), 2, material);
}

enum class Facing { Outward, Inward };

// The box [lo, hi] as six quads (12 triangles) facing out of it or into it.
void addBox(World& world, glm::vec3 lo, glm::vec3 hi, uint32_t material, Facing facing) {
    for (int axis = 0; axis < 3; ++axis) {
        const int b = (axis + 1) % 3;
        const int c = (axis + 2) % 3;
        glm::vec3 edgeB(0.0f), edgeC(0.0f);
        edgeB[b] = hi[b] - lo[b];
        edgeC[c] = hi[c] - lo[c];
        for (bool high : {false, true}) {
            glm::vec3 corner = lo;
            corner[axis] = high ? hi[axis] : lo[axis];
            // cross(edgeB, edgeC) points along +axis: outward on the high side.
            const bool alongAxis = high == (facing == Facing::Outward);
            if (alongAxis)
                addQuad(world, corner, edgeB, edgeC, material);
            else
                addQuad(world, corner, edgeC, edgeB, material);
        }
    }
}

Cubemap skyOf(int n, const std::function<glm::dvec3(const glm::dvec3&)>& radiance) {
    Cubemap sky = makeCubemap(n);
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i)
                sky.at(face, i, j) = glm::vec4(radiance(texelDirection(face, i, j, n)), 0.0f);
        }
    }
    return sky;
}

Cubemap constantSky(glm::dvec3 radiance) {
    return skyOf(4, [radiance](const glm::dvec3&) { return radiance; });
}

// A smooth, coloured, everywhere positive sky.
glm::dvec3 gradientSky(const glm::dvec3& d) {
    return glm::dvec3(0.4, 0.7, 1.0) * (1.0 + 0.6 * d.y + 0.3 * d.x * d.z + 0.2 * d.x);
}

// Each texel of `sky` repeated over factor x factor texels: the same radiance function, which is
// constant over each original texel.
Cubemap upsampleNearest(const Cubemap& sky, int factor) {
    Cubemap fine = makeCubemap(sky.faceSize * factor);
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < fine.faceSize; ++j) {
            for (int i = 0; i < fine.faceSize; ++i)
                fine.at(face, i, j) = sky.at(face, i / factor, j / factor);
        }
    }
    return fine;
}

glm::dvec3 rgb(const glm::vec4& texel) {
    return glm::dvec3(glm::vec3(texel));
}

void expectNear(const glm::dvec3& actual, const glm::dvec3& expected, double tolerance, const char* what) {
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(actual[c], expected[c], tolerance) << what << ", channel " << c;
}

// Largest |estimate - exact| / standard error over all coefficients and channels, where the
// standard error is above rounding.
double worstStandardizedError(const PathTracedProbe& probe, const std::vector<glm::dvec3>& exact,
                              double scale) {
    double worst = 0.0;
    for (size_t i = 0; i < exact.size(); ++i) {
        for (int c = 0; c < 3; ++c) {
            const double difference = std::abs(probe.radiance.rgb[i][c] - exact[i][c]);
            const double allowed = probe.standardError[i][c] + kRoundingError * scale;
            worst = std::max(worst, difference / allowed);
        }
    }
    return worst;
}

// --- Open sky ----------------------------------------------------------------------------------

// Checks: with no triangles every ray sees the sky; at the sky's own face size each texel-centre ray
// falls in its own texel, so the traced cube map is the sky bit for bit; at twice the size each sky
// texel covers 2 x 2 traced texels (nearest lookup, no filtering). Exact: no arithmetic on radiance.
TEST(ReferenceTracerOpenSky, ZeroTrianglesSeeTheSkyTexelForTexel) {
    const Cubemap sky = skyOf(16, gradientSky);
    const ReferenceTracer tracer(World{}, sky);
    const glm::dvec3 probe(0.5, -2.0, 3.0);
    const ProbeTexels same = traceProbeTexels(tracer, probe, 16);
    EXPECT_EQ(same.backFaceTexels, 0u);
    for (size_t t = 0; t < sky.texels.size(); ++t)
        ASSERT_EQ(rgb(same.radiance.texels[t]), rgb(sky.texels[t])) << "texel " << t;
    const ProbeTexels twice = traceProbeTexels(tracer, probe, 32);
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < 32; ++j) {
            for (int i = 0; i < 32; ++i) {
                ASSERT_EQ(rgb(twice.radiance.at(face, i, j)), rgb(sky.at(face, i / 2, j / 2)))
                    << "face " << face << " texel " << i << ", " << j;
            }
        }
    }
}

// Checks: the path-traced probe of the open sky (bounce 0) converges to the exact projection of what
// it integrates, the nearest-texel sky, which is constant over each sky texel. Its exact projection is
// the reference projection of the sky repeated over 16 x 16 texels per texel (midpoint error of the
// basis over 1/256 of a face: measured 8e-7 of L_00 against 32 x 32, checked below a tenth of the
// estimate's standard error). The texel-centre projection of the 16-face sky itself differs from it
// by the basis's midpoint error over whole texels (measured 2.7e-4 of L_00, about one standard
// error): that is why it is not the reference here.
TEST(ReferenceTracerOpenSky, PathTracedSkyConvergesToItsExactProjection) {
    const Cubemap sky = skyOf(16, gradientSky);
    const ReferenceTracer tracer(World{}, sky);
    const PathTracedProbe probe = pathTraceProbe(tracer, glm::dvec3(0.0), {.order = 3, .bounces = 0});
    const ShCoefficients exact = projectCubemap(upsampleNearest(sky, 16), 3);
    const double scale = exact.rgb[0].z;
    const double worst = worstStandardizedError(probe, exact.rgb, scale);
    EXPECT_LE(worst, kStandardErrors);
    const double texelCentres = testing::maxDifference(projectCubemap(sky, 3), exact);
    const double finer = testing::maxDifference(projectCubemap(upsampleNearest(sky, 32), 3), exact);
    std::printf("open sky, 4096 samples: worst |error| = %.2f standard errors; standard error of L00 %.2e "
                "of L00; texel-centre projection off by %.2e, 16x vs 32x upsampling %.2e (of L00)\n",
                worst, probe.standardError[0].z / scale, texelCentres / scale, finer / scale);
    EXPECT_LE(finer, 0.1 * probe.standardError[0].z);
}

// Checks: a far emissive triangle (one facing the probe, circumradius 20 at distance 100) covers the
// texels of its direction: every texel whose ray lies within its inscribed cone (half-angle
// atan(10/100)) sees exactly its emission, every texel outside its circumscribed cone (atan(20/100))
// exactly the sky. A margin of 1e-4 radians keeps float rays off the cones' edges.
TEST(ReferenceTracerOpenSky, AFarTriangleCoversTheTexelsOfItsDirection) {
    World world;
    const glm::vec3 emission(3.0f, 2.0f, 1.0f);
    const uint32_t lamp = addMaterial(world, {.albedo = glm::vec3(0.0f), .emission = emission});
    for (double angle : {90.0, 210.0, 330.0}) { // counter-clockwise seen from +z, where the probe is
        const double radians = angle * kPi / 180.0;
        world.positions.emplace_back(20.0 * std::cos(radians), 20.0 * std::sin(radians), -100.0);
        world.normals.emplace_back(0.0f, 0.0f, 1.0f);
        world.uvs.emplace_back(0.0f);
    }
    world.indices = {0, 1, 2};
    world.triangleMaterials = {lamp};
    const Cubemap sky = skyOf(64, gradientSky);
    const ProbeTexels seen = traceProbeTexels(ReferenceTracer(world, sky), glm::dvec3(0.0), 64);
    const double inner = std::atan(0.1) - 1e-4;
    const double outer = std::atan(0.2) + 1e-4;
    int lit = 0;
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < 64; ++j) {
            for (int i = 0; i < 64; ++i) {
                const double angle = std::acos(-texelDirection(face, i, j, 64).z);
                const glm::dvec3 radiance = rgb(seen.radiance.at(face, i, j));
                if (angle < inner) {
                    EXPECT_EQ(radiance, glm::dvec3(emission)) << face << ": " << i << ", " << j;
                    ++lit;
                }
                if (angle > outer) {
                    EXPECT_EQ(radiance, rgb(sky.at(face, i, j))) << face << ": " << i << ", " << j;
                }
            }
        }
    }
    EXPECT_GE(lit, 20); // about pi (0.1 / (2/64))^2 = 32 texel centres lie in the inner cone
    EXPECT_EQ(seen.backFaceTexels, 0u);
}

// --- Closed boxes ------------------------------------------------------------------------------

const glm::vec3 kEmission(0.5f, 1.0f, 2.0f);
const glm::dvec3 kInsideBox(0.3, -0.2, 0.1); // off the centre, so that no symmetry helps

World emissiveBox(glm::vec3 albedo, Facing facing, bool doubleSided) {
    World world;
    const uint32_t wall =
        addMaterial(world, {.albedo = albedo, .emission = kEmission, .doubleSided = doubleSided});
    addBox(world, glm::vec3(-1.0f), glm::vec3(1.0f), wall, facing);
    return world;
}

// Checks: inside a closed box of emissive, black walls facing in, every texel sees the emission Le
// exactly, and the path-traced probe (any bounces: black walls end every path) is Le's constant,
// L_00 = Le sqrt(4 pi) (docs/conventions.md: L_00 = integral L y_00, y_00 = 1 / sqrt(4 pi)) to
// rounding, since every sample is Le; the other coefficients are the quadrature error of the
// Fibonacci sets for y_lm, zero within the standard errors (measured: 7.7e-5 of L_00; bound 1e-3).
TEST(ReferenceTracerBox, EmissiveWallsGiveTheirConstant) {
    const ReferenceTracer tracer(emissiveBox(glm::vec3(0.0f), Facing::Inward, false),
                                 constantSky({9.0, 9.0, 9.0}));
    const ProbeTexels seen = traceProbeTexels(tracer, kInsideBox, 16);
    EXPECT_EQ(seen.backFaceTexels, 0u);
    for (size_t t = 0; t < seen.radiance.texels.size(); ++t)
        ASSERT_EQ(rgb(seen.radiance.texels[t]), glm::dvec3(kEmission)) << "texel " << t;
    const PathTracedProbe probe = pathTraceProbe(tracer, kInsideBox, {.order = 3, .bounces = 2});
    std::vector<glm::dvec3> exact(9, glm::dvec3(0.0));
    exact[0] = glm::dvec3(kEmission) * std::sqrt(4.0 * kPi);
    expectNear(probe.radiance.rgb[0], exact[0], kRoundingError * exact[0].z, "L00");
    EXPECT_LE(worstStandardizedError(probe, exact, exact[0].z), kStandardErrors);
    double largest = 0.0;
    for (size_t i = 1; i < 9; ++i) {
        expectNear(probe.radiance.rgb[i], exact[i], 1e-3 * exact[0].z, "L_lm, l > 0");
        largest = std::max(largest, glm::length(probe.radiance.rgb[i]) / glm::length(exact[0]));
    }
    std::printf("emissive box: L00 off by %.1e relative, largest |L_lm| (l > 0) %.1e of |L00|\n",
                glm::length(probe.radiance.rgb[0] - exact[0]) / glm::length(exact[0]), largest);
}

// Checks (white furnace): in a closed box of uniform emission Le and albedo a, every path with K
// bounces carries Le (1 + a + ... + a^K) = Le (1 - a^(K+1)) / (1 - a): each hit adds throughput Le and
// multiplies the throughput by a, and no path escapes. So the estimate has no variance, and L_00 /
// sqrt(4 pi) is the series to rounding (1e-9 relative allows 200 bounces of rounding), for K = 0..5,
// and within 1e-9 of the limit Le / (1 - a) at K = 200 (a^201 <= 0.875^201 = 2e-12).
TEST(ReferenceTracerBox, FurnaceSumsTheGeometricSeries) {
    const glm::dvec3 albedo(0.5, 0.75, 0.875); // exact in float, as the World holds them
    const ReferenceTracer tracer(emissiveBox(glm::vec3(albedo), Facing::Inward, false),
                                 constantSky(glm::dvec3(0.0)));
    double worst = 0.0;
    for (int bounces : {0, 1, 2, 3, 4, 5, 200}) {
        const PathTracedProbe probe =
            pathTraceProbe(tracer, kInsideBox, {.order = 1, .bounces = bounces, .samples = 256});
        for (int c = 0; c < 3; ++c) {
            const double expected =
                kEmission[c] * (1.0 - std::pow(albedo[c], bounces + 1)) / (1.0 - albedo[c]);
            const double estimate = probe.radiance.rgb[0][c] / std::sqrt(4.0 * kPi);
            EXPECT_NEAR(estimate, expected, 1e-9 * expected) << bounces << " bounces, channel " << c;
            EXPECT_LE(probe.standardError[0][c], 1e-9 * probe.radiance.rgb[0][c]) << bounces << " bounces";
            if (bounces == 200) {
                EXPECT_NEAR(estimate, kEmission[c] / (1.0 - albedo[c]), 1e-9 * expected);
            }
            worst = std::max(worst, std::abs(estimate - expected) / expected);
        }
    }
    std::printf("furnace: worst relative error %.1e over 0..5 and 200 bounces\n", worst);
}

// Checks: inside a one-sided box facing out, every texel sees a back face (6 N^2 of them) and
// nothing, although its walls are emissive, white and sunlit; the path-traced probe is exactly 0.
// The same box double-sided shows its inner faces: the emission, exactly, since the sun's shadow rays
// from inside all meet the box.
TEST(ReferenceTracerBox, BackFacesOfOneSidedMaterialsLeaveNothing) {
    for (bool doubleSided : {false, true}) {
        World world = emissiveBox(glm::vec3(1.0f), Facing::Outward, doubleSided);
        world.suns.push_back({.direction = {0.0f, 1.0f, 0.0f}, .irradiance = glm::vec3(5.0f)});
        const ReferenceTracer tracer(world, constantSky({9.0, 9.0, 9.0}));
        const ProbeTexels seen = traceProbeTexels(tracer, kInsideBox, 8);
        EXPECT_EQ(seen.backFaceTexels, doubleSided ? 0u : 6u * 8u * 8u);
        const glm::dvec3 expected = doubleSided ? glm::dvec3(kEmission) : glm::dvec3(0.0);
        for (size_t t = 0; t < seen.radiance.texels.size(); ++t)
            ASSERT_EQ(rgb(seen.radiance.texels[t]), expected)
                << "double-sided " << doubleSided << ", texel " << t;
        if (doubleSided) continue;
        const PathTracedProbe probe =
            pathTraceProbe(tracer, kInsideBox, {.order = 3, .bounces = 2, .samples = 256});
        for (size_t i = 0; i < probe.radiance.rgb.size(); ++i) {
            EXPECT_EQ(probe.radiance.rgb[i], glm::dvec3(0.0)) << "coefficient " << i;
            EXPECT_EQ(probe.standardError[i], glm::dvec3(0.0)) << "coefficient " << i;
        }
    }
}

// --- Suns, normals and textures ----------------------------------------------------------------

const glm::vec3 kFloorAlbedo(0.5f, 0.6f, 0.7f);
const glm::vec3 kSunIrradiance(2.0f, 3.0f, 4.0f);

// A floor [-10, 10]^2 at y = 0 facing up, a black square [-1, 1]^2 at y = 2 above it, a sun from
// normalize(0.3, 1, 0.2) and one from straight below (under every surface it could light).
World sunlitFloor() {
    World world;
    const uint32_t floor = addMaterial(world, {.albedo = kFloorAlbedo});
    const uint32_t black = addMaterial(world, {.albedo = glm::vec3(0.0f)});
    addQuad(world, {-10.0f, 0.0f, 10.0f}, {20.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -20.0f}, floor);
    addQuad(world, {-1.0f, 2.0f, 1.0f}, {2.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -2.0f}, black);
    world.suns.push_back(
        {.direction = glm::normalize(glm::vec3(0.3f, 1.0f, 0.2f)), .irradiance = kSunIrradiance});
    world.suns.push_back({.direction = {0.0f, -1.0f, 0.0f}, .irradiance = glm::vec3(100.0f)});
    return world;
}

// Checks, one ray each against the transport worked by hand (relative 1e-12: the same float inputs,
// shaded in double): a floor point in the occluder's shadow (the occluder's centre cast along the
// sun) sees 0; a lit point albedo / pi E_sun cos(theta) with cos(theta) = l.y, the sun below adding
// nothing; a ray up sees the sky; a ray to the occluder's underside sees its back face (one-sided)
// and nothing.
TEST(ReferenceTracerSun, ShadowedAndLitFloorPointsMatchHandValues) {
    const glm::dvec3 skyValue(0.1, 0.2, 0.3);
    const ReferenceTracer tracer(sunlitFloor(), constantSky(skyValue));
    const glm::dvec3 probe(4.0, 1.0, 4.0);
    const glm::dvec3 toSun(tracer.suns()[0].direction);
    const auto towards = [&](glm::dvec3 point) {
        return directRadiance(tracer, probe, glm::normalize(point - probe));
    };
    const glm::dvec3 shadowed = glm::dvec3(0.0, 2.0, 0.0) - 2.0 / toSun.y * toSun;
    const RayRadiance inShadow = towards(shadowed);
    EXPECT_EQ(inShadow.radiance, glm::dvec3(0.0));
    EXPECT_FALSE(inShadow.backFace);
    const glm::dvec3 lit = glm::dvec3(kFloorAlbedo) / kPi * glm::dvec3(kSunIrradiance) * toSun.y;
    expectNear(towards({5.0, 0.0, -3.0}).radiance, lit, 1e-12 * lit.z, "lit floor");
    EXPECT_EQ(directRadiance(tracer, probe, {0.0, 1.0, 0.0}).radiance,
              rgb(glm::vec4(glm::vec3(skyValue), 0.0f)));
    const RayRadiance underside = towards({0.0, 2.0, 0.0});
    EXPECT_TRUE(underside.backFace);
    EXPECT_EQ(underside.radiance, glm::dvec3(0.0));
}

// Checks: the sun term uses the interpolated vertex normal, not the geometric one: a floor whose
// vertex normals all lean to n' = normalize(0.2, 1, 0) is lit by albedo / pi E_sun n'.l (relative
// 1e-12, as above); with the geometric normal it would be l.y, 3% away.
TEST(ReferenceTracerSun, ShadingUsesTheInterpolatedVertexNormal) {
    World world = sunlitFloor();
    const glm::vec3 leaning = glm::normalize(glm::vec3(0.2f, 1.0f, 0.0f));
    std::fill(world.normals.begin(), world.normals.end(), leaning);
    const ReferenceTracer tracer(world, constantSky(glm::dvec3(0.0)));
    const glm::dvec3 probe(4.0, 1.0, 4.0);
    const glm::dvec3 toSun(tracer.suns()[0].direction);
    const glm::dvec3 expected = glm::dvec3(kFloorAlbedo) / kPi * glm::dvec3(kSunIrradiance) *
                                glm::dot(glm::normalize(glm::dvec3(leaning)), toSun);
    const glm::dvec3 seen =
        directRadiance(tracer, probe, glm::normalize(glm::dvec3(5.0, 0.0, -3.0) - probe)).radiance;
    expectNear(seen, expected, 1e-12 * expected.z, "leaning normals");
}

// A 2 x 2 texture, rows top to bottom: red, green / blue, white.
SceneTexture quadrantTexture() {
    return {2, 2, {{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {1, 1, 1, 1}}};
}

// Checks: textures are sampled bilinearly with repeat at TEXCOORD_0, texel centres at (i + 0.5) / w,
// v = 0 at the top row (glTF). A quad facing the probe, uv = (s, t) at its point (-1 + 2s, -1 + 2t, -1),
// emission factor 2 times the texture; worked by hand: (0.25, 0.25) is the red centre; (0.5, 0.25)
// halfway red to green; (0.375, 0.5) the mean of the rows (0.75 red + 0.25 green, 0.75 blue + 0.25
// white); (0.05, 0.75) wraps left onto white (weight 0.4) and blue; (0.25, 0.1) wraps up onto the
// bottom row (weight 0.3). Then the albedo texture, lit head-on by a sun of irradiance pi. Tolerance:
// Embree's float barycentrics move uv by about 1e-7, the texture's gradient is at most 2 per texel.
TEST(ReferenceTracerTexture, SampledBilinearlyWithRepeatFromTheTopRow) {
    World world;
    world.textures.push_back(quadrantTexture());
    const uint32_t glowing =
        addMaterial(world, {.albedo = glm::vec3(0.0f), .emission = glm::vec3(2.0f), .emissionTexture = 0});
    addQuad(world, {-1.0f, -1.0f, -1.0f}, {2.0f, 0.0f, 0.0f}, {0.0f, 2.0f, 0.0f}, glowing);
    const ReferenceTracer tracer(world, constantSky(glm::dvec3(0.0)));
    const auto at = [&](double s, double t) {
        return directRadiance(tracer, glm::dvec3(0.0),
                              glm::normalize(glm::dvec3(-1.0 + 2.0 * s, -1.0 + 2.0 * t, -1.0)))
            .radiance;
    };
    constexpr double kUvError = 1e-5;
    expectNear(at(0.25, 0.25), {2.0, 0.0, 0.0}, kUvError, "red centre");
    expectNear(at(0.5, 0.25), {1.0, 1.0, 0.0}, kUvError, "red to green");
    expectNear(at(0.375, 0.5), {1.0, 0.5, 1.0}, kUvError, "four texels");
    expectNear(at(0.05, 0.75), {0.8, 0.8, 2.0}, kUvError, "wrap in u");
    expectNear(at(0.25, 0.1), {1.4, 0.0, 0.6}, kUvError, "wrap in v");

    world.materials[0] = {.albedo = glm::vec3(1.0f), .albedoTexture = 0};
    world.suns.push_back({.direction = {0.0f, 0.0f, 1.0f}, .irradiance = glm::vec3(float(kPi))});
    const ReferenceTracer lit(world, constantSky(glm::dvec3(0.0)));
    const glm::dvec3 seen =
        directRadiance(lit, glm::dvec3(0.0), glm::normalize(glm::dvec3(-0.25, 0.0, -1.0))).radiance;
    expectNear(seen, {0.5, 0.25, 0.5}, kUvError, "albedo texture");
}

// --- Bounces under the sky -------------------------------------------------------------------------

// Checks: sky light reaches the probe through one bounce off a floor. A probe at height h = 1 over
// the centre of a floor square of half-size A = 10 (albedo a, one-sided, up) under a uniform sky Ls
// sees the floor over Omega = 4 asin(A^2 / (A^2 + h^2)) (the solid angle of a rectangle seen from
// its axis) and the sky elsewhere. A floor point sees the sky over its whole hemisphere, so it leaves
// a Ls after one bounce (nothing at bounce 0, and a second bounce adds nothing): L_00 = y_00 Ls
// (4 pi - Omega + a Omega) for K >= 1, y_00 Ls (4 pi - Omega) for K = 0. Every path is exact; only
// which directions meet the floor varies, so the check is to the standard error. The estimate must
// also tell Omega from 2 pi (an infinite floor): they differ by more than 10 standard errors.
TEST(ReferenceTracerBounce, FloorReflectsTheSkyAfterOneBounce) {
    const glm::dvec3 skyValue(1.0, 0.8, 0.6);
    const glm::vec3 albedo(0.25f, 0.5f, 0.75f);
    World world;
    const uint32_t floor = addMaterial(world, {.albedo = albedo});
    addQuad(world, {-10.0f, 0.0f, 10.0f}, {20.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -20.0f}, floor);
    const ReferenceTracer tracer(world, constantSky(skyValue));
    const double omega = 4.0 * std::asin(100.0 / 101.0);
    for (int bounces : {0, 1, 2}) {
        const PathTracedProbe probe =
            pathTraceProbe(tracer, {0.0, 1.0, 0.0}, {.order = 1, .bounces = bounces, .samples = 4096});
        const glm::dvec3 floorRadiance = bounces == 0 ? glm::dvec3(0.0) : glm::dvec3(albedo) * skyValue;
        const auto expected = [&](double floorSolidAngle) {
            return kY00 * (skyValue * (4.0 * kPi - floorSolidAngle) + floorRadiance * floorSolidAngle);
        };
        const glm::dvec3 exact = expected(omega);
        const double worst = worstStandardizedError(probe, {exact}, exact.x);
        EXPECT_LE(worst, kStandardErrors) << bounces << " bounces";
        const double infiniteFloor = std::abs(expected(2.0 * kPi).x - exact.x) / probe.standardError[0].x;
        EXPECT_GT(infiniteFloor, 10.0) << bounces << " bounces";
        std::printf("floor under the sky, %d bounces: |error| %.2f standard errors, standard error %.2e of "
                    "L00; an infinite floor is %.0f standard errors away\n",
                    bounces, worst, probe.standardError[0].x / exact.x, infiniteFloor);
    }
}

// --- Determinism and throughput ---------------------------------------------------------------

// Checks: pathTraceProbes gives the same bits on 1 thread, on all cores and on 3 (more threads than
// this machine's 2 cores), and each probe equals its single pathTraceProbe call: results depend on
// the seed alone. A different seed changes them (so the comparison is not of constants). Prints the
// rays per second of the all-core run and of texel rays.
TEST(ReferenceTracerDeterminism, SameBitsForAnyThreadCountAndAlone) {
    World world = sunlitFloor();
    const uint32_t grey = addMaterial(world, {.albedo = glm::vec3(0.6f), .doubleSided = true});
    addBox(world, {2.0f, 0.0f, -3.0f}, {3.0f, 1.5f, -2.0f}, grey, Facing::Outward);
    const ReferenceTracer tracer(world, skyOf(16, gradientSky));
    std::vector<glm::dvec3> positions;
    for (int k = 0; k < 8; ++k)
        positions.emplace_back(-3.0 + k, 0.5 + 0.1 * k, 1.0 - 0.5 * k);
    const PathTraceOptions options{.order = 3, .bounces = 2, .samples = 4096};
    const auto start = std::chrono::steady_clock::now();
    const std::vector<PathTracedProbe> all = pathTraceProbes(tracer, positions, options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    uint64_t rays = 0;
    for (const PathTracedProbe& probe : all)
        rays += probe.rays;
    std::printf("path tracing: %llu rays in %.3f s on all cores: %.2f M rays/s\n", (unsigned long long)rays,
                seconds, rays / seconds * 1e-6);
    const auto expectSame = [&](const std::vector<PathTracedProbe>& other, const char* what) {
        ASSERT_EQ(other.size(), all.size());
        for (size_t p = 0; p < all.size(); ++p) {
            EXPECT_EQ(other[p].radiance.rgb, all[p].radiance.rgb) << what << ", probe " << p;
            EXPECT_EQ(other[p].standardError, all[p].standardError) << what << ", probe " << p;
            EXPECT_EQ(other[p].rays, all[p].rays) << what << ", probe " << p;
        }
    };
    PathTraceOptions oneThread = options;
    oneThread.threads = 1;
    expectSame(pathTraceProbes(tracer, positions, oneThread), "1 thread");
    PathTraceOptions threeThreads = options;
    threeThreads.threads = 3;
    expectSame(pathTraceProbes(tracer, positions, threeThreads), "3 threads");
    std::vector<PathTracedProbe> alone;
    for (const glm::dvec3& position : positions)
        alone.push_back(pathTraceProbe(tracer, position, options));
    expectSame(alone, "one call per probe");
    PathTraceOptions otherSeed = options;
    otherSeed.seed = 2;
    EXPECT_NE(pathTraceProbe(tracer, positions[0], otherSeed).radiance.rgb, all[0].radiance.rgb);

    const auto texelStart = std::chrono::steady_clock::now();
    const ProbeTexels texels = traceProbeTexels(tracer, positions[0], 256);
    const double texelSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - texelStart).count();
    std::printf("texel rays (with shadow rays): 6 x 256^2 texels in %.3f s: %.2f M texels/s\n", texelSeconds,
                6.0 * 256 * 256 / texelSeconds * 1e-6);
    EXPECT_EQ(texels.backFaceTexels, traceProbeTexels(tracer, positions[0], 256).backFaceTexels);
}

// --- Refusals ----------------------------------------------------------------------------------

// Checks: inconsistent Worlds, a sky that is not a cube map and bad options are input errors.
TEST(ReferenceTracerErrors, InconsistentInputsAreRefused) {
    const Cubemap sky = constantSky(glm::dvec3(1.0));
    const World good = emissiveBox(glm::vec3(0.5f), Facing::Inward, false);
    const auto refuses = [&](const std::function<void(World&)>& spoil, const char* what) {
        World world = good;
        spoil(world);
        testing::expectInputError([&] { ReferenceTracer tracer(world, sky); }, what);
    };
    refuses([](World& w) { w.indices[5] = 1000; }, "index past the vertices");
    refuses([](World& w) { w.indices.pop_back(); }, "a partial triangle");
    refuses([](World& w) { w.normals.pop_back(); }, "a missing normal");
    refuses([](World& w) { w.triangleMaterials[3] = 7; }, "a material past the list");
    refuses([](World& w) { w.materials[0].albedoTexture = 0; }, "a texture past the list");
    refuses([](World& w) { w.positions[2].x = NAN; }, "a NaN position");
    refuses([](World& w) { w.suns.push_back({.direction = glm::vec3(0.0f)}); }, "a sun without direction");
    refuses([](World& w) { w.textures.push_back({2, 2, {}}); }, "a texture without texels");
    Cubemap broken = sky;
    broken.texels.pop_back();
    testing::expectInputError([&] { ReferenceTracer tracer(good, broken); }, "a sky short of a texel");
    const ReferenceTracer tracer(good, sky);
    testing::expectInputError([&] { pathTraceProbe(tracer, kInsideBox, {.order = 0}); }, "order 0");
    testing::expectInputError([&] { pathTraceProbe(tracer, kInsideBox, {.order = kMaxOrder + 1}); },
                              "order 9");
    testing::expectInputError([&] { pathTraceProbe(tracer, kInsideBox, {.bounces = -1}); },
                              "negative bounces");
    testing::expectInputError([&] { pathTraceProbe(tracer, kInsideBox, {.samples = 0}); }, "no samples");
    testing::expectInputError([&] { traceProbeTexels(tracer, kInsideBox, 0); }, "face size 0");
}

} // namespace
} // namespace shprobe
