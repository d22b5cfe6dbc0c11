// CPU side of the render shaders (no device): the basis polynomials and their constants, the
// folding of probes (checked by evaluating the folded terms the way sh_irradiance.glsl does, in
// double), the non-linear L1 model's properties (Geomerics), Sloan's "Stupid SH Tricks" facts for a delta
// light on the references, the sun's exact irradiance (against quadrature, and the fp32 code the shaders run,
// sun_light.h, against it), and the errors for probes the renderer cannot use.
#include "common/error.h"
#include "glsl/sun_light.h"
#include "render/probe_shading.h"
#include "render/scene.h"
#include "sh/basis.h"
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
    // Sloan's shader constants with the 1/pi of the Lambertian BRDF ("Stupid SH Tricks"): c1 = A_1 K_1 / pi =
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
    // Sloan ("Stupid SH Tricks"): order 3 gives 17/16 at the pole and 1/16 opposite; order 5 gives 31/32 and
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
            // The model's range is 4 |R1| (Geomerics); random normals come within ~1% of the extremes.
            EXPECT_NEAR(highest[c] - lowest[c], 4.0 * glm::length(r1), 0.02 * 4.0 * l1.r0[c] + 1e-12) << c;
        }
    }
}

TEST(RenderShading, LinearL1GoesNegativeWhereTheNonLinearModelDoesNot) {
    // A delta light: R1 = R0, the linear model R0 + 2 R1.n reaches -R0 opposite the light (Geomerics' L1
    // notes).
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

// ---- The sun: exact irradiance of a uniform cap ----------------------------------------------

double degrees(double d) {
    return d * kPi / 180.0;
}

// E / L of a cap of radius r at angle theta from the normal, by quadrature, independent of the
// closed form: around the cap's centre, directions at polar angle beta <= r and azimuth phi have
// n.w = a + b cos(phi), a = cos(theta) cos(beta), b = sin(theta) sin(beta) >= 0, and the azimuthal
// integral of max(0, a + b cos(phi)) is exact: 2 pi a (a >= b), 0 (a <= -b), else
// 2 (a acos(-a/b) + sqrt(b^2 - a^2)), whose first derivative in a is continuous. The midpoint rule in
// beta (weight sin(beta)) then converges as h^2: 20000 steps give ~1e-10 relative.
double capIrradianceByQuadrature(double cosTheta, double r) {
    const int steps = 20000;
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta)), h = r / steps;
    double sum = 0.0;
    for (int k = 0; k < steps; ++k) {
        double beta = (k + 0.5) * h;
        double a = cosTheta * std::cos(beta), b = sinTheta * std::sin(beta);
        double azimuthal = a >= b    ? 2.0 * kPi * a
                           : a <= -b ? 0.0
                                     : 2.0 * (a * std::acos(-a / b) + std::sqrt(b * b - a * a));
        sum += azimuthal * std::sin(beta);
    }
    return sum * h;
}

const double kSunRadiiDegrees[] = {0.25, 0.5, 1.146, 3.0, 10.0, 20.0, 26.0, 27.0, 45.0, 60.0, 89.0, 90.0};

TEST(RenderShading, SunIrradianceIsTheExactIrradianceOfACap) {
    double worst = 0.0;
    for (double radiusDegrees : kSunRadiiDegrees) {
        const double r = degrees(radiusDegrees), s = std::sin(r), peak = kPi * s * s;
        std::vector<double> cosines = {-1.0, -0.5, 0.0, 0.3, 0.7, 1.0};
        for (int k = -10; k <= 10; ++k)
            cosines.push_back(std::clamp(s * k / 9.0, -1.0, 1.0));
        for (double e : cosines) {
            double closed = sphericalCapIrradiance(e, r), quadrature = capIrradianceByQuadrature(e, r);
            worst = std::max(worst, std::abs(closed - quadrature) / peak);
            EXPECT_NEAR(closed, quadrature, 1e-8 * peak) << "radius " << radiusDegrees << " deg, cos " << e;
            if (e * e >= s * s) {
                EXPECT_NEAR(closed, peak * std::max(e, 0.0), 1e-15 * peak) << "whole cap above or below";
            }
        }
        // At the terminator (theta = 90 degrees) half the cap is up: r - sin r cos r exactly.
        EXPECT_NEAR(sphericalCapIrradiance(0.0, r), r - s * std::cos(r), 1e-12 * peak);
    }
    // A hemisphere of sky: pi (1 + cos theta) / 2.
    for (double e : {-0.9, -0.2, 0.0, 0.5, 0.99})
        EXPECT_NEAR(sphericalCapIrradiance(e, 0.5 * kPi), 0.5 * kPi * (1.0 + e), 1e-14);
    std::printf("  closed form vs quadrature: worst %.2e of the peak pi sin^2 r\n", worst);
}

// The fp32 code of sun_light.h (the shaders run the same source) against the double closed form, at
// the same fp32 cosine, densely across the terminator. Errors relative to the peak s^2 (E/pi per
// unit radiance): the fp32 rounding of sin r, cos r and sin^2 r (foldSun) moves the result by
// ~1e-7 of it; every term is of the size of the result (no cancellation), so a few ulps more.
TEST(RenderShading, SunFp32CodeMatchesTheClosedForm) {
    for (double radiusDegrees : kSunRadiiDegrees) {
        const double r = degrees(radiusDegrees), s = std::sin(r);
        SphericalLight light{glm::dvec3(0.0, 0.0, 1.0), r, glm::dvec3(1.0)};
        const glm::vec4 shape = foldSun(light).shape;
        double worst = 0.0;
        auto check = [&](double cosine) {
            float e = float(std::clamp(cosine, -1.0, 1.0));
            double fp32 = glsl::sunCapIrradianceOverPi(e, shape);
            double reference = sphericalCapIrradiance(double(e), r) / kPi;
            ASSERT_TRUE(std::isfinite(fp32)) << "cos " << e << " radius " << radiusDegrees;
            double error = std::abs(fp32 - reference) / (s * s);
            worst = std::max(worst, error);
        };
        for (int k = 0; k <= 20000; ++k)
            check(-1.0 + 2.0 * k / 20000.0);
        for (int k = 0; k <= 20000; ++k)
            check(s * (-1.05 + 2.1 * k / 20000.0));
        std::printf("  radius %6.3f deg: fp32 vs double worst %.2e of sin^2 r\n", radiusDegrees, worst);
        EXPECT_LT(worst, 3e-7) << "radius " << radiusDegrees;
    }
}

TEST(RenderShading, SunFoldsAndIsAddedByMode) {
    SphericalLight sun{glm::dvec3(0.0, 3.0, 4.0), degrees(2.0), glm::dvec3(100.0, 50.0, 0.0)};
    ShCoefficients probe = makeCoefficients(3, Quantity::Radiance);
    ProbeShading plain = foldProbe(probe, 3, "plain.json");
    EXPECT_FALSE(plain.sun.has_value());
    EXPECT_EQ(plain.foldedSun.direction.w, 0.0f) << "no sun: the shaders add nothing";
    EXPECT_EQ(glsl::sunShading(plain.foldedSun, SHPROBE_SHADING_IRRADIANCE, glm::vec3(0, 0, 1), glm::vec3(1)),
              glm::vec3(0.0f));

    ProbeShading sunny = foldProbe(probe, 3, "sunny.json", sun);
    ASSERT_TRUE(sunny.sun.has_value());
    EXPECT_NEAR(glm::length(sunny.sun->direction), 1.0, 1e-15);
    EXPECT_EQ(sunny.foldedSun.direction, glm::vec4(0.0f, 0.6f, 0.8f, 1.0f));
    const double s = std::sin(sun.angularRadius);
    EXPECT_FLOAT_EQ(sunny.foldedSun.shape.z, float(s * s));
    EXPECT_FLOAT_EQ(sunny.foldedSun.shape.w, float(2.0 - 2.0 * std::cos(sun.angularRadius)));

    const glm::dvec3 d(0.0, 0.6, 0.8);
    // Facing the sun: E / pi = L sin^2 r; the disc shows L inside and nothing outside.
    glm::dvec3 facing = sunShadeReference(*sunny.sun, ShadingMode::Irradiance, d);
    EXPECT_NEAR(facing.r, 100.0 * s * s, 1e-12);
    EXPECT_EQ(sunShadeReference(*sunny.sun, ShadingMode::L1NonLinear, d), facing);
    EXPECT_EQ(sunShadeReference(*sunny.sun, ShadingMode::Radiance, d), sun.radiance);
    glm::dvec3 outside = glm::normalize(d + glm::dvec3(0.05, 0.0, 0.0)); // 2.9 degrees away
    EXPECT_EQ(sunShadeReference(*sunny.sun, ShadingMode::Radiance, outside), glm::dvec3(0.0));
    glm::vec3 albedo(0.5f);
    EXPECT_EQ(glsl::sunShading(sunny.foldedSun, SHPROBE_SHADING_RADIANCE, glm::vec3(d), albedo),
              glm::vec3(100.0f, 50.0f, 0.0f));
    EXPECT_NEAR(glsl::sunShading(sunny.foldedSun, SHPROBE_SHADING_L1_NONLINEAR, glm::vec3(d), albedo).r,
                0.5 * 100.0 * s * s, 1e-6 * 100.0 * s * s);

    // The sun's power counts in the automatic exposure: its mean over the sphere, L Omega / (4 pi).
    ShCoefficients dark = makeCoefficients(3, Quantity::Radiance);
    double meanLuminance = glm::dot(sun.radiance, glm::dvec3(0.2126, 0.7152, 0.0722)) *
                           capSolidAngle(sun.angularRadius) / (4.0 * kPi);
    EXPECT_FLOAT_EQ(autoExposure(dark, sun), float(0.5 / meanLuminance));
    EXPECT_EQ(autoExposure(dark), 1.0f);

    for (double badRadius : {0.0, -0.1, degrees(90.5)}) {
        SphericalLight bad = sun;
        bad.angularRadius = badRadius;
        EXPECT_THROW(foldProbe(probe, 3, "bad.json", bad), Error) << badRadius;
    }
    SphericalLight negative = sun;
    negative.radiance.g = -1.0;
    EXPECT_THROW(foldProbe(probe, 3, "bad.json", negative), Error);
    SphericalLight nowhere = sun;
    nowhere.direction = glm::dvec3(0.0);
    EXPECT_THROW(foldProbe(probe, 3, "bad.json", nowhere), Error);
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
