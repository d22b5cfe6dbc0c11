#version 450
// The direct pass of per-vertex transfer (scene/transfer.h): for each vertex side, U_0 = pi / g^2
// times the sum of y(w) over its g x g rays that meet nothing (bvhAnyHit), the rays of
// glsl/transfer_rays.glsl. One invocation per side, casting the pass's share of its rays.
//
// Interface:
//   set 0, bindings 0-5, push constants, specialization and dispatch: glsl/transfer_pass.glsl;
//   binding 4 gets U_0, the same value in r, g and b
#extension GL_GOOGLE_include_directive : require

#include "transfer_pass.glsl"

void main() {
    uint s;
    if (!transferSideIndex(s)) return;
    TransferSide side = sides[s];
    float sum[SH_BASIS_CAPACITY];
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
        sum[i] = 0.0;
    if (transferCasts(side)) {
        uvec2 state = transferRayState(side);
        float y[SH_BASIS_CAPACITY];
        for (uint k = params.firstRay; k < transferRaysEnd(); ++k) {
            vec3 direction = transferRayDirection(side.normal.xyz, params.strata, k, state);
            if (bvhAnyHit(params.nodeCount, side.origin.xyz, direction, 0.0, transferNoLimit())) continue;
            shEvalBasis(direction, y);
            for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
                sum[i] += y[i];
        }
    }
    float scale = 3.14159265358979323846 / float(params.strata * params.strata);
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
        transferStoreSum(s, i, vec3(sum[i]), scale);
}
