// The transfer files (transfer_gltf.h): the scene rewritten by tinygltf as one .glb with the
// attributes added, and the plain binary file.
#include "scene/transfer_gltf.h"

#include "common/error.h"
#include "common/little_endian.h"
#include "formats/json_reading.h"
#include "sh/basis.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <tiny_gltf.h>

namespace shprobe {

namespace {

static_assert(std::endian::native == std::endian::little, "the files are written as little-endian");

constexpr int kArrayBuffer = 34962; // bufferView.target for vertex attributes

// The floats of one World vertex's transfer, channel by channel.
void appendVertex(const VertexTransfer& transfer, size_t vertex, int channels, float* out) {
    const size_t count = size_t(transfer.order) * size_t(transfer.order);
    for (size_t i = 0; i < count; ++i) {
        const glm::vec3& c = transfer.coefficients[vertex * count + i];
        for (int k = 0; k < channels; ++k)
            out[i * size_t(channels) + size_t(k)] += c[k];
    }
}

// The bytes of `values` appended to `bin` at a multiple of `alignment`; their offset.
size_t appendBytes(std::vector<unsigned char>& bin, const void* values, size_t size, size_t alignment) {
    bin.resize((bin.size() + alignment - 1) / alignment * alignment, 0);
    const size_t offset = bin.size();
    bin.insert(bin.end(), static_cast<const unsigned char*>(values),
               static_cast<const unsigned char*>(values) + size);
    return offset;
}

int addView(tinygltf::Model& model, size_t offset, size_t length, int target) {
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = offset;
    view.byteLength = length;
    view.target = target;
    model.bufferViews.push_back(view);
    return int(model.bufferViews.size() - 1);
}

std::string imageMimeType(const std::vector<unsigned char>& bytes, const std::string& stated) {
    if (bytes.size() >= 4 && std::memcmp(bytes.data(), "\x89PNG", 4) == 0) return "image/png";
    if (bytes.size() >= 3 && std::memcmp(bytes.data(), "\xFF\xD8\xFF", 3) == 0) return "image/jpeg";
    return stated.empty() ? "application/octet-stream" : stated;
}

bool isTransferAttribute(const std::string& name) {
    return name.starts_with(kTransferAttributePrefix);
}

// Whether anything of the model but a transfer attribute names an accessor from `first` on.
bool namesAccessorFrom(const tinygltf::Model& model, int first) {
    for (const tinygltf::Mesh& mesh : model.meshes)
        for (const tinygltf::Primitive& primitive : mesh.primitives) {
            if (primitive.indices >= first) return true;
            for (const auto& [name, accessor] : primitive.attributes)
                if (accessor >= first) return true;
            for (const auto& target : primitive.targets)
                for (const auto& [name, accessor] : target)
                    if (accessor >= first) return true;
        }
    for (const tinygltf::Skin& skin : model.skins)
        if (skin.inverseBindMatrices >= first) return true;
    for (const tinygltf::Animation& animation : model.animations)
        for (const tinygltf::AnimationSampler& sampler : animation.samplers)
            if (sampler.input >= first || sampler.output >= first) return true;
    return false;
}

// Whether `json` names a buffer view from `first` on ("bufferView" anywhere: an image's, a sparse
// accessor's, an extension's such as Draco's).
bool namesViewFrom(const nlohmann::json& json, int first) {
    if (json.is_object())
        if (auto view = json.find("bufferView");
            view != json.end() && view->is_number_integer() && view->get<int64_t>() >= first)
            return true;
    if (json.is_structured())
        for (const nlohmann::json& value : json)
            if (namesViewFrom(value, first)) return true;
    return false;
}

// The same of the scene's JSON, but for the accessors from `firstAccessor` on, whose views they are.
bool sceneNamesViewFrom(const nlohmann::json& scene, int first, size_t firstAccessor) {
    for (const auto& [key, value] : scene.items()) {
        if (key != "accessors") {
            if (namesViewFrom(value, first)) return true;
            continue;
        }
        for (size_t a = 0; a < std::min(firstAccessor, value.size()); ++a)
            if (namesViewFrom(value[a], first)) return true;
    }
    return false;
}

// A scene that already holds a transfer (one of ours, baked again) loses it: its attributes go, and
// so do their accessors, buffer views and bytes where they are the last of each, as this file writes
// them, and nothing else names them (`source`: the scene's JSON). Elsewhere, as in a file edited
// since, they stay, unused, rather than renumber the accessors and views the scene's extensions
// may name.
void dropEarlierTransfer(tinygltf::Model& model, const nlohmann::json& source) {
    std::set<int> accessors;
    for (tinygltf::Mesh& mesh : model.meshes)
        for (tinygltf::Primitive& primitive : mesh.primitives)
            std::erase_if(primitive.attributes, [&](const auto& attribute) {
                if (!isTransferAttribute(attribute.first)) return false;
                accessors.insert(attribute.second);
                return true;
            });
    const size_t firstAccessor = model.accessors.size() - accessors.size();
    if (accessors.empty() || *accessors.begin() != int(firstAccessor) ||
        *accessors.rbegin() != int(model.accessors.size() - 1))
        return;
    std::set<int> views;
    for (size_t a = firstAccessor; a < model.accessors.size(); ++a) {
        const tinygltf::Accessor& accessor = model.accessors[a];
        if (accessor.sparse.isSparse) return;
        views.insert(accessor.bufferView);
    }
    const size_t firstView = model.bufferViews.size() - views.size();
    if (*views.begin() != int(firstView) || *views.rbegin() != int(model.bufferViews.size() - 1)) return;
    if (namesAccessorFrom(model, int(firstAccessor)) ||
        sceneNamesViewFrom(source, int(firstView), firstAccessor))
        return;
    // Their bytes go too where they end the buffer: no view left reaches them.
    const int buffer = model.bufferViews[firstView].buffer;
    size_t start = SIZE_MAX, end = 0;
    for (size_t v = 0; v < model.bufferViews.size(); ++v) {
        const tinygltf::BufferView& view = model.bufferViews[v];
        if (view.buffer != buffer) continue;
        if (v >= firstView)
            start = std::min(start, view.byteOffset);
        else
            end = std::max(end, view.byteOffset + view.byteLength);
    }
    model.accessors.resize(firstAccessor);
    model.bufferViews.resize(firstView);
    if (buffer >= 0 && size_t(buffer) < model.buffers.size() && end <= start &&
        start <= model.buffers[size_t(buffer)].data.size())
        model.buffers[size_t(buffer)].data.resize(start);
}

// Every buffer joined into buffer 0 (the .glb's BIN chunk), and every image's bytes in a buffer view
// of it: the .glb then stands alone, wherever it is moved.
std::vector<unsigned char> joinBuffers(tinygltf::Model& model) {
    std::vector<unsigned char> bin;
    std::vector<size_t> starts;
    for (const tinygltf::Buffer& buffer : model.buffers)
        starts.push_back(appendBytes(bin, buffer.data.data(), buffer.data.size(), 8));
    for (tinygltf::BufferView& view : model.bufferViews) {
        if (view.buffer >= 0 && size_t(view.buffer) < starts.size())
            view.byteOffset += starts[size_t(view.buffer)];
        view.buffer = 0;
    }
    for (tinygltf::Image& image : model.images) {
        if (image.bufferView >= 0 || image.image.empty()) continue;
        const size_t offset = appendBytes(bin, image.image.data(), image.image.size(), 4);
        image.bufferView = addView(model, offset, image.image.size(), 0);
        image.mimeType = imageMimeType(image.image, image.mimeType);
        image.uri.clear();
    }
    return bin;
}

// The mesh each node draws its own: the first node of a mesh keeps it, the others get copies.
std::map<int, int> ownMeshes(tinygltf::Model& model, const std::vector<PrimitiveTransfer>& primitives) {
    std::map<int, int> meshOfNode, nodeOfMesh;
    for (const PrimitiveTransfer& p : primitives) {
        if (meshOfNode.count(p.node)) continue;
        if (nodeOfMesh.emplace(p.mesh, p.node).second) {
            meshOfNode[p.node] = p.mesh;
            continue;
        }
        model.meshes.push_back(model.meshes[size_t(p.mesh)]);
        meshOfNode[p.node] = int(model.meshes.size() - 1);
        model.nodes[size_t(p.node)].mesh = meshOfNode[p.node];
    }
    return meshOfNode;
}

tinygltf::Value describe(const VertexTransfer& transfer, const TransferDescription& description,
                         int channels) {
    using Value = tinygltf::Value;
    const int attributes = transferAttributeCount(transfer.order, channels);
    Value::Array names;
    for (int a = 0; a < attributes; ++a)
        names.emplace_back(std::string(kTransferAttributePrefix) + std::to_string(a));
    Value::Object o;
    o["format"] = Value(std::string("shprobe.transfer"));
    o["version"] = Value(int(kTransferVersion));
    o["convention"] = Value(std::string(kConventionName));
    o["order"] = Value(transfer.order);
    o["model"] = Value(std::string(transferModelName(description.model)));
    o["bounces"] = Value(description.bounces);
    o["rays"] = Value(transfer.rays);
    o["channels"] = Value(channels);
    o["attributes"] = Value(std::move(names));
    o["layout"] = Value(std::string(
        "per vertex, order^2 * channels floats, coefficient i's channel c at i * channels + c (i = "
        "l(l+1)+m), "
        "packed 4 to an attribute in order (_SH_TRANSFER_0.xyzw holds floats 0..3), zeros after the last"));
    o["formula"] = Value(std::string(
        "L_out = sum_i T_i L_i: L_i the sky's radiance coefficients, T_i the vertex's transfer, the "
        "vertex's albedo / pi included"));
    o["instances"] =
        Value(std::string("a mesh drawn by several nodes is copied, so that each node has its own"));
    return Value(std::move(o));
}

// The attributes of one placed primitive: one VEC4 float accessor each.
void addAttributes(tinygltf::Model& model, std::vector<unsigned char>& bin, const PrimitiveTransfer& p,
                   int mesh, int channels, int order) {
    const size_t floats = size_t(order) * size_t(order) * size_t(channels);
    const int attributes = transferAttributeCount(order, channels);
    tinygltf::Primitive& primitive = model.meshes[size_t(mesh)].primitives[size_t(p.primitive)];
    std::vector<float> column(size_t(p.vertexCount) * 4);
    for (int a = 0; a < attributes; ++a) {
        for (size_t v = 0; v < p.vertexCount; ++v)
            for (size_t k = 0; k < 4; ++k) {
                const size_t f = size_t(a) * 4 + k;
                column[v * 4 + k] = f < floats ? p.values[v * floats + f] : 0.0f;
            }
        const size_t bytes = column.size() * sizeof(float);
        tinygltf::Accessor accessor;
        accessor.bufferView = addView(model, appendBytes(bin, column.data(), bytes, 16), bytes, kArrayBuffer);
        accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
        accessor.type = TINYGLTF_TYPE_VEC4;
        accessor.count = p.vertexCount;
        model.accessors.push_back(accessor);
        primitive.attributes[std::string(kTransferAttributePrefix) + std::to_string(a)] =
            int(model.accessors.size() - 1);
    }
}

// Every "extras" and "extensions" value of `from` put at the same place in `to`, where `to` has that
// place: tinygltf keeps them as values of its own, whose integers are 32-bit (3000000000 came back
// -1294967296) and which drop empty objects, arrays and nulls.
void keepExtensionData(const nlohmann::json& from, nlohmann::json& to) {
    if (from.is_object() && to.is_object()) {
        for (const auto& [key, value] : from.items()) {
            if (key == "extras" || key == "extensions")
                to[key] = value;
            else if (to.contains(key))
                keepExtensionData(value, to[key]);
        }
    }
    if (from.is_array() && to.is_array())
        for (size_t i = 0; i < std::min(from.size(), to.size()); ++i)
            keepExtensionData(from[i], to[i]);
}

// The .glb tinygltf wrote with the scene's JSON (`original`) kept where tinygltf rewrote it: its extras and
// extensions (the buffers' aside: the .glb has one buffer of its own), a copied mesh's those of the
// mesh it copies (`copied`: copy -> original), asset.extras.shTransfer added.
std::string withSourceJson(const std::string& glb, nlohmann::json original,
                           const std::map<int, int>& copied) {
    const uint32_t jsonBytes = littleEndian32(glb, 12);
    nlohmann::json written = nlohmann::json::parse(std::string_view(glb).substr(20, jsonBytes));
    const nlohmann::json description = written["asset"]["extras"]["shTransfer"];
    original.erase("buffers");
    keepExtensionData(original, written);
    for (const auto& [copy, mesh] : copied)
        keepExtensionData(original["meshes"][size_t(mesh)], written["meshes"][size_t(copy)]);
    written["asset"]["extras"]["shTransfer"] = description;
    std::string text = jsonText(written);
    text.resize((text.size() + 3) / 4 * 4, ' '); // a chunk is padded to 4 bytes, JSON's with spaces
    const std::string_view bin = std::string_view(glb).substr(20 + jsonBytes);
    std::string out = glb.substr(0, 8);
    appendLittleEndian32(out, uint32_t(12 + 8 + text.size() + bin.size()));
    appendLittleEndian32(out, uint32_t(text.size()));
    out += glb.substr(16, 4); // "JSON"
    out += text;
    out += bin;
    return out;
}

} // namespace

void requireTransferGlbSource(const GltfSceneSource& source, const std::string& path) {
    // From the JSON itself: tinygltf takes [], [null] and [{}] for no extras.
    const nlohmann::json root = nlohmann::json::parse(source.json);
    const auto asset = root.find("asset");
    if (asset == root.end() || !asset->contains("extras")) return;
    const nlohmann::json& extras = (*asset)["extras"];
    if (extras.is_null() || extras.is_object()) return;
    throw Error(ErrorKind::Input,
                path + ": asset.extras is not an object, so it cannot hold the transfer's description "
                       "(asset.extras.shTransfer); write the transfer alone (-o FILE.shpt)");
}

int transferChannels(const VertexTransfer& transfer) {
    return transfer.coloured() ? 3 : 1;
}

int transferAttributeCount(int order, int channels) {
    return (order * order * channels + 3) / 4;
}

std::vector<PrimitiveTransfer> primitiveTransfers(const GltfSceneSource& source,
                                                  const VertexTransfer& transfer) {
    const int channels = transferChannels(transfer);
    const size_t floats = size_t(transfer.order) * size_t(transfer.order) * size_t(channels);
    std::vector<PrimitiveTransfer> out;
    for (const GltfPlacedPrimitive& placed : source.primitives) {
        PrimitiveTransfer p{placed.node, placed.mesh, placed.primitive, placed.positionCount, {}};
        p.values.assign(size_t(placed.positionCount) * floats, 0.0f);
        std::vector<uint32_t> corners(placed.positionCount, 0);
        for (size_t k = 0; k < placed.sourceVertices.size(); ++k) {
            if (!transfer.used[placed.firstVertex + k]) continue;
            const uint32_t v = placed.sourceVertices[k];
            appendVertex(transfer, placed.firstVertex + k, channels, &p.values[size_t(v) * floats]);
            ++corners[v];
        }
        for (size_t v = 0; v < corners.size(); ++v)
            for (size_t f = 0; corners[v] > 1 && f < floats; ++f)
                p.values[v * floats + f] /= float(corners[v]);
        out.push_back(std::move(p));
    }
    return out;
}

std::string transferGlb(const GltfSceneSource& source, const VertexTransfer& transfer,
                        const TransferDescription& description) {
    tinygltf::Model model = *source.model;
    const nlohmann::json original = nlohmann::json::parse(source.json);
    dropEarlierTransfer(model, original);
    const int channels = transferChannels(transfer);
    const std::vector<PrimitiveTransfer> primitives = primitiveTransfers(source, transfer);
    std::vector<unsigned char> bin = joinBuffers(model);
    const std::map<int, int> meshOfNode = ownMeshes(model, primitives);
    std::map<int, int> copied;
    for (const PrimitiveTransfer& p : primitives) {
        addAttributes(model, bin, p, meshOfNode.at(p.node), channels, transfer.order);
        if (meshOfNode.at(p.node) != p.mesh) copied[meshOfNode.at(p.node)] = p.mesh;
    }
    model.buffers.assign(1, tinygltf::Buffer());
    model.buffers[0].data = std::move(bin);
    tinygltf::Value::Object extras;
    if (model.asset.extras.IsObject()) extras = model.asset.extras.Get<tinygltf::Value::Object>();
    extras["shTransfer"] = describe(transfer, description, channels);
    model.asset.extras = tinygltf::Value(std::move(extras));
    std::ostringstream stream;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, stream, false, true))
        throw Error(ErrorKind::Output, "transfer: tinygltf could not write the .glb");
    return withSourceJson(stream.str(), original, copied);
}

std::string transferBinary(const GltfSceneSource& source, const VertexTransfer& transfer,
                           const TransferDescription& description) {
    const std::vector<PrimitiveTransfer> primitives = primitiveTransfers(source, transfer);
    std::string bytes(kTransferMagic, sizeof(kTransferMagic));
    auto put = [&](auto value) { appendLittleEndian32(bytes, uint32_t(value)); };
    for (uint32_t field : {kTransferVersion, uint32_t(transfer.order), uint32_t(transferChannels(transfer)),
                           uint32_t(description.model), uint32_t(description.bounces),
                           uint32_t(transfer.rays), uint32_t(primitives.size())})
        put(field);
    for (const PrimitiveTransfer& p : primitives) {
        put(int32_t(p.node));
        put(int32_t(p.mesh));
        put(int32_t(p.primitive));
        put(p.vertexCount);
    }
    for (const PrimitiveTransfer& p : primitives)
        bytes.append(reinterpret_cast<const char*>(p.values.data()), p.values.size() * sizeof(float));
    return bytes;
}

} // namespace shprobe
