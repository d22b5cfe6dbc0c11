// Lambertian convolution (A_l) and evaluation of probes, against analytic results.
#include "common/error.h"
#include "sh/basis.h"
#include "sh/irradiance.h"
#include "test_support.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

namespace shprobe {
namespace {

using testing::gaussLegendre;
using testing::legendre;
using testing::QuadratureNode;
using testing::randomDirections;

constexpr double kPi = std::numbers::pi;

// docs/conventions.md prints A_2..A_8 to 9 decimals.
constexpr double kPrintedValueError = 1e-9;
// Gauss-Legendre quadrature is exact for the polynomials P_l(t) t; what is left is rounding of
// about 20 terms whose sizes reach 1 (P_16 takes values up to 1 with alternating-sign sums).
constexpr double kQuadratureError = 1e-10;
// Evaluations sum at most 64 products of order 1 in double, about 1e-15 of rounding; 1e-9 leaves a
// wide margin while still pinning the exact fractions of the delta-light test.
constexpr double kEvaluationError = 1e-9;

// Checks: A_0..A_8 equal the values docs/conventions.md prints (pi, 2pi/3, pi/4, 0, -pi/24, 0, ...).
TEST(Irradiance, BandFactorValues) {
    const double expected[] = {kPi, 2.0 * kPi / 3.0, 0.785398163, 0.0,         -0.130899694,
                               0.0, 0.049087385,     0.0,         -0.024543693};
    for (int l = 0; l <= 8; ++l)
        EXPECT_NEAR(irradianceBandFactor(l), expected[l], kPrintedValueError) << "l = " << l;
    EXPECT_NEAR(irradianceBandFactor(2), kPi / 4.0, 1e-15);
    EXPECT_NEAR(irradianceBandFactor(4), -kPi / 24.0, 1e-15);
    for (int l = 3; l <= 31; l += 2)
        EXPECT_EQ(irradianceBandFactor(l), 0.0) << "l = " << l;
    EXPECT_THROW(irradianceBandFactor(-1), Error);
}

// Checks: the closed form equals its definition by Funk-Hecke, A_l = 2 pi integral_0^1 P_l(t) t dt
// (the clamped cosine max(0, t) against P_l), computed by 16-node Gauss-Legendre on [0, 1], exact
// for these polynomials of degree <= 17; l = 0..16, twice the bands the project uses.
TEST(Irradiance, BandFactorMatchesClampedCosineIntegral) {
    const std::vector<QuadratureNode> nodes = gaussLegendre(16, 0.0, 1.0);
    for (int l = 0; l <= 16; ++l) {
        double integral = 0.0;
        for (const QuadratureNode& node : nodes)
            integral += node.weight * legendre(l, node.t) * node.t;
        EXPECT_NEAR(irradianceBandFactor(l), 2.0 * kPi * integral, kQuadratureError) << "l = " << l;
    }
}

// Checks: a constant environment c (L_00 = c sqrt(4 pi)) gives irradiance pi c at every normal:
// the cosine-weighted hemisphere integral of a constant.
TEST(Irradiance, ConstantEnvironmentGivesPiTimesRadiance) {
    const glm::dvec3 c(0.5, 1.25, 3.0);
    ShCoefficients radiance = makeCoefficients(kMaxOrder, Quantity::Radiance);
    radiance.rgb[0] = c * std::sqrt(4.0 * kPi);
    const ShCoefficients irradiance = convolveIrradiance(radiance);
    EXPECT_EQ(irradiance.quantity, Quantity::Irradiance);
    for (const glm::dvec3& n : randomDirections(200, 99)) {
        const glm::dvec3 e = evaluate(irradiance, n);
        EXPECT_NEAR(e.r, kPi * c.r, kEvaluationError);
        EXPECT_NEAR(e.g, kPi * c.g, kEvaluationError);
        EXPECT_NEAR(e.b, kPi * c.b, kEvaluationError);
    }
}

// Radiance coefficients of a delta light of unit power from d0, projected exactly: L_i = y_i(d0).
ShCoefficients deltaLight(int order, const glm::dvec3& d0) {
    ShCoefficients radiance = makeCoefficients(order, Quantity::Radiance);
    std::vector<double> y(size_t(coefficientCount(order)));
    evalBasis(order, d0, y);
    for (size_t i = 0; i < y.size(); ++i)
        radiance.rgb[i] = glm::dvec3(y[i]);
    return radiance;
}

// Checks Sloan's facts ("Stupid SH Tricks") for a delta light, whose exact irradiance is max(0, n.d0): by the
// addition theorem E(n) = sum_l A_l (2l+1)/(4 pi) P_l(n.d0). Order 3 gives 1/4 + 1/2 + 5/16 = 17/16
// at the light (overshoots 1 by 1/16) and 1/4 - 1/2 + 5/16 = 1/16 opposite it (a back lobe);
// order 5 adds -9/96: 31/32 at the light and -1/32 opposite ("a -1 lobe against a peak of 31").
TEST(Irradiance, DeltaLightMatchesSloansFacts) {
    const glm::dvec3 d0 = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
    const ShCoefficients order3 = convolveIrradiance(deltaLight(3, d0));
    const ShCoefficients order5 = convolveIrradiance(deltaLight(5, d0));
    EXPECT_NEAR(evaluate(order3, d0).r, 17.0 / 16.0, kEvaluationError);
    EXPECT_NEAR(evaluate(order3, -d0).r, 1.0 / 16.0, kEvaluationError);
    EXPECT_NEAR(evaluate(order5, d0).r, 31.0 / 32.0, kEvaluationError);
    EXPECT_NEAR(evaluate(order5, -d0).r, -1.0 / 32.0, kEvaluationError);
}

// Checks: convolution multiplies band l by A_l and nothing else, and keeps the order.
TEST(Irradiance, ConvolutionScalesEachBand) {
    ShCoefficients radiance = makeCoefficients(4, Quantity::Radiance);
    for (size_t i = 0; i < radiance.rgb.size(); ++i)
        radiance.rgb[i] = glm::dvec3(double(i) + 1.0, -2.0, 0.5);
    const ShCoefficients irradiance = convolveIrradiance(radiance);
    ASSERT_EQ(irradiance.order, 4);
    ASSERT_EQ(irradiance.rgb.size(), radiance.rgb.size());
    for (size_t i = 0; i < radiance.rgb.size(); ++i) {
        const glm::dvec3 expected = radiance.rgb[i] * irradianceBandFactor(shBand(int(i)));
        EXPECT_EQ(irradiance.rgb[i], expected) << "i = " << i;
    }
}

// Checks: convolving irradiance again, or a probe whose size disagrees with its order, is an input error.
TEST(Irradiance, InvalidInputThrows) {
    const ShCoefficients irradiance = makeCoefficients(3, Quantity::Irradiance);
    try {
        convolveIrradiance(irradiance);
        ADD_FAILURE() << "convolving irradiance did not throw";
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Input);
    }
    ShCoefficients wrongSize = makeCoefficients(3, Quantity::Radiance);
    wrongSize.rgb.pop_back();
    EXPECT_THROW(convolveIrradiance(wrongSize), Error);
    EXPECT_THROW(evaluate(wrongSize, glm::dvec3(0, 0, 1)), Error);
}

} // namespace
} // namespace shprobe
