// Per-vertex transfer (transfer.h): the direct pass by shadow rays, each bounce by closest hits whose
// triangles' previous-bounce transfer is interpolated.
#include "scene/transfer.h"

#include "common/error.h"
#include "common/parallel.h"
#include "scene/bvh.h"
#include "scene/sampling.h"
#include "scene/surface_shading.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/irradiance.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <mutex>
#include <numbers>
#include <optional>
#include <span>

namespace shprobe {

namespace {

// A thread should cast at least this many rays, so that starting it stays a small part of its run.
constexpr size_t kRaysPerThread = 4096;
// Vertex sides per work item: enough to keep the shared counter cold.
constexpr size_t kSidesPerItem = 16;

void requireOptions(const TransferOptions& options) {
    auto refuse = [](const std::string& what) { throw Error(ErrorKind::Input, "transfer: " + what); };
    if (options.order < 1 || options.order > kMaxOrder)
        refuse("SH order must be in 1.." + std::to_string(kMaxOrder) + ", got " +
               std::to_string(options.order));
    if (options.rays < 1 || options.rays > kMaxTransferRays)
        refuse("rays must be in 1.." + std::to_string(kMaxTransferRays) + ", got " +
               std::to_string(options.rays));
    if (options.bounces < 0 || options.bounces > kMaxTransferBounces)
        refuse("bounces must be in 0.." + std::to_string(kMaxTransferBounces) + ", got " +
               std::to_string(options.bounces));
}

using Basis = std::array<double, coefficientCount(kMaxOrder)>;

// A vertex's side: the front (along its normal) or, for a vertex of a double-sided material, the back.
struct Side {
    uint32_t vertex = 0;
    bool back = false;
};

class TransferBaker {
  public:
    TransferBaker(const World& world, const TransferOptions& options)
        : options_(options), shading_(world, makeCubemap(1)), bvh_(buildBvh(world)),
          count_(size_t(coefficientCount(options.order))),
          strata_(int(std::ceil(std::sqrt(double(options.rays))))) {
        layOutSides();
    }

    VertexTransfer run(const TransferProgress& progress);

  private:
    void layOutSides();
    glm::dvec3 albedo(uint32_t vertex) const;
    glm::dvec3 normal(const Side& side) const;
    glm::dvec3 rayOrigin(uint32_t vertex) const;
    template <typename Ray> void forEachRay(const Side& side, Ray&& ray) const;
    void direct(const Side& side, std::span<glm::vec3> out, uint64_t& rays) const;
    void bounce(const Side& side, std::span<const glm::vec3> previous, std::span<glm::vec3> out,
                uint64_t& rays) const;
    template <typename Pass> void forEachSide(const Pass& pass);

    const TransferOptions& options_;
    SceneShading shading_;
    Bvh bvh_;
    size_t count_;
    int strata_;
    std::vector<int64_t> corner_;    // per vertex: 3 t + c of the first triangle t using it, -1: none
    std::vector<uint32_t> backSlot_; // per vertex: its back side's index, 0 for none
    std::vector<Side> sides_;        // fronts of every vertex (index = vertex), then the backs
    std::atomic<uint64_t> rays_{0};
    std::atomic<uint64_t> done_{0};
    uint64_t total_ = 0;
    const TransferProgress* progress_ = nullptr;
    std::mutex reporting_;
};

void TransferBaker::layOutSides() {
    const World& world = shading_.world();
    corner_.assign(world.positions.size(), -1);
    for (size_t i = world.indices.size(); i-- > 0;)
        corner_[world.indices[i]] = int64_t(i);
    backSlot_.assign(world.positions.size(), 0);
    for (uint32_t v = 0; v < world.positions.size(); ++v)
        sides_.push_back({v, false});
    if (options_.model == TransferModel::Unshadowed) return;
    for (uint32_t v = 0; v < world.positions.size(); ++v) {
        if (corner_[v] < 0) continue;
        const uint32_t material = world.triangleMaterials[size_t(corner_[v]) / 3];
        if (!world.materials[material].doubleSided) continue;
        backSlot_[v] = uint32_t(sides_.size());
        sides_.push_back({v, true});
    }
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
    return p + towards * (std::min(4.0 * shading_.offset(), 0.5 * distance) / distance);
}

glm::dvec3 TransferBaker::normal(const Side& side) const {
    const glm::dvec3 n(shading_.world().normals[side.vertex]);
    return side.back ? -n : n;
}

// Calls ray(origin, direction) for the side's g x g stratified cosine-distributed rays.
template <typename Ray> void TransferBaker::forEachRay(const Side& side, Ray&& ray) const {
    const glm::dvec3 n = normal(side);
    const glm::dvec3 origin = rayOrigin(side.vertex) + shading_.offset() * n;
    RandomStream random(options_.seed, side.back ? 1 : 0, side.vertex);
    const int g = strata_;
    for (int a = 0; a < g; ++a) {
        for (int b = 0; b < g; ++b) {
            const double u1 = (a + random.next()) / g;
            const double u2 = (b + random.next()) / g;
            ray(origin, cosineDirection(n, u1, u2));
        }
    }
}

// U_0: pi / g^2 times the sum of y(w) over the rays that meet nothing.
void TransferBaker::direct(const Side& side, std::span<glm::vec3> out, uint64_t& rays) const {
    std::array<double, coefficientCount(kMaxOrder)> sum{};
    Basis basis{};
    forEachRay(side, [&](const glm::dvec3& origin, const glm::dvec3& direction) {
        ++rays;
        if (anyHit(bvh_, {glm::vec3(origin), glm::vec3(direction)})) return;
        evalBasis(options_.order, direction, basis);
        for (size_t i = 0; i < count_; ++i)
            sum[i] += basis[i];
    });
    const double scale = std::numbers::pi / (double(strata_) * strata_);
    for (size_t i = 0; i < count_; ++i)
        out[i] = glm::vec3(float(sum[i] * scale));
}

// U_k: 1 / g^2 times the sum, over the rays that meet a surface's front (or either side of a
// double-sided one), of its albedo times U_{k-1} interpolated over its triangle.
void TransferBaker::bounce(const Side& side, std::span<const glm::vec3> previous, std::span<glm::vec3> out,
                           uint64_t& rays) const {
    const World& world = shading_.world();
    std::array<glm::dvec3, coefficientCount(kMaxOrder)> sum{};
    forEachRay(side, [&](const glm::dvec3& origin, const glm::dvec3& direction) {
        ++rays;
        const std::optional<RayHit> found = closestHit(bvh_, {glm::vec3(origin), glm::vec3(direction)});
        if (!found) return;
        const SurfaceHit hit =
            shading_.describe(found->triangle, glm::dvec2(found->hit.u, found->hit.v), direction);
        if (hit.backFace || hit.albedo == glm::dvec3(0.0)) return;
        const uint32_t* corners = &world.indices[3 * size_t(found->triangle)];
        const double weights[3] = {1.0 - hit.barycentric.x - hit.barycentric.y, hit.barycentric.x,
                                   hit.barycentric.y};
        for (int c = 0; c < 3; ++c) {
            const size_t slot = hit.frontSide ? corners[c] : backSlot_[corners[c]];
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
    const size_t items = (sides_.size() + kSidesPerItem - 1) / kSidesPerItem;
    const size_t rays = sides_.size() * size_t(strata_) * size_t(strata_);
    forEachItem(int(items), threadCount(rays, kRaysPerThread), [&](int item) {
        const size_t first = size_t(item) * kSidesPerItem;
        const size_t last = std::min(first + kSidesPerItem, sides_.size());
        uint64_t cast = 0;
        for (size_t s = first; s < last; ++s)
            if (corner_[sides_[s].vertex] >= 0) pass(s, cast);
        rays_ += cast;
        const uint64_t finished = done_ += last - first;
        if (!*progress_) return;
        const std::lock_guard lock(reporting_);
        (*progress_)(finished, total_);
    });
}

VertexTransfer TransferBaker::run(const TransferProgress& progress) {
    const World& world = shading_.world();
    const size_t vertices = world.positions.size();
    VertexTransfer transfer;
    transfer.order = options_.order;
    transfer.coefficients.assign(vertices * count_, glm::vec3(0.0f));
    progress_ = &progress;
    if (options_.model == TransferModel::Unshadowed) {
        Basis basis{};
        for (uint32_t v = 0; v < vertices; ++v) {
            if (corner_[v] < 0) continue;
            const glm::dvec3 rho = albedo(v) * std::numbers::inv_pi;
            evalBasis(options_.order, normal({v, false}), basis);
            for (size_t i = 0; i < count_; ++i)
                transfer.coefficients[v * count_ + i] =
                    glm::vec3(rho * (irradianceBandFactor(shBand(int(i))) * basis[i]));
        }
        return transfer;
    }
    const int bounces = options_.model == TransferModel::Interreflected ? options_.bounces : 0;
    total_ = uint64_t(sides_.size()) * uint64_t(bounces + 1);
    std::vector<glm::vec3> previous(sides_.size() * count_), current(previous.size());
    std::vector<glm::dvec3> sum(vertices * count_, glm::dvec3(0.0));
    for (int k = 0; k <= bounces; ++k) {
        forEachSide([&](size_t s, uint64_t& rays) {
            const std::span<glm::vec3> out(&current[s * count_], count_);
            if (k == 0)
                direct(sides_[s], out, rays);
            else
                bounce(sides_[s], previous, out, rays);
        });
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
    return TransferBaker(world, options).run(progress);
}

} // namespace shprobe
