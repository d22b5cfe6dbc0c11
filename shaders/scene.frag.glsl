// Surfaces lit by the probe: colour = shadeNormal(n, albedo) plus the probe's sun, if any, added
// analytically (sun_light.h) (linear, unclamped), and the normal it was evaluated at, so tests can
// compare every pixel with the CPU reference.
// Outputs: location 0 colour (rgb, a = 1); location 1 direction (xyz = n, w = SHPROBE_DIRECTION_SHADING).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"
#include "sun_light.h"

layout(push_constant, std430) uniform Push {
    ObjectConstants object;
};

layout(location = 0) in vec3 worldNormal;
layout(location = 0) out vec4 color;
layout(location = 1) out vec4 direction;

void main() {
    vec3 n = normalize(worldNormal);
    vec3 albedo = object.albedo.rgb;
    color = vec4(shadeNormal(n, albedo) + sunShading(u.sun, SHADING, n, albedo), 1.0);
    direction = vec4(n, SHPROBE_DIRECTION_SHADING);
}
