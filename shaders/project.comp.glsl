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
//   set 0, binding 0: readonly buffer, vec4 texels[]: RGBA32F, one band of rows of all six faces,
//                     face after face (Vulkan layer order): texel (face, i, firstRow + r) at
//                     face * rowCount * faceSize + r * faceSize + i. When the whole cube map fits
//                     one binding (rowCount = faceSize) this is the plain face-major layout.
//   set 0, binding 1: buffer, vec4 partials[]: slot s holds SH_COEFFICIENTS vec4 at s * SH_COEFFICIENTS
//   push constants: ProjectParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8)
//   each invocation strides over the band's positions; dispatch any number of workgroups. lavapipe
//   ends loops after 65535 iterations (nested loops count against the outermost), so keep the
//   positions per invocation times 6 (1 + n^2 + n^2 / 2) below that at order n.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_EXT_control_flow_attributes : require

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

    uint faceSize = params.faceSize;
    uint bandTexels = params.rowCount * faceSize;
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint position = gl_GlobalInvocationID.x; position < bandTexels; position += stride) {
        uint row = position / faceSize;
        uint column = position - row * faceSize;
        uint j = params.firstRow + row;
        float weight = texelSolidAngle(column, j, faceSize);
        vec3 unit = normalize(vec3(texelCenterCoord(column, faceSize), texelCenterCoord(j, faceSize), 1.0f));
        for (uint face = 0u; face < 6u; ++face) {
            vec3 radiance = texels[face * bandTexels + position].rgb * weight;
            float basis[SH_BASIS_CAPACITY];
            shEvalBasis(orientToFace(face, unit), basis);
            // Unrolled once the order is known, so sums and basis live in registers.
            for (uint i = 0u; i < SH_COEFFICIENTS; ++i) sums[i] += radiance * basis[i];
        }
    }

    countSubgroups();
    uint lanes = subgroupAdd(1u); // invocations in this subgroup, as the hardware groups them
    uint slot = (params.partialOffset + gl_WorkGroupID.x) * SH_COEFFICIENTS;
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i) {
        vec3 total = workgroupSum(sums[i], lanes);
        if (gl_LocalInvocationIndex == 0u) partials[slot + i] = vec4(total, 0.0f);
    }
}
