// What the two transfer modules (shaders/transfer_direct.comp.glsl, transfer_bounce.comp.glsl)
// share: their specialization constants, bindings 0-4 and push constants, and the traversal, the
// basis and the rays they cast. The includer adds its further bindings after including this.
//   set 0, bindings 0-2: readonly buffers, the hierarchy (glsl/bvh_traversal.glsl)
//   set 0, binding 3: readonly buffer, TransferSide sides[] (glsl/transfer_interface.h)
//   set 0, binding 4: buffer, vec4 transfer[]: side s's coefficient i at s * SH_COEFFICIENTS + i; a
//   pass that is not a side's last leaves its sums there unscaled, for the next to carry on
//   push constants: TransferParams; specialization: 0 = workgroup width, 1 = SH order (1..8);
//   dispatch ceil(sideCount / width) workgroups, one invocation per side.
#ifndef SHPROBE_TRANSFER_PASS_GLSL
#define SHPROBE_TRANSFER_PASS_GLSL
#include "bvh_interface.h"
#include "gpu_interface.h"
#include "transfer_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;

layout(set = 0, binding = 0, std430) readonly buffer Nodes { BvhNode bvhNodes[]; };
layout(set = 0, binding = 1, std430) readonly buffer Triangles { BvhTriangle bvhTriangles[]; };
layout(set = 0, binding = 2, std430) readonly buffer TriangleIds { uint bvhTriangleIds[]; };
layout(set = 0, binding = 3, std430) readonly buffer Sides { TransferSide sides[]; };
layout(set = 0, binding = 4, std430) buffer Transfer { vec4 transfer[]; };
layout(push_constant, std430) uniform Push { TransferParams params; };

#include "bvh_traversal.glsl"
#include "sh_basis.glsl"
#include "transfer_rays.glsl"

// A ray's tMax: +infinity (a bit pattern: GLSL has no infinite literal).
float transferNoLimit() {
    return uintBitsToFloat(0x7f800000u);
}

// The invocation's side index, or false past the chunk.
bool transferSideIndex(out uint s) {
    s = params.firstSide + gl_GlobalInvocationID.x;
    return gl_GlobalInvocationID.x < params.sideCount;
}

// Whether the side casts rays: a vertex no triangle uses casts none, and its transfer is 0.
bool transferCasts(TransferSide side) {
    return (side.ids.w & SHPROBE_SIDE_UNUSED) == 0u;
}

// One past the pass's last ray.
uint transferRaysEnd() {
    return params.firstRay + params.rayCount;
}

// The side's random state before the pass's first ray: two draws per ray before it.
uvec2 transferRayState(TransferSide side) {
    return skipRandomStates(side.ids.xy, 2u * params.firstRay);
}

// What the pass's sums start from: 0, or the sums the side's pass before left.
vec3 transferSumSoFar(uint s, uint i) {
    return params.firstRay == 0u ? vec3(0.0) : transfer[s * SH_COEFFICIENTS + i].rgb;
}

// The factor the pass's sums are stored with: `scale` after the side's last ray, else 1.
float transferStoredScale(float scale) {
    return transferRaysEnd() == params.strata * params.strata ? scale : 1.0;
}

#endif
