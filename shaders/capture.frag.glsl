// What a probe sees of a surface (scene/scene.h): a front face leaves its emission plus, reflected
// by its albedo, the suns' irradiance (shadowed through their shadow maps) and the irradiance of
// the previous bounce; the back of a one-sided surface
// leaves nothing and is marked in alpha (SHPROBE_CAPTURE_BACK_FACE).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3u; // the previous volume's order
#include "capture_common.glsl"
#include "capture_volume.glsl"
#include "probe_volume.glsl"

layout(std430, set = 0, binding = SHPROBE_CAPTURE_SHADOWS) readonly buffer Shadows {
    float shadowDepths[];
};

// Whether nothing lies between x and the sun: its shadow map, looked up at x moved off the surface
// by two map texels along the geometric normal (facing the sun) and compared with a further
// quarter texel of depth, so that a surface does not shadow itself through the map's texels.
bool sunlit(CaptureSun sun, vec3 x, vec3 faceNormal) {
    vec3 offset = x + faceNormal * (2.0 * sun.scale.x);
    vec3 p = (sun.worldToShadow * vec4(offset, 1.0)).xyz;
    uint size = sun.map.y;
    uvec2 texel = uvec2(clamp(floor(p.xy * float(size)), vec2(0.0), vec2(float(size - 1u))));
    float nearest = shadowDepths[sun.map.x + texel.y * size + texel.x];
    return p.z >= nearest - 0.25 * sun.scale.x * sun.scale.y;
}

// The suns' irradiance at a surface point of shading normal n whose front faces along faceNormal:
// none from a sun behind the surface itself.
vec3 sunIrradiance(vec3 x, vec3 n, vec3 faceNormal) {
    vec3 e = vec3(0.0);
    for (uint s = 0u; s < c.face.w; ++s) {
        CaptureSun sun = suns[s];
        float cosine = dot(n, sun.direction.xyz);
        if (cosine <= 0.0 || dot(faceNormal, sun.direction.xyz) <= 0.0) continue;
        if (sunlit(sun, x, faceNormal)) e += sun.irradiance.rgb * cosine;
    }
    return e;
}

layout(location = 0) in vec3 worldPosition;
layout(location = 1) in vec3 shadingNormal;
layout(location = 2) in vec2 uv;
layout(location = 3) flat in uint triangle;
layout(location = 4) flat in vec3 geometricNormal;

layout(location = 0) out vec4 radiance;

void main() {
    CaptureMaterial material = materials[triangleMaterials[triangle]];
    bool front = dot(geometricNormal, worldPosition - c.probe.xyz) < 0.0;
    bool doubleSided = material.sides.x > 0.5;
    if (!front && !doubleSided) {
        radiance = vec4(0.0, 0.0, 0.0, SHPROBE_CAPTURE_BACK_FACE);
        return;
    }
    vec3 n = normalize(shadingNormal) * (front ? 1.0 : -1.0);
    vec3 faceNormal = normalize(geometricNormal) * (front ? 1.0 : -1.0);
    vec3 irradiance = sunIrradiance(worldPosition, n, faceNormal);
    if (volume.counts.w != 0u) {
        ProbeVolumeGrid grid = ProbeVolumeGrid(volume.boundsMin.xyz, volume.boundsMax.xyz, volume.counts.xyz);
        irradiance += probeVolumeIrradiance(grid, worldPosition, n);
    }
    radiance = vec4(surfaceLeaving(material, uv, irradiance), 0.0);
}
