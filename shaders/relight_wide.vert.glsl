#version 450
// relight.vert with 31 transfer attributes (order 5 RGB takes 19, order 6 RGB 27, order 8 grey
// 16), for devices with 32 vertex attributes.
#extension GL_GOOGLE_include_directive : require
#include "render_interface.h"
#define SHPROBE_TRANSFER_ATTRIBUTES SHPROBE_RELIGHT_WIDE_ATTRIBUTES
#include "relight_vertex.glsl"
