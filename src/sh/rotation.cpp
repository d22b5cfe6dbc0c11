// SH rotation by band matrices (see rotation.h for the convention). The recurrence is Ivanic &
// Ruedenberg's (J. Phys. Chem. 100, 6342, 1996; corrected in J. Phys. Chem. A 102, 9099, 1998):
// D^l_mn = u U + v V + w W, where U, V, W combine band 1 with band l-1 through the helper P. It is
// written for the real basis WITHOUT the Condon-Shortley phase (y_1,-1, y_10, y_11 proportional to
// +y, +z, +x); our basis (docs/conventions.md) multiplies y_lm by (-1)^m, so D_ours = (-1)^(m+n) D_IR.
#include "sh/rotation.h"

#include "common/error.h"
#include "common/short_number.h"
#include "sh/basis.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <string>

namespace shprobe {

namespace {

// One band's matrix with signed indices m, n in -l..l, stored row-major.
class BandMatrix {
  public:
    explicit BandMatrix(int l) : l_(l), values_(size_t((2 * l + 1) * (2 * l + 1)), 0.0) {}
    double& at(int m, int n) { return values_[size_t((m + l_) * (2 * l_ + 1) + (n + l_))]; }
    double at(int m, int n) const { return values_[size_t((m + l_) * (2 * l_ + 1) + (n + l_))]; }
    std::vector<double>& values() { return values_; }

  private:
    int l_;
    std::vector<double> values_;
};

// Band 1 without the phase: the basis is (y, z, x) for m = -1, 0, 1, and a linear function a.w
// becomes (R a).w under g(w) = f(R^T w), so D^1_mn = R(axis(m), axis(n)).
BandMatrix bandOne(const glm::dmat3& R) {
    const int axisOf[3] = {1, 2, 0}; // m = -1, 0, 1 -> y, z, x
    BandMatrix d(1);
    for (int m = -1; m <= 1; ++m) {
        for (int n = -1; n <= 1; ++n)
            d.at(m, n) = R[axisOf[n + 1]][axisOf[m + 1]]; // glm: R[column][row]
    }
    return d;
}

// Builds band l from band 1 (r) and band l-1 (prev): Ivanic & Ruedenberg's coefficients u, v, w
// and functions U, V, W, written through their helper P (with the 1998 corrections).
class IvanicRuedenberg {
  public:
    IvanicRuedenberg(int l, const BandMatrix& r, const BandMatrix& prev) : l_(l), r_(r), prev_(prev) {}

    double entry(int m, int n) const {
        const bool m0 = m == 0;
        const int am = std::abs(m);
        const double denominator =
            std::abs(n) == l_ ? 2.0 * l_ * (2.0 * l_ - 1.0) : double(l_ + n) * (l_ - n);
        const double u = std::sqrt((l_ + m) * (l_ - m) / denominator);
        const double v =
            0.5 * std::sqrt((m0 ? 2.0 : 1.0) * (l_ + am - 1) * (l_ + am) / denominator) * (m0 ? -1.0 : 1.0);
        const double w = m0 ? 0.0 : -0.5 * std::sqrt((l_ - am - 1) * (l_ - am) / denominator);
        double sum = 0.0;
        if (u != 0.0) sum += u * bigU(m, n);
        if (v != 0.0) sum += v * bigV(m, n);
        if (w != 0.0) sum += w * bigW(m, n); // w = 0 exactly when W would index outside band l-1
        return sum;
    }

  private:
    double helperP(int i, int a, int b) const {
        if (b == l_) return r_.at(i, 1) * prev_.at(a, l_ - 1) - r_.at(i, -1) * prev_.at(a, -l_ + 1);
        if (b == -l_) return r_.at(i, 1) * prev_.at(a, -l_ + 1) + r_.at(i, -1) * prev_.at(a, l_ - 1);
        return r_.at(i, 0) * prev_.at(a, b);
    }

    double bigU(int m, int n) const { return helperP(0, m, n); }

    double bigV(int m, int n) const {
        if (m == 0) return helperP(1, 1, n) + helperP(-1, -1, n);
        if (m > 0) {
            const bool m1 = m == 1;
            return helperP(1, m - 1, n) * (m1 ? std::numbers::sqrt2 : 1.0) -
                   (m1 ? 0.0 : helperP(-1, -m + 1, n));
        }
        const bool mMinus1 = m == -1;
        return (mMinus1 ? 0.0 : helperP(1, m + 1, n)) +
               helperP(-1, -m - 1, n) * (mMinus1 ? std::numbers::sqrt2 : 1.0);
    }

    double bigW(int m, int n) const {
        if (m > 0) return helperP(1, m + 1, n) + helperP(-1, -m - 1, n);
        return helperP(1, m - 1, n) - helperP(-1, -m + 1, n);
    }

    int l_;
    const BandMatrix& r_;
    const BandMatrix& prev_;
};

BandMatrix nextBand(int l, const BandMatrix& r, const BandMatrix& prev) {
    const IvanicRuedenberg recurrence(l, r, prev);
    BandMatrix d(l);
    for (int m = -l; m <= l; ++m) {
        for (int n = -l; n <= l; ++n)
            d.at(m, n) = recurrence.entry(m, n);
    }
    return d;
}

// D_ours = (-1)^(m+n) D_IR: our y_lm carries the Condon-Shortley phase (-1)^m.
std::vector<double> withCondonShortleyPhase(int l, BandMatrix d) {
    for (int m = -l; m <= l; ++m) {
        for (int n = -l; n <= l; ++n) {
            if ((m + n) % 2 != 0) d.at(m, n) = -d.at(m, n);
        }
    }
    return std::move(d.values());
}

void requireFinite(const glm::dmat3& R) {
    for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r) {
            if (!std::isfinite(R[c][r]))
                throw Error(ErrorKind::Input, "rotation matrix has a non-finite entry");
        }
    }
}

std::string rowMajorText(const glm::dmat3& R) {
    std::string text;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            text += (text.empty() ? "" : ",") + shortNumber(R[c][r]);
    }
    return text;
}

} // namespace

namespace {

void requireOrthonormal(const glm::dmat3& R) {
    requireFinite(R);
    const glm::dmat3 gram = glm::transpose(R) * R;
    double deviation = 0.0;
    for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r)
            deviation = std::max(deviation, std::abs(gram[c][r] - (r == c ? 1.0 : 0.0)));
    }
    if (deviation > kRotationTolerance) {
        throw Error(ErrorKind::Input, "matrix (" + rowMajorText(R) +
                                          ") is not orthonormal: |R^T R - I| = " + shortNumber(deviation) +
                                          ", more than " + shortNumber(kRotationTolerance) +
                                          " (give its entries to 7 digits)");
    }
}

} // namespace

void validateOrthogonal(const glm::dmat3& Q) {
    requireOrthonormal(Q);
    const double det = glm::determinant(Q);
    if (std::abs(std::abs(det) - 1.0) > kRotationTolerance)
        throw Error(ErrorKind::Input,
                    "matrix (" + rowMajorText(Q) + ") is not orthogonal: determinant " + shortNumber(det));
}

void validateRotation(const glm::dmat3& R) {
    requireOrthonormal(R);
    const double det = glm::determinant(R);
    if (std::abs(det - 1.0) > kRotationTolerance) {
        throw Error(ErrorKind::Input,
                    "matrix (" + rowMajorText(R) + ") is not a rotation: determinant " + shortNumber(det));
    }
}

namespace {

glm::dmat3 fromRowMajor(std::span<const double, 9> rowMajor) {
    glm::dmat3 R(0.0);
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            R[c][r] = rowMajor[size_t(3 * r + c)];
    }
    return R;
}

} // namespace

glm::dmat3 rotationFromRowMajor(std::span<const double, 9> rowMajor) {
    glm::dmat3 R = fromRowMajor(rowMajor);
    validateRotation(R);
    return R;
}

glm::dmat3 orthogonalFromRowMajor(std::span<const double, 9> rowMajor) {
    glm::dmat3 Q = fromRowMajor(rowMajor);
    validateOrthogonal(Q);
    return Q;
}

// The matrix of v -> q v q* (e.g. Shoemake, "Animating rotation with quaternion curves", 1985).
glm::dmat3 rotationFromQuaternion(double w, double x, double y, double z) {
    const double norm = std::sqrt(w * w + x * x + y * y + z * z);
    if (!std::isfinite(norm) || std::abs(norm - 1.0) > kQuaternionNormTolerance) {
        throw Error(ErrorKind::Input, "quaternion (w,x,y,z) = (" + shortNumber(w) + "," + shortNumber(x) +
                                          "," + shortNumber(y) + "," + shortNumber(z) +
                                          ") is not a unit quaternion (norm " + shortNumber(norm) +
                                          ", not 1 to " + shortNumber(kQuaternionNormTolerance) + ")");
    }
    w /= norm, x /= norm, y /= norm, z /= norm; // so that R is orthonormal to rounding
    glm::dmat3 R(0.0);                          // R[column][row]
    R[0][0] = 1.0 - 2.0 * (y * y + z * z);
    R[1][0] = 2.0 * (x * y - w * z);
    R[2][0] = 2.0 * (x * z + w * y);
    R[0][1] = 2.0 * (x * y + w * z);
    R[1][1] = 1.0 - 2.0 * (x * x + z * z);
    R[2][1] = 2.0 * (y * z - w * x);
    R[0][2] = 2.0 * (x * z - w * y);
    R[1][2] = 2.0 * (y * z + w * x);
    R[2][2] = 1.0 - 2.0 * (x * x + y * y);
    validateRotation(R);
    return R;
}

glm::dmat3 rotationFromEulerZYZ(double alphaDegrees, double betaDegrees, double gammaDegrees) {
    const double toRadians = std::numbers::pi / 180.0;
    auto rotationZ = [](double angle) {
        glm::dmat3 R(1.0);
        R[0][0] = std::cos(angle), R[1][0] = -std::sin(angle);
        R[0][1] = std::sin(angle), R[1][1] = std::cos(angle);
        return R;
    };
    glm::dmat3 rotationY(1.0);
    const double beta = betaDegrees * toRadians;
    rotationY[0][0] = std::cos(beta), rotationY[2][0] = std::sin(beta);
    rotationY[0][2] = -std::sin(beta), rotationY[2][2] = std::cos(beta);
    const glm::dmat3 R =
        rotationZ(gammaDegrees * toRadians) * rotationY * rotationZ(alphaDegrees * toRadians);
    validateRotation(R); // rejects non-finite angles
    return R;
}

ShRotation makeShRotation(const glm::dmat3& R, int order) {
    requireOrder(order);
    validateOrthogonal(R);
    ShRotation rotation{order, {std::vector<double>{1.0}}};
    if (order == 1) return rotation;
    const BandMatrix one = bandOne(R);
    BandMatrix previous = one;
    rotation.bands.push_back(withCondonShortleyPhase(1, one));
    for (int l = 2; l < order; ++l) {
        BandMatrix current = nextBand(l, one, previous);
        rotation.bands.push_back(withCondonShortleyPhase(l, current));
        previous = std::move(current);
    }
    return rotation;
}

ShCoefficients rotate(const ShRotation& rotation, const ShCoefficients& coefficients) {
    if (coefficients.order != rotation.order ||
        coefficients.rgb.size() != size_t(coefficientCount(coefficients.order)) ||
        rotation.bands.size() != size_t(rotation.order)) {
        throw Error(ErrorKind::Input, "cannot rotate an order-" + std::to_string(coefficients.order) +
                                          " probe by an order-" + std::to_string(rotation.order) +
                                          " SH rotation");
    }
    ShCoefficients rotated = coefficients;
    for (int l = 0; l < rotation.order; ++l) {
        const std::vector<double>& d = rotation.bands[size_t(l)];
        const int size = 2 * l + 1;
        for (int row = 0; row < size; ++row) {
            glm::dvec3 sum(0.0);
            for (int column = 0; column < size; ++column)
                sum += d[size_t(row * size + column)] * coefficients.rgb[size_t(l * l + column)];
            rotated.rgb[size_t(l * l + row)] = sum;
        }
    }
    return rotated;
}

glm::dmat3 lightRotation(double yawDegrees, double pitchDegrees) {
    const glm::dvec3 y(0.0, 1.0, 0.0), x(1.0, 0.0, 0.0);
    const glm::dmat4 yaw = glm::rotate(glm::dmat4(1.0), glm::radians(yawDegrees), y);
    const glm::dmat4 pitch = glm::rotate(glm::dmat4(1.0), glm::radians(pitchDegrees), x);
    return glm::dmat3(yaw * pitch);
}

} // namespace shprobe
