#version 450
// Sums the partial slots written by project.comp into one set of SH coefficients per probe.
// Workgroup (i, p) sums coefficient i of probe p, whose slots are p * partialCount ..
// (p + 1) * partialCount - 1: invocation t adds slots t, t + width, t + 2 width, ..., then invocation 0 adds the
// invocations' sums in order. The order is fixed, so the same input gives bit-identical
// coefficients on every run.
// Workaround(llvmpipe, Mesa 22.3): each invocation loops partialCount / width times, which keeps
// llvmpipe's 65535-iteration loop limit (dispatch_plan.h, maxPositionsPerInvocation) out of reach
// for millions of slots; one invocation looping over 32768 slots lost some of them
// (docs/gpu-path.md). A whole workgroup per coefficient is a sound reduction on any device, so
// nothing here needs dropping elsewhere.
// Sums are compensated (Kahan 1965) so their error stays at a few ulps of the total; `precise`
// keeps the compiler from reassociating the compensation away.
//
// Interface (shaders/INTERFACE.md):
//   set 0, binding 0: readonly buffer, vec4 partials[]: partialCount slots of SH_COEFFICIENTS vec4
//                     per probe, probe after probe
//   set 0, binding 1: writeonly buffer, vec4 coefficients[]: SH_COEFFICIENTS vec4 (rgb, a = 0) per
//                     probe, probe p's at p * SH_COEFFICIENTS
//   push constants: ReduceParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8); dispatch (SH_COEFFICIENTS, probes, 1).
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;
const uint SH_COEFFICIENTS = SH_ORDER * SH_ORDER;

layout(set = 0, binding = 0, std430) readonly buffer Partials { vec4 partials[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Coefficients { vec4 coefficients[]; };
layout(push_constant, std430) uniform Push { ReduceParams params; };

shared vec3 invocationSums[gl_WorkGroupSize.x];

// One step of compensated summation (Kahan 1965): total + value, carrying the lost low bits.
void addCompensated(inout vec3 total, inout vec3 compensation, vec3 value) {
    precise vec3 term = value - compensation;
    precise vec3 next = total + term;
    compensation = (next - total) - term;
    total = next;
}

void main() {
    uint coefficient = gl_WorkGroupID.x;
    uint firstSlot = gl_WorkGroupID.y * params.partialCount;
    vec3 total = vec3(0.0f), compensation = vec3(0.0f);
    for (uint slot = gl_LocalInvocationIndex; slot < params.partialCount; slot += gl_WorkGroupSize.x)
        addCompensated(total, compensation, partials[(firstSlot + slot) * SH_COEFFICIENTS + coefficient].rgb);
    invocationSums[gl_LocalInvocationIndex] = total;
    barrier();
    if (gl_LocalInvocationIndex != 0u) return;
    total = vec3(0.0f);
    compensation = vec3(0.0f);
    for (uint t = 0u; t < gl_WorkGroupSize.x; ++t) addCompensated(total, compensation, invocationSums[t]);
    coefficients[gl_WorkGroupID.y * SH_COEFFICIENTS + coefficient] = vec4(total, 0.0f);
}
