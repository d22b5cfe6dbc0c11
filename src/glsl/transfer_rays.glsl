// The rays of a vertex side as scene/transfer.cpp casts them: g x g stratified cosine-distributed
// directions about the side's normal, stratum (a, b) jittered by the side's next two random
// numbers (random_words.h: the CPU's to 2^-24), so the directions are the CPU's to float rounding.
#ifndef SHPROBE_TRANSFER_RAYS_GLSL
#define SHPROBE_TRANSFER_RAYS_GLSL
#include "random_words.h"
#include "transfer_interface.h"

// scene/sampling.h cosineDirection in float: Duff et al.'s frame ("Building an Orthonormal Basis,
// Revisited", 2017) and Malley's method. The angle is taken in [-pi, pi), where Vulkan bounds the
// error of sin and cos, and the point turned by pi to match: cos(phi - pi) = -cos(phi).
vec3 transferCosineDirection(vec3 n, float u1, float u2) {
    float sign = (floatBitsToUint(n.z) & 0x80000000u) != 0u ? -1.0 : 1.0; // copysign(1, n.z)
    float a = -1.0 / (sign + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    vec3 bitangent = vec3(b, sign + n.y * n.y * a, -n.y);
    float r = sqrt(u1);
    float phi = 6.28318530717958647692 * u2 - 3.14159265358979323846;
    return -r * cos(phi) * t - r * sin(phi) * bitangent + sqrt(max(0.0, 1.0 - u1)) * n;
}

// The direction of the side's ray k, in stratum (k / strata, k % strata), drawing its two numbers
// from `state`.
vec3 transferRayDirection(vec3 n, uint strata, uint k, inout uvec2 state) {
    float u1 = (float(k / strata) + nextRandom(state)) / float(strata);
    float u2 = (float(k % strata) + nextRandom(state)) / float(strata);
    return transferCosineDirection(n, u1, u2);
}

#endif
