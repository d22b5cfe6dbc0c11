#version 450
// The projection's access pattern over a storage buffer of rgba16f texels (read_texels.glsl).
#extension GL_GOOGLE_include_directive : require
#define SHPROBE_BUFFER_TEXELS uvec2
#define SHPROBE_BUFFER_HALVES
#include "read_texels.glsl"
