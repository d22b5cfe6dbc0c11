#version 450
// The device's own read bound for `shprobe bench`: fetches every texel exactly as project.comp does
// (same image, layers, positions and stride) and only sums them, so its speed is the most any
// projection reading the texels this way can reach on the device. Not part of the baking interface.
//
//   set 0, binding 0: sampler2DArray cubemaps (as project.comp)
//   set 0, binding 1: buffer, vec4 sums[]: one per invocation (keeps the reads from being optimized away)
//   push constants: ProjectParams; dispatch (groups, probes, 1) as project.comp
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"
#include "position_walk.glsl"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;

layout(set = 0, binding = 0) uniform sampler2DArray cubemaps;
layout(set = 0, binding = 1, std430) writeonly buffer Sums { vec4 sums[]; };
layout(push_constant, std430) uniform Push { ProjectParams params; };

void main() {
    uint faceSize = params.faceSize;
    uint positions = faceSize * faceSize;
    int firstLayer = int(gl_WorkGroupID.y) * 6;
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    PositionWalk walk = startWalk(gl_GlobalInvocationID.x, stride, faceSize);
    vec4 sum = vec4(0.0f);
    for (uint position = gl_GlobalInvocationID.x; position < positions; position += stride) {
        for (uint face = 0u; face < 6u; ++face) sum += texelFetch(cubemaps, ivec3(walk.i, walk.j, firstLayer + int(face)), 0);
        stepWalk(walk, faceSize);
    }
    sums[(gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationIndex] = sum;
}
