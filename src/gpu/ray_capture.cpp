// RayCapture (ray_capture.h): the surface cache laid out on the host and gathered on the device,
// then probes captured by rays into the raster capture's target and baked as it bakes them.
#include "gpu/ray_capture.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/capture_interface.h"
#include "glsl/ray_capture_interface.h"
#include "scene/emitters.h"
#include "scene/ray_bake.h"
#include "scene/ray_caster.h"
#include "scene/surface_cache.h"
#include "scene/view_rays.h"
#include "sh/cubemap.h"
#include "sh/irradiance.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_scene_spirv.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace shprobe {

namespace {

// RayCapture::buffers, in this order.
enum RayBuffer : size_t {
    kNodes,
    kTriangles,
    kIds,
    kLattices,
    kGatherPoints,
    kCacheA,
    kCacheB,
    kPicks,
    kPickDensities,
    kStratumSky,
    kSunlitCells,
    kSunlitPlanes,
    kCastingTexels,
    kRayBufferCount
};

constexpr uint32_t kLocalSize = 64;
// The most bytes of ray distances a batch of probes reads back, or the device binds as one storage
// buffer if less: with s x s rays per texel a probe holds 4 * 6 N^2 s^2 (25 MB at N = 32, s = 32),
// so large s bakes fewer probes per batch.
constexpr uint64_t kRayDistanceBytes = uint64_t(256) << 20;
// Rays per gather submission: a bounded time per command buffer on any device (lavapipe: about 1 s).
constexpr uint64_t kRaysPerSubmission = uint64_t(1) << 22;
// Workgroups per dispatch dimension that every device allows (maxComputeWorkGroupCount >= 65535);
// the modules loop over what lies beyond.
constexpr uint32_t kMaxGroups = 65535;

uint32_t groupsFor(uint64_t threads) {
    return uint32_t(std::clamp<uint64_t>((threads + kLocalSize - 1) / kLocalSize, 1, kMaxGroups));
}

// Workaround(llvmpipe, Mesa 22.3): llvmpipe ends an invocation's loops after 65535 iterations in
// all (glsl/dispatch_plan.h), and a texel's or cache point's rays, or a stratum's shadow rays to
// the sky, are a loop around traversals whose steps the scene decides, so many rays or long paths
// left the light short (docs/scene-probes.md).
// A dispatch has each invocation cast at most this many rays times the traversals each takes in a
// row (1 + its bounces as a path), carrying the sums from pass to pass, which leaves a ray's segment
// (its traversal, next-event rays and table searches) 2,000 loop iterations. Other devices spend a
// dispatch per pass.
constexpr uint64_t kRaySegmentsPerPass = 32;

// The items (texels or points) each invocation takes when a dispatch spreads `items` over groupsFor's.
uint64_t itemsPerInvocation(uint64_t items) {
    const uint64_t invocations = uint64_t(groupsFor(items)) * kLocalSize;
    return (items + invocations - 1) / invocations;
}

// Sets constants.pass to each pass over `rays` rays per item (texel or point) and calls
// dispatchPass: `items` spread over the dispatch's invocations, each ray `segments` traversals in a
// row.
template <typename DispatchPass>
void forEachPass(glsl::RayCaptureConstants& constants, uint32_t rays, uint64_t segments, uint64_t items,
                 DispatchPass&& dispatchPass) {
    const uint32_t perPass =
        uint32_t(std::max<uint64_t>(1, kRaySegmentsPerPass / (segments * itemsPerInvocation(items))));
    for (uint32_t first = 0; first < rays; first += perPass) {
        constants.pass = glm::uvec4(first, std::min(perPass, rays - first), 0u, 0u);
        dispatchPass();
    }
}

// The texels (face n^2 + j n + i) whose strata cast shadow rays to the sky (stratumSkyRays' counts),
// as (the most one of its strata casts, texel), from the most down; and in `busiest`, for each group
// of SHPROBE_SKY_STRATA_PER_PASS strata of a texel (r = sb s + sa) and each k, the most that the k-th
// busiest stratum of the group casts in any texel, so that shadow ray e of a group is cast by at
// most #{k : busiest[group][k] > e} strata of one texel.
std::vector<glm::uvec2> texelsCastingToTheSky(std::span<const uint32_t> stratumSky, uint32_t n, uint32_t s,
                                              std::vector<std::vector<uint32_t>>& busiest) {
    const uint32_t strata = s * s, perGroup = SHPROBE_SKY_STRATA_PER_PASS;
    busiest.assign((strata + perGroup - 1) / perGroup, std::vector<uint32_t>(perGroup, 0u));
    std::vector<glm::uvec2> casting;
    std::vector<uint32_t> counts;
    for (uint32_t texel = 0; texel < uint32_t(kFaceCount) * n * n; ++texel) {
        const uint32_t face = texel / (n * n), i = texel % (n * n) % n, j = texel % (n * n) / n;
        uint32_t most = 0;
        for (uint32_t group = 0; group < busiest.size(); ++group) {
            counts.clear();
            for (uint32_t r = group * perGroup; r < std::min(strata, (group + 1) * perGroup); ++r)
                counts.push_back(stratumSky[glsl::stratumIndex(face, i, j, r % s, r / s, n, s)]);
            std::sort(counts.begin(), counts.end(), std::greater<>());
            for (size_t k = 0; k < counts.size(); ++k)
                busiest[group][k] = std::max(busiest[group][k], counts[k]);
            most = std::max(most, counts[0]);
        }
        if (most > 0) casting.push_back({most, texel});
    }
    std::stable_sort(casting.begin(), casting.end(), [](glm::uvec2 a, glm::uvec2 b) { return a.x > b.x; });
    return casting;
}

// The sky passes of a view of faces n and s x s rays a texel (capture_rays.comp's pass constants),
// and the texels they cover (SHPROBE_RAYS_CASTING_TEXELS): each pass casts shadow rays [z, z + w) of
// a group of SHPROBE_SKY_STRATA_PER_PASS strata from y, as many as keep an invocation within
// kRaySegmentsPerPass traversals (one stratum may cast thousands), over the texels that cast any
// of them. The first pass starts every such texel's sums; none where no stratum casts any.
std::vector<glm::uvec4> planSkyPasses(std::span<const uint32_t> stratumSky, uint32_t n, uint32_t s,
                                      std::vector<uint32_t>& castingTexels) {
    if (stratumSky.empty()) return {};
    std::vector<std::vector<uint32_t>> busiest;
    const std::vector<glm::uvec2> casting = texelsCastingToTheSky(stratumSky, n, s, busiest);
    for (const glm::uvec2& texel : casting)
        castingTexels.push_back(texel.y);
    std::vector<glm::uvec4> passes;
    for (uint32_t group = 0; group < busiest.size(); ++group) {
        for (uint32_t first = 0; first < busiest[group][0] || passes.empty();) {
            const auto beyondFirst = [first](uint32_t count) { return count > first; };
            const auto texels =
                uint32_t(std::partition_point(casting.begin(), casting.end(),
                                              [&](glm::uvec2 texel) { return beyondFirst(texel.x); }) -
                         casting.begin());
            const auto strata = std::max<uint64_t>(
                1, uint64_t(std::count_if(busiest[group].begin(), busiest[group].end(), beyondFirst)));
            const uint32_t count =
                uint32_t(std::max<uint64_t>(1, kRaySegmentsPerPass / (strata * itemsPerInvocation(texels))));
            passes.push_back({texels, group * SHPROBE_SKY_STRATA_PER_PASS, first, count});
            first += count;
        }
    }
    return passes;
}

// Every cache point of the world's lattices at `spacing`, side by side (scene/surface_cache.h's
// order), and each triangle's first point and m. A zero-area triangle's points have no normal: no
// ray meets such a triangle, so they gather nothing (normal 0, which cache_gather.comp skips).
struct CacheLayout {
    std::vector<glsl::CacheLattice> lattices;
    std::vector<glsl::CacheGatherPoint> points;
};

CacheLayout layOutCache(const SceneShading& shading, double spacing) {
    const World& world = shading.world();
    CacheLayout layout;
    for (uint32_t t = 0; t < uint32_t(world.triangleCount()); ++t) {
        const int m = latticeSubdivisions(world, t, spacing);
        const int sides = world.materials[world.triangleMaterials[t]].doubleSided ? 2 : 1;
        const size_t count = latticePoints(m);
        if (layout.points.size() + sides * count > UINT32_MAX)
            throw Error(ErrorKind::Input, "scene: the surface cache would hold more than 2^32 points; raise "
                                          "the cache spacing");
        layout.lattices.push_back({glm::uvec4(uint32_t(layout.points.size()), uint32_t(m), 0u, 0u)});
        for (int side = 0; side < sides; ++side)
            for (size_t index = 0; index < count; ++index) {
                const SurfaceHit at = cacheGatherPoint(shading, t, side, latticeBarycentric(m, index));
                const bool solid = std::isfinite(at.shadingNormal.x) && std::isfinite(at.rayOrigin.x);
                layout.points.push_back(
                    {glm::vec4(solid ? glm::vec3(at.rayOrigin) : glm::vec3(0.0f), 0.0f),
                     glm::vec4(solid ? glm::vec3(at.shadingNormal) : glm::vec3(0.0f), 0.0f)});
            }
    }
    return layout;
}

// The paths' next-event tables (EmitterSampler's, SkySampler's, SunlitSampler's) as ray_paths.glsl
// reads them.
struct NextEventTable {
    std::vector<glsl::PickedIndex> picks; // the emitters', the sky texels', then the suns' cells
    std::vector<float> densities;         // per sky texel, then per World triangle
    std::vector<float> sunCells;          // per sun and cell of its plane
    std::vector<glsl::SunlitPlane> sunPlanes;
    uint32_t emitters = 0;
    uint32_t skyTexels = 0;
    uint32_t sunlitCells = 0;
    size_t sunlitSuns = 0;
};

// Appends the distribution's picks over `indices` indices with their running sums in float, as
// ray_paths.glsl searches them, and says which indices it can pick: one whose float sum does not pass
// the sum before it never is (its probability below the sum's float resolution), so its density is
// written as 0 and the cosine rays count its light whole, as the estimate needs.
std::vector<bool> appendPicks(const DiscreteDistribution& distribution, size_t indices,
                              std::vector<glsl::PickedIndex>& picks) {
    std::vector<bool> pickable(indices, false);
    float before = 0.0f;
    for (size_t k = 0; k < distribution.picked().size(); ++k) {
        const float sum = float(distribution.cumulative()[k]);
        if (!(sum > before)) continue;
        picks.push_back({distribution.picked()[k], sum});
        pickable[distribution.picked()[k]] = true;
        before = sum;
    }
    return pickable;
}

// `sunlit`: whether the paths sample the suns' lit points (bounces by paths), from rays cast by `caster`.
NextEventTable nextEventTable(const SceneShading& shading, const RayCaster& caster, bool sunlit) {
    const World& world = shading.world();
    const EmitterSampler emitters(world);
    const SkySampler sky(shading.sky());
    const SunlitSampler sunCells = sunlit ? SunlitSampler(shading, caster) : SunlitSampler();
    const size_t cellsPerSun = size_t(SunlitSampler::kCells) * SunlitSampler::kCells;
    NextEventTable table;
    const std::vector<bool> emitting = appendPicks(emitters.triangles(), world.triangleCount(), table.picks);
    table.emitters = uint32_t(table.picks.size());
    const std::vector<bool> bright = appendPicks(sky.texels(), shading.sky().texels.size(), table.picks);
    table.skyTexels = uint32_t(table.picks.size()) - table.emitters;
    const std::vector<bool> lit =
        appendPicks(sunCells.cells(), sunCells.planes().size() * cellsPerSun, table.picks);
    table.sunlitCells = uint32_t(table.picks.size()) - table.emitters - table.skyTexels;
    table.sunlitSuns = sunCells.sampledSuns();
    for (const SunPlane& plane : sunCells.planes())
        table.sunPlanes.push_back({glm::vec4(glm::vec3(plane.corner), float(plane.cellSize)),
                                   glm::vec4(glm::vec3(plane.across), 0.0f),
                                   glm::vec4(glm::vec3(plane.down), 0.0f),
                                   glm::vec4(glm::vec3(plane.toSun), 0.0f)});
    for (uint32_t c = 0; c < uint32_t(lit.size()); ++c)
        table.sunCells.push_back(lit[c] ? float(sunCells.cells().probability(c)) : 0.0f);
    for (uint32_t t = 0; t < uint32_t(shading.sky().texels.size()); ++t)
        table.densities.push_back(bright[t] ? float(sky.texels().probability(t)) : 0.0f);
    for (uint32_t t = 0; t < uint32_t(world.triangleCount()); ++t)
        table.densities.push_back(emitting[t] ? float(emitters.areaDensity(t)) : 0.0f);
    return table;
}

// capture_rays (probes: its variant, the bits SHPROBE_RAYS_BY_PATHS and SHPROBE_RAYS_STRATUM_SKY_RAYS)
// or cache_gather.
ComputeProgram createRayProgram(const Device& device, bool probes, uint32_t variant = 0) {
    std::vector<VkDescriptorType> bindings(probes ? SHPROBE_RAYS_PROBE_BINDINGS : SHPROBE_RAYS_BINDINGS,
                                           VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
    if (probes) bindings[SHPROBE_RAYS_OUTPUT] = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    return createComputeProgram(device,
                                {.name = probes ? "capture_rays" : "cache_gather",
                                 .spirv = probes ? std::span<const uint32_t>(spirv::capture_rays_comp)
                                                 : std::span<const uint32_t>(spirv::cache_gather_comp),
                                 .bindings = bindings,
                                 .pushConstantSize = sizeof(glsl::RayCaptureConstants),
                                 .localSize = kLocalSize,
                                 .variant = variant});
}

// The bindings of a ray program's set: the capture's buffers, the hierarchy, the lattices, the
// cache read (bounce `cacheBounce`; none: either), then the program's input and output.
std::vector<BindingTarget> rayTargets(const SceneCapture& capture, const RayCapture& rays, int cacheBounce,
                                      BindingTarget input, BindingTarget output) {
    std::vector<BindingTarget> targets(SHPROBE_RAYS_BINDINGS);
    for (size_t b = 0; b < SHPROBE_CAPTURE_BINDINGS; ++b)
        targets[b] = {capture.buffers[b].buffer};
    targets[SHPROBE_RAYS_BVH_NODES] = {rays.buffers[kNodes].buffer};
    targets[SHPROBE_RAYS_BVH_TRIANGLES] = {rays.buffers[kTriangles].buffer};
    targets[SHPROBE_RAYS_BVH_IDS] = {rays.buffers[kIds].buffer};
    targets[SHPROBE_RAYS_LATTICES] = {rays.buffers[kLattices].buffer};
    const size_t cache = cacheBounce > 0 && (cacheBounce - 1) % 2 == 1 ? kCacheB : kCacheA;
    targets[SHPROBE_RAYS_CACHE] = {rays.buffers[cache].buffer};
    targets[SHPROBE_RAYS_INPUT] = input;
    targets[SHPROBE_RAYS_OUTPUT] = output;
    return targets;
}

glsl::RayCaptureConstants rayConstants(const SceneCapture& capture, const RayCapture& rays) {
    glsl::RayCaptureConstants constants{};
    constants.sizes = glm::uvec4(uint32_t(capture.options.faceSize), capture.skyFaceSize,
                                 uint32_t(capture.suns.size()), uint32_t(rays.bvh.nodes.size()));
    constants.scale = glm::vec4(rays.surfaceOffsetScale, 0.0f, 0.0f, 0.0f);
    const uint64_t viewStream = viewStreamBase(rays.options.seed);
    constants.seed =
        glm::uvec4(uint32_t(rays.options.seed), 0u, uint32_t(viewStream), uint32_t(viewStream >> 32));
    const uint32_t pathBounces = rays.options.bounceLight == BounceLight::Paths ? rays.options.bounces : 0;
    constants.paths = glm::uvec4(uint32_t(pathBounces), rays.emitters, rays.skyTexels, rays.sunlitCells);
    return constants;
}

// Bounce k of every cache point into cache (k - 1) % 2, from the other (bounce k - 1).
void gatherBounce(const Context& context, const SceneCapture& capture, const RayCapture& rays, int bounce) {
    const uint64_t raysPerPoint = uint64_t(rays.gatherSide) * rays.gatherSide;
    const uint32_t chunk = uint32_t(std::max<uint64_t>(1, kRaysPerSubmission / raysPerPoint));
    glsl::RayCaptureConstants constants = rayConstants(capture, rays);
    constants.seed.y = uint32_t(bounce);
    for (uint32_t first = 0; first < rays.cachePoints; first += chunk) {
        const uint32_t count = std::min(chunk, rays.cachePoints - first);
        constants.work = glm::uvec4(count, first, bounce > 1 ? 1u : 0u, rays.gatherSide);
        submitAndWait(context, [&](VkCommandBuffer commands) {
            forEachPass(constants, uint32_t(raysPerPoint), 1, count, [&] {
                dispatch(commands, rays.gather, rays.gatherSets[size_t(bounce - 1) % 2], constants,
                         {groupsFor(count)});
                computeWriteBarrier(commands);
            });
        });
    }
}

void requireOptions(const RayCaptureOptions& options) {
    if (options.bounces < 0) throw Error(ErrorKind::Input, "scene: bounces must be 0 or more");
    if (options.raysPerTexel < 1 || options.raysPerTexel > 1024)
        throw Error(ErrorKind::Input,
                    "scene: rays per texel must be in 1..1024, got " + std::to_string(options.raysPerTexel));
    if (!(options.cacheSpacing >= 0.0) || !std::isfinite(options.cacheSpacing))
        throw Error(ErrorKind::Input, "scene: the cache spacing must be a finite number of 0 or more");
    if (options.gatherRays < 1 || options.gatherRays > 1 << 20)
        throw Error(ErrorKind::Input,
                    "scene: gather rays must be in 1..1048576, got " + std::to_string(options.gatherRays));
    if (options.visibilitySize < 0 || options.visibilitySize > 64)
        throw Error(ErrorKind::Input, "scene: the visibility map's size must be in 0..64, got " +
                                          std::to_string(options.visibilitySize));
}

// The bytes of one probe's ray distances: 6 N^2 s^2 floats.
uint64_t rayDistanceBytes(const SceneCapture& capture, const RayCapture& rays) {
    const uint64_t n = uint64_t(capture.options.faceSize);
    return sizeof(float) * 6 * n * n * rays.texelSide * rays.texelSide;
}

// What the probes' program binds for one target: the probes (host-written, RayProbe), the target's
// image and its texels' hit distances.
struct ProbeRaySet {
    Buffer positions;
    Buffer distances;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
};

void destroyProbeRaySet(const Device& device, ProbeRaySet& set) {
    if (set.pool) vkDestroyDescriptorPool(device.device, set.pool, nullptr);
    destroyBuffer(device, set.positions);
    destroyBuffer(device, set.distances);
    set = ProbeRaySet{};
}

ProbeRaySet createProbeRaySet(const Context& context, const SceneCapture& capture, const RayCapture& rays,
                              const CaptureTarget& target) {
    ProbeRaySet set;
    OnFailure undo([&] { destroyProbeRaySet(context, set); });
    set.positions = createBuffer(context, sizeof(glsl::RayProbe) * target.probeCount,
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Upload, "probe positions");
    set.distances = createBuffer(context, rayDistanceBytes(capture, rays) * target.probeCount,
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback, "hit distances");
    set.pool = createDescriptorPool(
        context, {.sets = 1, .storageBuffers = SHPROBE_RAYS_PROBE_BINDINGS, .storageImages = 1});
    std::vector<BindingTarget> targets = rayTargets(
        capture, rays, rays.options.bounces, {set.positions.buffer}, {.imageView = target.cubemaps.view});
    targets.push_back({set.distances.buffer});
    targets.push_back({rays.buffers[kPicks].buffer});
    targets.push_back({rays.buffers[kPickDensities].buffer});
    targets.push_back({rays.buffers[kStratumSky].buffer});
    targets.push_back({rays.buffers[kSunlitCells].buffer});
    targets.push_back({rays.buffers[kSunlitPlanes].buffer});
    targets.push_back({rays.buffers[kCastingTexels].buffer});
    set.set = createDescriptorSet(context, set.pool, rays.probes, targets);
    return set;
}

// A probe at `position` and the seed of its paths, named by its place in the world's box as the
// cpu names them (RayBaker's viewIndex): the same wherever it is baked, with whichever probes.
glsl::RayProbe rayProbe(const RayCapture& rays, const glm::dvec3& position) {
    const uint64_t seed = probePathSeed(
        rays.options.seed, placeIndex(position, glm::dvec3(rays.boundsMin), rays.visibilityRange));
    return {glm::vec4(glm::vec3(position), 1.0f), glm::uvec4(uint32_t(seed), uint32_t(seed >> 32), 0u, 0u)};
}

// The capture of `positions` into layers 6p..6p+5, visible to the bake's reads.
void recordProbeRays(VkCommandBuffer commands, const SceneCapture& capture, const RayCapture& rays,
                     const ProbeRaySet& set, std::span<const glm::dvec3> positions) {
    auto* mapped = static_cast<glsl::RayProbe*>(set.positions.mapped);
    for (size_t p = 0; p < positions.size(); ++p)
        mapped[p] = rayProbe(rays, positions[p]);
    glsl::RayCaptureConstants constants = rayConstants(capture, rays);
    const bool cachedBounce = rays.options.bounces > 0 && rays.options.bounceLight == BounceLight::Cache;
    constants.work = glm::uvec4(uint32_t(positions.size()), 0u, cachedBounce ? 1u : 0u, rays.texelSide);
    const uint64_t texels = 6 * uint64_t(capture.options.faceSize) * uint64_t(capture.options.faceSize);
    for (const glm::uvec4& sky : rays.skyPasses) {
        constants.pass = sky;
        dispatch(commands, rays.probes, set.set, constants, {groupsFor(sky.x), uint32_t(positions.size())});
        computeWriteBarrier(commands);
    }
    forEachPass(constants, rays.texelSide * rays.texelSide, 1 + uint64_t(constants.paths.x), texels, [&] {
        dispatch(commands, rays.probes, set.set, constants, {groupsFor(texels), uint32_t(positions.size())});
        computeWriteBarrier(commands);
    });
}

// Probe k's visibility map of a batch (DistanceMoments) and the nearest faces its rays met, from
// its rays' hit distances (negative: a back face) in the directions the cpu casts them, in its order.
void readDistances(const RayCapture& rays, const ProbeRaySet& set, int faceSize, size_t k, SceneProbe& probe,
                   NearestHits& nearest) {
    DistanceMoments moments(rays.options.visibilitySize, rays.visibilityRange);
    const uint64_t raysPerProbe =
        6 * uint64_t(faceSize) * uint64_t(faceSize) * rays.texelSide * rays.texelSide;
    const float* distances = static_cast<const float*>(set.distances.mapped) + raysPerProbe * k;
    forEachViewRay(faceSize, int(rays.texelSide), rays.options.seed, [&](const glm::dvec3& direction) {
        const float distance = *distances++;
        moments.add(direction, std::abs(double(distance)));
        nearest.add(direction, std::abs(double(distance)), std::signbit(distance));
    });
    probe.visibility = moments.texels();
}

// The probes seen from `positions`, without relocation, and the nearest faces each saw.
std::vector<SceneProbe> bakeViews(const Context& context, const SceneCapture& capture, const RayCapture& rays,
                                  std::span<const glm::dvec3> positions, const SceneBakeOptions& options,
                                  std::vector<NearestHits>& nearest) {
    const uint64_t distanceBytes =
        std::min<uint64_t>(kRayDistanceBytes, context.info.limits.maxStorageBufferRange);
    const uint32_t byDistances =
        uint32_t(std::max<uint64_t>(1, distanceBytes / rayDistanceBytes(capture, rays)));
    CaptureTarget target = createCaptureTarget(
        context, capture, std::min(byDistances, capturesPerBatch(context, capture, options.probesPerBatch)));
    ScopeExit releaseTarget([&] { destroyCaptureTarget(context, target); });
    ProbeRaySet set = createProbeRaySet(context, capture, rays, target);
    ScopeExit releaseSet([&] { destroyProbeRaySet(context, set); });
    nearest.assign(positions.size(), NearestHits{});
    std::vector<SceneProbe> probes = bakeCapturedProbes(
        context, capture, target, positions, options,
        [&](VkCommandBuffer commands, std::span<const glm::dvec3> members) {
            recordProbeRays(commands, capture, rays, set, members);
        },
        [&](size_t first, std::span<SceneProbe> batch) {
            invalidateBuffer(context, set.distances);
            for (size_t k = 0; k < batch.size(); ++k)
                readDistances(rays, set, capture.options.faceSize, k, batch[k], nearest[first + k]);
        });
    if (rays.options.skySuns.empty()) return probes;
    for (size_t p = 0; p < probes.size(); ++p) {
        addSeenSuns(BvhRayCaster(rays.bvh), rays.options.skySuns, positions[p], probes[p].radiance);
        probes[p].irradiance = convolveIrradiance(probes[p].radiance);
    }
    return probes;
}

// A probe's view is bound whole (its hit distances, its strata's sky rays: a value per ray), so
// it must fit one storage buffer of the device.
void requireViewFitsABinding(const Context& context, int faceSize, int raysPerTexel) {
    const uint64_t s = uint64_t(squareSide(raysPerTexel)), n = uint64_t(faceSize);
    const uint64_t bytes = sizeof(float) * kFaceCount * n * n * s * s;
    const uint64_t limit = context.info.limits.maxStorageBufferRange;
    if (bytes <= limit) return;
    throw Error(ErrorKind::Input, "scene: faces " + std::to_string(n) + " and " + std::to_string(s * s) +
                                      " rays a texel make a probe's view of " + std::to_string(bytes >> 20) +
                                      " MiB of hit distances, more than " + context.info.name +
                                      " binds as one storage buffer (" + std::to_string(limit >> 20) +
                                      " MiB); ask fewer --rays-per-texel or a smaller --face-size, or "
                                      "bake with --backend cpu");
}

} // namespace

RayCapture createRayCapture(const Context& context, const SceneCapture& capture, const SceneShading& shading,
                            const RayCaptureOptions& options) {
    requireOptions(options);
    requireViewRays(capture.options.faceSize, options.raysPerTexel);
    requireViewFitsABinding(context, capture.options.faceSize, options.raysPerTexel);
    RayCapture rays;
    OnFailure undo([&] { destroyRayCapture(context, rays); });
    rays.options = options;
    const World& world = shading.world();
    rays.bvh = buildBvh(world);
    rays.surfaceOffsetScale = float(kSurfaceOffsetScale);
    rays.gatherSide = uint32_t(squareSide(options.gatherRays));
    rays.texelSide = uint32_t(squareSide(options.raysPerTexel));
    rays.visibilityRange = visibilityRangeOf(world);
    rays.boundsMin = world.boundsMin;
    const bool cached = options.bounceLight == BounceLight::Cache;
    const CacheLayout cache =
        cached ? layOutCache(shading, cacheSpacingFor(world, options.cacheSpacing)) : CacheLayout{};
    rays.cachePoints = uint32_t(cache.points.size());
    const NextEventTable nextEvents =
        nextEventTable(shading, BvhRayCaster(rays.bvh), !cached && options.bounces > 0);
    rays.emitters = nextEvents.emitters;
    rays.skyTexels = nextEvents.skyTexels;
    rays.sunlitCells = nextEvents.sunlitCells;
    rays.sunlitSuns = nextEvents.sunlitSuns;
    rays.buffers.resize(kRayBufferCount);
    rays.buffers[kNodes] = createStorage(context, rays.bvh.nodes, "BVH nodes");
    rays.buffers[kTriangles] = createStorage(context, rays.bvh.triangles, "BVH triangles");
    rays.buffers[kIds] = createStorage(context, rays.bvh.triangleIds, "BVH triangle ids");
    rays.buffers[kLattices] = createStorage(context, cache.lattices, "cache lattices");
    rays.buffers[kGatherPoints] = createStorage(context, cache.points, "cache points");
    const std::vector<glm::vec4> zeros(options.bounces > 0 ? cache.points.size() : 0, glm::vec4(0.0f));
    rays.buffers[kCacheA] = createStorage(context, zeros, "surface cache");
    rays.buffers[kCacheB] = createStorage(context, zeros, "surface cache");
    rays.buffers[kPicks] = createStorage(context, nextEvents.picks, "next-event picks");
    rays.buffers[kPickDensities] = createStorage(context, nextEvents.densities, "next-event densities");
    const std::vector<uint32_t> stratumSky =
        stratumSkyRays(shading.sky(), capture.options.faceSize, int(rays.texelSide));
    std::vector<uint32_t> castingTexels;
    rays.skyPasses =
        planSkyPasses(stratumSky, uint32_t(capture.options.faceSize), rays.texelSide, castingTexels);
    rays.buffers[kStratumSky] = createStorage(context, stratumSky, "strata's sky rays");
    rays.buffers[kSunlitCells] = createStorage(context, nextEvents.sunCells, "sunlit cells");
    rays.buffers[kSunlitPlanes] = createStorage(context, nextEvents.sunPlanes, "sun planes");
    rays.buffers[kCastingTexels] = createStorage(context, castingTexels, "texels casting to the sky");
    const uint32_t variant = (cached || options.bounces == 0 ? 0u : SHPROBE_RAYS_BY_PATHS) |
                             (rays.skyPasses.empty() ? 0u : SHPROBE_RAYS_STRATUM_SKY_RAYS);
    rays.probes = createRayProgram(context, true, variant);
    if (!cached || options.bounces == 0) return rays;
    rays.gather = createRayProgram(context, false);
    rays.pool = createDescriptorPool(context, {.sets = 2, .storageBuffers = 2 * SHPROBE_RAYS_BINDINGS});
    for (int parity = 0; parity < 2; ++parity) {
        const size_t written = parity == 0 ? kCacheA : kCacheB;
        rays.gatherSets[size_t(parity)] = createDescriptorSet(context, rays.pool, rays.gather,
                                                              rayTargets(capture, rays, parity == 0 ? 2 : 1,
                                                                         {rays.buffers[kGatherPoints].buffer},
                                                                         {rays.buffers[written].buffer}));
    }
    for (int bounce = 1; bounce <= options.bounces; ++bounce)
        gatherBounce(context, capture, rays, bounce);
    return rays;
}

void destroyRayCapture(const Device& device, RayCapture& rays) {
    if (rays.pool) vkDestroyDescriptorPool(device.device, rays.pool, nullptr);
    destroyComputeProgram(device, rays.gather);
    destroyComputeProgram(device, rays.probes);
    for (Buffer& buffer : rays.buffers)
        destroyBuffer(device, buffer);
    rays = RayCapture{};
}

std::vector<SceneProbe> bakeRayProbes(const Context& context, const SceneCapture& capture,
                                      const RayCapture& rays, std::span<const glm::dvec3> positions,
                                      const SceneBakeOptions& options) {
    std::vector<NearestHits> nearest;
    std::vector<SceneProbe> probes = bakeViews(context, capture, rays, positions, options, nearest);
    const ProbeRelocation& rule = rays.options.relocation;
    auto inside = [&](const SceneProbe& probe) {
        return insideGeometry(probe.backFaceTexels, capture.options.faceSize, rule.invalidBackFaces);
    };
    // The probes inside that may move, and the view from through their back face, all in one bake.
    std::vector<size_t> moving;
    std::vector<glm::dvec3> through, at;
    for (size_t p = 0; p < probes.size(); ++p)
        if (inside(probes[p]))
            if (const std::optional<glm::dvec3> offset = throughBackFace(rule, nearest[p])) {
                moving.push_back(p);
                through.push_back(*offset);
                at.push_back(positions[p] + *offset);
            }
    if (moving.empty()) return probes;
    std::vector<NearestHits> there;
    bakeViews(context, capture, rays, at, options, there);
    // Then, off the front face seen from there, the probes where they are captured.
    std::vector<glm::vec3> moved(moving.size());
    for (size_t k = 0; k < moving.size(); ++k) {
        moved[k] = offFrontFace(rule, through[k], there[k]);
        at[k] = positions[moving[k]] + glm::dvec3(moved[k]);
    }
    std::vector<SceneProbe> captured = bakeViews(context, capture, rays, at, options, there);
    for (size_t k = 0; k < moving.size(); ++k) {
        if (inside(captured[k])) continue;
        probes[moving[k]] = std::move(captured[k]);
        probes[moving[k]].offset = moved[k];
    }
    return probes;
}

Cubemap traceRayCubemap(const Context& context, const SceneCapture& capture, const RayCapture& rays,
                        const glm::dvec3& position) {
    CaptureTarget target = createCaptureTarget(context, capture, 1);
    ScopeExit releaseTarget([&] { destroyCaptureTarget(context, target); });
    ProbeRaySet set = createProbeRaySet(context, capture, rays, target);
    ScopeExit releaseSet([&] { destroyProbeRaySet(context, set); });
    return readCapturedCubemap(context, target, position,
                               [&](VkCommandBuffer commands, std::span<const glm::dvec3> members) {
                                   recordProbeRays(commands, capture, rays, set, members);
                               });
}

} // namespace shprobe
