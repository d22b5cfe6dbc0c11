#version 450
// The radiance relight.vert computed per vertex, interpolated: linear, unclamped, a = 1.
// Input: location 0 vec3 radiance. Output: location 0 vec4 colour.
layout(location = 0) in vec3 radiance;
layout(location = 0) out vec4 color;

void main() {
    color = vec4(radiance, 1.0);
}
