// Hanning and Lanczos windows and Sloan's de-ringing by scan and bisection (see windowing.h).
#include "sh/windowing.h"

#include "common/error.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInfinity = std::numeric_limits<double>::infinity();
// Local refinement: start from this many of the lowest samples, stop when the step is this small.
constexpr int kRefinedSamples = 8;
constexpr double kSmallestStep = 1e-9;
constexpr int kMaxRefinementSteps = 2000;

void requireSampleCount(int sampleCount) {
    if (sampleCount < 1) throw Error(ErrorKind::Input, "minimum search needs at least one sample direction");
}

double smallestChannel(const glm::dvec3& v, int* channel = nullptr) {
    const int c = v.r <= v.g && v.r <= v.b ? 0 : (v.g <= v.b ? 1 : 2);
    if (channel) *channel = c;
    return v[c];
}

// Direction k of n spread evenly by the golden angle (a Fibonacci sphere): z uniform in (-1, 1).
glm::dvec3 fibonacciDirection(int k, int n) {
    const double goldenAngle = kPi * (3.0 - std::sqrt(5.0));
    const double z = 1.0 - (2.0 * k + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(goldenAngle * k), r * std::sin(goldenAngle * k), z};
}

// The basis at every sample direction, computed once and reused for every window tried.
struct SampleTable {
    int order = 0;
    std::vector<glm::dvec3> directions;
    std::vector<double> basis; // directions.size() x order^2

    SampleTable(int basisOrder, int sampleCount) : order(basisOrder) {
        const size_t count = size_t(coefficientCount(order));
        basis.resize(size_t(sampleCount) * count);
        for (int k = 0; k < sampleCount; ++k) {
            directions.push_back(fibonacciDirection(k, sampleCount));
            evalBasis(order, directions.back(), std::span<double>(basis).subspan(size_t(k) * count, count));
        }
    }

    double valueAt(const ShCoefficients& c, size_t k) const {
        const double* y = &basis[k * c.rgb.size()];
        glm::dvec3 sum(0.0);
        for (size_t i = 0; i < c.rgb.size(); ++i)
            sum += c.rgb[i] * y[i];
        return smallestChannel(sum);
    }
};

// Pattern search on the sphere: try eight tangent directions at step h, move to the best lower
// point, halve h when none is lower.
SphereMinimum refine(const ShCoefficients& c, glm::dvec3 p, double step) {
    double value = smallestChannel(evaluate(c, p));
    for (int iteration = 0; iteration < kMaxRefinementSteps && step > kSmallestStep; ++iteration) {
        const glm::dvec3 helper = std::abs(p.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
        const glm::dvec3 t1 = glm::normalize(glm::cross(p, helper));
        const glm::dvec3 t2 = glm::cross(p, t1);
        glm::dvec3 best = p;
        double bestValue = value;
        for (int k = 0; k < 8; ++k) {
            const double angle = kPi / 4.0 * k;
            const glm::dvec3 q = glm::normalize(p + step * (std::cos(angle) * t1 + std::sin(angle) * t2));
            const double v = smallestChannel(evaluate(c, q));
            if (v < bestValue) best = q, bestValue = v;
        }
        if (bestValue < value) {
            p = best, value = bestValue;
        } else {
            step *= 0.5;
        }
    }
    SphereMinimum minimum{value, p, 0};
    smallestChannel(evaluate(c, p), &minimum.channel);
    return minimum;
}

SphereMinimum minimumWithTable(const ShCoefficients& c, const SampleTable& table) {
    std::vector<std::pair<double, size_t>> values(table.directions.size());
    for (size_t k = 0; k < values.size(); ++k)
        values[k] = {table.valueAt(c, k), k};
    const size_t starts = std::min(values.size(), size_t(kRefinedSamples));
    std::partial_sort(values.begin(), values.begin() + std::ptrdiff_t(starts), values.end());
    const double spacing = std::sqrt(4.0 * kPi / double(values.size()));
    SphereMinimum minimum = refine(c, table.directions[values[0].second], spacing);
    for (size_t s = 1; s < starts; ++s) {
        const SphereMinimum candidate = refine(c, table.directions[values[s].second], spacing);
        if (candidate.value < minimum.value) minimum = candidate;
    }
    return minimum;
}

// The function whose sign de-ringing controls, for a window of the given strength.
ShCoefficients windowedTarget(const ShCoefficients& radiance, const DeringOptions& options, double strength) {
    const double width = strength > 0.0 ? 1.0 / strength : kInfinity;
    const ShCoefficients windowed =
        applyWindow(radiance, windowFactors(options.window, width, radiance.order));
    return options.target == DeringTarget::Irradiance ? convolveIrradiance(windowed) : windowed;
}

// A negative strength and a non-negative one, and the minimum found at the latter.
struct StrengthBracket {
    double negative = 0.0;
    double nonNegative = 1.0;
    double minimum = 0.0;
};

// Non-negativity is not monotone in the strength (a sky with a sun at order 5: non-negative for
// strengths 0.12..0.17, negative again until 0.49), so the strengths k / steps are tried from the
// weakest, and the first non-negative one is bracketed with the step before it. Strength 1 keeps
// band 0 alone, which is non-negative once L00 >= 0 is checked.
template <typename MinimumAt> StrengthBracket scanForNonNegative(const MinimumAt& minimumAt, int steps) {
    StrengthBracket bracket;
    for (int step = 1; step <= steps; ++step) {
        const double strength = double(step) / steps;
        const double value = minimumAt(strength);
        if (value >= 0.0) {
            bracket.nonNegative = strength, bracket.minimum = value;
            break;
        }
        bracket.negative = strength;
    }
    return bracket;
}

template <typename MinimumAt>
void bisect(StrengthBracket& bracket, const MinimumAt& minimumAt, double tolerance) {
    while (bracket.nonNegative - bracket.negative > tolerance) {
        const double middle = 0.5 * (bracket.negative + bracket.nonNegative);
        const double value = minimumAt(middle);
        if (value >= 0.0) {
            bracket.nonNegative = middle, bracket.minimum = value;
        } else {
            bracket.negative = middle;
        }
    }
}

void requireDeringInput(const ShCoefficients& radiance, const DeringOptions& options) {
    requireCoefficients(radiance);
    requireSampleCount(options.sampleCount);
    if (radiance.quantity != Quantity::Radiance) {
        throw Error(ErrorKind::Input, "de-ringing needs radiance coefficients, got irradiance");
    }
    if (!(options.strengthTolerance > 0.0) || options.scanSteps < 1) {
        throw Error(ErrorKind::Input, "de-ringing needs a positive tolerance and at least one scan step");
    }
    const glm::dvec3 mean = radiance.rgb[0];
    if (mean.r < 0.0 || mean.g < 0.0 || mean.b < 0.0) {
        throw Error(ErrorKind::Input,
                    "probe has a negative mean radiance (L00 < 0): no window makes it non-negative");
    }
}

} // namespace

std::vector<double> windowFactors(WindowKind kind, double width, int order) {
    requireOrder(order);
    if (!(width > 0.0))
        throw Error(ErrorKind::Input, "window width must be positive, got " + std::to_string(width));
    std::vector<double> factors(static_cast<size_t>(order), 1.0);
    for (int l = 1; l < order; ++l) {
        const double x = l / width; // 0 for an infinite width
        if (x >= 1.0) {
            factors[size_t(l)] = 0.0;
        } else if (kind == WindowKind::Hanning) {
            factors[size_t(l)] = 0.5 * (1.0 + std::cos(kPi * x));
        } else if (x > 0.0) {
            factors[size_t(l)] = std::sin(kPi * x) / (kPi * x);
        }
    }
    return factors;
}

ShCoefficients applyWindow(const ShCoefficients& coefficients, std::span<const double> bandFactors) {
    requireCoefficients(coefficients);
    if (bandFactors.size() < size_t(coefficients.order)) {
        throw Error(ErrorKind::Input, "window holds " + std::to_string(bandFactors.size()) +
                                          " band factors, order " + std::to_string(coefficients.order) +
                                          " needs " + std::to_string(coefficients.order));
    }
    ShCoefficients windowed = coefficients;
    for (size_t i = 0; i < windowed.rgb.size(); ++i)
        windowed.rgb[i] *= bandFactors[size_t(shBand(int(i)))];
    return windowed;
}

SphereMinimum minimumOnSphere(const ShCoefficients& coefficients, int sampleCount) {
    requireCoefficients(coefficients);
    requireSampleCount(sampleCount);
    return minimumWithTable(coefficients, SampleTable(coefficients.order, sampleCount));
}

DeringResult deringWindow(const ShCoefficients& radiance, const DeringOptions& options) {
    requireDeringInput(radiance, options);
    const SampleTable table(radiance.order, options.sampleCount);
    auto minimumAt = [&](double strength) {
        return minimumWithTable(windowedTarget(radiance, options, strength), table).value;
    };
    const double unwindowed = minimumAt(0.0);
    if (unwindowed >= 0.0) {
        return DeringResult{windowFactors(options.window, kInfinity, radiance.order), kInfinity, unwindowed};
    }
    StrengthBracket bracket = scanForNonNegative(minimumAt, options.scanSteps);
    bisect(bracket, minimumAt, options.strengthTolerance);
    const double width = 1.0 / bracket.nonNegative;
    return DeringResult{windowFactors(options.window, width, radiance.order), width, bracket.minimum};
}

} // namespace shprobe
