// The double-precision reference projection of cube maps and equirect maps.
#include "common/error.h"
#include "glsl/equirect_geometry.h"
#include "sh/basis.h"
#include "sh/projection.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

namespace shprobe {
namespace {

constexpr double kPi = std::numbers::pi;

// Sums of at most a few million double products of values of order 1: rounding only. Used where
// the result is exact in exact arithmetic (exact solid angles, symmetry, linearity, one texel).
constexpr double kRoundingError = 1e-12;
// An environment equal to y_k, stored in fp32 and sampled at texel centers, projects to e_k up to
// the midpoint-rule error of the texels, O(1/N^2). Measured over all 64 x 64 (k, i) pairs of order 8
// (the test prints them): 1.46e-4 at N = 64 and 3.66e-5 at 512 x 256, falling 4x per doubling
// (2.34e-3, 5.83e-4 at N = 16, 32). Bounds: the measurement plus about 35%.
constexpr double kCubeBasisError = 2e-4;     // N = 64
constexpr double kEquirectBasisError = 5e-5; // 512 x 256
// The equirect white furnace at 512 x 256: the zonal (about +Y) harmonics of even bands keep the
// same midpoint-rule error, times sqrt(4 pi) for L_00 = c sqrt(4 pi): measured 5.39e-5; bound with margin.
constexpr double kEquirectFurnaceError = 7.5e-5;
// The same smooth environment projected from a 128-cube and a 1024 x 512 equirect map, both
// discretization errors O(1e-5) here: measured 3.54e-5 relative to L_00; bound with margin.
constexpr double kCubeVsEquirectError = 5e-5;

using Environment = std::function<glm::dvec3(const glm::dvec3&)>;

Cubemap cubemapOf(int n, const Environment& radiance) {
    Cubemap cube = makeCubemap(n);
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i)
                cube.at(face, i, j) = glm::vec4(radiance(texelDirection(face, i, j, n)), 0.0f);
        }
    }
    return cube;
}

Image equirectOf(int w, int h, const Environment& radiance) {
    Image image = makeImage(w, h);
    for (int j = 0; j < h; ++j) {
        for (int i = 0; i < w; ++i)
            image.at(i, j) = glm::vec4(radiance(equirectDirection(i, j, w, h)), 0.0f);
    }
    return image;
}

double basisAt(int index, const glm::dvec3& d) {
    std::array<double, coefficientCount(kMaxOrder)> y{};
    evalBasis(kMaxOrder, d, y);
    return y[size_t(index)];
}

// An environment equal to y_k in red, 2 y_k in green and -y_k in blue.
const glm::dvec3 kBasisEnvironmentColor(1.0, 2.0, -1.0);

Environment basisEnvironment(int k) {
    return [k](const glm::dvec3& d) { return kBasisEnvironmentColor * basisAt(k, d); };
}

// Largest |L_i - expected_i| over all channels, divided per channel by the channel's scale.
double worstDeviation(const ShCoefficients& result, const std::vector<glm::dvec3>& expected,
                      glm::dvec3 scale) {
    double worst = 0.0;
    for (size_t i = 0; i < result.rgb.size(); ++i) {
        const glm::dvec3 deviation = glm::abs(result.rgb[i] - expected[i]) / scale;
        worst = std::max({worst, deviation.x, deviation.y, deviation.z});
    }
    return worst;
}

// Worst deviation from e_k of the projections of y_k, over all k of order 8.
double worstBasisProjectionError(const std::function<ShCoefficients(const Environment&)>& project) {
    const int count = coefficientCount(kMaxOrder);
    double worst = 0.0;
    for (int k = 0; k < count; ++k) {
        std::vector<glm::dvec3> unit(size_t(count), glm::dvec3(0.0));
        unit[size_t(k)] = kBasisEnvironmentColor;
        worst = std::max(
            worst, worstDeviation(project(basisEnvironment(k)), unit, glm::abs(kBasisEnvironmentColor)));
    }
    return worst;
}

double cubeBasisProjectionError(int n) {
    return worstBasisProjectionError(
        [n](const Environment& f) { return projectCubemap(cubemapOf(n, f), kMaxOrder); });
}

double equirectBasisProjectionError(int w, int h) {
    return worstBasisProjectionError(
        [w, h](const Environment& f) { return projectEquirect(equirectOf(w, h, f), kMaxOrder); });
}

const glm::dvec3 kConstantRadiance(0.5, 1.25, 3.0);

// Expected projection of the constant environment: L_00 = c sqrt(4 pi), all others 0.
std::vector<glm::dvec3> constantProjection(int order) {
    std::vector<glm::dvec3> expected(size_t(coefficientCount(order)), glm::dvec3(0.0));
    expected[0] = kConstantRadiance * std::sqrt(4.0 * kPi);
    return expected;
}

// Checks (white furnace): a constant environment c projects to L_00 = c sqrt(4 pi) and, through
// l = 3, to 0 everywhere else, exactly up to rounding: the exact solid angles sum to 4 pi, and each
// y_lm with 1 <= l <= 3 changes sign under one of the cube's mirror symmetries or averages to zero
// over its axis permutations, so texel sums cancel pairwise. (From l = 4 on, some combinations
// such as x^4 + y^4 + z^4 - 3/5 are invariant under the cube's symmetries and keep a discretization
// error; the basis-function test covers those.) Alpha is garbage and must be ignored.
TEST(Projection, ConstantCubemapWhiteFurnace) {
    for (int n : {1, 2, 7, 32}) {
        Cubemap cube = cubemapOf(n, [](const glm::dvec3&) { return kConstantRadiance; });
        for (glm::vec4& texel : cube.texels)
            texel.a = -1e30f;
        const ShCoefficients result = projectCubemap(cube, 4);
        EXPECT_EQ(result.quantity, Quantity::Radiance);
        EXPECT_LT(worstDeviation(result, constantProjection(4), kConstantRadiance), kRoundingError)
            << "N = " << n;
    }
}

// Checks: the equirect white furnace. L_00 is exact (the row solid angles sum to 4 pi) and every odd
// band vanishes by the y -> -y mirror of the rows; even bands keep the midpoint-rule error of the
// zonal (about +Y) harmonics, which is small at 512 x 256.
TEST(Projection, ConstantEquirectWhiteFurnace) {
    const ShCoefficients result =
        projectEquirect(equirectOf(512, 256, [](const glm::dvec3&) { return kConstantRadiance; }), kMaxOrder);
    const std::vector<glm::dvec3> expected = constantProjection(kMaxOrder);
    double worstEvenBand = 0.0;
    for (size_t i = 0; i < result.rgb.size(); ++i) {
        const glm::dvec3 deviation = glm::abs(result.rgb[i] - expected[i]) / kConstantRadiance;
        const double worst = std::max({deviation.x, deviation.y, deviation.z});
        const bool exact = i == 0 || shBand(int(i)) % 2 == 1;
        if (!exact) worstEvenBand = std::max(worstEvenBand, worst);
        EXPECT_LT(worst, exact ? kRoundingError : kEquirectFurnaceError) << "i = " << i;
    }
    std::printf("equirect 512x256 white furnace, worst even-band coefficient / c: %.3g\n", worstEvenBand);
}

// Checks: an environment equal to one basis function y_k projects to the unit vector e_k, for all
// 64 functions of order 8, within the measured discretization bound; and the error falls as the
// resolution grows (quadratically: by more than 3x per doubling).
TEST(Projection, BasisFunctionProjectsToUnitVector) {
    const double cube16 = cubeBasisProjectionError(16);
    const double cube32 = cubeBasisProjectionError(32);
    const double cube64 = cubeBasisProjectionError(64);
    const double equirect128 = equirectBasisProjectionError(128, 64);
    const double equirect256 = equirectBasisProjectionError(256, 128);
    const double equirect512 = equirectBasisProjectionError(512, 256);
    std::printf("basis projection error, cube N = 16, 32, 64: %.3g %.3g %.3g\n", cube16, cube32, cube64);
    std::printf("basis projection error, equirect 128x64, 256x128, 512x256: %.3g %.3g %.3g\n", equirect128,
                equirect256, equirect512);
    EXPECT_LT(cube64, kCubeBasisError);
    EXPECT_LT(equirect512, kEquirectBasisError);
    EXPECT_LT(cube32, cube16 / 3.0);
    EXPECT_LT(cube64, cube32 / 3.0);
    EXPECT_LT(equirect256, equirect128 / 3.0);
    EXPECT_LT(equirect512, equirect256 / 3.0);
}

// A smooth environment with all bands present: exp(2 d.s) for a different s per channel.
glm::dvec3 smoothEnvironment(const glm::dvec3& d) {
    return {std::exp(2.0 * glm::dot(d, glm::normalize(glm::dvec3(0.3, -0.5, 0.8)))),
            std::exp(2.0 * glm::dot(d, glm::normalize(glm::dvec3(-0.9, 0.1, 0.2)))),
            std::exp(2.0 * glm::dot(d, glm::dvec3(0.0, 1.0, 0.0)))};
}

// Checks: a cube map and an equirect map of the same analytic environment give the same
// coefficients (docs/conventions.md: equirect and cube-map paths agree up to discretization error).
TEST(Projection, CubemapAndEquirectAgree) {
    const ShCoefficients cube = projectCubemap(cubemapOf(128, smoothEnvironment), kMaxOrder);
    const ShCoefficients equirect = projectEquirect(equirectOf(1024, 512, smoothEnvironment), kMaxOrder);
    const double error = worstDeviation(cube, equirect.rgb, cube.rgb[0]);
    std::printf("cube 128 vs equirect 1024x512, worst difference relative to L_00: %.3g\n", error);
    EXPECT_LT(error, kCubeVsEquirectError);
}

// Values k/16 with small k: sums and small multiples of them are exact in fp32, so the inputs of
// the linearity test carry no rounding of their own.
Cubemap randomDyadicCubemap(int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> numerator(-1000, 1000);
    Cubemap cube = makeCubemap(n);
    for (glm::vec4& texel : cube.texels) {
        texel = glm::vec4(numerator(rng), numerator(rng), numerator(rng), 0.0f) / 16.0f;
    }
    return cube;
}

// Checks: projection is linear: P(2 f - 3 g) = 2 P(f) - 3 P(g), up to double rounding.
TEST(Projection, Linear) {
    constexpr int n = 16;
    const Cubemap f = randomDyadicCubemap(n, 1);
    const Cubemap g = randomDyadicCubemap(n, 2);
    Cubemap combination = makeCubemap(n);
    for (size_t t = 0; t < combination.texels.size(); ++t)
        combination.texels[t] = 2.0f * f.texels[t] - 3.0f * g.texels[t];
    const ShCoefficients pf = projectCubemap(f, kMaxOrder);
    const ShCoefficients pg = projectCubemap(g, kMaxOrder);
    std::vector<glm::dvec3> expected;
    for (size_t i = 0; i < pf.rgb.size(); ++i)
        expected.push_back(2.0 * pf.rgb[i] - 3.0 * pg.rgb[i]);
    // Values reach 60 and partial sums a few hundred: scale the rounding bound accordingly.
    EXPECT_LT(worstDeviation(projectCubemap(combination, kMaxOrder), expected, glm::dvec3(1000.0)),
              kRoundingError);
}

// Checks: an environment lit at one texel projects to c y_i(d) Omega, d the texel's direction and
// Omega its exact solid angle: the weight of each texel is exactly its solid angle.
TEST(Projection, SingleTexel) {
    constexpr int n = 8, face = int(Face::NegativeY), i = 3, j = 6;
    const glm::vec4 c(2.0f, 0.5f, 7.0f, 1.0f);
    Cubemap cube = makeCubemap(n);
    cube.at(face, i, j) = c;
    const ShCoefficients result = projectCubemap(cube, kMaxOrder);
    const glm::dvec3 d = texelDirection(face, i, j, n);
    std::vector<glm::dvec3> expected;
    for (int k = 0; k < coefficientCount(kMaxOrder); ++k) {
        expected.push_back(glm::dvec3(c) * basisAt(k, d) * texelSolidAngle(i, j, n));
    }
    EXPECT_LT(worstDeviation(result, expected, glm::dvec3(1.0)), kRoundingError);
}

// Checks: the same for one pixel of an equirect map, with the exact row solid angle.
TEST(Projection, SingleEquirectPixel) {
    constexpr int w = 16, h = 8, i = 11, j = 2;
    Image image = makeImage(w, h);
    image.at(i, j) = glm::vec4(3.0f, 1.0f, 0.25f, 0.0f);
    const ShCoefficients result = projectEquirect(image, kMaxOrder);
    const glm::dvec3 d = equirectDirection(i, j, w, h);
    std::vector<glm::dvec3> expected;
    for (int k = 0; k < coefficientCount(kMaxOrder); ++k) {
        expected.push_back(glm::dvec3(3.0, 1.0, 0.25) * basisAt(k, d) * equirectRowSolidAngle(j, w, h));
    }
    EXPECT_LT(worstDeviation(result, expected, glm::dvec3(1.0)), kRoundingError);
}

// Largest |fp32 - double| of a direction's components (unit vectors: absolute), and the relative
// error of a row's solid angle, of the shaders' equirect geometry against sh/cubemap.h's.
struct Fp32GeometryError {
    double direction = 0.0;
    double solidAngle = 0.0;
};

void addFp32GeometryError(int i, int j, int width, int height, Fp32GeometryError& worst) {
    const glm::vec2 row = glsl::equirectRowSinCos(glsl::uint(j), glsl::uint(height));
    const glm::vec3 direction =
        glsl::equirectDirectionOf(row, glsl::equirectColumnSinCos(glsl::uint(i), glsl::uint(width)));
    const glm::dvec3 deviation = glm::abs(glm::dvec3(direction) - equirectDirection(i, j, width, height));
    worst.direction = std::max({worst.direction, deviation.x, deviation.y, deviation.z});
    const double solidAngle = glsl::equirectSolidAngleScale(glsl::uint(width), glsl::uint(height)) * row.x;
    const double exact = equirectRowSolidAngle(j, width, height);
    worst.solidAngle = std::max(worst.solidAngle, std::abs(solidAngle - exact) / exact);
}

// Checks: the fp32 equirect geometry of project_equirect.comp (src/glsl/equirect_geometry.h,
// the same arithmetic compiled as C++) against the double geometry of the reference, for every pixel
// of every map up to 64 x 33 and for the pole, equator and other rows of large maps (up to 16384 x
// 8192, odd heights too): directions within 4e-7 (a few fp32 ulps of components up to 1) and row
// solid angles within 1e-6 relative, also at the poles, where (2 pi / W)(cos theta_j -
// cos theta_j+1) in fp32 would cancel to nothing (the shaders use 2 sin t sin h instead) and a
// rounded theta / pi near 1 would lose most of sin theta (preciseSinCosPi folds in integers).
// Measured: 1.3e-7 and 2.8e-7.
TEST(Projection, Fp32EquirectGeometryMatchesDouble) {
    Fp32GeometryError worst;
    for (int width = 1; width <= 64; ++width)
        for (int height = 1; height <= 33; height += 4)
            for (int j = 0; j < height; ++j)
                for (int i = 0; i < width; ++i)
                    addFp32GeometryError(i, j, width, height, worst);
    for (const auto& [width, height] :
         {std::pair{2048, 1024}, std::pair{4095, 2047}, std::pair{16384, 8192}, std::pair{1000, 999}}) {
        for (int j : {0, 1, 2, height / 3, height / 2 - 1, height / 2, height - 2, height - 1})
            for (int i = 0; i < width; ++i)
                addFp32GeometryError(i, j, width, height, worst);
        for (int j = 0; j < height; ++j)
            addFp32GeometryError(width / 3, j, width, height, worst);
    }
    std::printf("fp32 equirect geometry: direction %.3g, row solid angle %.3g relative\n", worst.direction,
                worst.solidAngle);
    EXPECT_LT(worst.direction, 4e-7);
    EXPECT_LT(worst.solidAngle, 1e-6);
}

// Checks: an unsupported order and a cube map whose texel count disagrees with its size are input errors.
TEST(Projection, InvalidInputThrows) {
    const Cubemap cube = makeCubemap(2);
    EXPECT_THROW(projectCubemap(cube, 0), Error);
    EXPECT_THROW(projectCubemap(cube, kMaxOrder + 1), Error);
    Cubemap truncated = cube;
    truncated.texels.pop_back();
    EXPECT_THROW(projectCubemap(truncated, 3), Error);
    EXPECT_THROW(projectEquirect(makeImage(4, 2), 9), Error);
}

} // namespace
} // namespace shprobe
