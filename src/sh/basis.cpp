// Real orthonormal SH with the Condon-Shortley phase (docs/conventions.md): the recurrence of Lisle &
// Huang, "Algorithms for Spherical Harmonic Lighting", section 2.1 (basis.h), normalized.
#include "sh/basis.h"

#include "common/error.h"
#include "glsl/gpu_interface.h"

#include <array>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <string>

namespace shprobe {

namespace {

// The C++ code and the shaders accept the same orders.
static_assert(kMaxOrder == SHPROBE_MAX_ORDER, "kMaxOrder (basis.h) and SHPROBE_MAX_ORDER (gpu_interface.h)");

constexpr double kPi = std::numbers::pi;

void requireOrderFits(int order, std::span<double> out) {
    requireOrder(order);
    if (out.size() < size_t(coefficientCount(order))) {
        throw Error(ErrorKind::Input, "SH output holds " + std::to_string(out.size()) + " values, order " +
                                          std::to_string(order) + " needs " +
                                          std::to_string(coefficientCount(order)));
    }
}

using NormalizationTable = std::array<double, coefficientCount(kMaxOrder)>;

const NormalizationTable& normalizationTable() {
    static const NormalizationTable table = [] {
        NormalizationTable t{};
        for (int l = 0; l < kMaxOrder; ++l) {
            for (int m = -l; m <= l; ++m)
                t[size_t(shIndex(l, m))] = recurrenceNormalization(l, m);
        }
        return t;
    }();
    return table;
}

} // namespace

int shBand(int index) {
    if (index < 0) throw Error(ErrorKind::Input, "negative SH index " + std::to_string(index));
    int l = int(std::sqrt(double(index)));
    while (l * l > index)
        --l; // guard the floating-point square root at perfect squares
    while ((l + 1) * (l + 1) <= index)
        ++l;
    return l;
}

// K_l^|m| = sqrt((2l+1)/(4 pi) (l-|m|)!/(l+|m|)!) (docs/conventions.md), the factorial ratio as the
// product 1 / ((l-|m|+1) ... (l+|m|)).
double shNormalization(int l, int m) {
    const int absM = std::abs(m);
    if (l < 0 || absM > l) {
        throw Error(ErrorKind::Input, "no SH band l = " + std::to_string(l) + ", m = " + std::to_string(m));
    }
    double factorialRatio = 1.0;
    for (int k = l - absM + 1; k <= l + absM; ++k)
        factorialRatio /= k;
    return std::sqrt((2 * l + 1) / (4.0 * kPi) * factorialRatio);
}

double recurrenceNormalization(int l, int m) {
    return m == 0 ? shNormalization(l, 0) : std::numbers::sqrt2 * shNormalization(l, m);
}

void evalBasis(int order, const glm::dvec3& d, std::span<double> out) {
    requireOrderFits(order, out);
    evalBasisRecurrence<double>(order, d.x, d.y, d.z, out.data());
    const NormalizationTable& normalization = normalizationTable();
    for (int i = 0; i < coefficientCount(order); ++i)
        out[size_t(i)] *= normalization[size_t(i)];
}

void requireOrder(int order) {
    if (order < 1 || order > kMaxOrder)
        throw Error(ErrorKind::Input,
                    "SH order must be in 1.." + std::to_string(kMaxOrder) + ", got " + std::to_string(order));
}

void requireCoefficients(const ShCoefficients& probe) {
    if (probe.order < 1 || probe.order > kMaxOrder ||
        probe.rgb.size() != size_t(coefficientCount(probe.order)))
        throw Error(ErrorKind::Input, "SH probe of order " + std::to_string(probe.order) + " holds " +
                                          std::to_string(probe.rgb.size()) + " coefficients");
}

} // namespace shprobe
