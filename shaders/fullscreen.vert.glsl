// One triangle covering the viewport, at the far plane (depth 1): draw 3 vertices, no inputs.
#version 450

void main() {
    vec2 corner = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2); // (0,0) (2,0) (0,2)
    gl_Position = vec4(corner * 2.0 - 1.0, 1.0, 1.0);
}
