// Real orthonormal SH with the Condon-Shortley phase (docs/conventions.md): the recurrence of Lisle &
// Huang, "Algorithms for Spherical Harmonic Lighting", section 2.1, and, to check it, the closed-form
// polynomials through l = 4.
#include "basis.h"

#include "error.h"

#include <array>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <string>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kMaxClosedFormOrder = 5;

void requireOrderFits(int order, int maxOrder, std::span<double> out) {
    if (order < 1 || order > maxOrder) {
        throw Error(ErrorKind::Input,
                    "SH order must be in 1.." + std::to_string(maxOrder) + ", got " + std::to_string(order));
    }
    if (out.size() < size_t(coefficientCount(order))) {
        throw Error(ErrorKind::Input, "SH output holds " + std::to_string(out.size()) + " values, order " +
                                          std::to_string(order) + " needs " +
                                          std::to_string(coefficientCount(order)));
    }
}

// Factor turning the recurrence's unnormalized Y_lm into y_lm (docs/conventions.md): sqrt(2) K_l^|m|
// for m != 0, K_l^0 for m = 0. The Condon-Shortley phase is already in the recurrence's Y_lm.
double recurrenceNormalization(int l, int m) {
    return m == 0 ? shNormalization(l, 0) : std::numbers::sqrt2 * shNormalization(l, m);
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

// Unnormalized Y_lm by the Lisle-Huang recurrence ("Algorithms for Spherical Harmonic Lighting",
// section 2.1), stored at l(l+1)+m.
class RecurrenceBasis {
  public:
    RecurrenceBasis(std::span<double> y, const glm::dvec3& d) : y_(y), d_(d) {}

    void run(int order) {
        y_[0] = 1.0; // base: Y00 = 1, Y1-1 = -y, Y10 = z, Y11 = -x
        if (order == 1) return;
        at(1, -1) = -d_.y;
        at(1, 0) = d_.z;
        at(1, 1) = -d_.x;
        for (int l = 2; l < order; ++l) {
            edges(l);
            for (int m = 0; m < l; ++m)
                interior(l, m);
        }
    }

  private:
    double& at(int l, int m) { return y_[size_t(shIndex(l, m))]; }

    // Y_l,l = (2l-1)(-x Y_l-1,l-1 + y Y_l-1,-(l-1)); Y_l,-l = (2l-1)(-y Y_l-1,l-1 - x Y_l-1,-(l-1)).
    void edges(int l) {
        const double cosine = at(l - 1, l - 1);
        const double sine = at(l - 1, -(l - 1));
        at(l, l) = (2 * l - 1) * (-d_.x * cosine + d_.y * sine);
        at(l, -l) = (2 * l - 1) * (-d_.y * cosine - d_.x * sine);
    }

    // Y_l,±m = ((2l-1) z Y_l-1,±m - (l+m-1) Y_l-2,±m) / (l-m); the term Y_l-2,±m is 0 for m > l-2.
    // For m = 0 both lines compute the same Y_l,0.
    void interior(int l, int m) {
        const double twoBelowPositive = m <= l - 2 ? at(l - 2, m) : 0.0;
        const double twoBelowNegative = m <= l - 2 ? at(l - 2, -m) : 0.0;
        const double scale = 1.0 / (l - m);
        at(l, m) = scale * ((2 * l - 1) * d_.z * at(l - 1, m) - (l + m - 1) * twoBelowPositive);
        at(l, -m) = scale * ((2 * l - 1) * d_.z * at(l - 1, -m) - (l + m - 1) * twoBelowNegative);
    }

    std::span<double> y_;
    glm::dvec3 d_;
};

// Closed forms (Sloan, "Stupid Spherical Harmonics (SH) Tricks", appendix; Brown, "Spherical Harmonic
// Basis Functions", with Sloan's signs: odd m carries a minus).
void closedFormBand0(std::span<double> out) {
    out[0] = 0.5 * std::sqrt(1.0 / kPi);
}

void closedFormBand1(const glm::dvec3& d, std::span<double> out) {
    const double c = std::sqrt(3.0 / (4.0 * kPi));
    out[1] = -c * d.y;
    out[2] = c * d.z;
    out[3] = -c * d.x;
}

void closedFormBand2(const glm::dvec3& d, std::span<double> out) {
    const double x = d.x, y = d.y, z = d.z;
    const double c = 0.5 * std::sqrt(15.0 / kPi);
    out[4] = c * x * y;
    out[5] = -c * y * z;
    out[6] = 0.25 * std::sqrt(5.0 / kPi) * (3.0 * z * z - 1.0);
    out[7] = -c * x * z;
    out[8] = 0.5 * c * (x * x - y * y);
}

void closedFormBand3(const glm::dvec3& d, std::span<double> out) {
    const double x = d.x, y = d.y, z = d.z;
    const double c3 = 0.25 * std::sqrt(35.0 / (2.0 * kPi));
    const double c2 = 0.5 * std::sqrt(105.0 / kPi);
    const double c1 = 0.25 * std::sqrt(21.0 / (2.0 * kPi));
    out[9] = -c3 * y * (3.0 * x * x - y * y);
    out[10] = c2 * x * y * z;
    out[11] = -c1 * y * (5.0 * z * z - 1.0);
    out[12] = 0.25 * std::sqrt(7.0 / kPi) * z * (5.0 * z * z - 3.0);
    out[13] = -c1 * x * (5.0 * z * z - 1.0);
    out[14] = 0.5 * c2 * z * (x * x - y * y);
    out[15] = -c3 * x * (x * x - 3.0 * y * y);
}

void closedFormBand4(const glm::dvec3& d, std::span<double> out) {
    const double x = d.x, y = d.y, z = d.z;
    const double x2 = x * x, y2 = y * y, z2 = z * z;
    const double c4 = 0.75 * std::sqrt(35.0 / kPi);
    const double c3 = 0.75 * std::sqrt(35.0 / (2.0 * kPi));
    const double c2 = 0.75 * std::sqrt(5.0 / kPi);
    const double c1 = 0.75 * std::sqrt(5.0 / (2.0 * kPi));
    out[16] = c4 * x * y * (x2 - y2);
    out[17] = -c3 * y * z * (3.0 * x2 - y2);
    out[18] = c2 * x * y * (7.0 * z2 - 1.0);
    out[19] = -c1 * y * z * (7.0 * z2 - 3.0);
    out[20] = 0.1875 * std::sqrt(1.0 / kPi) * (35.0 * z2 * z2 - 30.0 * z2 + 3.0);
    out[21] = -c1 * x * z * (7.0 * z2 - 3.0);
    out[22] = 0.5 * c2 * (x2 - y2) * (7.0 * z2 - 1.0);
    out[23] = -c3 * x * z * (x2 - 3.0 * y2);
    out[24] = 0.25 * c4 * (x2 * x2 - 6.0 * x2 * y2 + y2 * y2);
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

void evalBasis(int order, const glm::dvec3& d, std::span<double> out) {
    requireOrderFits(order, kMaxOrder, out);
    RecurrenceBasis(out, d).run(order);
    const NormalizationTable& normalization = normalizationTable();
    for (int i = 0; i < coefficientCount(order); ++i)
        out[size_t(i)] *= normalization[size_t(i)];
}

void evalBasisClosedForm(int order, const glm::dvec3& d, std::span<double> out) {
    requireOrderFits(order, kMaxClosedFormOrder, out);
    closedFormBand0(out);
    if (order > 1) closedFormBand1(d, out);
    if (order > 2) closedFormBand2(d, out);
    if (order > 3) closedFormBand3(d, out);
    if (order > 4) closedFormBand4(d, out);
}

} // namespace shprobe
