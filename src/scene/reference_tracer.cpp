// The ray-traced reference for probes in a scene (reference_tracer.h). Embree finds the first hit in
// single precision; everything after it is double: the hit point and normals from the triangle's own
// vertices and Embree's barycentrics, the materials, the suns' shadow rays and the SH sums.
//
// Path tracing. A path from the probe adds, at each front-face hit, throughput times the surface's
// emission and its sun light, albedo / pi sum_suns E_sun max(0, n.l) V(x, l) (next-event estimation:
// suns are delta lights, so no sampled ray can reach them and nothing is counted twice; emissive
// surfaces are never sampled as lights, so their emission is counted at every hit). While bounces are
// left it continues in a cosine-distributed direction about the shading normal, where the Lambertian
// BRDF albedo / pi times cos over the density cos / pi leaves throughput *= albedo. A path that
// escapes adds the sky; one that meets the back of a one-sided material ends with nothing. The
// expectation is the transport of scene.h with exactly `bounces` levels of E_bounce.
//
// Directions from the probe. Each replica is the spherical Fibonacci set of m directions (Marques et
// al., "Spherical Fibonacci Point Sets for Illumination Integrals", 2013) under its own uniformly
// random rotation: every direction is then uniform on the sphere, so each replica is an unbiased
// estimate, while the set keeps its even spread, whose error falls faster than m^(-1/2) for smooth
// radiance. The replicas are independent, so their spread gives an honest standard error.
#include "scene/reference_tracer.h"

#include "common/error.h"
#include "common/parallel.h"
#include "scene/embree_rays.h"
#include "scene/sampling.h"
#include "sh/basis.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <numbers>
#include <numeric>
#include <string>
#include <utility>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;

} // namespace

struct ReferenceTracer::State {
    explicit State(const World& world, const Cubemap& sky)
        : shading(world, sky), rays(makeEmbreeRayCaster(world, shading.solidTriangles())) {}

    SceneShading shading;
    std::unique_ptr<RayCaster> rays;
};

ReferenceTracer::ReferenceTracer(const World& world, const Cubemap& sky)
    : state_(std::make_unique<State>(world, sky)) {}

ReferenceTracer::~ReferenceTracer() = default;
ReferenceTracer::ReferenceTracer(ReferenceTracer&&) noexcept = default;
ReferenceTracer& ReferenceTracer::operator=(ReferenceTracer&&) noexcept = default;

std::optional<SurfaceHit> ReferenceTracer::intersect(const glm::dvec3& origin,
                                                     const glm::dvec3& direction) const {
    const std::optional<RayHit> hit = state_->rays->closestHit({glm::vec3(origin), glm::vec3(direction)});
    if (!hit) return std::nullopt;
    return state_->shading.describe(hit->triangle, glm::dvec2(hit->hit.u, hit->hit.v), direction);
}

bool ReferenceTracer::occluded(const glm::dvec3& origin, const glm::dvec3& direction) const {
    return state_->rays->anyHit({glm::vec3(origin), glm::vec3(direction)});
}

glm::dvec3 ReferenceTracer::skyRadiance(const glm::dvec3& direction) const {
    return state_->shading.skyRadiance(direction);
}

std::span<const SceneSun> ReferenceTracer::suns() const {
    return state_->shading.suns();
}

namespace {

// What a front face leaves towards the ray with no bounced light (surface_shading.h), the suns'
// shadow rays cast by Embree.
glm::dvec3 directlyLeaving(const ReferenceTracer& tracer, const SurfaceHit& hit, uint64_t& rays) {
    return leavingWithoutBounce(tracer.suns(), hit, rays,
                                [&](const glm::dvec3& origin, const glm::dvec3& direction) {
                                    return tracer.occluded(origin, direction);
                                });
}

// The stream of a replica's rotation of the Fibonacci set: an index no path's stream has.
constexpr uint64_t kRotationStream = ~uint64_t(0);
// The streams of pathTraceSurfaces' paths: one per point, apart from every probe replica's.
constexpr uint64_t kSurfaceStream = ~uint64_t(0) - 1;

// Radiance arriving at `origin` from `direction` along a path of at most `bounces` bounces, the
// sky(direction) where it escapes.
template <typename Sky>
glm::dvec3 pathRadiance(const ReferenceTracer& tracer, int bounces, glm::dvec3 origin, glm::dvec3 direction,
                        RandomStream& random, uint64_t& rays, const Sky& sky) {
    glm::dvec3 sum(0.0);
    glm::dvec3 throughput(1.0);
    for (int depth = 0;; ++depth) {
        ++rays;
        const std::optional<SurfaceHit> hit = tracer.intersect(origin, direction);
        if (!hit) return sum + throughput * sky(direction);
        if (hit->backFace) return sum;
        sum += throughput * directlyLeaving(tracer, *hit, rays);
        throughput *= hit->albedo;
        if (depth == bounces || throughput == glm::dvec3(0.0)) return sum; // nothing more can arrive
        const double u1 = random.next();
        const double u2 = random.next();
        origin = hit->rayOrigin;
        direction = cosineDirection(hit->shadingNormal, u1, u2);
    }
}

// One replica's estimate L_lm = (4 pi / m) sum_k L(w_k) y_lm(w_k), and the rays it cast.
struct ReplicaEstimate {
    std::vector<glm::dvec3> coefficients;
    uint64_t rays = 0;
};

ReplicaEstimate traceReplica(const ReferenceTracer& tracer, const glm::dvec3& position,
                             const PathTraceOptions& options, int m, int replica) {
    ReplicaEstimate estimate{std::vector<glm::dvec3>(size_t(coefficientCount(options.order))), 0};
    RandomStream rotationStream(options.seed, uint64_t(replica), kRotationStream);
    const glm::dmat3 rotation = randomRotation(rotationStream);
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    for (int k = 0; k < m; ++k) {
        const glm::dvec3 direction = rotation * fibonacciDirection(k, m);
        RandomStream random(options.seed, uint64_t(replica), uint64_t(k));
        const glm::dvec3 weighted =
            pathRadiance(tracer, options.bounces, position, direction, random, estimate.rays,
                         [&](const glm::dvec3& d) { return tracer.skyRadiance(d); }) *
            (4.0 * kPi / m);
        evalBasis(options.order, direction, basis);
        for (size_t i = 0; i < estimate.coefficients.size(); ++i)
            estimate.coefficients[i] += weighted * basis[i];
    }
    return estimate;
}

// The seen suns' deltas, E y_lm(l) where nothing blocks them: the same in every replica, so they
// add no variance.
void addSeenSuns(const ReferenceTracer& tracer, const glm::dvec3& position, const PathTraceOptions& options,
                 PathTracedProbe& probe) {
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    for (const SceneSun& sun : options.seenSuns) {
        const glm::dvec3 direction = glm::normalize(glm::dvec3(sun.direction));
        ++probe.rays;
        if (tracer.occluded(position, direction)) continue;
        evalBasis(options.order, direction, basis);
        for (size_t i = 0; i < probe.radiance.rgb.size(); ++i)
            probe.radiance.rgb[i] += glm::dvec3(sun.irradiance) * basis[i];
    }
}

// The replicas' mean, and its standard error sqrt(sum (X_r - mean)^2 / (R (R - 1))).
// One surface point's estimate: albedo times the mean of the paths' radiance, and its standard error.
SurfaceRadiance traceSurface(const ReferenceTracer& tracer, const SurfacePoint& point,
                             const ShCoefficients& sky, const SurfacePathOptions& options, uint64_t index) {
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    const auto skyRadiance = [&](const glm::dvec3& direction) {
        evalBasis(sky.order, direction, basis);
        glm::dvec3 radiance(0.0);
        for (size_t i = 0; i < sky.rgb.size(); ++i)
            radiance += sky.rgb[i] * basis[i];
        return radiance;
    };
    RandomStream random(options.seed, kSurfaceStream, index);
    SurfaceRadiance estimate;
    glm::dvec3 sum(0.0), squares(0.0);
    for (int k = 0; k < options.samples; ++k) {
        const double u1 = random.next();
        const double u2 = random.next();
        const glm::dvec3 radiance =
            pathRadiance(tracer, options.bounces, point.origin, cosineDirection(point.normal, u1, u2), random,
                         estimate.rays, skyRadiance);
        sum += radiance;
        squares += radiance * radiance;
    }
    const double n = double(options.samples);
    const glm::dvec3 mean = sum / n;
    const glm::dvec3 variance =
        glm::max(squares / n - mean * mean, glm::dvec3(0.0)) * (n / std::max(n - 1.0, 1.0));
    estimate.radiance = point.albedo * mean;
    estimate.standardError = point.albedo * glm::sqrt(variance / n);
    return estimate;
}

PathTracedProbe combineReplicas(std::span<const ReplicaEstimate> replicas, int order) {
    PathTracedProbe probe{makeCoefficients(order, Quantity::Radiance),
                          std::vector<glm::dvec3>(size_t(coefficientCount(order))), 0};
    const double count = double(replicas.size());
    for (const ReplicaEstimate& replica : replicas) {
        for (size_t i = 0; i < probe.radiance.rgb.size(); ++i)
            probe.radiance.rgb[i] += replica.coefficients[i] / count;
        probe.rays += replica.rays;
    }
    for (const ReplicaEstimate& replica : replicas) {
        for (size_t i = 0; i < probe.radiance.rgb.size(); ++i) {
            const glm::dvec3 deviation = replica.coefficients[i] - probe.radiance.rgb[i];
            probe.standardError[i] += deviation * deviation;
        }
    }
    for (glm::dvec3& error : probe.standardError)
        error = glm::sqrt(error / (count * (count - 1.0)));
    return probe;
}

void requirePathTraceOptions(const PathTraceOptions& options, size_t probes) {
    requireOrder(options.order);
    if (options.bounces < 0)
        throw Error(ErrorKind::Input, "bounces must be 0 or more, got " + std::to_string(options.bounces));
    if (options.samples < 1)
        throw Error(ErrorKind::Input, "samples must be 1 or more, got " + std::to_string(options.samples));
    if (probes > size_t(INT_MAX / kPathTraceReplicas)) {
        throw Error(ErrorKind::Input, std::to_string(probes) + " probes are more than one call traces");
    }
}

} // namespace

RayRadiance directRadiance(const ReferenceTracer& tracer, const glm::dvec3& origin,
                           const glm::dvec3& direction) {
    const std::optional<SurfaceHit> hit = tracer.intersect(origin, direction);
    if (!hit) return {tracer.skyRadiance(direction), false};
    if (hit->backFace) return {glm::dvec3(0.0), true};
    uint64_t rays = 0;
    return {directlyLeaving(tracer, *hit, rays), false};
}

ProbeTexels traceProbeTexels(const ReferenceTracer& tracer, const glm::dvec3& position, int faceSize) {
    ProbeTexels texels{makeCubemap(faceSize), 0};
    const int rows = kFaceCount * faceSize;
    std::vector<size_t> backFaces(static_cast<size_t>(rows), 0); // per row, so that rows write apart
    forEachItem(rows, threadCount(size_t(rows) * faceSize, kRaysPerThread), [&](int row) {
        const int face = row / faceSize;
        const int j = row % faceSize;
        for (int i = 0; i < faceSize; ++i) {
            const RayRadiance ray = directRadiance(tracer, position, texelDirection(face, i, j, faceSize));
            texels.radiance.at(face, i, j) = glm::vec4(glm::vec3(ray.radiance), 0.0f);
            backFaces[size_t(row)] += ray.backFace ? 1 : 0;
        }
    });
    texels.backFaceTexels = std::accumulate(backFaces.begin(), backFaces.end(), size_t(0));
    return texels;
}

PathTracedProbe pathTraceProbe(const ReferenceTracer& tracer, const glm::dvec3& position,
                               const PathTraceOptions& options) {
    return std::move(pathTraceProbes(tracer, std::span(&position, 1), options).front());
}

// Work items are (probe, replica) pairs, each writing its own estimate; the replicas of a probe are
// then combined in replica order, whatever thread traced them.
std::vector<PathTracedProbe> pathTraceProbes(const ReferenceTracer& tracer,
                                             std::span<const glm::dvec3> positions,
                                             const PathTraceOptions& options) {
    requirePathTraceOptions(options, positions.size());
    const int m = (options.samples - 1) / kPathTraceReplicas + 1;
    const int items = int(positions.size()) * kPathTraceReplicas;
    const size_t rays = size_t(items) * size_t(m) * size_t(options.bounces + 1);
    const unsigned threads = options.threads > 0 ? options.threads : threadCount(rays, kRaysPerThread);
    std::vector<ReplicaEstimate> replicas(static_cast<size_t>(items));
    forEachItem(items, threads, [&](int item) {
        replicas[size_t(item)] = traceReplica(tracer, positions[size_t(item / kPathTraceReplicas)], options,
                                              m, item % kPathTraceReplicas);
    });
    std::vector<PathTracedProbe> probes;
    probes.reserve(positions.size());
    for (size_t p = 0; p < positions.size(); ++p) {
        probes.push_back(combineReplicas(
            std::span(replicas).subspan(p * kPathTraceReplicas, kPathTraceReplicas), options.order));
        addSeenSuns(tracer, positions[p], options, probes.back());
    }
    return probes;
}

std::vector<SurfaceRadiance> pathTraceSurfaces(const ReferenceTracer& tracer,
                                               std::span<const SurfacePoint> points,
                                               const ShCoefficients& sky, const SurfacePathOptions& options) {
    if (options.bounces < 0)
        throw Error(ErrorKind::Input, "bounces must be 0 or more, got " + std::to_string(options.bounces));
    if (options.samples < 1)
        throw Error(ErrorKind::Input, "samples must be 1 or more, got " + std::to_string(options.samples));
    if (points.size() > size_t(INT_MAX))
        throw Error(ErrorKind::Input, "too many surface points for one call");
    std::vector<SurfaceRadiance> estimates(points.size());
    const size_t rays = points.size() * size_t(options.samples) * size_t(options.bounces + 1);
    forEachItem(int(points.size()), threadCount(rays, kRaysPerThread), [&](int p) {
        estimates[size_t(p)] = traceSurface(tracer, points[size_t(p)], sky, options, uint64_t(p));
    });
    return estimates;
}

} // namespace shprobe
