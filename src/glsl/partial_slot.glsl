// What the projection modules share (project.comp, project_equirect.comp and their storage-image
// variants, shaders/INTERFACE.md): the signed sums of texels whose directions differ in coordinate
// signs, one accumulator per coefficient, and the workgroup's reduction of them into its partial
// slot, which reduce.comp sums.
//
// The includer enables GL_KHR_shader_subgroup_basic and GL_KHR_shader_subgroup_arithmetic, declares
// the workgroup size and SH_ORDER and includes sh_basis.glsl first. In main:
//   SH_EACH_COEFFICIENT(SH_DECLARE_SUM)   declares sum0, sum1, ... = 0
//   SH_EACH_COEFFICIENT(SH_ACCUMULATE)    adds (basis[k] * weight) * radiance[SH_ODD_AXES(l, m)] to sum k,
//                                         from the includer's float basis[], float weight and
//                                         vec3 radiance[8] after signedSums
//   SH_WRITE_PARTIAL_SLOT                 once, at the end: the workgroup's sums into its slot
// Binding: set 0, binding 1: buffer, vec4 partials[]: slot s holds SH_COEFFICIENTS vec4 at
// s * SH_COEFFICIENTS; workgroup (g, p) writes slot p * gl_NumWorkGroups.x + g.
#ifndef SHPROBE_PARTIAL_SLOT_GLSL
#define SHPROBE_PARTIAL_SLOT_GLSL
#include "gpu_interface.h"

layout(set = 0, binding = 1, std430) writeonly buffer Partials { vec4 partials[]; };

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

// The axes in which y_lm is odd, as a mask, bit 0 x, bit 1 y, bit 2 z. y_lm is Re or Im of
// (x + iy)^|m| (terms x^(|m| - 2k) y^(2k) for cos(m phi), m > 0; x^(|m| - 1 - 2k) y^(2k + 1) for
// sin(|m| phi), m < 0) times a polynomial in z of parity l - |m|; so for D = diag(+-1, +-1, +-1),
// y_lm(D d) = y_lm(d) (-1)^(sum of the parities of the negated axes). The rule is a
// constant expression of the literals l and m, so that every use indexes radiance[] by a constant
// in the SPIR-V already. Called as a function, each of project.comp's 192 uses was a call for the
// driver to inline and fold: lavapipe created the pipeline twice as slowly (docs/gpu-path.md,
// "Start-up").
#define SH_ODD_AXES(l, m)                                                                           \
    ((m) > 0 ? ((m) & 1) | ((((l) - (m)) & 1) << 2)                                                 \
             : (m) < 0 ? ((-(m) - 1) & 1) | 2 | ((((l) + (m)) & 1) << 2) : (((l) & 1) << 2))

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

#define SH_DECLARE_SUM(k, l, m) vec3 sum##k = vec3(0.0f);
#define SH_ACCUMULATE(k, l, m) \
    if (k < SH_COEFFICIENTS) sum##k += (basis[k] * weight) * radiance[SH_ODD_AXES(l, m)];

// Workaround(llvmpipe, Mesa 22.3): for speed, every sum is reduced over its subgroup before the
// first barrier. llvmpipe runs a shader with barriers as a coroutine, and a value live across a
// barrier is written to the coroutine's frame wherever it is assigned: every iteration, for the
// sums (order 5 15% faster, docs/benchmark.md). The subgroup totals are assigned once, and a few
// chunks of them take few barriers (each barrier switches every subgroup). Harmless elsewhere:
// the subgroup adds are needed anyway.
#define SH_SUBGROUP_TOTAL(k, l, m) vec3 subgroupTotal##k = k < SH_COEFFICIENTS ? subgroupAdd(sum##k) : vec3(0.0f);
#define SH_REDUCE(k, l, m)                                                                              \
    if (k < SH_COEFFICIENTS) {                                                                          \
        const uint chunkIndex = uint(k) % REDUCTION_CHUNK;                                              \
        if (subgroupElect()) subgroupSums[chunkIndex * gl_WorkGroupSize.x + gl_SubgroupID] = subgroupTotal##k; \
        if (chunkIndex + 1u == REDUCTION_CHUNK || k + 1 == SH_COEFFICIENTS)                            \
            reduceChunk(uint(k) - chunkIndex, slot, subgroupLanes);                                     \
    }
// subgroupLanes: the invocations in this subgroup, as the hardware groups them.
#define SH_WRITE_PARTIAL_SLOT                                                                    \
    SH_EACH_COEFFICIENT(SH_SUBGROUP_TOTAL)                                                       \
    countSubgroups();                                                                            \
    uint subgroupLanes = subgroupAdd(1u);                                                        \
    uint slot = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * SH_COEFFICIENTS;   \
    SH_EACH_COEFFICIENT(SH_REDUCE)

#endif
