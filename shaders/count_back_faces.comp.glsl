#version 450
// Counts, per probe, the texels of its captured cube map that see the back of a one-sided
// surface (alpha SHPROBE_CAPTURE_BACK_FACE, capture.frag): a probe that sees mostly back faces is
// inside geometry. Workgroup p counts probe p's 6 N^2 texels: invocation t counts texels t,
// t + width, ..., then the workgroup adds the counts (integers: the order does not matter).
//
//   set 0, binding 0: rgba32f image2DArray, the capture (6 layers per probe), in GENERAL
//   set 0, binding 1: writeonly buffer, uint counts[]: one per probe
//   push constants: uint faceSize
//   specialization: 0 = workgroup width (a power of two); dispatch (probes, 1, 1).
#extension GL_GOOGLE_include_directive : require
#include "capture_interface.h"
#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2DArray cubemaps;
layout(set = 0, binding = 1, std430) writeonly buffer Counts { uint counts[]; };
layout(push_constant, std430) uniform Push { uint faceSize; };

shared uint invocationCounts[gl_WorkGroupSize.x];

void main() {
    uint probe = gl_WorkGroupID.x;
    uint faceTexels = faceSize * faceSize;
    uint count = 0u;
    for (uint t = gl_LocalInvocationID.x; t < 6u * faceTexels; t += gl_WorkGroupSize.x) {
        uint inFace = t % faceTexels;
        ivec3 texel = ivec3(inFace % faceSize, inFace / faceSize, 6u * probe + t / faceTexels);
        if (imageLoad(cubemaps, texel).a > 0.5 * SHPROBE_CAPTURE_BACK_FACE) ++count;
    }
    invocationCounts[gl_LocalInvocationID.x] = count;
    barrier();
    for (uint stride = gl_WorkGroupSize.x / 2u; stride > 0u; stride /= 2u) {
        if (gl_LocalInvocationID.x < stride)
            invocationCounts[gl_LocalInvocationID.x] += invocationCounts[gl_LocalInvocationID.x + stride];
        barrier();
    }
    if (gl_LocalInvocationID.x == 0u) counts[probe] = invocationCounts[0];
}
