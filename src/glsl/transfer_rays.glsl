// The rays of a vertex side as scene/transfer.cpp casts them: g x g stratified cosine-distributed
// directions about the side's normal, stratum (a, b) jittered by the side's next two random
// numbers. The generator is scene/sampling.h's splitmix64 (Steele, Lea & Flood, "Fast Splittable
// Pseudorandom Number Generators", 2014) on pairs of 32-bit words, as Vulkan 1.1 promises no 64-bit
// integers; each number keeps the top 24 of its 53 bits (a float's mantissa), so the jitter is the
// CPU's to 2^-24, and the directions are the CPU's to float rounding.
#ifndef SHPROBE_TRANSFER_RAYS_GLSL
#define SHPROBE_TRANSFER_RAYS_GLSL
#include "transfer_interface.h"

// 64-bit words as (low, high).
uvec2 transferAdd64(uvec2 a, uvec2 b) {
    uint carry;
    uint low = uaddCarry(a.x, b.x, carry);
    return uvec2(low, a.y + b.y + carry);
}

// The low 64 bits of a b.
uvec2 transferMultiply64(uvec2 a, uvec2 b) {
    uint high, low;
    umulExtended(a.x, b.x, high, low);
    return uvec2(low, high + a.x * b.y + a.y * b.x);
}

// z ^ (z >> s) for 0 < s < 32.
uvec2 transferXorShift64(uvec2 z, uint s) {
    return z ^ uvec2((z.x >> s) | (z.y << (32u - s)), z.y >> s);
}

// splitmix64's output function (scene/sampling.h mix64).
uvec2 transferMix64(uvec2 z) {
    z = transferMultiply64(transferXorShift64(z, 30u), uvec2(0x1ce4e5b9u, 0xbf58476du));
    z = transferMultiply64(transferXorShift64(z, 27u), uvec2(0x133111ebu, 0x94d049bbu));
    return transferXorShift64(z, 31u);
}

// The next number of the stream in [0, 1): RandomStream::next's top 24 bits.
float transferNextRandom(inout uvec2 state) {
    state = transferAdd64(state, uvec2(0x7f4a7c15u, 0x9e3779b9u));
    return float(transferMix64(state).y >> 8) * (1.0 / 16777216.0);
}

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

// The direction of the side's ray in stratum (a, b), drawing its two numbers from `state`.
vec3 transferRayDirection(vec3 n, uint strata, uint a, uint b, inout uvec2 state) {
    float u1 = (float(a) + transferNextRandom(state)) / float(strata);
    float u2 = (float(b) + transferNextRandom(state)) / float(strata);
    return transferCosineDirection(n, u1, u2);
}

#endif
