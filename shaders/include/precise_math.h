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

SHPROBE_END

#endif
