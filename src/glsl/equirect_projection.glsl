// The equirect projection modules' code (project_equirect.comp and its storage-image variants,
// shaders/INTERFACE.md): projects W x H equirect maps directly, without a cube map, each pixel
// weighted by the exact solid angle of its row, (2 pi / W)(cos theta_j - cos theta_j+1) (the double
// reference's weight, sh/projection.h). Each workgroup writes the sum, over its pixels, of
// L(w) y_i(w) dOmega into one partial slot, in the layout reduce.comp sums (partial_slot.glsl), so
// reduce and convolve serve both projections unchanged.
//
// Positions (equirect_geometry.h): (i, j) with j < ceil(H / 2) and, for even W, i < ceil(W / 4);
// with each come its row mirror (i, H - 1 - j), which negates y, the column mirror W - 1 - i (x),
// the half turn i + W / 2 (x and z) and W / 2 - 1 - i (z), and their row mirrors: eight pixels
// seeing one direction with its coordinates' signs changed in all eight ways, so one basis
// evaluation and n^2 multiply-adds of signed sums serve them, as for a face pair of project.comp.
// For odd W there is no half turn: i < ceil(W / 2), four pixels, the z-negated four being zero.
// A column or row that is its own mirror image (the middle of an odd W / 2 or W, or of an odd H)
// is read twice at half weight.
//
// The includer defines SHPROBE_STORAGE_FORMAT or not (cubemap_input.glsl) and nothing else.
//   set 0, binding 0: the equirect maps, probe p at layer p (cubemap_input.glsl, named equirects)
//   set 0, binding 1: the partial slots (partial_slot.glsl): workgroup (g, p) writes slot
//                     p * gl_NumWorkGroups.x + g
//   push constants: EquirectParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8)
//   dispatch (groups, probes, 1): the invocations share the equirectProjectionPositions(W, H)
//   positions of probe gl_WorkGroupID.y in streams, in one loop. Any groups >= 1 is correct; on
//   llvmpipe the positions per invocation must stay within maxEquirectPositionsPerInvocation
//   (dispatch_plan.h, the loop-cap workaround), which shprobe's plan there ensures.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#include "gpu_interface.h"
#include "position_walk.glsl"
#include "equirect_geometry.h"
#define SHPROBE_INPUT_NAME equirects
#include "cubemap_input.glsl"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;

#include "sh_basis.glsl"
#include "partial_slot.glsl"

layout(push_constant, std430) uniform Push { EquirectParams params; };

void main() {
    SH_EACH_COEFFICIENT(SH_DECLARE_SUM)

    uint width = params.width, height = params.height;
    bool halfTurn = equirectHasHalfTurn(width);
    uint halfWidth = width / 2u;
    uint columns = equirectPositionColumns(width);
    // A column that is its own mirror: the middle of W / 2 (half turn) or of W.
    uint selfMirroredColumn = halfTurn ? halfWidth - 1u : width - 1u;
    float solidAngleScale = equirectSolidAngleScale(width, height);
    int layer = int(gl_WorkGroupID.y);
    START_STREAM_OF(columns * quadrantSize(height))
    PositionWalk walk = startWalk(first, lanes, columns);
    for (uint position = first; position < end; position += lanes) {
        uint i = walk.i, j = walk.j;
        uint mirrorI = width - 1u - i, mirrorJ = height - 1u - j;
        // radiance[s]: the pixel whose direction is this position's with the axes in s negated
        // (bit 0 x, bit 1 y, bit 2 z).
        vec3 radiance[8];
        radiance[0] = readRadiance(i, j, layer);
        radiance[1] = readRadiance(mirrorI, j, layer);
        radiance[2] = readRadiance(i, mirrorJ, layer);
        radiance[3] = readRadiance(mirrorI, mirrorJ, layer);
        if (halfTurn) {
            radiance[4] = readRadiance(halfWidth - 1u - i, j, layer);
            radiance[5] = readRadiance(i + halfWidth, j, layer);
            radiance[6] = readRadiance(halfWidth - 1u - i, mirrorJ, layer);
            radiance[7] = readRadiance(i + halfWidth, mirrorJ, layer);
        } else {
            radiance[4] = radiance[5] = radiance[6] = radiance[7] = vec3(0.0f);
        }
        signedSums(radiance);
        vec2 row = equirectRowSinCos(j, height);
        float weight = solidAngleScale * row.x;
        if (2u * i == selfMirroredColumn) weight *= 0.5f;
        if (2u * j + 1u == height) weight *= 0.5f;
        float basis[SH_BASIS_CAPACITY];
        shEvalBasis(equirectDirectionOf(row, equirectColumnSinCos(i, width)), basis);
        SH_EACH_COEFFICIENT(SH_ACCUMULATE)
        stepWalk(walk, columns);
    }

    SH_WRITE_PARTIAL_SLOT
}
