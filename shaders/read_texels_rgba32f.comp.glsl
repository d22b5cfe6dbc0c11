#version 450
// The read bound of the storage projection for rgba32f cube maps (read_texels.glsl).
#extension GL_GOOGLE_include_directive : require
#define SHPROBE_STORAGE_FORMAT rgba32f
#include "read_texels.glsl"
