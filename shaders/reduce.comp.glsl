#version 450
// Sums the partial slots written by project.comp into one set of SH coefficients, in a fixed
// order (slot 0, 1, 2, ...), so the same input gives bit-identical coefficients on every run.
// Thousands of slots are summed in sequence, so the sum is compensated (Kahan 1965): its error
// stays at a few ulps of the total instead of growing with the slot count. `precise` keeps the
// compiler from reassociating the compensation away.
//
// Interface (shaders/INTERFACE.md):
//   set 0, binding 0: readonly buffer, vec4 partials[]: partialCount slots of SH_COEFFICIENTS vec4
//   set 0, binding 1: writeonly buffer, vec4 coefficients[]: SH_COEFFICIENTS vec4 (rgb, a = 0)
//   push constants: ReduceParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8); dispatch one workgroup.
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;
const uint SH_COEFFICIENTS = SH_ORDER * SH_ORDER;

layout(set = 0, binding = 0, std430) readonly buffer Partials { vec4 partials[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Coefficients { vec4 coefficients[]; };
layout(push_constant, std430) uniform Push { ReduceParams params; };

void main() {
    for (uint i = gl_LocalInvocationIndex; i < SH_COEFFICIENTS; i += gl_WorkGroupSize.x) {
        precise vec3 total = vec3(0.0f);
        precise vec3 compensation = vec3(0.0f);
        for (uint slot = 0u; slot < params.partialCount; ++slot) {
            precise vec3 term = partials[slot * SH_COEFFICIENTS + i].rgb - compensation;
            precise vec3 next = total + term;
            compensation = (next - total) - term;
            total = next;
        }
        coefficients[i] = vec4(total, 0.0f);
    }
}
