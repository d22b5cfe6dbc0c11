// The world's triangles seen from one face of one probe (capture_interface.h). No vertex inputs:
// vertex v of the draw is corner v % 3 of triangle v / 3, pulled from the storage buffers, so the
// fragment knows its triangle (its material, its geometric normal) without gl_PrimitiveID.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "capture_common.glsl"

layout(location = 0) out vec3 worldPosition;
layout(location = 1) out vec3 shadingNormal;
layout(location = 2) out vec2 uv;
layout(location = 3) flat out uint triangle;
layout(location = 4) flat out vec3 geometricNormal;

// How much farther a back face is drawn, relative to its distance (2^-16): far above the
// rasterizer's few ulps of depth (lavapipe misorders faces 1.6e-7 apart), far below any gap meant.
const float BACK_SHIFT = 1.0 / 65536.0;

void main() {
    triangle = uint(gl_VertexIndex) / 3u;
    vec3 p0 = vertices[indices[3u * triangle]].positionU.xyz;
    vec3 p1 = vertices[indices[3u * triangle + 1u]].positionU.xyz;
    vec3 p2 = vertices[indices[3u * triangle + 2u]].positionU.xyz;
    // Counter-clockwise seen from the front (glTF): the front's side, unnormalized.
    geometricNormal = cross(p1 - p0, p2 - p0);
    CaptureVertex v = vertices[indices[gl_VertexIndex]];
    worldPosition = v.positionU.xyz;
    shadingNormal = v.normalV.xyz;
    uv = vec2(v.positionU.w, v.normalV.w);
    gl_Position = c.worldToClip * vec4(worldPosition, 1.0);
    // A triangle whose back faces the probe (capture.frag's test, on the triangle's plane) is drawn
    // BACK_SHIFT farther (depth = z / w, with z the near plane): where a texel's ray passes through
    // an edge joining a front and a back face, both cover the texel at the same depth, and rounding
    // must not let the back, where the ray leaves a solid, hide the front, where it enters.
    if (c.view.z != 0.0 && dot(geometricNormal, p0 - c.probe.xyz) >= 0.0) gl_Position.z *= 1.0 - BACK_SHIFT;
}
