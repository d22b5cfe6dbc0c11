// scene/sampling.h's counter-based random numbers, splitmix64 (Steele, Lea & Flood, "Fast Splittable
// Pseudorandom Number Generators", 2014), on pairs of 32-bit words (low, high), as Vulkan 1.1
// promises no 64-bit integers; shared by C++ (which checks them against RandomStream) and GLSL. A
// number keeps the top 24 of RandomStream::next's 53 bits (RandomStream::nextFloat): a float's mantissa.
#ifndef SHPROBE_RANDOM_WORDS_H
#define SHPROBE_RANDOM_WORDS_H
#include "shared.h"

SHPROBE_BEGIN

SHPROBE_FN uvec2 add64(uvec2 a, uvec2 b) {
    uint carry;
    uint low = uaddCarry(a.x, b.x, carry);
    return uvec2(low, a.y + b.y + carry);
}

// The low 64 bits of a b.
SHPROBE_FN uvec2 multiply64(uvec2 a, uvec2 b) {
    uint high, low;
    umulExtended(a.x, b.x, high, low);
    return uvec2(low, high + a.x * b.y + a.y * b.x);
}

// z ^ (z >> s) for 0 < s < 32.
SHPROBE_FN uvec2 xorShift64(uvec2 z, uint s) {
    return z ^ uvec2((z.x >> s) | (z.y << (32u - s)), z.y >> s);
}

// splitmix64's output function (scene/sampling.h mix64).
SHPROBE_FN uvec2 mix64Words(uvec2 z) {
    z = multiply64(xorShift64(z, 30u), uvec2(0x1ce4e5b9u, 0xbf58476du));
    z = multiply64(xorShift64(z, 27u), uvec2(0x133111ebu, 0x94d049bbu));
    return xorShift64(z, 31u);
}

// splitmix64's Weyl sequence: a draw adds this to the state.
SHPROBE_FN uvec2 randomStep() {
    return uvec2(0x7f4a7c15u, 0x9e3779b9u);
}

// The state after a draw from `state`.
SHPROBE_FN uvec2 nextRandomState(uvec2 state) {
    return add64(state, randomStep());
}

// The state after `draws` draws from `state`, at once.
SHPROBE_FN uvec2 skipRandomStates(uvec2 state, uint draws) {
    return add64(state, multiply64(uvec2(draws, 0u), randomStep()));
}

// The number in [0, 1) drawn into `state` (the state nextRandomState gave).
SHPROBE_FN float randomOfState(uvec2 state) {
    return float(mix64Words(state).y >> 8u) * (1.0f / 16777216.0f);
}

SHPROBE_END

#ifndef __cplusplus
// The next number of the stream in [0, 1): RandomStream::nextFloat.
float nextRandom(inout uvec2 state) {
    state = nextRandomState(state);
    return randomOfState(state);
}
#endif

#endif
