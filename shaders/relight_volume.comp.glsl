#version 450
// Relights a probe volume baked with its transfer (docs/probe-volume.md, "Relighting") under a sky
// of radiance coefficients S_j: L_i = static_i + sum_j T_ij S_j, then E_i = A_l L_i, written with
// the probe's validity in w: the layout probe_volume.glsl's probeVolumeCoefficient returns, so a
// volume relit every frame (a time of day) is sampled from this output as it is. One invocation per
// output coefficient.
//
// Interface (shaders/INTERFACE.md):
//   set 0, binding 0: readonly buffer, float transfer[]: the file's transfer section as it is
//   set 0, binding 1: readonly buffer, float staticRadiance[]: the file's static radiance as it is
//   set 0, binding 2: readonly buffer, uint validity[]: the file's validity bytes, four a word
//   set 0, binding 3: readonly buffer, vec4 sky[]: the sky's SH_COEFFICIENTS coefficients (rgb)
//   set 0, binding 4: writeonly buffer, vec4 irradiance[]: probe p's E_i at p * SH_COEFFICIENTS + i
//   push constants: RelightVolumeParams (gpu_interface.h)
//   specialization: 0 = workgroup width, 1 = SH order (1..8); dispatch
//   ceil(probeCount * SH_COEFFICIENTS / width) workgroups.
#extension GL_GOOGLE_include_directive : require

#include "gpu_interface.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3;
const uint SH_COEFFICIENTS = SH_ORDER * SH_ORDER;

layout(set = 0, binding = 0, std430) readonly buffer Transfer { float transfer[]; };
layout(set = 0, binding = 1, std430) readonly buffer StaticRadiance { float staticRadiance[]; };
layout(set = 0, binding = 2, std430) readonly buffer Validity { uint validity[]; };
layout(set = 0, binding = 3, std430) readonly buffer Sky { vec4 sky[]; };
layout(set = 0, binding = 4, std430) writeonly buffer Irradiance { vec4 irradiance[]; };
layout(push_constant, std430) uniform Push { RelightVolumeParams params; };

vec3 staticRadianceAt(uint first) {
    return vec3(staticRadiance[first], staticRadiance[first + 1u], staticRadiance[first + 2u]);
}

void main() {
    uint index = gl_GlobalInvocationID.x;
    if (index >= params.probeCount * SH_COEFFICIENTS) return;
    uint probe = index / SH_COEFFICIENTS;
    uint l = bandOfIndex(index - probe * SH_COEFFICIENTS);
    vec3 radiance = staticRadianceAt(3u * index);
    uint row = 3u * SH_COEFFICIENTS * index; // T_i0 of this probe's row i
    for (uint j = 0u; j < SH_COEFFICIENTS; ++j, row += 3u)
        radiance += vec3(transfer[row], transfer[row + 1u], transfer[row + 2u]) * sky[j].rgb;
    uint valid = (validity[probe >> 2u] >> (8u * (probe & 3u))) & 0xffu;
    irradiance[index] = vec4(radiance * params.bandScale[l / 4u][l % 4u], float(valid));
}
