// Double-precision reference projection of environments onto SH: L_lm = sum L(w) y_lm(w) dOmega,
// each texel weighted by its exact solid angle (Sloan, "Stupid Spherical Harmonics (SH) Tricks",
// projection from cube maps).
#pragma once
#include "common/work_counter.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"

namespace shprobe {

// Their rows (of each face, or of the equirect image) are counted into `progress`.
ShCoefficients projectCubemap(const Cubemap& cubemap, int order, WorkCounter* progress = nullptr);
ShCoefficients projectEquirect(const Image& equirect, int order, WorkCounter* progress = nullptr);

// The function the coefficients describe, sum_i c_i y_i(w), at each texel's centre, negative values
// kept (alpha 1): projectCubemap's inverse for a band-limited function, up to its quadrature.
Cubemap evaluateCubemap(const ShCoefficients& coefficients, int faceSize);

} // namespace shprobe
