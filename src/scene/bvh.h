// Ray casting against a World's triangles: a bounding volume hierarchy built once per scene on the
// CPU with the binned surface area heuristic, and the closest-hit and any-hit traversals over it.
// The node and triangle arrays are those of glsl/bvh_interface.h, so that a compute shader walks the
// same hierarchy; the traversals here are that walk's bit-exact model (the CPU's own rays go through
// Embree, scene/ray_caster.h). docs/scene-probes.md, "Ray casting", says how it is built and tested.
//
// The ray/triangle test is the watertight one of Woop, Benthin and Wald, "Watertight Ray/Triangle
// Intersection" (JCGT 2013): a ray through an edge or a vertex shared by triangles hits at least one
// of them, so no ray slips through a closed mesh. The boxes are tested conservatively (Ize, "Robust
// BVH Ray Traversal", JCGT 2013), so the hierarchy loses no hit that testing every triangle finds.
#pragma once
#include "glsl/bvh_interface.h"
#include "scene/scene.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace shprobe {

// The points origin + t direction with tMin <= t <= tMax. The direction must be finite and not
// zero; it need not be a unit vector (t is measured in its lengths).
struct Ray {
    glm::vec3 origin{0.0f};
    glm::vec3 direction{0.0f, 0.0f, 1.0f};
    float tMin = 0.0f;
    float tMax = std::numeric_limits<float>::infinity();
};

// Where a ray meets a triangle: the point origin + t direction = (1 - u - v) p0 + u p1 + v p2.
// The front is the side the winding normal (p1 - p0) x (p2 - p0) points to: the ray hits the front
// when dot(direction, normal) < 0.
struct TriangleHit {
    float t = 0.0f;
    float u = 0.0f;
    float v = 0.0f;
    bool frontFace = false;
};

// The first triangle along a ray: its index in the World (triangle k is indices[3k..3k+2]).
struct RayHit {
    uint32_t triangle = 0;
    TriangleHit hit;
};

struct BvhOptions {
    int binCount = 32;          // candidate split planes per axis are binCount - 1; 2..256
    int maxLeafTriangles = 8;   // a node with more is always split; 1 or more
    float traversalCost = 1.0f; // the cost of visiting a node, in triangle tests; > 0
};

// The hierarchy of a World's triangles (glsl/bvh_interface.h): nodes[0] is the root (no node at all
// for a World without triangles); triangles[i] is the World's triangle triangleIds[i].
struct Bvh {
    std::vector<glsl::BvhNode> nodes;
    std::vector<glsl::BvhTriangle> triangles;
    std::vector<uint32_t> triangleIds;
    int depth = 0; // of the deepest leaf, the root at 0; at most SHPROBE_BVH_MAX_DEPTH
};

// Builds the hierarchy top-down, each node split where the binned surface area heuristic puts the
// lowest expected cost, or made a leaf where that is cheaper (and it holds at most
// maxLeafTriangles). Throws Error(Input) for options out of range, an index count not a multiple of
// 3, an index past the positions or a position that is not finite.
Bvh buildBvh(const World& world, const BvhOptions& options = {});
// What buildBvh refuses in a World, and every caster of rays (scene/ray_caster.h) too: Error(Input)
// "BVH: ..." for an index count not a multiple of 3, an index past the positions or a position that
// is not finite.
void checkBvhWorld(const World& world);

// How much of the hierarchy traversals visited, summed over calls.
struct TraversalCounts {
    uint64_t nodes = 0;     // boxes tested
    uint64_t triangles = 0; // triangle tests
};

// The hit of smallest t in [tMin, tMax], if any; of hits at the same t, the one of the lowest World
// index, so that the answer does not depend on how the hierarchy was built.
std::optional<RayHit> closestHit(const Bvh& bvh, const Ray& ray);
std::optional<RayHit> closestHit(const Bvh& bvh, const Ray& ray, TraversalCounts& counts);
// Whether any triangle, front or back, is hit with t in [tMin, tMax] (a shadow ray): the same answer
// as closestHit(...).has_value(), found without looking for the closest.
bool anyHit(const Bvh& bvh, const Ray& ray);
bool anyHit(const Bvh& bvh, const Ray& ray, TraversalCounts& counts);

// The watertight test on its own, for a ray prepared once (the axis it runs most along, and the
// shear that takes it to +z): the same test the traversals run, for checks against every triangle.
struct PreparedRay {
    glm::vec3 origin{0.0f};
    int kx = 0, ky = 1, kz = 2; // the axes permuted so that kz is the direction's largest
    glm::vec3 shear{0.0f};      // Sx, Sy, Sz of the paper
    float tMin = 0.0f;
    float tMax = 0.0f;
};
PreparedRay prepareRay(const Ray& ray);
// The hit of the ray on triangle (p0, p1, p2) with tMin <= t <= tMax, if any. Points on an edge or
// a vertex hit; a degenerate triangle (zero area seen along the ray) never does.
std::optional<TriangleHit> intersectTriangle(const PreparedRay& ray, const glm::vec3& p0, const glm::vec3& p1,
                                             const glm::vec3& p2);

} // namespace shprobe
