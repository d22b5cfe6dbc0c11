// The projection modules' code (project.comp and its storage-image variants, shaders/INTERFACE.md):
// each workgroup writes the solid-angle-weighted sum, over its texels, of L(w) y_i(w) dOmega into
// one partial slot (SH_COEFFICIENTS vec4, rgb used). Sloan, "Stupid SH Tricks" (seed 000),
// projection from cube maps with exact texel solid angles.
//
// Each invocation takes texel positions (i, j) and handles that position on all six faces: the
// solid angle and the normalized (a, b, 1) depend on the position only, so they are computed once
// for six texels. Opposite faces' directions at one position differ only in the signs of two
// coordinates, and a sign change of x, y or z multiplies y_lm by +-1 according to its parity in
// that coordinate (basisParity). So the basis is evaluated once per face pair, and each
// coefficient takes the sum or the difference of the pair's radiance: per six texels, three basis
// evaluations and 3 n^2 multiply-adds instead of six and 6 n^2.
//
// The includer defines SHPROBE_STORAGE_FORMAT or not (cubemap_input.glsl) and nothing else.
//   set 0, binding 0: the cube maps (cubemap_input.glsl)
//   set 0, binding 1: buffer, vec4 partials[]: slot s holds SH_COEFFICIENTS vec4 at s * SH_COEFFICIENTS;
//                     workgroup (g, p) writes slot p * gl_NumWorkGroups.x + g
//   push constants: ProjectParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8)
//   dispatch (groups, probes, 1): the invocations share the N^2 positions of probe gl_WorkGroupID.y
//   in streams (main). lavapipe ends loops after 65535 iterations (nested loops count against the
//   outermost): keep the positions per invocation times 6 (1 + n^2 + n^2 / 2) below that at order n.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#include "gpu_interface.h"
#include "position_walk.glsl"
#include "texel_geometry.h"
#include "cubemap_input.glsl"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;

#include "sh_basis.glsl"

layout(set = 0, binding = 1, std430) writeonly buffer Partials { vec4 partials[]; };
layout(push_constant, std430) uniform Push { ProjectParams params; };

// One entry per subgroup; a subgroup of one invocation is the worst case.
shared vec3 subgroupSums[gl_WorkGroupSize.x];
shared uint subgroupCount;

// The reduction relies only on subgroupAdd, subgroupElect, gl_SubgroupID and
// gl_SubgroupInvocationID, not on gl_SubgroupSize or gl_NumSubgroups: lavapipe (Mesa 22.3)
// reports a subgroup size of 32 under LP_NATIVE_VECTOR_WIDTH=1024 on 256-bit CPUs while running
// subgroups of 16, and rounds gl_NumSubgroups down when the width is not a multiple of it.
// (START_STREAM takes gl_SubgroupSize only as a stream width, correct for any power of two.)
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

// Face pair p is faces 2p (+axis) and 2p + 1 (-axis); at the same position the opposite face's
// direction negates two coordinates (face table in texel_geometry.h):
//   +X ( c, -b, -a), -X (-c, -b,  a): x and z
//   +Y ( a,  c,  b), -Y ( a, -c, -b): y and z
//   +Z ( a, -b,  c), -Z (-a, -b, -c): x and z
const uvec3 NEGATED_BY_OPPOSITE_FACE[3] = uvec3[3](uvec3(1, 0, 1), uvec3(0, 1, 1), uvec3(1, 0, 1));

// L(near) + L(far) y_lm(far direction) / y_lm(near direction). The sign is a constant once l, m and
// the pair are, so this is one addition or subtraction, shared by coefficients of equal parity.
vec3 pairSum(vec3 near, vec3 far, int l, int m, uint pair) {
    return near + reflectionSign(basisParity(l, m), NEGATED_BY_OPPOSITE_FACE[pair]) * far;
}

void main() {
#define DECLARE_SUM(k, l, m) vec3 sum##k = vec3(0.0f);
    SH_EACH_COEFFICIENT(DECLARE_SUM)

    uint faceSize = params.faceSize;
    int firstLayer = int(gl_WorkGroupID.y) * 6;
    START_STREAM(faceSize)
    PositionWalk walk = startWalk(first, lanes, faceSize);
    for (uint position = first; position < end; position += lanes) {
        // All reads first: llvmpipe calls a function per texel fetch, around which the sums are spilled.
#define READ_FACE(f) vec3 radiance##f = readRadiance(walk.i, walk.j, firstLayer + f);
        READ_FACE(0) READ_FACE(1) READ_FACE(2) READ_FACE(3) READ_FACE(4) READ_FACE(5)
        float weight = texelSolidAngle(walk.i, walk.j, faceSize);
        vec3 unit = normalize(vec3(texelCenterCoord(walk.i, faceSize), texelCenterCoord(walk.j, faceSize), 1.0f));
#define ACCUMULATE(k, l, m) if (k < SH_COEFFICIENTS) sum##k += basis[k] * pairSum(near, far, l, m, pair);
#define ACCUMULATE_PAIR(PAIR, NEAR, FAR)                        \
        {                                                       \
            const uint pair = PAIR;                             \
            vec3 near = NEAR * weight, far = FAR * weight;      \
            float basis[SH_BASIS_CAPACITY];                     \
            shEvalBasis(orientToFace(2u * pair, unit), basis);  \
            SH_EACH_COEFFICIENT(ACCUMULATE)                     \
        }
        ACCUMULATE_PAIR(0u, radiance0, radiance1)
        ACCUMULATE_PAIR(1u, radiance2, radiance3)
        ACCUMULATE_PAIR(2u, radiance4, radiance5)
        stepWalk(walk, faceSize);
    }

    countSubgroups();
    uint subgroupLanes = subgroupAdd(1u); // invocations in this subgroup, as the hardware groups them
    uint slot = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * SH_COEFFICIENTS;
#define REDUCE(k, l, m)                                                                \
    if (k < SH_COEFFICIENTS) {                                                     \
        vec3 total = workgroupSum(sum##k, subgroupLanes);                          \
        if (gl_LocalInvocationIndex == 0u) partials[slot + k] = vec4(total, 0.0f); \
    }
    SH_EACH_COEFFICIENT(REDUCE)
}
