// Triangle meshes of the shapes the renderer draws, built on the CPU: a UV sphere and a torus,
// with exact (analytic) vertex normals. Counter-clockwise front faces seen from outside.
#pragma once
#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

namespace shprobe {

struct MeshVertex {
    glm::vec3 position;
    glm::vec3 normal;
};

struct MeshData {
    std::vector<MeshVertex> vertices;
    std::vector<uint32_t> indices; // triangle list
};

// Unit sphere centred at the origin, poles on +-Y: `segments` around, `rings` from pole to pole.
MeshData makeSphereMesh(int segments, int rings);

// Torus around the Y axis: tube centre at distance majorRadius, tube radius minorRadius.
MeshData makeTorusMesh(float majorRadius, float minorRadius, int segments, int sides);

} // namespace shprobe
