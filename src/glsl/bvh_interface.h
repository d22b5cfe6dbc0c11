// The bounding volume hierarchy of a scene's triangles (scene/bvh.h), laid out so that a compute
// shader can walk the same arrays the CPU builds: nodes in one array, the root first, the two
// children of an interior node side by side; the triangles in leaf order, each leaf a contiguous
// range. Every struct is made of 16-byte vectors, so the std430 layouts equal the C++ ones, which
// static_asserts pin.
#ifndef SHPROBE_BVH_INTERFACE_H
#define SHPROBE_BVH_INTERFACE_H
#include "shared.h"

// The deepest a hierarchy is built (the root at depth 0): a traversal stack of this many entries
// never overflows, since a walk pushes at most one node per level it descends.
#define SHPROBE_BVH_MAX_DEPTH 64

SHPROBE_BEGIN

// One node: its box, and in the w components (uint bits, floatBitsToUint in GLSL) what it holds.
// Interior node (count 0): children at `first` and `first + 1`. Leaf (count > 0): the triangles
// `first` to `first + count - 1` of the leaf-ordered triangle array.
struct BvhNode {
    vec4 boundsMin; // xyz: the box's lower corner; w: first (child or triangle index)
    vec4 boundsMax; // xyz: the box's upper corner; w: count (triangles; 0: interior node)
};
#ifdef __cplusplus
static_assert(sizeof(BvhNode) == 32);
#endif

// A triangle in leaf order: its world-space corners, counter-clockwise seen from its front
// (scene/scene.h). The w components are 0.
struct BvhTriangle {
    vec4 p0;
    vec4 p1;
    vec4 p2;
};
#ifdef __cplusplus
static_assert(sizeof(BvhTriangle) == 48);
#endif

SHPROBE_END

#endif
