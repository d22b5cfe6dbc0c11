// The limits of the glTF reader (scene/gltf_scene.h), in one place; docs/reliability.md lists them
// with the message each refusal gives. Every size a file claims is checked against them, or against
// the bytes that back it, before anything of that size is allocated, read or decoded.
#pragma once
#include <climits>
#include <cstddef>
#include <cstdint>

namespace shprobe {

// The largest glTF, .glb, buffer or image file read: tinygltf counts bytes in int.
constexpr uint64_t kMaxGltfFileBytes = (uint64_t(1) << 31) - 1;

// glTF nests a handful of levels (root, meshes, a primitive, its attributes); extras may go
// further. The JSON parser stops here, before it builds the levels below.
constexpr int kMaxGltfJsonDepth = 64;

// tinygltf reads indices into int, and sizes (byteLength, byteOffset, count) into size_t from JSON
// numbers, which hold integers exactly up to 2^53.
constexpr int64_t kMaxGltfIndex = INT_MAX;
constexpr int64_t kMaxGltfSize = int64_t(1) << 53;

// The largest byte stride glTF allows (bufferView.byteStride, 4 to 252).
constexpr int64_t kMaxGltfByteStride = 252;

// Triangles in the World, every instance counted (a small file may instance one large mesh many
// times); vertices are limited to 3 per triangle of it. The defaults of GltfLoadOptions.
constexpr size_t kMaxGltfTriangles = 20'000'000;
// Pixels of one texture: a texel takes 16 bytes in World, so 8192 x 8192 is 1 GiB.
constexpr int64_t kMaxGltfTexturePixels = int64_t(8192) * 8192;
// Pixels of all the textures the scene's materials use (2 GiB in World), as an environment
// image's default --max-pixels: the textures go to the device in one storage buffer.
constexpr int64_t kMaxGltfSceneTexturePixels = int64_t(1) << 27;

} // namespace shprobe
