// A probe's sphere shaded by its own SH: what a white diffuse sphere at the probe would reflect,
// E(n) / pi from the probe's irradiance coefficients; a probe inside geometry (invalid) is drawn
// dark red.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
layout(constant_id = SHPROBE_SPEC_ORDER) const uint SH_ORDER = 3u;
#include "capture_common.glsl"
#include "capture_volume.glsl"
#include "sh_basis.glsl"

layout(location = 0) in vec3 worldNormal;
layout(location = 1) flat in uint probe;

layout(location = 0) out vec4 radiance;

void main() {
    if (probeVolumeCoefficient(probe, 0u).w < 0.5) {
        radiance = vec4(0.3, 0.0, 0.0, 0.0);
        return;
    }
    float y[SH_BASIS_CAPACITY];
    shEvalBasis(normalize(worldNormal), y);
    vec3 e = vec3(0.0);
    for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
        e += probeVolumeCoefficient(probe, i).rgb * y[i];
    radiance = vec4(max(e, vec3(0.0)) * (1.0 / 3.14159265358979), 0.0);
}
