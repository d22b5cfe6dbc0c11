#version 450
// Projection of equirect maps onto SH, reading a sampled image of any format (the code and its
// interface: include/equirect_projection.glsl, shaders/INTERFACE.md).
#extension GL_GOOGLE_include_directive : require
#include "equirect_projection.glsl"
