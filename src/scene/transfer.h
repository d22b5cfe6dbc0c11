// Precomputed radiance transfer per vertex (Sloan, Kautz and Snyder, "Precomputed Radiance Transfer
// for Real-Time Rendering in Dynamic, Low-Frequency Lighting Environments", 2002; the three diffuse
// models of Lisle and Huang, "Algorithms for Spherical Harmonic Lighting"): for each vertex of a
// World, the vector T_i (RGB) that turns a distant sky's radiance coefficients L_i into the radiance
// the vertex's diffuse surface leaves, L_out = sum_i T_i L_i (i the flat index of docs/conventions.md):
//
//   unshadowed      T_i = rho / pi * A_l y_i(n)                                  (exact, no rays)
//   shadowed        T_i = rho / pi * integral V(x, w) max(0, n.w) y_i(w) dw
//   interreflected  T_i = rho / pi * sum_{k=0..K} U_k,i(x), U_0 the integral above and
//                   U_k(x) = integral (1 - V(x, w)) max(0, n.w) rho(h) / pi U_{k-1}(h) dw
//
// with rho the vertex's albedo (material factor times texture at its TEXCOORD_0), n its shading
// normal, V(x, w) 1 where the ray from x along w meets nothing, h the first surface it meets and
// U_{k-1}(h) interpolated from h's triangle's vertices by the barycentrics. A hit on the back of a
// one-sided material brings nothing (it is the inside of something); the back of a double-sided one
// brings the transfer of its vertices' back sides (their normals turned), computed for that.
//
// The integrals are estimated by g x g stratified cosine-distributed rays (one jittered in each
// stratum of the unit square, scene/sampling.h), from the vertex moved largest SceneShading::offset of its
// triangles off the surface along its normal (and 4 offsets into its first triangle, towards the centroid, so
// that a vertex in a room's corner does not start its rays on the plane of the next wall): pi / g^2 times the
// sum of the integrand over the rays. The same rays (the seed, the vertex and its side name them) are cast
// again for each bounce, so that a vertex's transfer depends on nothing else: the same bits for any thread
// count.
#pragma once
#include "glsl/transfer_interface.h"
#include "scene/bvh.h"
#include "scene/scene.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace shprobe {

enum class TransferModel {
    Unshadowed = 0,
    Shadowed = 1,
    Interreflected = 2
}; // as the binary file numbers them

// "unshadowed", "shadowed", "interreflected"; and back (Error(Input) for another name).
const char* transferModelName(TransferModel model);
TransferModel parseTransferModel(const std::string& name);

struct TransferOptions {
    TransferModel model = TransferModel::Shadowed;
    int order = 3;   // 1..kMaxOrder
    int rays = 256;  // per vertex (and per bounce), rounded up to a square g x g; 1..kMaxTransferRays
    int bounces = 1; // interreflected only: K, 0..kMaxTransferBounces
    uint64_t seed = 1;
};

constexpr int kMaxTransferRays = 1 << 20;
constexpr int kMaxTransferBounces = 64;

// The transfer of every World vertex: vertex v's coefficient i is coefficients[v * order^2 + i].
// A vertex no triangle with area uses has none (zeros, and used[v] false).
struct VertexTransfer {
    int order = 3;
    int rays = 0; // per vertex and bounce, as cast (g^2); 0 for unshadowed
    std::vector<glm::vec3> coefficients;
    std::vector<bool> used;
    uint64_t raysCast = 0;

    size_t vertexCount() const { return coefficients.size() / (size_t(order) * size_t(order)); }
    // Whether the red, green and blue transfer differ anywhere: a grey scene (every albedo the
    // transfer met grey) gives the same bits in the three.
    bool coloured() const;
};

// Called with the vertex passes done so far (a vertex's side and bounce each), of `total`, from
// whichever thread finished one (one call at a time).
using TransferProgress = std::function<void(uint64_t done, uint64_t total)>;

// The transfer of the world's vertices on all cores, its rays cast by Embree (scene/ray_caster.h).
// Throws Error(Input) for options out of range, or for a world SceneShading or buildBvh refuses;
// Error(Device) where Embree's plugin cannot be loaded.
VertexTransfer computeTransfer(const World& world, const TransferOptions& options,
                               const TransferProgress& progress = {});

// A distant sky's radiance arriving from `direction` (unit, pointing away from the surface).
using SkyRadiance = std::function<glm::dvec3(const glm::dvec3& direction)>;

// The radiance each vertex's diffuse surface leaves under `sky`, estimated by computeTransfer's rays
// with the sky's radiance in place of the basis y(w): for a sky band-limited to the order, equal to
// sum_i T_i L_i up to rounding (relighting is baking, Sloan et al. 2002), which tests check. A vertex
// no triangle uses gets 0. Throws as computeTransfer does, and Error(Input) for the unshadowed
// model, which casts no rays.
std::vector<glm::vec3> computeVertexRadiance(const World& world, const TransferOptions& options,
                                             const SkyRadiance& sky);

// Whether anything lies along origin + t direction, t >= 0 (direction unit): all the shadowed model
// asks of the scene.
using OcclusionTest = std::function<bool(const glm::vec3& origin, const glm::vec3& direction)>;

// The shadowed model's transfer by computeTransfer's rays on all cores, each answered by `occluded`
// instead of Embree: so that another ray caster (the GPU's hierarchy on the cores, in
// shprobe-reference's --transfer-rate) is timed and checked on the same rays. Throws as computeTransfer does,
// and Error(Input) for another model.
VertexTransfer computeShadowedTransfer(const World& world, const TransferOptions& options,
                                       const OcclusionTest& occluded);

// What the passes with rays read, laid out as computeTransfer casts them, for another ray caster
// (gpu/transfer_rays.h): the world as SceneShading checked it, its hierarchy, and the vertex sides.
struct TransferScene {
    const World& world;
    const Bvh& bvh;
    int strata = 1; // g: each side casts g x g rays
    // The fronts of every vertex (side v is vertex v's), then the backs of the double-sided ones.
    std::vector<glsl::TransferSide> sides;
    std::vector<uint32_t> backSides; // per vertex: its back side, 0 for none
};

// One pass over every side into `current` (side s's coefficient i at s * order^2 + i): U_0 when
// `bounce` is 0, else U_bounce from `previous` (U_{bounce-1}, the same layout). Returns the rays cast.
using TransferCaster =
    std::function<uint64_t(const TransferScene& scene, int bounce, std::span<const glm::vec3> previous,
                           std::span<glm::vec3> current)>;

// computeTransfer with the passes cast by `caster` (progress: after each pass). The unshadowed
// model casts nothing and never calls it.
VertexTransfer computeTransfer(const World& world, const TransferOptions& options,
                               const TransferCaster& caster, const TransferProgress& progress = {});

} // namespace shprobe
