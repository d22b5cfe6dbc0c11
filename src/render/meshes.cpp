// Parametric meshes: a grid of (u, v) vertices wrapped around the shape, two triangles per cell.
#include "render/meshes.h"

#include "common/error.h"

#include <cmath>
#include <functional>
#include <numbers>

namespace shprobe {

namespace {

constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;

// (columns + 1) x (rows + 1) vertices from vertexAt(u, v), u and v in [0, 1]; cells split in two
// triangles, wound counter-clockwise when u runs along the outward normal's right-hand side.
MeshData makeGridMesh(int columns, int rows, const std::function<MeshVertex(float, float)>& vertexAt) {
    if (columns < 3 || rows < 2) throw Error(ErrorKind::Input, "a mesh needs at least 3 x 2 cells");
    MeshData mesh;
    for (int j = 0; j <= rows; ++j)
        for (int i = 0; i <= columns; ++i)
            mesh.vertices.push_back(vertexAt(float(i) / columns, float(j) / rows));
    auto index = [&](int i, int j) { return uint32_t(j * (columns + 1) + i); };
    for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < columns; ++i) {
            mesh.indices.insert(mesh.indices.end(), {index(i, j), index(i, j + 1), index(i + 1, j)});
            mesh.indices.insert(mesh.indices.end(), {index(i + 1, j), index(i, j + 1), index(i + 1, j + 1)});
        }
    }
    return mesh;
}

} // namespace

MeshData makeSphereMesh(int segments, int rings) {
    return makeGridMesh(segments, rings, [](float u, float v) {
        float theta = std::numbers::pi_v<float> * v, phi = kTwoPi * u;
        glm::vec3 n(std::sin(theta) * std::sin(phi), std::cos(theta), std::sin(theta) * std::cos(phi));
        return MeshVertex{n, n};
    });
}

MeshData makeTorusMesh(float majorRadius, float minorRadius, int segments, int sides) {
    return makeGridMesh(segments, sides, [=](float u, float v) {
        float phi = kTwoPi * u, psi = -kTwoPi * v;            // psi decreasing: same winding as the sphere
        glm::vec3 around(std::sin(phi), 0.0f, std::cos(phi)); // towards the tube centre
        glm::vec3 n = std::cos(psi) * around + std::sin(psi) * glm::vec3(0.0f, 1.0f, 0.0f);
        return MeshVertex{majorRadius * around + minorRadius * n, n};
    });
}

} // namespace shprobe
