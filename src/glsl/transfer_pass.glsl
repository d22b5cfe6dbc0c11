// What the two transfer modules (shaders/transfer_direct.comp.glsl, transfer_bounce.comp.glsl)
// share: their specialization constants, bindings 0-5 and push constants, and the traversal, the
// basis and the rays they cast. The includer adds its further bindings after including this.
//   set 0, bindings 0-2: readonly buffers, the hierarchy (glsl/bvh_traversal.glsl)
//   set 0, binding 3: readonly buffer, TransferSide sides[] (glsl/transfer_interface.h)
//   set 0, binding 4: buffer, vec4 transfer[]: side s's coefficient i at s * SH_COEFFICIENTS + i; a
//   pass that is not a side's last leaves its sums there unscaled, for the next to carry on
//   set 0, binding 5: buffer, vec4 carried[]: binding 4's layout, what rounding took from those sums
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
layout(set = 0, binding = 5, std430) buffer Carried { vec4 carried[]; };
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

// Adds the pass's sum of coefficient i (its rays alone) to what the side's passes before left, and
// stores the total: times `scale` after the side's last ray, else unscaled for the next pass. A
// million rays are 65,536 passes, and float sums rounded at each would lose a thousandth of a
// plain sum: the total is carried with the error of each addition (Knuth's two-sum, `precise` so
// that no compiler reassociates it), which brings it back to float rounding.
void transferStoreSum(uint s, uint i, vec3 pass, float scale) {
    uint at = s * SH_COEFFICIENTS + i;
    bool first = params.firstRay == 0u;
    vec3 before = first ? vec3(0.0) : transfer[at].rgb;
    precise vec3 lost = first ? vec3(0.0) : carried[at].rgb;
    precise vec3 total = before + pass;
    precise vec3 fromPass = total - before;
    lost += (before - (total - fromPass)) + (pass - fromPass);
    if (transferRaysEnd() == params.strata * params.strata) {
        transfer[at] = vec4((total + lost) * scale, 0.0);
        return;
    }
    transfer[at] = vec4(total, 0.0);
    carried[at] = vec4(lost, 0.0);
}

#endif
