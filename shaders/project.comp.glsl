#version 450
// Projects cube-map texels onto SH: each workgroup writes the solid-angle-weighted sum
// sum L(w) y_i(w) dOmega over its texels into one partial slot (SH_COEFFICIENTS vec4, rgb used).
// Sloan, "Stupid SH Tricks" (seed 000), projection from cube maps with exact texel solid angles.
//
// Each invocation takes texel positions (i, j) and handles that position on all six faces: the
// solid angle and the normalized (a, b, 1) depend on the position only, so they are computed once
// for six texels, and each face's direction is a signed permutation of the same vector.
//
// Interface (shaders/INTERFACE.md):
//   set 0, binding 0: sampler2DArray cubemaps: probe p's face f is layer 6p + f (any sampled format;
//                     read with texelFetch, so the sampler does not matter), N x N texels
//   set 0, binding 1: buffer, vec4 partials[]: slot s holds SH_COEFFICIENTS vec4 at s * SH_COEFFICIENTS;
//                     workgroup (g, p) writes slot p * gl_NumWorkGroups.x + g
//   push constants: ProjectParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8)
//   dispatch (groups, probes, 1): each invocation strides over the N^2 positions of probe
//   gl_WorkGroupID.y. lavapipe ends loops after 65535 iterations (nested loops count against the
//   outermost), so keep the positions per invocation times 6 (1 + n^2 + n^2 / 2) below that at order n.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_EXT_control_flow_attributes : require

#include "gpu_interface.h"
#include "position_walk.glsl"
#include "texel_geometry.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;

#include "sh_basis.glsl"

layout(set = 0, binding = 0) uniform sampler2DArray cubemaps;
layout(set = 0, binding = 1, std430) writeonly buffer Partials { vec4 partials[]; };
layout(push_constant, std430) uniform Push { ProjectParams params; };

// One entry per subgroup; a subgroup of one invocation is the worst case.
shared vec3 subgroupSums[gl_WorkGroupSize.x];
shared uint subgroupCount;

// The reduction relies only on subgroupAdd, subgroupElect, gl_SubgroupID and
// gl_SubgroupInvocationID. gl_SubgroupSize and gl_NumSubgroups are not used: lavapipe (Mesa 22.3)
// reports a subgroup size of 32 under LP_NATIVE_VECTOR_WIDTH=1024 on 256-bit CPUs while running
// subgroups of 16, and rounds gl_NumSubgroups down when the width is not a multiple of it.
void countSubgroups() {
    if (gl_LocalInvocationIndex == 0u) subgroupCount = 0u;
    barrier();
    if (subgroupElect()) atomicMax(subgroupCount, gl_SubgroupID + 1u);
    barrier();
}

// Sums value over the workgroup; the result is valid in invocation 0. Works for any number of
// subgroups, including more subgroups than a subgroup has invocations (lavapipe: 32 of 8), and for
// widths that are not a multiple of the subgroup size.
vec3 workgroupSum(vec3 value, uint lanes) {
    vec3 subgroupTotal = subgroupAdd(value);
    if (subgroupElect()) subgroupSums[gl_SubgroupID] = subgroupTotal;
    barrier();
    vec3 total = vec3(0.0f);
    if (gl_SubgroupID == 0u) {
        for (uint s = gl_SubgroupInvocationID; s < subgroupCount; s += lanes) total += subgroupSums[s];
        total = subgroupAdd(total);
    }
    barrier(); // subgroupSums is reused by the next call
    return total;
}

void main() {
    // Arrays sized for order 8, of which the first SH_COEFFICIENTS are used: glslang refuses
    // constant indices into arrays sized by a specialization constant, and with constant indices
    // after unrolling the compiler keeps the sums in registers.
    vec3 sums[SH_BASIS_CAPACITY];
    [[unroll]] for (uint i = 0u; i < SH_COEFFICIENTS; ++i) sums[i] = vec3(0.0f);

    uint faceSize = params.faceSize;
    uint positions = faceSize * faceSize;
    int firstLayer = int(gl_WorkGroupID.y) * 6;
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    PositionWalk walk = startWalk(gl_GlobalInvocationID.x, stride, faceSize);
    for (uint position = gl_GlobalInvocationID.x; position < positions; position += stride) {
        float weight = texelSolidAngle(walk.i, walk.j, faceSize);
        vec3 unit = normalize(vec3(texelCenterCoord(walk.i, faceSize), texelCenterCoord(walk.j, faceSize), 1.0f));
        for (uint face = 0u; face < 6u; ++face) {
            vec3 radiance = texelFetch(cubemaps, ivec3(walk.i, walk.j, firstLayer + int(face)), 0).rgb * weight;
            float basis[SH_BASIS_CAPACITY];
            shEvalBasis(orientToFace(face, unit), basis);
            [[unroll]] for (uint k = 0u; k < SH_COEFFICIENTS; ++k) sums[k] += radiance * basis[k];
        }
        stepWalk(walk, faceSize);
    }

    countSubgroups();
    uint lanes = subgroupAdd(1u); // invocations in this subgroup, as the hardware groups them
    uint slot = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * SH_COEFFICIENTS;
    for (uint k = 0u; k < SH_COEFFICIENTS; ++k) {
        vec3 total = workgroupSum(sums[k], lanes);
        if (gl_LocalInvocationIndex == 0u) partials[slot + k] = vec4(total, 0.0f);
    }
}
