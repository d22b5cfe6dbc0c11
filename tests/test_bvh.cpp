// Ray casting (scene/bvh.h): the watertight triangle test against closed forms, the hierarchy's
// layout (glsl/bvh_interface.h), its traversals against testing every triangle, against Embree on a
// real model and the Cornell box, and the quality of its splits.
#include "scene/bvh.h"

#include "common/error.h"
#include "scene/gltf_scene.h"
#include "scene/ray_caster.h"
#include "scene_fixtures.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <unistd.h>
#include <vector>

namespace shprobe {
namespace {

using namespace shprobe::testing;

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// --- Scenes ------------------------------------------------------------------------------------

World worldOf(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices) {
    World world;
    world.positions = positions;
    world.indices = indices;
    return world;
}

// The triangle (0,0,0), (1,0,0), (0,1,0): its front faces +z, and a point (x, y, 0) inside it has
// barycentrics u = x, v = y.
World unitTriangle() {
    return worldOf({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {0, 1, 2});
}

// The cube [-1, 1]^3 as 12 triangles facing outward, each face split along the diagonal through its
// centre; corner i is (+-1, +-1, +-1) by the bits of i.
World cube() {
    std::vector<glm::vec3> corners;
    for (int i = 0; i < 8; ++i)
        corners.push_back({i & 1 ? 1.0f : -1.0f, i & 2 ? 1.0f : -1.0f, i & 4 ? 1.0f : -1.0f});
    const uint32_t faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    std::vector<uint32_t> indices;
    for (const auto& f : faces)
        indices.insert(indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
    return worldOf(corners, indices);
}

// The octahedron |x| + |y| + |z| = 1 as 8 triangles facing outward, one per octant.
World octahedron() {
    const std::vector<glm::vec3> corners = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                            {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
    std::vector<uint32_t> indices;
    for (uint32_t x : {0u, 1u})
        for (uint32_t y : {2u, 3u})
            for (uint32_t z : {4u, 5u}) {
                const bool mirrored = ((x == 1) != (y == 3)) != (z == 5); // an odd number of negative axes
                indices.insert(indices.end(), {x, mirrored ? z : y, mirrored ? y : z});
            }
    return worldOf(corners, indices);
}

std::array<glm::vec3, 3> cornersOf(const World& world, size_t t) {
    return {world.positions[world.indices[3 * t]], world.positions[world.indices[3 * t + 1]],
            world.positions[world.indices[3 * t + 2]]};
}

glm::vec3 windingNormal(const World& world, size_t t) {
    const auto [p0, p1, p2] = cornersOf(world, t);
    return glm::cross(p1 - p0, p2 - p0);
}

// --- Rays --------------------------------------------------------------------------------------

class RandomRays {
  public:
    explicit RandomRays(uint64_t seed) : random_(seed) {}

    glm::vec3 direction() {
        for (;;) {
            const glm::vec3 d(normal_(random_), normal_(random_), normal_(random_));
            const float length = glm::length(d);
            if (length > 1e-3f) return d / length;
        }
    }
    float uniform(float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(random_); }
    glm::vec3 inBox(const glm::vec3& lo, const glm::vec3& hi) {
        return {uniform(lo.x, hi.x), uniform(lo.y, hi.y), uniform(lo.z, hi.z)};
    }
    size_t index(size_t count) { return std::uniform_int_distribution<size_t>(0, count - 1)(random_); }

  private:
    std::mt19937_64 random_;
    std::normal_distribution<float> normal_;
};

// Rays from random points of the scene's bounds: half in random directions, half aimed at a random
// vertex (through edges and vertices shared by several triangles, where ties and rounding are
// most likely to tell two traversals apart); a third of them limited to a random tMax.
std::vector<Ray> sceneRays(const World& world, size_t count, uint64_t seed) {
    RandomRays random(seed);
    std::vector<Ray> rays(count);
    const float diagonal = glm::length(world.boundsMax - world.boundsMin);
    for (size_t k = 0; k < count; ++k) {
        Ray& ray = rays[k];
        ray.origin = random.inBox(world.boundsMin, world.boundsMax);
        ray.direction =
            k % 2 ? random.direction() : world.positions[random.index(world.positions.size())] - ray.origin;
        if (ray.direction == glm::vec3(0.0f)) ray.direction = random.direction();
        if (k % 3 == 0) ray.tMax = random.uniform(0.0f, 0.5f * diagonal) / glm::length(ray.direction);
    }
    return rays;
}

// Every triangle tested, in World order, by the same watertight test; ties at equal t go to the
// lowest index, as closestHit promises.
std::optional<RayHit> bruteForceClosest(const World& world, const Ray& ray) {
    const PreparedRay prepared = prepareRay(ray);
    std::optional<RayHit> best;
    for (size_t t = 0; t < world.triangleCount(); ++t) {
        const auto [p0, p1, p2] = cornersOf(world, t);
        const auto hit = intersectTriangle(prepared, p0, p1, p2);
        if (hit && (!best || hit->t < best->hit.t)) best = RayHit{uint32_t(t), *hit};
    }
    return best;
}

// --- The triangle test -------------------------------------------------------------------------

// One triangle, rays along z: the hit point, t (in lengths of a non-unit direction too) and
// barycentrics are exact in float (every value a small dyadic fraction), and which face is hit
// follows the winding normal +z.
TEST(Bvh, SingleTriangleClosedForm) {
    const Bvh bvh = buildBvh(unitTriangle());
    const auto front = closestHit(bvh, {.origin = {0.25f, 0.5f, 2.0f}, .direction = {0, 0, -1}});
    ASSERT_TRUE(front);
    EXPECT_EQ(front->triangle, 0u);
    EXPECT_EQ(front->hit.t, 2.0f);
    EXPECT_EQ(front->hit.u, 0.25f);
    EXPECT_EQ(front->hit.v, 0.5f);
    EXPECT_TRUE(front->hit.frontFace);

    const auto back = closestHit(bvh, {.origin = {0.5f, 0.125f, -3.0f}, .direction = {0, 0, 2}});
    ASSERT_TRUE(back);
    EXPECT_EQ(back->hit.t, 1.5f);
    EXPECT_EQ(back->hit.u, 0.5f);
    EXPECT_EQ(back->hit.v, 0.125f);
    EXPECT_FALSE(back->hit.frontFace);

    // A slanted ray: (0.25, 0.25, 0) from (1.25, 2.25, 4) along (-1, -2, -4), t = 1.
    const auto slanted = closestHit(bvh, {.origin = {1.25f, 2.25f, 4.0f}, .direction = {-1, -2, -4}});
    ASSERT_TRUE(slanted);
    EXPECT_FLOAT_EQ(slanted->hit.t, 1.0f);
    EXPECT_FLOAT_EQ(slanted->hit.u, 0.25f);
    EXPECT_FLOAT_EQ(slanted->hit.v, 0.25f);
    EXPECT_TRUE(slanted->hit.frontFace);
}

// The edge x + y = 1 is inside (points on an edge hit), one float step beyond it is outside; a
// vertex hits; an edge-on ray (in the triangle's plane) sees no area and misses.
TEST(Bvh, EdgesAndVerticesOfOneTriangle) {
    const Bvh bvh = buildBvh(unitTriangle());
    auto hitsAt = [&](float x, float y) {
        return closestHit(bvh, {.origin = {x, y, 1.0f}, .direction = {0, 0, -1}}).has_value();
    };
    EXPECT_TRUE(hitsAt(0.5f, 0.5f));
    EXPECT_TRUE(hitsAt(std::nextafter(0.5f, 0.0f), 0.5f));
    EXPECT_FALSE(hitsAt(std::nextafter(0.5f, 1.0f), 0.5f));
    EXPECT_FALSE(hitsAt(0.5f, -1e-6f));
    EXPECT_FALSE(hitsAt(-1e-6f, 0.5f));
    EXPECT_TRUE(hitsAt(0.0f, 0.0f));
    EXPECT_TRUE(hitsAt(1.0f, 0.0f));
    EXPECT_FALSE(hitsAt(1.0f, 1e-6f));
    EXPECT_FALSE(closestHit(bvh, {.origin = {-1.0f, 0.25f, 0.0f}, .direction = {1, 0, 0}}));
}

// tMin and tMax bound the hit inclusively; anyHit agrees with closestHit on each.
TEST(Bvh, RayIntervalCutsOffHits) {
    const Bvh bvh = buildBvh(unitTriangle());
    const Ray down{.origin = {0.25f, 0.25f, 2.0f}, .direction = {0, 0, -1}};
    for (auto [tMin, tMax, hits] :
         std::vector<std::tuple<float, float, bool>>{{0.0f, kInfinity, true},
                                                     {0.0f, 2.0f, true},
                                                     {0.0f, std::nextafter(2.0f, 0.0f), false},
                                                     {2.0f, 3.0f, true},
                                                     {std::nextafter(2.0f, 3.0f), kInfinity, false},
                                                     {0.0f, 1.0f, false}}) {
        Ray ray = down;
        ray.tMin = tMin;
        ray.tMax = tMax;
        EXPECT_EQ(closestHit(bvh, ray).has_value(), hits) << tMin << " " << tMax;
        EXPECT_EQ(anyHit(bvh, ray), hits) << tMin << " " << tMax;
    }
    // Behind the origin: t = -2 is not in [0, inf].
    EXPECT_FALSE(closestHit(bvh, {.origin = {0.25f, 0.25f, 2.0f}, .direction = {0, 0, 1}}));
}

// The fixtures face outward (their winding normals point away from the centre).
TEST(Bvh, ClosedFixturesFaceOutward) {
    for (const World& world : {cube(), octahedron()})
        for (size_t t = 0; t < world.triangleCount(); ++t) {
            const auto [p0, p1, p2] = cornersOf(world, t);
            EXPECT_GT(glm::dot(windingNormal(world, t), p0 + p1 + p2), 0.0f) << t;
        }
}

// Rays through a shared edge and a shared vertex of the cube, from outside and inside: the hit is at
// the exact t, on a triangle that has that edge or vertex, and every triangle sharing them reports
// the hit by itself (the edge functions of a shared edge are the same numbers up to sign).
TEST(Bvh, SharedEdgesAndVerticesOfACube) {
    const World world = cube();
    const Bvh bvh = buildBvh(world);
    // The +x face's diagonal passes through its centre (1, 0, 0); corner 7 is (1, 1, 1).
    const auto edge = closestHit(bvh, {.origin = {0, 0, 0}, .direction = {1, 0, 0}});
    ASSERT_TRUE(edge);
    EXPECT_EQ(edge->hit.t, 1.0f);
    EXPECT_FALSE(edge->hit.frontFace);
    const auto outsideEdge = closestHit(bvh, {.origin = {4, 0, 0}, .direction = {-1, 0, 0}});
    ASSERT_TRUE(outsideEdge);
    EXPECT_EQ(outsideEdge->hit.t, 3.0f);
    EXPECT_TRUE(outsideEdge->hit.frontFace);
    const auto vertex = closestHit(bvh, {.origin = {0, 0, 0}, .direction = {1, 1, 1}});
    ASSERT_TRUE(vertex);
    EXPECT_EQ(vertex->hit.t, 1.0f);
    const auto outsideVertex = closestHit(bvh, {.origin = {3, 3, 3}, .direction = {-1, -1, -1}});
    ASSERT_TRUE(outsideVertex);
    EXPECT_EQ(outsideVertex->hit.t, 2.0f);
    EXPECT_TRUE(outsideVertex->hit.frontFace);

    auto triangleHits = [&](const Ray& ray) {
        int hits = 0;
        for (size_t t = 0; t < world.triangleCount(); ++t) {
            const auto [p0, p1, p2] = cornersOf(world, t);
            hits += intersectTriangle(prepareRay(ray), p0, p1, p2).has_value();
        }
        return hits;
    };
    EXPECT_EQ(triangleHits({.origin = {0, 0, 0}, .direction = {1, 0, 0}}), 2);
    // Corner 7 belongs to 6 triangles: both of each face it is on (each face's diagonal ends there).
    EXPECT_EQ(triangleHits({.origin = {0, 0, 0}, .direction = {1, 1, 1}}), 6);
}

// Watertightness: no ray from inside a closed mesh misses it. 1e5 random directions from the centre
// and from random inner points, and rays aimed at every vertex and at random points of every edge
// (which, rounded to float, lie on the edge or within an ulp of it: where a test that is not
// watertight lets rays through). Every hit is a back face (the meshes face outward) on the surface.
TEST(Bvh, NoRayFromInsideAClosedMeshMisses) {
    RandomRays random(3);
    auto onCube = [](const glm::vec3& p) { return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}); };
    auto onOctahedron = [](const glm::vec3& p) { return std::abs(p.x) + std::abs(p.y) + std::abs(p.z); };
    const std::vector<std::pair<World, std::function<float(const glm::vec3&)>>> meshes = {
        {cube(), onCube}, {octahedron(), onOctahedron}};
    for (const auto& mesh : meshes) {
        const World& world = mesh.first;
        const std::function<float(const glm::vec3&)>& level = mesh.second; // lambdas capture no bindings
        const Bvh bvh = buildBvh(world);
        int misses = 0, frontFaces = 0, offSurface = 0, rays = 0;
        auto cast = [&](const Ray& ray) {
            ++rays;
            const auto hit = closestHit(bvh, ray);
            misses += !hit || !anyHit(bvh, ray);
            if (!hit) return;
            frontFaces += hit->hit.frontFace;
            offSurface += std::abs(level(ray.origin + hit->hit.t * ray.direction) - 1.0f) > 1e-5f;
        };
        auto innerPoint = [&] {
            for (;;) {
                const glm::vec3 p = random.inBox(glm::vec3(-0.9f), glm::vec3(0.9f));
                if (level(p) < 0.9f) return p;
            }
        };
        for (int k = 0; k < 100'000; ++k) {
            const glm::vec3 origin = k % 2 ? glm::vec3(0.0f) : innerPoint();
            cast({.origin = origin, .direction = random.direction()});
        }
        for (size_t t = 0; t < world.triangleCount(); ++t) {
            const auto corners = cornersOf(world, t);
            for (int e = 0; e < 3; ++e) {
                cast({.origin = {0, 0, 0}, .direction = corners[e]});
                for (int k = 0; k < 2'000; ++k) {
                    const float s = random.uniform(0.0f, 1.0f);
                    const glm::vec3 target = corners[e] + s * (corners[(e + 1) % 3] - corners[e]);
                    const glm::vec3 origin = k % 2 ? glm::vec3(0.0f) : innerPoint();
                    cast({.origin = origin, .direction = target - origin});
                }
            }
        }
        EXPECT_EQ(misses, 0) << "of " << rays;
        EXPECT_EQ(frontFaces, 0);
        EXPECT_EQ(offSurface, 0);
        std::printf("closed mesh of %zu triangles: %d rays from inside, %d missed\n", world.triangleCount(),
                    rays, misses);
    }
}

// --- The hierarchy -----------------------------------------------------------------------------

// The layout glsl/bvh_interface.h states: children side by side, each leaf a range of the
// leaf-ordered triangles, every World triangle in exactly one leaf and copied there exactly, every
// box holding its children or triangles, and the depth within SHPROBE_BVH_MAX_DEPTH.
void expectLayout(const World& world, const Bvh& bvh) {
    ASSERT_EQ(bvh.triangles.size(), world.triangleCount());
    ASSERT_EQ(bvh.triangleIds.size(), world.triangleCount());
    std::vector<int> seen(world.triangleCount(), 0);
    for (size_t i = 0; i < bvh.triangleIds.size(); ++i) {
        ASSERT_LT(bvh.triangleIds[i], world.triangleCount());
        ++seen[bvh.triangleIds[i]];
        const auto corners = cornersOf(world, bvh.triangleIds[i]);
        EXPECT_EQ(glm::vec3(bvh.triangles[i].p0), corners[0]);
        EXPECT_EQ(glm::vec3(bvh.triangles[i].p1), corners[1]);
        EXPECT_EQ(glm::vec3(bvh.triangles[i].p2), corners[2]);
    }
    EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), ptrdiff_t(seen.size()));
    auto inside = [](const glsl::BvhNode& box, const glm::vec3& p) {
        return glm::all(glm::lessThanEqual(glm::vec3(box.boundsMin), p)) &&
               glm::all(glm::lessThanEqual(p, glm::vec3(box.boundsMax)));
    };
    std::vector<int> leafOf(world.triangleCount(), 0);
    std::vector<std::pair<uint32_t, int>> stack{{0, 0}};
    int depth = 0;
    while (!stack.empty()) {
        const auto [index, level] = stack.back();
        stack.pop_back();
        depth = std::max(depth, level);
        const glsl::BvhNode& node = bvh.nodes.at(index);
        const auto first = std::bit_cast<uint32_t>(node.boundsMin.w);
        const auto count = std::bit_cast<uint32_t>(node.boundsMax.w);
        if (count > 0) {
            ASSERT_LE(first + count, bvh.triangles.size());
            for (uint32_t i = first; i < first + count; ++i) {
                ++leafOf[i];
                for (const glm::vec4& p : {bvh.triangles[i].p0, bvh.triangles[i].p1, bvh.triangles[i].p2})
                    EXPECT_TRUE(inside(node, glm::vec3(p)));
            }
            continue;
        }
        ASSERT_LT(first + 1, bvh.nodes.size());
        for (uint32_t child : {first, first + 1}) {
            EXPECT_TRUE(inside(node, glm::vec3(bvh.nodes[child].boundsMin)));
            EXPECT_TRUE(inside(node, glm::vec3(bvh.nodes[child].boundsMax)));
            stack.push_back({child, level + 1});
        }
    }
    EXPECT_EQ(std::count(leafOf.begin(), leafOf.end(), 1), ptrdiff_t(leafOf.size()));
    EXPECT_EQ(depth, bvh.depth);
    EXPECT_LE(bvh.depth, SHPROBE_BVH_MAX_DEPTH);
}

TEST(Bvh, LayoutOfRealAndSmallScenes) {
    for (const World* world : {&engineWorld(SHPROBE_GLTF_MODELS_DIR), &openCornellBoxWithBlocks()})
        expectLayout(*world, buildBvh(*world));
    const World single = unitTriangle();
    const Bvh bvh = buildBvh(single);
    ASSERT_EQ(bvh.nodes.size(), 1u);
    expectLayout(single, bvh);
}

// A World without triangles has no node, and no ray hits it.
TEST(Bvh, EmptyWorld) {
    const Bvh bvh = buildBvh(World{});
    EXPECT_TRUE(bvh.nodes.empty());
    EXPECT_FALSE(closestHit(bvh, Ray{}));
    EXPECT_FALSE(anyHit(bvh, Ray{}));
}

// Triangles at exponentially growing distances make the heuristic peel one off at a time, a chain
// as deep as the triangles are many: the build falls back to halving in time to stay within
// SHPROBE_BVH_MAX_DEPTH, and the traversal (whose stack is that deep) still finds every hit.
TEST(Bvh, DepthStaysBoundedOnAChain) {
    World world;
    for (uint32_t k = 0; k < 200; ++k) {
        const float x = std::pow(1.5f, float(k));
        world.positions.insert(world.positions.end(), {{x, 0, 0}, {x, 1, 0}, {x, 0, 1}});
        world.indices.insert(world.indices.end(), {3 * k, 3 * k + 1, 3 * k + 2});
    }
    world.boundsMin = {1, 0, 0};
    world.boundsMax = {std::pow(1.5f, 199.0f), 1, 1};
    const Bvh bvh = buildBvh(world, {.binCount = 2, .maxLeafTriangles = 1});
    expectLayout(world, bvh);
    EXPECT_GT(bvh.depth, 32); // the heuristic did make a chain
    std::printf("a chain of %zu triangles: depth %d\n", world.triangleCount(), bvh.depth);
    int differ = 0;
    for (const Ray& ray : sceneRays(world, 2000, 5)) {
        const auto expected = bruteForceClosest(world, ray);
        const auto got = closestHit(bvh, ray);
        differ += expected.has_value() != got.has_value() ||
                  (expected && (expected->triangle != got->triangle || expected->hit.t != got->hit.t));
    }
    EXPECT_EQ(differ, 0);
}

TEST(Bvh, BadInputsAreRefused) {
    const World triangle = unitTriangle();
    for (const BvhOptions& options :
         {BvhOptions{.binCount = 1}, BvhOptions{.binCount = 257}, BvhOptions{.maxLeafTriangles = 0},
          BvhOptions{.traversalCost = 0.0f}, BvhOptions{.traversalCost = kInfinity}})
        EXPECT_THROW(buildBvh(triangle, options), Error);
    World bad = triangle;
    bad.indices.push_back(0);
    EXPECT_THROW(buildBvh(bad), Error);
    bad = triangle;
    bad.indices[2] = 3;
    EXPECT_THROW(buildBvh(bad), Error);
    bad = triangle;
    bad.positions[1].y = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(buildBvh(bad), Error);
}

// --- Traversals against testing every triangle -------------------------------------------------

// The hierarchy loses nothing: on 2,000 rays in the engine (121k triangles) and 20,000 in the
// Cornell box, closestHit gives the very triangle, t, barycentrics and face that testing every
// triangle with the same test gives (bit for bit: the same arithmetic on the same corners, and the
// same tie rule), and anyHit says whether there is one. No tolerance: the conservative box test
// must not drop a hit, not even one on a box's face or at the current closest t.
TEST(Bvh, TraversalsEqualTestingEveryTriangle) {
    for (auto [world, count] : {std::pair{&engineWorld(SHPROBE_GLTF_MODELS_DIR), 2'000},
                                std::pair{&openCornellBoxWithBlocks(), 20'000}}) {
        const Bvh bvh = buildBvh(*world);
        int differ = 0, anyDiffer = 0, hits = 0;
        for (const Ray& ray : sceneRays(*world, count, 7)) {
            const auto expected = bruteForceClosest(*world, ray);
            const auto got = closestHit(bvh, ray);
            hits += expected.has_value();
            anyDiffer += anyHit(bvh, ray) != expected.has_value();
            if (expected.has_value() != got.has_value()) {
                ++differ;
                continue;
            }
            if (!expected) continue;
            differ += expected->triangle != got->triangle || expected->hit.t != got->hit.t ||
                      expected->hit.u != got->hit.u || expected->hit.v != got->hit.v ||
                      expected->hit.frontFace != got->hit.frontFace;
        }
        EXPECT_EQ(differ, 0);
        EXPECT_EQ(anyDiffer, 0);
        std::printf("%s: %d rays, %d hits, %d differ from testing every triangle\n",
                    world->description.c_str(), count, hits, differ);
    }
}

// --- Against Embree (the cpu's RayCaster, scene/ray_caster.h) --------------------------------------

double secondsSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Random rays in random directions from random points of the bounds (no aimed rays: those ask for
// the tie rule, which Embree does not share), on 2CylinderEngine and the Cornell box, 500,000 each:
// together the 1e6 the comparison is sized for, a few seconds on two busy cores.
//
// The two may differ where a ray passes within rounding of an edge (Embree's robust mode runs its
// own watertight test, with its own rounding, and may give the edge to the other triangle, or a hit
// to a ray grazing a silhouette), and where coplanar triangles overlap: a tie in t that each breaks
// its own way (the Cornell box's blocks stand on the floor, their bottoms in its plane, and rays
// from inside a block meet both). Hence the bounds: hit or miss, and the triangle at a different t,
// may differ for one ray in 10^4 (edge rounding, a set of measure zero up to rounding); another
// triangle at the same t (within 1e-5 of the scene's extent) for one in 100 (the overlaps). Both
// compute t in float from the same coordinates: on the same triangle the mean relative difference
// is held to 1e-5, and the worst to 2e-5 of the scene's extent (relative to t alone, a ray starting
// a hair from a surface would show the coordinates' rounding as a large fraction of a tiny t). On
// the same triangle the points the barycentrics name lie within the same 2e-5 of the extent (u and v
// alone may differ more on a sliver, whose edges are short) and the face always agrees: the cpu
// backends shade what the gpu's walk of the hierarchy would.
TEST(Bvh, AgreesWithEmbree) {
    for (const World* world : {&engineWorld(SHPROBE_GLTF_MODELS_DIR), &openCornellBoxWithBlocks()}) {
        const auto buildStart = std::chrono::steady_clock::now();
        const Bvh bvh = buildBvh(*world);
        const double buildSeconds = secondsSince(buildStart);
        const std::unique_ptr<RayCaster> embree = makeRayCaster(*world); // the cpu's caster, the plugin
        constexpr size_t kRays = 500'000;
        RandomRays random(11);
        std::vector<Ray> rays(kRays);
        for (Ray& ray : rays)
            ray = {.origin = random.inBox(world->boundsMin, world->boundsMax),
                   .direction = random.direction()};

        std::vector<std::optional<RayHit>> ours(kRays);
        const auto oursStart = std::chrono::steady_clock::now();
        for (size_t k = 0; k < kRays; ++k)
            ours[k] = closestHit(bvh, rays[k]);
        const double oursSeconds = secondsSince(oursStart);
        std::vector<std::optional<RayHit>> theirs(kRays);
        const auto theirsStart = std::chrono::steady_clock::now();
        for (size_t k = 0; k < kRays; ++k)
            theirs[k] = embree->closestHit(rays[k]);
        const double theirsSeconds = secondsSince(theirsStart);

        // Hit distances compared in units of the scene's size: both t carry the rounding of the
        // coordinates, an ulp of the scene's extent divided by the cosine of the incidence.
        const double extent = glm::length(world->boundsMax - world->boundsMin);
        size_t hitMiss = 0, tie = 0, triangle = 0, occluded = 0, sameTriangle = 0, face = 0;
        double worstRelative = 0.0, sumRelative = 0.0, worstOfExtent = 0.0, worstBarycentric = 0.0;
        for (size_t k = 0; k < kRays; ++k) {
            if (ours[k].has_value() != theirs[k].has_value()) {
                ++hitMiss;
                continue;
            }
            if (k % 10 == 0) occluded += anyHit(bvh, rays[k]) != embree->anyHit(rays[k]);
            if (!ours[k]) continue;
            const double difference = std::abs(double(ours[k]->hit.t) - theirs[k]->hit.t);
            if (ours[k]->triangle != theirs[k]->triangle) {
                ++(difference <= 1e-5 * extent ? tie : triangle);
                continue;
            }
            face += ours[k]->hit.frontFace != theirs[k]->hit.frontFace;
            const uint32_t* corner = &world->indices[3 * size_t(ours[k]->triangle)];
            const glm::dvec3 p0(world->positions[corner[0]]), p1(world->positions[corner[1]]),
                p2(world->positions[corner[2]]);
            const glm::dvec3 apart = double(ours[k]->hit.u - theirs[k]->hit.u) * (p1 - p0) +
                                     double(ours[k]->hit.v - theirs[k]->hit.v) * (p2 - p0);
            worstBarycentric = std::max(worstBarycentric, glm::length(apart) / extent);
            const double relative = difference / theirs[k]->hit.t;
            worstRelative = std::max(worstRelative, relative);
            worstOfExtent = std::max(worstOfExtent, difference / extent);
            sumRelative += relative;
            ++sameTriangle;
        }
        const double n = double(kRays);
        std::printf("%s: BVH built in %.3f s, %zu nodes, depth %d\n", world->description.c_str(),
                    buildSeconds, bvh.nodes.size(), bvh.depth);
        std::printf("  %zu rays: closestHit %.2f Mrays/s, Embree (the cpu's RayCaster) %.2f Mrays/s (one "
                    "thread each)\n",
                    kRays, n / oursSeconds * 1e-6, n / theirsSeconds * 1e-6);
        std::printf("  hit/miss differ %.2e; another triangle at the same t %.2e, at another t %.2e; "
                    "occluded differs %.2e (of %zu)\n",
                    double(hitMiss) / n, double(tie) / n, double(triangle) / n, double(occluded) / (n / 10),
                    kRays / 10);
        std::printf(
            "  t on the same triangle: relative difference mean %.2e, worst %.2e (%.2e of the extent)\n",
            sumRelative / double(std::max<size_t>(sameTriangle, 1)), worstRelative, worstOfExtent);
        std::printf("  on the same triangle: the points u, v name %.2e of the extent apart at most, the face "
                    "differs for %zu rays\n",
                    worstBarycentric, face);
        EXPECT_LT(double(hitMiss) / n, 1e-4);
        EXPECT_LT(double(triangle) / n, 1e-4);
        EXPECT_LT(double(tie) / n, 1e-2);
        EXPECT_LT(double(occluded) / (n / 10), 1e-4);
        EXPECT_LT(sumRelative / double(std::max<size_t>(sameTriangle, 1)), 1e-5);
        EXPECT_LT(worstOfExtent, 2e-5);
        EXPECT_LT(worstBarycentric, 2e-5);
        EXPECT_EQ(face, 0u);
    }
}

// --- Quality of the splits ---------------------------------------------------------------------

// The binned heuristic makes a hierarchy worth having: a ray in the engine (121k triangles) visits
// on average under 1% as many boxes as there are triangles and tests under 0.1% of the triangles
// (testing every triangle is the alternative). Shadow rays stop at the first hit and visit fewer.
TEST(Bvh, SplitsKeepVisitsFew) {
    const World& world = engineWorld(SHPROBE_GLTF_MODELS_DIR);
    const Bvh bvh = buildBvh(world);
    RandomRays random(13);
    constexpr int kRays = 100'000;
    TraversalCounts closest, any;
    for (int k = 0; k < kRays; ++k) {
        const Ray ray{.origin = random.inBox(world.boundsMin, world.boundsMax),
                      .direction = random.direction()};
        closestHit(bvh, ray, closest);
        anyHit(bvh, ray, any);
    }
    const double nodes = double(closest.nodes) / kRays, triangles = double(closest.triangles) / kRays;
    std::printf("%s: per ray, closestHit visits %.1f boxes and tests %.1f triangles; anyHit %.1f and %.1f\n",
                world.description.c_str(), nodes, triangles, double(any.nodes) / kRays,
                double(any.triangles) / kRays);
    EXPECT_LT(nodes, 0.01 * double(world.triangleCount()));
    EXPECT_LT(triangles, 0.001 * double(world.triangleCount()));
    EXPECT_LE(any.nodes, closest.nodes);
}

} // namespace
} // namespace shprobe
