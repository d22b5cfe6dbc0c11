#version 450
// A bounce of per-vertex transfer (scene/transfer.h): for each vertex side, U_k = 1 / g^2 times the
// sum, over its g x g rays (glsl/transfer_rays.glsl) that meet the front of a surface or either
// side of a double-sided one (bvhClosestHit), of the albedo there times U_{k-1} of the side met,
// interpolated over the triangle by the hit's barycentrics. One invocation per side, casting the
// pass's share of its rays.
//
// Interface:
//   set 0, bindings 0-5, push constants, specialization and dispatch: glsl/transfer_pass.glsl;
//   binding 4 gets U_k
//   set 0, binding 6: readonly buffer, vec4 previous[]: U_{k-1}, binding 4's layout
//   set 0, binding 7: readonly buffer, TransferTriangle triangles[]: per World triangle
//   set 0, binding 8: readonly buffer, TransferMaterial materials[]
//   set 0, binding 9: readonly buffer, vec2 uvs[]: per World vertex, TEXCOORD_0
//   set 0, binding 10: readonly buffer, TransferTexture textures[]
//   set 0, binding 11: readonly buffer, vec4 texels[]: every texture's, one after the other
//   set 0, binding 12: readonly buffer, uint backSides[]: per World vertex, its back side (0: none)
#extension GL_GOOGLE_include_directive : require

#include "transfer_pass.glsl"

layout(set = 0, binding = 6, std430) readonly buffer Previous { vec4 previous[]; };
layout(set = 0, binding = 7, std430) readonly buffer WorldTriangles { TransferTriangle triangles[]; };
layout(set = 0, binding = 8, std430) readonly buffer Materials { TransferMaterial materials[]; };
layout(set = 0, binding = 9, std430) readonly buffer Uvs { vec2 uvs[]; };
layout(set = 0, binding = 10, std430) readonly buffer Textures { TransferTexture textures[]; };
layout(set = 0, binding = 11, std430) readonly buffer Texels { vec4 texels[]; };
layout(set = 0, binding = 12, std430) readonly buffer BackSides { uint backSides[]; };

// glTF's default sampler as scene/surface_shading.cpp reads it: bilinear, repeat, texel (i, j)
// centred at ((i + 0.5) / w, (j + 0.5) / h); mod() may round up to n, which the clamp takes to n - 1.
vec3 sampleTexture(TransferTexture texture, vec2 uv) {
    uint width = texture.extent.y, height = texture.extent.z;
    float x = mod(uv.x * float(width) - 0.5, float(width));
    float y = mod(uv.y * float(height) - 0.5, float(height));
    uint i0 = min(uint(x), width - 1u), j0 = min(uint(y), height - 1u);
    uint i1 = (i0 + 1u) % width, j1 = (j0 + 1u) % height;
    float fx = x - float(i0), fy = y - float(j0);
    uint first = texture.extent.x;
    vec3 top = (1.0 - fx) * texels[first + j0 * width + i0].rgb + fx * texels[first + j0 * width + i1].rgb;
    vec3 bottom = (1.0 - fx) * texels[first + j1 * width + i0].rgb + fx * texels[first + j1 * width + i1].rgb;
    return (1.0 - fy) * top + fy * bottom;
}

// What a ray's hit brings back, weighted by the albedo there: the sum over the triangle's corners
// of their weight times U_{k-1} of the side met, into `sum`. Nothing from the back of a one-sided
// material (the inside of something).
void gather(BvhHit hit, inout vec3 sum[SHPROBE_MAX_COEFFICIENTS]) {
    TransferTriangle triangle = triangles[hit.triangle];
    TransferMaterial material = materials[triangle.corners.w];
    if (!hit.frontFace && material.texture.y == 0) return;
    float weights[3] = float[3](1.0 - hit.u - hit.v, hit.u, hit.v);
    vec3 albedo = material.albedo.rgb;
    if (material.texture.x >= 0) {
        vec2 uv = weights[0] * uvs[triangle.corners.x] + weights[1] * uvs[triangle.corners.y] +
                  weights[2] * uvs[triangle.corners.z];
        albedo *= sampleTexture(textures[material.texture.x], uv);
    }
    for (uint c = 0u; c < 3u; ++c) {
        uint vertex = triangle.corners[c];
        uint slot = hit.frontFace ? vertex : backSides[vertex];
        vec3 weighted = weights[c] * albedo;
        for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
            sum[i] += weighted * previous[slot * SH_COEFFICIENTS + i].rgb;
    }
}

void main() {
    uint s;
    if (!transferSideIndex(s)) return;
    TransferSide side = sides[s];
    vec3 sum[SHPROBE_MAX_COEFFICIENTS];
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
        sum[i] = vec3(0.0);
    if (transferCasts(side)) {
        uvec2 state = transferRayState(side);
        for (uint k = params.firstRay; k < transferRaysEnd(); ++k) {
            vec3 direction = transferRayDirection(side.normal.xyz, params.strata, k, state);
            BvhHit hit;
            if (bvhClosestHit(params.nodeCount, side.origin.xyz, direction, 0.0, transferNoLimit(), hit))
                gather(hit, sum);
        }
    }
    float scale = 1.0 / float(params.strata * params.strata);
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
        transferStoreSum(s, i, sum[i], scale);
}
