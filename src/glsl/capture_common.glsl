// The capture modules' bindings and push constants (capture_interface.h), and the world's
// surfaces as scene/scene.h describes them.
#ifndef SHPROBE_CAPTURE_COMMON_GLSL
#define SHPROBE_CAPTURE_COMMON_GLSL
#include "capture_world.glsl"
#include "texel_geometry.h"

layout(push_constant, std430) uniform Push {
    CaptureConstants c;
};

// The sky texel a direction falls in.
vec3 skyRadiance(vec3 d) {
    return skyTexel(d, c.face.z);
}

#endif
