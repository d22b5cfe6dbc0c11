// Declarations shared by the scene modules (scene.vert/.frag, background.frag): the uniform block,
// the specialization constants and the shading function of a normal. See render_interface.h.
//
// Bindings: set 0, binding 0: RenderUniforms (uniform block); binding 1: the environment cube map
// (combined image sampler, linear filtering). Specialization constants: SHPROBE_SPEC_RENDER_ORDER,
// SHPROBE_SPEC_SHADING, SHPROBE_SPEC_BACKGROUND.
#ifndef SHPROBE_RENDER_COMMON_GLSL
#define SHPROBE_RENDER_COMMON_GLSL

#include "render_interface.h"
#include "sh_irradiance.glsl"

layout(constant_id = SHPROBE_SPEC_RENDER_ORDER) const uint SH_ORDER = 3u;
layout(constant_id = SHPROBE_SPEC_SHADING) const uint SHADING = SHPROBE_SHADING_IRRADIANCE;
layout(constant_id = SHPROBE_SPEC_BACKGROUND) const uint BACKGROUND = SHPROBE_BACKGROUND_ENVIRONMENT;

layout(set = 0, binding = 0, std140) uniform Uniforms {
    RenderUniforms u;
};

// What a surface of unit normal n and the given albedo shows, by SHADING.
vec3 shadeNormal(vec3 n, vec3 albedo) {
    if (SHADING == SHPROBE_SHADING_RADIANCE) return shRadiance(u.radiance, n, SH_ORDER);
    if (SHADING == SHPROBE_SHADING_IRRADIANCE) return albedo * shIrradianceOverPi(u.irradiance, n, SH_ORDER);
    return albedo * shL1NonLinearOverPi(u.l1, n);
}

#endif
