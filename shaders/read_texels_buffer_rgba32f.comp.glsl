#version 450
// The projection's access pattern over an rgba32f storage buffer (read_texels.glsl).
#extension GL_GOOGLE_include_directive : require
#define SHPROBE_BUFFER_TEXELS vec4
#include "read_texels.glsl"
