// The projections' dispatch plan (project.comp and project_equirect.comp), shared by C++ and GLSL:
// how many positions a probe has, how many each invocation walks, and how many workgroups per probe
// shprobe dispatches (shaders/INTERFACE.md, "project.comp dispatch rules" and "project_equirect.comp
// dispatch rules"). The shaders walk positionsPerInvocation (START_STREAM, position_walk.glsl); the
// baker (gpu/probe_baker.cpp) and examples/bake_probe plan with the rest.
// 32-bit unsigned arithmetic only, so that both languages compute the same numbers: every value
// stays below 2^32 for faces up to 65535 texels wide, workgroup widths up to 1024, and any device
// limits.
#ifndef SHPROBE_DISPATCH_PLAN_H
#define SHPROBE_DISPATCH_PLAN_H
#include "equirect_geometry.h"
#include "gpu_interface.h"
#include "texel_geometry.h"

SHPROBE_BEGIN

// A projection position is a texel and its three mirror images (quadrantSize) on each of the six
// faces.
SHPROBE_CONST uint kTexelsPerPosition = 4u * 6u;

// shprobe's defaults for the plan's free parameters (gpu/probe_baker.h, ProbeBakerOptions, and
// `shprobe bake --texels-per-invocation`); any width the device allows and any number of texels
// per invocation from 1 up give correct sums.
SHPROBE_CONST uint kDefaultTexelsPerInvocation = 256u;
SHPROBE_CONST uint kDefaultWorkgroupWidth = 64u;
// reduce.comp and convolve.comp handle one value per coefficient: a small workgroup is enough.
SHPROBE_CONST uint kCoefficientWorkgroupWidth = 64u;

// ceil(a / b) for b > 0, without the overflow of (a + b - 1) / b.
SHPROBE_FN uint divideRoundingUp(uint a, uint b) {
    return a / b + uint(a % b != 0u);
}

// The positions of one probe of N x N faces: ceil(N / 2)^2.
SHPROBE_FN uint projectionPositions(uint faceSize) {
    uint quadrant = quadrantSize(faceSize);
    return quadrant * quadrant;
}

// The positions of one W x H equirect map (equirect_geometry.h): ceil(W / 4) or, for odd W,
// ceil(W / 2) columns times ceil(H / 2) rows.
SHPROBE_FN uint equirectProjectionPositions(uint width, uint height) {
    return equirectPositionColumns(width) * quadrantSize(height);
}

// The positions each invocation walks when `groups` workgroups of `width` invocations share a
// probe's positions: the walk's stride (START_STREAM). Any groups >= 1 cover all positions.
SHPROBE_FN uint positionsPerInvocation(uint positions, uint groups, uint width) {
    return divideRoundingUp(positions, groups * width);
}

// Workaround(llvmpipe, Mesa 22.3): llvmpipe ends a shader's loops after 65535 iterations in all
// (Mesa, gallivm/lp_bld_limits.h: LP_MAX_TGSI_LOOP_ITERATIONS, "shared between every loop"),
// nested loops counted against the outermost one, and the sums are then silently wrong. A loop over
// positions that reads eight texels, evaluates one basis and multiplies n^2 sums per position costs
// fewer than 2 (1 + n^2 + floor(n^2 / 2)) iterations per position at order n, nested loops
// included; project.comp has three such loops (one per face pair), project_equirect.comp one, and
// a position costs fewer than 1 + 2 loops (1 + n^2 + floor(n^2 / 2)) iterations in all. The bound
// is deliberately loose (a basis evaluation takes a few times fewer, whatever the compiler
// unrolls), and half the limit leaves a further margin. Other devices lose nothing by the cap,
// since the plan never needs more positions per invocation than it allows; to drop it for a
// device, pass a larger maxPositions to planPositionsPerInvocation.
SHPROBE_FN uint loopCappedPositions(uint order, uint loops) {
    uint coefficients = order * order;
    return 32768u / (1u + 2u * loops * (1u + coefficients + coefficients / 2u));
}

// project.comp's cap: 1 + 6 (1 + n^2 + floor(n^2 / 2)) iterations per position.
SHPROBE_FN uint maxPositionsPerInvocation(uint order) {
    return loopCappedPositions(order, 3u);
}

// project_equirect.comp's cap: 1 + 2 (1 + n^2 + floor(n^2 / 2)) iterations per position.
SHPROBE_FN uint maxEquirectPositionsPerInvocation(uint order) {
    return loopCappedPositions(order, 1u);
}

// The most workgroups per probe a bake of `probes` probes may dispatch: one dispatch row
// (maxComputeWorkGroupCount[0]) and the partial slots of all probes (slotBytes each: n^2 vec4)
// in one storage-buffer binding (maxStorageBufferRange).
SHPROBE_FN uint maxGroupsPerProbe(uint maxWorkGroupCountX, uint maxStorageBufferRange, uint slotBytes,
                                  uint probes) {
    return min(maxWorkGroupCountX, maxStorageBufferRange / slotBytes / probes);
}

// shprobe's positions per invocation, for positions of texelsPerPosition texels each: the
// requested texels per invocation in whole positions, but at least as many as maxGroups workgroups
// of `width` need to cover the positions, and at most maxPositions (the loop cap). 0 when no number
// meets both bounds: the probes do not fit one bake.
SHPROBE_FN uint planPositionsOf(uint positions, uint texelsPerPosition, uint texelsPerInvocation, uint width,
                                uint maxGroups, uint maxPositions) {
    if (maxGroups == 0u) return 0u;
    uint least = divideRoundingUp(divideRoundingUp(positions, maxGroups), width);
    if (least > maxPositions) return 0u;
    uint requested = divideRoundingUp(texelsPerInvocation, texelsPerPosition);
    return clamp(requested, max(least, 1u), maxPositions);
}

// project.comp's: positions of kTexelsPerPosition texels, maxPositions = maxPositionsPerInvocation.
SHPROBE_FN uint planPositionsPerInvocation(uint positions, uint texelsPerInvocation, uint width,
                                           uint maxGroups, uint maxPositions) {
    return planPositionsOf(positions, kTexelsPerPosition, texelsPerInvocation, width, maxGroups,
                           maxPositions);
}

// project_equirect.comp's for a W x H map (imageWidth = W): equirectProjectionPositions(W, H)
// positions of equirectTexelsPerPosition(W) texels, maxPositions = maxEquirectPositionsPerInvocation.
SHPROBE_FN uint planEquirectPositionsPerInvocation(uint imageWidth, uint imageHeight,
                                                   uint texelsPerInvocation, uint width, uint maxGroups,
                                                   uint maxPositions) {
    return planPositionsOf(equirectProjectionPositions(imageWidth, imageHeight),
                           equirectTexelsPerPosition(imageWidth), texelsPerInvocation, width, maxGroups,
                           maxPositions);
}

// The workgroups per probe that give each invocation at most `perInvocation` positions; with
// planPositionsPerInvocation's result, at most maxGroups.
// Shared memory a projection workgroup of this width declares (partial_slot.glsl): a vec3 per
// entry of its reduction chunk, SHPROBE_REDUCTION_ENTRIES rounded up to the width, counted as 16
// bytes (a vec4: the layout of shared vec3 arrays is the implementation's), and the subgroup
// count, counted as 16 bytes too. 8208 at width 64.
SHPROBE_FN uint projectionSharedBytes(uint width) {
    return 16u * divideRoundingUp(SHPROBE_REDUCTION_ENTRIES, width) * width + 16u;
}

SHPROBE_FN uint planGroups(uint positions, uint perInvocation, uint width) {
    return divideRoundingUp(positions, perInvocation * width);
}

SHPROBE_END

#endif
