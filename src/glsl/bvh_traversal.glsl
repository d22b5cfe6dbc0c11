// Ray casting in a compute shader against the hierarchy scene/bvh.h builds (glsl/bvh_interface.h):
// the closest-hit and any-hit traversals of scene/bvh.cpp, written to give the same answers bit for
// bit (the same float operations in the same order), with nothing past Vulkan 1.1 compute (no ray
// query extension), so that it runs on lavapipe. test_bvh_gpu compares the two hit for hit.
//
// The includer declares, before including this file, the three arrays as buffers:
//     BvhNode bvhNodes[];         // the root first (Bvh::nodes)
//     BvhTriangle bvhTriangles[]; // in leaf order (Bvh::triangles)
//     uint bvhTriangleIds[];      // the World index of each (Bvh::triangleIds)
// and calls bvhClosestHit / bvhAnyHit with a ray (origin + t direction, tMin <= t <= tMax).
//
// The ray/triangle test is the watertight one of Woop, Benthin and Wald, "Watertight Ray/Triangle
// Intersection" (JCGT 2013); the boxes are tested conservatively after Ize, "Robust BVH Ray
// Traversal" (JCGT 2013). See scene/bvh.cpp for why each step is as it is.
//
// Rounding: the C++ is compiled without fused multiply-adds, and every product there is rounded
// before the sum that uses it. SPIR-V lets a Vulkan compiler fuse a * b + c into one fma unless the
// result is decorated NoContraction, which GLSL's `precise` asks for: each value below made of a
// product and a sum is `precise` so that it is rounded as the C++ rounds it on any device. (Lavapipe
// happens not to fuse these: test_bvh_gpu also passes with them dropped.) Divisions are IEEE ones on
// lavapipe (LLVM's fdiv); Vulkan only asks for 2.5 ulp, so elsewhere t, u and v may differ in the
// last bits, which test_bvh_gpu would show.
// The comparisons rely on IEEE infinities and NaNs (a slab distance 0 * infinity is NaN and is
// ignored), which lavapipe keeps.
#ifndef SHPROBE_BVH_TRAVERSAL_GLSL
#define SHPROBE_BVH_TRAVERSAL_GLSL
#include "bvh_interface.h"

// Where a ray meets a triangle: origin + t direction = (1 - u - v) p0 + u p1 + v p2; `triangle` is
// the World index; frontFace: the ray sees the side the winding normal points to.
struct BvhHit {
    uint triangle;
    float t;
    float u;
    float v;
    bool frontFace;
};

// The ray prepared once for the watertight test (section 3 of Woop et al.): the axis it runs most
// along becomes z (x and y swapped where it runs backwards, to keep the winding), and the shear
// that takes the direction to +z.
struct BvhPreparedRay {
    vec3 origin;
    int kx, ky, kz;
    vec3 shear; // Sx, Sy, Sz of the paper
    float tMin;
    float tMax;
};

BvhPreparedRay bvhPrepareRay(vec3 origin, vec3 direction, float tMin, float tMax) {
    vec3 a = abs(direction);
    BvhPreparedRay ray;
    ray.origin = origin;
    ray.kz = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
    ray.kx = (ray.kz + 1) % 3;
    ray.ky = (ray.kx + 1) % 3;
    if (direction[ray.kz] < 0.0) {
        int swap = ray.kx;
        ray.kx = ray.ky;
        ray.ky = swap;
    }
    ray.shear = vec3(direction[ray.kx] / direction[ray.kz], direction[ray.ky] / direction[ray.kz],
                     1.0 / direction[ray.kz]);
    ray.tMin = tMin;
    ray.tMax = tMax;
    return ray;
}

// The sheared coordinates of a corner relative to the origin. `precise`: p[kx] - Sx p[kz] with the
// product rounded first, as in C++ (fused, the edge functions of two triangles sharing an edge
// could differ from the C++ ones).
vec3 bvhShear(BvhPreparedRay ray, vec3 corner) {
    vec3 p = corner - ray.origin;
    precise float x = p[ray.kx] - ray.shear.x * p[ray.kz];
    precise float y = p[ray.ky] - ray.shear.y * p[ray.kz];
    precise float z = ray.shear.z * p[ray.kz];
    return vec3(x, y, z);
}

// The exact error of the float product a b: a b = fl(a b) + the result (Dekker's product, the
// factors split in halves by 4097 = 2^12 + 1). `precise`: fused, the splits would not be exact.
float bvhProductError(float a, float b, float product) {
    precise float ca = 4097.0 * a;
    precise float aHi = ca - (ca - a);
    precise float aLo = a - aHi;
    precise float cb = 4097.0 * b;
    precise float bHi = cb - (cb - b);
    precise float bLo = b - bHi;
    precise float error = ((aHi * bHi - product) + aHi * bLo + aLo * bHi) + aLo * bLo;
    return error;
}

// Whether the exact product a b is -0: one factor zero, their signs different.
bool bvhNegativeZeroProduct(float a, float b) {
    return (a == 0.0 || b == 0.0) && ((floatBitsToUint(a) ^ floatBitsToUint(b)) & 0x80000000u) != 0u;
}

// The edge function a.x b.y - a.y b.x. Where it rounds to 0 the C++ recomputes it in double, where
// the products are exact; a shader may have no doubles (shaderFloat64), so here the two products'
// exact errors are taken instead: the rounded products are then equal, the exact difference is the
// difference of the errors, which double holds exactly, so both round it once to the same float.
// A zero takes the sign IEEE gives the double difference (-0 only for -0 - +0), spelled out, as
// the C++ passes it on to u and v and a compiler may not keep the sign of a zero sum.
float bvhEdgeFunction(vec3 a, vec3 b) {
    precise float p = a.x * b.y;
    precise float q = a.y * b.x;
    precise float e = p - q;
    if (e != 0.0) return e;
    precise float exact = bvhProductError(a.x, b.y, p) - bvhProductError(a.y, b.x, q);
    if (exact != 0.0) return exact;
    bool positiveZeroQ = (a.y == 0.0 || b.x == 0.0) && !bvhNegativeZeroProduct(a.y, b.x);
    bool negative = bvhNegativeZeroProduct(a.x, b.y) && positiveZeroQ;
    return uintBitsToFloat(negative ? 0x80000000u : 0u);
}

// The watertight test without culling: the hit of the ray on (p0, p1, p2) with tMin <= t <= tMax.
// Points on an edge or a vertex hit; a degenerate triangle never does. `triangle` is left to the caller.
bool bvhIntersectTriangle(BvhPreparedRay ray, vec3 p0, vec3 p1, vec3 p2, out BvhHit hit) {
    vec3 a = bvhShear(ray, p0);
    vec3 b = bvhShear(ray, p1);
    vec3 c = bvhShear(ray, p2);
    float u = bvhEdgeFunction(c, b); // the weight of p0
    float v = bvhEdgeFunction(a, c); // of p1
    float w = bvhEdgeFunction(b, a); // of p2
    hit.triangle = 0u;
    hit.t = 0.0;
    hit.u = 0.0;
    hit.v = 0.0;
    hit.frontFace = false;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    precise float determinant = u + v + w;
    if (determinant == 0.0) return false;
    precise float inverse = 1.0 / determinant;
    precise float t = (u * a.z + v * b.z + w * c.z) * inverse;
    if (!(t >= ray.tMin && t <= ray.tMax)) return false;
    hit.t = t;
    hit.u = v * inverse;
    hit.v = w * inverse;
    hit.frontFace = determinant > 0.0;
    return true;
}

// The far end of a box's interval widened by 2 gamma(3) of its size, gamma(n) = n u / (1 - n u)
// (Ize, "Robust BVH Ray Traversal"). The factor is the C++ constant's float, bit for bit (folded
// from the formula, a compiler might round it otherwise); `precise`: t + |t| 2gamma3, the product
// rounded first, as in C++.
float bvhWidened(float t) {
    const float twoGamma3 = uintBitsToFloat(0x34c00002u); // 0x1.800004p-22
    precise float widened = t + abs(t) * twoGamma3;
    return widened;
}

// Whether the ray meets the node's box within [tMin, tMax]; `near`: where it enters. A NaN slab
// distance (the ray parallel to the slab and in its plane) fails both comparisons and is ignored.
bool bvhHitsBox(BvhNode node, vec3 origin, vec3 inverse, float tMin, float tMax, out float near) {
    float enter = tMin, leave = tMax;
    for (int axis = 0; axis < 3; ++axis) {
        bool negative = (floatBitsToUint(inverse[axis]) & 0x80000000u) != 0u;
        float lo = negative ? node.boundsMax[axis] : node.boundsMin[axis];
        float hi = negative ? node.boundsMin[axis] : node.boundsMax[axis];
        float t0 = (lo - origin[axis]) * inverse[axis];
        float t1 = (hi - origin[axis]) * inverse[axis];
        enter = t0 > enter ? t0 : enter;
        leave = t1 < leave ? t1 : leave;
    }
    near = enter;
    return enter <= bvhWidened(leave);
}

uint bvhFirst(BvhNode node) {
    return floatBitsToUint(node.boundsMin.w);
}
uint bvhCount(BvhNode node) {
    return floatBitsToUint(node.boundsMax.w);
}

// The walk of scene/bvh.cpp, nearer child first, with a stack of the farther children and where
// the ray enters them. With anyHit, it stops at the first hit; otherwise it keeps the hit of
// smallest t and, of hits at the same t, the one of the lowest World index, whatever the leaf
// order; a hit on a triangle's back counts as at t (1 + backShift) (0: as at t, exactly).
// `nodeCount` 0: an empty hierarchy.
bool bvhTrace(uint nodeCount, vec3 origin, vec3 direction, float tMin, float tMax, bool anyHit, float backShift,
              out BvhHit best) {
    best.triangle = 0u;
    best.t = 0.0;
    best.u = 0.0;
    best.v = 0.0;
    best.frontFace = false;
    if (nodeCount == 0u) return false;
    BvhPreparedRay prepared = bvhPrepareRay(origin, direction, tMin, tMax);
    vec3 inverse = 1.0 / direction;
    uint stackNode[SHPROBE_BVH_MAX_DEPTH];
    float stackNear[SHPROBE_BVH_MAX_DEPTH];
    int size = 0;
    bool found = false;
    float near;
    if (!bvhHitsBox(bvhNodes[0], origin, inverse, tMin, prepared.tMax, near)) return false;
    uint current = 0u;
    for (;;) {
        BvhNode node = bvhNodes[current];
        uint count = bvhCount(node);
        bool descended = false;
        if (count > 0u) {
            uint first = bvhFirst(node);
            for (uint i = first; i < first + count; ++i) {
                BvhTriangle triangle = bvhTriangles[i];
                BvhHit hit;
                if (!bvhIntersectTriangle(prepared, triangle.p0.xyz, triangle.p1.xyz, triangle.p2.xyz, hit))
                    continue;
                uint id = bvhTriangleIds[i];
                if (anyHit) {
                    hit.triangle = id;
                    best = hit;
                    return true;
                }
                float key = hit.frontFace ? hit.t : hit.t * (1.0 + backShift);
                if (!found || key < prepared.tMax || (key == prepared.tMax && id < best.triangle)) {
                    hit.triangle = id;
                    best = hit;
                    found = true;
                    prepared.tMax = key;
                }
            }
        } else {
            uint first = bvhFirst(node);
            float nearA, nearB;
            bool hitA = bvhHitsBox(bvhNodes[first], origin, inverse, tMin, prepared.tMax, nearA);
            bool hitB = bvhHitsBox(bvhNodes[first + 1u], origin, inverse, tMin, prepared.tMax, nearB);
            if (hitA && hitB) {
                bool aFirst = nearA <= nearB;
                stackNode[size] = aFirst ? first + 1u : first;
                stackNear[size] = aFirst ? nearB : nearA;
                ++size;
                current = aFirst ? first : first + 1u;
                descended = true;
            } else if (hitA || hitB) {
                current = hitA ? first : first + 1u;
                descended = true;
            }
        }
        if (descended) continue;
        // The next pending node the ray still reaches before the limit.
        bool pending = false;
        while (size > 0) {
            --size;
            if (!(stackNear[size] > bvhWidened(prepared.tMax))) {
                pending = true;
                break;
            }
        }
        if (!pending) return found;
        current = stackNode[size];
    }
    return found;
}

// The hit of smallest t in [tMin, tMax], if any (scene/bvh.h's closestHit).
bool bvhClosestHit(uint nodeCount, vec3 origin, vec3 direction, float tMin, float tMax, out BvhHit hit) {
    return bvhTrace(nodeCount, origin, direction, tMin, tMax, false, 0.0, hit);
}

// bvhClosestHit with hits on a triangle's back counted as at t (1 + 2^-16): where a ray passes
// through an edge joining a front and a back face, both at the same t but for rounding, it enters
// the solid through the front one, whatever the rounding (the raster capture draws back faces as
// much farther, capture.vert). A back face meant to be in front of a front face is hidden only
// when the two lie within 2^-16 of the distance.
bool bvhClosestHitFrontFirst(uint nodeCount, vec3 origin, vec3 direction, float tMin, float tMax, out BvhHit hit) {
    return bvhTrace(nodeCount, origin, direction, tMin, tMax, false, 1.0 / 65536.0, hit);
}

// Whether any triangle, front or back, is hit with t in [tMin, tMax] (scene/bvh.h's anyHit).
bool bvhAnyHit(uint nodeCount, vec3 origin, vec3 direction, float tMin, float tMax) {
    BvhHit hit;
    return bvhTrace(nodeCount, origin, direction, tMin, tMax, true, 0.0, hit);
}

#endif
