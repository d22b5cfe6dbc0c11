// Reading a glTF 2.0 scene (docs/scene-probes.md, "Scene input") into a World: a .gltf (JSON, its
// buffers and images in files beside it or in data URIs) or a .glb (binary, the file's BIN chunk).
//
// What is read, from the default scene (else scene 0; else every node that has no parent):
//   - every mesh primitive drawn as triangles (mode 4, or absent), triangle strips and fans
//     (converted to triangle lists), placed by its node's transform (matrix, or translation,
//     rotation and scale) composed down the hierarchy; a transform that mirrors (determinant < 0)
//     flips the winding, as glTF says, so that every World triangle is counter-clockwise seen
//     from its front;
//   - POSITION, NORMAL (transformed by the inverse transpose, normalized; a primitive without
//     normals gets flat face normals, its vertices unshared; a zero normal is replaced by the mean
//     of its triangles' face normals) and TEXCOORD_0, from accessors of any byte stride, sparse
//     accessors and accessors without a buffer view (zeros) included, integer components
//     normalized where the accessor says so; KHR_mesh_quantization's integer positions, normals
//     and texture coordinates;
//   - materials as diffuse surfaces: baseColorFactor.rgb and baseColorTexture as albedo,
//     emissiveFactor times KHR_materials_emissive_strength and emissiveTexture as emission,
//     doubleSided; colour textures (PNG or JPEG, in a buffer view, a data URI or a file) decoded
//     from sRGB to linear, alpha ignored. A primitive without a material gets glTF's default
//     material (albedo 1, no emission, one-sided);
//   - KHR_lights_punctual's directional lights as suns (towards the light: the node's world +Z).
//
// What is ignored, and said in World::description ("; 2 point lights ignored"): point and spot
// lights, and primitives of points or lines (no surface to light). Ignored without a word (they do
// not change what a diffuse surface reflects, or a scene without them is the one meant): cameras,
// animations, skins (a skinned mesh is placed by its node, in its bind pose), morph targets (the
// base shape), metallic, roughness, normal, occlusion and alpha (every surface is opaque),
// samplers (textures repeat and are filtered bilinearly, World's rule) and KHR_texture_transform.
//
// What is refused, as one line "PATH: REASON" in Error(ErrorKind::Input): a path that is missing, a
// folder, empty or unreadable (common/input_file.h); a file that is neither JSON nor a .glb, or a
// .glb cut short; a buffer or image URI naming a file outside the scene's folder (by "..", an
// absolute path or a symbolic link), refused before the file is opened; a property of the wrong
// JSON type (glTF 2.0's schema: "scenes[0].name must be a string"); what tinygltf refuses (its
// messages joined into the line); a buffer or image file that cannot be read; a buffer view
// reaching past its buffer, or an accessor whose count of elements (at its stride, from its
// offset) needs more bytes than its buffer view holds, refused from the JSON before tinygltf reads
// a buffer; an index past the vertices; a value that is NaN or infinite;
// an attribute of the wrong type or component type; a triangle list whose count is not a multiple
// of 3; a node hierarchy with a cycle or a node with two parents; an extension in
// extensionsRequired that is not read here (Draco, KHR_texture_basisu, ...); a texture read through
// a TEXCOORD other than 0; a scene without triangles; and more triangles or vertices (summed over every node
// that instances a mesh), pixels in one texture or in all the textures the drawn materials use (from the
// images' headers) than the limits below (scene/gltf_limits.h), before any vertex is read or image
// decoded. Input quoted in a message (a URI, a name) is cut to a few hundred bytes (common/quoted.h).
#pragma once
#include "scene/gltf_limits.h"
#include "scene/scene.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace tinygltf {
class Model;
}

namespace shprobe {

struct GltfLoadOptions {
    // Triangles in the World, every instance counted: the scene's total is checked before any
    // vertex is read; vertices are limited to 3 per triangle of it.
    size_t maxTriangles = kMaxGltfTriangles;
    // Pixels of one texture, and of all the textures the drawn materials use: checked from the
    // images' headers before any is decoded.
    int64_t maxTexturePixels = kMaxGltfTexturePixels;
    int64_t maxSceneTexturePixels = kMaxGltfSceneTexturePixels;
};

// The files the scene at `path` reads besides itself: the buffer and image URIs that are not data
// URIs, as the paths loadGltfScene opens, from the JSON alone (a .gltf, or a .glb's JSON chunk), so
// that a command can tell its outputs from them before any work. Throws what loadGltfScene throws
// for a file it cannot read or a URI outside the scene's folder.
std::vector<std::string> gltfExternalFiles(const std::string& path);

// What the scene at `path` is, whatever path names it: Fnv1a64 (common/content_hash.h) of the file
// and then of each file gltfExternalFiles lists, in its order, each part its length (8 bytes, least
// significant first) and its bytes, as "fnv1a64:" and 16 hex digits. A listed file that cannot be
// read (an image no material uses, which loadGltfScene never opens) counts as the length 2^64 - 1
// and no bytes. Throws what gltfExternalFiles throws.
std::string gltfSceneHash(const std::string& path);

// Reads the scene at `path` into world-space triangles; see above for what is read, ignored and
// refused. World::description is "NAME (T triangles, M materials, S suns)" with NAME the path.
World loadGltfScene(const std::string& path, const GltfLoadOptions& options = {});

// Where World vertices come from: the node that placed a mesh primitive, and each vertex's index in
// the primitive's POSITION (a primitive without normals has 3 World vertices per triangle, its
// corners; the others one per POSITION element, in order).
struct GltfPlacedPrimitive {
    int node = -1;
    int mesh = -1;
    int primitive = -1;
    uint32_t firstVertex = 0;             // World vertices firstVertex, firstVertex + 1, ...
    std::vector<uint32_t> sourceVertices; // ... each one's POSITION element
    uint32_t positionCount = 0;           // POSITION's count
};

// The scene as loadGltfScene reads it, with tinygltf's model kept for a command that writes the
// scene back with more in it (scene/transfer_gltf.h): every image given its bytes (from its buffer
// view, data URI or file), and the placed primitives in World vertex order. Throws what
// loadGltfScene throws, and Error(Input) for an image file that cannot be read.
struct GltfSceneSource {
    World world;
    std::vector<GltfPlacedPrimitive> primitives;
    std::shared_ptr<const tinygltf::Model> model;
    std::string json; // the file's JSON as written (a .glb's JSON chunk), checked by checkGltfJson
};
GltfSceneSource loadGltfSceneSource(const std::string& path, const GltfLoadOptions& options = {});

} // namespace shprobe
