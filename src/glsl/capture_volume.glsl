// The capture's volume of the previous bounce (SHPROBE_CAPTURE_VOLUME: CaptureVolumeHeader, then
// order^2 vec4 per probe), and its coefficients as glsl/probe_volume.glsl reads them. The includer
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

#endif
