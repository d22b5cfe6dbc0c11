#version 450
// The device's arithmetic bound for `shprobe bench`: each invocation runs `steps` rounds of eight
// independent vec4 fused multiply-adds (32 per round, chains long enough to hide their latency)
// and writes their sum. The factor and term come from push constants, so no compiler can fold the
// chains; the factor is 1 and the term small, so the values stay normal floats. Not part of the
// baking interface.
//
//   set 0, binding 0: buffer vec4 sums[]: one per invocation (keeps the arithmetic from being
//                     optimized away)
//   push constants: uint steps, float factor, float term
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;

layout(set = 0, binding = 0, std430) writeonly buffer Sums { vec4 sums[]; };
layout(push_constant, std430) uniform Push {
    uint steps;
    float factor;
    float term;
};

void main() {
    vec4 start = vec4(float(gl_GlobalInvocationID.x)) * 1e-6f;
    vec4 chain[8] = vec4[8](start, start + 1.0f, start + 2.0f, start + 3.0f, start + 4.0f, start + 5.0f,
                            start + 6.0f, start + 7.0f);
    for (uint step = 0u; step < steps; ++step) {
        // Literal indices only: the chains stay in registers (an array indexed at run time stays
        // in memory on llvmpipe).
        chain[0] = fma(chain[0], vec4(factor), vec4(term));
        chain[1] = fma(chain[1], vec4(factor), vec4(term));
        chain[2] = fma(chain[2], vec4(factor), vec4(term));
        chain[3] = fma(chain[3], vec4(factor), vec4(term));
        chain[4] = fma(chain[4], vec4(factor), vec4(term));
        chain[5] = fma(chain[5], vec4(factor), vec4(term));
        chain[6] = fma(chain[6], vec4(factor), vec4(term));
        chain[7] = fma(chain[7], vec4(factor), vec4(term));
    }
    sums[gl_GlobalInvocationID.x] =
        chain[0] + chain[1] + chain[2] + chain[3] + chain[4] + chain[5] + chain[6] + chain[7];
}
