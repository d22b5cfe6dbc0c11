// Folding SH probes for the render shaders (sh_irradiance.glsl; the fold itself is sh/folding.h)
// and the double references of the shading modes.
#include "render/probe_shading.h"

#include "common/counted.h"
#include "common/error.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <span>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;

static_assert(kFoldedCount == SHPROBE_FOLDED_COUNT, "the uniforms hold the folded coefficients");

std::array<glm::vec4, SHPROBE_FOLDED_COUNT> toUniform(const FoldedCoefficients& c) {
    std::array<glm::vec4, SHPROBE_FOLDED_COUNT> folded{};
    for (size_t i = 0; i < c.size(); ++i)
        folded[i] = glm::vec4(glm::vec3(c[i]), 0.0f);
    return folded;
}

// E_00 y_00 / pi = L_00 y_00 whatever the quantity: the mean of E / pi over the sphere.
glm::dvec3 meanRadiance(const ShCoefficients& probe) {
    double y00 = basisPolynomialScale(0);
    return probe.quantity == Quantity::Radiance ? probe.rgb[0] * y00 : probe.rgb[0] * y00 / kPi;
}

// The shaders sum terms in float, each a value times a low-degree polynomial in the normal
// (|3 z^2 - 1| <= 2 and the like) or a transfer entry of at most a few units: sums of magnitudes up
// to a 16th of float's largest leave that headroom. NaN fails the test too.
bool withinFloatShading(const glm::dvec3& sumOfMagnitudes) {
    const double limit = std::numeric_limits<float>::max() / 16.0;
    return glm::all(glm::lessThanEqual(sumOfMagnitudes, glm::dvec3(limit)));
}

[[noreturn]] void failFloatRange(const std::string& name) {
    throw Error(ErrorKind::Input, name +
                                      ": its light is past the float range the shaders take (a coefficient "
                                      "or the sun's radiance within a factor of 16 of 3.4e38, or above)");
}

// A probe whose folded sums could pass float's range would be drawn as infinity; a sun's irradiance
// is at most pi times its radiance.
void requireFloatShading(const ProbeShading& shading, const std::string& name) {
    auto within = [](std::span<const glm::vec4> values, double scale) {
        glm::dvec3 sum(0.0);
        for (const glm::vec4& value : values)
            sum += glm::abs(glm::dvec3(glm::vec3(value)));
        return withinFloatShading(sum * scale);
    };
    if (!within(shading.irradiance, 1.0) || (shading.hasRadiance && !within(shading.radiance, 1.0)) ||
        !within(shading.l1, 1.0) || !within(std::span(&shading.foldedSun.radiance, 1), kPi))
        failFloatRange(name);
}

} // namespace

const char* shadingModeName(ShadingMode mode) {
    switch (mode) {
    case ShadingMode::Radiance:
        return "radiance";
    case ShadingMode::Irradiance:
        return "irradiance";
    case ShadingMode::L1NonLinear:
        return "l1-nonlinear";
    }
    return "?";
}

ShadingMode parseShadingMode(const std::string& name) {
    for (ShadingMode mode : {ShadingMode::Radiance, ShadingMode::Irradiance, ShadingMode::L1NonLinear})
        if (name == shadingModeName(mode)) return mode;
    throw Error(ErrorKind::Input, "unknown mode '" + name + "' (radiance, irradiance or l1-nonlinear)");
}

glsl::RenderSun foldSun(const SphericalLight& sun) {
    const double r = sun.angularRadius, s = std::sin(r), half = std::sin(0.5 * r);
    glsl::RenderSun folded{};
    folded.direction = glm::vec4(glm::vec3(glm::normalize(sun.direction)), 1.0f);
    folded.radiance = glm::vec4(glm::vec3(sun.radiance), 0.0f);
    folded.shape = glm::vec4(float(s), float(std::cos(r)), float(s * s), float(4.0 * half * half));
    return folded;
}

void requireFloatLight(const ShCoefficients& light, const std::string& name) {
    glm::dvec3 sum(0.0);
    for (const glm::dvec3& coefficient : light.rgb)
        sum += glm::abs(coefficient);
    if (!withinFloatShading(sum)) failFloatRange(name);
}

ProbeShading foldProbe(const ShCoefficients& probe, int order, const std::string& name,
                       const std::optional<SphericalLight>& sun) {
    if (order < 1 || order > kMaxRenderOrder)
        throw Error(ErrorKind::Input, "render order " + std::to_string(order) + " is outside 1.." +
                                          std::to_string(kMaxRenderOrder));
    if (probe.order < order)
        throw Error(ErrorKind::Input, name + ": the probe has order " + std::to_string(probe.order) + " (" +
                                          counted(coefficientCount(probe.order), "coefficient") +
                                          "); order " + std::to_string(order) + " needs " +
                                          std::to_string(coefficientCount(order)) +
                                          " (bake it with --order " + std::to_string(order) + ")");
    ProbeShading shading;
    shading.order = order;
    std::optional<FoldedCoefficients> radiance = foldCoefficients(probe, order, FoldedQuantity::Radiance);
    shading.hasRadiance = radiance.has_value();
    if (radiance) shading.radiance = toUniform(*radiance);
    shading.irradiance = toUniform(*foldCoefficients(probe, order, FoldedQuantity::IrradianceOverPi));

    // The L1 model needs L_00 and L_1m, which any probe of order >= 2 gives (A_0, A_1 != 0).
    if (probe.order >= 2) {
        RenormalizedL1 l1 = renormalizedL1(*radianceOf(probe, 2));
        shading.l1[0] = glm::vec4(glm::vec3(l1.r0), 0.0f);
        for (int axis = 0; axis < 3; ++axis)
            shading.l1[size_t(axis) + 1] = glm::vec4(glm::vec3(l1.r1[axis]), 0.0f);
    } else {
        shading.l1[0] = glm::vec4(glm::vec3(meanRadiance(probe)), 0.0f); // no L1: ambient only
    }
    if (sun) {
        const glm::dvec3& d = sun->direction;
        const glm::dvec3& sunRadiance = sun->radiance;
        bool finite = std::isfinite(d.x) && std::isfinite(d.y) && std::isfinite(d.z) &&
                      std::isfinite(sunRadiance.r) && std::isfinite(sunRadiance.g) &&
                      std::isfinite(sunRadiance.b);
        if (!finite || glm::length(d) == 0.0 || !std::isfinite(glm::length(d)) ||
            glm::any(glm::lessThan(sunRadiance, glm::dvec3(0.0))) || !(sun->angularRadius > 0.0) ||
            sun->angularRadius > 0.5 * kPi)
            throw Error(ErrorKind::Input, name + ": the sun needs a direction, a finite radiance >= 0 and an "
                                                 "angular radius in (0, 90] degrees");
        shading.sun = SphericalLight{glm::normalize(d), sun->angularRadius, sunRadiance};
        shading.foldedSun = foldSun(*shading.sun);
    }
    requireFloatShading(shading, name);
    return shading;
}

// R0 = (1/4pi) int L = L_00 y_00 (y_00 = 1/sqrt(4pi)); R1 = (1/4pi) int L w, and since
// y_1-1 = -k y, y_10 = k z, y_11 = -k x with k = sqrt(3/4pi), int L w = (-L_11, -L_1-1, L_10) / k.
RenormalizedL1 renormalizedL1(const ShCoefficients& radiance) {
    if (radiance.quantity != Quantity::Radiance || radiance.order < 2)
        throw Error(ErrorKind::Input, "the L1 model needs radiance coefficients of order 2 or more");
    const double k = std::sqrt(3.0 / (4.0 * kPi));
    const double toR1 = 1.0 / (4.0 * kPi * k);
    RenormalizedL1 l1;
    l1.r0 = radiance.rgb[0] * basisPolynomialScale(0);
    l1.r1[0] = -radiance.rgb[3] * toR1;
    l1.r1[1] = -radiance.rgb[1] * toR1;
    l1.r1[2] = radiance.rgb[2] * toR1;
    return l1;
}

// Geomerics' non-linear L1 model (their notes on SH irradiance), per channel: R0 (a + (1 - a)(p + 1) q^p).
glm::dvec3 l1NonLinearOverPi(const ShCoefficients& radiance, const glm::dvec3& n) {
    RenormalizedL1 l1 = renormalizedL1(radiance);
    glm::dvec3 result(0.0);
    for (int c = 0; c < 3; ++c) {
        double r0 = l1.r0[c];
        glm::dvec3 r1(l1.r1[0][c], l1.r1[1][c], l1.r1[2][c]);
        if (r0 <= 0.0) continue;
        double length1 = glm::length(r1);
        double r = std::min(length1 / r0, 1.0);
        double q = length1 > 0.0 ? std::clamp(0.5 + 0.5 * glm::dot(r1, n) / length1, 0.0, 1.0) : 0.5;
        double p = 1.0 + 2.0 * r;
        double a = (1.0 - r) / (1.0 + r);
        result[c] = r0 * (a + (1.0 - a) * (p + 1.0) * std::pow(q, p));
    }
    return result;
}

glm::dvec3 shadeReference(const ShCoefficients& radiance, ShadingMode mode, int order, const glm::dvec3& n) {
    switch (mode) {
    case ShadingMode::Radiance:
        return evaluate(truncateOrder(radiance, order), n);
    case ShadingMode::Irradiance:
        return evaluate(convolveIrradiance(truncateOrder(radiance, order)), n) / kPi;
    case ShadingMode::L1NonLinear:
        return l1NonLinearOverPi(radiance, n);
    }
    return glm::dvec3(0.0);
}

// Snyder (1996), in the form of Lagarde & de Rousiers (2014, sphere area lights); see sun_light.h.
double sphericalCapIrradiance(double cosTheta, double angularRadius) {
    const double s = std::sin(angularRadius), s2 = s * s;
    const double e = std::clamp(cosTheta, -1.0, 1.0);
    if (e * e >= s2) return kPi * s2 * std::max(e, 0.0);
    const double sinTheta = std::sqrt(1.0 - e * e);
    const double x = std::sqrt(1.0 / s2 - 1.0); // cot r
    const double y = std::clamp(-x * e / sinTheta, -1.0, 1.0);
    const double q = sinTheta * std::sqrt(1.0 - y * y);
    return std::max((e * std::acos(y) - x * q) * s2 + std::atan(q / x), 0.0);
}

glm::dvec3 sunShadeReference(const SphericalLight& sun, ShadingMode mode, const glm::dvec3& n) {
    const glm::dvec3 d = glm::normalize(sun.direction);
    if (mode == ShadingMode::Radiance) {
        const double half = std::sin(0.5 * sun.angularRadius);
        return glm::dot(n - d, n - d) <= 4.0 * half * half ? sun.radiance : glm::dvec3(0.0);
    }
    return sun.radiance * sphericalCapIrradiance(glm::dot(n, d), sun.angularRadius) / kPi;
}

float autoExposure(const ShCoefficients& probe, const std::optional<SphericalLight>& sun) {
    // A white surface under uniform radiance L reflects L: map the mean radiance to 0.5 before the
    // filmic curve, which leaves room for the brighter side of a lit sphere.
    constexpr double kMidGrey = 0.5;
    glm::dvec3 mean = meanRadiance(probe);
    if (sun) mean += sun->radiance * capSolidAngle(sun->angularRadius) / (4.0 * kPi);
    double luminance = glm::dot(mean, glm::dvec3(0.2126, 0.7152, 0.0722));
    return luminance > 0.0 && std::isfinite(luminance) ? float(kMidGrey / luminance) : 1.0f;
}

} // namespace shprobe
