// Windows, de-ringing, and the papers' facts about truncated irradiance: Sloan's order-3 and
// order-5 lobes ("Stupid SH Tricks"), Lisle-Huang's H_2n recurrence for A_l ("Algorithms for
// Spherical Harmonic Lighting"), and the L1 antipodal identity of Geomerics' notes ("Odd terms in
// the SH irradiance expansion").
#include "common/error.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/projection.h"
#include "sh/windowing.h"
#include "test_support.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace shprobe {
namespace {

using testing::expectInputError;

constexpr double kPi = std::numbers::pi;
constexpr double kDegree = kPi / 180.0;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Window factors and exact fractions: one cosine or sine and a division.
constexpr double kFormulaError = 1e-12;
// Sums of at most 64 products of order-1 values.
constexpr double kEvaluationError = 1e-12;
// The independent dense check of de-ringing: 200,000 directions; the de-ringed minimum sits at 0
// and the pattern search places it within ~1e-9 rad, where the function is flat to ~1e-16.
constexpr int kDenseSamples = 200000;
constexpr double kNonNegativeTolerance = 1e-12;

const glm::dvec3 kSunDirection = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));

// The sky the de-ringing tests use: uniform radiance 0.2 plus a sun of radius 0.5 degree and power 50
// (radiance about 2.1e5), built analytically; unwindowed, its expansion goes negative.
ShCoefficients skyWithSun(int order) {
    ShCoefficients radiance = makeCoefficients(order, Quantity::Radiance);
    addAmbient(radiance, glm::dvec3(0.2, 0.25, 0.3));
    const double radius = 0.5 * kDegree;
    addSphericalLight(radiance, SphericalLight{kSunDirection, radius,
                                               glm::dvec3(50.0, 45.0, 40.0) / capSolidAngle(radius)});
    return radiance;
}

glm::dvec3 fibonacciDirection(int k, int n) {
    const double goldenAngle = kPi * (3.0 - std::sqrt(5.0));
    const double z = 1.0 - (2.0 * k + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(goldenAngle * k), r * std::sin(goldenAngle * k), z};
}

// Smallest channel value over kDenseSamples directions (no refinement): the independent check.
double denseMinimum(const ShCoefficients& c) {
    double minimum = kInfinity;
    for (int k = 0; k < kDenseSamples; ++k) {
        const glm::dvec3 v = evaluate(c, fibonacciDirection(k, kDenseSamples));
        minimum = std::min({minimum, v.r, v.g, v.b});
    }
    return minimum;
}

// --- Windows ------------------------------------------------------------------------------------

// Checks: every window keeps band 0 (factor 1, L00 unchanged), for both kinds and many widths.
TEST(Windowing, WindowsLeaveL0Unchanged) {
    const ShCoefficients radiance = skyWithSun(kMaxOrder);
    for (WindowKind kind : {WindowKind::Hanning, WindowKind::Lanczos}) {
        for (double width : {0.3, 1.0, 2.5, 4.0, 9.0, 1e6}) {
            const std::vector<double> factors = windowFactors(kind, width, kMaxOrder);
            ASSERT_EQ(factors.size(), size_t(kMaxOrder));
            EXPECT_EQ(factors[0], 1.0);
            EXPECT_EQ(applyWindow(radiance, factors).rgb[0], radiance.rgb[0]) << "width " << width;
        }
    }
}

// Checks: strength zero (infinite width) is the identity, factor for factor and coefficient for
// coefficient.
TEST(Windowing, ZeroStrengthIsIdentity) {
    const ShCoefficients radiance = skyWithSun(kMaxOrder);
    for (WindowKind kind : {WindowKind::Hanning, WindowKind::Lanczos}) {
        const std::vector<double> factors = windowFactors(kind, kInfinity, kMaxOrder);
        for (double f : factors)
            EXPECT_EQ(f, 1.0);
        const ShCoefficients windowed = applyWindow(radiance, factors);
        for (size_t i = 0; i < radiance.rgb.size(); ++i)
            EXPECT_EQ(windowed.rgb[i], radiance.rgb[i]) << "i = " << i;
    }
}

// Checks values worked out by hand at width 4: Hanning (1 + cos(pi l/4))/2 = 1, (2 + sqrt 2)/4,
// 1/2, (2 - sqrt 2)/4, 0; Lanczos sin(pi l/4)/(pi l/4) = 1, 2 sqrt 2/pi, 2/pi, 2 sqrt 2/(3 pi), 0;
// both 0 beyond the width; width 1 keeps band 0 alone.
TEST(Windowing, KnownValues) {
    const std::vector<double> hanning = windowFactors(WindowKind::Hanning, 4.0, 6);
    const std::vector<double> lanczos = windowFactors(WindowKind::Lanczos, 4.0, 6);
    const double sqrt2 = std::numbers::sqrt2;
    const double expectedHanning[] = {1.0, (2.0 + sqrt2) / 4.0, 0.5, (2.0 - sqrt2) / 4.0, 0.0, 0.0};
    const double expectedLanczos[] = {1.0, 2.0 * sqrt2 / kPi, 2.0 / kPi, 2.0 * sqrt2 / (3.0 * kPi), 0.0, 0.0};
    for (size_t l = 0; l < 6; ++l) {
        EXPECT_NEAR(hanning[l], expectedHanning[l], kFormulaError) << "Hanning l = " << l;
        EXPECT_NEAR(lanczos[l], expectedLanczos[l], kFormulaError) << "Lanczos l = " << l;
    }
    for (WindowKind kind : {WindowKind::Hanning, WindowKind::Lanczos}) {
        const std::vector<double> one = windowFactors(kind, 1.0, kMaxOrder);
        for (size_t l = 1; l < one.size(); ++l)
            EXPECT_EQ(one[l], 0.0) << "l = " << l;
    }
}

// --- The papers' facts --------------------------------------------------------------------------

// The order-n irradiance of a unit-power delta light from d0.
ShCoefficients deltaIrradiance(int order) {
    ShCoefficients radiance = makeCoefficients(order, Quantity::Radiance);
    addDirectionalLight(radiance,
                        DirectionalLight{kSunDirection, glm::dvec3(1.0), DirectionalNormalization::Power});
    return convolveIrradiance(radiance);
}

// Checks Sloan's facts ("Stupid SH Tricks") on the irradiance of a delta light,
// E(t) = sum_l A_l (2l+1)/(4 pi) P_l(t), t = n.d. Order 3: E = 3/32 + t/2 + 15 t^2/32, which gives 17/16
// facing the light (a 1/16 overshoot) and 1/16 opposite (the back lobe: "17 against 1"); it also dips to
// -19/480 at t = -8/15, which minimumOnSphere must find. Order 5 adds -3/32 P_4(t): 31/32 facing and -1/32
// opposite ("a -1 lobe against a peak of 31"), which is also its minimum.
TEST(Windowing, SloanTruncatedClampedCosineFacts) {
    const ShCoefficients order3 = deltaIrradiance(3);
    EXPECT_NEAR(evaluate(order3, kSunDirection).r, 17.0 / 16.0, kEvaluationError);
    EXPECT_NEAR(evaluate(order3, kSunDirection).r - 1.0, 1.0 / 16.0, kEvaluationError);
    EXPECT_NEAR(evaluate(order3, -kSunDirection).r, 1.0 / 16.0, kEvaluationError);
    const SphereMinimum minimum = minimumOnSphere(order3);
    EXPECT_NEAR(minimum.value, -19.0 / 480.0, kEvaluationError);
    EXPECT_NEAR(glm::dot(minimum.direction, kSunDirection), -8.0 / 15.0,
                1e-6); // the minimum is flat: sqrt(1e-12)

    const ShCoefficients order5 = deltaIrradiance(5);
    const double peak = evaluate(order5, kSunDirection).r, back = evaluate(order5, -kSunDirection).r;
    EXPECT_NEAR(peak, 31.0 / 32.0, kEvaluationError);
    EXPECT_NEAR(back, -1.0 / 32.0, kEvaluationError);
    EXPECT_NEAR(peak / back, -31.0, 1e-9);
    const SphereMinimum minimum5 = minimumOnSphere(order5); // the -1 lobe is the minimum, at -d
    EXPECT_NEAR(minimum5.value, -1.0 / 32.0, kEvaluationError);
    EXPECT_NEAR(glm::dot(minimum5.direction, kSunDirection), -1.0, 1e-6);
}

// Checks Lisle & Huang's H_2n recurrence ("Algorithms for Spherical Harmonic Lighting", eq. 10),
// H_0 = 1, H_2n+2 = (1/2 - n)/(2 + n) H_2n, with H_1 = 2/3 and H_l = 0 for odd l > 1, against the
// closed form of docs/conventions.md: A_l = pi H_l for l <= 8.
TEST(Windowing, HRecurrenceGivesBandFactors) {
    std::array<double, 9> h{};
    h[0] = 1.0;
    h[1] = 2.0 / 3.0;
    for (int n = 0; 2 * n + 2 <= 8; ++n)
        h[size_t(2 * n + 2)] = (0.5 - n) / (2.0 + n) * h[size_t(2 * n)];
    for (int l = 0; l <= 8; ++l)
        EXPECT_NEAR(kPi * h[size_t(l)], irradianceBandFactor(l), kFormulaError) << "l = " << l;
}

// An environment that is not band-limited: sky, a sun disc and a bright patch, drawn at face size 32.
Cubemap testEnvironment() {
    constexpr int kFaceSize = 32;
    Cubemap cubemap = makeCubemap(kFaceSize);
    const glm::dvec3 patch = glm::normalize(glm::dvec3(-1.0, 0.2, -0.4));
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < kFaceSize; ++j) {
            for (int i = 0; i < kFaceSize; ++i) {
                const glm::dvec3 w = texelDirection(face, i, j, kFaceSize);
                glm::dvec3 value(0.3, 0.4, 0.6);
                if (glm::dot(w, kSunDirection) > std::cos(5.0 * kDegree))
                    value += glm::dvec3(300.0, 280.0, 250.0);
                if (glm::dot(w, patch) > 0.7) value += glm::dvec3(2.0, 1.0, 0.2);
                cubemap.at(face, i, j) = glm::vec4(glm::vec3(value), 1.0f);
            }
        }
    }
    return cubemap;
}

// Exact irradiance of the cube map's texels, E(n) = sum max(0, n.w) L(w) Omega (red channel).
double exactIrradiance(const Cubemap& cubemap, const glm::dvec3& n) {
    double sum = 0.0;
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < cubemap.faceSize; ++j) {
            for (int i = 0; i < cubemap.faceSize; ++i) {
                const double cosine = glm::dot(n, texelDirection(face, i, j, cubemap.faceSize));
                sum += std::max(0.0, cosine) * cubemap.at(face, i, j).r *
                       texelSolidAngle(i, j, cubemap.faceSize);
            }
        }
    }
    return sum;
}

// Checks the antipodal identity of Geomerics' "Odd terms in the SH irradiance expansion",
// n.R1 = (I(n) - I(-n)) / 4, with its renormalized units R1 = 1/(4 pi) integral w R(w) and
// I(n) = (1/pi) integral_H n.w R(w) = E(n)/pi. In our units R1 = (-L11, -L1-1, L10) / (4 pi c),
// c = sqrt(3/(4 pi)). It holds for any environment because max(0, t) - max(0, -t) = t; so the odd
// part of the SH irradiance, which is only band 1 (A_l = 0 for odd l > 1), is exact at any order even where
// E_sh(n) itself is not: on a sky with a sun, at order 3, measured |E_sh(n) - E(n)| up to 0.48 (9.33
// against 8.85) while both sides of the identity agree to 4e-14.
TEST(Windowing, L1AntipodalIdentity) {
    constexpr double kIdentityError = 1e-12; // sums over 6144 texels of terms up to ~1
    const Cubemap cubemap = testEnvironment();
    const ShCoefficients radiance = projectCubemap(cubemap, 3);
    const ShCoefficients irradiance = convolveIrradiance(radiance);
    const double c = std::sqrt(3.0 / (4.0 * kPi));
    const glm::dvec3 r1 =
        glm::dvec3(-radiance.rgb[3].r, -radiance.rgb[1].r, radiance.rgb[2].r) / (4.0 * kPi * c);
    double largestEvenError = 0.0;
    for (const glm::dvec3& n : {glm::dvec3(0, 0, 1), kSunDirection, glm::normalize(glm::dvec3(-1, 0.3, 0.2)),
                                glm::normalize(glm::dvec3(0.5, 0.5, -0.7))}) {
        const double plus = exactIrradiance(cubemap, n), minus = exactIrradiance(cubemap, -n);
        EXPECT_NEAR(glm::dot(n, r1), (plus - minus) / kPi / 4.0, kIdentityError);
        const double shPlus = evaluate(irradiance, n).r, shMinus = evaluate(irradiance, -n).r;
        EXPECT_NEAR(shPlus - shMinus, plus - minus, kIdentityError);
        largestEvenError = std::max(largestEvenError, std::abs(shPlus - plus));
    }
    EXPECT_GT(largestEvenError, 0.1); // not a truism: E_sh itself is off
}

// --- De-ringing ---------------------------------------------------------------------------------

struct DeringCase {
    int order;
    WindowKind window;
    DeringTarget target;
};

ShCoefficients windowedTarget(const ShCoefficients& radiance, const DeringCase& test, double width) {
    const ShCoefficients windowed = applyWindow(radiance, windowFactors(test.window, width, test.order));
    return test.target == DeringTarget::Irradiance ? convolveIrradiance(windowed) : windowed;
}

// Checks Sloan's de-ringing on the sky with a sun: without a window the target goes negative on a
// dense set of 200,000 directions; with the window found it does not; and no weaker window is
// non-negative: none on a grid of 256 strengths below it (4 times finer than the library's scan),
// and not the one 2 tolerances weaker (the bisection's boundary).
void checkDeringing(const DeringCase& test) {
    constexpr int kCheckedStrengths = 256;
    const ShCoefficients radiance = skyWithSun(test.order);
    EXPECT_LT(denseMinimum(windowedTarget(radiance, test, kInfinity)), 0.0);

    const DeringOptions options{.window = test.window, .target = test.target};
    const DeringResult result = deringWindow(radiance, options);
    ASSERT_TRUE(std::isfinite(result.width));
    EXPECT_GE(result.minimum, 0.0);
    const ShCoefficients windowed = applyWindow(radiance, result.bandFactors);
    EXPECT_GE(denseMinimum(test.target == DeringTarget::Irradiance ? convolveIrradiance(windowed) : windowed),
              -kNonNegativeTolerance);

    const double strength = 1.0 / result.width;
    for (int k = 1; k < kCheckedStrengths && double(k) / kCheckedStrengths < strength; ++k) {
        ASSERT_LT(minimumOnSphere(windowedTarget(radiance, test, kCheckedStrengths / double(k))).value, 0.0)
            << "strength " << k << "/" << kCheckedStrengths << " is non-negative, found " << strength;
    }
    const double weaker = 1.0 / (strength - 2.0 * options.strengthTolerance);
    EXPECT_LT(minimumOnSphere(windowedTarget(radiance, test, weaker)).value, 0.0);
}

// Measured (width found; minimum of the target before -> after, over the dense set):
// order 3 Hanning irradiance: width 2.07, -1.35 -> 7.6e-4 (the sun is 80 times the sky's
// irradiance: only a nearly linear probe stays positive);
// order 5 Hanning irradiance: width 8.49, -0.93 -> 2.1e-4, peak irradiance 49.1 -> 48.3;
// order 5 Lanczos irradiance: width 7.12, -0.93 -> 3.2e-4;
// order 5 Hanning radiance: width 1.68, -14.9 -> 3.2e-5;
// order 8 Hanning irradiance: width 24.4, -0.15 -> 7.0e-5.
TEST(Windowing, DeringIrradianceOrder3Hanning) {
    checkDeringing({3, WindowKind::Hanning, DeringTarget::Irradiance});
}
TEST(Windowing, DeringIrradianceOrder5Hanning) {
    checkDeringing({5, WindowKind::Hanning, DeringTarget::Irradiance});
}
TEST(Windowing, DeringIrradianceOrder5Lanczos) {
    checkDeringing({5, WindowKind::Lanczos, DeringTarget::Irradiance});
}
TEST(Windowing, DeringRadianceOrder5Hanning) {
    checkDeringing({5, WindowKind::Hanning, DeringTarget::Radiance});
}
TEST(Windowing, DeringIrradianceOrder8Hanning) {
    checkDeringing({8, WindowKind::Hanning, DeringTarget::Irradiance});
}

// Checks why de-ringing scans before it bisects: at order 5 the sky with a sun is non-negative for
// weak windows (strength 1/8.49 found), negative again at strength 0.3 (width 3.3), non-negative
// only from about 0.49 on. Plain bisection over [0, 1] would have stopped at width 2.07.
TEST(Windowing, NonNegativityIsNotMonotoneInStrength) {
    const DeringCase test{5, WindowKind::Hanning, DeringTarget::Irradiance};
    const ShCoefficients radiance = skyWithSun(test.order);
    const DeringResult result = deringWindow(radiance);
    EXPECT_GT(result.width, 5.0);
    EXPECT_LT(minimumOnSphere(windowedTarget(radiance, test, 1.0 / 0.3)).value, 0.0);
    EXPECT_GE(minimumOnSphere(windowedTarget(radiance, test, 1.0 / 0.6)).value, 0.0);
}

// Checks: a probe that is already non-negative gets the identity (infinite width).
TEST(Windowing, NonNegativeProbeNeedsNoWindow) {
    ShCoefficients radiance = makeCoefficients(5, Quantity::Radiance);
    addAmbient(radiance, glm::dvec3(1.0));
    addSphericalLight(radiance, SphericalLight{kSunDirection, 40.0 * kDegree, glm::dvec3(0.5)});
    const DeringResult result = deringWindow(radiance);
    EXPECT_EQ(result.width, kInfinity);
    for (double f : result.bandFactors)
        EXPECT_EQ(f, 1.0);
}

// Checks: widths <= 0 or NaN, too few factors, irradiance input to de-ringing and a negative mean
// radiance are input errors.
TEST(Windowing, InvalidInputThrows) {
    expectInputError([] { windowFactors(WindowKind::Hanning, 0.0, 3); }, "width 0");
    expectInputError([] { windowFactors(WindowKind::Lanczos, std::nan(""), 3); }, "NaN width");
    expectInputError([] { windowFactors(WindowKind::Hanning, 2.0, 0); }, "order 0");
    const ShCoefficients radiance = skyWithSun(5);
    const std::vector<double> tooFew = {1.0, 1.0};
    expectInputError([&] { applyWindow(radiance, tooFew); }, "too few factors");
    expectInputError([&] { deringWindow(convolveIrradiance(radiance)); }, "irradiance input");
    ShCoefficients negative = radiance;
    negative.rgb[0].g = -1.0;
    expectInputError([&] { deringWindow(negative); }, "negative mean");
    expectInputError([&] { minimumOnSphere(radiance, 0); }, "no samples");
}

} // namespace
} // namespace shprobe
