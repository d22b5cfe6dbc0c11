#version 450
// Projects cube-map texels onto SH: each workgroup writes the solid-angle-weighted sum
// sum L(w) y_i(w) dOmega over its texels, one partial slot (SH_COEFFICIENTS vec4, rgb used).
// Sloan, "Stupid SH Tricks" (seed 000), projection from cube maps with exact texel solid angles.
//
// Interface (shaders/INTERFACE.md):
//   set 0, binding 0: readonly buffer, vec4 texels[]: RGBA32F, texel firstTexel at index 0
//                     (layout: face after face in Vulkan layer order, rows top to bottom)
//   set 0, binding 1: buffer, vec4 partials[]: slot s holds SH_COEFFICIENTS vec4 at s * SH_COEFFICIENTS
//   push constants: ProjectParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8)
//   each invocation strides over the dispatch's texels; dispatch any number of workgroups.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#include "gpu_interface.h"
#include "texel_geometry.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;
#include "sh_basis.glsl"

layout(set = 0, binding = 0, std430) readonly buffer Texels { vec4 texels[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Partials { vec4 partials[]; };
layout(push_constant, std430) uniform Push { ProjectParams params; };

// One entry per subgroup; a subgroup of one invocation is the worst case.
shared vec3 subgroupSums[gl_WorkGroupSize.x];
shared uint subgroupCount;

vec3 weightedRadiance(uint texel, out vec3 direction) {
    uint faceTexels = params.faceSize * params.faceSize;
    uint index = params.firstTexel + texel;
    uint face = index / faceTexels;
    uint row = (index - face * faceTexels) / params.faceSize;
    uint column = index - face * faceTexels - row * params.faceSize;
    float a = texelCenterCoord(column, params.faceSize);
    float b = texelCenterCoord(row, params.faceSize);
    direction = normalize(faceDirection(face, a, b));
    return texels[texel].rgb * texelSolidAngle(column, row, params.faceSize);
}

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
    vec3 sums[SH_COEFFICIENTS];
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i) sums[i] = vec3(0.0f);

    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint texel = gl_GlobalInvocationID.x; texel < params.texelCount; texel += stride) {
        vec3 direction;
        vec3 radiance = weightedRadiance(texel, direction);
        float basis[SH_COEFFICIENTS];
        shEvalBasis(direction, basis);
        for (uint i = 0u; i < SH_COEFFICIENTS; ++i) sums[i] += radiance * basis[i];
    }

    countSubgroups();
    uint lanes = subgroupAdd(1u); // invocations in this subgroup, as the hardware groups them
    uint slot = (params.partialOffset + gl_WorkGroupID.x) * SH_COEFFICIENTS;
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i) {
        vec3 total = workgroupSum(sums[i], lanes);
        if (gl_LocalInvocationIndex == 0u) partials[slot + i] = vec4(total, 0.0f);
    }
}
