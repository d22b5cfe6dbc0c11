// Real orthonormal SH basis in GLSL, Condon-Shortley phase, flat index l(l+1)+m
// (docs/conventions.md). The includer declares `const uint SH_ORDER` (usually a specialization constant)
// first; then SH_COEFFICIENTS = SH_ORDER^2 and shEvalBasis(d, y) fills y[0..SH_COEFFICIENTS).
//
// The shaders' one basis. The C++ one (src/sh/basis.h, evalBasisRecurrence: the double reference
// and the fast CPU projection) runs the unnormalized Lisle-Huang recurrence from band 0 and
// normalizes at the end. Here bands 0-4 are closed forms and bands 5-7 the recurrence in normalized
// form, all straight-line code with constant indices: an array indexed at run time stays in memory
// on llvmpipe, which made projection four times slower at order 3 and four to seven times at order
// 8 (docs/gpu-path.md). Both are checked against each other by test_gpu (GPU against CPU projections
// at orders 1, 3, 5 and 8).
#ifndef SHPROBE_SH_BASIS_GLSL
#define SHPROBE_SH_BASIS_GLSL
#include "gpu_interface.h"

const uint SH_COEFFICIENTS = SH_ORDER * SH_ORDER;
// Basis arrays have room for the highest order and only their first SH_COEFFICIENTS entries are
// written: glslang 12 refuses literal indices into arrays sized by a specialization constant.
const uint SH_BASIS_CAPACITY = uint(SHPROBE_MAX_COEFFICIENTS);

// Bands 0-4 as closed-form polynomials in x, y, z (Sloan, "Stupid SH Tricks", with the
// signs of docs/conventions.md). SH_ORDER is a constant when the pipeline is built, so the bands not
// needed disappear, and the remaining code is straight-line: no loops, no indexing at run time.
void shEvalBands0To4(vec3 d, inout float y[SH_BASIS_CAPACITY]) {
    float x = d.x, yy = d.y, z = d.z;
    y[0] = 0.282094791774f;
    if (SH_ORDER < 2u) return;
    y[1] = -0.488602511903f * yy;
    y[2] = 0.488602511903f * z;
    y[3] = -0.488602511903f * x;
    if (SH_ORDER < 3u) return;
    float x2 = x * x, y2 = yy * yy, z2 = z * z;
    y[4] = 1.092548430592f * x * yy;
    y[5] = -1.092548430592f * yy * z;
    y[6] = 0.315391565253f * (3.0f * z2 - 1.0f);
    y[7] = -1.092548430592f * x * z;
    y[8] = 0.546274215296f * (x2 - y2);
    if (SH_ORDER < 4u) return;
    y[9] = -0.590043589927f * yy * (3.0f * x2 - y2);
    y[10] = 2.890611442641f * x * yy * z;
    y[11] = -0.457045799464f * yy * (5.0f * z2 - 1.0f);
    y[12] = 0.373176332590f * z * (5.0f * z2 - 3.0f);
    y[13] = -0.457045799464f * x * (5.0f * z2 - 1.0f);
    y[14] = 1.445305721320f * z * (x2 - y2);
    y[15] = -0.590043589927f * x * (x2 - 3.0f * y2);
    if (SH_ORDER < 5u) return;
    y[16] = 2.503342941797f * x * yy * (x2 - y2);
    y[17] = -1.770130769780f * yy * z * (3.0f * x2 - y2);
    y[18] = 0.946174695758f * x * yy * (7.0f * z2 - 1.0f);
    y[19] = -0.669046543557f * yy * z * (7.0f * z2 - 3.0f);
    y[20] = 0.105785546915f * (35.0f * z2 * z2 - 30.0f * z2 + 3.0f);
    y[21] = -0.669046543557f * x * z * (7.0f * z2 - 3.0f);
    y[22] = 0.473087347879f * (x2 - y2) * (7.0f * z2 - 1.0f);
    y[23] = -1.770130769780f * x * z * (x2 - 3.0f * y2);
    y[24] = 0.625835735449f * (x2 * (x2 - 3.0f * y2) - y2 * (3.0f * x2 - y2));
}

// Bands 5-7 from bands l-1 and l-2, by the normalized recurrences of the associated Legendre
// functions applied to the whole basis values (the cos/sin(m phi) part depends on m only):
//   y_l,+-l     = -sqrt((2l+1)/(2l)) (x y_l-1,+-(l-1) -+ y y_l-1,-+(l-1))   (complex multiplication)
//   y_l,+-(l-1) = sqrt(2l+1) z y_l-1,+-(l-1)
//   y_l,+-m     = a_lm (z y_l-1,+-m - b_lm y_l-2,+-m),  a_lm = sqrt((4l^2-1)/(l^2-m^2)),
//                 b_lm = sqrt(((l-1)^2-m^2)/(4(l-1)^2-1))
// (Lisle & Huang 2007, "Algorithms for Spherical Harmonic Lighting", section 2.1, in normalized form.)
// Workaround(llvmpipe, Mesa 22.3): spelled out for literal l and m, so that every index into y and
// every factor is a constant: a loop over the bands left y in memory on llvmpipe (as any array
// indexed at run time), with a masked store per lane and write, and order-8 projection ran 12 times
// as long as order 5 (4-7 times as long as now). A loop over l and m gives the same values where a
// driver keeps y in registers.
#define SH_INDEX(l, m) ((l) * ((l) + 1) + (m))
#define SH_SECTORAL(l)                                                                            \
    y[SH_INDEX(l, l)] = -sqrt(float(2 * (l) + 1) / float(2 * (l))) *                              \
        (d.x * y[SH_INDEX((l) - 1, (l) - 1)] - d.y * y[SH_INDEX((l) - 1, 1 - (l))]);              \
    y[SH_INDEX(l, -(l))] = -sqrt(float(2 * (l) + 1) / float(2 * (l))) *                           \
        (d.x * y[SH_INDEX((l) - 1, 1 - (l))] + d.y * y[SH_INDEX((l) - 1, (l) - 1)]);              \
    y[SH_INDEX(l, (l) - 1)] = sqrt(float(2 * (l) + 1)) * d.z * y[SH_INDEX((l) - 1, (l) - 1)];     \
    y[SH_INDEX(l, 1 - (l))] = sqrt(float(2 * (l) + 1)) * d.z * y[SH_INDEX((l) - 1, 1 - (l))];
#define SH_STEP_UP(l, m)                                                                          \
    y[SH_INDEX(l, m)] = sqrt(float(4 * (l) * (l) - 1) / float((l) * (l) - (m) * (m))) *            \
        (d.z * y[SH_INDEX((l) - 1, m)] -                                                          \
         sqrt(float(((l) - 1) * ((l) - 1) - (m) * (m)) / float(4 * ((l) - 1) * ((l) - 1) - 1)) *   \
             y[SH_INDEX((l) - 2, m)]);
#define SH_STEP(l, m) SH_STEP_UP(l, m) SH_STEP_UP(l, -(m))

#if SHPROBE_MAX_ORDER != 8
#error "shEvalBands5To7 spells out the bands up to 7 (order 8)"
#endif
void shEvalBands5To7(vec3 d, inout float y[SH_BASIS_CAPACITY]) {
    if (SH_ORDER < 6u) return;
    SH_SECTORAL(5) SH_STEP_UP(5, 0) SH_STEP(5, 1) SH_STEP(5, 2) SH_STEP(5, 3)
    if (SH_ORDER < 7u) return;
    SH_SECTORAL(6) SH_STEP_UP(6, 0) SH_STEP(6, 1) SH_STEP(6, 2) SH_STEP(6, 3) SH_STEP(6, 4)
    if (SH_ORDER < 8u) return;
    SH_SECTORAL(7) SH_STEP_UP(7, 0) SH_STEP(7, 1) SH_STEP(7, 2) SH_STEP(7, 3) SH_STEP(7, 4) SH_STEP(7, 5)
}
#undef SH_STEP
#undef SH_STEP_UP
#undef SH_SECTORAL
#undef SH_INDEX

void shEvalBasis(vec3 d, out float y[SH_BASIS_CAPACITY]) {
    shEvalBands0To4(d, y);
    shEvalBands5To7(d, y);
}

// Every coefficient up to SH_BASIS_CAPACITY as X(index, l, m), for code that needs one variable
// per coefficient.
// Workaround(llvmpipe, Mesa 22.3): llvmpipe keeps an array that is ever indexed in a loop in
// memory, with a masked per-lane store for every write, so accumulators are spelled out as sum0,
// sum1, ... instead (docs/benchmark.md). An array of sums indexed in a loop over the coefficients
// gives the same values where a driver keeps it in registers.
#define SH_EACH_COEFFICIENT(X) X(0, 0, 0) X(1, 1, -1) X(2, 1, 0) X(3, 1, 1) X(4, 2, -2) \
    X(5, 2, -1) X(6, 2, 0) X(7, 2, 1) X(8, 2, 2) X(9, 3, -3) X(10, 3, -2) X(11, 3, -1) X(12, 3, 0) \
    X(13, 3, 1) X(14, 3, 2) X(15, 3, 3) X(16, 4, -4) X(17, 4, -3) X(18, 4, -2) X(19, 4, -1) \
    X(20, 4, 0) X(21, 4, 1) X(22, 4, 2) X(23, 4, 3) X(24, 4, 4) X(25, 5, -5) X(26, 5, -4) \
    X(27, 5, -3) X(28, 5, -2) X(29, 5, -1) X(30, 5, 0) X(31, 5, 1) X(32, 5, 2) X(33, 5, 3) \
    X(34, 5, 4) X(35, 5, 5) X(36, 6, -6) X(37, 6, -5) X(38, 6, -4) X(39, 6, -3) X(40, 6, -2) \
    X(41, 6, -1) X(42, 6, 0) X(43, 6, 1) X(44, 6, 2) X(45, 6, 3) X(46, 6, 4) X(47, 6, 5) \
    X(48, 6, 6) X(49, 7, -7) X(50, 7, -6) X(51, 7, -5) X(52, 7, -4) X(53, 7, -3) X(54, 7, -2) \
    X(55, 7, -1) X(56, 7, 0) X(57, 7, 1) X(58, 7, 2) X(59, 7, 3) X(60, 7, 4) X(61, 7, 5) \
    X(62, 7, 6) X(63, 7, 7)

// The list holds every coefficient of the highest order (gpu_interface.h), no more, no fewer.
#define SH_COUNT_COEFFICIENT(k, l, m) +1
#if (0 SH_EACH_COEFFICIENT(SH_COUNT_COEFFICIENT)) != SHPROBE_MAX_COEFFICIENTS
#error "SH_EACH_COEFFICIENT must list SHPROBE_MAX_COEFFICIENTS coefficients"
#endif
#undef SH_COUNT_COEFFICIENT

#endif
