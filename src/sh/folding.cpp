// Folded SH coefficients. Basis polynomials: docs/conventions.md through l = 2, Sloan ("Stupid SH
// Tricks", appendix A2) and Brown ("Spherical Harmonic Basis Functions") with Sloan's Condon-Shortley
// signs for l = 3, 4.
#include "sh/folding.h"

#include "common/error.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;

// k_i of y_i = k_i p_i, i = l(l+1) + m, l <= 4. K_l^m of docs/conventions.md times the integer factors
// of the associated Legendre polynomials, with the (-1)^m phase on odd m.
const std::array<double, kFoldedCount>& polynomialScales() {
    static const std::array<double, kFoldedCount> scales = [] {
        const double s = std::sqrt(1.0 / kPi);
        return std::array<double, kFoldedCount>{
            0.5 * s,                           // 1
            -std::sqrt(3.0 / (4.0 * kPi)),     // y
            std::sqrt(3.0 / (4.0 * kPi)),      // z
            -std::sqrt(3.0 / (4.0 * kPi)),     // x
            0.5 * std::sqrt(15.0) * s,         // xy
            -0.5 * std::sqrt(15.0) * s,        // yz
            0.25 * std::sqrt(5.0) * s,         // 3z^2 - 1
            -0.5 * std::sqrt(15.0) * s,        // xz
            0.25 * std::sqrt(15.0) * s,        // x^2 - y^2
            -0.25 * std::sqrt(35.0 / 2.0) * s, // y (3x^2 - y^2)
            0.5 * std::sqrt(105.0) * s,        // xyz
            -0.25 * std::sqrt(21.0 / 2.0) * s, // y (5z^2 - 1)
            0.25 * std::sqrt(7.0) * s,         // z (5z^2 - 3)
            -0.25 * std::sqrt(21.0 / 2.0) * s, // x (5z^2 - 1)
            0.25 * std::sqrt(105.0) * s,       // z (x^2 - y^2)
            -0.25 * std::sqrt(35.0 / 2.0) * s, // x (x^2 - 3y^2)
            0.75 * std::sqrt(35.0) * s,        // xy (x^2 - y^2)
            -0.75 * std::sqrt(35.0 / 2.0) * s, // yz (3x^2 - y^2)
            0.75 * std::sqrt(5.0) * s,         // xy (7z^2 - 1)
            -0.75 * std::sqrt(5.0 / 2.0) * s,  // yz (7z^2 - 3)
            3.0 / 16.0 * s,                    // 35z^4 - 30z^2 + 3
            -0.75 * std::sqrt(5.0 / 2.0) * s,  // xz (7z^2 - 3)
            0.375 * std::sqrt(5.0) * s,        // (x^2 - y^2)(7z^2 - 1)
            -0.75 * std::sqrt(35.0 / 2.0) * s, // xz (x^2 - 3y^2)
            3.0 / 16.0 * std::sqrt(35.0) * s,  // x^2 (x^2 - 3y^2) - y^2 (3x^2 - y^2)
        };
    }();
    return scales;
}

constexpr int kY20 = 6; // flat index of y_20, split as in Sloan's shader

void requireIndex(int index) {
    if (index < 0 || index >= kFoldedCount)
        throw Error(ErrorKind::Input, "no basis polynomial " + std::to_string(index) + " (bands 0..4 only)");
}

// c_i = s_l k_i f_i, with Sloan's split of y_20.
FoldedCoefficients fold(const std::vector<glm::dvec3>& f, int order, double (*bandScale)(int)) {
    FoldedCoefficients c{};
    for (int i = 0; i < coefficientCount(order); ++i)
        c[size_t(i)] = bandScale(shBand(i)) * polynomialScales()[size_t(i)] * f[size_t(i)];
    if (order >= 3) {
        c[0] -= c[kY20]; // the constant of k (3z^2 - 1)
        c[kY20] *= 3.0;  // the z^2 term
    }
    return c;
}

double unitScale(int) {
    return 1.0;
}
double irradianceOverPiScale(int l) {
    return irradianceBandFactor(l) / kPi;
}

// Radiance-like values to fold with A_l / pi: the radiance, or E_lm / A_l (0 where A_l = 0, whose
// band the irradiance does not need).
std::vector<glm::dvec3> irradianceFoldInput(const ShCoefficients& probe, int order) {
    ShCoefficients truncated = truncateOrder(probe, order);
    if (probe.quantity == Quantity::Irradiance) {
        for (int i = 0; i < coefficientCount(order); ++i) {
            double a = irradianceBandFactor(shBand(i));
            truncated.rgb[size_t(i)] = a == 0.0 ? glm::dvec3(0.0) : truncated.rgb[size_t(i)] / a;
        }
    }
    return truncated.rgb;
}

} // namespace

double basisPolynomialScale(int index) {
    requireIndex(index);
    return polynomialScales()[size_t(index)];
}

double basisPolynomial(int index, const glm::dvec3& d) {
    requireIndex(index);
    const double x = d.x, y = d.y, z = d.z, x2 = x * x, y2 = y * y, z2 = z * z;
    const double p[kFoldedCount] = {1.0,
                                    y,
                                    z,
                                    x,
                                    x * y,
                                    y * z,
                                    3.0 * z2 - 1.0,
                                    x * z,
                                    x2 - y2,
                                    y * (3.0 * x2 - y2),
                                    x * y * z,
                                    y * (5.0 * z2 - 1.0),
                                    z * (5.0 * z2 - 3.0),
                                    x * (5.0 * z2 - 1.0),
                                    z * (x2 - y2),
                                    x * (x2 - 3.0 * y2),
                                    x * y * (x2 - y2),
                                    y * z * (3.0 * x2 - y2),
                                    x * y * (7.0 * z2 - 1.0),
                                    y * z * (7.0 * z2 - 3.0),
                                    (35.0 * z2 - 30.0) * z2 + 3.0,
                                    x * z * (7.0 * z2 - 3.0),
                                    (x2 - y2) * (7.0 * z2 - 1.0),
                                    x * z * (x2 - 3.0 * y2),
                                    x2 * (x2 - 3.0 * y2) - y2 * (3.0 * x2 - y2)};
    return p[index];
}

ShCoefficients truncateOrder(const ShCoefficients& probe, int order) {
    if (order < 1 || order > probe.order || probe.rgb.size() < size_t(coefficientCount(order)))
        throw Error(ErrorKind::Input, "cannot take order " + std::to_string(order) + " of a probe of order " +
                                          std::to_string(probe.order));
    ShCoefficients truncated = makeCoefficients(order, probe.quantity);
    std::copy_n(probe.rgb.begin(), coefficientCount(order), truncated.rgb.begin());
    return truncated;
}

std::optional<ShCoefficients> radianceOf(const ShCoefficients& probe, int order) {
    ShCoefficients radiance = truncateOrder(probe, order);
    radiance.quantity = Quantity::Radiance;
    if (probe.quantity == Quantity::Radiance) return radiance;
    for (int i = 0; i < coefficientCount(order); ++i) {
        double a = irradianceBandFactor(shBand(i));
        if (a == 0.0) return std::nullopt;
        radiance.rgb[size_t(i)] /= a;
    }
    return radiance;
}

std::optional<FoldedCoefficients> foldCoefficients(const ShCoefficients& probe, int order,
                                                   FoldedQuantity quantity) {
    if (order < 1 || order > kMaxFoldedOrder)
        throw Error(ErrorKind::Input, "cannot fold order " + std::to_string(order) +
                                          ": the polynomial form holds "
                                          "orders 1 to " +
                                          std::to_string(kMaxFoldedOrder));
    if (quantity == FoldedQuantity::IrradianceOverPi)
        return fold(irradianceFoldInput(probe, order), order, irradianceOverPiScale);
    std::optional<ShCoefficients> radiance = radianceOf(probe, order);
    if (!radiance) return std::nullopt;
    return fold(radiance->rgb, order, unitScale);
}

} // namespace shprobe
