// The projection modules' code (project.comp and its storage-image variants, shaders/INTERFACE.md):
// each workgroup writes the solid-angle-weighted sum, over its texels, of L(w) y_i(w) dOmega into
// one partial slot (SH_COEFFICIENTS vec4, rgb used). Sloan, "Stupid Spherical Harmonics (SH)
// Tricks", projection from cube maps with exact texel solid angles.
//
// Positions (i, j) cover the quarter of a face with i, j < ceil(N / 2) (quadrantSize); with each
// comes its column mirror (N - 1 - i, j), row mirror (i, N - 1 - j) and both. The solid angle and
// the normalized (a, b, 1) depend on the position only, and the eight texels of a face pair (two
// opposite faces, four mirror images each) see one direction d with its coordinates' signs
// changed in all eight ways. A sign change of x, y or z multiplies y_lm by +-1 according to its
// parity in that coordinate (basisParity), so one basis evaluation serves eight texels, and each
// coefficient multiplies one of eight signed sums of their radiance (signedSums): per 24 texels,
// three basis evaluations and 3 n^2 multiply-adds instead of 24 and 24 n^2.
//
// The includer defines SHPROBE_STORAGE_FORMAT or not (cubemap_input.glsl) and nothing else.
//   set 0, binding 0: the cube maps (cubemap_input.glsl)
//   set 0, binding 1: buffer, vec4 partials[]: slot s holds SH_COEFFICIENTS vec4 at s * SH_COEFFICIENTS;
//                     workgroup (g, p) writes slot p * gl_NumWorkGroups.x + g
//   push constants: ProjectParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8)
//   dispatch (groups, probes, 1): the invocations share the ceil(N / 2)^2 positions of probe
//   gl_WorkGroupID.y in streams (main), in one loop per face pair. Any groups >= 1 is correct;
//   on llvmpipe the positions per invocation must stay within maxPositionsPerInvocation
//   (dispatch_plan.h, the loop-cap workaround), which shprobe's plan there ensures.
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

// Coefficients reduced per pair of barriers, and their subgroup totals: one entry per subgroup
// and coefficient (a subgroup of one invocation is the worst case), SHPROBE_REDUCTION_ENTRIES
// rounded up to a multiple of the width.
const uint REDUCTION_CHUNK = (SHPROBE_REDUCTION_ENTRIES + gl_WorkGroupSize.x - 1u) / gl_WorkGroupSize.x;
shared vec3 subgroupSums[REDUCTION_CHUNK * gl_WorkGroupSize.x];
shared uint subgroupCount;

// Workaround(llvmpipe, Mesa 22.3): the reduction relies only on subgroupAdd, subgroupElect,
// gl_SubgroupID and gl_SubgroupInvocationID, not on gl_SubgroupSize or gl_NumSubgroups: lavapipe
// reports a subgroup size of 32 under LP_NATIVE_VECTOR_WIDTH=1024 on 256-bit CPUs while running
// subgroups of 16, and rounds gl_NumSubgroups down when the width is not a multiple of it. So the
// subgroups are counted (countSubgroups) and each subgroup's size is its subgroupAdd(1); where
// both built-ins are right, gl_NumSubgroups and gl_SubgroupSize would do. (START_STREAM takes
// gl_SubgroupSize only as a stream width, correct for any power of two.)
void countSubgroups() {
    if (gl_LocalInvocationIndex == 0u) subgroupCount = 0u;
    barrier();
    if (subgroupElect()) atomicMax(subgroupCount, gl_SubgroupID + 1u);
    barrier();
}

// Sums the subgroup totals of coefficients first .. first + REDUCTION_CHUNK - 1 (fewer at the end),
// stored at subgroupSums[c * width + subgroup], over the workgroup and writes them to the partial
// slot. Works for any number of subgroups, including more subgroups than a subgroup has
// invocations (lavapipe: 32 of 8), and for widths that are not a multiple of the subgroup size.
void reduceChunk(uint first, uint slot, uint lanes) {
    barrier();
    if (gl_SubgroupID == 0u) {
        for (uint c = 0u; c < REDUCTION_CHUNK && first + c < SH_COEFFICIENTS; ++c) {
            vec3 total = vec3(0.0f);
            for (uint s = gl_SubgroupInvocationID; s < subgroupCount; s += lanes)
                total += subgroupSums[c * gl_WorkGroupSize.x + s];
            total = subgroupAdd(total);
            if (gl_LocalInvocationIndex == 0u) partials[slot + first + c] = vec4(total, 0.0f);
        }
    }
    barrier(); // subgroupSums is reused by the next chunk
}

// The eight texels of face pair p (faces 2p and 2p + 1) at a position and its mirror images see
// one direction d with its coordinates' signs changed in all eight ways (face table in
// texel_geometry.h): the opposite face, the mirrored column and the mirrored row each negate a
// fixed set of axes, bit 0 x, bit 1 y, bit 2 z:
//   +X ( c, -b, -a), -X (-c, -b,  a): opposite x and z, column z, row y
//   +Y ( a,  c,  b), -Y ( a, -c, -b): opposite y and z, column x, row z
//   +Z ( a, -b,  c), -Z (-a, -b, -c): opposite x and z, column x, row y
const uvec3 PAIR_REFLECTIONS[3] = uvec3[3](uvec3(5, 4, 2), uvec3(6, 1, 4), uvec3(5, 1, 2));

// The axes in which y_lm is odd, as a mask like the reflections' (basisParity).
uint oddAxes(int l, int m) {
    uvec3 parity = basisParity(l, m);
    return parity.x | (parity.y << 1u) | (parity.z << 2u);
}

// In: radiance[s] is the texel whose direction is d with the axes in s negated. Out: radiance[p]
// is the sum over s of (-1)^|p & s| radiance[s], a Walsh-Hadamard transform: the sum that y_lm(d)
// multiplies when y_lm is odd in the axes p, since y_lm(d reflected in s) = (-1)^|p & s| y_lm(d).
// Twelve butterflies (24 vec3 additions and subtractions) give all eight.
void signedSums(inout vec3 radiance[8]) {
#define BUTTERFLY(s, t) { vec3 plus = radiance[s] + radiance[t]; radiance[t] = radiance[s] - radiance[t]; radiance[s] = plus; }
    BUTTERFLY(0, 1) BUTTERFLY(2, 3) BUTTERFLY(4, 5) BUTTERFLY(6, 7)
    BUTTERFLY(0, 2) BUTTERFLY(1, 3) BUTTERFLY(4, 6) BUTTERFLY(5, 7)
    BUTTERFLY(0, 4) BUTTERFLY(1, 5) BUTTERFLY(2, 6) BUTTERFLY(3, 7)
#undef BUTTERFLY
}

// The solid angle of texel (i, j). On an odd face the middle column (row) is its own mirror image
// and is read twice: each read counts half.
float positionWeight(uint i, uint j, uint faceSize) {
    float weight = texelSolidAngleFp32(i, j, faceSize);
    if (2u * i + 1u == faceSize) weight *= 0.5f;
    if (2u * j + 1u == faceSize) weight *= 0.5f;
    return weight;
}

void main() {
#define DECLARE_SUM(k, l, m) vec3 sum##k = vec3(0.0f);
    SH_EACH_COEFFICIENT(DECLARE_SUM)

    uint faceSize = params.faceSize;
    uint quadrant = quadrantSize(faceSize);
    int firstLayer = int(gl_WorkGroupID.y) * 6;
    START_STREAM(quadrant)
    // Workaround(llvmpipe, Mesa 22.3): for speed, face pair by face pair, eight texels at a time;
    // one pass reading all 24 texels of a position ran 20% slower on lavapipe (docs/gpu-path.md).
    // Both give the same sums, and another device may prefer the one pass. PAIR is a literal, so
    // the masks are constants, and radiance[] and basis[] are indexed by constants only.
#define READ_MIRRORS(face, mask)                                      \
    radiance[mask] = readRadiance(walk.i, walk.j, face);              \
    radiance[mask ^ column] = readRadiance(mirrorI, walk.j, face);    \
    radiance[mask ^ row] = readRadiance(walk.i, mirrorJ, face);       \
    radiance[mask ^ column ^ row] = readRadiance(mirrorI, mirrorJ, face);
#define ACCUMULATE(k, l, m) \
    if (k < SH_COEFFICIENTS) sum##k += (basis[k] * weight) * radiance[oddAxes(l, m)];
#define PROJECT_PAIR(PAIR)                                                                       \
    {                                                                                            \
        const uint opposite = PAIR_REFLECTIONS[PAIR].x;                                          \
        const uint column = PAIR_REFLECTIONS[PAIR].y, row = PAIR_REFLECTIONS[PAIR].z;            \
        PositionWalk walk = startWalk(first, lanes, quadrant);                                   \
        for (uint position = first; position < end; position += lanes) {                        \
            uint mirrorI = faceSize - 1u - walk.i, mirrorJ = faceSize - 1u - walk.j;             \
            vec3 radiance[8];                                                                    \
            READ_MIRRORS(firstLayer + 2 * PAIR, 0u)                                              \
            READ_MIRRORS(firstLayer + 2 * PAIR + 1, opposite)                                    \
            signedSums(radiance);                                                                \
            float weight = positionWeight(walk.i, walk.j, faceSize);                             \
            vec2 ab = vec2(texelCenterCoord(walk.i, faceSize), texelCenterCoord(walk.j, faceSize)); \
            float basis[SH_BASIS_CAPACITY];                                                      \
            shEvalBasis(orientToFace(2u * PAIR, normalize(vec3(ab, 1.0f))), basis);              \
            SH_EACH_COEFFICIENT(ACCUMULATE)                                                      \
            stepWalk(walk, quadrant);                                                            \
        }                                                                                        \
    }
    PROJECT_PAIR(0) PROJECT_PAIR(1) PROJECT_PAIR(2)

    // Workaround(llvmpipe, Mesa 22.3): for speed, every sum is reduced over its subgroup before the
    // first barrier. llvmpipe runs a shader with barriers as a coroutine, and a value live across a
    // barrier is written to the coroutine's frame wherever it is assigned: every iteration, for the
    // sums (order 5 15% faster, docs/benchmark.md). The subgroup totals are assigned once, and a few
    // chunks of them take few barriers (each barrier switches every subgroup). Harmless elsewhere:
    // the subgroup adds are needed anyway.
#define SUBGROUP_TOTAL(k, l, m) vec3 subgroupTotal##k = k < SH_COEFFICIENTS ? subgroupAdd(sum##k) : vec3(0.0f);
    SH_EACH_COEFFICIENT(SUBGROUP_TOTAL)
    countSubgroups();
    uint subgroupLanes = subgroupAdd(1u); // invocations in this subgroup, as the hardware groups them
    uint slot = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * SH_COEFFICIENTS;
#define REDUCE(k, l, m)                                                                                 \
    if (k < SH_COEFFICIENTS) {                                                                          \
        const uint chunkIndex = uint(k) % REDUCTION_CHUNK;                                              \
        if (subgroupElect()) subgroupSums[chunkIndex * gl_WorkGroupSize.x + gl_SubgroupID] = subgroupTotal##k; \
        if (chunkIndex + 1u == REDUCTION_CHUNK || k + 1 == SH_COEFFICIENTS)                            \
            reduceChunk(uint(k) - chunkIndex, slot, subgroupLanes);                                     \
    }
    SH_EACH_COEFFICIENT(REDUCE)
}
