// Buffers and push constants of the capture by rays (capture_rays.comp, cache_gather.comp), shared
// by C++ and GLSL. Set 0 holds the scene capture's bindings (capture_interface.h, 0 to 9), then the
// scene's hierarchy (bvh_interface.h), the surface cache's lattices and the cache a pass reads, then
// what each module reads and writes of its own. The transport is src/scene/scene.h's, with bounces
// gathered at the surfaces as the cpu backend gathers them (scene/ray_bake.h, scene/surface_cache.h),
// or continued as paths from the probes' hits (BounceLight::Paths).
#ifndef SHPROBE_RAY_CAPTURE_INTERFACE_H
#define SHPROBE_RAY_CAPTURE_INTERFACE_H
#include "shared.h"

// BvhNode[], BvhTriangle[], uint[] (the World index of each): the hierarchy (bvh_interface.h).
#define SHPROBE_RAYS_BVH_NODES 10
#define SHPROBE_RAYS_BVH_TRIANGLES 11
#define SHPROBE_RAYS_BVH_IDS 12
// CacheLattice[]: one per World triangle.
#define SHPROBE_RAYS_LATTICES 13
// vec4[]: the irradiance (rgb) of each cache point, as read.
#define SHPROBE_RAYS_CACHE 14
// capture_rays: RayProbe[]; cache_gather: CacheGatherPoint[].
#define SHPROBE_RAYS_INPUT 15
// capture_rays: the rgba32f 2D-array image of 6 layers per probe; cache_gather: vec4[], the
// irradiance gathered per point.
#define SHPROBE_RAYS_OUTPUT 16
// The bindings of cache_gather; capture_rays has one more.
#define SHPROBE_RAYS_BINDINGS 17
// capture_rays: float[], each ray's hit distance (infinity: none; negative: the back of a
// one-sided material), probe p's 6 N^2 texels from 6 N^2 p, faces and rows in order, each texel's
// s^2 rays from s^2 times its index, strata row by row (scene/view_rays.h).
#define SHPROBE_RAYS_DISTANCES 17
// capture_rays: PickedIndex[], what the paths' next-event estimation picks from: the emissive
// triangles (scene/emitters.h EmitterSampler; paths.y of them), then the sky's texels (SkySampler;
// paths.z of them), each in its sampler's order.
#define SHPROBE_RAYS_PICKS 18
// capture_rays: float[], per sky texel (6 sizes.y^2 of them, face after face, rows in order) the
// probability SkySampler picks it with, then per World triangle the density per unit area of the
// emitters' points on it (EmitterSampler::areaDensity; 0: never picked).
#define SHPROBE_RAYS_PICK_DENSITIES 19
// capture_rays: uint[], per stratum of the view (faces, rows of N s strata, in order) the shadow
// rays it adds towards the sky (scene/emitters.h stratumSkyRays), read by the variant with
// SHPROBE_RAYS_STRATUM_SKY_RAYS.
#define SHPROBE_RAYS_STRATUM_SKY 20
// capture_rays: float[], per sun and cell of its plane (SHPROBE_SUNLIT_CELLS^2 a sun, rows in order)
// the probability SunlitSampler (scene/emitters.h) picks it with; its picks follow the sky texels'
// in SHPROBE_RAYS_PICKS (paths.w of them).
#define SHPROBE_RAYS_SUNLIT_CELLS 21
// capture_rays: SunlitPlane[], one per sun, where its rays into the world start.
#define SHPROBE_RAYS_SUNLIT_PLANES 22
// capture_rays: uint[], the texels (face N^2 + j N + i) whose strata cast shadow rays to the sky,
// those whose busiest stratum casts the most first: a sky pass covers the first pass.x of them.
#define SHPROBE_RAYS_CASTING_TEXELS 23
// The most strata of a texel one sky pass casts shadow rays of: with one ray each, an invocation's
// traversals in a dispatch (gpu/ray_capture.cpp, kRaySegmentsPerPass).
#define SHPROBE_SKY_STRATA_PER_PASS 32u
// The bindings of capture_rays.
#define SHPROBE_RAYS_PROBE_BINDINGS 24
// Cells across a sun's plane (SunlitSampler::kCells).
#define SHPROBE_SUNLIT_CELLS 128u
// capture_rays' SHPROBE_SPEC_VARIANT for bounces by paths (the default, 0: from the cache).
#define SHPROBE_RAYS_BY_PATHS 1u
// capture_rays' SHPROBE_SPEC_VARIANT bit for strata that cast shadow rays to the sky (a variant of
// its own, as the paths are, so that captures without them do not carry their code: see
// docs/benchmark.md).
#define SHPROBE_RAYS_STRATUM_SKY_RAYS 2u

SHPROBE_BEGIN

// A triangle's lattice of cache points (scene/surface_cache.h): barycentrics (i/m, j/m),
// i + j <= m, row by row; side s (1: the back of a double-sided material) starts at
// first + s (m + 1)(m + 2) / 2.
struct CacheLattice {
    uvec4 points; // x: the first point, y: m
};

// Where a cache point gathers from: just off its surface, on its side, moved into the triangle at
// its edges (scene/surface_cache.h cacheGatherPoint), and the shading normal there.
struct CacheGatherPoint {
    vec4 origin; // xyz
    vec4 normal; // xyz: unit, on the point's side
};

// A probe capture_rays captures: where, and the seed of its paths' Owen-scrambled Sobol' sets
// (scene/view_rays.h probePathSeed).
struct RayProbe {
    vec4 position; // xyz
    uvec4 paths;   // xy: the seed's words (low, high)
};

// An index a sampler picks and the running sum of the probabilities up to it (DiscreteDistribution).
struct PickedIndex {
    uint index;
    float cumulative;
};

// A sun's plane (scene/emitters.h SunPlane): cell (i, j) spans corner + [i, i + 1] across +
// [j, j + 1] down; its rays travel along -toSun.
struct SunlitPlane {
    vec4 corner; // xyz; w: the cell's side
    vec4 across; // xyz
    vec4 down;   // xyz
    vec4 toSun;  // xyz: unit
};

// Push constants of both modules.
struct RayCaptureConstants {
    uvec4 sizes; // x: probe face size N; y: sky face size; z: sun count; w: BVH node count
    uvec4 work;  // x: the probes (capture_rays) or points (cache_gather) of the pass; y: the first
                 // point (cache_gather); z: the bounce the cache holds (0: none, reflect no bounce);
                 // w: g, the gather's g x g rays per point, or s, the probes' s x s rays per texel
    vec4 scale;  // x: a leaving ray's start off a surface over its triangle's largest coordinate
                 // (scene/surface_shading.h kSurfaceOffsetScale)
    uvec4 seed;  // x: the random numbers' seed; y: the bounce gathered; zw: the words (low, high)
                 // of the probes' view stream base (scene/view_rays.h viewStreamBase)
    uvec4 paths; // capture_rays: x: the bounces continued as paths from each ray's hit (0: none, the
                 // cache's if work.z); y: emitter triangles; z: sky texels picked; w: sun cells
                 // picked (SunlitSampler)
    uvec4 pass;  // x: the first of each texel's s^2 (or point's g^2) rays this pass casts; y: how
                 // many. A pass after the first carries on the sums the one before left in the
                 // output; the last finishes them (gpu/ray_capture.cpp says why there are passes).
                 // capture_rays' sky passes, before those: x: the texels of
                 // SHPROBE_RAYS_CASTING_TEXELS covered; y: the first of the
                 // SHPROBE_SKY_STRATA_PER_PASS strata a texel's (r = sb s + sa) cast; z: the first of
                 // each stratum's shadow rays to the sky cast; w: how many (0: a pass of the view's rays)
};

SHPROBE_END

#ifdef __cplusplus
static_assert(sizeof(shprobe::glsl::CacheLattice) == 16);
static_assert(sizeof(shprobe::glsl::CacheGatherPoint) == 32);
static_assert(sizeof(shprobe::glsl::RayProbe) == 32);
static_assert(sizeof(shprobe::glsl::PickedIndex) == 8);
static_assert(sizeof(shprobe::glsl::SunlitPlane) == 64);
static_assert(sizeof(shprobe::glsl::RayCaptureConstants) == 96);
#endif

#endif
