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
#include "sh/basis.h"

#include <embree3/rtcore.h>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <limits>
#include <mutex>
#include <numbers>
#include <numeric>
#include <string>
#include <utility>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;

// Rays leaving a surface start this far off it along its geometric normal, in units of the scene's
// largest coordinate: 256 float ulps of it, well above the few ulps by which Embree's single-precision
// hit distances err there, so a leaving ray never meets its own triangle again; 3e-5 of the scene.
constexpr double kOffsetScale = 256.0 * std::numeric_limits<float>::epsilon();

// A thread should cast at least this many rays (a few milliseconds), so that starting it (tens of
// microseconds) stays a small part of its run.
constexpr size_t kRaysPerThread = 4096;

// --- World checks ------------------------------------------------------------------------------

Error sceneError(const std::string& message) {
    return Error(ErrorKind::Input, "scene: " + message);
}

template <glm::length_t L> bool isFinite(const glm::vec<L, float>& v) {
    for (glm::length_t i = 0; i < L; ++i) {
        if (!std::isfinite(v[i])) return false;
    }
    return true;
}

void requireVertices(const World& world) {
    const size_t count = world.positions.size();
    if (world.normals.size() != count || world.uvs.size() != count) {
        throw sceneError(std::to_string(count) + " positions but " + std::to_string(world.normals.size()) +
                         " normals and " + std::to_string(world.uvs.size()) + " texture coordinates");
    }
    for (size_t i = 0; i < count; ++i) {
        if (!isFinite(world.positions[i]) || !isFinite(world.normals[i]) || !isFinite(world.uvs[i]))
            throw sceneError("vertex " + std::to_string(i) + " is not finite");
    }
}

void requireTriangles(const World& world) {
    if (world.indices.size() % 3 != 0 || world.triangleMaterials.size() != world.triangleCount()) {
        throw sceneError(std::to_string(world.indices.size()) + " indices for " +
                         std::to_string(world.triangleMaterials.size()) + " triangle materials");
    }
    for (size_t i = 0; i < world.indices.size(); ++i) {
        if (world.indices[i] >= world.positions.size()) {
            throw sceneError("index " + std::to_string(i) + " is " + std::to_string(world.indices[i]) +
                             ", past the " + std::to_string(world.positions.size()) + " vertices");
        }
    }
    for (size_t t = 0; t < world.triangleMaterials.size(); ++t) {
        if (world.triangleMaterials[t] >= world.materials.size()) {
            throw sceneError("triangle " + std::to_string(t) + " has material " +
                             std::to_string(world.triangleMaterials[t]) + " of " +
                             std::to_string(world.materials.size()));
        }
    }
}

void requireMaterials(const World& world) {
    const int textures = int(world.textures.size());
    for (size_t m = 0; m < world.materials.size(); ++m) {
        for (int texture : {world.materials[m].albedoTexture, world.materials[m].emissionTexture}) {
            if (texture < -1 || texture >= textures) {
                throw sceneError("material " + std::to_string(m) + " names texture " +
                                 std::to_string(texture) + " of " + std::to_string(textures));
            }
        }
    }
    for (size_t t = 0; t < world.textures.size(); ++t) {
        const SceneTexture& texture = world.textures[t];
        if (texture.width < 1 || texture.height < 1 ||
            texture.texels.size() != size_t(texture.width) * size_t(texture.height)) {
            throw sceneError("texture " + std::to_string(t) + " is " + std::to_string(texture.width) + " x " +
                             std::to_string(texture.height) + " with " +
                             std::to_string(texture.texels.size()) + " texels");
        }
    }
}

// The suns with unit directions; a sun must have a direction and finite irradiance.
std::vector<SceneSun> normalizedSuns(std::vector<SceneSun> suns) {
    for (size_t s = 0; s < suns.size(); ++s) {
        const float length = glm::length(suns[s].direction);
        if (!std::isfinite(length) || length == 0.0f || !isFinite(suns[s].irradiance))
            throw sceneError("sun " + std::to_string(s) + " has no direction or a non-finite irradiance");
        suns[s].direction /= length;
    }
    return suns;
}

void requireSky(const Cubemap& sky) {
    if (sky.faceSize < 1 || sky.texels.size() != size_t(kFaceCount) * sky.faceSize * sky.faceSize) {
        throw sceneError("the sky cube map of face size " + std::to_string(sky.faceSize) + " holds " +
                         std::to_string(sky.texels.size()) + " texels");
    }
}

// --- What shading reads ------------------------------------------------------------------------

struct Shading {
    World world;                     // suns normalized
    std::vector<uint32_t> triangles; // Embree's primitive k is the World's triangle triangles[k]
    Cubemap sky;
    double offset = 0.0; // kOffsetScale times the largest coordinate
};

// Zero-area triangles cover no solid angle and have no normal: they are left out of Embree's scene.
std::vector<uint32_t> triangleList(const World& world) {
    std::vector<uint32_t> triangles;
    for (uint32_t t = 0; t < uint32_t(world.triangleCount()); ++t) {
        const glm::dvec3 p0(world.positions[world.indices[3 * t]]);
        const glm::dvec3 p1(world.positions[world.indices[3 * t + 1]]);
        const glm::dvec3 p2(world.positions[world.indices[3 * t + 2]]);
        if (glm::cross(p1 - p0, p2 - p0) != glm::dvec3(0.0)) triangles.push_back(t);
    }
    return triangles;
}

double largestCoordinate(const World& world) {
    double largest = 0.0;
    for (const glm::vec3& p : world.positions)
        largest = std::max({largest, double(std::abs(p.x)), double(std::abs(p.y)), double(std::abs(p.z))});
    return largest;
}

Shading makeShading(const World& world, const Cubemap& sky) {
    requireVertices(world);
    requireTriangles(world);
    requireMaterials(world);
    requireSky(sky);
    Shading shading{world, triangleList(world), sky, kOffsetScale * largestCoordinate(world)};
    shading.world.suns = normalizedSuns(world.suns);
    return shading;
}

// (1 - u - v) a0 + u a1 + v a2 in double: Embree's barycentrics weigh the vertices so (Embree's
// triangle parametrization).
template <typename Vector>
auto interpolate(const std::vector<Vector>& attribute, const uint32_t* vertex, const glm::dvec3& weights) {
    using Double = glm::vec<Vector::length(), double>;
    return weights.x * Double(attribute[vertex[0]]) + weights.y * Double(attribute[vertex[1]]) +
           weights.z * Double(attribute[vertex[2]]);
}

// The unit normal of the counter-clockwise winding (scene.h: triangles face the side they turn
// counter-clockwise on).
glm::dvec3 geometricNormal(const World& world, const uint32_t* vertex) {
    const glm::dvec3 p0(world.positions[vertex[0]]);
    const glm::dvec3 p1(world.positions[vertex[1]]);
    const glm::dvec3 p2(world.positions[vertex[2]]);
    return glm::normalize(glm::cross(p1 - p0, p2 - p0));
}

// The interpolated vertex normal, unit; where the vertex normals cancel, the geometric one.
glm::dvec3 shadingNormal(const glm::dvec3& interpolated, const glm::dvec3& geometric) {
    const double length = glm::length(interpolated);
    return length > 0.0 ? interpolated / length : geometric;
}

// x mod n in [0, n), for finite x.
double wrap(double x, int n) {
    const double r = std::fmod(x, double(n));
    return r < 0.0 ? r + n : r;
}

// glTF's default sampler: bilinear, repeat; texel (i, j) centred at ((i + 0.5) / w, (j + 0.5) / h),
// rows top to bottom from v = 0 at the top (glTF 2.0, "Images"). Alpha is not read: surfaces are opaque.
glm::dvec3 sampleBilinear(const SceneTexture& texture, const glm::dvec2& uv) {
    const double x = wrap(uv.x * texture.width - 0.5, texture.width);
    const double y = wrap(uv.y * texture.height - 0.5, texture.height);
    // wrap's r + n rounds to n for a tiny negative r: then i0 = n - 1 with fx = 1, all weight on texel 0.
    const int i0 = std::min(int(x), texture.width - 1);
    const int j0 = std::min(int(y), texture.height - 1);
    const int i1 = (i0 + 1) % texture.width;
    const int j1 = (j0 + 1) % texture.height;
    const double fx = x - i0;
    const double fy = y - j0;
    const auto texel = [&](int i, int j) {
        return glm::dvec3(glm::vec3(texture.texels[size_t(j) * texture.width + i]));
    };
    const glm::dvec3 top = (1.0 - fx) * texel(i0, j0) + fx * texel(i1, j0);
    const glm::dvec3 bottom = (1.0 - fx) * texel(i0, j1) + fx * texel(i1, j1);
    return (1.0 - fy) * top + fy * bottom;
}

glm::dvec3 materialColor(const World& world, const glm::vec3& factor, int texture, const glm::dvec2& uv) {
    if (texture < 0) return glm::dvec3(factor);
    return glm::dvec3(factor) * sampleBilinear(world.textures[size_t(texture)], uv);
}

SurfaceHit describeHit(const Shading& shading, uint32_t triangle, const glm::dvec2& barycentric,
                       const glm::dvec3& direction) {
    const World& world = shading.world;
    const uint32_t* vertex = &world.indices[3 * size_t(triangle)];
    const glm::dvec3 weights(1.0 - barycentric.x - barycentric.y, barycentric.x, barycentric.y);
    const SceneMaterial& material = world.materials[world.triangleMaterials[triangle]];
    const glm::dvec3 normal = geometricNormal(world, vertex);
    const bool front = glm::dot(normal, direction) < 0.0;
    const double side = front ? 1.0 : -1.0;
    SurfaceHit hit;
    hit.position = interpolate(world.positions, vertex, weights);
    hit.normal = side * normal;
    hit.shadingNormal = side * shadingNormal(interpolate(world.normals, vertex, weights), normal);
    hit.rayOrigin = hit.position + shading.offset * hit.normal;
    const glm::dvec2 uv = interpolate(world.uvs, vertex, weights);
    hit.albedo = materialColor(world, material.albedo, material.albedoTexture, uv);
    hit.emission = materialColor(world, material.emission, material.emissionTexture, uv);
    hit.backFace = !front && !material.doubleSided;
    return hit;
}

// --- Embree ------------------------------------------------------------------------------------

const char* embreeErrorName(RTCError code) {
    switch (code) {
    case RTC_ERROR_NONE:
        return "no error";
    case RTC_ERROR_UNKNOWN:
        return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT:
        return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
        return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
        return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
        return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
        return "cancelled";
    }
    return "unknown error";
}

// The first error Embree reports through its callback, which may run on its build threads and must
// not throw through Embree: it is kept here and thrown after the call that caused it.
struct EmbreeErrors {
    std::mutex mutex;
    RTCError code = RTC_ERROR_NONE;
    std::string message;
};

void recordEmbreeError(void* userPtr, RTCError code, const char* message) {
    auto& errors = *static_cast<EmbreeErrors*>(userPtr);
    const std::lock_guard lock(errors.mutex);
    if (errors.code != RTC_ERROR_NONE) return;
    errors.code = code;
    errors.message = std::string(embreeErrorName(code)) + (message ? std::string(": ") + message : "");
}

// A refused argument is the scene's fault; anything else (memory, processor) the machine's.
void throwIfFailed(EmbreeErrors& errors, const char* what) {
    const std::lock_guard lock(errors.mutex);
    if (errors.code == RTC_ERROR_NONE) return;
    const ErrorKind kind = errors.code == RTC_ERROR_INVALID_ARGUMENT ? ErrorKind::Input : ErrorKind::Device;
    throw Error(kind, std::string("Embree failed ") + what + ": " + errors.message);
}

RTCDevice newDevice(EmbreeErrors& errors) {
    RTCDevice device = rtcNewDevice(nullptr);
    if (!device) {
        throw Error(ErrorKind::Device,
                    std::string("Embree could not start: ") + embreeErrorName(rtcGetDeviceError(nullptr)));
    }
    rtcSetDeviceErrorFunction(device, recordEmbreeError, &errors);
    return device;
}

// Embree's own buffers (padded as its vector loads need), filled with the kept triangles.
void attachTriangles(RTCDevice device, RTCScene scene, const Shading& shading, EmbreeErrors& errors) {
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    throwIfFailed(errors, "creating the triangle geometry");
    const World& world = shading.world;
    auto* vertices = static_cast<glm::vec3*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(glm::vec3), world.positions.size()));
    auto* indices =
        static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                       3 * sizeof(uint32_t), shading.triangles.size()));
    if (vertices && indices) {
        std::copy(world.positions.begin(), world.positions.end(), vertices);
        for (size_t k = 0; k < shading.triangles.size(); ++k)
            std::copy_n(&world.indices[3 * size_t(shading.triangles[k])], 3, &indices[3 * k]);
        rtcCommitGeometry(geometry);
        rtcAttachGeometry(scene, geometry);
    }
    rtcReleaseGeometry(geometry); // the scene holds it now
    throwIfFailed(errors, "storing the triangles");
}

RTCRay makeRay(const glm::dvec3& origin, const glm::dvec3& direction) {
    RTCRay ray{};
    ray.org_x = float(origin.x);
    ray.org_y = float(origin.y);
    ray.org_z = float(origin.z);
    ray.dir_x = float(direction.x);
    ray.dir_y = float(direction.y);
    ray.dir_z = float(direction.z);
    ray.tnear = 0.0f;
    ray.tfar = std::numeric_limits<float>::infinity();
    ray.mask = ~0u;
    return ray;
}

// The sky texel a direction falls in: face-local (a, b) to texel i = floor((a + 1) / 2 N), as
// Vulkan's NEAREST filter picks it ("Cube Map Face Selection", then "Texel Selection").
glm::dvec3 nearestSkyTexel(const Cubemap& sky, const glm::dvec3& direction) {
    const FacePoint point = directionToFace(direction);
    const int n = sky.faceSize;
    const auto texel = [n](double coordinate) {
        return std::clamp(int(std::floor((coordinate + 1.0) * 0.5 * n)), 0, n - 1);
    };
    return glm::dvec3(glm::vec3(sky.at(point.face, texel(point.a), texel(point.b))));
}

} // namespace

struct ReferenceTracer::State {
    EmbreeErrors errors;
    Shading shading;
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;

    ~State() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

ReferenceTracer::ReferenceTracer(const World& world, const Cubemap& sky) : state_(std::make_unique<State>()) {
    State& state = *state_;
    state.shading = makeShading(world, sky);
    state.device = newDevice(state.errors);
    state.scene = rtcNewScene(state.device);
    throwIfFailed(state.errors, "creating the scene");
    // Robust mode: watertight edges, so that no ray slips between two triangles sharing an edge.
    rtcSetSceneFlags(state.scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(state.scene, RTC_BUILD_QUALITY_HIGH);
    if (!state.shading.triangles.empty())
        attachTriangles(state.device, state.scene, state.shading, state.errors);
    rtcCommitScene(state.scene);
    throwIfFailed(state.errors, "building the scene");
}

ReferenceTracer::~ReferenceTracer() = default;
ReferenceTracer::ReferenceTracer(ReferenceTracer&&) noexcept = default;
ReferenceTracer& ReferenceTracer::operator=(ReferenceTracer&&) noexcept = default;

std::optional<SurfaceHit> ReferenceTracer::intersect(const glm::dvec3& origin,
                                                     const glm::dvec3& direction) const {
    RTCRayHit query{};
    query.ray = makeRay(origin, direction);
    query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcIntersect1(state_->scene, &context, &query);
    if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    return describeHit(state_->shading, state_->shading.triangles[query.hit.primID],
                       glm::dvec2(query.hit.u, query.hit.v), direction);
}

bool ReferenceTracer::occluded(const glm::dvec3& origin, const glm::dvec3& direction) const {
    RTCRay ray = makeRay(origin, direction);
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcOccluded1(state_->scene, &context, &ray);
    return ray.tfar < 0.0f; // Embree marks an occluded ray with tfar = -inf
}

glm::dvec3 ReferenceTracer::skyRadiance(const glm::dvec3& direction) const {
    return nearestSkyTexel(state_->shading.sky, direction);
}

std::span<const SceneSun> ReferenceTracer::suns() const {
    return state_->shading.world.suns;
}

namespace {

// sum_suns E_sun max(0, n.l) V(x, l) at a hit, n its shading normal; one shadow ray per sun above
// the surface, counted in rays.
glm::dvec3 sunIrradiance(const ReferenceTracer& tracer, const SurfaceHit& hit, uint64_t& rays) {
    glm::dvec3 sum(0.0);
    for (const SceneSun& sun : tracer.suns()) {
        const glm::dvec3 toSun(sun.direction);
        const double cosine = glm::dot(hit.shadingNormal, toSun);
        if (cosine <= 0.0) continue;
        ++rays;
        if (!tracer.occluded(hit.rayOrigin, toSun)) sum += glm::dvec3(sun.irradiance) * cosine;
    }
    return sum;
}

// What a front face leaves towards the ray with no bounced light: emission + albedo / pi E_suns.
glm::dvec3 directlyLeaving(const ReferenceTracer& tracer, const SurfaceHit& hit, uint64_t& rays) {
    return hit.emission + hit.albedo / kPi * sunIrradiance(tracer, hit, rays);
}

// splitmix64's output function (Steele, Lea & Flood, "Fast Splittable Pseudorandom Number
// Generators", 2014): a bijection of 64-bit words that scrambles every input bit into every output bit.
uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

// Counter-based random numbers: a stream is named by (seed, replica, index), never by the thread
// that draws from it, so results do not depend on how work is spread over threads.
class RandomStream {
  public:
    RandomStream(uint64_t seed, uint64_t replica, uint64_t index)
        : state_(mix64(mix64(mix64(seed) + replica) + index)) {}
    // Uniform in [0, 1), 53 bits (splitmix64's Weyl sequence, scrambled).
    double next() {
        state_ += 0x9e3779b97f4a7c15ull;
        return double(mix64(state_) >> 11) * 0x1p-53;
    }

  private:
    uint64_t state_;
};

// The stream of a replica's rotation of the Fibonacci set: an index no path's stream has.
constexpr uint64_t kRotationStream = ~uint64_t(0);

// A branch-free orthonormal frame (t, b, n) about unit n (Duff et al., "Building an Orthonormal
// Basis, Revisited", 2017), then a cosine-distributed direction in it by Malley's method: a uniform
// point of the unit disc lifted onto the hemisphere (Pharr, Jakob & Humphreys, "Physically Based
// Rendering", "Cosine-Weighted Hemisphere Sampling").
glm::dvec3 cosineDirection(const glm::dvec3& n, double u1, double u2) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double b = n.x * n.y * a;
    const glm::dvec3 t(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    const glm::dvec3 bitangent(b, sign + n.y * n.y * a, -n.y);
    const double r = std::sqrt(u1);
    const double phi = 2.0 * kPi * u2;
    return r * std::cos(phi) * t + r * std::sin(phi) * bitangent + std::sqrt(std::max(0.0, 1.0 - u1)) * n;
}

// Radiance arriving at `origin` from `direction` along a path of at most `bounces` bounces.
glm::dvec3 pathRadiance(const ReferenceTracer& tracer, int bounces, glm::dvec3 origin, glm::dvec3 direction,
                        RandomStream& random, uint64_t& rays) {
    glm::dvec3 sum(0.0);
    glm::dvec3 throughput(1.0);
    for (int depth = 0;; ++depth) {
        ++rays;
        const std::optional<SurfaceHit> hit = tracer.intersect(origin, direction);
        if (!hit) return sum + throughput * tracer.skyRadiance(direction);
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

// A uniformly distributed rotation, from the unit quaternion of three uniforms (Shoemake, "Uniform
// Random Rotations", Graphics Gems III, 1992).
glm::dmat3 randomRotation(RandomStream& random) {
    const double u1 = random.next();
    const double u2 = random.next();
    const double u3 = random.next();
    const double a = std::sqrt(1.0 - u1);
    const double b = std::sqrt(u1);
    const glm::dquat q(b * std::cos(2.0 * kPi * u3), a * std::sin(2.0 * kPi * u2),
                       a * std::cos(2.0 * kPi * u2), b * std::sin(2.0 * kPi * u3));
    return glm::mat3_cast(q);
}

// Direction k of m of the spherical Fibonacci set: z at the centre of stratum k of [-1, 1], the
// azimuth advancing by the golden ratio (Marques et al.).
glm::dvec3 fibonacciDirection(int k, int m) {
    constexpr double kInverseGoldenRatio = 0.6180339887498948482;
    const double z = 1.0 - (2.0 * k + 1.0) / m;
    const double turn = k * kInverseGoldenRatio;
    const double phi = 2.0 * kPi * (turn - std::floor(turn));
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
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
            pathRadiance(tracer, options.bounces, position, direction, random, estimate.rays) *
            (4.0 * kPi / m);
        evalBasis(options.order, direction, basis);
        for (size_t i = 0; i < estimate.coefficients.size(); ++i)
            estimate.coefficients[i] += weighted * basis[i];
    }
    return estimate;
}

// The replicas' mean, and its standard error sqrt(sum (X_r - mean)^2 / (R (R - 1))).
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
    if (options.order < 1 || options.order > kMaxOrder) {
        throw Error(ErrorKind::Input, "SH order must be in 1.." + std::to_string(kMaxOrder) + ", got " +
                                          std::to_string(options.order));
    }
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
    }
    return probes;
}

} // namespace shprobe
