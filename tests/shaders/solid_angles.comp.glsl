#version 450
// Test module: writes texelSolidAngleFp32 (src/glsl/texel_geometry.h) of every texel of one
// N x N face, so the GPU's own evaluation of the weight can be checked against the double formula.
#extension GL_GOOGLE_include_directive : require

#include "texel_geometry.h"

layout(local_size_x = 64) in;
layout(set = 0, binding = 0, std430) writeonly buffer SolidAngles { float solidAngles[]; };
layout(push_constant, std430) uniform Push { uint faceSize; };

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint texel = gl_GlobalInvocationID.x; texel < faceSize * faceSize; texel += stride)
        solidAngles[texel] = texelSolidAngleFp32(texel % faceSize, texel / faceSize, faceSize);
}
