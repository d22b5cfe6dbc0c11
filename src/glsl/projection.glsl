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
// parity in that coordinate (SH_ODD_AXES, partial_slot.glsl), so one basis evaluation serves eight
// texels, and each coefficient multiplies one of eight signed sums of their radiance (signedSums):
// per 24 texels, three basis evaluations and 3 n^2 multiply-adds instead of 24 and 24 n^2.
//
// The includer defines SHPROBE_STORAGE_FORMAT or not (cubemap_input.glsl) and nothing else.
//   set 0, binding 0: the cube maps (cubemap_input.glsl)
//   set 0, binding 1: the partial slots (partial_slot.glsl): workgroup (g, p) writes slot
//                     p * gl_NumWorkGroups.x + g
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
#include "partial_slot.glsl"

layout(push_constant, std430) uniform Push { ProjectParams params; };

// The eight texels of face pair p (faces 2p and 2p + 1) at a position and its mirror images see
// one direction d with its coordinates' signs changed in all eight ways (face table in
// texel_geometry.h): the opposite face, the mirrored column and the mirrored row each negate a
// fixed set of axes, bit 0 x, bit 1 y, bit 2 z:
//   +X ( c, -b, -a), -X (-c, -b,  a): opposite x and z, column z, row y
//   +Y ( a,  c,  b), -Y ( a, -c, -b): opposite y and z, column x, row z
//   +Z ( a, -b,  c), -Z (-a, -b, -c): opposite x and z, column x, row y
const uvec3 PAIR_REFLECTIONS[3] = uvec3[3](uvec3(5, 4, 2), uvec3(6, 1, 4), uvec3(5, 1, 2));

// The solid angle of texel (i, j). On an odd face the middle column (row) is its own mirror image
// and is read twice: each read counts half.
float positionWeight(uint i, uint j, uint faceSize) {
    float weight = texelSolidAngleFp32(i, j, faceSize);
    if (2u * i + 1u == faceSize) weight *= 0.5f;
    if (2u * j + 1u == faceSize) weight *= 0.5f;
    return weight;
}

void main() {
    SH_EACH_COEFFICIENT(SH_DECLARE_SUM)

    uint faceSize = params.faceSize;
    uint quadrant = quadrantSize(faceSize);
    int firstLayer = int(gl_WorkGroupID.y) * 6;
    START_STREAM(quadrant)
    // Workaround(llvmpipe, Mesa 22.3): for speed, face pair by face pair, eight texels at a time;
    // one pass reading all 24 texels of a position ran slower on lavapipe (docs/gpu-path.md).
    // Both give the same sums, and another device may prefer the one pass. PAIR is a literal, so
    // the masks are constants, and radiance[] and basis[] are indexed by constants only.
#define READ_MIRRORS(face, mask)                                      \
    radiance[mask] = readRadiance(walk.i, walk.j, face);              \
    radiance[mask ^ column] = readRadiance(mirrorI, walk.j, face);    \
    radiance[mask ^ row] = readRadiance(walk.i, mirrorJ, face);       \
    radiance[mask ^ column ^ row] = readRadiance(mirrorI, mirrorJ, face);
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
            SH_EACH_COEFFICIENT(SH_ACCUMULATE)                                                   \
            stepWalk(walk, quadrant);                                                            \
        }                                                                                        \
    }
    PROJECT_PAIR(0) PROJECT_PAIR(1) PROJECT_PAIR(2)

    SH_WRITE_PARTIAL_SLOT
}
