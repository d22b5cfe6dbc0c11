// SH coefficients folded for evaluation as polynomials, the form src/glsl/sh_irradiance.glsl
// takes: with y_i = k_i p_i(x, y, z) (the basis of docs/conventions.md written as a constant k_i times
// a polynomial p_i) and s_l a per-band scale, the folded coefficient is c_i = s_l k_i f_i, so that
// sum_i c_i p_i(n) = sum_i s_l f_i y_i(n) costs one multiply-add per coefficient. As in Sloan's
// irradiance shader (Sloan, "Stupid SH Tricks", appendix A10), y_20 = k_6 (3 z^2 - 1) is split:
// p_6 = z^2 with c_6 = 3 s_2 k_6 f_6, and the constant -s_2 k_6 f_6 goes into c_0.
//
// Used by the render shaders' uniforms (src/render/probe_shading.h) and the header export formats
// (src/formats/probe_export.h), so that both hand the shader the same numbers.
#pragma once
#include "sh/coefficients.h"

#include <array>
#include <glm/vec3.hpp>
#include <optional>

namespace shprobe {

// Bands the polynomial form covers: 0..4, i.e. orders 1 to 5 and 25 coefficients.
constexpr int kMaxFoldedOrder = 5;
constexpr int kFoldedCount = kMaxFoldedOrder * kMaxFoldedOrder;

// y_i = basisPolynomialScale(i) * basisPolynomial(i, d) for i < 25 (docs/conventions.md; Sloan's signs:
// the odd-m constants are negative). The polynomials are the ones sh_irradiance.glsl evaluates,
// except that the shader evaluates z^2 for y_20 = k (3 z^2 - 1) (Sloan's split, above).
// Throw Error(Input) for an index outside 0..24.
double basisPolynomialScale(int index);
double basisPolynomial(int index, const glm::dvec3& d);

// The first `order` bands of a probe (1 <= order <= probe.order); throws Error(Input) otherwise.
ShCoefficients truncateOrder(const ShCoefficients& probe, int order);

// The radiance L_lm of the first `order` bands: the probe itself, or E_lm / A_l for an irradiance
// probe; std::nullopt when a band with A_l = 0 (odd l > 1) is needed, since E_lm lost it.
std::optional<ShCoefficients> radianceOf(const ShCoefficients& probe, int order);

// What folded coefficients evaluate to.
enum class FoldedQuantity {
    Radiance,         // s_l = 1: sh_irradiance.glsl's shRadiance returns L(d)
    IrradianceOverPi, // s_l = A_l / pi: shIrradianceOverPi returns E(n) / pi
};

// rgb per coefficient, in flat-index order; entries from coefficientCount(order) on are 0.
using FoldedCoefficients = std::array<glm::dvec3, kFoldedCount>;

// Folds the first `order` bands (1..kMaxFoldedOrder) of a radiance or irradiance probe. Any probe
// folds to IrradianceOverPi (an irradiance probe's bands with A_l = 0 contribute 0); Radiance of an
// irradiance probe is std::nullopt when it needs a band with A_l = 0 (order 4 or 5). Throws
// Error(Input) when the order is outside 1..5 or above the probe's.
std::optional<FoldedCoefficients> foldCoefficients(const ShCoefficients& probe, int order,
                                                   FoldedQuantity quantity);

} // namespace shprobe
