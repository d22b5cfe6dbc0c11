// CPU side of the render shaders (no device): the basis polynomials and their constants, the
// folding of probes (checked by evaluating the folded terms the way sh_irradiance.glsl does, in
// double), the non-linear L1 model's properties (seed 004), the seed-000 facts for a delta light
// on the references, and the errors for probes the renderer cannot use.
#include "render/probe_shading.h"
#include "render/scene.h"
#include "sh/basis.h"
#include "sh/error.h"
#include "sh/irradiance.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <random>

namespace shprobe {
namespace {

constexpr double kPi = std::numbers::pi;

// Double arithmetic on values near 1 with a few dozen operations: 1e-12 is ~5000 ulps of margin.
constexpr double kDoubleTolerance = 1e-12;

std::vector<glm::dvec3> randomDirections(int count, uint32_t seed) {
    std::mt19937 random(seed);
    std::normal_distribution<double> normal;
    std::vector<glm::dvec3> directions;
    while (int(directions.size()) < count) {
        glm::dvec3 d(normal(random), normal(random), normal(random));
        if (glm::length(d) > 1e-3) directions.push_back(glm::normalize(d));
    }
    // The axes and diagonals, where the polynomials' special cases are.
    for (glm::dvec3 d :
         {glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1), glm::dvec3(-1, 0, 0),
          glm::dvec3(0, -1, 0), glm::dvec3(0, 0, -1), glm::dvec3(1, 1, 1), glm::dvec3(1, -1, 0)})
        directions.push_back(glm::normalize(d));
    return directions;
}

// Radiance of a positive environment: a few smooth lobes, projected by quadrature-free means:
// L_lm = sum_k w_k y_lm(d_k) is the projection of delta lights of power w_k, always a valid
// (non-negative) radiance distribution.
ShCoefficients deltaLights(const std::vector<std::pair<glm::dvec3, glm::dvec3>>& lights, int order) {
    ShCoefficients radiance = makeCoefficients(order, Quantity::Radiance);
    std::vector<double> y(size_t(coefficientCount(order)));
    for (const auto& [direction, power] : lights) {
        evalBasis(order, glm::normalize(direction), y);
        for (size_t i = 0; i < y.size(); ++i)
            radiance.rgb[i] += power * y[i];
    }
    return radiance;
}

ShCoefficients testProbe() {
    return deltaLights({{{0.3, 0.8, -0.5}, {9.0, 8.0, 6.0}},
                        {{-0.7, 0.1, 0.2}, {1.0, 2.0, 4.0}},
                        {{0.1, -0.9, 0.3}, {0.5, 0.4, 0.3}},
                        {{0.0, 0.0, 1.0}, {2.0, 2.0, 2.0}}},
                       5);
}

// The folded evaluation of sh_irradiance.glsl, term by term, in double (p_6 = z^2: Sloan's split).
glm::dvec3 evaluateFolded(const std::array<glm::vec4, SHPROBE_FOLDED_COUNT>& c, const glm::dvec3& n,
                          int order, bool skipBand3) {
    glm::dvec3 sum(0.0);
    for (int i = 0; i < coefficientCount(order); ++i) {
        int l = shBand(i);
        if (l == 3 && skipBand3) continue;
        double p = i == 6 ? n.z * n.z : basisPolynomial(i, n);
        sum += glm::dvec3(glm::vec3(c[size_t(i)])) * p;
    }
    return sum;
}

double largest(const glm::dvec3& v) {
    return std::max({std::abs(v.r), std::abs(v.g), std::abs(v.b)});
}

TEST(RenderShading, PolynomialsTimesConstantsAreTheBasis) {
    std::array<double, 25> y{};
    for (const glm::dvec3& d : randomDirections(200, 1)) {
        evalBasis(5, d, y);
        for (int i = 0; i < 25; ++i)
            EXPECT_NEAR(basisPolynomialScale(i) * basisPolynomial(i, d), y[size_t(i)], kDoubleTolerance)
                << "index " << i << " (l=" << shBand(i) << ")";
    }
}

TEST(RenderShading, SloanConstantsOfOrderThree) {
    // Sloan's shader constants with the 1/pi of the Lambertian BRDF (seed 001): c1 = A_1 K_1 / pi =
    // sqrt(3)/(3 sqrt(pi)), c2 = A_2 K_(2,+-2 etc.) / pi = sqrt(15)/(8 sqrt(pi)), c3 = sqrt(5)/(16 sqrt(pi)),
    // c0 = 1/(2 sqrt(pi)); note the minus signs of the odd-m terms (y, x, yz, xz).
    const double sqrtPi = std::sqrt(kPi);
    EXPECT_NEAR(irradianceBandFactor(0) / kPi * basisPolynomialScale(0), 1.0 / (2.0 * sqrtPi),
                kDoubleTolerance);
    EXPECT_NEAR(irradianceBandFactor(1) / kPi * basisPolynomialScale(1), -std::sqrt(3.0) / (3.0 * sqrtPi),
                kDoubleTolerance);
    EXPECT_NEAR(irradianceBandFactor(1) / kPi * basisPolynomialScale(3), -std::sqrt(3.0) / (3.0 * sqrtPi),
                kDoubleTolerance);
    EXPECT_NEAR(irradianceBandFactor(2) / kPi * basisPolynomialScale(4), std::sqrt(15.0) / (8.0 * sqrtPi),
                kDoubleTolerance);
    EXPECT_NEAR(irradianceBandFactor(2) / kPi * basisPolynomialScale(5), -std::sqrt(15.0) / (8.0 * sqrtPi),
                kDoubleTolerance);
    EXPECT_NEAR(irradianceBandFactor(2) / kPi * basisPolynomialScale(6), std::sqrt(5.0) / (16.0 * sqrtPi),
                kDoubleTolerance);
    EXPECT_NEAR(irradianceBandFactor(2) / kPi * basisPolynomialScale(8), std::sqrt(15.0) / (16.0 * sqrtPi),
                kDoubleTolerance);
}

// The folded coefficients are stored in fp32: relative error 6e-8 per term; 25 terms of size up
// to sum |c_i p_i| give at most ~2e-6 of that sum, well above what double evaluation adds.
constexpr double kFoldTolerance = 2e-6;

TEST(RenderShading, FoldedIrradianceAndRadianceMatchTheReference) {
    ShCoefficients radiance = testProbe();
    for (int order : {1, 2, 3, 4, 5}) {
        ProbeShading folded = foldProbe(radiance, order, "probe");
        ASSERT_TRUE(folded.hasRadiance);
        for (const glm::dvec3& n : randomDirections(100, 2)) {
            glm::dvec3 e = shadeReference(radiance, ShadingMode::Irradiance, order, n);
            glm::dvec3 l = shadeReference(radiance, ShadingMode::Radiance, order, n);
            double scale = largest(radiance.rgb[0]);
            EXPECT_LT(largest(evaluateFolded(folded.irradiance, n, order, true) - e), kFoldTolerance * scale)
                << "irradiance, order " << order;
            EXPECT_LT(largest(evaluateFolded(folded.radiance, n, order, false) - l),
                      4 * kFoldTolerance * scale)
                << "radiance, order " << order;
        }
    }
}

TEST(RenderShading, IrradianceProbesFoldLikeTheirRadiance) {
    ShCoefficients radiance = testProbe();
    ShCoefficients irradiance = convolveIrradiance(radiance);
    ProbeShading fromRadiance = foldProbe(radiance, 5, "r");
    ProbeShading fromIrradiance = foldProbe(irradiance, 5, "e");
    for (int i = 0; i < 25; ++i)
        EXPECT_LT(glm::length(fromRadiance.irradiance[size_t(i)] - fromIrradiance.irradiance[size_t(i)]),
                  1e-5f)
            << i;
    EXPECT_FALSE(fromIrradiance.hasRadiance) << "band 3 of radiance is lost in irradiance (A_3 = 0)";
    ProbeShading order3 = foldProbe(irradiance, 3, "e");
    EXPECT_TRUE(order3.hasRadiance) << "bands 0..2 divide back by A_l";
    for (int i = 0; i < 9; ++i)
        EXPECT_LT(glm::length(order3.radiance[size_t(i)] - fromRadiance.radiance[size_t(i)]), 1e-5f) << i;
    for (int i = 0; i < 4; ++i)
        EXPECT_LT(glm::length(fromRadiance.l1[size_t(i)] - fromIrradiance.l1[size_t(i)]), 1e-5f) << i;
}

TEST(RenderShading, DeltaLightFactsOfSloan) {
    // A delta light of power pi along d: exact E(n)/pi = max(n.d, 0), 1 at the pole, 0 opposite.
    // Sloan (seed 000): order 3 gives 17/16 at the pole and 1/16 opposite; order 5 gives 31/32 and
    // -1/32 ("-1 against a peak of 31").
    const glm::dvec3 d = glm::normalize(glm::dvec3(0.2, 0.5, -0.8));
    ShCoefficients light = deltaLights({{d, glm::dvec3(kPi)}}, 5);
    auto e = [&](int order, const glm::dvec3& n) {
        return shadeReference(light, ShadingMode::Irradiance, order, n).r;
    };
    EXPECT_NEAR(e(3, d), 17.0 / 16.0, kDoubleTolerance);
    EXPECT_NEAR(e(3, -d), 1.0 / 16.0, kDoubleTolerance);
    EXPECT_NEAR(e(5, d), 31.0 / 32.0, kDoubleTolerance);
    EXPECT_NEAR(e(5, -d), -1.0 / 32.0, kDoubleTolerance);
}

TEST(RenderShading, NonLinearL1IsNonNegativeKeepsEnergyAndRange) {
    const std::vector<glm::dvec3> normals = randomDirections(20000, 3);
    for (const ShCoefficients& radiance :
         {testProbe(), deltaLights({{{0, 0, 1}, {1, 1, 1}}}, 2),
          deltaLights({{{1, 0, 0}, {1, 0, 0}}, {{-1, 0, 0}, {1, 0, 0}}}, 2)}) {
        RenormalizedL1 l1 = renormalizedL1(radiance);
        glm::dvec3 lowest(1e30), highest(-1e30);
        for (const glm::dvec3& n : normals) {
            glm::dvec3 value = l1NonLinearOverPi(radiance, n);
            lowest = glm::min(lowest, value);
            highest = glm::max(highest, value);
        }
        for (int c = 0; c < 3; ++c) {
            glm::dvec3 r1(l1.r1[0][c], l1.r1[1][c], l1.r1[2][c]);
            EXPECT_GE(lowest[c], 0.0) << "channel " << c;
            // The model's range is 4 |R1| (seed 004); random normals come within ~1% of the extremes.
            EXPECT_NEAR(highest[c] - lowest[c], 4.0 * glm::length(r1), 0.02 * 4.0 * l1.r0[c] + 1e-12) << c;
        }
    }
}

TEST(RenderShading, LinearL1GoesNegativeWhereTheNonLinearModelDoesNot) {
    // A delta light: R1 = R0, the linear model R0 + 2 R1.n reaches -R0 opposite the light (seed 004).
    const glm::dvec3 d(0.0, 1.0, 0.0);
    ShCoefficients light = deltaLights({{d, glm::dvec3(1.0)}}, 2);
    RenormalizedL1 l1 = renormalizedL1(light);
    EXPECT_NEAR(shadeReference(light, ShadingMode::Irradiance, 2, -d).r, -l1.r0.r, kDoubleTolerance);
    EXPECT_NEAR(l1NonLinearOverPi(light, -d).r, 0.0, kDoubleTolerance);
    EXPECT_NEAR(l1NonLinearOverPi(light, d).r, 4.0 * l1.r0.r, kDoubleTolerance) << "the peak: 4 R0";
}

// Mean over the sphere of the model = R0, by Gauss-Legendre in cos(theta) (the model is a smooth
// function of n.R1 only, so a zonal quadrature about R1 is exact up to the rule's order).
TEST(RenderShading, NonLinearL1KeepsTheL0Energy) {
    ShCoefficients radiance = testProbe();
    RenormalizedL1 l1 = renormalizedL1(radiance);
    for (int c = 0; c < 3; ++c) {
        glm::dvec3 axis = glm::normalize(glm::dvec3(l1.r1[0][c], l1.r1[1][c], l1.r1[2][c]));
        glm::dvec3 side = glm::normalize(glm::cross(axis, glm::dvec3(0.3, 0.4, 0.5)));
        const int steps = 20000;
        double mean = 0.0;
        for (int k = 0; k < steps; ++k) { // midpoint rule in x = cos(theta), error O(1/steps^2)
            double x = -1.0 + (k + 0.5) * 2.0 / steps;
            glm::dvec3 n = x * axis + std::sqrt(1.0 - x * x) * side;
            mean += l1NonLinearOverPi(radiance, n)[c] / steps;
        }
        EXPECT_NEAR(mean, l1.r0[c], 1e-6 * l1.r0[c]) << "channel " << c;
    }
}

TEST(RenderShading, ProbesWithTooFewBandsAreRefusedByName) {
    ShCoefficients order3 = makeCoefficients(3, Quantity::Radiance);
    try {
        foldProbe(order3, 5, "sky.json");
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::Input);
        EXPECT_NE(std::string(e.what()).find("sky.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("order 3"), std::string::npos) << e.what();
    }
}

TEST(RenderShading, NamesParse) {
    for (ShadingMode mode : {ShadingMode::Radiance, ShadingMode::Irradiance, ShadingMode::L1NonLinear})
        EXPECT_EQ(parseShadingMode(shadingModeName(mode)), mode);
    for (Background background :
         {Background::Color, Background::Environment, Background::Radiance, Background::Shading})
        EXPECT_EQ(parseBackground(backgroundName(background)), background);
    EXPECT_EQ(parseBackground("sh"), Background::Radiance);
    EXPECT_THROW(parseShadingMode("phong"), Error);
    EXPECT_THROW(parseBackground("sky"), Error);
}

} // namespace
} // namespace shprobe
