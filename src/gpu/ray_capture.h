// Light probes inside a scene by rays on the GPU: the cpu backend's transport (scene/ray_bake.h) in
// compute shaders on the scene's hierarchy (glsl/bvh_traversal.glsl), writing the same 2D-array
// image the raster capture writes (gpu/scene_capture.h), which recordProbeBake then bakes.
//
//   SceneCapture capture = createSceneCapture(context, world, sky, {.faceSize = 32});
//   RayCapture rays = createRayCapture(context, capture, SceneShading(world, sky), {.bounces = 2});
//   std::vector<SceneProbe> probes = bakeRayProbes(context, capture, rays, positions, {.order = 3});
//
// A probe's texel holds the mean of what arrives along its rays from the probe (capture_rays.comp),
// through the texel's centre, or s x s jittered as the cpu's (scene/view_rays.h): the sky (its
// texel, nearest), nothing from the back of a one-sided material (marked, for the validity count,
// where most of its rays met one), else the front's emission + albedo / pi times the suns'
// irradiance (a shadow ray each) and the last bounce's irradiance. Bounces are gathered at the
// surfaces, as the cpu gathers them: every point of every triangle's lattice (scene/surface_cache.h,
// without refinement) gathers E_k by g x g stratified cosine rays reading E_{k-1} at their hits
// (cache_gather.comp), bounce after bounce, when the capture is created. All points are gathered,
// none lazily, so every probe reads the same cache: a brick is exactly its part of the whole bake.
// Or, with BounceLight::Paths, no cache: each ray's hit continues as a path, as the cpu's do
// (glsl/ray_paths.glsl), its random numbers named by the probe's place in the world, so that a
// probe's result does not depend on the probes baked with it either.
#pragma once
#include "gpu/scene_capture.h"
#include "scene/bvh.h"
#include "scene/ray_bake.h"
#include "scene/surface_shading.h"
#include "vk/pipeline.h"

#include <array>
#include <cstdint>
#include <vector>

namespace shprobe {

struct RayCaptureOptions {
    int bounces = 0;               // k: the probes see the surfaces reflect bounce k (0: none)
    int raysPerTexel = 1;          // 1: through the texel's centre; more, rounded up to a square
                                   // s x s: the cpu's jittered rays (RayBakeOptions::raysPerTexel)
    double cacheSpacing = 0.0;     // the largest distance between cache points; 0: cacheSpacingFor's
    int gatherRays = 64;           // per cache point and bounce, rounded up to a square (g x g strata)
    uint64_t seed = 1;             // of the gather's and the paths' random numbers
    int visibilitySize = 16;       // each probe's visibility map (RayBakedProbe's): size x size
                                   // octahedral texels of its rays' hit distances; 0: none
    ProbeRelocation relocation;    // probes inside geometry moved out as the cpu moves them
    std::vector<SceneSun> skySuns; // suns taken out of the sky (RayBakeOptions::skySuns): a probe
                                   // that sees one adds its delta; the capture's world lights with them
    BounceLight bounceLight = BounceLight::Cache; // where the bounces come from (RayBakeOptions's)
};

// The hierarchy and the surface cache on the device, with the two compute programs.
struct RayCapture {
    RayCaptureOptions options;
    Bvh bvh;                         // on the host too: the sky's suns a probe sees
    float surfaceOffsetScale = 0.0f; // kSurfaceOffsetScale: a triangle's offset over its largest coordinate
    uint32_t cachePoints = 0;        // over all lattices and sides; 0 with paths
    uint32_t emitters = 0;           // emissive triangles the paths sample (EmitterSampler)
    uint32_t skyTexels = 0;          // sky texels the paths sample (SkySampler)
    uint32_t sunlitCells = 0;        // suns' plane cells the paths sample (SunlitSampler)
    size_t sunlitSuns = 0;           // the suns those cells belong to
    uint32_t gatherSide = 1;         // g
    uint32_t texelSide = 1;          // s
    double visibilityRange = 1.0;    // the farthest distance a visibility map records (visibilityRangeOf)
    glm::vec3 boundsMin{0.0f};       // the world's lower corner, where the probes' paths are named from
    // The passes of the view's strata's shadow rays to the sky (stratumSkyRays; always asked: the
    // gpu bakes no transfer, see skyThroughStrata), as their RayCaptureConstants::pass; empty: none.
    std::vector<glm::uvec4> skyPasses;
    // The hierarchy's three arrays, the lattices, the gather points, two caches, the paths' picks and
    // densities, the strata's sky rays, the suns' cells and planes, the texels the sky passes cover.
    std::vector<Buffer> buffers;
    ComputeProgram probes; // capture_rays.comp
    ComputeProgram gather; // cache_gather.comp
    VkDescriptorPool pool = VK_NULL_HANDLE;
    std::array<VkDescriptorSet, 2> gatherSets{}; // bounce k gathers with set (k - 1) % 2
};

// Lays out and gathers the cache, options.bounces bounces, where options.bounceLight asks for it
// (submissions of a bounded number of rays each). `shading` is of the world and sky the capture
// holds. Throws Error(Input) for options out of range, a cache past 2^32 points or buffers past the
// device's limits.
RayCapture createRayCapture(const Context& context, const SceneCapture& capture, const SceneShading& shading,
                            const RayCaptureOptions& options);
void destroyRayCapture(const Device& device, RayCapture& rays);

// bakeSceneProbes by rays: every position, probesPerBatch per command buffer (fewer where the rays'
// distances would pass kRayDistanceBytes), results in input order, each with its visibility map,
// from its rays' hit distances as the cpu's rays gather them; probes inside geometry moved out by
// options.relocation (their views from where they may go, then from where they go, two more bakes
// of them all), the offset in SceneProbe::offset.
std::vector<SceneProbe> bakeRayProbes(const Context& context, const SceneCapture& capture,
                                      const RayCapture& rays, std::span<const glm::dvec3> positions,
                                      const SceneBakeOptions& options);

// What a probe at `position` sees through its texels (alpha as bakeRayProbes captures it), for tests
// and pictures.
Cubemap traceRayCubemap(const Context& context, const SceneCapture& capture, const RayCapture& rays,
                        const glm::dvec3& position);

} // namespace shprobe
