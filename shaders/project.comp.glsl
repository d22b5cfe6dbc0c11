#version 450
// Projection of cube maps onto SH, reading a sampled image of any format (the code and its
// interface: include/projection.glsl, shaders/INTERFACE.md).
#extension GL_GOOGLE_include_directive : require
#include "projection.glsl"
