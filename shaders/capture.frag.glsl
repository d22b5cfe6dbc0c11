// What a probe sees of a surface (scene/scene.h): a front face leaves its emission plus the
// irradiance of the previous bounce reflected by its albedo; the back of a one-sided surface
// leaves nothing and is marked in alpha (SHPROBE_CAPTURE_BACK_FACE).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3u; // the previous volume's order
#include "capture_common.glsl"
layout(std430, set = 0, binding = SHPROBE_CAPTURE_VOLUME) readonly buffer Volume {
    CaptureVolumeHeader volume;
    vec4 volumeCoefficients[];
};

vec4 probeVolumeCoefficient(uint probe, uint index) {
    return volumeCoefficients[probe * SH_ORDER * SH_ORDER + index];
}
#include "probe_volume.glsl"

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
    vec3 albedo = material.albedo.rgb * textureColor(material.albedo.w, uv);
    vec3 emission = material.emission.rgb * textureColor(material.emission.w, uv);
    vec3 bounced = vec3(0.0);
    if (volume.counts.w != 0u) {
        ProbeVolumeGrid grid = ProbeVolumeGrid(volume.boundsMin.xyz, volume.boundsMax.xyz, volume.counts.xyz);
        bounced = probeVolumeIrradiance(grid, worldPosition, n);
    }
    radiance = vec4(emission + albedo * (1.0 / 3.14159265358979) * bounced, 0.0);
}
