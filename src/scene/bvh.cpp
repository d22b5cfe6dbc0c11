#include "scene/bvh.h"

#include "common/error.h"

#include <glm/common.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <utility>

namespace shprobe {

namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();

[[noreturn]] void fail(const std::string& problem) {
    throw Error(ErrorKind::Input, "BVH: " + problem);
}

// --- Building ----------------------------------------------------------------------------------

struct Box {
    glm::vec3 lo{kInfinity};
    glm::vec3 hi{-kInfinity};

    void grow(const glm::vec3& point) {
        lo = glm::min(lo, point);
        hi = glm::max(hi, point);
    }
    void grow(const Box& box) {
        lo = glm::min(lo, box.lo);
        hi = glm::max(hi, box.hi);
    }
    // Half the surface area: the heuristic compares ratios of areas only.
    float halfArea() const {
        if (!(lo.x <= hi.x)) return 0.0f; // empty
        const glm::vec3 d = hi - lo;
        return d.x * d.y + d.y * d.z + d.z * d.x;
    }
};

// What the heuristic reads of each World triangle.
struct Primitives {
    std::vector<Box> boxes;
    std::vector<glm::vec3> centroids;
};

// The nodes of one range of the triangle order still to split.
struct Task {
    uint32_t node = 0;
    uint32_t begin = 0;
    uint32_t end = 0;
    int depth = 0;
};

struct Split {
    int axis = -1; // -1: none better than a leaf
    int bin = 0;   // triangles in bins 0..bin go left
    float cost = kInfinity;
};

void checkOptions(const BvhOptions& options) {
    if (options.binCount < 2 || options.binCount > 256)
        fail("binCount " + std::to_string(options.binCount) + " is not in 2..256");
    if (options.maxLeafTriangles < 1)
        fail("maxLeafTriangles " + std::to_string(options.maxLeafTriangles) + " is below 1");
    if (!(options.traversalCost > 0.0f) || !std::isfinite(options.traversalCost))
        fail("traversalCost " + std::to_string(options.traversalCost) + " is not a positive number");
}

std::array<glm::vec3, 3> corners(const World& world, size_t triangle) {
    return {world.positions[world.indices[3 * triangle]], world.positions[world.indices[3 * triangle + 1]],
            world.positions[world.indices[3 * triangle + 2]]};
}

Primitives primitivesOf(const World& world) {
    Primitives primitives;
    primitives.boxes.resize(world.triangleCount());
    primitives.centroids.resize(world.triangleCount());
    for (size_t t = 0; t < world.triangleCount(); ++t) {
        for (const glm::vec3& p : corners(world, t))
            primitives.boxes[t].grow(p);
        primitives.centroids[t] = 0.5f * (primitives.boxes[t].lo + primitives.boxes[t].hi);
    }
    return primitives;
}

int ceilLog2(uint32_t n) {
    return n <= 1 ? 0 : int(std::bit_width(n - 1));
}

// The bin of a centroid along `axis`, the same function for the heuristic and the partition.
struct Binning {
    int axis = 0;
    int count = 0;
    float lo = 0.0f;
    float scale = 0.0f; // bins per unit length

    int binOf(const glm::vec3& centroid) const {
        const int bin = int((centroid[axis] - lo) * scale);
        return std::clamp(bin, 0, count - 1);
    }
};

Binning binningOf(const Box& centroidBox, int axis, int binCount) {
    const float extent = centroidBox.hi[axis] - centroidBox.lo[axis];
    return {axis, binCount, centroidBox.lo[axis], float(binCount) / extent};
}

// The best of the binCount - 1 planes along one axis by the surface area heuristic: the cost of a
// split, relative to one triangle test, is traversalCost + (A_L N_L + A_R N_R) / A.
Split bestSplitAlong(const Primitives& primitives, std::span<const uint32_t> range, const Binning& binning,
                     float parentArea, float traversalCost) {
    std::vector<Box> bins(binning.count);
    std::vector<uint32_t> counts(binning.count, 0);
    for (uint32_t triangle : range) {
        const int bin = binning.binOf(primitives.centroids[triangle]);
        bins[bin].grow(primitives.boxes[triangle]);
        ++counts[bin];
    }
    std::vector<float> rightCost(binning.count, 0.0f); // A_R N_R of bins bin+1..count-1
    Box right;
    uint32_t rightCount = 0;
    for (int bin = binning.count - 1; bin > 0; --bin) {
        right.grow(bins[bin]);
        rightCount += counts[bin];
        rightCost[bin - 1] = right.halfArea() * float(rightCount);
    }
    Split best;
    Box left;
    uint32_t leftCount = 0;
    for (int bin = 0; bin + 1 < binning.count; ++bin) {
        left.grow(bins[bin]);
        leftCount += counts[bin];
        if (leftCount == 0 || leftCount == range.size()) continue;
        const float weighted = left.halfArea() * float(leftCount) + rightCost[bin];
        const float cost = traversalCost + (parentArea > 0.0f ? weighted / parentArea : 0.0f);
        if (cost < best.cost) best = {binning.axis, bin, cost};
    }
    return best;
}

class Builder {
  public:
    Builder(const World& world, const BvhOptions& options)
        : options_(options), primitives_(primitivesOf(world)) {
        order_.resize(world.triangleCount());
        for (uint32_t t = 0; t < order_.size(); ++t)
            order_[t] = t;
    }

    // Splits depth first; the two children of a node are appended together, so they lie side by side.
    void build(Bvh& bvh) {
        bvh.nodes.push_back({});
        std::vector<Task> tasks{{0, 0, uint32_t(order_.size()), 0}};
        while (!tasks.empty()) {
            const Task task = tasks.back();
            tasks.pop_back();
            bvh.depth = std::max(bvh.depth, task.depth);
            const uint32_t middle = splitPoint(task, bvh.nodes[task.node]);
            if (middle == task.end) continue; // a leaf
            const auto children = uint32_t(bvh.nodes.size());
            bvh.nodes.resize(bvh.nodes.size() + 2);
            setContents(bvh.nodes[task.node], children, 0);
            tasks.push_back({children + 1, middle, task.end, task.depth + 1});
            tasks.push_back({children, task.begin, middle, task.depth + 1});
        }
    }

    const std::vector<uint32_t>& order() const { return order_; }

  private:
    static void setContents(glsl::BvhNode& node, uint32_t first, uint32_t count) {
        node.boundsMin.w = std::bit_cast<float>(first);
        node.boundsMax.w = std::bit_cast<float>(count);
    }

    // Sets the node's box and, for a leaf, its triangles; returns where the range splits, or its
    // end for a leaf.
    uint32_t splitPoint(const Task& task, glsl::BvhNode& node) {
        const std::span<uint32_t> range(order_.data() + task.begin, task.end - task.begin);
        Box box, centroidBox;
        for (uint32_t triangle : range) {
            box.grow(primitives_.boxes[triangle]);
            centroidBox.grow(primitives_.centroids[triangle]);
        }
        node.boundsMin = glm::vec4(box.lo, 0.0f);
        node.boundsMax = glm::vec4(box.hi, 0.0f);
        const uint32_t middle = partition(task, range, box, centroidBox);
        if (middle == task.end) setContents(node, task.begin, uint32_t(range.size()));
        return middle;
    }

    uint32_t partition(const Task& task, std::span<uint32_t> range, const Box& box, const Box& centroidBox) {
        const auto count = uint32_t(range.size());
        if (count <= 1) return task.end;
        Split best;
        Binning bestBinning;
        for (int axis = 0; axis < 3; ++axis) {
            if (!(centroidBox.hi[axis] > centroidBox.lo[axis])) continue;
            const Binning binning = binningOf(centroidBox, axis, options_.binCount);
            const Split split =
                bestSplitAlong(primitives_, range, binning, box.halfArea(), options_.traversalCost);
            if (split.cost < best.cost) {
                best = split;
                bestBinning = binning;
            }
        }
        const bool fits = count <= uint32_t(options_.maxLeafTriangles);
        if (fits && !(best.cost < float(count))) return task.end; // a leaf is cheaper
        if (best.axis >= 0) {
            const auto left = std::partition(range.begin(), range.end(), [&](uint32_t triangle) {
                return bestBinning.binOf(primitives_.centroids[triangle]) <= best.bin;
            });
            const auto leftCount = uint32_t(left - range.begin());
            // Halving from either child must still end within SHPROBE_BVH_MAX_DEPTH.
            if (task.depth + 1 + ceilLog2(std::max(leftCount, count - leftCount)) <= SHPROBE_BVH_MAX_DEPTH)
                return task.begin + leftCount;
        }
        return medianSplit(task, range, centroidBox);
    }

    // Halves the range at the median centroid along the box's longest axis: where the heuristic
    // finds no split (every centroid in one point) or its split would make the tree too deep.
    uint32_t medianSplit(const Task& task, std::span<uint32_t> range, const Box& centroidBox) {
        const glm::vec3 extent = centroidBox.hi - centroidBox.lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
        const auto middle = range.begin() + range.size() / 2;
        std::nth_element(range.begin(), middle, range.end(), [&](uint32_t a, uint32_t b) {
            return primitives_.centroids[a][axis] < primitives_.centroids[b][axis];
        });
        return task.begin + uint32_t(range.size() / 2);
    }

    const BvhOptions& options_;
    Primitives primitives_;
    std::vector<uint32_t> order_; // World triangle indices, each leaf a contiguous range
};

// --- Traversal ---------------------------------------------------------------------------------

uint32_t firstOf(const glsl::BvhNode& node) {
    return std::bit_cast<uint32_t>(node.boundsMin.w);
}
uint32_t countOf(const glsl::BvhNode& node) {
    return std::bit_cast<uint32_t>(node.boundsMax.w);
}

// The far end of a box's interval widened by 2 gamma(3) of its size, gamma(n) = n u / (1 - n u),
// as Ize ("Robust BVH Ray Traversal") shows covers the rounding of the slab distances; applied to
// the current closest t too, so that a triangle computed at that t is never cut off by its box.
float widened(float t) {
    constexpr float u = std::numeric_limits<float>::epsilon() / 2;
    constexpr float twoGamma3 = 2 * (3 * u / (1 - 3 * u));
    return t + std::abs(t) * twoGamma3;
}

struct BoxRay {
    glm::vec3 origin;
    glm::vec3 inverse; // 1 / direction: +-infinity along an axis the ray is parallel to
};

// Whether the ray meets the box within [tMin, tMax]; `near` is where it enters. A slab distance
// that is NaN (the ray parallel to the slab and in its plane) fails both comparisons and is
// ignored, which counts the ray as inside that slab.
bool hitsBox(const glsl::BvhNode& node, const BoxRay& ray, float tMin, float tMax, float& near) {
    float enter = tMin, leave = tMax;
    for (int axis = 0; axis < 3; ++axis) {
        const bool negative = std::signbit(ray.inverse[axis]);
        const float lo = negative ? node.boundsMax[axis] : node.boundsMin[axis];
        const float hi = negative ? node.boundsMin[axis] : node.boundsMax[axis];
        const float t0 = (lo - ray.origin[axis]) * ray.inverse[axis];
        const float t1 = (hi - ray.origin[axis]) * ray.inverse[axis];
        enter = t0 > enter ? t0 : enter;
        leave = t1 < leave ? t1 : leave;
    }
    near = enter;
    return enter <= widened(leave);
}

struct NoCounts {
    void node() {}
    void triangle() {}
};
struct Counting {
    TraversalCounts& counts;
    void node() { ++counts.nodes; }
    void triangle() { ++counts.triangles; }
};

// A node to visit later and where the ray enters its box.
struct Pending {
    uint32_t node;
    float near;
};

// Walks the hierarchy nearer child first, calling visitLeaf(node) on each leaf the ray reaches
// within [tMin, limit()] until it returns true; limit() may shrink as hits are found.
template <typename Counter, typename Limit, typename VisitLeaf>
void walk(const Bvh& bvh, const Ray& ray, Counter& counter, const Limit& limit, const VisitLeaf& visitLeaf) {
    if (bvh.nodes.empty()) return;
    const BoxRay boxRay{ray.origin, 1.0f / ray.direction};
    std::array<Pending, SHPROBE_BVH_MAX_DEPTH> stack;
    int size = 0;
    float near;
    counter.node();
    if (!hitsBox(bvh.nodes[0], boxRay, ray.tMin, limit(), near)) return;
    uint32_t current = 0;
    for (;;) {
        const glsl::BvhNode& node = bvh.nodes[current];
        if (countOf(node) > 0) {
            if (visitLeaf(node)) return;
        } else {
            const uint32_t first = firstOf(node);
            float nearA, nearB;
            counter.node();
            counter.node();
            const bool hitA = hitsBox(bvh.nodes[first], boxRay, ray.tMin, limit(), nearA);
            const bool hitB = hitsBox(bvh.nodes[first + 1], boxRay, ray.tMin, limit(), nearB);
            if (hitA && hitB) {
                const bool aFirst = nearA <= nearB;
                stack[size++] = aFirst ? Pending{first + 1, nearB} : Pending{first, nearA};
                current = aFirst ? first : first + 1;
                continue;
            }
            if (hitA || hitB) {
                current = hitA ? first : first + 1;
                continue;
            }
        }
        // The next pending node the ray still reaches before the limit.
        do {
            if (size == 0) return;
            --size;
        } while (stack[size].near > widened(limit()));
        current = stack[size].node;
    }
}

template <typename Counter>
std::optional<RayHit> closestHitWith(const Bvh& bvh, const Ray& ray, Counter counter) {
    PreparedRay prepared = prepareRay(ray);
    std::optional<RayHit> best;
    walk(
        bvh, ray, counter, [&] { return prepared.tMax; },
        [&](const glsl::BvhNode& leaf) {
            const uint32_t first = firstOf(leaf);
            for (uint32_t i = first; i < first + countOf(leaf); ++i) {
                counter.triangle();
                const glsl::BvhTriangle& triangle = bvh.triangles[i];
                const auto hit = intersectTriangle(prepared, triangle.p0, triangle.p1, triangle.p2);
                if (!hit) continue;
                const uint32_t id = bvh.triangleIds[i];
                // Ties at equal t go to the lowest World index, whatever the leaf order (the test
                // already bounds t by the closest so far).
                if (!best || hit->t < best->hit.t || (hit->t == best->hit.t && id < best->triangle)) {
                    best = RayHit{id, *hit};
                    prepared.tMax = hit->t;
                }
            }
            return false;
        });
    return best;
}

template <typename Counter> bool anyHitWith(const Bvh& bvh, const Ray& ray, Counter counter) {
    const PreparedRay prepared = prepareRay(ray);
    bool found = false;
    walk(
        bvh, ray, counter, [&] { return prepared.tMax; },
        [&](const glsl::BvhNode& leaf) {
            const uint32_t first = firstOf(leaf);
            for (uint32_t i = first; i < first + countOf(leaf) && !found; ++i) {
                counter.triangle();
                const glsl::BvhTriangle& triangle = bvh.triangles[i];
                found = intersectTriangle(prepared, triangle.p0, triangle.p1, triangle.p2).has_value();
            }
            return found;
        });
    return found;
}

// The sheared 2D coordinates of a corner relative to the origin (section 3 of Woop et al.).
struct Sheared {
    float x, y, z;
};
Sheared shear(const PreparedRay& ray, const glm::vec3& corner) {
    const glm::vec3 p = corner - ray.origin;
    return {p[ray.kx] - ray.shear.x * p[ray.kz], p[ray.ky] - ray.shear.y * p[ray.kz],
            ray.shear.z * p[ray.kz]};
}

// The edge function of the sheared edge (a, b) at the origin. Where it rounds to 0, the paper
// recomputes it in double, where the products are exact, so that its sign is exact.
float edgeFunction(const Sheared& a, const Sheared& b) {
    const float e = a.x * b.y - a.y * b.x;
    if (e != 0.0f) return e;
    return float(double(a.x) * double(b.y) - double(a.y) * double(b.x));
}

} // namespace

void checkBvhWorld(const World& world) {
    if (world.indices.size() % 3 != 0)
        fail(std::to_string(world.indices.size()) + " indices are not a multiple of 3");
    if (world.indices.size() / 3 >= std::numeric_limits<uint32_t>::max()) fail("too many triangles");
    for (uint32_t index : world.indices)
        if (index >= world.positions.size())
            fail("index " + std::to_string(index) + " past the " + std::to_string(world.positions.size()) +
                 " positions");
    for (const glm::vec3& p : world.positions)
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            fail("a position is not finite");
}

Bvh buildBvh(const World& world, const BvhOptions& options) {
    checkOptions(options);
    checkBvhWorld(world);
    Bvh bvh;
    if (world.triangleCount() == 0) return bvh;
    Builder builder(world, options);
    builder.build(bvh);
    for (uint32_t id : builder.order()) {
        const auto [p0, p1, p2] = corners(world, id);
        bvh.triangles.push_back({glm::vec4(p0, 0.0f), glm::vec4(p1, 0.0f), glm::vec4(p2, 0.0f)});
        bvh.triangleIds.push_back(id);
    }
    return bvh;
}

// Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection": the axis the ray runs most along
// becomes z (x and y swapped where it runs backwards, to keep the winding), and the shear that
// takes the direction to +z.
PreparedRay prepareRay(const Ray& ray) {
    const glm::vec3 d = ray.direction;
    const glm::vec3 a = glm::abs(d);
    PreparedRay prepared;
    prepared.origin = ray.origin;
    prepared.kz = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
    prepared.kx = (prepared.kz + 1) % 3;
    prepared.ky = (prepared.kx + 1) % 3;
    if (d[prepared.kz] < 0.0f) std::swap(prepared.kx, prepared.ky);
    prepared.shear = {d[prepared.kx] / d[prepared.kz], d[prepared.ky] / d[prepared.kz],
                      1.0f / d[prepared.kz]};
    prepared.tMin = ray.tMin;
    prepared.tMax = ray.tMax;
    return prepared;
}

// The test of Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection", without culling: the
// three edge functions of the sheared triangle at the origin, each computed the same way (up to
// sign) for the two triangles sharing the edge, so a point on it is in at least one of them.
// Their sum is the projected area, positive when the ray sees the front (the winding normal
// against the direction).
std::optional<TriangleHit> intersectTriangle(const PreparedRay& ray, const glm::vec3& p0, const glm::vec3& p1,
                                             const glm::vec3& p2) {
    const Sheared a = shear(ray, p0), b = shear(ray, p1), c = shear(ray, p2);
    const float u = edgeFunction(c, b); // the weight of p0
    const float v = edgeFunction(a, c); // of p1
    const float w = edgeFunction(b, a); // of p2
    if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return std::nullopt;
    const float determinant = u + v + w;
    if (determinant == 0.0f) return std::nullopt;
    const float inverse = 1.0f / determinant;
    const float t = (u * a.z + v * b.z + w * c.z) * inverse;
    if (!(t >= ray.tMin && t <= ray.tMax)) return std::nullopt;
    return TriangleHit{t, v * inverse, w * inverse, determinant > 0.0f};
}

std::optional<RayHit> closestHit(const Bvh& bvh, const Ray& ray) {
    return closestHitWith(bvh, ray, NoCounts{});
}
std::optional<RayHit> closestHit(const Bvh& bvh, const Ray& ray, TraversalCounts& counts) {
    return closestHitWith(bvh, ray, Counting{counts});
}
bool anyHit(const Bvh& bvh, const Ray& ray) {
    return anyHitWith(bvh, ray, NoCounts{});
}
bool anyHit(const Bvh& bvh, const Ray& ray, TraversalCounts& counts) {
    return anyHitWith(bvh, ray, Counting{counts});
}

} // namespace shprobe
