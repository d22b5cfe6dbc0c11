// SH rotation: against exact projections of rotated environments, group properties, known signed
// permutations, the three ways of giving a rotation, and invalid input.
#include "common/error.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/projection.h"
#include "sh/rotation.h"
#include "test_support.h"

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/matrix.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

namespace shprobe {
namespace {

using testing::expectInputError;
using testing::gaussLegendre;
using testing::maxDifference;
using testing::QuadratureNode;

constexpr double kPi = std::numbers::pi;

// Exact quadrature of band-limited functions leaves the rounding of ~600 weighted products of
// order-1 values; the recurrence adds a few ulps per band. Measured at most 5e-15 (order 8);
// 1e-10 is the bar the issue sets.
constexpr double kExactError = 1e-10;
// Orthogonality, composition and the conversions are a few dozen double operations per entry
// (orthogonality measured at 5e-15 for order 8).
constexpr double kMatrixError = 1e-12;
// Rotating a cube-map projection against projecting the rotated environment at face size 128:
// both carry the cube map's midpoint-rule error, measured at 2.2e-5 (see the test).
constexpr double kCubemapError = 3e-5;

constexpr std::array<int, 3> kTestedOrders = {3, 5, 8};

using SphereFunction = std::function<glm::dvec3(const glm::dvec3&)>;

// Projection of f on the basis by Gauss-Legendre (16 nodes in cos theta) x 32 uniform phi: exact
// when f is a polynomial of degree <= 7 (the product with y_i has degree <= 14, as in test_basis).
ShCoefficients projectExactly(const SphereFunction& f, int order) {
    constexpr int kPhiSamples = 32;
    ShCoefficients out = makeCoefficients(order, Quantity::Radiance);
    std::vector<double> y(size_t(coefficientCount(order)));
    for (const QuadratureNode& node : gaussLegendre(16)) {
        const double sinTheta = std::sqrt(1.0 - node.t * node.t);
        for (int k = 0; k < kPhiSamples; ++k) {
            const double phi = 2.0 * kPi * k / kPhiSamples;
            const glm::dvec3 d(sinTheta * std::cos(phi), sinTheta * std::sin(phi), node.t);
            evalBasis(order, d, y);
            const glm::dvec3 weighted = f(d) * (node.weight * 2.0 * kPi / kPhiSamples);
            for (size_t i = 0; i < y.size(); ++i)
                out.rgb[i] += weighted * y[i];
        }
    }
    return out;
}

ShCoefficients randomCoefficients(int order, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    ShCoefficients c = makeCoefficients(order, Quantity::Radiance);
    for (glm::dvec3& v : c.rgb)
        v = glm::dvec3(uniform(rng), uniform(rng), uniform(rng));
    return c;
}

// The band-limited function sum_i c_i y_i(w), evaluated in double.
glm::dvec3 evaluateSum(const ShCoefficients& c, const glm::dvec3& w) {
    std::vector<double> y(c.rgb.size());
    evalBasis(c.order, w, y);
    glm::dvec3 sum(0.0);
    for (size_t i = 0; i < y.size(); ++i)
        sum += c.rgb[i] * y[i];
    return sum;
}

glm::dmat3 randomRotation(unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal;
    glm::dvec4 q(normal(rng), normal(rng), normal(rng), normal(rng));
    q = glm::normalize(q);
    return rotationFromQuaternion(q.x, q.y, q.z, q.w);
}

void expectCoefficientsNear(const ShCoefficients& actual, const ShCoefficients& expected, double tolerance,
                            const char* what) {
    ASSERT_EQ(actual.rgb.size(), expected.rgb.size()) << what;
    for (size_t i = 0; i < actual.rgb.size(); ++i) {
        for (int channel = 0; channel < 3; ++channel) {
            ASSERT_NEAR(actual.rgb[i][channel], expected.rgb[i][channel], tolerance)
                << what << ": i = " << i << " (l = " << shBand(int(i)) << "), channel " << channel;
        }
    }
}

double maxMatrixDifference(const glm::dmat3& a, const glm::dmat3& b) {
    double difference = 0.0;
    for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r)
            difference = std::max(difference, std::abs(a[c][r] - b[c][r]));
    }
    return difference;
}

double bandEntry(const ShRotation& rotation, int l, int m, int n) {
    return rotation.bands[size_t(l)][size_t((m + l) * (2 * l + 1) + (n + l))];
}

// Checks the definition: for f = sum c_i y_i (exactly band-limited), the rotated coefficients equal
// the exact projection of g(w) = f(R^T w); and back: rotating those by R^T gives c again. Orders
// 3, 5, 8 and five random rotations each.
TEST(Rotation, MatchesExactProjectionOfRotatedEnvironment) {
    for (int order : kTestedOrders) {
        for (unsigned trial = 0; trial < 5; ++trial) {
            const ShCoefficients f = randomCoefficients(order, 100 + trial);
            const glm::dmat3 R = randomRotation(200 + trial);
            const ShCoefficients g = projectExactly(
                [&](const glm::dvec3& w) { return evaluateSum(f, glm::transpose(R) * w); }, order);
            SCOPED_TRACE("order " + std::to_string(order) + ", trial " + std::to_string(trial));
            expectCoefficientsNear(rotate(makeShRotation(R, order), f), g, kExactError, "R f");
            expectCoefficientsNear(rotate(makeShRotation(glm::transpose(R), order), g), f, kExactError,
                                   "R^T g");
        }
    }
}

struct Lobes {
    std::array<glm::dvec3, 3> axes = {glm::normalize(glm::dvec3(1, 2, 3)),
                                      glm::normalize(glm::dvec3(-1, 0.5, -0.2)), glm::dvec3(0, -1, 0)};
    std::array<glm::dvec3, 3> colours = {glm::dvec3(1, 0.5, 0.2), glm::dvec3(0.1, 0.8, 0.3),
                                         glm::dvec3(0.4, 0.4, 1.0)};

    // Three spherical Gaussians exp(6 (w.axis - 1)): smooth, but not band-limited.
    glm::dvec3 operator()(const glm::dvec3& w) const {
        glm::dvec3 sum(0.0);
        for (size_t k = 0; k < axes.size(); ++k)
            sum += colours[k] * std::exp(6.0 * (glm::dot(w, axes[k]) - 1.0));
        return sum;
    }
};

Cubemap drawCubemap(const SphereFunction& f, int faceSize) {
    Cubemap cubemap = makeCubemap(faceSize);
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < faceSize; ++j) {
            for (int i = 0; i < faceSize; ++i)
                cubemap.at(face, i, j) = glm::vec4(glm::vec3(f(texelDirection(face, i, j, faceSize))), 1.0f);
        }
    }
    return cubemap;
}

// Checks the same with projectCubemap on a non-band-limited environment (three spherical Gaussian
// lobes, coefficients up to 0.5): rotating the projection of f and projecting g differ only by the
// cube map's midpoint-rule error, which is second order: measured 3.6e-4, 8.9e-5, 2.2e-5 at face
// sizes 32, 64, 128 (order 5). So the difference must shrink by more than kMinimumRatio per doubling
// and end below kCubemapError at 128.
TEST(Rotation, MatchesCubemapProjectionOfRotatedLobes) {
    constexpr int kOrder = 5;
    constexpr double kMinimumRatio = 3.5; // second order gives 4
    const glm::dmat3 R = rotationFromEulerZYZ(30.0, 50.0, -70.0);
    const Lobes lobes;
    const ShRotation rotation = makeShRotation(R, kOrder);
    double previous = 0.0;
    for (int faceSize : {32, 64, 128}) {
        const ShCoefficients expected = projectCubemap(
            drawCubemap([&](const glm::dvec3& w) { return lobes(glm::transpose(R) * w); }, faceSize), kOrder);
        const ShCoefficients actual = rotate(rotation, projectCubemap(drawCubemap(lobes, faceSize), kOrder));
        const double difference = maxDifference(actual, expected);
        if (previous > 0.0) {
            EXPECT_GT(previous / difference, kMinimumRatio) << "face size " << faceSize;
        }
        previous = difference;
    }
    EXPECT_LT(previous, kCubemapError);
}

// Checks: every band matrix is orthogonal (D D^T = I), for order 8 and random rotations.
TEST(Rotation, BandMatricesAreOrthogonal) {
    for (unsigned trial = 0; trial < 10; ++trial) {
        const ShRotation rotation = makeShRotation(randomRotation(300 + trial), kMaxOrder);
        ASSERT_EQ(rotation.bands.size(), size_t(kMaxOrder));
        for (int l = 0; l < kMaxOrder; ++l) {
            for (int a = -l; a <= l; ++a) {
                for (int b = -l; b <= l; ++b) {
                    double dot = 0.0;
                    for (int n = -l; n <= l; ++n)
                        dot += bandEntry(rotation, l, a, n) * bandEntry(rotation, l, b, n);
                    ASSERT_NEAR(dot, a == b ? 1.0 : 0.0, kMatrixError)
                        << "l " << l << ", rows " << a << ", " << b;
                }
            }
        }
    }
}

// Checks the group law: rotating by R1 and then by R2 equals rotating once by R2 R1, and the
// identity leaves coefficients unchanged, for orders 3, 5, 8.
TEST(Rotation, CompositionAndIdentity) {
    const glm::dmat3 r1 = randomRotation(400);
    const glm::dmat3 r2 = randomRotation(401);
    for (int order : kTestedOrders) {
        const ShCoefficients c = randomCoefficients(order, 402);
        const ShCoefficients twice = rotate(makeShRotation(r2, order), rotate(makeShRotation(r1, order), c));
        expectCoefficientsNear(twice, rotate(makeShRotation(r2 * r1, order), c), kMatrixError, "R2 (R1 c)");
        expectCoefficientsNear(rotate(makeShRotation(glm::dmat3(1.0), order), c), c, kMatrixError,
                               "identity");
    }
}

// Checks band 1 against signed permutations worked out by hand from y1-1 = -c y, y10 = c z,
// y11 = -c x: a linear function a.w has a = c (-L11, -L1-1, L10), and g(w) = f(R^T w) has a' = R a.
// Rx(90): a' = (ax, -az, ay) -> L1-1' = L10, L10' = -L1-1, L11' = L11.
// Ry(90): a' = (az, ay, -ax) -> L1-1' = L1-1, L10' = L11, L11' = -L10.
// Rz(90): a' = (-ay, ax, az) -> L1-1' = L11, L10' = L10, L11' = -L1-1.
TEST(Rotation, QuarterTurnsAreSignedPermutationsInBandOne) {
    using Matrix = std::array<std::array<double, 3>, 3>; // rows m' = -1, 0, 1; columns n = -1, 0, 1
    const std::array<glm::dvec3, 3> axes = {glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)};
    const std::array<Matrix, 3> expected = {
        Matrix{{{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}}},
        Matrix{{{1, 0, 0}, {0, 0, 1}, {0, -1, 0}}},
        Matrix{{{0, 0, 1}, {0, 1, 0}, {-1, 0, 0}}},
    };
    for (size_t axis = 0; axis < 3; ++axis) {
        const glm::dvec3 a = axes[axis];
        const glm::dmat3 R = rotationFromQuaternion(std::sqrt(0.5), std::sqrt(0.5) * a.x,
                                                    std::sqrt(0.5) * a.y, std::sqrt(0.5) * a.z);
        const ShRotation rotation = makeShRotation(R, 2);
        for (int m = -1; m <= 1; ++m) {
            for (int n = -1; n <= 1; ++n) {
                EXPECT_NEAR(bandEntry(rotation, 1, m, n), expected[axis][size_t(m + 1)][size_t(n + 1)],
                            kMatrixError)
                    << "axis " << axis << ", (m', n) = (" << m << ", " << n << ")";
            }
        }
    }
}

// Checks every band for a rotation about z by theta, where g(w) = f(R^T w) shifts phi by -theta:
// a cos(m phi) + b sin(m phi) becomes (a cos m theta - b sin m theta) cos(m phi)
// + (a sin m theta + b cos m theta) sin(m phi), i.e. L_lm' = cos(m theta) L_lm - sin(m theta) L_l,-m
// and L_l,-m' = sin(m theta) L_lm + cos(m theta) L_l,-m for m > 0.
TEST(Rotation, RotationAboutZMixesEachPairByMTheta) {
    const double theta = 0.7;
    const ShRotation rotation =
        makeShRotation(rotationFromEulerZYZ(theta * 180.0 / kPi, 0.0, 0.0), kMaxOrder);
    for (int l = 0; l < kMaxOrder; ++l) {
        for (int m = -l; m <= l; ++m) {
            for (int n = -l; n <= l; ++n) {
                const int am = std::abs(m);
                double expected = 0.0;
                if (n == m) expected = std::cos(am * theta);
                if (m != 0 && n == -m) expected = m > 0 ? -std::sin(am * theta) : std::sin(am * theta);
                EXPECT_NEAR(bandEntry(rotation, l, m, n), expected, kMatrixError)
                    << "(l, m, n) = (" << l << ", " << m << ", " << n << ")";
            }
        }
    }
}

// Checks the meaning of the convention on a light: the coefficients of a delta light from d,
// y_i(d), rotated by R, are those of a delta light from R d.
TEST(Rotation, LightFromDirectionMovesToRotatedDirection) {
    const glm::dmat3 R = randomRotation(500);
    const glm::dvec3 d = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
    ShCoefficients light = makeCoefficients(kMaxOrder, Quantity::Radiance);
    ShCoefficients moved = makeCoefficients(kMaxOrder, Quantity::Radiance);
    std::vector<double> y(size_t(coefficientCount(kMaxOrder)));
    evalBasis(kMaxOrder, d, y);
    for (size_t i = 0; i < y.size(); ++i)
        light.rgb[i] = glm::dvec3(y[i]);
    evalBasis(kMaxOrder, R * d, y);
    for (size_t i = 0; i < y.size(); ++i)
        moved.rgb[i] = glm::dvec3(y[i]);
    expectCoefficientsNear(rotate(makeShRotation(R, kMaxOrder), light), moved, kMatrixError, "delta light");
}

// Rodrigues' formula for the rotation by angle about a unit axis, written independently.
glm::dmat3 axisAngle(const glm::dvec3& axis, double angle) {
    glm::dmat3 cross(0.0); // [axis]_x, R[column][row]
    cross[1][0] = -axis.z, cross[2][0] = axis.y;
    cross[0][1] = axis.z, cross[2][1] = -axis.x;
    cross[0][2] = -axis.y, cross[1][2] = axis.x;
    return glm::dmat3(1.0) + std::sin(angle) * cross + (1.0 - std::cos(angle)) * (cross * cross);
}

// Checks: the quaternion (cos a/2, sin a/2 n), the row-major matrix of Rodrigues' formula, glm's own
// quaternion conversion, and Z-Y-Z Euler angles give the same matrix and the same SH rotation.
TEST(Rotation, QuaternionEulerAndMatrixAgree) {
    const glm::dvec3 axis = glm::normalize(glm::dvec3(0.2, -0.6, 0.9));
    const double angle = 1.1;
    const glm::dmat3 rodrigues = axisAngle(axis, angle);
    const double s = std::sin(angle / 2);
    const glm::dmat3 fromQuaternion =
        rotationFromQuaternion(std::cos(angle / 2), s * axis.x, s * axis.y, s * axis.z);
    std::array<double, 9> rowMajor{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            rowMajor[size_t(3 * r + c)] = rodrigues[c][r];
    }
    const glm::dmat3 fromRowMajor = rotationFromRowMajor(rowMajor);
    const glm::dmat3 fromGlm =
        glm::mat3_cast(glm::dquat(std::cos(angle / 2), s * axis.x, s * axis.y, s * axis.z));
    EXPECT_LT(maxMatrixDifference(fromQuaternion, rodrigues), kMatrixError);
    EXPECT_LT(maxMatrixDifference(fromRowMajor, rodrigues), kMatrixError);
    EXPECT_LT(maxMatrixDifference(fromQuaternion, fromGlm), kMatrixError);

    // Z-Y-Z: R = Rz(gamma) Ry(beta) Rz(alpha), each factor an axis-angle rotation.
    const double alpha = 25.0, beta = 70.0, gamma = -140.0, toRadians = kPi / 180.0;
    const glm::dmat3 euler = rotationFromEulerZYZ(alpha, beta, gamma);
    const glm::dmat3 product = axisAngle(glm::dvec3(0, 0, 1), gamma * toRadians) *
                               axisAngle(glm::dvec3(0, 1, 0), beta * toRadians) *
                               axisAngle(glm::dvec3(0, 0, 1), alpha * toRadians);
    EXPECT_LT(maxMatrixDifference(euler, product), kMatrixError);

    const ShCoefficients c = randomCoefficients(kMaxOrder, 600);
    expectCoefficientsNear(rotate(makeShRotation(fromQuaternion, kMaxOrder), c),
                           rotate(makeShRotation(fromRowMajor, kMaxOrder), c), kMatrixError,
                           "quaternion vs matrix");
}

// Checks: non-orthonormal matrices, reflections (det -1), non-finite entries, non-unit quaternions,
// orders outside 1..8 and a probe of another order are input errors, loud in every build type.
TEST(Rotation, InvalidInputThrows) {
    const std::array<double, 9> scaled = {1.01, 0, 0, 0, 1, 0, 0, 0, 1};
    const std::array<double, 9> sheared = {1, 0.01, 0, 0, 1, 0, 0, 0, 1};
    const std::array<double, 9> reflection = {1, 0, 0, 0, 1, 0, 0, 0, -1};
    const std::array<double, 9> notANumber = {std::nan(""), 0, 0, 0, 1, 0, 0, 0, 1};
    const std::array<double, 9> nearlyIdentity = {1, 1e-8, 0, -1e-8, 1, 0, 0, 0, 1};
    expectInputError([&] { rotationFromRowMajor(scaled); }, "scaled matrix");
    expectInputError([&] { rotationFromRowMajor(sheared); }, "sheared matrix");
    expectInputError([&] { rotationFromRowMajor(reflection); }, "reflection");
    expectInputError([&] { rotationFromRowMajor(notANumber); }, "NaN matrix");
    EXPECT_NO_THROW(rotationFromRowMajor(nearlyIdentity)); // within kRotationTolerance
    expectInputError([] { rotationFromQuaternion(1.0, 0.1, 0.0, 0.0); }, "non-unit quaternion");
    // A quaternion typed to 4 digits is normalized: the quarter turn about z it means, to 1e-15.
    const glm::dmat3 typed = rotationFromQuaternion(0.7071, 0.0, 0.0, 0.7071);
    const glm::dmat3 exact = rotationFromQuaternion(std::sqrt(0.5), 0.0, 0.0, std::sqrt(0.5));
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
            EXPECT_NEAR(typed[c][r], exact[c][r], 1e-15) << c << ", " << r;
    expectInputError([] { rotationFromQuaternion(0.0, 0.0, 0.0, 0.0); }, "zero quaternion");
    expectInputError([] { rotationFromEulerZYZ(std::nan(""), 0.0, 0.0); }, "NaN Euler angle");
    expectInputError([] { makeShRotation(glm::dmat3(2.0), 3); }, "makeShRotation of a scaled matrix");
    expectInputError([] { makeShRotation(glm::dmat3(1.0), 0); }, "order 0");
    expectInputError([] { makeShRotation(glm::dmat3(1.0), kMaxOrder + 1); }, "order 9");
    expectInputError(
        [] { rotate(makeShRotation(glm::dmat3(1.0), 3), makeCoefficients(4, Quantity::Radiance)); },
        "order mismatch");
}

} // namespace
} // namespace shprobe
