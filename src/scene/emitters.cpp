#include "scene/emitters.h"

#include "common/parallel.h"
#include "scene/sampling.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

namespace shprobe {

namespace {

double triangleArea(const World& world, uint32_t triangle) {
    const auto [p0, p1, p2] = triangleCorners(world, triangle);
    return 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
}

// The point of `triangle` at barycentrics (u, v): (1 - u - v) p0 + u p1 + v p2.
glm::dvec3 trianglePoint(const World& world, uint32_t triangle, const glm::dvec2& barycentric) {
    const uint32_t* vertex = &world.indices[3 * size_t(triangle)];
    return (1.0 - barycentric.x - barycentric.y) * glm::dvec3(world.positions[vertex[0]]) +
           barycentric.x * glm::dvec3(world.positions[vertex[1]]) +
           barycentric.y * glm::dvec3(world.positions[vertex[2]]);
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

// The plane square of a sun (unit direction `toSun`) covering the world's bounding sphere, its
// corner twice the sphere's radius out towards the sun, so that every ray from it starts outside
// the world; its sides follow CosineFrame's tangents about the sun's direction.
SunPlane sunPlane(const World& world, const glm::dvec3& toSun) {
    const glm::dvec3 low(world.boundsMin), high(world.boundsMax);
    const double radius = 0.5 * glm::length(high - low) * 1.01;
    const CosineFrame frame(toSun);
    const double cell = 2.0 * radius / SunlitSampler::kCells;
    return {0.5 * (low + high) - radius * (frame.t + frame.bitangent) + 2.0 * radius * toSun, cell * frame.t,
            cell * frame.bitangent, toSun, cell};
}

// The share of the light leaving `surface` (cosine-weighted) that meets another surface: 3 x 3 rays
// through the centres of the strata of cosine-distributed directions. Light that leaves only for
// the sky (a sunlit roof's) lights nothing a probe sees after a bounce.
double reachingShare(const SurfaceHit& surface, const RayCaster& caster) {
    constexpr int kSide = 3;
    int met = 0;
    for (int b = 0; b < kSide; ++b)
        for (int a = 0; a < kSide; ++a) {
            const glm::dvec3 direction =
                cosineDirection(surface.shadingNormal, (a + 0.5) / kSide, (b + 0.5) / kSide);
            met += caster.anyHit({glm::vec3(surface.rayOrigin), glm::vec3(direction)}) ? 1 : 0;
        }
    return double(met) / (kSide * kSide);
}

// The light a sun's ray reflects where it first meets a surface, per unit area of its plane, that
// reaches another surface: the largest channel of albedo times the sun's irradiance times n.l
// (shading normal) over |n.l| (geometric, capped at 4 times), times reachingShare; 0 where it meets
// nothing, a back face or a surface turned away.
double sunlitPower(const SceneShading& shading, const SceneSun& sun, const SunPlane& plane,
                   const RayCaster& caster, const glm::dvec3& origin) {
    const glm::dvec3 direction = -plane.toSun;
    const std::optional<RayHit> hit = caster.closestHit({glm::vec3(origin), glm::vec3(direction)});
    if (!hit) return 0.0;
    const SurfaceHit surface = shading.describe(hit->triangle, {hit->hit.u, hit->hit.v}, direction);
    const double lit = glm::dot(surface.shadingNormal, plane.toSun);
    if (surface.backFace || !(lit > 0.0)) return 0.0;
    const glm::dvec3 reflected = surface.albedo * glm::dvec3(sun.irradiance);
    const double slant = std::abs(glm::dot(surface.normal, plane.toSun));
    const double power = std::max({reflected.r, reflected.g, reflected.b}) * std::min(lit / slant, 4.0);
    return power > 0.0 ? power * reachingShare(surface, caster) : 0.0;
}

// Each cell's weight, or a quarter of its largest neighbour's where that is more (rows of
// SunlitSampler::kCells, kCells rows a sun).
std::vector<double> withLitNeighbours(const std::vector<double>& weights) {
    const int n = SunlitSampler::kCells;
    std::vector<double> dilated = weights;
    for (size_t first = 0; first < weights.size(); first += size_t(n) * n)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                double& cell = dilated[first + size_t(j) * n + size_t(i)];
                for (int b = std::max(j - 1, 0); b <= std::min(j + 1, n - 1); ++b)
                    for (int a = std::max(i - 1, 0); a <= std::min(i + 1, n - 1); ++a)
                        cell = std::max(cell, 0.25 * weights[first + size_t(b) * n + size_t(a)]);
            }
    return dilated;
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
    return {triangle, barycentric, trianglePoint(*world_, triangle, barycentric), areaDensity(triangle)};
}

double EmitterSampler::areaDensity(uint32_t triangle) const {
    const double probability = triangles_.probability(triangle);
    return probability > 0.0 ? probability / triangleArea(*world_, triangle) : 0.0;
}

SunlitSampler::SunlitSampler(const SceneShading& shading, const RayCaster& caster)
    : shading_(&shading), caster_(&caster) {
    const World& world = shading.world();
    if (world.suns.empty() || world.triangleCount() == 0) return;
    const size_t perSun = size_t(kCells) * kCells;
    std::vector<double> weights(world.suns.size() * perSun);
    for (const SceneSun& sun : world.suns)
        planes_.push_back(sunPlane(world, glm::normalize(glm::dvec3(sun.direction))));
    forEachItem(int(weights.size() / kCells), threadCount(weights.size(), 1024), [&](int row) {
        const size_t sun = size_t(row) / kCells;
        const SunPlane& plane = planes_[sun];
        for (int i = 0; i < kCells; ++i) {
            const glm::dvec3 centre =
                plane.corner + (i + 0.5) * plane.across + (row % kCells + 0.5) * plane.down;
            weights[size_t(row) * kCells + size_t(i)] =
                sunlitPower(shading, world.suns[sun], plane, caster, centre);
        }
    });
    // A sun whose light reaches other surfaces from 4% of its square or more lights the scene
    // broadly, and the cosine rays meet what it lights often enough: sampling it costs time for no
    // lower error (docs/benchmark.md). Sunlight let in through an opening reaches them from 1%.
    constexpr double kMostLitShare = 0.04;
    for (size_t first = 0; first < weights.size(); first += perSun) {
        const auto cells = weights.begin() + std::ptrdiff_t(first);
        const double lit =
            double(std::count_if(cells, cells + std::ptrdiff_t(perSun), [](double w) { return w > 0.0; }));
        if (lit >= kMostLitShare * double(perSun)) std::fill(cells, cells + std::ptrdiff_t(perSun), 0.0);
    }
    cells_ = DiscreteDistribution(withLitNeighbours(weights));
    if (cells_.empty()) planes_.clear();
}

SunlitLight SunlitSampler::reflectedTo(const SurfaceHit& at, double u0, double u1, double u2,
                                       uint64_t& rays) const {
    const SunRay sunRay = sample(u0, u1, u2);
    ++rays;
    const std::optional<RayHit> met =
        caster_->closestHit({glm::vec3(sunRay.origin), glm::vec3(sunRay.direction)});
    if (!met) return {};
    const glm::dvec2 barycentric(met->hit.u, met->hit.v);
    const glm::dvec3 toLit = trianglePoint(shading_->world(), met->triangle, barycentric) - at.rayOrigin;
    const double distance = glm::length(toLit);
    if (!(distance > 0.0)) return {};
    const glm::dvec3 direction = toLit / distance;
    const double cosine = glm::dot(at.shadingNormal, direction);
    if (!(cosine > 0.0)) return {};
    const SurfaceHit lit = shading_->describe(met->triangle, barycentric, direction);
    const SceneSun& sun = shading_->suns()[sunRay.sun];
    const glm::dvec3 toSun(sun.direction);
    const double sunCosine = glm::dot(lit.shadingNormal, toSun);
    const double litCosine = std::abs(glm::dot(lit.normal, direction));
    if (lit.backFace || !(sunCosine > 0.0) || !(litCosine > 0.0)) return {};
    const float reach = float(distance - 2.0 * std::max(at.offset, lit.offset));
    ++rays;
    if (caster_->anyHit({glm::vec3(at.rayOrigin), glm::vec3(direction), 0.0f, reach})) return {};
    ++rays;
    if (caster_->anyHit({glm::vec3(lit.rayOrigin), glm::vec3(toSun)})) return {};
    const double density =
        sunRay.planeDensity * std::abs(glm::dot(lit.normal, toSun)) * distance * distance / litCosine;
    if (!(density > 0.0)) return {};
    const glm::dvec3 reflected = lit.albedo * std::numbers::inv_pi * glm::dvec3(sun.irradiance) * sunCosine;
    return {reflected * (cosine / density), density, cosine};
}

size_t SunlitSampler::sampledSuns() const {
    const uint32_t perSun = uint32_t(kCells) * kCells;
    size_t suns = 0;
    uint32_t last = UINT32_MAX;
    for (const uint32_t cell : cells_.picked()) { // in order: sun after sun
        if (cell / perSun != last) ++suns;
        last = cell / perSun;
    }
    return suns;
}

SunRay SunlitSampler::sample(double u0, double u1, double u2) const {
    const uint32_t index = cells_.pick(u0);
    const uint32_t perSun = uint32_t(kCells) * kCells;
    const uint32_t sun = index / perSun, i = index % kCells, j = index % perSun / kCells;
    const SunPlane& plane = planes_[sun];
    return {sun, plane.corner + (i + u1) * plane.across + (j + u2) * plane.down, -plane.toSun,
            cells_.probability(index) / (plane.cellSize * plane.cellSize)};
}

double SunlitSampler::areaDensity(uint32_t sun, const glm::dvec3& position, const glm::dvec3& normal) const {
    if (sun >= planes_.size()) return 0.0;
    const SunPlane& plane = planes_[sun];
    const double area = plane.cellSize * plane.cellSize;
    const glm::dvec3 offset = position - plane.corner;
    const double i = std::floor(glm::dot(offset, plane.across) / area),
                 j = std::floor(glm::dot(offset, plane.down) / area);
    if (!(i >= 0.0 && i < kCells && j >= 0.0 && j < kCells)) return 0.0;
    const uint32_t index = sun * uint32_t(kCells) * kCells + uint32_t(j) * kCells + uint32_t(i);
    return cells_.probability(index) / area * std::abs(glm::dot(normal, plane.toSun));
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
