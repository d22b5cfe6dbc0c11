// Points on a world's emissive triangles and directions towards its sky's bright texels, for
// next-event estimation: light that paths find only by chance (a small bright lamp, a gap in a
// canopy) sampled where it is, each sample weighted against the cosine rays' own chance of meeting
// it by the power heuristic (Veach and Guibas, "Optimally Combining Sampling Techniques for Monte
// Carlo Rendering", 1995), so that neither estimate counts it twice.
#pragma once
#include "glsl/ray_capture_interface.h"
#include "scene/ray_caster.h"
#include "scene/scene.h"
#include "scene/surface_shading.h"
#include "sh/cubemap.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace shprobe {

// Indices picked with probability proportional to their weights (an index of weight 0, or of a weight
// that is not finite, never).
class DiscreteDistribution {
  public:
    explicit DiscreteDistribution(const std::vector<double>& weights);
    bool empty() const { return picked_.empty(); }
    // The index for a number uniform in [0, 1).
    uint32_t pick(double u) const;
    double probability(uint32_t index) const { return probabilities_[index]; }
    // The indices of positive weight, and their probabilities' running sums (the last 1).
    const std::vector<uint32_t>& picked() const { return picked_; }
    const std::vector<double>& cumulative() const { return cumulative_; }

  private:
    std::vector<uint32_t> picked_;      // the indices of positive weight
    std::vector<double> cumulative_;    // their probabilities' running sums, the last one 1
    std::vector<double> probabilities_; // per index
};

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
    // The triangles' distribution sample() picks from, for a device that samples as it does.
    const DiscreteDistribution& triangles() const { return triangles_; }

  private:
    const World* world_;
    DiscreteDistribution triangles_;
};

// A direction towards the sky and its probability density per unit solid angle.
struct SkyDirection {
    glm::dvec3 direction{0.0};
    double density = 0.0;
};

// A texel of a sky cube map is picked with probability proportional to its largest channel times
// its solid angle, and a point uniformly in it on its face: the density per solid angle is then
// that probability times (N / 2)^2 (1 + a^2 + b^2)^(3/2) at face point (a, b), the second factor the
// area a unit solid angle covers on the face. Texels read as SceneShading::skyRadiance reads them.
// A sky none of whose texels holds at least 4 times the mean texel's power is not sampled (empty):
// cosine rays find its light as well, and a shadow ray a bounce towards it (always blocked in a
// closed room) would be cast for nothing (docs/benchmark.md).
class SkySampler {
  public:
    explicit SkySampler(const Cubemap& sky);
    bool empty() const { return texels_.empty(); }
    // The direction for three numbers uniform in [0, 1).
    SkyDirection sample(double u0, double u1, double u2) const;
    // sample()'s density per unit solid angle at `direction` (unit): 0 towards a black texel.
    double density(const glm::dvec3& direction) const;
    // The texels' distribution sample() picks from, for a device that samples as it does.
    const DiscreteDistribution& texels() const { return texels_; }

  private:
    double densityAt(uint32_t texel, double a, double b) const;
    int faceSize_ = 0;
    DiscreteDistribution texels_; // face after face, rows top to bottom
};

// A sun's ray into the world (SunlitSampler::sample): it starts outside the world's bounding sphere
// and travels away from the sun; planeDensity is its origin's density per unit area of the sun's plane.
struct SunRay {
    uint32_t sun = 0;
    glm::dvec3 origin{0.0};
    glm::dvec3 direction{0.0};
    double planeDensity = 0.0;
};

// What a sunlit point reflects to a surface point: L max(0, n.w) / p(w), p(w) the density per solid
// angle with which it was drawn (0 where none reaches the point), and max(0, n.w).
struct SunlitLight {
    glm::dvec3 irradiance{0.0};
    double density = 0.0;
    double cosine = 0.0;
};

// The square of a sun's plane its rays start from, kCells x kCells cells across the world's
// bounding sphere: cell (i, j) spans corner + [i, i + 1] across + [j, j + 1] down.
struct SunPlane {
    glm::dvec3 corner{0.0};
    glm::dvec3 across{0.0};
    glm::dvec3 down{0.0};
    glm::dvec3 toSun{0.0};
    double cellSize = 0.0;
};

// Points the suns light, for the light they reflect: where the sun comes in through a small opening,
// the lit patch of floor lights the room, and a path's cosine rays find that patch by chance. A
// point is drawn as the first surface a sun's ray meets, the ray started in a cell of the sun's
// plane picked in proportion to the light that the surface its centre ray meets reflects and that
// reaches another surface (a sunlit roof's goes to the sky), uniformly in the cell. Its density per
// unit area of surface is the plane's, times |n.l|. Cells never picked leave what they light to the
// cosine rays, and the power heuristic keeps both estimates unbiased wherever they overlap; a cell
// next to a picked one is picked with at least a quarter of its weight, so that a lit patch's edges,
// where the cell's ray may fall just outside the light, are sampled too. A sun whose light reaches
// other surfaces from 4% of its square or more is not sampled (kMostLitShare, emitters.cpp).
class SunlitSampler {
  public:
    static constexpr int kCells = int(SHPROBE_SUNLIT_CELLS);
    SunlitSampler() = default; // empty: no sun
    // Casts kCells^2 rays a sun; `shading` is of the world `caster` casts against. Both must
    // outlive the sampler.
    SunlitSampler(const SceneShading& shading, const RayCaster& caster);
    bool empty() const { return cells_.empty(); }
    // The suns whose lit points it draws.
    size_t sampledSuns() const;
    // The ray for three numbers uniform in [0, 1); not for an empty sampler.
    SunRay sample(double u0, double u1, double u2) const;
    // The light that the first surface y met by sample()'s ray reflects of its sun to `at`, where `at`
    // sees y and y sees the sun (a ray into the world and two shadow rays, counted in `rays`).
    SunlitLight reflectedTo(const SurfaceHit& at, double u0, double u1, double u2, uint64_t& rays) const;
    // The density per unit area with which sample()'s rays for sun `sun` first meet the surface of unit
    // geometric normal `normal` at `position`, were it the first they meet there: 0 where its cell is
    // never picked.
    double areaDensity(uint32_t sun, const glm::dvec3& position, const glm::dvec3& normal) const;
    // The (sun, cell) pairs' distribution, index sun kCells^2 + j kCells + i, and the suns' planes,
    // for a device that samples as sample() does.
    const DiscreteDistribution& cells() const { return cells_; }
    const std::vector<SunPlane>& planes() const { return planes_; }

  private:
    const SceneShading* shading_ = nullptr;
    const RayCaster* caster_ = nullptr;
    std::vector<SunPlane> planes_;
    DiscreteDistribution cells_{std::vector<double>{}};
};

// The shadow rays a texel view of faces `faceSize` with side x side rays a texel adds towards the sky
// in each of its strata (the strata of all faces, rows of faceSize side, in order): a quarter of the
// view's rays shared out in proportion to the sky's largest channel at the stratum's centre times
// the stratum's solid angle, rounded down (so none below 4 times the mean), at most 4096 a stratum.
// The sky a stratum shows is then the mean of what its ray and these see of it (scene/ray_bake.cpp
// skyThroughStratum), so that a small bright patch of sky partly behind an edge is measured by many
// rays, not won or lost by one; a smooth sky gets none. Empty where side < 2 (rays through the
// texels' centres) or no stratum gets a ray.
std::vector<uint32_t> stratumSkyRays(const Cubemap& sky, int faceSize, int side);

// The power heuristic's weight (exponent 2) of a sample drawn with density `chosen` where another
// technique would have drawn it with density `other` (both per unit solid angle).
inline double powerHeuristic(double chosen, double other) {
    const double a = chosen * chosen, b = other * other;
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

} // namespace shprobe
