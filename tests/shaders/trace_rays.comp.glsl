#version 450
// Test module: casts each ray of a buffer against a hierarchy (glsl/bvh_traversal.glsl) with both
// traversals, so that test_bvh_gpu can compare the GPU's hits with scene/bvh.h's, bit for bit.
#extension GL_GOOGLE_include_directive : require

#include "bvh_interface.h"
#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;

// A ray: origin.xyz and tMin in w, direction.xyz and tMax in w.
struct TraceRay {
    vec4 origin;
    vec4 direction;
};
// Per ray: the closest hit's World triangle (0xffffffff: none), t, u and v bits; then its front face
// (1 or 0) and whether the any-hit traversal found a hit (1 or 0).
struct TraceResult {
    uvec4 hit;
    uvec4 flags;
};

layout(set = 0, binding = 0, std430) readonly buffer Nodes { BvhNode bvhNodes[]; };
layout(set = 0, binding = 1, std430) readonly buffer Triangles { BvhTriangle bvhTriangles[]; };
layout(set = 0, binding = 2, std430) readonly buffer TriangleIds { uint bvhTriangleIds[]; };
layout(set = 0, binding = 3, std430) readonly buffer Rays { TraceRay rays[]; };
layout(set = 0, binding = 4, std430) writeonly buffer Results { TraceResult results[]; };
layout(push_constant, std430) uniform Push {
    uint rayCount;
    uint nodeCount;
};

#include "bvh_traversal.glsl"

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint i = gl_GlobalInvocationID.x; i < rayCount; i += stride) {
        TraceRay ray = rays[i];
        BvhHit hit;
        bool closest = bvhClosestHit(nodeCount, ray.origin.xyz, ray.direction.xyz, ray.origin.w, ray.direction.w, hit);
        bool any = bvhAnyHit(nodeCount, ray.origin.xyz, ray.direction.xyz, ray.origin.w, ray.direction.w);
        TraceResult result;
        result.hit = closest ? uvec4(hit.triangle, floatBitsToUint(hit.t), floatBitsToUint(hit.u), floatBitsToUint(hit.v))
                             : uvec4(0xffffffffu, 0u, 0u, 0u);
        result.flags = uvec4(closest && hit.frontFace ? 1u : 0u, any ? 1u : 0u, 0u, 0u);
        results[i] = result;
    }
}
