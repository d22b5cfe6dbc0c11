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

double emissionWeight(const World& world, uint32_t triangle) {
    const glm::vec3 emission = world.materials[world.triangleMaterials[triangle]].emission;
    return double(std::max({emission.r, emission.g, emission.b}));
}

} // namespace

EmitterSampler::EmitterSampler(const World& world)
    : world_(&world), areaDensities_(world.triangleCount(), 0.0) {
    std::vector<double> weights;
    double total = 0.0;
    for (uint32_t t = 0; t < uint32_t(world.triangleCount()); ++t) {
        const double weight = triangleArea(world, t) * emissionWeight(world, t);
        if (!(weight > 0.0) || !std::isfinite(weight)) continue;
        triangles_.push_back(t);
        weights.push_back(weight);
        total += weight;
    }
    double sum = 0.0;
    for (size_t k = 0; k < triangles_.size(); ++k) {
        sum += weights[k];
        cumulative_.push_back(sum / total);
        areaDensities_[triangles_[k]] = weights[k] / total / triangleArea(world, triangles_[k]);
    }
    if (!cumulative_.empty()) cumulative_.back() = 1.0;
}

EmitterPoint EmitterSampler::sample(double u0, double u1, double u2) const {
    const size_t k =
        std::min(size_t(std::upper_bound(cumulative_.begin(), cumulative_.end(), u0) - cumulative_.begin()),
                 triangles_.size() - 1);
    const uint32_t triangle = triangles_[k];
    const double root = std::sqrt(u1);
    const glm::dvec2 barycentric(root * (1.0 - u2), root * u2);
    const uint32_t* vertex = &world_->indices[3 * size_t(triangle)];
    const glm::dvec3 p0(world_->positions[vertex[0]]), p1(world_->positions[vertex[1]]),
        p2(world_->positions[vertex[2]]);
    const glm::dvec3 position =
        (1.0 - barycentric.x - barycentric.y) * p0 + barycentric.x * p1 + barycentric.y * p2;
    return {triangle, barycentric, position, areaDensities_[triangle]};
}

double EmitterSampler::areaDensity(uint32_t triangle) const {
    return areaDensities_[triangle];
}

} // namespace shprobe
