// Real orthonormal spherical harmonics with the Condon-Shortley phase (docs/conventions.md).
// Order n = number of bands: l = 0..n-1, n^2 coefficients, flat index i = l(l+1) + m.
#pragma once
#include "sh/coefficients.h"

#include <glm/vec3.hpp>
#include <span>

namespace shprobe {

constexpr int kMaxOrder = 8;
// How files name this convention (field "convention").
inline constexpr char kConventionName[] = "real-orthonormal-condon-shortley";

constexpr int coefficientCount(int order) {
    return order * order;
}
constexpr int shIndex(int l, int m) {
    return l * (l + 1) + m;
}
// Band l of flat index i.
int shBand(int index);

// Throw Error(Input) for an order outside 1..kMaxOrder ("SH order must be in 1..8, got 9"), and for
// a probe of such an order or without order^2 coefficients.
void requireOrder(int order);
void requireCoefficients(const ShCoefficients& probe);

// y_i(d) for i < order^2 at unit direction d: evalBasisRecurrence, then recurrenceNormalization.
// Order 1..kMaxOrder. out must hold coefficientCount(order) values.
void evalBasis(int order, const glm::dvec3& d, std::span<double> out);

// Normalization constant K_l^|m| = sqrt((2l+1)/(4 pi) (l-|m|)!/(l+|m|)!).
double shNormalization(int l, int m);

// The factor turning evalBasisRecurrence's Y_lm into y_lm (docs/conventions.md): sqrt(2) K_l^|m|
// for m != 0, K_l^0 for m = 0. The Condon-Shortley phase is already in Y_lm.
double recurrenceNormalization(int l, int m);

// The C++ basis, written once for evalBasis (double) and the fast CPU projection (float SIMD lanes,
// fast_projection.cpp): the unnormalized Y_lm, l < order, at l(l+1)+m of out, for the unit
// direction (x, y, z), by the algebraic recurrence of Lisle & Huang ("Algorithms for Spherical
// Harmonic Lighting", section 2.1). Value is any type with +, -, * (double, or a vector of Scalar
// lanes); Scalar is its element type. The shaders have their own evaluation (src/glsl/
// sh_basis.glsl, which says why it differs).
template <class Scalar, class Value>
void evalBasisRecurrence(int order, const Value& x, const Value& y, const Value& z, Value* out) {
    const auto at = [out](int l, int m) -> Value& { return out[shIndex(l, m)]; };
    out[0] = Value{} + Scalar(1); // Y00 = 1, Y1-1 = -y, Y10 = z, Y11 = -x
    if (order < 2) return;
    at(1, -1) = -y;
    at(1, 0) = z;
    at(1, 1) = -x;
    for (int l = 2; l < order; ++l) {
        // Y_l,l = (2l-1)(y Y_l-1,-(l-1) - x Y_l-1,l-1); Y_l,-l = -(2l-1)(y Y_l-1,l-1 + x Y_l-1,-(l-1)).
        const Scalar twoLMinusOne = Scalar(2 * l - 1);
        const Value cosine = at(l - 1, l - 1);
        const Value sine = at(l - 1, -(l - 1));
        at(l, l) = twoLMinusOne * (y * sine - x * cosine);
        at(l, -l) = -twoLMinusOne * (y * cosine + x * sine);
        // Y_l,+-m = ((2l-1) z Y_l-1,+-m - (l+m-1) Y_l-2,+-m) / (l-m), without the second term for
        // m > l-2. For m = 0 both lines compute the same Y_l,0.
        for (int m = 0; m < l; ++m) {
            Value positive = twoLMinusOne * z * at(l - 1, m);
            Value negative = twoLMinusOne * z * at(l - 1, -m);
            if (m <= l - 2) {
                positive -= Scalar(l + m - 1) * at(l - 2, m);
                negative -= Scalar(l + m - 1) * at(l - 2, -m);
            }
            at(l, m) = positive * (Scalar(1) / Scalar(l - m));
            at(l, -m) = negative * (Scalar(1) / Scalar(l - m));
        }
    }
}

} // namespace shprobe
