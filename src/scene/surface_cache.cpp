// SurfaceCache (surface_cache.h): lattices of points on the triangles, cells halved where their
// corners disagree.
#include "scene/surface_cache.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace shprobe {

namespace {

// The index of lattice point (i, j), i + j <= m, row by row.
size_t latticeIndex(int m, int i, int j) {
    return size_t(j) * size_t(m + 1) - size_t(j) * size_t(j - 1) / 2 + size_t(i);
}

// Three lattice points, their weights, and the cell they are the corners of: the lower cells
// (i0 + j0 <= m - 1) first, row by row, then the upper ones (i0 + j0 <= m - 2), m^2 in all.
struct LatticeBlend {
    std::array<size_t, 3> points{};
    glm::dvec3 weights{0.0};
    size_t cell = 0;
};

// Linear interpolation over the lattice triangles: (u, v) m falls in cell (i0, j0), whose lower
// triangle has corners (i0, j0), (i0 + 1, j0), (i0, j0 + 1) and whose upper one, where it exists
// (i0 + j0 + 2 <= m), (i0 + 1, j0 + 1), (i0, j0 + 1), (i0 + 1, j0).
LatticeBlend blendAt(int m, const glm::dvec2& barycentric) {
    const double x = std::clamp(barycentric.x, 0.0, 1.0) * m;
    const double y = std::clamp(barycentric.y, 0.0, 1.0) * m;
    int i0 = std::min(int(x), m - 1);
    int j0 = std::min(int(y), m - 1);
    while (i0 + j0 > m - 1) // u + v a rounding over 1
        (i0 > 0 ? i0 : j0) -= 1;
    const double fx = x - i0;
    const double fy = y - j0;
    if (fx + fy <= 1.0 || i0 + j0 + 2 > m) {
        return {{latticeIndex(m, i0, j0), latticeIndex(m, i0 + 1, j0), latticeIndex(m, i0, j0 + 1)},
                glm::dvec3(1.0 - fx - fy, fx, fy),
                latticeIndex(m - 1, i0, j0)};
    }
    return {{latticeIndex(m, i0 + 1, j0 + 1), latticeIndex(m, i0, j0 + 1), latticeIndex(m, i0 + 1, j0)},
            glm::dvec3(fx + fy - 1.0, 1.0 - fx, 1.0 - fy),
            latticePoints(m - 1) + latticeIndex(m - 2, i0, j0)};
}

// A point's state: not gathered, being gathered by some thread, gathered.
constexpr uint8_t kEmpty = 0;
constexpr uint8_t kGathering = 1;
constexpr uint8_t kReady = 2;

// A cell's state, where it is not a pointer to its halves: not yet decided, interpolated whole,
// interpolated whole from the corners the shaded point sees.
constexpr uintptr_t kUndecided = 0;
constexpr uintptr_t kWhole = 1;
constexpr uintptr_t kWholeBlocked = 2;

// A point gathered by the first thread that needs it and kept. Another that needs it while it is
// being gathered gathers it too, rather than wait on a thread the system may not be running: the
// same rays and numbers give the same value, so only time is lost, and rarely.
template <typename Gather>
CachePoint keptPoint(std::atomic<uint8_t>& state, CachePoint& value, std::atomic<uint64_t>& gathered,
                     const Gather& gather) {
    uint8_t seen = state.load(std::memory_order_acquire);
    if (seen == kReady) return value;
    const CachePoint point = gather();
    if (seen == kEmpty && state.compare_exchange_strong(seen, kGathering, std::memory_order_acquire)) {
        value = point;
        state.store(kReady, std::memory_order_release);
        ++gathered;
    }
    return point;
}

template <typename Corners> glm::dvec3 mix(const Corners& corners, const glm::dvec3& weights) {
    glm::dvec3 sum(0.0);
    for (int c = 0; c < 3; ++c)
        if (weights[c] != 0.0) sum += weights[c] * glm::dvec3(corners[c].point.irradiance);
    return sum;
}

// The child of a halved cell that barycentrics (a, b, c) fall in: 0, 1, 2 at corners A, B, C
// (where a, b or c is at least 1/2), else 3, the middle one.
int childAt(const glm::dvec3& weights) {
    for (int c = 0; c < 3; ++c)
        if (weights[c] >= 0.5) return c;
    return 3;
}

// Whether a cell's corners' irradiance (the channels summed) differs by more than kCacheContrast
// of the brightest.
template <typename Corners> bool disagree(const Corners& corners) {
    double lowest = std::numeric_limits<double>::infinity(), highest = 0.0;
    for (const auto& corner : corners) {
        const glm::vec3& e = corner.point.irradiance;
        const double sum = double(e.r) + double(e.g) + double(e.b);
        lowest = std::min(lowest, sum);
        highest = std::max(highest, sum);
    }
    return highest - lowest > kCacheContrast * highest;
}

// The edges' midpoints of a halved cell, AB, BC and CA, that child needs, as a bit mask.
constexpr std::array<unsigned, 4> kChildMidpoints{0b101, 0b011, 0b110, 0b111};

double longestEdge(const World& world, uint32_t triangle) {
    const auto [p0, p1, p2] = triangleCorners(world, triangle);
    return std::max({glm::length(p1 - p0), glm::length(p2 - p1), glm::length(p0 - p2)});
}

} // namespace

size_t latticePoints(int m) {
    return size_t(m + 1) * size_t(m + 2) / 2;
}

glm::dvec2 latticeBarycentric(int m, size_t index) {
    int j = 0;
    while (latticeIndex(m, 0, j + 1) <= index)
        ++j;
    const int i = int(index - latticeIndex(m, 0, j));
    return glm::dvec2(i, j) / double(m);
}

int latticeSubdivisions(const World& world, uint32_t triangle, double spacing) {
    const double cells = std::ceil(longestEdge(world, triangle) / spacing);
    return int(std::clamp(cells, 1.0, double(kMaxCacheSubdivisions)));
}

CappedLattices cappedLattices(const World& world, double spacing) {
    CappedLattices capped;
    for (uint32_t t = 0; t < world.triangleCount(); ++t) {
        const double longest = longestEdge(world, t);
        if (longest / spacing <= double(kMaxCacheSubdivisions) || !hasArea(world, t)) continue;
        ++capped.triangles;
        capped.widestSpacing = std::max(capped.widestSpacing, longest / kMaxCacheSubdivisions);
    }
    return capped;
}

// The edges' midpoints (AB, BC, CA) of a halved cell and its four children.
struct SurfaceCache::Halves {
    std::array<std::atomic<uint8_t>, 3> states{};
    std::array<CachePoint, 3> points{};
    std::array<std::atomic<uintptr_t>, 4> children{};
};

int cacheSides(const World& world, uint32_t triangle) {
    return world.materials[world.triangleMaterials[triangle]].doubleSided ? 2 : 1;
}

size_t cachePointCount(const World& world, double spacing) {
    size_t points = 0;
    for (uint32_t t = 0; t < world.triangleCount(); ++t)
        points += size_t(cacheSides(world, t)) * latticePoints(latticeSubdivisions(world, t, spacing));
    return points;
}

SurfaceCache::SurfaceCache(const World& world, double spacing, int bounces, int refinement,
                           CacheQueries queries)
    : queries_(std::move(queries)), refinement_(refinement) {
    lattices_.resize(world.triangleCount());
    for (uint32_t t = 0; t < uint32_t(lattices_.size()); ++t) {
        const int m = latticeSubdivisions(world, t, spacing);
        const int sides = cacheSides(world, t);
        lattices_[t] = {pointCount_, cellCount_, m};
        pointCount_ += sides * latticePoints(m);
        cellCount_ += sides * size_t(m) * size_t(m);
    }
    for (int k = 1; k <= bounces; ++k) {
        points_.emplace_back(pointCount_);
        states_.push_back(std::make_unique<std::atomic<uint8_t>[]>(pointCount_));
        if (refinement_ > 0) cells_.push_back(std::make_unique<std::atomic<uintptr_t>[]>(cellCount_));
    }
}

SurfaceCache::~SurfaceCache() = default;

CacheCounts SurfaceCache::counts() const {
    return {pointsGathered_.load(), cellsHalved_.load()};
}

// Lattice point `index` of a triangle's side, with the random numbers (bounce, the point).
CachePoint SurfaceCache::latticePoint(int bounce, uint32_t triangle, int side, size_t index) {
    const Lattice& lattice = lattices_[triangle];
    const size_t point = lattice.firstPoint + size_t(side) * latticePoints(lattice.subdivisions) + index;
    return keptPoint(
        states_[size_t(bounce - 1)][point], points_[size_t(bounce - 1)][point], pointsGathered_, [&] {
            return queries_.gather(bounce, triangle, side, latticeBarycentric(lattice.subdivisions, index),
                                   uint64_t(bounce), uint64_t(point));
        });
}

glm::dvec3 SurfaceCache::irradiance(int bounce, uint32_t triangle, int side, const glm::dvec2& barycentric,
                                    const glm::dvec3& from) {
    const Lattice& lattice = lattices_[triangle];
    const int m = lattice.subdivisions;
    const LatticeBlend blend = blendAt(m, barycentric);
    Corner corners[3];
    for (int c = 0; c < 3; ++c) {
        if (refinement_ == 0 && blend.weights[c] == 0.0) continue; // a cell decides by all three
        corners[c] = {latticeBarycentric(m, blend.points[c]),
                      latticePoint(bounce, triangle, side, blend.points[c])};
    }
    if (refinement_ == 0) return mix(corners, blend.weights);
    const uint64_t cell = lattice.firstCell + size_t(side) * size_t(m) * size_t(m) + blend.cell;
    return refined(bounce, triangle, side, cell, corners, blend.weights, from);
}

// Down a cell's halves to the one holding the point, gathering the midpoints it needs; a midpoint's
// random numbers are named by the cell, the path of children down to it and the edge:
// (cell << 16) | (path << 2) | edge, the path 1 followed by a base-4 digit per level (at most 7
// digits in all: 14 bits).
glm::dvec3 SurfaceCache::refined(int bounce, uint32_t triangle, int side, uint64_t cell,
                                 const Corner (&outer)[3], const glm::dvec3& outerWeights,
                                 const glm::dvec3& from) {
    Corner corners[3] = {outer[0], outer[1], outer[2]};
    glm::dvec3 weights = outerWeights;
    std::atomic<uintptr_t>* slot = &cells_[size_t(bounce - 1)][cell];
    uint64_t path = 1;
    for (int depth = 0;; ++depth) {
        uintptr_t state = slot->load(std::memory_order_acquire);
        if (state == kUndecided) state = decide(*slot, triangle, side, corners, depth);
        if (state == kWhole) return mix(corners, weights);
        if (state == kWholeBlocked) return visibleMix(triangle, side, corners, weights, from);
        Halves& halves = *reinterpret_cast<Halves*>(state);
        const int child = childAt(weights);
        Corner midpoints[3];
        for (int e = 0; e < 3; ++e) {
            if (!(kChildMidpoints[size_t(child)] & (1u << e))) continue;
            const glm::dvec2 barycentric = 0.5 * (corners[e].barycentric + corners[(e + 1) % 3].barycentric);
            const uint64_t index = (cell << 16) | (path << 2) | uint64_t(e);
            midpoints[e] = {
                barycentric,
                keptPoint(halves.states[size_t(e)], halves.points[size_t(e)], pointsGathered_, [&] {
                    return queries_.gather(bounce, triangle, side, barycentric, uint64_t(bounce) | 1ull << 32,
                                           index);
                })};
        }
        const Corner &ab = midpoints[0], &bc = midpoints[1], &ca = midpoints[2];
        const glm::dvec3 w = weights;
        if (child == 0) {
            corners[1] = ab, corners[2] = ca;
            weights = glm::dvec3(2.0 * w[0] - 1.0, 2.0 * w[1], 2.0 * w[2]);
        } else if (child == 1) {
            corners[0] = ab, corners[2] = bc;
            weights = glm::dvec3(2.0 * w[0], 2.0 * w[1] - 1.0, 2.0 * w[2]);
        } else if (child == 2) {
            corners[0] = ca, corners[1] = bc;
            weights = glm::dvec3(2.0 * w[0], 2.0 * w[1], 2.0 * w[2] - 1.0);
        } else { // a A + b B + c C = (1 - 2a) BC + (1 - 2b) CA + (1 - 2c) AB
            corners[0] = bc, corners[1] = ca, corners[2] = ab;
            weights = glm::dvec3(1.0) - 2.0 * w;
        }
        path = path * 4 + uint64_t(child);
        slot = &halves.children[size_t(child)];
    }
}

// Whether a cell is halved (its corners' irradiance differs, or a surface stands between two of them,
// above `refinement` levels), else read whole (from the corners a point sees, where a surface
// stands between them at the last level). The decision is the cell's corners' alone, so that threads
// deciding at once agree: the first to store its halves keeps them.
uintptr_t SurfaceCache::decide(std::atomic<uintptr_t>& slot, uint32_t triangle, int side,
                               const Corner (&corners)[3], int depth) {
    if (depth < refinement_) {
        if (disagree(corners) || blocked(triangle, side, corners)) {
            auto halves = std::make_unique<Halves>();
            uintptr_t expected = kUndecided;
            const uintptr_t mine = reinterpret_cast<uintptr_t>(halves.get());
            if (!slot.compare_exchange_strong(expected, mine, std::memory_order_acq_rel)) return expected;
            const std::lock_guard lock(halvesMutex_);
            halves_.push_back(std::move(halves));
            ++cellsHalved_;
            return mine;
        }
        slot.store(kWhole, std::memory_order_release);
        return kWhole;
    }
    const uintptr_t state = blocked(triangle, side, corners) ? kWholeBlocked : kWhole;
    slot.store(state, std::memory_order_release);
    return state;
}

// Whether a surface lies between two corners of a cell, where their rays leave.
bool SurfaceCache::blocked(uint32_t triangle, int side, const Corner (&corners)[3]) const {
    std::array<glm::dvec3, 3> origins;
    for (int c = 0; c < 3; ++c)
        origins[size_t(c)] = queries_.origin(triangle, side, corners[c].barycentric);
    for (int c = 0; c < 3; ++c)
        if (queries_.blocked(origins[size_t(c)], origins[size_t(c + 1) % 3])) return true;
    return false;
}

// The corners a shaded point's rays (leaving at `from`) reach, their weights scaled to sum 1; all
// where it reaches none.
glm::dvec3 SurfaceCache::visibleMix(uint32_t triangle, int side, const Corner (&corners)[3],
                                    const glm::dvec3& weights, const glm::dvec3& from) const {
    glm::dvec3 seen(0.0);
    for (int c = 0; c < 3; ++c)
        if (weights[c] > 0.0 &&
            !queries_.blocked(from, queries_.origin(triangle, side, corners[c].barycentric)))
            seen[c] = weights[c];
    const double total = seen[0] + seen[1] + seen[2];
    return total > 0.0 ? mix(corners, seen / total) : mix(corners, weights);
}

} // namespace shprobe
