// Owen-scrambled Sobol' points in 2D (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020)
// on 32-bit words, and the Morton codes that number a face's texels: shared by C++
// (scene/sampling.h, whose owenScrambledSobol the cpu's paths draw from) and GLSL (the gpu's paths,
// glsl/ray_paths.glsl), so that both draw the same points.
#ifndef SHPROBE_SOBOL_WORDS_H
#define SHPROBE_SOBOL_WORDS_H
#include "random_words.h"
#include "shared.h"

SHPROBE_BEGIN

SHPROBE_FN uint reverseBits(uint x) {
    x = ((x >> 1u) & 0x55555555u) | ((x & 0x55555555u) << 1u);
    x = ((x >> 2u) & 0x33333333u) | ((x & 0x33333333u) << 2u);
    x = ((x >> 4u) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4u);
    x = ((x >> 8u) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8u);
    return (x >> 16u) | (x << 16u);
}

// Flips each bit by a hash of the bits below it (Laine and Karras, "Stratified Sampling for
// Stochastic Transparency", 2011).
SHPROBE_FN uint laineKarrasPermutation(uint x, uint seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Owen's scrambling of a 0.32 fixed-point number: each bit flipped by a hash of the bits above it.
SHPROBE_FN uint nestedUniformScramble(uint x, uint seed) {
    return reverseBits(laineKarrasPermutation(reverseBits(x), seed));
}

// Sobol's second dimension: the index's bits through the generator matrix of x + 1 (Pascal's
// triangle mod 2); the first is the index's bits reversed.
SHPROBE_FN uint sobolSecondDimension(uint index) {
    uint result = 0u;
    for (uint v = 1u << 31u; index != 0u; index >>= 1u, v ^= v >> 1u)
        if ((index & 1u) != 0u) result ^= v;
    return result;
}

// Point `index` of the Owen-scrambled Sobol' set named by the 64-bit `seed` (low, high words), in
// 0.32 fixed point. `shuffled` scrambles the index too, which keeps the set but decorrelates it from
// other sets drawn at the same index (Burley's padding); unshuffled, consecutive indices keep their
// stratification.
SHPROBE_FN uvec2 owenScrambledSobolWords(uint index, uvec2 seed, bool shuffled) {
    uvec2 hash = mix64Words(seed);
    uint i = shuffled ? nestedUniformScramble(index, mix64Words(add64(hash, uvec2(1u, 0u))).x) : index;
    return uvec2(nestedUniformScramble(reverseBits(i), hash.x),
                 nestedUniformScramble(sobolSecondDimension(i), hash.y));
}

// v's low 16 bits spread to the even places.
SHPROBE_FN uint spreadBits(uint v) {
    v &= 0xffffu;
    v = (v | (v << 8u)) & 0x00ff00ffu;
    v = (v | (v << 4u)) & 0x0f0f0f0fu;
    v = (v | (v << 2u)) & 0x33333333u;
    return (v | (v << 1u)) & 0x55555555u;
}

// The Morton code of (i, j): their bits interleaved, i's in the even places, so that texels near
// each other get indices near each other, at every scale.
SHPROBE_FN uint mortonCode(uint i, uint j) {
    return spreadBits(i) | (spreadBits(j) << 1u);
}

// The smallest power of two at least n (n >= 1).
SHPROBE_FN uint powerOfTwoAtLeast(uint n) {
    uint power = 1u;
    while (power < n)
        power <<= 1u;
    return power;
}

// The number of the first path of texel (i, j) of `face` in a view of faces n, perTexel rays a
// texel: face by face along a Morton curve (a face's codes fill the square of the power of two at
// least n), each texel's rays in a row and none left between texels: a Sobol' set's points left
// unused in every block (the first 9 of each 16) stratify the paths worse than fewer rays do.
SHPROBE_FN uint firstTexelPath(uint face, uint i, uint j, uint n, uint perTexel) {
    uint side = powerOfTwoAtLeast(n);
    return (face * side * side + mortonCode(i, j)) * perTexel;
}

// The set of a probe's Owen-scrambled Sobol' sets, beyond every bounce's, from which the shadow
// rays towards the sky in a texel view's strata draw (scene/emitters.h stratumSkyRays): stratum k
// of a texel draws from the set named by mix64(mix64(probe seed + this) + its path's number).
#define SHPROBE_STRATUM_SKY_USE 65536u

// The first of a probe's Owen-scrambled Sobol' sets from which its paths draw the suns' rays into
// the world (scene/emitters.h SunlitSampler): at bounce level k, set this + 2k for the cell's pick
// and this + 2k + 1 for the point in the cell.
#define SHPROBE_SUNLIT_USE 131072u

SHPROBE_END

#endif
