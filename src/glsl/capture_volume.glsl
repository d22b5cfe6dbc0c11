// The capture's volume of the previous bounce (SHPROBE_CAPTURE_VOLUME: CaptureVolumeHeader, then
// order^2 vec4 per probe, then the visibility maps and the capture offsets), its coefficients,
// visibility and offsets as
// glsl/probe_volume.glsl reads them. The includer
// declares SH_ORDER first.
#ifndef SHPROBE_CAPTURE_VOLUME_GLSL
#define SHPROBE_CAPTURE_VOLUME_GLSL

layout(std430, set = 0, binding = SHPROBE_CAPTURE_VOLUME) readonly buffer Volume {
    CaptureVolumeHeader volume;
    vec4 volumeCoefficients[];
};

vec4 probeVolumeCoefficient(uint probe, uint index) {
    return volumeCoefficients[probe * SH_ORDER * SH_ORDER + index];
}

#define SHPROBE_PROBE_VOLUME_VISIBILITY
uint probeVolumeVisibilitySize() {
    return volume.visibility.x;
}

vec2 probeVolumeVisibility(uint probe, uint texel) {
    uint size = volume.visibility.x;
    uint index = probe * size * size + texel;
    vec4 pair = volumeCoefficients[volume.visibility.y + index / 2u];
    return (index & 1u) == 0u ? pair.xy : pair.zw;
}

vec3 probeVolumeOffset(uint probe) {
    return volume.visibility.z == 0u ? vec3(0.0) : volumeCoefficients[volume.visibility.z + probe].xyz;
}

#endif
