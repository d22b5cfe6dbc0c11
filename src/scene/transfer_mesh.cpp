#include "scene/transfer_mesh.h"

#include "common/error.h"
#include "common/short_number.h"
#include "scene/gltf_scene.h"
#include "scene/transfer_gltf.h"
#include "sh/basis.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tiny_gltf.h>

namespace shprobe {

namespace {

[[noreturn]] void refuse(const std::string& path, const std::string& reason) {
    throw Error(ErrorKind::Input, path + ": " + reason);
}

int extrasNumber(const tinygltf::Value& description, const char* key, const std::string& path) {
    if (!description.Has(key) || !description.Get(key).IsNumber())
        refuse(path, std::string("asset.extras.shTransfer has no number \"") + key + "\"");
    return description.Get(key).GetNumberAsInt();
}

// A string field must be what the writer (transfer_gltf.cpp) writes: another format, or another SH
// convention, would be drawn as if it were this one.
void requireString(const tinygltf::Value& description, const char* key, const std::string& expected,
                   const std::string& path) {
    const bool matches = description.Has(key) && description.Get(key).IsString() &&
                         description.Get(key).Get<std::string>() == expected;
    if (!matches)
        refuse(path, std::string("asset.extras.shTransfer's \"") + key + "\" is not \"" + expected +
                         "\" (make the file with this shprobe's transfer)");
}

// "attributes" must list the names order and channels make, so that a header edited apart from
// its attributes is not read with the wrong layout.
void requireAttributeNames(const tinygltf::Value& description, int attributes, const std::string& path) {
    const tinygltf::Value& names = description.Get("attributes");
    bool matches = names.IsArray() && names.ArrayLen() == size_t(attributes);
    for (int a = 0; matches && a < attributes; ++a)
        matches = names.Get(a).IsString() &&
                  names.Get(a).Get<std::string>() == kTransferAttributePrefix + std::to_string(a);
    if (!matches)
        refuse(path, "asset.extras.shTransfer's \"attributes\" is not " +
                         std::string(kTransferAttributePrefix) + "0.." + std::to_string(attributes - 1) +
                         ", the " + std::to_string(attributes) + " its order and channels make");
}

// The header's fields against what this reader draws (docs/transfer.md, "glTF").
TransferMesh describedMesh(const tinygltf::Value& description, const std::string& path) {
    requireString(description, "format", "shprobe.transfer", path);
    const int version = extrasNumber(description, "version", path);
    if (version != int(kTransferVersion))
        refuse(path, "asset.extras.shTransfer is version " + std::to_string(version) +
                         "; this shprobe reads " + std::to_string(kTransferVersion));
    requireString(description, "convention", kConventionName, path);
    TransferMesh mesh;
    mesh.order = extrasNumber(description, "order", path);
    mesh.channels = extrasNumber(description, "channels", path);
    if (mesh.order < 1 || mesh.order > kMaxOrder || (mesh.channels != 1 && mesh.channels != 3))
        refuse(path, "asset.extras.shTransfer: order " + std::to_string(mesh.order) + ", channels " +
                         std::to_string(mesh.channels) + " (orders 1.." + std::to_string(kMaxOrder) +
                         ", channels 1 or 3)");
    mesh.attributes = transferAttributeCount(mesh.order, mesh.channels);
    requireAttributeNames(description, mesh.attributes, path);
    return mesh;
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

std::string primitiveName(const GltfPlacedPrimitive& placed) {
    return "mesh " + std::to_string(placed.mesh) + " primitive " + std::to_string(placed.primitive);
}

// As many transfer attributes as the header's order and channels make: one more or one fewer means
// the header does not describe these attributes.
void requireAttributeCount(const tinygltf::Primitive& primitive, const GltfPlacedPrimitive& placed,
                           const TransferMesh& mesh, const std::string& path) {
    const auto isTransfer = [](const auto& attribute) {
        return attribute.first.starts_with(kTransferAttributePrefix);
    };
    const auto found = std::count_if(primitive.attributes.begin(), primitive.attributes.end(), isTransfer);
    if (found != mesh.attributes)
        refuse(path, primitiveName(placed) + " has " + std::to_string(found) + " " +
                         kTransferAttributePrefix + " attributes, but asset.extras.shTransfer's order " +
                         std::to_string(mesh.order) + " and channels " + std::to_string(mesh.channels) +
                         " make " + std::to_string(mesh.attributes));
}

// Every element of attribute `k`: its coefficients finite (the device would draw NaN and infinity
// as they are), its floats past the last coefficient zero, as the writer pads them.
void checkValues(const Vec4Elements& elements, uint32_t count, int k, const TransferMesh& mesh,
                 const std::string& where, const std::string& path) {
    const int coefficients = mesh.order * mesh.order * mesh.channels;
    for (uint32_t v = 0; v < count; ++v)
        for (int c = 0; c < 4; ++c) {
            float value;
            std::memcpy(&value, elements.first + size_t(v) * elements.stride + size_t(c) * 4, 4);
            const bool padding = k * 4 + c >= coefficients;
            if (padding ? value == 0.0f : std::isfinite(value)) continue;
            refuse(path, where + " holds " + shortNumber(value) + " at vertex " + std::to_string(v) +
                             (padding ? " past the " + std::to_string(coefficients) +
                                            " floats asset.extras.shTransfer's order and channels make"
                                      : "; transfer coefficients must be finite"));
        }
}

void readPrimitive(const tinygltf::Model& model, const GltfPlacedPrimitive& placed, TransferMesh& mesh,
                   const std::string& path) {
    const tinygltf::Primitive& primitive =
        model.meshes.at(size_t(placed.mesh)).primitives.at(size_t(placed.primitive));
    requireAttributeCount(primitive, placed, mesh, path);
    const size_t floats = size_t(mesh.attributes) * 4;
    for (int k = 0; k < mesh.attributes; ++k) {
        const std::string name = kTransferAttributePrefix + std::to_string(k);
        const auto found = primitive.attributes.find(name);
        if (found == primitive.attributes.end())
            refuse(path,
                   primitiveName(placed) + " has no " + name + " (make the file with shprobe transfer)");
        const Vec4Elements elements = vec4Elements(model, found->second, placed.positionCount, name, path);
        checkValues(elements, placed.positionCount, k, mesh, primitiveName(placed) + "'s " + name, path);
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
    TransferMesh mesh = describedMesh(model.asset.extras.Get("shTransfer"), path);
    mesh.transfer.assign(source.world.positions.size() * size_t(mesh.attributes) * 4, 0.0f);
    for (const GltfPlacedPrimitive& placed : source.primitives)
        readPrimitive(model, placed, mesh, path);
    mesh.world = std::move(source.world);
    return mesh;
}

} // namespace shprobe
