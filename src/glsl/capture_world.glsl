// The world's surfaces as scene/scene.h describes them, and the sky, in the capture's storage
// buffers (capture_interface.h): what every module that shades the world reads, rasterized
// (capture.frag) or by rays (capture_rays.comp, cache_gather.comp).
#ifndef SHPROBE_CAPTURE_WORLD_GLSL
#define SHPROBE_CAPTURE_WORLD_GLSL
#include "capture_interface.h"

layout(std430, set = 0, binding = SHPROBE_CAPTURE_VERTICES) readonly buffer Vertices {
    CaptureVertex vertices[];
};
layout(std430, set = 0, binding = SHPROBE_CAPTURE_INDICES) readonly buffer Indices {
    uint indices[];
};
layout(std430, set = 0, binding = SHPROBE_CAPTURE_TRIANGLES) readonly buffer Triangles {
    uint triangleMaterials[];
};
layout(std430, set = 0, binding = SHPROBE_CAPTURE_MATERIALS) readonly buffer Materials {
    CaptureMaterial materials[];
};
layout(std430, set = 0, binding = SHPROBE_CAPTURE_TEXTURES) readonly buffer Textures {
    CaptureTexture textures[];
};
layout(std430, set = 0, binding = SHPROBE_CAPTURE_TEXELS) readonly buffer Texels {
    vec4 texels[];
};
layout(std430, set = 0, binding = SHPROBE_CAPTURE_SKY) readonly buffer Sky {
    vec4 sky[];
};

layout(std430, set = 0, binding = SHPROBE_CAPTURE_SUNS) readonly buffer Suns {
    CaptureSun suns[];
};

// The index of the sky texel a direction falls in (faces n x n, face after face, rows in order),
// no filtering, and the face-local point (a, b) in [-1, 1]^2 where it falls (sh/cubemap.h
// directionToFace, then the texel holding that point).
uint skyTexelIndex(vec3 d, uint n, out vec2 ab) {
    vec3 m = abs(d);
    uint face;
    if (m.x >= m.y && m.x >= m.z) {
        face = d.x >= 0.0 ? 0u : 1u;
        ab = d.x >= 0.0 ? vec2(-d.z, -d.y) / m.x : vec2(d.z, -d.y) / m.x;
    } else if (m.y >= m.z) {
        face = d.y >= 0.0 ? 2u : 3u;
        ab = d.y >= 0.0 ? vec2(d.x, d.z) / m.y : vec2(d.x, -d.z) / m.y;
    } else {
        face = d.z >= 0.0 ? 4u : 5u;
        ab = d.z >= 0.0 ? vec2(d.x, -d.y) / m.z : vec2(-d.x, -d.y) / m.z;
    }
    uvec2 texel = uvec2(clamp(floor((ab + 1.0) * 0.5 * float(n)), 0.0, float(n - 1u)));
    return (face * n + texel.y) * n + texel.x;
}

vec3 skyTexel(vec3 d, uint n) {
    vec2 ab;
    return sky[skyTexelIndex(d, n, ab)].rgb;
}

// Bilinear with repeat, texel centres at (i + 0.5) / width, row 0 at v = 0 (glTF's default
// sampler); white for no texture.
vec3 textureColor(float index, vec2 uv) {
    if (index < 0.0) return vec3(1.0);
    uvec4 e = textures[uint(index)].extent;
    ivec2 size = ivec2(e.yz);
    vec2 p = uv * vec2(size) - 0.5;
    vec2 base = floor(p);
    vec2 f = p - base;
    ivec2 t0 = ivec2(base);
    ivec2 x = (ivec2(t0.x, t0.x + 1) % size.x + size.x) % size.x;
    ivec2 y = (ivec2(t0.y, t0.y + 1) % size.y + size.y) % size.y;
    vec3 top = mix(texels[e.x + y.x * size.x + x.x].rgb, texels[e.x + y.x * size.x + x.y].rgb, f.x);
    vec3 bottom = mix(texels[e.x + y.y * size.x + x.x].rgb, texels[e.x + y.y * size.x + x.y].rgb, f.x);
    return mix(top, bottom, f.y);
}

// A material's albedo and emission at texture coordinate uv.
vec3 surfaceAlbedo(CaptureMaterial material, vec2 uv) {
    return material.albedo.rgb * textureColor(material.albedo.w, uv);
}
vec3 surfaceEmission(CaptureMaterial material, vec2 uv) {
    return material.emission.rgb * textureColor(material.emission.w, uv);
}

// What a front face leaves (scene/scene.h): its emission, plus the irradiance it receives
// reflected by its albedo (Lambert: albedo / pi); both at texture coordinate uv.
vec3 surfaceLeaving(CaptureMaterial material, vec2 uv, vec3 irradiance) {
    vec3 reflected = surfaceAlbedo(material, uv) * (1.0 / 3.14159265358979) * irradiance;
    return surfaceEmission(material, uv) + reflected;
}

#endif
