#include "scene/emitters.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace shprobe {

namespace {

double triangleArea(const World& world, uint32_t triangle) {
    const uint32_t* vertex = &world.indices[3 * size_t(triangle)];
    const glm::dvec3 p0(world.positions[vertex[0]]), p1(world.positions[vertex[1]]),
        p2(world.positions[vertex[2]]);
    return 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
}

// Each triangle's area times its emission factor's largest channel.
std::vector<double> emittedPower(const World& world) {
    std::vector<double> weights(world.triangleCount());
    for (uint32_t t = 0; t < uint32_t(weights.size()); ++t) {
        const glm::vec3 emission = world.materials[world.triangleMaterials[t]].emission;
        weights[t] = triangleArea(world, t) * double(std::max({emission.r, emission.g, emission.b}));
    }
    return weights;
}

// Each texel's largest channel times its solid angle; none where no texel holds at least 4 times
// the mean (SkySampler).
std::vector<double> skyPower(const Cubemap& sky) {
    const uint32_t n = uint32_t(sky.faceSize);
    std::vector<double> weights(sky.texels.size());
    double total = 0.0, largest = 0.0;
    for (uint32_t t = 0; t < uint32_t(weights.size()); ++t) {
        const glm::vec4 texel = sky.texels[t];
        weights[t] = double(std::max({texel.r, texel.g, texel.b})) *
                     texelSolidAngle(int(t % n), int(t / n % n), int(n));
        if (!(std::isfinite(weights[t]) && weights[t] > 0.0)) continue;
        total += weights[t];
        largest = std::max(largest, weights[t]);
    }
    if (!(largest >= 4.0 * total / double(weights.size()))) return std::vector<double>(weights.size(), 0.0);
    return weights;
}

// The area of face points per unit solid angle at (a, b): (1 + a^2 + b^2)^(3/2).
double faceAreaPerSolidAngle(double a, double b) {
    const double r2 = 1.0 + a * a + b * b;
    return r2 * std::sqrt(r2);
}

} // namespace

DiscreteDistribution::DiscreteDistribution(const std::vector<double>& weights)
    : probabilities_(weights.size(), 0.0) {
    double total = 0.0;
    for (uint32_t i = 0; i < uint32_t(weights.size()); ++i) {
        if (!(weights[i] > 0.0) || !std::isfinite(weights[i])) continue;
        picked_.push_back(i);
        total += weights[i];
    }
    double sum = 0.0;
    for (const uint32_t i : picked_) {
        probabilities_[i] = weights[i] / total;
        cumulative_.push_back((sum += weights[i]) / total);
    }
    if (!cumulative_.empty()) cumulative_.back() = 1.0;
}

uint32_t DiscreteDistribution::pick(double u) const {
    const size_t k =
        size_t(std::upper_bound(cumulative_.begin(), cumulative_.end(), u) - cumulative_.begin());
    return picked_[std::min(k, picked_.size() - 1)];
}

EmitterSampler::EmitterSampler(const World& world) : world_(&world), triangles_(emittedPower(world)) {}

EmitterPoint EmitterSampler::sample(double u0, double u1, double u2) const {
    const uint32_t triangle = triangles_.pick(u0);
    const double root = std::sqrt(u1);
    const glm::dvec2 barycentric(root * (1.0 - u2), root * u2);
    const uint32_t* vertex = &world_->indices[3 * size_t(triangle)];
    const glm::dvec3 p0(world_->positions[vertex[0]]), p1(world_->positions[vertex[1]]),
        p2(world_->positions[vertex[2]]);
    const glm::dvec3 position =
        (1.0 - barycentric.x - barycentric.y) * p0 + barycentric.x * p1 + barycentric.y * p2;
    return {triangle, barycentric, position, areaDensity(triangle)};
}

double EmitterSampler::areaDensity(uint32_t triangle) const {
    const double probability = triangles_.probability(triangle);
    return probability > 0.0 ? probability / triangleArea(*world_, triangle) : 0.0;
}

std::vector<uint32_t> stratumSkyRays(const Cubemap& sky, int faceSize, int side) {
    constexpr double kShareOfView = 0.25;
    constexpr double kMostInAStratum = 4096.0;
    if (side < 2) return {};
    const int m = faceSize * side, n = sky.faceSize;
    std::vector<double> weights(size_t(kFaceCount) * size_t(m) * size_t(m));
    double total = 0.0;
    for (size_t c = 0; c < weights.size(); ++c) {
        const int face = int(c / (size_t(m) * m)), j = int(c / m % m), i = int(c % m);
        // The sky's texel holding the stratum's centre, as skyRadiance reads it there.
        const glm::vec4 texel = sky.at(face, (2 * i + 1) * n / (2 * m), (2 * j + 1) * n / (2 * m));
        const double weight = double(std::max({texel.r, texel.g, texel.b})) * texelSolidAngle(i, j, m);
        weights[c] = std::isfinite(weight) && weight > 0.0 ? weight : 0.0;
        total += weights[c];
    }
    if (!(total > 0.0)) return {};
    const double budget = kShareOfView * double(weights.size());
    std::vector<uint32_t> rays(weights.size());
    for (size_t c = 0; c < weights.size(); ++c)
        rays[c] = uint32_t(std::min(kMostInAStratum, std::floor(budget * weights[c] / total)));
    if (std::all_of(rays.begin(), rays.end(), [](uint32_t count) { return count == 0; })) return {};
    return rays;
}

SkySampler::SkySampler(const Cubemap& sky) : faceSize_(sky.faceSize), texels_(skyPower(sky)) {}

SkyDirection SkySampler::sample(double u0, double u1, double u2) const {
    const uint32_t texel = texels_.pick(u0);
    const uint32_t n = uint32_t(faceSize_);
    const int face = int(texel / (n * n));
    const double a = 2.0 * (double(texel % n) + u1) / n - 1.0;
    const double b = 2.0 * (double(texel / n % n) + u2) / n - 1.0;
    return {faceDirection(face, a, b), densityAt(texel, a, b)};
}

// Texel `texel`'s probability per unit face area (each texel (2 / N)^2 of it) per unit solid angle at
// face point (a, b).
double SkySampler::densityAt(uint32_t texel, double a, double b) const {
    const double texelArea = 4.0 / (double(faceSize_) * faceSize_);
    return texels_.probability(texel) / texelArea * faceAreaPerSolidAngle(a, b);
}

double SkySampler::density(const glm::dvec3& direction) const {
    const FacePoint point = directionToFace(direction);
    const int n = faceSize_;
    const auto texel = [n](double coordinate) {
        return std::clamp(int(std::floor((coordinate + 1.0) * 0.5 * n)), 0, n - 1);
    };
    return densityAt(uint32_t((point.face * n + texel(point.b)) * n + texel(point.a)), point.a, point.b);
}

} // namespace shprobe
