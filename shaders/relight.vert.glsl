#version 450
// A mesh relit by its per-vertex transfer, up to 15 transfer attributes (order 3 RGB takes 7,
// order 4 RGB 12, order 7 grey 13): fits any Vulkan device's 16 vertex attributes. The code and
// its interface: include/relight_vertex.glsl, shaders/INTERFACE.md.
#extension GL_GOOGLE_include_directive : require
#include "render_interface.h"
#define SHPROBE_TRANSFER_ATTRIBUTES SHPROBE_RELIGHT_ATTRIBUTES
#include "relight_vertex.glsl"
