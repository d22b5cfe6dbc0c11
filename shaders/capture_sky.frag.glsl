// What a probe (or a camera) sees where no geometry is: the sky texel along the texel's direction.
// Drawn first, over the whole face; capture.frag draws the world over it.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "capture_common.glsl"

layout(location = 0) out vec4 radiance;

// The unit direction through the centre of this fragment's texel of the probe's face: the ray the
// reference casts for it (sh/cubemap.h texelDirection). A camera's view: through the pixel, from
// the inverse of its projection.
vec3 fragmentDirection() {
    if (c.face.x == SHPROBE_CAPTURE_CAMERA) {
        vec2 ndc = 2.0 * gl_FragCoord.xy / c.view.xy - 1.0;
        // Clip depth 0 is infinitely far: the inverse maps it to a point at infinity, w = 0, whose
        // xyz is the direction itself (no difference of nearby points to lose precision in).
        return normalize((inverse(c.worldToClip) * vec4(ndc, 0.0, 1.0)).xyz);
    }
    uint n = c.face.y;
    vec2 ab = vec2(texelCenterCoord(uint(gl_FragCoord.x), n), texelCenterCoord(uint(gl_FragCoord.y), n));
    return normalize(orientToFace(c.face.x, vec3(ab, 1.0)));
}

void main() {
    radiance = vec4(skyRadiance(fragmentDirection()), 0.0);
}
