// The vertex stage of relight.vert and relight_wide.vert: a mesh with per-vertex transfer relit by
// a light's radiance coefficients, L_out = sum_i T_i L_i, once per vertex (sh_transfer.glsl).
// The dot product is taken here, not per fragment: it is linear in T, so interpolating L_out across
// a triangle gives what interpolating T and then summing would, for order^2 multiply-adds a vertex
// instead of a pixel and one vec3 varying instead of up to 31 vec4.
//
// Interface (shaders/INTERFACE.md): location 0 vec3 position (world space); locations 1..
// SHPROBE_TRANSFER_ATTRIBUTES vec4 transfer (_SH_TRANSFER_0, ...); set 0, binding 0 readonly
// buffer vec4 light[order^2] (rgb; e.g. rotate.comp's output); push constants RelightConstants;
// specialization 1 = SH order (1..8), 5 = channels (3 or 1). Output: location 0 vec3 radiance.
#ifndef SHPROBE_RELIGHT_VERTEX_GLSL
#define SHPROBE_RELIGHT_VERTEX_GLSL

#include "render_interface.h"
#include "sh_transfer.glsl"

layout(constant_id = SHPROBE_SPEC_RENDER_ORDER) const uint SH_ORDER = 3u;
layout(constant_id = SHPROBE_SPEC_TRANSFER_CHANNELS) const uint CHANNELS = 3u;

layout(location = 0) in vec3 position;
layout(location = 1) in vec4 transfer[SHPROBE_TRANSFER_ATTRIBUTES];

layout(set = 0, binding = 0, std430) readonly buffer Light {
    vec4 light[];
};
layout(push_constant, std430) uniform Push {
    RelightConstants draw;
};

layout(location = 0) out vec3 radiance;

// The sum walks the attributes and their components in order, so that once the loops are unrolled
// (their bounds are constants) every attribute is read at a constant index: an input array indexed
// at run time (shTransferCoefficient's i) costs lavapipe a copy of all of them per vertex, 14x the
// time of the whole draw at order 5.
void main() {
    const uint floats = SH_ORDER * SH_ORDER * CHANNELS;
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < SHPROBE_TRANSFER_ATTRIBUTES; ++k)
        for (uint c = 0u; c < 4u; ++c) {
            uint f = 4u * k + c; // float f of the transfer (sh_transfer.glsl's packing)
            if (f >= floats) continue;
            if (CHANNELS == 1u)
                sum += transfer[k][c] * light[f].rgb;
            else
                sum[f % 3u] += transfer[k][c] * light[f / 3u][f % 3u];
        }
    radiance = sum;
    gl_Position = draw.clipFromWorld * vec4(position, 1.0);
}

#endif
