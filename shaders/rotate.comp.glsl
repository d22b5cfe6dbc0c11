#version 450
// Rotates a batch of probes: c'_lm = sum_n D^l_mn c_ln, each band by its own (2l+1) x (2l+1)
// matrix (Ivanic & Ruedenberg; built on the CPU by makeShRotation, src/sh/rotation.h). One
// invocation per output coefficient.
//
// Interface (shaders/INTERFACE.md):
//   set 0, binding 0: readonly buffer, float matrices[]: a rotation's band matrices one after the
//                     other, D^l row-major from float l(4l^2-1)/3; rotation p at p * matrixStride
//   set 0, binding 1: readonly buffer, vec4 probes[]: probe p's coefficient i at p * SH_COEFFICIENTS + i
//   set 0, binding 2: writeonly buffer, vec4 rotated[]: same layout (rgb, a = 0)
//   push constants: RotateParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8); dispatch
//   ceil(probeCount * SH_COEFFICIENTS / width) workgroups.
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;
const uint SH_COEFFICIENTS = SH_ORDER * SH_ORDER;

layout(set = 0, binding = 0, std430) readonly buffer Matrices { float matrices[]; };
layout(set = 0, binding = 1, std430) readonly buffer Probes { vec4 probes[]; };
layout(set = 0, binding = 2, std430) writeonly buffer Rotated { vec4 rotated[]; };
layout(push_constant, std430) uniform Push { RotateParams params; };

void main() {
    uint index = gl_GlobalInvocationID.x;
    if (index >= params.probeCount * SH_COEFFICIENTS) return;
    uint probe = index / SH_COEFFICIENTS;
    uint i = index - probe * SH_COEFFICIENTS;
    uint l = bandOfIndex(i);
    uint width = 2u * l + 1u;
    uint row = i - l * l; // m + l
    uint matrix = probe * params.matrixStride + l * (4u * l * l - 1u) / 3u + row * width;
    uint band = probe * SH_COEFFICIENTS + l * l;
    vec3 total = vec3(0.0f);
    for (uint n = 0u; n < width; ++n) total += matrices[matrix + n] * probes[band + n].rgb;
    rotated[index] = vec4(total, 0.0f);
}
