// Functions GPUs may evaluate too loosely for shprobe, written with arithmetic and sqrt only, shared
// by C++ and GLSL. GLSL's atan need only be within 4096 ulps (Vulkan spec, "Precision of SPIR-V
// Instructions"); lavapipe's is 2e-5 relative off.
#ifndef SHPROBE_PRECISE_MATH_H
#define SHPROBE_PRECISE_MATH_H
#include "shared.h"

SHPROBE_BEGIN

// atan(t) for 0 <= t <= 1 to about an ulp: two half-angle steps, atan(t) = 2 atan(t / (1 + sqrt(1 + t^2))),
// bring t below tan(pi/16) = 0.199, where the odd Taylor series to t^17 is exact in fp32 (the first
// omitted term is below 1e-13 relative).
SHPROBE_FN float preciseAtan(float t) {
    float x = t / (1.0f + sqrt(1.0f + t * t));
    x = x / (1.0f + sqrt(1.0f + x * x));
    float x2 = x * x;
    float series = 1.0f / 17.0f;
    series = 1.0f / 15.0f - x2 * series;
    series = 1.0f / 13.0f - x2 * series;
    series = 1.0f / 11.0f - x2 * series;
    series = 1.0f / 9.0f - x2 * series;
    series = 1.0f / 7.0f - x2 * series;
    series = 1.0f / 5.0f - x2 * series;
    series = 1.0f / 3.0f - x2 * series;
    series = 1.0f - x2 * series;
    return 4.0f * x * series;
}

// (sin(pi n / d), cos(pi n / d)) for integers |n| <= d, 1 <= d < 2^29, to a few ulps. GLSL's sin
// and cos need only be within 2^-11 absolute on [-pi, pi] (Vulkan spec, as above), coarser than an
// equirect row's solid angle near the poles. The symmetries sin(-x) = -sin x, sin(pi - x) = sin x,
// cos(pi - x) = -cos x and sin(pi/2 - x) = cos x fold n / d into r = m / (2d) in [0, 1/4] in integer
// arithmetic, so that the one rounding is that of the final quotient (folding a rounded n / d would
// turn 1 - n / d near 1 into a difference of close numbers); there x = pi r <= pi/4, and the Taylor
// series through x^13 (sine) and x^14 (cosine), nested as 1 - x^2/(2*3) (1 - x^2/(4*5) (...)), are
// exact in fp32 (the first omitted terms are below 3e-14). The factors are reciprocals folded at
// compile time: a division per step would be a real division on GPUs and CPUs alike.
SHPROBE_FN vec2 preciseSinCosPi(int numerator, uint denominator) {
    float sineSign = numerator < 0 ? -1.0f : 1.0f;
    uint twiceDenominator = 2u * denominator;
    uint m = 2u * uint(abs(numerator)); // r = m / (2d)
    float cosineSign = 1.0f;
    if (m > denominator) { // r > 1/2: pi - x
        m = twiceDenominator - m;
        cosineSign = -1.0f;
    }
    bool complement = 2u * m > denominator; // r > 1/4: pi/2 - x
    if (complement) m = denominator - m;
    float x = 3.14159265358979f * (float(m) / float(twiceDenominator));
    float x2 = x * x;
    float sine = 1.0f - x2 * (1.0f / 156.0f);
    sine = 1.0f - x2 * (1.0f / 110.0f) * sine;
    sine = 1.0f - x2 * (1.0f / 72.0f) * sine;
    sine = 1.0f - x2 * (1.0f / 42.0f) * sine;
    sine = 1.0f - x2 * (1.0f / 20.0f) * sine;
    sine = x * (1.0f - x2 * (1.0f / 6.0f) * sine);
    float cosine = 1.0f - x2 * (1.0f / 182.0f);
    cosine = 1.0f - x2 * (1.0f / 132.0f) * cosine;
    cosine = 1.0f - x2 * (1.0f / 90.0f) * cosine;
    cosine = 1.0f - x2 * (1.0f / 56.0f) * cosine;
    cosine = 1.0f - x2 * (1.0f / 30.0f) * cosine;
    cosine = 1.0f - x2 * (1.0f / 12.0f) * cosine;
    cosine = 1.0f - x2 * 0.5f * cosine;
    return complement ? vec2(sineSign * cosine, cosineSign * sine)
                      : vec2(sineSign * sine, cosineSign * cosine);
}

SHPROBE_END

#endif
