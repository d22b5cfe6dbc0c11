// Linear HDR colour -> display: exposure, the ACES filmic curve fitted by Narkowicz (2015), and
// the sRGB encoding (by the target's _SRGB format, or here when SHPROBE_SPEC_ENCODE_SRGB = 1 for
// UNORM targets). Used for PNG output and for the viewer's swapchain, so both show the same bytes.
// Bindings: set 0, binding 0: the HDR colour (combined image sampler, read with texelFetch).
// Push constants: TonemapConstants.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_interface.h"

layout(constant_id = SHPROBE_SPEC_ENCODE_SRGB) const uint ENCODE_SRGB = 0u;

layout(set = 0, binding = 0) uniform sampler2D hdr;
layout(push_constant, std430) uniform Push {
    TonemapConstants constants;
};

layout(location = 0) out vec4 color;

vec3 acesFilmic(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

// IEC 61966-2-1 sRGB encoding.
vec3 encodeSrgb(vec3 c) {
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
    vec3 linear = texelFetch(hdr, ivec2(gl_FragCoord.xy), 0).rgb;
    vec3 mapped = acesFilmic(max(linear * constants.exposure.x, vec3(0.0)));
    color = vec4(ENCODE_SRGB == 1u ? encodeSrgb(mapped) : mapped, 1.0);
}
