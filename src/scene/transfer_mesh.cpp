#include "scene/transfer_mesh.h"

#include "common/error.h"
#include "scene/gltf_scene.h"
#include "sh/basis.h"

#include <cstring>
#include <tiny_gltf.h>

namespace shprobe {

namespace {

constexpr char kAttributePrefix[] = "_SH_TRANSFER_";

[[noreturn]] void refuse(const std::string& path, const std::string& reason) {
    throw Error(ErrorKind::Input, path + ": " + reason);
}

int extrasNumber(const tinygltf::Value& description, const char* key, const std::string& path) {
    if (!description.Has(key) || !description.Get(key).IsNumber())
        refuse(path, std::string("asset.extras.shTransfer has no number \"") + key + "\"");
    return description.Get(key).GetNumberAsInt();
}

// Where a VEC4 float accessor of `count` elements starts, and its elements' stride.
struct Vec4Elements {
    const unsigned char* first = nullptr;
    size_t stride = 16;
};

Vec4Elements vec4Elements(const tinygltf::Model& model, int accessorIndex, uint32_t count,
                          const std::string& name, const std::string& path) {
    const tinygltf::Accessor& accessor = model.accessors.at(size_t(accessorIndex));
    if (accessor.type != TINYGLTF_TYPE_VEC4 || accessor.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT ||
        accessor.count != count || accessor.sparse.isSparse || accessor.bufferView < 0)
        refuse(path, name + " is not a VEC4 float accessor of POSITION's count, in a buffer view");
    const tinygltf::BufferView& view = model.bufferViews.at(size_t(accessor.bufferView));
    const tinygltf::Buffer& buffer = model.buffers.at(size_t(view.buffer));
    const size_t stride = view.byteStride > 0 ? view.byteStride : 16;
    const size_t start = view.byteOffset + accessor.byteOffset;
    if (count > 0 && (start + (count - 1) * stride + 16 > view.byteOffset + view.byteLength ||
                      view.byteOffset + view.byteLength > buffer.data.size()))
        refuse(path, name + " reaches past its buffer view");
    return {buffer.data.data() + start, stride};
}

void readPrimitive(const tinygltf::Model& model, const GltfPlacedPrimitive& placed, TransferMesh& mesh,
                   const std::string& path) {
    const tinygltf::Primitive& primitive =
        model.meshes.at(size_t(placed.mesh)).primitives.at(size_t(placed.primitive));
    const size_t floats = size_t(mesh.attributes) * 4;
    for (int k = 0; k < mesh.attributes; ++k) {
        const std::string name = kAttributePrefix + std::to_string(k);
        const auto found = primitive.attributes.find(name);
        if (found == primitive.attributes.end())
            refuse(path, "mesh " + std::to_string(placed.mesh) + " primitive " +
                             std::to_string(placed.primitive) + " has no " + name +
                             " (make the file with shprobe transfer)");
        const Vec4Elements elements = vec4Elements(model, found->second, placed.positionCount, name, path);
        for (size_t v = 0; v < placed.sourceVertices.size(); ++v)
            std::memcpy(&mesh.transfer[(placed.firstVertex + v) * floats + size_t(k) * 4],
                        elements.first + size_t(placed.sourceVertices[v]) * elements.stride, 16);
    }
}

} // namespace

TransferMesh loadTransferMesh(const std::string& path) {
    GltfSceneSource source = loadGltfSceneSource(path);
    const tinygltf::Model& model = *source.model;
    if (!model.asset.extras.Has("shTransfer"))
        refuse(path, "no per-vertex transfer (asset.extras.shTransfer); make it with shprobe transfer");
    const tinygltf::Value& description = model.asset.extras.Get("shTransfer");
    TransferMesh mesh;
    mesh.order = extrasNumber(description, "order", path);
    mesh.channels = extrasNumber(description, "channels", path);
    if (mesh.order < 1 || mesh.order > kMaxOrder || (mesh.channels != 1 && mesh.channels != 3))
        refuse(path, "asset.extras.shTransfer: order " + std::to_string(mesh.order) + ", channels " +
                         std::to_string(mesh.channels) + " (orders 1.." + std::to_string(kMaxOrder) +
                         ", channels 1 or 3)");
    mesh.attributes = (mesh.order * mesh.order * mesh.channels + 3) / 4;
    mesh.transfer.assign(source.world.positions.size() * size_t(mesh.attributes) * 4, 0.0f);
    for (const GltfPlacedPrimitive& placed : source.primitives)
        readPrimitive(model, placed, mesh, path);
    mesh.world = std::move(source.world);
    return mesh;
}

} // namespace shprobe
