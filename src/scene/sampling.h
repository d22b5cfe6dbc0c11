// Random numbers and directions for the scene's Monte-Carlo integrals (scene/reference_tracer.h,
// scene/ray_bake.h): counter-based, so that a result never depends on which thread drew it.
#pragma once
#include "glsl/sobol_words.h"

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace shprobe {

// splitmix64's output function (Steele, Lea & Flood, "Fast Splittable Pseudorandom Number
// Generators", 2014): a bijection of 64-bit words that scrambles every input bit into every output bit.
inline uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

// Counter-based random numbers: a stream is named by (seed, stream, index), never by the thread
// that draws from it, so results do not depend on how work is spread over threads.
class RandomStream {
  public:
    RandomStream(uint64_t seed, uint64_t stream, uint64_t index)
        : state_(mix64(mix64(mix64(seed) + stream) + index)) {}
    // Uniform in [0, 1), 53 bits (splitmix64's Weyl sequence, scrambled).
    double next() {
        state_ += 0x9e3779b97f4a7c15ull;
        return double(mix64(state_) >> 11) * 0x1p-53;
    }
    // Uniform in [0, 1), next()'s top 24 bits: the number a device draws (glsl/random_words.h).
    float nextFloat() {
        state_ += 0x9e3779b97f4a7c15ull;
        return float(mix64(state_) >> 40) * 0x1p-24f;
    }
    // The state before the next draw: a device continues the stream from it (glsl/transfer_rays.glsl).
    uint64_t state() const { return state_; }

  private:
    uint64_t state_;
};

// A branch-free orthonormal frame (t, b, n) about unit n (Duff et al., "Building an Orthonormal
// Basis, Revisited", 2017), and a cosine-distributed direction in it by Malley's method: a uniform
// point (u1, u2) of the unit square taken to the unit disc (radius sqrt(u1), azimuth 2 pi u2) and
// lifted onto the hemisphere (Pharr, Jakob & Humphreys, "Physically Based Rendering",
// "Cosine-Weighted Hemisphere Sampling").
struct CosineFrame {
    explicit CosineFrame(const glm::dvec3& normal) : n(normal) {
        const double sign = std::copysign(1.0, n.z);
        const double a = -1.0 / (sign + n.z);
        const double b = n.x * n.y * a;
        t = glm::dvec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        bitangent = glm::dvec3(b, sign + n.y * n.y * a, -n.y);
    }
    // The direction of u1 with the azimuth's cosine and sine.
    glm::dvec3 direction(double u1, double cosPhi, double sinPhi) const {
        const double r = std::sqrt(u1);
        return r * cosPhi * t + r * sinPhi * bitangent + std::sqrt(std::max(0.0, 1.0 - u1)) * n;
    }

    glm::dvec3 n;
    glm::dvec3 t{0.0};
    glm::dvec3 bitangent{0.0};
};

inline glm::dvec3 cosineDirection(const glm::dvec3& n, double u1, double u2) {
    const double phi = 2.0 * std::numbers::pi * u2;
    return CosineFrame(n).direction(u1, std::cos(phi), std::sin(phi));
}

// cos x and sin x for |x| <= pi / 4 by their Taylor series to x^18 and x^19, Horner in x^2 (the first
// term left out, below 1e-19 there).
inline glm::dvec2 smallAngleCosSin(double x) {
    // (-1)^k / (2k)! and (-1)^k / (2k + 1)!, k = 0..9.
    struct Terms {
        std::array<double, 10> cosine{}, sine{};
    };
    constexpr Terms kTerms = [] {
        Terms terms;
        double factorial = 1.0;
        for (int k = 0; k < 10; ++k) {
            const double sign = k % 2 ? -1.0 : 1.0;
            if (k > 0) factorial *= double(2 * k - 1) * double(2 * k);
            terms.cosine[size_t(k)] = sign / factorial;
            terms.sine[size_t(k)] = sign / (factorial * double(2 * k + 1));
        }
        return terms;
    }();
    const double x2 = x * x;
    double cosine = 0.0, sine = 0.0;
    for (size_t k = kTerms.cosine.size() - 1; k > 0; --k) {
        cosine = x2 * (kTerms.cosine[k] + cosine);
        sine = x2 * (kTerms.sine[k] + sine);
    }
    return {1.0 + cosine, x * (1.0 + sine)};
}

// g x g cosine-distributed directions about a unit normal, one in each stratum of the unit square,
// row by row, jittered by a RandomStream (two numbers a stratum): cosineDirection(n, (a + u1) / g,
// (b + u2) / g) to rounding. Where g >= 8 the azimuth 2 pi (b + u2) / g is taken apart by angle
// addition: the columns' starts once, when made, and the jitter's angle (at most pi / 4) by
// smallAngleCosSin, so that no ray pays for a sincos (docs/benchmark.md).
class StratifiedCosineDirections {
  public:
    explicit StratifiedCosineDirections(int g) : g_(g) {
        for (int b = 0; g >= 8 && b < g; ++b)
            starts_.emplace_back(std::cos(kTwoPi * b / g), std::sin(kTwoPi * b / g));
    }
    int side() const { return g_; }

    // Calls direction(w) for each direction about n, in order.
    template <typename Direction>
    void forEach(const glm::dvec3& n, RandomStream& random, Direction&& direction) const {
        const CosineFrame frame(n);
        for (int a = 0; a < g_; ++a) {
            for (int b = 0; b < g_; ++b) {
                const double u1 = (a + random.next()) / g_;
                const double jitter = random.next();
                if (starts_.empty()) {
                    const double phi = kTwoPi * ((b + jitter) / g_);
                    direction(frame.direction(u1, std::cos(phi), std::sin(phi)));
                    continue;
                }
                const glm::dvec2 turn = smallAngleCosSin(kTwoPi * jitter / g_), start = starts_[size_t(b)];
                direction(frame.direction(u1, start.x * turn.x - start.y * turn.y,
                                          start.y * turn.x + start.x * turn.y));
            }
        }
    }

  private:
    static constexpr double kTwoPi = 2.0 * std::numbers::pi;
    int g_;
    std::vector<glm::dvec2> starts_; // the columns' cos, sin where g >= 8, else none
};

// Owen-scrambled Sobol' points in 2D (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020;
// glsl/sobol_words.h, shared with the gpu's paths): Sobol's first two dimensions, each scrambled by
// a hash that acts as Owen's nested uniform scrambling. Every aligned block of 2^m consecutive
// indices is then a (0, m, 2)-net, stratified at every scale, and each point is uniform over the
// seeds, so an estimate stays unbiased. Point `index` of the set named by `seed`; `shuffled`
// scrambles the index too (Burley's padding).
inline glm::dvec2 owenScrambledSobol(uint32_t index, uint64_t seed, bool shuffled) {
    const glm::uvec2 point =
        glsl::owenScrambledSobolWords(index, glm::uvec2(uint32_t(seed), uint32_t(seed >> 32)), shuffled);
    return {double(point.x) * 0x1p-32, double(point.y) * 0x1p-32};
}

using glsl::firstTexelPath;
using glsl::mortonCode;

// A uniformly distributed rotation, from the unit quaternion of three uniforms (Shoemake, "Uniform
// Random Rotations", Graphics Gems III, 1992).
inline glm::dmat3 randomRotation(RandomStream& random) {
    constexpr double kTwoPi = 2.0 * std::numbers::pi;
    const double u1 = random.next();
    const double u2 = random.next();
    const double u3 = random.next();
    const double a = std::sqrt(1.0 - u1);
    const double b = std::sqrt(u1);
    const glm::dquat q(b * std::cos(kTwoPi * u3), a * std::sin(kTwoPi * u2), a * std::cos(kTwoPi * u2),
                       b * std::sin(kTwoPi * u3));
    return glm::mat3_cast(q);
}

// Direction k of m of the spherical Fibonacci set (Marques et al., "Spherical Fibonacci Point Sets
// for Illumination Integrals", 2013): z at the centre of stratum k of [-1, 1], the azimuth
// advancing by the golden ratio.
inline glm::dvec3 fibonacciDirection(int k, int m) {
    constexpr double kInverseGoldenRatio = 0.6180339887498948482;
    const double z = 1.0 - (2.0 * k + 1.0) / m;
    const double turn = k * kInverseGoldenRatio;
    const double phi = 2.0 * std::numbers::pi * (turn - std::floor(turn));
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
}

} // namespace shprobe
