// The triangles of glTF mesh primitives (part of the glTF reader, scene/gltf_scene.h): read from
// tinygltf's model with every accessor checked against its buffer, then placed in world space.
#pragma once
#include "scene/scene.h"

#include <cstddef>
#include <glm/mat4x4.hpp>
#include <string>
#include <vector>

namespace tinygltf {
class Model;
}

namespace shprobe {

// The model the primitives come from, and how to name it in errors.
struct GltfGeometrySource {
    const tinygltf::Model& model;
    const std::string& path;
    bool quantized = false; // KHR_mesh_quantization is used: integer positions, normals and uvs
};

// What a primitive draws, from its mode and counts alone (nothing is read): triangles, or points
// and lines (modes 0 to 3), which have no surface. Throws Error(Input) "PATH: WHERE: REASON" for
// an unknown mode, a primitive without POSITION or a triangle list whose count is not a multiple
// of 3.
struct PrimitiveShape {
    bool pointsOrLines = false;
    size_t triangles = 0;
    size_t vertices = 0; // POSITION's count
};
PrimitiveShape primitiveShape(const GltfGeometrySource& source, int mesh, int primitive);

// A primitive in its mesh's space, as a triangle list.
struct PrimitiveGeometry {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals; // empty: the primitive has none (flat normals are made)
    std::vector<glm::vec2> uvs;     // empty: none
    std::vector<uint32_t> indices;  // 3 per triangle, each below positions.size()
};

// Reads a primitive of triangles (primitiveShape says so); throws Error(Input) "PATH: WHERE:
// REASON" for accessors of the wrong type, past their buffer, of different counts, holding NaN
// or infinite values, and for indices past the vertices.
PrimitiveGeometry readPrimitive(const GltfGeometrySource& source, int mesh, int primitive);

// Appends the primitive, placed by `transform`, to the world's positions, normals, uvs, indices
// and triangleMaterials (bounds are left to the caller). A transform of negative determinant flips
// the winding, as glTF says. Throws Error(Input) "WHERE: REASON" if the transform takes a vertex
// to infinity.
void appendPrimitive(World& world, const PrimitiveGeometry& geometry, const glm::dmat4& transform,
                     uint32_t material, const std::string& where);

} // namespace shprobe
