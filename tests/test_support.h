// Helpers shared by the unit tests: Gauss-Legendre quadrature, random directions, coefficient
// differences and the check that a call fails with an input error.
#pragma once
#include "common/error.h"
#include "sh/coefficients.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace shprobe::testing {

// A radiance probe of `order` whose coefficients are all distinct, for files the commands read.
inline ShCoefficients distinctProbe(int order) {
    ShCoefficients probe = makeCoefficients(order, Quantity::Radiance);
    for (size_t i = 0; i < probe.rgb.size(); ++i)
        probe.rgb[i] = glm::dvec3(1.0 + double(i), 0.5, -0.25 * double(i));
    return probe;
}

struct QuadratureNode {
    double t;
    double weight;
};

// Legendre polynomial P_l(t) by Bonnet's recurrence (m+1) P_m+1 = (2m+1) t P_m - m P_m-1.
inline double legendre(int l, double t) {
    double p0 = 1.0, p1 = t;
    if (l == 0) return p0;
    for (int m = 1; m < l; ++m) {
        const double p2 = ((2.0 * m + 1.0) * t * p1 - m * p0) / (m + 1.0);
        p0 = p1;
        p1 = p2;
    }
    return p1;
}

// Gauss-Legendre nodes on [lo, hi] by Newton's method on P_n (Abramowitz & Stegun 25.4.29):
// exact for polynomials of degree up to 2n - 1. On the default [-1, 1] the nodes are P_n's roots
// themselves, not mapped (mapping would round them).
inline std::vector<QuadratureNode> gaussLegendre(int n, double lo = -1.0, double hi = 1.0) {
    std::vector<QuadratureNode> nodes;
    for (int k = 1; k <= n; ++k) {
        double t = std::cos(std::numbers::pi * (k - 0.25) / (n + 0.5));
        double derivative = 0.0;
        for (int iteration = 0; iteration < 100; ++iteration) {
            const double pn = legendre(n, t);
            derivative = n * (t * pn - legendre(n - 1, t)) / (t * t - 1.0);
            const double step = pn / derivative;
            t -= step;
            if (std::abs(step) < 1e-16) break;
        }
        const double weight = 2.0 / ((1.0 - t * t) * derivative * derivative);
        if (lo == -1.0 && hi == 1.0)
            nodes.push_back({t, weight});
        else
            nodes.push_back({lo + 0.5 * (t + 1.0) * (hi - lo), 0.5 * (hi - lo) * weight});
    }
    return nodes;
}

// Directions uniform on the sphere: normalized standard normal triples (Muller 1959), from seed.
inline std::vector<glm::dvec3> randomDirections(int count, uint32_t seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal;
    std::vector<glm::dvec3> directions;
    for (int k = 0; k < count; ++k)
        directions.push_back(glm::normalize(glm::dvec3(normal(rng), normal(rng), normal(rng))));
    return directions;
}

// Largest difference between two probes' coefficients over all channels.
inline double maxDifference(const ShCoefficients& a, const ShCoefficients& b) {
    double difference = 0.0;
    for (size_t i = 0; i < a.rgb.size(); ++i) {
        for (int channel = 0; channel < 3; ++channel)
            difference = std::max(difference, std::abs(a.rgb[i][channel] - b.rgb[i][channel]));
    }
    return difference;
}

// Expects call to throw an Error of kind Input; what names the case in failure messages.
inline void expectInputError(const std::function<void()>& call, const char* what) {
    try {
        call();
        ADD_FAILURE() << what << " did not throw";
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Input) << what;
    }
}

// The message of the Error of `kind` that f must throw (a failure, and "", where it throws none).
inline std::string errorOf(ErrorKind kind, const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), kind) << error.what();
        return error.what();
    }
    ADD_FAILURE() << "no Error was thrown";
    return {};
}

// Whether this build runs under a sanitizer (the tests and the program are built alike), whose
// allocator owns the heap and whose shadow memory reserves terabytes of address space.
inline bool underSanitizer() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
    return true;
#endif
#endif
    return false;
}

} // namespace shprobe::testing
