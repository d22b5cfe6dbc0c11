// Lambertian (clamped-cosine) convolution and evaluation of SH probes.
// E_lm = A_l L_lm (Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance Environment
// Maps"); the A_l closed form (Brown, "Spherical Harmonic Basis Functions") of docs/conventions.md.
#pragma once
#include "sh/coefficients.h"
#include <glm/vec3.hpp>

namespace shprobe {

// A_l for any l >= 0: pi, 2pi/3, 0 for odd l > 1, and the closed form for even l.
double irradianceBandFactor(int l);

// Irradiance coefficients E_lm = A_l L_lm of radiance coefficients.
ShCoefficients convolveIrradiance(const ShCoefficients& radiance);

// sum c_i y_i(d) at a unit direction: radiance for radiance coefficients, E(n) for irradiance.
glm::dvec3 evaluate(const ShCoefficients& coefficients, const glm::dvec3& direction);

} // namespace shprobe
