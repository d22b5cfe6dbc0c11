// Real orthonormal spherical harmonics with the Condon-Shortley phase (docs/conventions.md).
// Order n = number of bands: l = 0..n-1, n^2 coefficients, flat index i = l(l+1) + m.
#pragma once
#include <glm/vec3.hpp>
#include <span>

namespace shprobe {

constexpr int kMaxOrder = 8;

constexpr int coefficientCount(int order) {
    return order * order;
}
constexpr int shIndex(int l, int m) {
    return l * (l + 1) + m;
}
// Band l of flat index i.
int shBand(int index);

// y_i(d) for i < order^2 at unit direction d, by the algebraic recurrence of Lisle & Huang
// ("Algorithms for Spherical Harmonic Lighting", section 2.1) followed by the normalization K_lm.
// Order 1..kMaxOrder. out must hold coefficientCount(order) values.
void evalBasis(int order, const glm::dvec3& d, std::span<double> out);

// The same basis from the closed-form polynomials (Sloan, "Stupid Spherical Harmonics (SH) Tricks";
// Brown, "Spherical Harmonic Basis Functions", with Sloan's signs), order 1..5. Used to check the recurrence.
void evalBasisClosedForm(int order, const glm::dvec3& d, std::span<double> out);

// Normalization constant K_l^|m| = sqrt((2l+1)/(4 pi) (l-|m|)!/(l+|m|)!).
double shNormalization(int l, int m);

} // namespace shprobe
