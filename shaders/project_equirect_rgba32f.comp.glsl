#version 450
// Projection of equirect maps onto SH, reading a storage image of format rgba32f (the code and its
// interface: include/equirect_projection.glsl, shaders/INTERFACE.md).
#extension GL_GOOGLE_include_directive : require
#define SHPROBE_STORAGE_FORMAT rgba32f
#include "equirect_projection.glsl"
