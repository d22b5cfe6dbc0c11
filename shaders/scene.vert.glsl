// Meshes (sphere, torus): world position and normal for scene.frag.
// Inputs: location 0 position, location 1 normal (object space). Push constants: ObjectConstants.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "render_common.glsl"

layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;

layout(push_constant, std430) uniform Push {
    ObjectConstants object;
};

layout(location = 0) out vec3 worldNormal;

void main() {
    // mat3(model) is a rotation times a uniform scale: it maps normals as it maps directions.
    worldNormal = mat3(object.model) * normal;
    gl_Position = u.viewProjection * (object.model * vec4(position, 1.0));
}
