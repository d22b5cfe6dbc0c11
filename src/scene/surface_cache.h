// The irradiance cache of the cpu bake (scene/ray_bake.h): points on the surfaces that hold the
// irradiance of each bounce, gathered when first needed and kept, read back by interpolation.
//
// Each triangle carries a lattice of points (barycentrics (i/m, j/m), i + j <= m, m chosen so
// that neighbouring points lie at most `spacing` apart; one lattice per side of a double-sided
// material), whose cells, the lattice's m^2 small triangles, interpolate their corners linearly.
// Where that is wrong, a cell is halved, recursively, as far as `refinement` levels (so down to
// spacing / 2^refinement), so that the points follow the edges and not the area:
//
// - where its corners' irradiance differs by more than kCacheContrast of the brightest (an
//   overhang over part of the cell, a shadow's edge: interpolating carries the bright side's light
//   into the dark);
// - where a surface stands between two of its corners, seen from just off the surface (the foot of
//   a wall on a floor: the cell reaches into the next room). A cell still blocked at the last
//   level reads only the corners the shaded point sees.
//
// A cell's halves are its edges' midpoints and four children: at the corners A, B, C and in the
// middle. Whether a cell is halved depends on its corners alone, and every point's random numbers
// are named by where it lies (the lattice point, or the cell and path of a midpoint), so the cache
// holds the same values whichever thread asks first and in whatever order: bakes repeat to the
// bit, and bricks merge into the whole bake.
#pragma once
#include "scene/scene.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace shprobe {

// The most subdivisions of a triangle's edges: (m + 1)(m + 2) / 2 points per lattice at most.
constexpr int kMaxCacheSubdivisions = 256;
// The most times a cell may be halved.
constexpr int kMaxCacheRefinement = 6;

// A cell is halved where its corners' irradiance (the channels summed) differs by more than this
// share of the brightest: twice or more the noise of 64 gather rays in the measured scenes
// (docs/scene-probes.md), and far less than across an overhang's or a wall's edge.
constexpr double kCacheContrast = 0.5;

// Points of a lattice of m subdivisions: rows j = 0..m of m + 1 - j points, (m + 1)(m + 2) / 2.
size_t latticePoints(int m);
// The barycentrics (i / m, j / m) of lattice point `index`, row by row.
glm::dvec2 latticeBarycentric(int m, size_t index);
// The subdivisions m of `triangle`'s lattice: each lattice edge at most `spacing` long, m in
// 1..kMaxCacheSubdivisions.
int latticeSubdivisions(const World& world, uint32_t triangle, double spacing);
// The triangles of some area whose lattice at `spacing` would need more than kMaxCacheSubdivisions,
// and the largest spacing their capped lattices keep.
struct CappedLattices {
    size_t triangles = 0;
    double widestSpacing = 0.0;
};
CappedLattices cappedLattices(const World& world, double spacing);

// The sides a triangle's cache covers: two for a double-sided material, else one.
int cacheSides(const World& world, uint32_t triangle);
// The points of every lattice at `spacing`, each side's, before any cell is halved.
size_t cachePointCount(const World& world, double spacing);

// One bounce's irradiance at a point.
struct CachePoint {
    glm::vec3 irradiance{0.0f};
};

// What the cache asks of the baker. Each may run on many threads at once.
struct CacheQueries {
    // Bounce's irradiance at `triangle`'s point `barycentric`, on side 0 (front) or 1, with the
    // random numbers of (stream, index).
    std::function<CachePoint(int bounce, uint32_t triangle, int side, const glm::dvec2& barycentric,
                             uint64_t stream, uint64_t index)>
        gather;
    // Where that point's rays leave: just off the surface, on that side.
    std::function<glm::dvec3(uint32_t triangle, int side, const glm::dvec2& barycentric)> origin;
    // Whether any surface lies on the segment between two points.
    std::function<bool(const glm::dvec3& from, const glm::dvec3& to)> blocked;
};

// What a cache has gathered.
struct CacheCounts {
    uint64_t points = 0;      // over all bounces, midpoints of halved cells included
    uint64_t halvedCells = 0; // over all bounces and levels
};

class SurfaceCache {
  public:
    // The lattices of the world's triangles at `spacing` (> 0) for `bounces` bounces; cells halved
    // at most `refinement` times (0: the lattices alone).
    SurfaceCache(const World& world, double spacing, int bounces, int refinement, CacheQueries queries);
    ~SurfaceCache();

    // E_bounce (1..bounces) at `triangle`'s point `barycentric` on `side`, interpolated; `from` is
    // where the shaded point's rays leave (to test which corners it sees in a blocked cell).
    glm::dvec3 irradiance(int bounce, uint32_t triangle, int side, const glm::dvec2& barycentric,
                          const glm::dvec3& from);
    CacheCounts counts() const;

  private:
    struct Lattice {
        size_t firstPoint = 0; // side s's points start at firstPoint + s (m + 1)(m + 2) / 2
        size_t firstCell = 0;  // and its cells at firstCell + s m^2
        int subdivisions = 1;  // m
    };
    struct Corner {
        glm::dvec2 barycentric{0.0};
        CachePoint point;
    };
    struct Halves;
    CachePoint latticePoint(int bounce, uint32_t triangle, int side, size_t index);
    glm::dvec3 refined(int bounce, uint32_t triangle, int side, uint64_t cell, const Corner (&corners)[3],
                       const glm::dvec3& weights, const glm::dvec3& from);
    uintptr_t decide(std::atomic<uintptr_t>& slot, uint32_t triangle, int side, const Corner (&corners)[3],
                     int depth);
    bool blocked(uint32_t triangle, int side, const Corner (&corners)[3]) const;
    glm::dvec3 visibleMix(uint32_t triangle, int side, const Corner (&corners)[3], const glm::dvec3& weights,
                          const glm::dvec3& from) const;

    CacheQueries queries_;
    int refinement_ = 0;
    std::vector<Lattice> lattices_;
    size_t pointCount_ = 0;
    size_t cellCount_ = 0;
    std::vector<std::vector<CachePoint>> points_;                  // bounce k's at [k - 1], per point
    std::vector<std::unique_ptr<std::atomic<uint8_t>[]>> states_;  // likewise: empty, gathering, ready
    std::vector<std::unique_ptr<std::atomic<uintptr_t>[]>> cells_; // likewise, per cell: undecided,
                                                                   // whole, whole but blocked, halves
    std::mutex halvesMutex_;
    std::vector<std::unique_ptr<Halves>> halves_;
    std::atomic<uint64_t> pointsGathered_{0};
    std::atomic<uint64_t> cellsHalved_{0};
};

} // namespace shprobe
