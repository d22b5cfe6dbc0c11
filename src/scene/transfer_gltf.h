// The files engines read per-vertex transfer from (docs/transfer.md):
//   - the scene itself as a .glb, each placed mesh primitive given the vertex attributes
//     _SH_TRANSFER_0 .. _SH_TRANSFER_{k-1} (VEC4 float accessors), described in asset.extras.shTransfer;
//   - a little-endian binary file (.shpt) of the same numbers, for engines that keep their own meshes.
// Per vertex, the transfer is order^2 x channels floats, coefficient i's channel c at i * channels + c
// (channels: 3, or 1 where the scene is grey and the three are equal), packed 4 to an attribute.
#pragma once
#include "scene/gltf_scene.h"
#include "scene/transfer.h"

#include <cstdint>
#include <string>
#include <vector>

namespace shprobe {

// The attributes' names are kTransferAttributePrefix and their number, from 0.
constexpr char kTransferAttributePrefix[] = "_SH_TRANSFER_";

// What a transfer file says of how it was made.
struct TransferDescription {
    TransferModel model = TransferModel::Shadowed;
    int bounces = 0; // interreflected only; 0 otherwise
};

// The transfer of one placed primitive's POSITION elements: node, mesh and primitive of the input
// file, and positionCount x order^2 x channels floats. A primitive without normals (3 World vertices
// per triangle) gets, at each POSITION element, the mean of its corners in triangles with area; an
// element no such triangle uses gets zeros.
struct PrimitiveTransfer {
    int node = -1;
    int mesh = -1;
    int primitive = -1;
    uint32_t vertexCount = 0;
    std::vector<float> values;
};

// 3 where the transfer is coloured, else 1.
int transferChannels(const VertexTransfer& transfer);
// ceil(order^2 channels / 4).
int transferAttributeCount(int order, int channels);

std::vector<PrimitiveTransfer> primitiveTransfers(const GltfSceneSource& source,
                                                  const VertexTransfer& transfer);

// Throws Error(Input) "PATH: ..." where the scene's asset.extras is a value other than an object,
// which transferGlb could not add asset.extras.shTransfer to.
void requireTransferGlbSource(const GltfSceneSource& source, const std::string& path);

// The .glb: the source's model with one buffer (its buffers joined, its images moved into it), a mesh
// used by several nodes copied so that each node has its own, an earlier transfer dropped (its
// accessors, views and bytes where they come last, as this writes them), the attributes added; every
// extras and extensions value as the source's JSON has it. Throws Error(Output) if tinygltf cannot
// write it.
std::string transferGlb(const GltfSceneSource& source, const VertexTransfer& transfer,
                        const TransferDescription& description);

// The binary file (docs/transfer.md, "Binary file"):
//   header, 32 bytes: "SHPT", then uint32 version (1), order, channels, model (0 unshadowed,
//     1 shadowed, 2 interreflected), bounces, rays per vertex, primitive count P;
//   P records of 16 bytes: int32 node, mesh, primitive (the input file's), uint32 vertex count;
//   then each primitive's vertexCount x order^2 x channels float32, in the records' order.
constexpr char kTransferMagic[4] = {'S', 'H', 'P', 'T'};
constexpr uint32_t kTransferVersion = 1;
std::string transferBinary(const GltfSceneSource& source, const VertexTransfer& transfer,
                           const TransferDescription& description);

} // namespace shprobe
