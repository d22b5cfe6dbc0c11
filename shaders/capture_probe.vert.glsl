// The probes of the capture's volume (the previous bounce's, SHPROBE_CAPTURE_VOLUME) as small
// spheres, for pictures of a scene and its probes: instance p is probe p, at its grid position.
// Vertex inputs: location 0 position, location 1 normal of a unit sphere (render/meshes.h).
// Push constants: CaptureConstants, probe.w the spheres' radius.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3u;
#include "capture_common.glsl"
#include "capture_volume.glsl"

layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;

layout(location = 0) out vec3 worldNormal;
layout(location = 1) flat out uint probe;

void main() {
    probe = uint(gl_InstanceIndex);
    uvec3 counts = volume.counts.xyz;
    uvec3 cell = uvec3(probe % counts.x, (probe / counts.x) % counts.y, probe / (counts.x * counts.y));
    vec3 t = mix(vec3(0.5), vec3(cell) / vec3(max(counts, uvec3(2u)) - 1u), greaterThan(counts, uvec3(1u)));
    vec3 centre = mix(volume.boundsMin.xyz, volume.boundsMax.xyz, t);
    worldNormal = normal;
    gl_Position = c.worldToClip * vec4(centre + c.probe.w * position, 1.0);
}
