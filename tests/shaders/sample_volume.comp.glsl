#version 450
// Test module: glsl/probe_volume.glsl as an engine uses it, its coefficients in a 2D-array texture
// (docs/probe-volume.md, "On the GPU"): probe (i, j, k)'s coefficient c at texel
// (i * SH_ORDER^2 + c, j) of layer k, rgb and validity in w; the visibility maps in a storage
// buffer, the capture offsets in another. Writes E(n) at each point, for the CPU reference of scene/volume_sampling.h to check.
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3u;
layout(set = 0, binding = 0) uniform sampler2DArray volumeTexture;
layout(set = 0, binding = 1, std430) readonly buffer Points { vec4 points[]; }; // position, normal, ...
layout(set = 0, binding = 2, std430) writeonly buffer Results { vec4 results[]; };
layout(set = 0, binding = 3, std430) readonly buffer Visibility { vec2 moments[]; };
layout(set = 0, binding = 4, std430) readonly buffer Offsets { vec4 offsets[]; }; // xyz, per probe
layout(push_constant, std430) uniform Push {
    vec4 boundsMin;
    vec4 boundsMax;
    uvec4 counts;     // xyz: probes per axis; w: points
    uvec4 visibility; // x: texels a side of each probe's map, 0: none; y: 1 with capture offsets
};

vec4 probeVolumeCoefficient(uint probe, uint index) {
    uint i = probe % counts.x, j = (probe / counts.x) % counts.y, k = probe / (counts.x * counts.y);
    return texelFetch(volumeTexture, ivec3(i * SH_ORDER * SH_ORDER + index, j, k), 0);
}
#define SHPROBE_PROBE_VOLUME_VISIBILITY
uint probeVolumeVisibilitySize() {
    return visibility.x;
}
vec2 probeVolumeVisibility(uint probe, uint texel) {
    return moments[probe * visibility.x * visibility.x + texel];
}
vec3 probeVolumeOffset(uint probe) {
    return visibility.y == 0u ? vec3(0.0) : offsets[probe].xyz;
}
#include "probe_volume.glsl"

void main() {
    uint point = gl_GlobalInvocationID.x;
    if (point >= counts.w) return;
    ProbeVolumeGrid grid = ProbeVolumeGrid(boundsMin.xyz, boundsMax.xyz, counts.xyz);
    results[point] = vec4(probeVolumeIrradiance(grid, points[2u * point].xyz, points[2u * point + 1u].xyz), 0.0);
}
