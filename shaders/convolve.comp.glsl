#version 450
// Applies a per-band scale to SH coefficients: with bandScale[l] = A_l this is the Lambertian
// (clamped-cosine) convolution E_lm = A_l L_lm (Ramamoorthi & Hanrahan 2001, "An Efficient
// Representation for Irradiance Environment Maps"; A_l as in Brown, "Spherical Harmonic Basis Functions").
// A window (de-ringing) multiplies into bandScale on the host, so it needs no other pass.
//
// Interface (shaders/INTERFACE.md):
//   set 0, binding 0: readonly buffer, vec4 radiance[]: SH_COEFFICIENTS vec4 (rgb) per probe,
//                     probe p's at p * SH_COEFFICIENTS
//   set 0, binding 1: writeonly buffer, vec4 irradiance[]: the same layout (rgb, a = 0), starting
//                     at vec4 params.outputOffset
//   push constants: ConvolveParams (gpu_interface.h), bandScale[l / 4][l % 4] for band l
//   specialization: 0 = workgroup width, 1 = SH order (1..8); dispatch (1, probes, 1).
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;
const uint SH_COEFFICIENTS = SH_ORDER * SH_ORDER;

layout(set = 0, binding = 0, std430) readonly buffer Radiance { vec4 radiance[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Irradiance { vec4 irradiance[]; };
layout(push_constant, std430) uniform Push { ConvolveParams params; };

void main() {
    uint first = gl_WorkGroupID.y * SH_COEFFICIENTS;
    for (uint i = gl_LocalInvocationIndex; i < SH_COEFFICIENTS; i += gl_WorkGroupSize.x) {
        uint l = bandOfIndex(i);
        irradiance[params.outputOffset + first + i] = vec4(radiance[first + i].rgb * params.bandScale[l / 4u][l % 4u], 0.0f);
    }
}
