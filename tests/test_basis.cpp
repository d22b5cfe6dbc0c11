// The SH basis: golden values, recurrence against closed forms, orthonormality, normalization.
// The closed forms are written out here, apart from the library's one C++ basis (the recurrence of
// basis.h), as an independent check of it.
#include "common/error.h"
#include "sh/basis.h"
#include "test_support.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <vector>

namespace shprobe {
namespace {

using testing::gaussLegendre;
using testing::QuadratureNode;
using testing::randomDirections;

constexpr double kPi = std::numbers::pi;

// The golden values of docs/conventions.md are printed to 9 decimals: rounding leaves at most 5e-10.
constexpr double kGoldenError = 1e-9;
// Recurrence and closed forms are different double evaluations of the same polynomials of unit
// vectors with values of order 1: they differ by a few ulps times a few dozen operations.
constexpr double kClosedFormError = 1e-12;
// Gauss-Legendre x uniform-phi quadrature is exact for these polynomials; what remains is the
// rounding of about 500 weighted products summed in double.
constexpr double kOrthonormalityError = 1e-12;
// shNormalization is a short product and one square root.
constexpr double kNormalizationError = 1e-14;

constexpr std::array<double, 25> kGoldenValues = {
    0.282094792,  0.246781535,  0.394850457, -0.148068921, -0.167226801, 0.445938135, 0.302518440,
    -0.267562881, -0.089187627, 0.006081980, -0.357545939, 0.522930036,  0.080008903, -0.313758021,
    -0.190691168, 0.120423203,  0.062557508, 0.014744946,  -0.517223777, 0.429126063, -0.176103636,
    -0.257475638, -0.275852681, 0.291949931, -0.041965662};

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

// y_i(d) for i < order^2, order 1..5, from the closed forms.
std::vector<double> closedFormBasisAt(int order, const glm::dvec3& d) {
    std::vector<double> out(size_t(coefficientCount(order)));
    closedFormBand0(out);
    if (order > 1) closedFormBand1(d, out);
    if (order > 2) closedFormBand2(d, out);
    if (order > 3) closedFormBand3(d, out);
    if (order > 4) closedFormBand4(d, out);
    return out;
}

std::vector<double> basisAt(int order, const glm::dvec3& d) {
    std::vector<double> y(size_t(coefficientCount(order)));
    evalBasis(order, d, y);
    return y;
}

// Checks: y_i(d) at d = normalize(0.3, -0.5, 0.8) equals the 25 golden values of docs/conventions.md,
// which fix the convention (signs, Condon-Shortley phase, normalization, index order).
TEST(Basis, GoldenValues) {
    const std::vector<double> y = basisAt(5, glm::normalize(glm::dvec3(0.3, -0.5, 0.8)));
    for (int i = 0; i < 25; ++i)
        EXPECT_NEAR(y[size_t(i)], kGoldenValues[size_t(i)], kGoldenError) << "i = " << i;
}

// Checks: every (l, m) of the recurrence equals the hand-written polynomials (Sloan; Brown with
// Sloan's signs) at 1000 random directions, for every order the closed forms cover.
TEST(Basis, RecurrenceMatchesClosedForms) {
    for (const glm::dvec3& d : randomDirections(1000, 1234)) {
        for (int order = 1; order <= 5; ++order) {
            const std::vector<double> closedForm = closedFormBasisAt(order, d);
            const std::vector<double> recurrence = basisAt(order, d);
            for (int l = 0; l < order; ++l) {
                for (int m = -l; m <= l; ++m) {
                    const size_t i = size_t(shIndex(l, m));
                    ASSERT_NEAR(recurrence[i], closedForm[i], kClosedFormError)
                        << "(l, m) = (" << l << ", " << m << "), order " << order;
                }
            }
        }
    }
}

// Checks: the lower orders are prefixes of the higher ones (the bands do not depend on the order).
TEST(Basis, LowerOrderIsPrefix) {
    const glm::dvec3 d = glm::normalize(glm::dvec3(-0.7, 0.2, 0.4));
    const std::vector<double> full = basisAt(kMaxOrder, d);
    for (int order = 1; order < kMaxOrder; ++order) {
        const std::vector<double> prefix = basisAt(order, d);
        for (size_t i = 0; i < prefix.size(); ++i)
            EXPECT_EQ(prefix[i], full[i]) << "order " << order << ", i " << i;
    }
}

// Checks: integral over the sphere of y_i y_j = delta_ij for all 64 functions of order 8. The
// product is a polynomial of degree <= 14 in (x, y, z): in cos(theta) it is a polynomial of degree
// <= 14 (odd powers of sin(theta) only come with terms that integrate to 0 in phi), which 16
// Gauss-Legendre nodes integrate exactly; in phi a trigonometric polynomial of degree <= 14, which
// 32 uniform samples integrate exactly. So only rounding is left.
TEST(Basis, OrthonormalByExactQuadrature) {
    constexpr int kPhiSamples = 32;
    const int count = coefficientCount(kMaxOrder);
    std::vector<double> gram(size_t(count * count), 0.0);
    for (const QuadratureNode& node : gaussLegendre(16)) {
        const double sinTheta = std::sqrt(1.0 - node.t * node.t);
        for (int k = 0; k < kPhiSamples; ++k) {
            const double phi = 2.0 * kPi * k / kPhiSamples;
            const double weight = node.weight * 2.0 * kPi / kPhiSamples;
            const glm::dvec3 d(sinTheta * std::cos(phi), sinTheta * std::sin(phi), node.t);
            const std::vector<double> y = basisAt(kMaxOrder, d);
            for (int i = 0; i < count; ++i) {
                for (int j = 0; j < count; ++j)
                    gram[size_t(i * count + j)] += weight * y[size_t(i)] * y[size_t(j)];
            }
        }
    }
    for (int i = 0; i < count; ++i) {
        for (int j = 0; j < count; ++j) {
            EXPECT_NEAR(gram[size_t(i * count + j)], i == j ? 1.0 : 0.0, kOrthonormalityError)
                << "i = " << i << " (l = " << shBand(i) << "), j = " << j << " (l = " << shBand(j) << ")";
        }
    }
}

// Checks: K_l^|m| = sqrt((2l+1)/(4 pi) (l-|m|)!/(l+|m|)!) against values worked out by hand, and
// its symmetry in the sign of m.
TEST(Basis, NormalizationValues) {
    EXPECT_NEAR(shNormalization(0, 0), 0.5 / std::sqrt(kPi), kNormalizationError);
    EXPECT_NEAR(shNormalization(1, 0), std::sqrt(3.0 / (4.0 * kPi)), kNormalizationError);
    EXPECT_NEAR(shNormalization(1, 1), std::sqrt(3.0 / (8.0 * kPi)), kNormalizationError);
    EXPECT_NEAR(shNormalization(2, 1), std::sqrt(5.0 / (24.0 * kPi)), kNormalizationError);
    EXPECT_NEAR(shNormalization(2, 2), std::sqrt(5.0 / (96.0 * kPi)), kNormalizationError);
    EXPECT_NEAR(shNormalization(4, 4), std::sqrt(9.0 / (4.0 * kPi * 40320.0)), kNormalizationError);
    EXPECT_NEAR(shNormalization(7, 3), std::sqrt(15.0 / (4.0 * kPi) * 24.0 / 3628800.0), kNormalizationError);
    for (int l = 0; l < kMaxOrder; ++l) {
        for (int m = 1; m <= l; ++m)
            EXPECT_EQ(shNormalization(l, m), shNormalization(l, -m));
    }
    EXPECT_THROW(shNormalization(2, 3), Error);
}

// Checks: the band of a flat index is floor(sqrt(i)), including at the band edges.
TEST(Basis, BandOfIndex) {
    for (int l = 0; l < 20; ++l) {
        for (int m = -l; m <= l; ++m)
            EXPECT_EQ(shBand(shIndex(l, m)), l) << "(l, m) = (" << l << ", " << m << ")";
    }
    EXPECT_EQ(coefficientCount(3), 9);
    EXPECT_EQ(shIndex(2, -2), 4);
}

void expectInputError(int order) {
    std::vector<double> out(100);
    try {
        evalBasis(order, glm::dvec3(0, 0, 1), out);
        ADD_FAILURE() << "order " << order << " did not throw";
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Input) << "order " << order;
    }
}

// Checks: orders outside 1..kMaxOrder and too small an output are input errors, loud in every
// build type.
TEST(Basis, OutOfRangeOrderThrows) {
    expectInputError(0);
    expectInputError(-1);
    expectInputError(kMaxOrder + 1);
    std::vector<double> tooSmall(8);
    EXPECT_THROW(evalBasis(3, glm::dvec3(0, 0, 1), tooSmall), Error);
}

} // namespace
} // namespace shprobe
