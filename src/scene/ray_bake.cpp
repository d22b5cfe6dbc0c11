// RayBaker (ray_bake.h): probes by rays through texels or over the sphere, bounces from a lazily
// gathered irradiance cache on the surfaces.
#include "scene/ray_bake.h"

#include "common/error.h"
#include "common/parallel.h"
#include "scene/emitters.h"
#include "scene/ray_caster.h"
#include "scene/sampling.h"
#include "scene/surface_cache.h"
#include "scene/surface_shading.h"
#include "scene/view_rays.h"
#include "scene/volume_sampling.h"
#include "sh/basis.h"
#include "sh/irradiance.h"
#include "sh/projection.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <numbers>
#include <optional>
#include <string>

namespace shprobe {

namespace {

// The numbers of a probe's paths (BounceLight::Paths), named by its place in the world: the path of
// the probe's ray k draws point k of Owen-scrambled Sobol' sets (sampling.h), a set per bounce and
// use, scrambled by the probe's own seed. The rays are numbered along a Morton curve over each face
// (shadeTexels), so the first bounces of any block of neighbouring rays, which meet nearly the
// same surface, are stratified over its hemisphere at every scale (Ahmed and Wonka, "Screen-Space
// Blue-Noise Diffusion of Monte Carlo Sampling Error via Hierarchical Ordering of Pixels", 2020);
// the other sets are shuffled, so that no two uses draw alike. Each point stays uniform: the
// estimate stays unbiased.
class ProbePaths {
  public:
    ProbePaths(uint64_t seed, uint64_t viewIndex) : seed_(probePathSeed(seed, viewIndex)) {}
    // The probe ray whose path is traced next.
    void startRay(uint32_t ray) { ray_ = ray; }
    // The unit square's point for that path's bounce `level` (0: the first) direction.
    glm::dvec2 bounceDirection(int level) const { return set(kSetsPerBounce * level, level > 0); }
    // Three numbers for the point on the emitters at bounce `level` (EmitterSampler::sample).
    glm::dvec3 emitterPoint(int level) const {
        const glm::dvec2 picks = set(kSetsPerBounce * level + 1, true),
                         point = set(kSetsPerBounce * level + 2, true);
        return {picks.x, point.x, point.y};
    }
    // Three numbers for the direction towards the sky at bounce `level` (SkySampler::sample).
    glm::dvec3 skyPoint(int level) const {
        const glm::dvec2 picks = set(kSetsPerBounce * level + 1, true),
                         point = set(kSetsPerBounce * level + 3, true);
        return {picks.y, point.x, point.y};
    }
    // Three numbers for the sun's ray into the world at bounce `level` (SunlitSampler::sample).
    glm::dvec3 sunlitPoint(int level) const {
        const glm::dvec2 pick = set(int(SHPROBE_SUNLIT_USE) + 2 * level, true),
                         point = set(int(SHPROBE_SUNLIT_USE) + 2 * level + 1, true);
        return {pick.x, point.x, point.y};
    }

  private:
    // The direction; the emitter's and the sky texel's picks; the point on the emitter; in the texel.
    static constexpr int kSetsPerBounce = 4;
    glm::dvec2 set(int use, bool shuffled) const {
        return owenScrambledSobol(ray_, mix64(seed_ + uint64_t(use)), shuffled);
    }
    uint64_t seed_;
    uint32_t ray_ = 0;
};

// How far in from its triangle's edges a point whose rays leave is moved (insideTriangle): surface
// offsets, and the least share of the way to the centroid for a cache point.
constexpr double kInwardOffsets = 4.0;
constexpr double kLatticeInwardFraction = 0.01;

void requireOptions(const RayBakeOptions& options) {
    auto refuse = [](const std::string& what) { throw Error(ErrorKind::Input, "scene: " + what); };
    requireOrder(options.order);
    requireFaceSize(options.faceSize);
    if (options.bounces < 0) refuse("bounces must be 0 or more, got " + std::to_string(options.bounces));
    if (!(options.cacheSpacing >= 0.0) || !std::isfinite(options.cacheSpacing))
        refuse("the cache spacing must be a finite number of 0 or more");
    if (options.raysPerTexel < 1 || options.raysPerTexel > 1024)
        refuse("rays per texel must be in 1..1024, got " + std::to_string(options.raysPerTexel));
    requireViewRays(options.faceSize, options.raysPerTexel);
    if (options.visibilitySize < 0 || options.visibilitySize > 64)
        refuse("the visibility map's size must be in 0..64, got " + std::to_string(options.visibilitySize));
    if (options.cacheRefinement < 0 || options.cacheRefinement > kMaxCacheRefinement)
        refuse("cache refinement must be in 0.." + std::to_string(kMaxCacheRefinement) + ", got " +
               std::to_string(options.cacheRefinement));
    if (options.cacheRefinement > 0 && options.bounceLight == BounceLight::Paths)
        refuse("cache refinement halves the cache's cells; bounces by paths keep no cache");
    if (options.gatherRays < 1 || options.gatherRays > 1 << 20)
        refuse("gather rays must be in 1..1048576, got " + std::to_string(options.gatherRays));
    const ProbeRelocation& relocation = options.relocation;
    if (!(relocation.limit >= 0.0 && relocation.minFrontDistance >= 0.0) ||
        !std::isfinite(relocation.limit) || !std::isfinite(relocation.minFrontDistance))
        refuse("the relocation's limit and front-face distance must be finite numbers of 0 or more");
    if (!(relocation.invalidBackFaces >= 0.0 && relocation.invalidBackFaces <= 1.0))
        refuse("the back-face share of a probe inside geometry must be in 0..1");
}

// The surface a ray meets (described where it is shaded) and how far along the ray it lies.
struct Meeting {
    SurfaceHit surface;
    double distance = 0.0;
};

constexpr double kFar = std::numeric_limits<double>::infinity();

// How a path's bounce met a surface: the density per solid angle it drew `direction` with and how far
// it went, against which that surface's emission and the suns' light it reflects are weighted (the
// power heuristic against the emitters' and the sunlit points' sampling, which find them too).
struct PathBounce {
    glm::dvec3 direction{0.0};
    double cosineDensity = 0.0;
    double distance = 0.0;
};

// One of a probe's rays and the surface it met, if any, before it is shaded.
// Compact: a probe keeps all its rays until it knows whether it is inside geometry; the surface is
// described again when the ray is shaded.
struct ViewRay {
    glm::dvec3 direction{0.0};
    double distance = kFar;
    glm::dvec2 barycentric{0.0}; // where the surface is described (moved in from the edges)
    uint32_t triangle = 0;
    bool met = false;
    bool backFace = false;
};

// A probe's view before it is shaded: its rays in the order they were cast (texel by texel, s x s
// each, or over the sphere), and the visibility they give (RayBakedProbe).
struct ProbeLook {
    std::vector<ViewRay> rays;
    uint32_t backFaceTexels = 0;
    DistanceMoments moments;
    NearestHits nearest;
};

// The distance from the point at `barycentric` to its triangle's nearest edge: each barycentric
// weight times the triangle's height over the opposite edge (0 or NaN for a triangle of no area,
// which intersect then counts as near an edge).
double edgeDistance(const World& world, uint32_t triangle, const glm::dvec2& barycentric) {
    const auto [p0, p1, p2] = triangleCorners(world, triangle);
    const double twiceArea = glm::length(glm::cross(p1 - p0, p2 - p0));
    const glm::dvec3 weights(1.0 - barycentric.x - barycentric.y, barycentric.x, barycentric.y);
    return twiceArea * std::min({weights[0] / glm::length(p2 - p1), weights[1] / glm::length(p2 - p0),
                                 weights[2] / glm::length(p1 - p0)});
}

// A point on an edge or a corner, where a wall meets the next, moved towards the triangle's
// centroid: by `leastFraction` of the way (1% for a lattice point, 0 for a hit), or kInwardOffsets
// surface offsets where that is more (at most half the way), so that its rays start inside the room
// and not on the plane of the next wall, where a ray along that wall could slip out between the two.
glm::dvec2 insideTriangle(const SceneShading& shading, uint32_t triangle, const glm::dvec2& barycentric,
                          double leastFraction) {
    const auto [p0, p1, p2] = triangleCorners(shading.world(), triangle);
    const glm::dvec2 centroid(1.0 / 3.0);
    const glm::dvec3 point =
        (1.0 - barycentric.x - barycentric.y) * p0 + barycentric.x * p1 + barycentric.y * p2;
    const double distance = glm::length((p0 + p1 + p2) / 3.0 - point);
    if (distance == 0.0) return barycentric;
    const double fraction =
        std::clamp(kInwardOffsets * shading.offset(triangle) / distance, leastFraction, 0.5);
    return barycentric + fraction * (centroid - barycentric);
}

} // namespace

DistanceMoments::DistanceMoments(int size, double range)
    : size_(size), range_(range), sums_(size_t(size) * size, glm::dvec2(0.0)), counts_(sums_.size(), 0) {}

void DistanceMoments::add(const glm::dvec3& direction, double distance) {
    if (size_ == 0) return;
    const size_t texel = size_t(octahedralTexel(direction, size_));
    const double d = std::min(distance, range_);
    sums_[texel] += glm::dvec2(d, d * d);
    ++counts_[texel];
}

std::vector<glm::vec2> DistanceMoments::texels() const {
    std::vector<glm::vec2> moments(sums_.size());
    for (size_t t = 0; t < moments.size(); ++t)
        moments[t] =
            counts_[t] > 0 ? glm::vec2(sums_[t] / double(counts_[t])) : glm::vec2(range_, range_ * range_);
    return moments;
}

// A hit must be nearer by a relative 1e-5 to replace the nearest: rays that meet a face at the same
// distance (texel directions symmetric about its normal) then keep the first, whichever caster
// rounded their t (Embree's and the hierarchy's differ in the last bits).
void NearestHits::add(const glm::dvec3& direction, double distance, bool backFace) {
    constexpr double kSameDistance = 1e-5;
    double& nearest = backFace ? back : front;
    if (!(distance < nearest * (1.0 - kSameDistance))) return;
    nearest = distance;
    (backFace ? backDirection : frontDirection) = direction;
}

std::optional<glm::dvec3> throughBackFace(const ProbeRelocation& rule, const NearestHits& seen) {
    if (!(rule.limit > 0.0) || seen.back == kFar) return std::nullopt;
    const glm::dvec3 offset = seen.backDirection * (seen.back + 0.5 * rule.minFrontDistance);
    if (glm::length(offset) > rule.limit) return std::nullopt;
    return offset;
}

glm::vec3 offFrontFace(const ProbeRelocation& rule, const glm::dvec3& offset, const NearestHits& there) {
    if (there.front < rule.minFrontDistance) {
        const glm::dvec3 away = offset - there.frontDirection * (rule.minFrontDistance - there.front);
        if (glm::length(away) <= rule.limit) return glm::vec3(away);
    }
    return glm::vec3(offset);
}

double visibilityRangeOf(const World& world) {
    return std::max(glm::length(glm::dvec3(world.boundsMax) - glm::dvec3(world.boundsMin)), 1e-30);
}

World withSuns(const World& world, const std::vector<SceneSun>& skySuns) {
    if (skySuns.empty()) return world;
    World lit = world;
    lit.suns.insert(lit.suns.end(), skySuns.begin(), skySuns.end());
    return lit;
}

BounceLight autoBounceLight(const World& world, const RayBakeOptions& options, uint64_t probes) {
    const double spacing = cacheSpacingFor(world, options.cacheSpacing);
    // Rays a texel past 2 x 2 lower the paths' error, not the cache's: they ask for paths, so the
    // cache is weighed against the paths' rays at 2 x 2 at most.
    constexpr int kMostWeighedSide = 2;
    const int s = std::min(squareSide(options.raysPerTexel), kMostWeighedSide);
    const int g = squareSide(options.gatherRays);
    const double pathRays = double(probes) * kFaceCount * options.faceSize * options.faceSize * s * s;
    const double cacheRays = double(cachePointCount(world, spacing)) * g * g;
    constexpr double kCacheShare = 0.25;
    return cacheRays >= kCacheShare * pathRays ? BounceLight::Paths : BounceLight::Cache;
}

double cacheSpacingFor(const World& world, double asked) {
    if (asked > 0.0) return asked;
    const double diagonal = glm::length(glm::dvec3(world.boundsMax) - glm::dvec3(world.boundsMin));
    return diagonal > 0.0 ? diagonal / kDefaultCacheCells : 1.0;
}

SurfaceHit cacheGatherPoint(const SceneShading& shading, uint32_t triangle, int side,
                            const glm::dvec2& barycentric) {
    return shading.surfacePoint(
        triangle, insideTriangle(shading, triangle, barycentric, kLatticeInwardFraction), side == 0);
}

void addSeenSuns(const RayCaster& caster, std::span<const SceneSun> suns, const glm::dvec3& position,
                 ShCoefficients& radiance) {
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    for (const SceneSun& sun : suns) {
        const glm::dvec3 direction = glm::normalize(glm::dvec3(sun.direction));
        if (caster.anyHit({glm::vec3(position), glm::vec3(direction)})) continue;
        evalBasis(radiance.order, direction, basis);
        for (size_t i = 0; i < radiance.rgb.size(); ++i)
            radiance.rgb[i] += glm::dvec3(sun.irradiance) * basis[i];
    }
}

void requireViewRays(int faceSize, int raysPerTexel) {
    const int s = squareSide(raysPerTexel);
    if (double(kFaceCount) * faceSize * faceSize * s * s <= kMaxViewRays) return;
    throw Error(ErrorKind::Input, "scene: faces " + std::to_string(faceSize) + " and " +
                                      std::to_string(s * s) +
                                      " rays a texel make a probe's view of more than 2^28 rays");
}

bool insideGeometry(uint32_t backFaceTexels, int faceSize, double share) {
    return double(backFaceTexels) > share * 6.0 * double(faceSize) * faceSize;
}

struct RayBaker::State {
    State(const World& world, const Cubemap& sky, const RayBakeOptions& bakeOptions)
        : options(bakeOptions), shading(withSuns(world, bakeOptions.skySuns), sky),
          caster(makeRayCaster(world)), emitters(shading.world()), skyDirections(shading.sky()) {}

    RayBakeOptions options;
    SceneShading shading;
    std::unique_ptr<RayCaster> caster;
    EmitterSampler emitters; // the paths' next-event estimation (BounceLight::Paths)
    SkySampler skyDirections;
    SunlitSampler sunlit; // with paths, bounces and suns
    std::unique_ptr<SurfaceCache> cache;
    StratifiedCosineDirections gatherDirections{1}; // g x g gather rays per point
    int texelSide = 1;                              // s: s x s rays per texel
    std::vector<uint32_t> stratumSky;               // per stratum: its shadow rays to the sky
    double visibilityRange = 1.0; // the farthest distance visibility records: the world's diagonal
    std::atomic<uint64_t> probeRays{0};
    std::atomic<uint64_t> cacheRays{0};

    void layOutCache();
    std::optional<Meeting> intersect(const glm::dvec3& origin, const glm::dvec3& direction) const;
    bool occluded(const glm::dvec3& origin, const glm::dvec3& direction) const;
    glm::dvec3 arriving(int bounce, const glm::dvec3& origin, const glm::dvec3& direction, ProbePaths* paths,
                        uint64_t& rays, std::optional<double> cosineDensity = std::nullopt);
    glm::dvec3 leaving(int bounce, const SurfaceHit& hit, ProbePaths* paths, uint64_t& rays,
                       const PathBounce* from = nullptr);
    double emissionShare(const SurfaceHit& hit, const PathBounce& from) const;
    double sunShare(uint32_t sun, const SurfaceHit& hit, const PathBounce& from) const;
    static double bounceShare(double areaDensity, const SurfaceHit& hit, const PathBounce& from);
    glm::dvec3 bouncedIrradiance(int bounce, const SurfaceHit& hit, ProbePaths* paths, uint64_t& rays);
    glm::dvec3 emitterIrradiance(const SurfaceHit& hit, const ProbePaths& paths, int level,
                                 uint64_t& rays) const;
    glm::dvec3 skyIrradiance(const SurfaceHit& hit, const ProbePaths& paths, int level, uint64_t& rays) const;
    glm::dvec3 sunlitIrradiance(const SurfaceHit& hit, const ProbePaths& paths, int level,
                                uint64_t& rays) const;
    CachePoint gather(int bounce, uint32_t triangle, int side, const glm::dvec2& barycentric, uint64_t stream,
                      uint64_t index);
    bool segmentBlocked(const glm::dvec3& from, const glm::dvec3& to);
    template <typename Ray>
    void forEachProbeRay(const glm::dvec3& position, ProbeDirections directions, Ray&& ray) const;
    int sphereRayCount() const;
    uint64_t viewIndex(const glm::dvec3& position) const;
    ProbeLook look(const glm::dvec3& position, ProbeDirections directions, uint64_t& rays) const;
    uint32_t backFaceTexels(std::span<const ViewRay> rays, ProbeDirections directions) const;
    glm::dvec3 shadeRay(const ViewRay& ray, uint32_t index, ProbePaths& paths, uint64_t& rays);
    glm::dvec3 skyThroughStratum(const glm::dvec3& position, const ViewRay& ray, const glm::uvec4& stratum,
                                 uint32_t count, uint64_t seed, uint64_t& rays) const;
    Cubemap shadeTexels(const glm::dvec3& position, const ProbeLook& look, uint64_t& rays);
    ShCoefficients shadeSphere(const glm::dvec3& position, const ProbeLook& look, uint64_t& rays);
    std::optional<glm::vec3> relocation(const glm::dvec3& position, const NearestHits& seen,
                                        uint64_t& rays) const;
    RayBakedProbe bake(const glm::dvec3& position, uint64_t& rays);
    void addSeenSuns(const glm::dvec3& position, ShCoefficients& radiance, uint64_t& rays) const;
};

void RayBaker::State::layOutCache() {
    const World& world = shading.world();
    gatherDirections = StratifiedCosineDirections(squareSide(options.gatherRays));
    texelSide = squareSide(options.raysPerTexel);
    if (options.directions == ProbeDirections::Texels && options.skyThroughStrata)
        stratumSky = stratumSkyRays(shading.sky(), options.faceSize, texelSide);
    visibilityRange = visibilityRangeOf(world);
    if (options.bounceLight == BounceLight::Paths) {
        if (options.bounces > 0) sunlit = SunlitSampler(shading, *caster);
        return;
    }
    const double spacing = cacheSpacingFor(world, options.cacheSpacing);
    CacheQueries queries{
        .gather =
            [this](int bounce, uint32_t triangle, int side, const glm::dvec2& barycentric, uint64_t stream,
                   uint64_t index) { return gather(bounce, triangle, side, barycentric, stream, index); },
        .origin =
            [this](uint32_t triangle, int side, const glm::dvec2& barycentric) {
                return cacheGatherPoint(shading, triangle, side, barycentric).rayOrigin;
            },
        .blocked = [this](const glm::dvec3& from, const glm::dvec3& to) { return segmentBlocked(from, to); },
    };
    cache = std::make_unique<SurfaceCache>(world, spacing, options.bounces, options.cacheRefinement,
                                           std::move(queries));
}

// The surface a ray meets and how far it went; a hit nearer its triangle's edges than kInwardOffsets
// surface offsets is described moved in (insideTriangle), its distance kept. A ray that meets the edge
// where a wall meets the ceiling lies on the ceiling's plane, and the shadow rays of a point there,
// started off the wall but on that plane, slip out between the two: in the two rooms of
// docs/scene-probes.md, texel centres of probes as far from the floor as from a wall met such edges,
// and the closed room's probes saw the sun.
std::optional<Meeting> RayBaker::State::intersect(const glm::dvec3& origin,
                                                  const glm::dvec3& direction) const {
    const std::optional<RayHit> hit = caster->closestHit({glm::vec3(origin), glm::vec3(direction)});
    if (!hit) return std::nullopt;
    const glm::dvec2 barycentric(hit->hit.u, hit->hit.v);
    Meeting meeting{shading.describe(hit->triangle, barycentric, direction), 0.0};
    meeting.distance = glm::length(meeting.surface.position - origin);
    if (!(edgeDistance(shading.world(), hit->triangle, barycentric) >=
          kInwardOffsets * shading.offset(hit->triangle)))
        meeting.surface = shading.describe(
            hit->triangle, insideTriangle(shading, hit->triangle, barycentric, 0.0), direction);
    return meeting;
}

bool RayBaker::State::occluded(const glm::dvec3& origin, const glm::dvec3& direction) const {
    return caster->anyHit({glm::vec3(origin), glm::vec3(direction)});
}

// The radiance arriving at `origin` from `direction` with `bounce` bounces (scene.h): the sky, or
// what the surface met leaves. `cosineDensity`: the density with which a path's bounce drew
// `direction`, against which the sky or emission met is weighted (the power heuristic against
// skyIrradiance's and emitterIrradiance's densities); none for a probe's or a gather's ray, which
// count them whole.
glm::dvec3 RayBaker::State::arriving(int bounce, const glm::dvec3& origin, const glm::dvec3& direction,
                                     ProbePaths* paths, uint64_t& rays, std::optional<double> cosineDensity) {
    ++rays;
    const std::optional<Meeting> meeting = intersect(origin, direction);
    if (!meeting) {
        const double share =
            cosineDensity ? powerHeuristic(*cosineDensity, skyDirections.density(direction)) : 1.0;
        return share * shading.skyRadiance(direction);
    }
    if (!cosineDensity) return leaving(bounce, meeting->surface, paths, rays);
    const PathBounce from{direction, *cosineDensity, meeting->distance};
    return leaving(bounce, meeting->surface, paths, rays, &from);
}

// What a surface leaves towards the ray that met it with `bounce` bounces: nothing from a back face,
// else its emission and the suns' light plus bounce's irradiance, reflected; the first two weighted
// by their shares where a path's bounce met it `from`. `paths` continues the probe's paths
// (BounceLight::Paths; none for the cache's gathers).
glm::dvec3 RayBaker::State::leaving(int bounce, const SurfaceHit& hit, ProbePaths* paths, uint64_t& rays,
                                    const PathBounce* from) {
    if (hit.backFace) return glm::dvec3(0.0);
    const auto blocked = [this](auto& o, auto& d) { return occluded(o, d); };
    const glm::dvec3 direct =
        from ? emissionShare(hit, *from) * hit.emission +
                   reflectedSunLight(shading.suns(), hit, rays, blocked,
                                     [&](size_t sun) { return sunShare(uint32_t(sun), hit, *from); })
             : hit.emission + reflectedSunLight(shading.suns(), hit, rays, blocked);
    if (bounce == 0 || hit.albedo == glm::dvec3(0.0)) return direct;
    return direct + hit.albedo * std::numbers::inv_pi * bouncedIrradiance(bounce, hit, paths, rays);
}

// The share of an emitter's light a path's bounce keeps where it meets it: the power heuristic
// against the emitters' own sampling (emitterIrradiance), which finds the same light too.
double RayBaker::State::emissionShare(const SurfaceHit& hit, const PathBounce& from) const {
    return bounceShare(emitters.areaDensity(hit.triangle), hit, from);
}

// The share of sun `sun`'s light reflected by a surface a path's bounce met: the power heuristic
// against the sunlit points' sampling (sunlitIrradiance), which finds the same light too.
double RayBaker::State::sunShare(uint32_t sun, const SurfaceHit& hit, const PathBounce& from) const {
    return bounceShare(sunlit.areaDensity(sun, hit.position, hit.normal), hit, from);
}

// The power heuristic's weight of a path's bounce that met `hit` against a technique that draws
// points there with `areaDensity` per unit area (d^2 / |cos| of it per solid angle); 1 where it
// draws none.
double RayBaker::State::bounceShare(double areaDensity, const SurfaceHit& hit, const PathBounce& from) {
    const double cosine = std::abs(glm::dot(hit.normal, from.direction));
    if (!(areaDensity > 0.0) || !(cosine > 0.0)) return 1.0;
    return powerHeuristic(from.cosineDensity, areaDensity * from.distance * from.distance / cosine);
}

// E_bounce at a hit: the cache's, interpolated, or a path's: pi times the radiance of bounce - 1
// along one cosine-distributed direction (the cosine density cancels the cosine), and the emitters',
// the sky's and the sunlit points' light by a point or a direction sampled towards them, each
// weighted against the cosine ray by the power heuristic.
glm::dvec3 RayBaker::State::bouncedIrradiance(int bounce, const SurfaceHit& hit, ProbePaths* paths,
                                              uint64_t& rays) {
    if (options.bounceLight == BounceLight::Cache)
        return cache->irradiance(bounce, hit.triangle, hit.frontSide ? 0 : 1, hit.barycentric, hit.rayOrigin);
    const int level = options.bounces - bounce;
    const glm::dvec2 u = paths->bounceDirection(level);
    const glm::dvec3 direction = cosineDirection(hit.shadingNormal, u.x, u.y);
    const double density = std::max(glm::dot(hit.shadingNormal, direction), 0.0) * std::numbers::inv_pi;
    return emitterIrradiance(hit, *paths, level, rays) + skyIrradiance(hit, *paths, level, rays) +
           sunlitIrradiance(hit, *paths, level, rays) +
           std::numbers::pi * arriving(bounce - 1, hit.rayOrigin, direction, paths, rays, density);
}

// The emitters' irradiance at a hit from one point sampled on them (EmitterSampler) with the path's
// numbers at bounce `level`, seen by a shadow ray: L_e max(0, n.w) / p(w), p the point's density
// per solid angle, weighted by the power heuristic against the cosine rays' density. The numbers
// are drawn only where there are emitters (a fifth of a path's time went to drawing them).
glm::dvec3 RayBaker::State::emitterIrradiance(const SurfaceHit& hit, const ProbePaths& paths, int level,
                                              uint64_t& rays) const {
    if (emitters.empty()) return glm::dvec3(0.0);
    const glm::dvec3 u = paths.emitterPoint(level);
    const EmitterPoint point = emitters.sample(u.x, u.y, u.z);
    const glm::dvec3 toLight = point.position - hit.rayOrigin;
    const double distance = glm::length(toLight);
    if (!(distance > 0.0)) return glm::dvec3(0.0);
    const glm::dvec3 direction = toLight / distance;
    const double cosine = glm::dot(hit.shadingNormal, direction);
    if (!(cosine > 0.0)) return glm::dvec3(0.0);
    const SurfaceHit light = shading.describe(point.triangle, point.barycentric, direction);
    const double lightCosine = std::abs(glm::dot(light.normal, direction));
    if (light.backFace || !(lightCosine > 0.0)) return glm::dvec3(0.0);
    ++rays;
    const float reach = float(distance - 2.0 * std::max(hit.offset, light.offset));
    if (caster->anyHit({glm::vec3(hit.rayOrigin), glm::vec3(direction), 0.0f, reach})) return glm::dvec3(0.0);
    const double density = point.areaDensity * distance * distance / lightCosine;
    return light.emission * (cosine / density * powerHeuristic(density, cosine * std::numbers::inv_pi));
}

// The sky's irradiance at a hit from one direction sampled towards its bright texels (SkySampler)
// with the path's numbers at bounce `level`, seen by a shadow ray: L max(0, n.w) / p(w), weighted by
// the power heuristic against the cosine rays' density.
glm::dvec3 RayBaker::State::skyIrradiance(const SurfaceHit& hit, const ProbePaths& paths, int level,
                                          uint64_t& rays) const {
    if (skyDirections.empty()) return glm::dvec3(0.0);
    const glm::dvec3 u = paths.skyPoint(level);
    const SkyDirection sky = skyDirections.sample(u.x, u.y, u.z);
    const double cosine = glm::dot(hit.shadingNormal, sky.direction);
    if (!(cosine > 0.0)) return glm::dvec3(0.0);
    ++rays;
    if (occluded(hit.rayOrigin, sky.direction)) return glm::dvec3(0.0);
    return shading.skyRadiance(sky.direction) *
           (cosine / sky.density * powerHeuristic(sky.density, cosine * std::numbers::inv_pi));
}

// The light the suns' lit points reflect to a hit, from one sun's ray into the world drawn with the
// path's numbers at bounce `level` (SunlitSampler::reflectedTo), weighted by the power heuristic
// against the cosine rays' density.
glm::dvec3 RayBaker::State::sunlitIrradiance(const SurfaceHit& hit, const ProbePaths& paths, int level,
                                             uint64_t& rays) const {
    if (sunlit.empty()) return glm::dvec3(0.0);
    const glm::dvec3 u = paths.sunlitPoint(level);
    const SunlitLight light = sunlit.reflectedTo(hit, u.x, u.y, u.z, rays);
    if (!(light.density > 0.0)) return glm::dvec3(0.0);
    return light.irradiance * powerHeuristic(light.density, light.cosine * std::numbers::inv_pi);
}

// A segment between two points just off the surfaces, counted as a cache ray.
bool RayBaker::State::segmentBlocked(const glm::dvec3& from, const glm::dvec3& to) {
    const glm::dvec3 path = to - from;
    const double length = glm::length(path);
    ++cacheRays;
    if (!(length > 0.0)) return false;
    return caster->anyHit({glm::vec3(from), glm::vec3(path / length), 0.0f, float(length)});
}

// E_k at a cache point: pi times the mean of L_{k-1} over g x g cosine-distributed rays, one in each
// stratum of the unit square (jittered), about the point's shading normal.
CachePoint RayBaker::State::gather(int bounce, uint32_t triangle, int side, const glm::dvec2& barycentric,
                                   uint64_t stream, uint64_t index) {
    const SurfaceHit at = cacheGatherPoint(shading, triangle, side, barycentric);
    RandomStream random(options.seed, stream, index);
    const int g = gatherDirections.side();
    uint64_t rays = 0;
    glm::dvec3 sum(0.0);
    gatherDirections.forEach(at.shadingNormal, random, [&](const glm::dvec3& direction) {
        sum += arriving(bounce - 1, at.rayOrigin, direction, nullptr, rays);
    });
    cacheRays += rays;
    return {glm::vec3(sum * (std::numbers::pi / (double(g) * g)))};
}

// The directions of a probe's view from `position`, in order.
template <typename Ray>
void RayBaker::State::forEachProbeRay(const glm::dvec3& position, ProbeDirections directions,
                                      Ray&& ray) const {
    if (directions == ProbeDirections::Sphere)
        forEachSphereRay(sphereRayCount(), options.seed, viewIndex(position), ray);
    else
        forEachViewRay(options.faceSize, texelSide, options.seed, ray);
}

// The index of the random streams of a view from `position` (view_rays.h placeIndex).
uint64_t RayBaker::State::viewIndex(const glm::dvec3& position) const {
    return placeIndex(position, glm::dvec3(shading.world().boundsMin), visibilityRange);
}

// R = 6 N^2 s^2: as many as a texel view casts.
int RayBaker::State::sphereRayCount() const {
    return kFaceCount * options.faceSize * options.faceSize * texelSide * texelSide;
}

// A probe's rays from `position` and what they meet, unshaded, with the hit distances gathered into
// octahedral texels of visibilitySize^2: all that tells whether the probe is inside geometry, so
// that a probe left inside is never shaded.
ProbeLook RayBaker::State::look(const glm::dvec3& position, ProbeDirections directions,
                                uint64_t& rays) const {
    ProbeLook look{{}, 0, DistanceMoments(options.visibilitySize, visibilityRange), {}};
    look.rays.reserve(size_t(sphereRayCount()));
    forEachProbeRay(position, directions, [&](const glm::dvec3& direction) {
        ++rays;
        ViewRay ray{direction};
        if (const std::optional<Meeting> meeting = intersect(position, direction))
            ray = {
                direction, meeting->distance,        meeting->surface.barycentric, meeting->surface.triangle,
                true,      meeting->surface.backFace};
        look.moments.add(direction, ray.distance);
        look.nearest.add(direction, ray.distance, ray.backFace);
        look.rays.push_back(ray);
    });
    look.backFaceTexels = backFaceTexels(look.rays, directions);
    return look;
}

// The texels whose s x s rays met mostly back faces; over the sphere, the back-face rays / s^2.
uint32_t RayBaker::State::backFaceTexels(std::span<const ViewRay> rays, ProbeDirections directions) const {
    const size_t perTexel = size_t(texelSide) * size_t(texelSide);
    auto backFacing = [](auto first, auto last) {
        return size_t(std::count_if(first, last, [](const ViewRay& ray) { return ray.backFace; }));
    };
    if (directions == ProbeDirections::Sphere)
        return uint32_t(backFacing(rays.begin(), rays.end()) / perTexel);
    uint32_t texels = 0;
    for (size_t t = 0; t < rays.size(); t += perTexel)
        texels += 2 * backFacing(rays.begin() + t, rays.begin() + t + perTexel) > perTexel ? 1 : 0;
    return texels;
}

// The radiance a view's ray brings back, its path numbered `index` (ProbePaths): the sky, or what
// its surface leaves.
glm::dvec3 RayBaker::State::shadeRay(const ViewRay& ray, uint32_t index, ProbePaths& paths, uint64_t& rays) {
    if (!ray.met) return shading.skyRadiance(ray.direction);
    paths.startRay(index);
    return leaving(options.bounces, shading.describe(ray.triangle, ray.barycentric, ray.direction), &paths,
                   rays);
}

// A texel view's cube map: each texel the mean of its s x s rays (alpha: 1 where they met mostly
// the back of a one-sided material), its paths numbered from firstTexelPath (glsl/sobol_words.h), the
// sky in a stratum that stratumSkyRays gives rays seen by them too (skyThroughStratum).
Cubemap RayBaker::State::shadeTexels(const glm::dvec3& position, const ProbeLook& look, uint64_t& rays) {
    const uint32_t n = uint32_t(options.faceSize), s = uint32_t(texelSide), perTexel = s * s;
    const uint64_t view = viewIndex(position);
    const uint64_t skySeed = mix64(probePathSeed(options.seed, view) + SHPROBE_STRATUM_SKY_USE);
    ProbePaths paths(options.seed, view);
    Cubemap radiance = makeCubemap(options.faceSize);
    for (uint32_t t = 0; t < uint32_t(radiance.texels.size()); ++t) {
        const uint32_t face = t / (n * n), j = t % (n * n) / n, i = t % n;
        const uint32_t first = firstTexelPath(face, i, j, n, perTexel);
        glm::dvec3 sum(0.0);
        size_t backFacing = 0;
        for (uint32_t k = 0; k < perTexel; ++k) {
            const ViewRay& ray = look.rays[size_t(t) * perTexel + k];
            const uint32_t skyRays =
                stratumSky.empty() ? 0 : stratumSky[glsl::stratumIndex(face, i, j, k % s, k / s, n, s)];
            if (ray.met) sum += shadeRay(ray, first + k, paths, rays);
            sum +=
                skyThroughStratum(position, ray, {face, i, j, k}, skyRays, mix64(skySeed + first + k), rays);
            backFacing += ray.backFace ? 1 : 0;
        }
        radiance.texels[t] =
            glm::vec4(glm::vec3(sum / double(perTexel)), 2 * backFacing > perTexel ? 1.0f : 0.0f);
    }
    return radiance;
}

// The sky seen through the stratum (face, i, j, k: texel (i, j)'s ray k) of a texel view's `ray`: the
// mean of what it and `count` shadow rays more (none: what the ray sees) see of it, uniform in the stratum on
// its face as the view's rays are (forEachViewRay), at the points of the stratum's own Owen-scrambled Sobol'
// set (named by `seed`), to a float's 24 bits as the gpu draws them.
glm::dvec3 RayBaker::State::skyThroughStratum(const glm::dvec3& position, const ViewRay& ray,
                                              const glm::uvec4& stratum, uint32_t count, uint64_t seed,
                                              uint64_t& rays) const {
    const uint32_t n = uint32_t(options.faceSize), s = uint32_t(texelSide);
    glm::dvec3 sum = ray.met ? glm::dvec3(0.0) : shading.skyRadiance(ray.direction);
    for (uint32_t e = 0; e < count; ++e) {
        const glm::uvec2 point =
            glsl::owenScrambledSobolWords(e, glm::uvec2(uint32_t(seed), uint32_t(seed >> 32)), false);
        const glm::vec2 u = glm::vec2(point >> 8u) * 0x1p-24f;
        const glm::dvec3 direction =
            faceDirection(int(stratum.x), glsl::stratumCoord(stratum.y, stratum.w % s, s, u.x, n),
                          glsl::stratumCoord(stratum.z, stratum.w / s, s, u.y, n));
        ++rays;
        if (!occluded(position, direction)) sum += shading.skyRadiance(direction);
    }
    return sum / double(count + 1);
}

// A sphere view's radiance, each ray projected with the weight 4 pi / R (Monte-Carlo projection).
ShCoefficients RayBaker::State::shadeSphere(const glm::dvec3& position, const ProbeLook& look,
                                            uint64_t& rays) {
    const double weight = 4.0 * std::numbers::pi / double(look.rays.size());
    ProbePaths paths(options.seed, viewIndex(position));
    ShCoefficients radiance = makeCoefficients(options.order, Quantity::Radiance);
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    for (size_t k = 0; k < look.rays.size(); ++k) {
        const glm::dvec3 weighted = shadeRay(look.rays[k], uint32_t(k), paths, rays) * weight;
        evalBasis(options.order, look.rays[k].direction, basis);
        for (size_t i = 0; i < radiance.rgb.size(); ++i)
            radiance.rgb[i] += weighted * basis[i];
    }
    return radiance;
}

// Where a probe inside geometry that saw `seen` would be captured, from `position`.
std::optional<glm::vec3> RayBaker::State::relocation(const glm::dvec3& position, const NearestHits& seen,
                                                     uint64_t& rays) const {
    const std::optional<glm::dvec3> offset = throughBackFace(options.relocation, seen);
    if (!offset) return std::nullopt;
    return offFrontFace(options.relocation, *offset,
                        look(position + *offset, options.directions, rays).nearest);
}

// A probe at `position`, or where relocation takes it out of geometry; shaded only where it is not
// inside geometry.
RayBakedProbe RayBaker::State::bake(const glm::dvec3& position, uint64_t& rays) {
    auto inside = [&](const ProbeLook& look) {
        return insideGeometry(look.backFaceTexels, options.faceSize, options.relocation.invalidBackFaces);
    };
    ProbeLook seen = look(position, options.directions, rays);
    glm::vec3 offset(0.0f);
    if (inside(seen)) {
        if (const std::optional<glm::vec3> moved = relocation(position, seen.nearest, rays)) {
            ProbeLook there = look(position + glm::dvec3(*moved), options.directions, rays);
            if (!inside(there)) {
                seen = std::move(there);
                offset = *moved;
            }
        }
    }
    const glm::dvec3 at = position + glm::dvec3(offset);
    RayBakedProbe probe;
    probe.radiance = makeCoefficients(options.order, Quantity::Radiance);
    if (!inside(seen)) {
        probe.radiance = options.directions == ProbeDirections::Sphere
                             ? shadeSphere(at, seen, rays)
                             : projectCubemap(shadeTexels(at, seen, rays), options.order);
        addSeenSuns(at, probe.radiance, rays);
    }
    probe.backFaceTexels = seen.backFaceTexels;
    probe.visibility = seen.moments.texels();
    probe.irradiance = convolveIrradiance(probe.radiance);
    probe.offset = offset;
    return probe;
}

// Each sun counts a shadow ray.
void RayBaker::State::addSeenSuns(const glm::dvec3& position, ShCoefficients& radiance,
                                  uint64_t& rays) const {
    rays += options.skySuns.size();
    shprobe::addSeenSuns(*caster, options.skySuns, position, radiance);
}

RayBaker::RayBaker(const World& world, const Cubemap& sky, const RayBakeOptions& options) {
    requireOptions(options);
    state_ = std::make_unique<State>(world, sky, options);
    state_->layOutCache();
}

RayBaker::~RayBaker() = default;
RayBaker::RayBaker(RayBaker&&) noexcept = default;
RayBaker& RayBaker::operator=(RayBaker&&) noexcept = default;

std::vector<RayBakedProbe> RayBaker::bakeProbes(std::span<const glm::dvec3> positions,
                                                const BakeProgress& progress) {
    State& state = *state_;
    const size_t raysPerProbe = size_t(kFaceCount) * state.options.faceSize * state.options.faceSize;
    std::vector<RayBakedProbe> probes(positions.size());
    std::mutex reporting;
    size_t done = 0;
    forEachItem(int(positions.size()), threadCount(positions.size() * raysPerProbe, kRaysPerThread),
                [&](int p) {
                    uint64_t rays = 0;
                    probes[size_t(p)] = state.bake(positions[size_t(p)], rays);
                    state.probeRays += rays;
                    if (!progress) return;
                    const std::lock_guard lock(reporting);
                    progress(++done);
                });
    return probes;
}

Cubemap RayBaker::traceProbe(const glm::dvec3& position) {
    uint64_t rays = 0;
    Cubemap radiance =
        state_->shadeTexels(position, state_->look(position, ProbeDirections::Texels, rays), rays);
    state_->probeRays += rays;
    return radiance;
}

double RayBaker::visibilityRange() const {
    return state_->visibilityRange;
}

RayBakeCounts RayBaker::counts() const {
    const CacheCounts cache = state_->cache ? state_->cache->counts() : CacheCounts{};
    return {state_->probeRays.load(), state_->cacheRays.load(), cache.points, cache.halvedCells,
            state_->sunlit.sampledSuns()};
}

} // namespace shprobe
