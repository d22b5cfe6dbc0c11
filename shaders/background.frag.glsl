// Pixels no surface covers: along the view direction d, the environment, its SH reconstruction,
// the shading of a surface of normal d (albedo 1), or a flat colour (SHPROBE_SPEC_BACKGROUND). The
// probe's sun, if any (sun_light.h), is in the reconstruction as its disc and in the shading as
// light; the environment image already holds it.
// The camera is a perspective one or a panorama (equirect, docs/conventions.md) by u.camera.w.
// Outputs: location 0 colour; location 1 direction (xyz = d, w = SHPROBE_DIRECTION_*).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"
#include "sun_light.h"

layout(set = 0, binding = 1) uniform samplerCube environment;

layout(location = 0) out vec4 color;
layout(location = 1) out vec4 direction;

const float kPi = 3.14159265358979;

vec3 viewDirection() {
    vec2 pixel = gl_FragCoord.xy * u.viewport.zw; // 0..1, pixel centers
    if (uint(u.camera.w) == SHPROBE_PROJECTION_PANORAMA) {
        // theta = pi v, phi = 2 pi u - pi; d = (sin t sin p, cos t, -sin t cos p): center -Z, top +Y.
        float theta = kPi * pixel.y, phi = 2.0 * kPi * pixel.x - kPi;
        return vec3(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
    }
    vec4 far = u.inverseViewProjection * vec4(pixel * 2.0 - 1.0, 1.0, 1.0);
    return normalize(far.xyz / far.w - u.camera.xyz);
}

void main() {
    vec3 d = viewDirection();
    if (BACKGROUND == SHPROBE_BACKGROUND_ENVIRONMENT) {
        color = vec4(textureLod(environment, d, 0.0).rgb, 1.0);
        direction = vec4(d, SHPROBE_DIRECTION_NONE);
    } else if (BACKGROUND == SHPROBE_BACKGROUND_RADIANCE) {
        color = vec4(shRadiance(u.radiance, d, SH_ORDER) + sunShading(u.sun, SHPROBE_SHADING_RADIANCE, d, vec3(1.0)),
                     1.0);
        direction = vec4(d, SHPROBE_DIRECTION_RADIANCE);
    } else if (BACKGROUND == SHPROBE_BACKGROUND_SHADING) {
        color = vec4(shadeNormal(d, vec3(1.0)) + sunShading(u.sun, SHADING, d, vec3(1.0)), 1.0);
        direction = vec4(d, SHPROBE_DIRECTION_SHADING);
    } else {
        color = vec4(u.backgroundColor.rgb, 1.0);
        direction = vec4(d, SHPROBE_DIRECTION_NONE);
    }
}
