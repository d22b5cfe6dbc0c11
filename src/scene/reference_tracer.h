// The independent CPU reference for probes in a scene: Embree 3 casts the rays (single precision,
// robust mode), double precision carries the shading and every sum. It follows the light transport of
// scene.h exactly, so that the GPU capture (gpu/scene_capture.h) can be checked against it texel by
// texel (traceProbeTexels) and its SH probes against a converged path-traced estimate
// (pathTraceProbe). docs/scene-probes.md, "The ray-traced reference", says how it is built.
#pragma once
#include "scene/scene.h"
#include "scene/surface_shading.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace shprobe {

// Embree's device and scene, built once from a World, with its SceneShading (surface_shading.h). Move-only.
// Rays may be cast from many threads at once.
class ReferenceTracer {
  public:
    // The sky is what rays that hit nothing see (skyRadiance). Throws Error(Input) for a World whose
    // arrays disagree (scene.h), for non-finite vertices or a sun without a direction, or for a sky
    // whose texel count is not that of a cube map; Error(Device) where Embree cannot run.
    ReferenceTracer(const World& world, const Cubemap& sky);
    ~ReferenceTracer();
    ReferenceTracer(ReferenceTracer&&) noexcept;
    ReferenceTracer& operator=(ReferenceTracer&&) noexcept;

    // The first surface along origin + t direction, t >= 0 (direction unit), if any.
    std::optional<SurfaceHit> intersect(const glm::dvec3& origin, const glm::dvec3& direction) const;
    // Whether any surface, front or back, lies along origin + t direction, t >= 0.
    bool occluded(const glm::dvec3& origin, const glm::dvec3& direction) const;
    // The sky's texel the direction falls in: nearest texel, no filtering, as the GPU capture's
    // background reads it with a NEAREST sampler.
    glm::dvec3 skyRadiance(const glm::dvec3& direction) const;
    // The World's suns, their directions normalized.
    std::span<const SceneSun> suns() const;

  private:
    struct State;
    std::unique_ptr<State> state_;
};

// What one ray sees with no bounce (E_bounce = 0 in scene.h): the sky where it hits nothing, else the
// surface's emission plus albedo / pi times the suns' irradiance, each sun tested by a shadow ray;
// nothing from the back of a one-sided material.
struct RayRadiance {
    glm::dvec3 radiance{0.0};
    bool backFace = false;
};
RayRadiance directRadiance(const ReferenceTracer& tracer, const glm::dvec3& origin,
                           const glm::dvec3& direction);

// What a probe at `position` sees through the texel centres of a cube map of faceSize: one
// directRadiance ray per texel (texelDirection), so that a GPU capture can be compared texel by
// texel; and how many texels see the back of a one-sided material (where a probe lies inside
// something). Alpha is 0. Throws Error(Input) for faceSize < 1.
struct ProbeTexels {
    Cubemap radiance;
    size_t backFaceTexels = 0;
};
ProbeTexels traceProbeTexels(const ReferenceTracer& tracer, const glm::dvec3& position, int faceSize);

// The estimate is the mean of this many independent estimates (replicas), whose spread gives the
// standard error.
constexpr int kPathTraceReplicas = 16;

struct PathTraceOptions {
    int order = 3;      // SH order of the radiance coefficients, 1..kMaxOrder
    int bounces = 1;    // diffuse bounces after the first hit; 0: directRadiance's transport
    int samples = 4096; // directions per probe, rounded up to a multiple of kPathTraceReplicas
    uint64_t seed = 1;
    unsigned threads = 0; // 0: all cores (fewer for small jobs, where starting threads costs more)
    // Suns taken out of the sky, which the probe sees directly: each adds E y_lm(l) where nothing
    // blocks it. (The tracer's World holds them too, so that they light the surfaces.)
    std::vector<SceneSun> seenSuns;
};

// A path-traced probe: the radiance coefficients and, per coefficient, the standard error of each
// channel's estimate; rays is the number of rays cast (path segments and shadow rays).
struct PathTracedProbe {
    ShCoefficients radiance;
    std::vector<glm::dvec3> standardError;
    uint64_t rays = 0;
};

// The SH radiance coefficients L_lm of the light reaching `position` with at most options.bounces
// diffuse bounces: the exact solution of scene.h's transport truncated there, by Monte-Carlo
// integration over the sphere with next-event estimation of the suns, in double precision.
// Deterministic for a seed: the same bits for any thread count, and every probe uses the same random
// numbers, so a probe's estimate does not depend on which others are traced with it. Throws
// Error(Input) for an order out of range, negative bounces or samples below 1.
PathTracedProbe pathTraceProbe(const ReferenceTracer& tracer, const glm::dvec3& position,
                               const PathTraceOptions& options);
// pathTraceProbe for every position, on all cores; entry k equals pathTraceProbe(positions[k]) bit
// for bit.
std::vector<PathTracedProbe> pathTraceProbes(const ReferenceTracer& tracer,
                                             std::span<const glm::dvec3> positions,
                                             const PathTraceOptions& options);

// A point of a Lambertian surface for pathTraceSurfaces: its paths leave from `origin` (already moved
// off the surface) in cosine-distributed directions about the unit `normal`.
struct SurfacePoint {
    glm::dvec3 origin{0.0};
    glm::dvec3 normal{0.0};
    glm::dvec3 albedo{0.0};
};

struct SurfacePathOptions {
    int bounces = 1;    // diffuse bounces between the sky and the point; 0: the sky it sees directly
    int samples = 4096; // independent paths per point
    uint64_t seed = 1;
};

// A path-traced outgoing radiance, the standard error of each channel, and the rays cast.
struct SurfaceRadiance {
    glm::dvec3 radiance{0.0};
    glm::dvec3 standardError{0.0};
    uint64_t rays = 0;
};

// The radiance each point leaves, albedo / pi times the cosine-weighted integral of the radiance
// arriving with at most options.bounces bounces, under a distant sky given by its SH radiance
// coefficients: band-limited, evaluated exactly where a path escapes, in place of the tracer's cube
// map (emission and suns count as in pathTraceProbe). This is the path-traced counterpart of
// interreflected transfer (scene/transfer.h), L_out = sum_i T_i L_i, for checking it. Each estimate
// is albedo times the mean of `samples` independent paths' radiance (the cosine density cancels
// the Lambertian BRDF), its standard error sqrt(sample variance / samples). On all cores; the same
// bits for any thread count. Throws Error(Input) for bounces below 0 or samples below 1.
std::vector<SurfaceRadiance> pathTraceSurfaces(const ReferenceTracer& tracer,
                                               std::span<const SurfacePoint> points,
                                               const ShCoefficients& sky, const SurfacePathOptions& options);

} // namespace shprobe
