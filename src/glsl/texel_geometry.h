// Cube-map texel geometry, shared by C++ and GLSL. Conventions: docs/conventions.md, "Cube-map faces"
// and "Texel weight", and the Vulkan specification, "Cube Map Face Selection". Layer order and face
// orientation:
//
//              +----+
//              | +Y |          face 0 +X: ( 1, -b, -a)   face 1 -X: (-1, -b,  a)
//         +----+----+----+----+  face 2 +Y: ( a,  1,  b)   face 3 -Y: ( a, -1, -b)
//         | -X | +Z | +X | -Z |  face 4 +Z: ( a, -b,  1)   face 5 -Z: (-a, -b, -1)
//         +----+----+----+----+
//              | -Y |          a = 2(i + 0.5)/N - 1 (column), b = 2(j + 0.5)/N - 1 (row, top = 0)
//              +----+
#ifndef SHPROBE_TEXEL_GEOMETRY_H
#define SHPROBE_TEXEL_GEOMETRY_H
#include "precise_math.h"

SHPROBE_BEGIN

// Face-local coordinate of the center of texel i (or row j) on an N-wide face, in (-1, 1).
SHPROBE_FN float texelCenterCoord(uint i, uint faceSize) {
    return 2.0f * (float(i) + 0.5f) / float(faceSize) - 1.0f;
}

// The face table applied to v = (a, b, c): c along the face's axis, a and b across it.
// With c = 1 it gives the unnormalized direction through face-local point (a, b); applied to the
// normalized (a, b, 1) it gives unit directions, so one normalization serves all six faces.
SHPROBE_FN vec3 orientToFace(uint face, vec3 v) {
    switch (face) {
    case 0u:
        return vec3(v.z, -v.y, -v.x);
    case 1u:
        return vec3(-v.z, -v.y, v.x);
    case 2u:
        return vec3(v.x, v.z, v.y);
    case 3u:
        return vec3(v.x, -v.z, -v.y);
    case 4u:
        return vec3(v.x, -v.y, v.z);
    default:
        return vec3(-v.x, -v.y, -v.z);
    }
}

// Face-local coordinate of ray `stratum` of s across texel i (or row j) of an N-wide face, at
// `jitter` in [0, 1) of its stratum: a probe's view by rays (scene/view_rays.h, capture_rays.comp).
// s = 1 at jitter 1/2 is the texel's centre.
SHPROBE_FN float stratumCoord(uint i, uint stratum, uint s, float jitter, uint faceSize) {
    return 2.0f * (float(i) + (float(stratum) + jitter) / float(s)) / float(faceSize) - 1.0f;
}

// The index of ray (sa, sb) of texel (i, j) of `face` among a view's strata, the view's rays at
// faces of N s: faces, then rows of N s strata, in order (scene/emitters.h stratumSkyRays).
SHPROBE_FN uint stratumIndex(uint face, uint i, uint j, uint sa, uint sb, uint faceSize, uint s) {
    uint strata = faceSize * s;
    return (face * strata + j * s + sb) * strata + i * s + sa;
}

// The GPU projection visits the positions (i, j) with i, j < ceil(N / 2), each with its mirror
// images (N - 1 - i, j), (i, N - 1 - j) and (N - 1 - i, N - 1 - j): four texels per face.
SHPROBE_FN uint quadrantSize(uint faceSize) {
    return (faceSize + 1u) / 2u;
}

// Unnormalized direction through face-local point (a, b) of a face (shprobe::faceDirection of
// sh/cubemap.h is the unit one, in double).
SHPROBE_FN vec3 unnormalizedFaceDirection(uint face, float a, float b) {
    return orientToFace(face, vec3(a, b, 1.0f));
}

// Solid angle of the spherical triangle spanned by p0, p1, p2 (not necessarily unit), given
// their triple product, for triangles within a cube face (solid angle at most pi/3). Van Oosterom &
// Strackee (1983):
//   tan(omega / 2) = |p0.(p1 x p2)| / (|p0||p1||p2| + (p0.p1)|p2| + (p0.p2)|p1| + (p1.p2)|p0|).
SHPROBE_FN float triangleSolidAngle(vec3 p0, vec3 p1, vec3 p2, float tripleProduct) {
    float l0 = length(p0);
    float l1 = length(p1);
    float l2 = length(p2);
    float denominator = l0 * l1 * l2 + dot(p0, p1) * l2 + dot(p0, p2) * l1 + dot(p1, p2) * l0;
    return 2.0f * preciseAtan(abs(tripleProduct) / denominator);
}

// Exact solid angle of texel (i, j) of an N x N face, accurate in fp32 at every face size (what
// the shaders weigh texels by; shprobe::texelSolidAngle of sh/cubemap.h is the double reference).
// The four-atan2 form of docs/conventions.md cancels catastrophically in fp32 (terms near 0.5,
// result near 4/N^2). Here the texel, with corners (a, b, 1) on the plane z = 1, is split into two
// triangles whose triple products both equal its area (2/N)^2, taken from N itself rather than from
// differences of rounded corner coordinates; every term of the denominator is positive and only
// mildly sensitive to the corners' rounding. No cancellation anywhere: a few ulps of error.
SHPROBE_FN float texelSolidAngleFp32(uint i, uint j, uint faceSize) {
    float h = 1.0f / float(faceSize); // half the texel's width in face coordinates
    float a = texelCenterCoord(i, faceSize);
    float b = texelCenterCoord(j, faceSize);
    vec3 p00 = vec3(a - h, b - h, 1.0f);
    vec3 p10 = vec3(a + h, b - h, 1.0f);
    vec3 p11 = vec3(a + h, b + h, 1.0f);
    vec3 p01 = vec3(a - h, b + h, 1.0f);
    float area = 4.0f * h * h;
    return triangleSolidAngle(p00, p10, p11, area) + triangleSolidAngle(p00, p11, p01, area);
}

SHPROBE_END

#endif
