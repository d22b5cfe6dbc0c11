// Light probes inside a scene by rays on the CPU (scene/ray_caster.h casts them, scene/surface_shading.h
// shades what they hit), following the transport of scene.h:
//
//   RayBaker baker(world, sky, {.order = 3, .faceSize = 32, .bounces = 2});
//   std::vector<RayBakedProbe> probes = baker.bakeProbes(positions);
//
// A probe's view is a 6 x N x N cube map, projected with each texel's solid angle as a cube map is
// (sh/projection.h). One ray through each texel centre sees what the GPU capture
// (gpu/scene_capture.h) rasterizes, texel for texel; sharp edges (a bright opening, the rim of a
// light) then alias, an error falling as 1 / N. s x s jittered rays per texel turn that error into
// noise that falls faster, at s^2 the cost. Or the view is R = 6 N^2 s^2 directions stratified
// over the sphere (ProbeDirections::Sphere, scene/view_rays.h forEachSphereRay), each projected with
// the weight 4 pi / R: no texels, the same cost (docs/scene-probes.md measures all three).
//
// The light the surfaces reflect is computed at the surfaces, not read from a probe grid. Each
// triangle carries a lattice of cache points (scene/surface_cache.h: barycentrics (i/m, j/m),
// i + j <= m, m chosen so that neighbouring points lie at most `cacheSpacing` apart; one lattice per
// side of a double-sided material; cells halved where their corners disagree, cacheRefinement). A point's
// irradiance at bounce k, E_k(x) = integral of L_{k-1}(x, w) max(0, n.w) dw, is gathered by g x g stratified
// cosine-distributed rays about its shading normal, each ray reading what the surface it meets leaves at
// bounce k - 1 (emission, the suns by shadow rays, and E_{k-1} interpolated linearly between that triangle's
// points), or the sky. A probe at bounce k sees surfaces leave emission + albedo / pi (E_sun + E_k). Points
// are gathered on first use and kept, with their own random numbers (the seed, the bounce, the point's
// index): a bake gives the same bits for any thread count and any subset of probes, so bricks merge into
// exactly the whole bake. A probe inside geometry may be moved out before it is captured (ProbeRelocation),
// by its own rays alone, so that this stays true. The estimate converges to the exact transport as the points
// grow denser (interpolation) and the gather rays more (noise); docs/scene-probes.md measures both against
// the path tracer. With BounceLight::Paths no cache is kept: each probe ray that meets a surface goes on
// in one cosine-distributed direction a bounce, with the probe's own numbers (named by its place in
// the world), the suns by shadow rays and a point on the lamps and a direction towards the sky's
// bright texels at every hit (scene/emitters.h): no interpolation, noise that falls with the probe's
// rays, the same bits for any thread count and any subset of probes.
#pragma once
#include "scene/ray_caster.h"
#include "scene/scene.h"
#include "scene/surface_cache.h"
#include "scene/surface_shading.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace shprobe {

// Whether a probe is inside geometry: more than `share` of its 6 N^2 texels (faces N^2) see mostly
// back faces (half, by default: a probe in a room sees none, one inside a wall nearly all).
bool insideGeometry(uint32_t backFaceTexels, int faceSize, double share);

// Probe relocation (DDGI's, Majercik et al. 2019 and RTXGI; Unity's "virtual offset"): a probe
// inside geometry is moved along its nearest ray that met a back face, through that face and
// `minFrontDistance` / 2 past it, then, where its rays from there meet a front face nearer than
// `minFrontDistance`, away from that face by the difference; it is captured there and kept there if
// it is no longer inside geometry. An offset longer than `limit` is not taken: the probe stays where
// it was, inside. Both lengths are world units (the caller scales them by the grid's cells); the
// offset is rounded to float, as a volume records it, before the probe is captured.
struct ProbeRelocation {
    double limit = 0.0;            // the longest offset; 0: no probe moves
    double minFrontDistance = 0.0; // the least distance to a front face a moved probe keeps
    double invalidBackFaces = 0.5; // insideGeometry's share
};

// The directions of a probe's view: s x s rays through each texel of a 6 x N x N cube map, or as
// many stratified over the sphere (R = 6 N^2 s^2), which its validity, visibility map and relocation
// read as well.
enum class ProbeDirections { Texels, Sphere };

// Where the light a surface reflects at bounce k comes from: the irradiance cache on the surfaces
// (interpolated, gathered once for every probe), or a path from each probe ray's hit, continued in
// one cosine-distributed direction a bounce (unbiased, paid per probe ray). Which costs fewer rays
// depends on the grid: autoBounceLight chooses.
enum class BounceLight { Cache, Paths };

struct RayBakeOptions {
    int order = 3;             // SH order of the probes, 1..kMaxOrder
    int faceSize = 32;         // N: a probe's view is a 6 x N x N cube map
    int raysPerTexel = 1;      // 1: through the texel's centre (the rasterized capture's view); more,
                               // rounded up to a square s x s: one jittered in each stratum, averaged
    int bounces = 1;           // 0: what the probes see directly; k: k bounces off the surfaces
    double cacheSpacing = 0.0; // the largest distance between neighbouring cache points; 0: the
                               // world's diagonal / kDefaultCacheCells
    int gatherRays = 64;       // per cache point, rounded up to a square (g x g strata)
    int cacheRefinement = 0;   // the most times a cache cell is halved where its corners disagree
                               // (scene/surface_cache.h), down to cacheSpacing / 2^levels; 0: never
    int visibilitySize = 16;   // each probe's visibility map: size x size octahedral texels; 0: none
    // Suns taken out of the sky (sh/lights.h extractSun): light too small for rays to find, so it
    // is sampled explicitly. They light the surfaces as the World's suns do (a shadow ray each),
    // and a probe that sees one adds its delta to its radiance, E y_lm(l).
    std::vector<SceneSun> skySuns;
    ProbeRelocation relocation;
    ProbeDirections directions = ProbeDirections::Texels;
    BounceLight bounceLight = BounceLight::Cache;
    // A texel view's strata where the sky is bright add shadow rays towards it (emitters.h
    // stratumSkyRays); off where the bake must be linear in the sky (transfer), as the rays a
    // stratum adds follow the sky.
    bool skyThroughStrata = true;
    uint64_t seed = 1;
};

// `shprobe scene`'s rays a texel on both backends: 3 x 3 jittered rays. One ray through each
// texel's centre aliases sharp edges; 3 x 3 is the fewest that keep every coefficient of sunlit
// probes within the 2% of the path tracer asked of a bake (docs/scene-probes.md, "At the defaults").
constexpr int kDefaultRaysPerTexel = 9;

// Paths unless the cache casts fewer than a quarter of their rays: a probe's rays (at most 2 x 2 a
// texel: more lower only the paths' error) times `probes` (the whole grid's, so that its bricks
// agree) against the lattice points times their gather rays, each ray a bounce with its shadow
// rays. Paths are unbiased where the cache interpolates, and cost about as much per ray
// (docs/scene-probes.md measures both).
BounceLight autoBounceLight(const World& world, const RayBakeOptions& options, uint64_t probes);

// Cache points per world diagonal when RayBakeOptions::cacheSpacing is 0.
constexpr double kDefaultCacheCells = 64.0;

// The World lit by the sky's suns too (RayBakeOptions::skySuns).
World withSuns(const World& world, const std::vector<SceneSun>& skySuns);

// The cache spacing asked for, or where that is 0 the world's diagonal / kDefaultCacheCells.
double cacheSpacingFor(const World& world, double asked);

// The side s of the s x s rays that `count` rays are rounded up to (per texel, per cache point).
inline int squareSide(int count) {
    return int(std::ceil(std::sqrt(double(count))));
}

// The most rays a probe's view may cast, 6 N^2 s^2 (faces N, s x s rays a texel): its rays are kept
// until it is shaded, and its paths are numbered in 32 bits (Morton codes of 16-bit coordinates).
constexpr double kMaxViewRays = double(1 << 28);
// Throws Error(Input) for a view of faces `faceSize` and `raysPerTexel` rays a texel (rounded up to
// a square) of more than kMaxViewRays rays.
void requireViewRays(int faceSize, int raysPerTexel);

// Where the cache point of `triangle` at `barycentric` on side 0 (front) or 1 gathers from: there,
// or, on an edge or a corner where a wall meets the next, moved towards the triangle's centroid (1%
// of the way, or 4 surface offsets where that is more), so that its rays start inside the room and
// not on the plane of the next wall, where a ray along that wall could slip out between the two.
SurfaceHit cacheGatherPoint(const SceneShading& shading, uint32_t triangle, int side,
                            const glm::dvec2& barycentric);

// The nearest back face and the nearest front face a view's rays met: their directions (unit) and
// distances, infinity where none was met. Of rays within a relative 1e-5 of one distance, the first
// added counts.
struct NearestHits {
    glm::dvec3 backDirection{0.0};
    double back = std::numeric_limits<double>::infinity();
    glm::dvec3 frontDirection{0.0};
    double front = std::numeric_limits<double>::infinity();
    void add(const glm::dvec3& direction, double distance, bool backFace);
};

// Where a probe inside geometry is captured, as an offset from its position (ProbeRelocation), in
// two steps: through the nearest back face it saw (none where the rule's limit is 0, nothing was
// seen behind, or the offset would pass the limit), then, from the view `there` at that offset, off
// the nearest front face, where that stays within the limit; rounded to float, as volumes hold it.
std::optional<glm::dvec3> throughBackFace(const ProbeRelocation& rule, const NearestHits& seen);
glm::vec3 offFrontFace(const ProbeRelocation& rule, const glm::dvec3& offset, const NearestHits& there);

// Hit distances of a view gathered per octahedral texel (scene/volume_sampling.h) into their mean
// and mean square, each distance clamped to `range` (rays that meet nothing count as `range`): the
// visibility map of RayBakedProbe. A texel no ray fell in holds range, range^2: nothing near.
class DistanceMoments {
  public:
    DistanceMoments(int size, double range);
    void add(const glm::dvec3& direction, double distance);
    std::vector<glm::vec2> texels() const;

  private:
    int size_;
    double range_;
    std::vector<glm::dvec2> sums_;
    std::vector<uint32_t> counts_;
};

// The farthest distance a visibility map records: the world's diagonal (RayBaker::visibilityRange).
double visibilityRangeOf(const World& world);

// Adds to a probe's radiance at `position` each sun it sees (no surface on the way to it): a delta of
// irradiance E in direction l, whose projection is E y_lm(l) exactly.
void addSeenSuns(const RayCaster& caster, std::span<const SceneSun> suns, const glm::dvec3& position,
                 ShCoefficients& radiance);

struct RayBakedProbe {
    ShCoefficients radiance; // zero where the probe is still inside geometry: its rays are not shaded
    ShCoefficients irradiance;
    uint32_t backFaceTexels = 0; // of the 6 N^2 texels, those whose rays met mostly back faces; of
                                 // a sphere view, its back-face rays / s^2 (rounded down)
    // Per octahedral texel (volume_sampling.h), the mean and mean square distance to the first
    // surface its rays met, at most the world's diagonal (which rays that meet nothing count as):
    // the depth moments of Majercik et al., "Dynamic Diffuse Global Illumination with Ray-Traced
    // Irradiance Fields" (JCGT 2019), by which a sampler tells whether the probe sees a point.
    std::vector<glm::vec2> visibility;
    // Where the probe was captured, from the position it was asked for (ProbeRelocation): zero
    // unless it was moved out of geometry, which it then no longer is.
    glm::vec3 offset{0.0f};
};

// What a baker has cast so far.
struct RayBakeCounts {
    uint64_t probeRays = 0;   // the probes' own, with their shadow rays
    uint64_t cacheRays = 0;   // gathering cache points, with their shadow rays (a point two threads
                              // needed at once is gathered by both)
    uint64_t cachePoints = 0; // gathered, over all bounces
    uint64_t halvedCells = 0; // cache cells halved, over all bounces and levels
    size_t sunlitSuns = 0;    // the suns whose lit points the paths sample (SunlitSampler)
};

// Called after each probe with the number done so far, from whichever thread finished it (one call
// at a time).
using BakeProgress = std::function<void(size_t probesDone)>;

// The ray caster, the shading and the cache of one world, sky and options. Bakes may run one after
// another on the same baker (the cache is kept); not two at once.
class RayBaker {
  public:
    // Throws Error(Input) for a world, sky or options it cannot bake (surface_shading.h, bvh.h;
    // order, face size, bounces, spacing or gather rays out of range), Error(Device) where Embree
    // cannot be loaded (ray_caster.h).
    RayBaker(const World& world, const Cubemap& sky, const RayBakeOptions& options);
    ~RayBaker();
    RayBaker(RayBaker&&) noexcept;
    RayBaker& operator=(RayBaker&&) noexcept;

    // The probes at `positions` (each moved out of geometry where options.relocation says), on all
    // cores; entry k depends on positions[k] (its place in the world's box) alone.
    std::vector<RayBakedProbe> bakeProbes(std::span<const glm::dvec3> positions,
                                          const BakeProgress& progress = {});
    // What a probe at `position` sees through its texels, whatever options.directions (alpha: 1
    // where a ray met the back of a one-sided material, else 0).
    Cubemap traceProbe(const glm::dvec3& position);
    RayBakeCounts counts() const;
    // The distance the visibility maps record for rays that meet nothing: the world's diagonal. A
    // map of (range, range^2) in every texel hides nothing.
    double visibilityRange() const;

  private:
    struct State;
    std::unique_ptr<State> state_;
};

} // namespace shprobe
