// Per-vertex transfer (transfer.h): the direct pass by shadow rays, each bounce by closest hits whose
// triangles' previous-bounce transfer is interpolated.
#include "scene/transfer.h"

#include "common/error.h"
#include "common/parallel.h"
#include "scene/ray_caster.h"
#include "scene/sampling.h"
#include "scene/surface_shading.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/irradiance.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <span>

namespace shprobe {

namespace {

// Vertex sides per work item: enough to keep the shared counter cold.
constexpr size_t kSidesPerItem = 16;

void requireOptions(const TransferOptions& options) {
    auto refuse = [](const std::string& what) { throw Error(ErrorKind::Input, "transfer: " + what); };
    requireOrder(options.order);
    if (options.rays < 1 || options.rays > kMaxTransferRays)
        refuse("rays must be in 1.." + std::to_string(kMaxTransferRays) + ", got " +
               std::to_string(options.rays));
    if (options.bounces < 0 || options.bounces > kMaxTransferBounces)
        refuse("bounces must be in 0.." + std::to_string(kMaxTransferBounces) + ", got " +
               std::to_string(options.bounces));
}

using Basis = std::array<double, coefficientCount(kMaxOrder)>;
using Side = glsl::TransferSide;

uint32_t sideVertex(const Side& side) {
    return side.ids.z;
}
bool isBack(const Side& side) {
    return (side.ids.w & SHPROBE_SIDE_BACK) != 0;
}

class TransferBaker {
  public:
    // `sky`: the vertices' radiance under it (one RGB value per side and pass), not their transfer.
    // `occlusion`: what answers the shadowed pass's rays instead of Embree.
    TransferBaker(const World& world, const TransferOptions& options, const SkyRadiance* sky = nullptr,
                  const OcclusionTest* occlusion = nullptr)
        : options_(options), sky_(sky), occlusion_(occlusion), shading_(world, makeCubemap(1)),
          count_(sky ? 1 : size_t(coefficientCount(options.order))),
          strata_(int(std::ceil(std::sqrt(double(options.rays))))), scene_{.world = shading_.world(),
                                                                           .bvh = bvh_,
                                                                           .strata = strata_} {
        layOutSides();
    }

    // The passes cast by `caster`, or on all cores where it is empty.
    VertexTransfer run(const TransferProgress& progress, const TransferCaster& caster);

  private:
    void layOutSides();
    Side makeSide(uint32_t vertex, bool back) const;
    glm::dvec3 albedo(uint32_t vertex) const;
    glm::dvec3 rayOrigin(uint32_t vertex) const;
    template <typename Ray> void forEachRay(const Side& side, Ray&& ray) const;
    void direct(const Side& side, std::span<glm::vec3> out, uint64_t& rays) const;
    void bounce(const Side& side, std::span<const glm::vec3> previous, std::span<glm::vec3> out,
                uint64_t& rays) const;
    template <typename Pass> void forEachSide(const Pass& pass);
    void castOnCores(int k, std::span<const glm::vec3> previous, std::span<glm::vec3> current);

    const TransferOptions& options_;
    const SkyRadiance* sky_;
    const OcclusionTest* occlusion_;
    SceneShading shading_;
    Bvh bvh_;                            // built for a caster of the passes (the GPU's)
    std::unique_ptr<RayCaster> cpuRays_; // built for the passes on the cores
    size_t count_;
    int strata_;
    StratifiedCosineDirections directions_{strata_};
    TransferScene scene_;
    std::vector<int64_t> corner_; // per vertex: 3 t + c of the first triangle t with area using it, or -1
    // Per vertex: the largest offset of the triangles with area using it, each of which its rays
    // could meet again by rounding.
    std::vector<double> offsets_;
    std::atomic<uint64_t> rays_{0};
    std::atomic<uint64_t> done_{0};
    uint64_t total_ = 0;
    const TransferProgress* progress_ = nullptr;
    std::mutex reporting_;
};

void TransferBaker::layOutSides() {
    const World& world = shading_.world();
    // A zero-area triangle has no normal and no ray meets it: a vertex only such triangles use
    // (a flat primitive's copies of their corners) gets no transfer.
    corner_.assign(world.positions.size(), -1);
    offsets_.assign(world.positions.size(), 0.0);
    for (size_t t = world.triangleCount(); t-- > 0;) {
        if (!hasArea(world, t)) continue;
        for (size_t c = 0; c < 3; ++c) {
            const uint32_t v = world.indices[3 * t + c];
            corner_[v] = int64_t(3 * t + c);
            offsets_[v] = std::max(offsets_[v], shading_.offset(uint32_t(t)));
        }
    }
    scene_.backSides.assign(world.positions.size(), 0);
    for (uint32_t v = 0; v < world.positions.size(); ++v)
        scene_.sides.push_back(makeSide(v, false));
    // Back sides are only met by a bounce's rays.
    if (options_.model != TransferModel::Interreflected || options_.bounces == 0) return;
    for (uint32_t v = 0; v < world.positions.size(); ++v) {
        if (corner_[v] < 0) continue;
        const uint32_t material = world.triangleMaterials[size_t(corner_[v]) / 3];
        if (!world.materials[material].doubleSided) continue;
        scene_.backSides[v] = uint32_t(scene_.sides.size());
        scene_.sides.push_back(makeSide(v, true));
    }
}

// Where the side's rays start (as a Ray takes it, in float), about which normal, and its random
// stream (named by the seed, the side and the vertex).
Side TransferBaker::makeSide(uint32_t vertex, bool back) const {
    Side side{};
    side.ids.z = vertex;
    side.ids.w = back ? SHPROBE_SIDE_BACK : 0;
    if (corner_[vertex] < 0) {
        side.ids.w |= SHPROBE_SIDE_UNUSED;
        return side;
    }
    const glm::dvec3 n(shading_.world().normals[vertex]);
    const glm::dvec3 normal = back ? -n : n;
    side.origin = glm::vec4(glm::vec3(rayOrigin(vertex) + offsets_[vertex] * normal), 0.0f);
    side.normal = glm::vec4(glm::vec3(normal), 0.0f);
    const uint64_t state = RandomStream(options_.seed, back ? 1 : 0, vertex).state();
    side.ids.x = uint32_t(state);
    side.ids.y = uint32_t(state >> 32);
    return side;
}

// The material's albedo at the vertex (factor times texture at its TEXCOORD_0).
glm::dvec3 TransferBaker::albedo(uint32_t vertex) const {
    const size_t at = size_t(corner_[vertex]);
    const int c = int(at % 3);
    const glm::dvec2 barycentric(c == 1 ? 1.0 : 0.0, c == 2 ? 1.0 : 0.0);
    return shading_.surfacePoint(uint32_t(at / 3), barycentric, true).albedo;
}

// A vertex where walls meet (a room's corner) lies on the plane of the next wall: its rays start
// moved into its first triangle, towards the centroid, by 4 surface offsets (at most half the way),
// so that a ray along that wall cannot slip out between the two.
glm::dvec3 TransferBaker::rayOrigin(uint32_t vertex) const {
    const World& world = shading_.world();
    const uint32_t* t = &world.indices[size_t(corner_[vertex]) / 3 * 3];
    const glm::dvec3 p(world.positions[vertex]);
    const glm::dvec3 towards = (glm::dvec3(world.positions[t[0]]) + glm::dvec3(world.positions[t[1]]) +
                                glm::dvec3(world.positions[t[2]])) /
                                   3.0 -
                               p;
    const double distance = glm::length(towards);
    if (distance == 0.0) return p;
    return p + towards * (std::min(4.0 * offsets_[vertex], 0.5 * distance) / distance);
}

// Calls ray(origin, direction) for the side's g x g stratified cosine-distributed rays.
template <typename Ray> void TransferBaker::forEachRay(const Side& side, Ray&& ray) const {
    const glm::dvec3 n(side.normal);
    const glm::vec3 origin(side.origin);
    RandomStream random(options_.seed, isBack(side) ? 1 : 0, sideVertex(side));
    directions_.forEach(n, random, [&](const glm::dvec3& direction) { ray(origin, direction); });
}

// U_0: pi / g^2 times the sum of y(w) (or of the sky's radiance) over the rays that meet nothing.
void TransferBaker::direct(const Side& side, std::span<glm::vec3> out, uint64_t& rays) const {
    std::array<double, coefficientCount(kMaxOrder)> sum{};
    glm::dvec3 radiance(0.0);
    Basis basis{};
    forEachRay(side, [&](const glm::vec3& origin, const glm::dvec3& direction) {
        ++rays;
        if (occlusion_ ? (*occlusion_)(origin, glm::vec3(direction))
                       : cpuRays_->anyHit({origin, glm::vec3(direction)}))
            return;
        if (sky_) {
            radiance += (*sky_)(direction);
            return;
        }
        evalBasis(options_.order, direction, basis);
        for (size_t i = 0; i < count_; ++i)
            sum[i] += basis[i];
    });
    const double scale = std::numbers::pi / (double(strata_) * strata_);
    if (sky_) out[0] = glm::vec3(radiance * scale);
    for (size_t i = 0; !sky_ && i < count_; ++i)
        out[i] = glm::vec3(float(sum[i] * scale));
}

// U_k: 1 / g^2 times the sum, over the rays that meet a surface's front (or either side of a
// double-sided one), of its albedo times U_{k-1} interpolated over its triangle.
void TransferBaker::bounce(const Side& side, std::span<const glm::vec3> previous, std::span<glm::vec3> out,
                           uint64_t& rays) const {
    const World& world = shading_.world();
    std::array<glm::dvec3, coefficientCount(kMaxOrder)> sum{};
    forEachRay(side, [&](const glm::vec3& origin, const glm::dvec3& direction) {
        ++rays;
        const std::optional<RayHit> found = cpuRays_->closestHit({origin, glm::vec3(direction)});
        if (!found) return;
        const SurfaceHit hit =
            shading_.describe(found->triangle, glm::dvec2(found->hit.u, found->hit.v), direction);
        if (hit.backFace || hit.albedo == glm::dvec3(0.0)) return;
        const uint32_t* corners = &world.indices[3 * size_t(found->triangle)];
        const double weights[3] = {1.0 - hit.barycentric.x - hit.barycentric.y, hit.barycentric.x,
                                   hit.barycentric.y};
        for (int c = 0; c < 3; ++c) {
            const size_t slot = hit.frontSide ? corners[c] : scene_.backSides[corners[c]];
            const glm::vec3* from = &previous[slot * count_];
            for (size_t i = 0; i < count_; ++i)
                sum[i] += weights[c] * hit.albedo * glm::dvec3(from[i]);
        }
    });
    const double scale = 1.0 / (double(strata_) * strata_);
    for (size_t i = 0; i < count_; ++i)
        out[i] = glm::vec3(sum[i] * scale);
}

// pass(side index) for every side on all cores, progress counted.
template <typename Pass> void TransferBaker::forEachSide(const Pass& pass) {
    const std::vector<Side>& sides = scene_.sides;
    const size_t items = (sides.size() + kSidesPerItem - 1) / kSidesPerItem;
    const size_t rays = sides.size() * size_t(strata_) * size_t(strata_);
    forEachItem(int(items), threadCount(rays, kRaysPerThread), [&](int item) {
        const size_t first = size_t(item) * kSidesPerItem;
        const size_t last = std::min(first + kSidesPerItem, sides.size());
        uint64_t cast = 0;
        for (size_t s = first; s < last; ++s)
            if (corner_[sideVertex(sides[s])] >= 0) pass(s, cast);
        rays_ += cast;
        const uint64_t finished = done_ += last - first;
        if (!*progress_) return;
        const std::lock_guard lock(reporting_);
        (*progress_)(finished, total_);
    });
}

void TransferBaker::castOnCores(int k, std::span<const glm::vec3> previous, std::span<glm::vec3> current) {
    forEachSide([&](size_t s, uint64_t& rays) {
        const std::span<glm::vec3> out = current.subspan(s * count_, count_);
        if (k == 0)
            direct(scene_.sides[s], out, rays);
        else
            bounce(scene_.sides[s], previous, out, rays);
    });
}

VertexTransfer TransferBaker::run(const TransferProgress& progress, const TransferCaster& caster) {
    const World& world = shading_.world();
    const size_t vertices = world.positions.size();
    VertexTransfer transfer;
    transfer.order = sky_ ? 1 : options_.order; // under a sky: one value per vertex
    transfer.coefficients.assign(vertices * count_, glm::vec3(0.0f));
    transfer.used.resize(vertices);
    for (size_t v = 0; v < vertices; ++v)
        transfer.used[v] = corner_[v] >= 0;
    progress_ = &progress;
    if (options_.model == TransferModel::Unshadowed) {
        Basis basis{};
        for (uint32_t v = 0; v < vertices; ++v) {
            if (corner_[v] < 0) continue;
            const glm::dvec3 rho = albedo(v) * std::numbers::inv_pi;
            evalBasis(options_.order, glm::dvec3(world.normals[v]), basis);
            for (size_t i = 0; i < count_; ++i)
                transfer.coefficients[v * count_ + i] =
                    glm::vec3(rho * (irradianceBandFactor(shBand(int(i))) * basis[i]));
        }
        return transfer;
    }
    const int bounces = options_.model == TransferModel::Interreflected ? options_.bounces : 0;
    if (caster)
        bvh_ = buildBvh(world);
    else if (!occlusion_)
        cpuRays_ = makeRayCaster(world);
    const size_t sides = scene_.sides.size();
    total_ = uint64_t(sides) * uint64_t(bounces + 1);
    std::vector<glm::vec3> previous(sides * count_), current(previous.size());
    std::vector<glm::dvec3> sum(vertices * count_, glm::dvec3(0.0));
    for (int k = 0; k <= bounces; ++k) {
        if (caster) {
            rays_ += caster(scene_, k, previous, current);
            if (progress) progress(uint64_t(sides) * uint64_t(k + 1), total_);
        } else {
            castOnCores(k, previous, current);
        }
        for (size_t i = 0; i < sum.size(); ++i)
            sum[i] += glm::dvec3(current[i]); // the fronts come first: index v * count + i
        std::swap(previous, current);
    }
    for (uint32_t v = 0; v < vertices; ++v) {
        if (corner_[v] < 0) continue;
        const glm::dvec3 rho = albedo(v) * std::numbers::inv_pi;
        for (size_t i = 0; i < count_; ++i)
            transfer.coefficients[v * count_ + i] = glm::vec3(rho * sum[v * count_ + i]);
    }
    transfer.rays = strata_ * strata_;
    transfer.raysCast = rays_;
    return transfer;
}

} // namespace

const char* transferModelName(TransferModel model) {
    switch (model) {
    case TransferModel::Unshadowed:
        return "unshadowed";
    case TransferModel::Shadowed:
        return "shadowed";
    default:
        return "interreflected";
    }
}

TransferModel parseTransferModel(const std::string& name) {
    for (TransferModel model :
         {TransferModel::Unshadowed, TransferModel::Shadowed, TransferModel::Interreflected})
        if (name == transferModelName(model)) return model;
    throw Error(ErrorKind::Input,
                "transfer: the model must be unshadowed, shadowed or interreflected, got \"" + name + "\"");
}

bool VertexTransfer::coloured() const {
    for (const glm::vec3& c : coefficients)
        if (c.r != c.g || c.g != c.b) return true;
    return false;
}

VertexTransfer computeTransfer(const World& world, const TransferOptions& options,
                               const TransferProgress& progress) {
    requireOptions(options);
    return TransferBaker(world, options).run(progress, {});
}

std::vector<glm::vec3> computeVertexRadiance(const World& world, const TransferOptions& options,
                                             const SkyRadiance& sky) {
    requireOptions(options);
    if (options.model == TransferModel::Unshadowed)
        throw Error(ErrorKind::Input,
                    "vertex radiance: the unshadowed model casts no rays; relight its transfer");
    return TransferBaker(world, options, &sky).run({}, {}).coefficients;
}

VertexTransfer computeShadowedTransfer(const World& world, const TransferOptions& options,
                                       const OcclusionTest& occluded) {
    requireOptions(options);
    if (options.model != TransferModel::Shadowed)
        throw Error(ErrorKind::Input,
                    "transfer: another occlusion test answers the shadowed model's rays only");
    return TransferBaker(world, options, nullptr, &occluded).run({}, {});
}

VertexTransfer computeTransfer(const World& world, const TransferOptions& options,
                               const TransferCaster& caster, const TransferProgress& progress) {
    requireOptions(options);
    return TransferBaker(world, options).run(progress, caster);
}

} // namespace shprobe
