// Rotation of SH coefficients, orders 1..kMaxOrder, in double precision.
//
// Convention (docs/conventions.md, "Rotations"): rotating a probe f by R gives the coefficients of
// g(w) = f(R^T w), so a light that came from d comes from R d (column vectors, v' = R v).
//
// Each band l is rotated by its own (2l+1) x (2l+1) orthogonal matrix D^l, built from R by the
// real-basis recurrence of Ivanic & Ruedenberg (J. Phys. Chem. 100, 6342, 1996, with their
// corrections in J. Phys. Chem. A 102, 9099, 1998), written for the real basis without the
// Condon-Shortley phase and converted to ours by D'_mn = (-1)^(m+n) D_mn. (Brown, "Spherical Harmonic Basis
// Functions", lists corrected equations for the related recursion of Choi, Ivanic, Gordon & Ruedenberg, 1999,
// which goes through the complex basis, in a sign convention that is not ours.) The tests check the result
// against exact projections of rotated environments, to 1e-10, through order 8.
//
// Matrices: every glm::dmat3 here is the mathematical matrix R acting as v' = R * v. GLM stores it
// column-major, so element (row r, column c) is R[c][r]. Use rotationFromRowMajor for the 9 numbers of
// the command line and of files (r00, r01, r02, r10, ...).
#pragma once
#include "sh/coefficients.h"

#include <glm/mat3x3.hpp>
#include <span>
#include <vector>

namespace shprobe {

// Largest deviation from orthonormality (|R^T R - I| per element) and from det R = +1 accepted.
constexpr double kRotationTolerance = 1e-6;
// Largest deviation of a quaternion's norm from 1 accepted: it is normalized, so a quaternion typed
// to 4 digits, (0.7071, 0, 0, 0.7071) of norm 0.99999, is the rotation it means.
constexpr double kQuaternionNormTolerance = 1e-3;

// Band-wise rotation matrices. bands[l] holds D^l row-major: entry (m, n), m, n in -l..l, is at
// (m + l) * (2l + 1) + (n + l), and the rotated coefficients are c'_lm = sum_n D^l_mn c_ln.
struct ShRotation {
    int order = 0;
    std::vector<std::vector<double>> bands; // bands[l].size() == (2l+1)^2, l = 0..order-1
};

// Throws Error(Input) unless R is orthonormal with det +1, both within kRotationTolerance.
void validateRotation(const glm::dmat3& R);
// The same for an orthogonal matrix, proper (det +1) or improper (det -1: a reflection, such as a
// change to a left-handed frame).
void validateOrthogonal(const glm::dmat3& Q);

// R from 9 numbers, row-major (r00, r01, r02, r10, ...); validated.
glm::dmat3 rotationFromRowMajor(std::span<const double, 9> rowMajor);
// An orthogonal matrix (a rotation or a reflection) from 9 numbers, row-major; validated.
glm::dmat3 orthogonalFromRowMajor(std::span<const double, 9> rowMajor);
// R from a unit quaternion (w, x, y, z), v' = q v q*; |q| must be 1 within kRotationTolerance
// (q is then normalized).
glm::dmat3 rotationFromQuaternion(double w, double x, double y, double z);
// R = Rz(gamma) Ry(beta) Rz(alpha), angles in degrees (docs/conventions.md; Lisle & Huang,
// "Algorithms for Spherical Harmonic Lighting", eq. 6).
glm::dmat3 rotationFromEulerZYZ(double alphaDegrees, double betaDegrees, double gammaDegrees);

// A light's turn R = Ry(yaw) Rx(pitch), degrees (a light from d comes from R d): what relighting
// commands call turning the light.
glm::dmat3 lightRotation(double yawDegrees, double pitchDegrees);

// The band matrices of R (validated) for order 1..kMaxOrder. R may be improper (det -1): each
// step of the recurrence is linear in R's entries, so D^l is homogeneous of degree l and
// D^l(-R) = (-1)^l D^l(R), the parity y_lm(-w) = (-1)^l y_lm(w) asks for; g(w) = f(R^T w) then
// holds for reflections too (test_engine_exports checks it against projections).
ShRotation makeShRotation(const glm::dmat3& R, int order);

// Rotated coefficients; the probe's order must equal the rotation's. Works for radiance and
// irradiance alike (the Lambertian convolution commutes with rotation).
ShCoefficients rotate(const ShRotation& rotation, const ShCoefficients& coefficients);

} // namespace shprobe
