// Points on a world's emissive triangles for next-event estimation: light that paths find only by
// chance (a small bright lamp) sampled where it is, each sample weighted against the cosine rays'
// own chance of meeting it by the power heuristic (Veach and Guibas, "Optimally Combining Sampling
// Techniques for Monte Carlo Rendering", 1995), so that neither estimate counts it twice.
#pragma once
#include "scene/scene.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace shprobe {

// A point on an emissive triangle and its probability density per unit area.
struct EmitterPoint {
    uint32_t triangle = 0;
    glm::dvec2 barycentric{0.0}; // (u, v): (1 - u - v) p0 + u p1 + v p2
    glm::dvec3 position{0.0};
    double areaDensity = 0.0;
};

// A triangle is picked with probability proportional to its area times its emission factor's largest
// channel, and a point uniformly on it (Pharr, Jakob & Humphreys, "Physically Based Rendering",
// "Sampling a Triangle"). Triangles of no area or no emission are never picked.
class EmitterSampler {
  public:
    explicit EmitterSampler(const World& world);
    bool empty() const { return triangles_.empty(); }
    // The point for three numbers uniform in [0, 1).
    EmitterPoint sample(double u0, double u1, double u2) const;
    // The density per unit area of sample()'s points on `triangle`: 0 where it is never picked.
    double areaDensity(uint32_t triangle) const;

  private:
    const World* world_;
    std::vector<uint32_t> triangles_;   // the emissive ones
    std::vector<double> cumulative_;    // their weights' running sums, the last one 1
    std::vector<double> areaDensities_; // per World triangle
};

// The power heuristic's weight (exponent 2) of a sample drawn with density `chosen` where another
// technique would have drawn it with density `other` (both per unit solid angle).
inline double powerHeuristic(double chosen, double other) {
    const double a = chosen * chosen, b = other * other;
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

} // namespace shprobe
