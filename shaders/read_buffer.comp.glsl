#version 450
// The device's plain read bound for `shprobe bench`: each workgroup sums one contiguous block of a
// storage buffer of vec4, neighbouring invocations reading neighbouring vec4s (coalesced on a GPU,
// one stream per thread on a CPU device), and writes one sum per invocation. Nothing reads bytes
// faster on the device; not part of the baking interface.
//
//   set 0, binding 0: buffer vec4 words[]: the bytes read (one range, at most maxStorageBufferRange)
//   set 0, binding 1: buffer vec4 sums[]: one per invocation (keeps the reads from being optimized away)
//   push constants: uint count (vec4s in binding 0), uint perGroup (vec4s each workgroup reads)
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;

layout(set = 0, binding = 0, std430) readonly buffer Words { vec4 words[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Sums { vec4 sums[]; };
layout(push_constant, std430) uniform Push {
    uint count;
    uint perGroup;
};

void main() {
    uint first = gl_WorkGroupID.x * perGroup;
    uint end = min(first + perGroup, count);
    // A trip count the whole workgroup shares, then the rest: no per-lane bound in the loop.
    uint steps = (end - first) / gl_WorkGroupSize.x;
    vec4 sum = vec4(0.0f);
    for (uint step = 0u; step < steps; ++step)
        sum += words[first + step * gl_WorkGroupSize.x + gl_LocalInvocationIndex];
    uint rest = first + steps * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
    if (rest < end) sum += words[rest];
    sums[gl_GlobalInvocationID.x] = sum;
}
