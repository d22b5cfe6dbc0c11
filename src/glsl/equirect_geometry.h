// Equirect-map pixel geometry, shared by C++ and GLSL. Conventions: docs/conventions.md,
// "Equirectangular maps": pixel (i, j) of a W x H map, row 0 at the top, has
// theta = pi (j + 0.5) / H, phi = 2 pi (i + 0.5) / W - pi and the direction
// (sin theta sin phi, cos theta, -sin theta cos phi); every pixel of row j has the solid angle
// (2 pi / W)(cos theta_j - cos theta_j+1), theta_j = pi j / H its top edge. sh/cubemap.h has the
// double versions (equirectDirection, equirectRowSolidAngle).
#ifndef SHPROBE_EQUIRECT_GEOMETRY_H
#define SHPROBE_EQUIRECT_GEOMETRY_H
#include "precise_math.h"
#include "texel_geometry.h"

SHPROBE_BEGIN

// (sin theta, cos theta) of row j: theta / pi = (2j + 1) / (2H).
SHPROBE_FN vec2 equirectRowSinCos(uint j, uint height) {
    return preciseSinCosPi(int(2u * j + 1u), 2u * height);
}

// (sin phi, cos phi) of column i: phi / pi = (2i + 1 - W) / W.
SHPROBE_FN vec2 equirectColumnSinCos(uint i, uint width) {
    return preciseSinCosPi(int(2u * i + 1u) - int(width), width);
}

// The unit direction of pixel (i, j), from its row's and column's sines and cosines.
SHPROBE_FN vec3 equirectDirectionOf(vec2 row, vec2 column) {
    return vec3(row.x * column.x, row.y, -row.x * column.y);
}

// The solid angle of a pixel of row j is this scale times the row's sin theta, without the
// cancellation of cos theta_j - cos theta_j+1 in fp32 (two numbers near each other near the poles):
// cos(t - h) - cos(t + h) = 2 sin t sin h, with t the row's center and h = pi / (2H) half its height,
// so the solid angle is (4 pi / W) sin h sin t.
SHPROBE_FN float equirectSolidAngleScale(uint width, uint height) {
    return 12.5663706144f / float(width) * preciseSinCosPi(1, 2u * height).x;
}

// The GPU projection (project_equirect.comp) visits positions (i, j), j < ceil(H / 2), each with
// its row mirror H - 1 - j (theta -> pi - theta: y negated) and, for i < ceil(W / 2), its column
// mirror W - 1 - i (phi -> -phi: x negated). When W is even the half turn i + W / 2 (phi -> phi + pi:
// x and z negated) is a pixel too: then i < ceil(W / 4) and the position also holds W / 2 - 1 - i
// (z negated) and i + W / 2, eight pixels whose directions differ in the signs of x, y and z.
SHPROBE_FN bool equirectHasHalfTurn(uint width) {
    return (width & 1u) == 0u;
}

SHPROBE_FN uint equirectPositionColumns(uint width) {
    return equirectHasHalfTurn(width) ? quadrantSize(width / 2u) : quadrantSize(width);
}

// Pixels per position: 8 with the half turn, 4 without (fewer where a column or row is its own
// mirror image).
SHPROBE_FN uint equirectTexelsPerPosition(uint width) {
    return equirectHasHalfTurn(width) ? 8u : 4u;
}

SHPROBE_END

#endif
