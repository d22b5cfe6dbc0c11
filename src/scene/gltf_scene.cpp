// glTF scenes read with tinygltf (scene/gltf_scene.h): the file and its layout checked first, then
// the node hierarchy walked, each mesh instance, material, texture and sun added to the World.
#include "scene/gltf_scene.h"

#include "common/content_hash.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/little_endian.h"
#include "common/quoted.h"
#include "common/short_number.h"
#include "image/codec.h"
#include "scene/gltf_geometry.h"
#include "scene/gltf_schema.h"
#include "scene/scene_images.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/matrix.hpp>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <span>
#include <string_view>
#include <tiny_gltf.h>

namespace shprobe {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
    throw Error(ErrorKind::Input, path + ": " + problem);
}

std::string counted(size_t count, const std::string& noun) {
    return std::to_string(count) + " " + noun + (count == 1 ? "" : "s");
}

// ---- The file: .glb layout, JSON, tinygltf ------------------------------------------------------

bool isGlb(std::string_view bytes) {
    return bytes.substr(0, 4) == "glTF";
}

// The bytes of a .glb that its header counts, with the JSON chunk's, after the layout is checked
// (the specification's 4.4, "Binary glTF Layout"): a 12-byte header (magic, version 2, length),
// then chunks of an 8-byte header (length, type) and their data: JSON, then optionally BIN.
// tinygltf checks less: it reads the BIN chunk's data past the length it was given.
std::pair<std::string_view, std::string_view> glbParts(std::string_view bytes, const std::string& path) {
    const std::string cut = "the file is cut short (" + counted(bytes.size(), "byte") + "): ";
    if (bytes.size() < 20) fail(path, cut + "a .glb has a 12-byte header and an 8-byte chunk header");
    if (const uint32_t version = littleEndian32(bytes, 4); version != 2)
        fail(path, "a binary glTF of version " + std::to_string(version) + "; only version 2 is read");
    const uint64_t length = littleEndian32(bytes, 8);
    if (length > bytes.size()) fail(path, cut + "its header says " + counted(length, "byte"));
    const std::string_view file = bytes.substr(0, size_t(length));
    const uint64_t jsonLength = littleEndian32(file, 12);
    if (littleEndian32(file, 16) != 0x4E4F534A) fail(path, "the first chunk of the .glb is not its JSON");
    if (20 + jsonLength > length) fail(path, cut + "its JSON chunk has " + counted(jsonLength, "byte"));
    const uint64_t binAt = 20 + jsonLength;
    if (binAt < length) {
        if (binAt + 8 > length) fail(path, cut + "it ends in the header of its second chunk");
        const uint64_t binLength = littleEndian32(file, size_t(binAt));
        if (binAt + 8 + binLength > length)
            fail(path, cut + "its BIN chunk has " + counted(binLength, "byte"));
    }
    return {file, file.substr(20, size_t(jsonLength))};
}

// ---- The files a scene names: URIs kept to the scene's folder ---------------------------------

std::string folderOf(const std::string& path) {
    const std::string folder = std::filesystem::path(path).parent_path().string();
    return folder.empty() ? "." : folder;
}

// The file name a URI means, decoded as its reader decodes it: tinygltf a buffer's (dlib's
// urldecode, where "+" is a space and a bad escape a 0 byte), this file an image's (RFC 3986's %XX).
std::string bufferFileName(const std::string& uri) {
    auto hex = [](char c) {
        return std::isxdigit(static_cast<unsigned char>(c)) ? std::stoi(std::string(1, c), nullptr, 16) : 0;
    };
    std::string name;
    for (size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '+') {
            name += ' ';
        } else if (uri[i] == '%' && uri.size() > i + 2) {
            name += char(hex(uri[i + 1]) << 4 | hex(uri[i + 2]));
            i += 2;
        } else {
            name += uri[i];
        }
    }
    return name;
}

std::string imageFileName(const std::string& uri) {
    std::string name;
    for (size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
            std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
            name += char(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
            i += 2;
        } else {
            name += uri[i];
        }
    }
    return name;
}

// Whether folder/name stays in the folder or below it, by its name ("..", an absolute path) and
// after its links. The name is taken as the system opens it: up to a 0 byte. A path the system
// cannot resolve is left to the reader, which says why.
bool insideFolder(const std::string& folder, const std::string& decoded) {
    namespace fs = std::filesystem;
    const fs::path name(decoded.c_str());
    if (name.is_absolute()) return false;
    const fs::path normal = name.lexically_normal();
    if (!normal.empty() && *normal.begin() == "..") return false;
    std::error_code error;
    const fs::path base = fs::weakly_canonical(folder, error);
    const fs::path file = error ? fs::path() : fs::weakly_canonical(fs::path(folder) / name, error);
    if (error) return true;
    return std::mismatch(base.begin(), base.end(), file.begin(), file.end()).first == base.end();
}

// A buffer's or an image's URI that names a file, not a data URI tinygltf decodes.
struct FileUri {
    std::string where; // "buffers[0].uri"
    std::string uri;
    std::string name; // decoded as its reader decodes it
};

std::vector<FileUri> fileUris(const nlohmann::json& root) {
    std::vector<FileUri> uris;
    for (const char* list : {"buffers", "images"}) {
        if (!root.contains(list)) continue;
        const nlohmann::json& items = root[list];
        for (size_t i = 0; i < items.size(); ++i) {
            if (!items[i].contains("uri")) continue;
            const std::string uri = items[i]["uri"].get<std::string>();
            if (uri.empty() || tinygltf::IsDataURI(uri)) continue;
            uris.push_back({std::string(list) + "[" + std::to_string(i) + "].uri", uri,
                            list == std::string_view("buffers") ? bufferFileName(uri) : imageFileName(uri)});
        }
    }
    return uris;
}

// The path a URI's file is read from, after refusing one outside the scene's folder: a scene may
// name only its own files, not any file the program can read.
std::string uriFile(const std::string& path, const FileUri& uri) {
    const std::string folder = folderOf(path);
    if (!insideFolder(folder, uri.name))
        fail(path, uri.where + " " + quotedInput(uri.uri) +
                       " is outside the scene's folder; a scene reads only files in its folder or below");
    return folder + "/" + uri.name;
}

// The files of every buffer and image URI, checked as uriFile does; `json` was checked by
// checkGltfJson, so each list and URI has its type.
std::vector<std::string> uriFiles(std::string_view json, const std::string& path) {
    std::vector<std::string> files;
    for (const FileUri& uri : fileUris(nlohmann::json::parse(json)))
        files.push_back(uriFile(path, uri));
    return files;
}

// Reads buffer files through common/input_file.h, so that a buffer file that is missing, a folder or
// too large is said in the project's words, and only files in the scene's folder (or below) are
// looked for: tinygltf also tries the process's working folder. uriFiles refused the others first.
struct FileAccess {
    std::string folder;
    std::string prefix;  // the scene's folder, with a final '/'
    std::string failure; // the first file that could not be read: "PATH: REASON"
};

bool fileExists(const std::string& path, void* user) {
    const auto& access = *static_cast<FileAccess*>(user);
    // Whether it exists is said on reading.
    return path.compare(0, access.prefix.size(), access.prefix) == 0 &&
           insideFolder(access.folder, path.substr(access.prefix.size()));
}

std::string expandFilePath(const std::string& path, void*) {
    return path;
}

bool readWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
    auto& access = *static_cast<FileAccess*>(user);
    try {
        const std::string bytes = readInputFile(path, kMaxGltfFileBytes, "a glTF buffer file");
        out->assign(bytes.begin(), bytes.end());
        return true;
    } catch (const Error& error) {
        if (access.failure.empty()) access.failure = error.what();
        *err = error.what();
        return false;
    }
}

// Images are kept as the file stores them (PNG or JPEG bytes), decoded when a material uses them.
bool keepImageBytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                    const unsigned char* bytes, int size, void*) {
    image->image.assign(bytes, bytes + std::max(size, 0));
    image->as_is = true;
    return true;
}

// JSON starts with an object or an array after white space, and perhaps a UTF-8 byte order mark
// (which nlohmann-json skips).
bool looksLikeJson(std::string_view text) {
    if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
    const size_t start = text.find_first_not_of(" \t\r\n");
    return start != std::string_view::npos && (text[start] == '{' || text[start] == '[');
}

// tinygltf's messages as the one line gives them: the first, cut (it may quote a data URI of
// megabytes whole), and the number of the others.
std::string tinygltfProblem(const std::string& messages) {
    std::string first;
    size_t count = 0;
    for (size_t start = 0; start < messages.size();) {
        size_t end = messages.find('\n', start);
        if (end == std::string::npos) end = messages.size();
        if (end > start && count++ == 0)
            first = clipped(std::string_view(messages).substr(start, end - start));
        start = end + 1;
    }
    return count > 1 ? first + " (and " + counted(count - 1, "more problem") + ")" : first;
}

tinygltf::Model parseModel(const std::string& path, std::string_view bytes) {
    const bool binary = isGlb(bytes);
    const auto [data, json] = binary ? glbParts(bytes, path) : std::pair{bytes, bytes};
    if (!binary && !looksLikeJson(json))
        fail(path,
             "not a glTF file: neither JSON (a .gltf) nor binary glTF (a .glb, which starts with \"glTF\")");
    checkGltfJson(json, path);
    uriFiles(json, path); // refuses a file outside the folder before tinygltf opens it
    const std::string folder = folderOf(path);
    FileAccess access{folder, folder.back() == '/' ? folder : folder + "/", {}};
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&keepImageBytes, nullptr);
    loader.SetFsCallbacks({&fileExists, &expandFilePath, &readWholeFile, nullptr, &access});
    tinygltf::Model model;
    std::string err, warn;
    const bool loaded =
        binary ? loader.LoadBinaryFromMemory(&model, &err, &warn,
                                             reinterpret_cast<const unsigned char*>(data.data()),
                                             unsigned(data.size()), folder)
               : loader.LoadASCIIFromString(&model, &err, &warn, data.data(), unsigned(data.size()), folder);
    if (!access.failure.empty()) fail(path, "cannot read " + access.failure);
    // tinygltf also reports some faults in `err` while it goes on (a texture info without index).
    if (!loaded || !err.empty()) {
        const std::string message = tinygltfProblem(err + warn);
        fail(path, message.empty() ? "tinygltf cannot read the file" : message);
    }
    return model;
}

bool usesExtension(const tinygltf::Model& model, std::string_view name) {
    auto has = [&](const std::vector<std::string>& list) {
        return std::find(list.begin(), list.end(), name) != list.end();
    };
    return has(model.extensionsUsed) || has(model.extensionsRequired);
}

// ---- The node hierarchy -------------------------------------------------------------------------

std::string nodeName(int node) {
    return "nodes[" + std::to_string(node) + "]";
}

// Each node's parent (-1: none), after checking that the nodes form trees (the specification's
// 3.5.3): children that exist, no node with two parents, no cycle. tinygltf checks none of it, and a
// cycle would make the walk below endless.
std::vector<int> checkedParents(const tinygltf::Model& model, const std::string& path) {
    const size_t count = model.nodes.size();
    std::vector<int> parents(count, -1);
    for (size_t n = 0; n < count; ++n)
        for (int child : model.nodes[n].children) {
            if (child < 0 || size_t(child) >= count)
                fail(path, nodeName(int(n)) + ".children names node " + std::to_string(child) +
                               ", but the file has " + counted(count, "node"));
            if (parents[size_t(child)] >= 0)
                fail(path, "node " + std::to_string(child) + " is a child of node " +
                               std::to_string(parents[size_t(child)]) + " and of node " + std::to_string(n) +
                               "; glTF nodes form trees, with one parent each");
            parents[size_t(child)] = int(n);
        }
    // With one parent each, the nodes no root leads to are those on a cycle or below one.
    std::vector<bool> reached(count, false);
    std::vector<int> stack;
    for (size_t n = 0; n < count; ++n)
        if (parents[n] < 0) stack.push_back(int(n));
    while (!stack.empty()) {
        const int node = stack.back();
        stack.pop_back();
        reached[size_t(node)] = true;
        stack.insert(stack.end(), model.nodes[size_t(node)].children.begin(),
                     model.nodes[size_t(node)].children.end());
    }
    const auto unreached = std::find(reached.begin(), reached.end(), false);
    if (unreached == reached.end()) return parents;
    // Up the parents from there until a node repeats: that node is on the cycle.
    std::vector<bool> seen(count, false);
    int node = int(unreached - reached.begin());
    for (; !seen[size_t(node)]; node = parents[size_t(node)])
        seen[size_t(node)] = true;
    std::string cycle = std::to_string(node);
    for (int at = parents[size_t(node)]; at != node; at = parents[size_t(at)])
        cycle = std::to_string(at) + " -> " + cycle;
    fail(path, "the node hierarchy has a cycle: nodes " + std::to_string(node) + " -> " + cycle +
                   " (each the parent of the next)");
}

// The root nodes to draw: the default scene's, else scene 0's, else every node without a parent.
std::vector<int> sceneRoots(const tinygltf::Model& model, const std::vector<int>& parents,
                            const std::string& path) {
    if (model.defaultScene >= 0 && size_t(model.defaultScene) >= model.scenes.size())
        fail(path, "the default scene is " + std::to_string(model.defaultScene) + ", but the file has " +
                       counted(model.scenes.size(), "scene"));
    if (model.scenes.empty()) {
        std::vector<int> roots;
        for (size_t n = 0; n < parents.size(); ++n)
            if (parents[n] < 0) roots.push_back(int(n));
        return roots;
    }
    const int scene = std::max(model.defaultScene, 0);
    const std::string where = "scenes[" + std::to_string(scene) + "].nodes";
    std::vector<int> roots = model.scenes[size_t(scene)].nodes;
    std::vector<bool> listed(parents.size(), false);
    for (int root : roots) {
        if (root < 0 || size_t(root) >= parents.size())
            fail(path, where + " names node " + std::to_string(root) + ", but the file has " +
                           counted(parents.size(), "node"));
        if (parents[size_t(root)] >= 0)
            fail(path, where + " names node " + std::to_string(root) + ", a child of node " +
                           std::to_string(parents[size_t(root)]) + "; a scene lists root nodes only");
        if (listed[size_t(root)]) fail(path, where + " names node " + std::to_string(root) + " twice");
        listed[size_t(root)] = true;
    }
    return roots;
}

// The node's transform relative to its parent: its matrix, or T * R * S (3.5.2).
glm::dmat4 localTransform(const tinygltf::Node& node, int index, const std::string& path) {
    if (node.matrix.size() == 16) return glm::make_mat4(node.matrix.data()); // column-major, as glm
    glm::dmat4 transform(1.0);
    if (node.translation.size() == 3)
        transform = glm::translate(transform, glm::make_vec3(node.translation.data()));
    if (node.rotation.size() == 4) {
        // glTF's [x, y, z, w]; a quaternion not of unit length is normalized.
        const glm::dquat rotation(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
        if (!(glm::length(rotation) > 0.0))
            fail(path, nodeName(index) + ".rotation is [0, 0, 0, 0], not a rotation");
        transform *= glm::mat4_cast(glm::normalize(rotation));
    }
    if (node.scale.size() == 3) transform = glm::scale(transform, glm::make_vec3(node.scale.data()));
    return transform;
}

struct PlacedNode {
    int node;
    glm::dmat4 world;
};

// Every node under the roots with its world transform, parents before children.
std::vector<PlacedNode> placeNodes(const tinygltf::Model& model, const std::vector<int>& roots,
                                   const std::string& path) {
    std::vector<PlacedNode> placed;
    std::vector<PlacedNode> stack;
    for (auto root = roots.rbegin(); root != roots.rend(); ++root)
        stack.push_back({*root, glm::dmat4(1.0)}); // taken in the file's order
    while (!stack.empty()) {
        const PlacedNode parent = stack.back();
        stack.pop_back();
        const tinygltf::Node& node = model.nodes[size_t(parent.node)];
        const PlacedNode here{parent.node, parent.world * localTransform(node, parent.node, path)};
        placed.push_back(here);
        for (auto child = node.children.rbegin(); child != node.children.rend(); ++child)
            stack.push_back({*child, here.world}); // taken in the file's order
    }
    return placed;
}

// ---- The scene's totals, before anything is read ---------------------------------------------

std::string meshName(int mesh) {
    return "meshes[" + std::to_string(mesh) + "]";
}

// The vertices the World may hold: 3 per triangle of the triangle limit, within its uint32_t indices.
uint64_t vertexLimit(const GltfLoadOptions& options) {
    return options.maxTriangles > UINT32_MAX / 3 ? UINT32_MAX : 3 * uint64_t(options.maxTriangles);
}

uint64_t saturatingAdd(uint64_t a, uint64_t b) {
    return a > UINT64_MAX - b ? UINT64_MAX : a + b;
}

// The bytes of image `index`: those tinygltf kept (from a buffer view or a data URI), else its
// file's, read into `file`.
std::span<const unsigned char> imageBytes(const tinygltf::Model& model, int index, const std::string& path,
                                          std::string& file) {
    const tinygltf::Image& image = model.images[size_t(index)];
    const std::string what = path + ": images[" + std::to_string(index) + "]";
    if (!image.image.empty()) return image.image;
    if (image.uri.empty()) fail(what, "has no image data");
    const std::string name =
        uriFile(path, {"images[" + std::to_string(index) + "].uri", image.uri, imageFileName(image.uri)});
    try {
        file = readInputFile(name, kMaxGltfFileBytes, "an image file");
    } catch (const Error& error) {
        fail(what, error.what());
    }
    return {reinterpret_cast<const unsigned char*>(file.data()), file.size()};
}

// What the World will hold, counted from the counts and image headers alone: the triangles and
// vertices of every node that instances a mesh, and the pixels of every image the drawn primitives'
// materials use. A small file may instance a large mesh many times, or name many images whose
// headers claim large sizes; each total is refused before any vertex is read or image decoded.
class SceneTotals {
  public:
    SceneTotals(const GltfGeometrySource& source, const GltfLoadOptions& options)
        : source_(source), options_(options), meshes_(source.model.meshes.size()) {}

    void check(const std::vector<PlacedNode>& placed) {
        const tinygltf::Model& model = source_.model;
        uint64_t triangles = 0, vertices = 0;
        size_t instances = 0;
        for (const PlacedNode& node : placed) {
            const int mesh = model.nodes[size_t(node.node)].mesh;
            if (mesh < 0) continue;
            if (size_t(mesh) >= model.meshes.size())
                fail(source_.path, nodeName(node.node) + ".mesh is " + std::to_string(mesh) +
                                       ", but the file has " + counted(model.meshes.size(), "mesh"));
            const MeshTotals& totals = meshTotals(mesh);
            if (totals.triangles == 0) continue;
            ++instances;
            triangles = saturatingAdd(triangles, totals.triangles);
            vertices = saturatingAdd(vertices, totals.vertices);
        }
        const std::string made =
            "the scene's " + counted(instances, "mesh instance") + (instances == 1 ? " makes " : " make ");
        if (triangles > options_.maxTriangles)
            fail(source_.path, made + counted(triangles, "triangle") + ", more than the limit of " +
                                   counted(options_.maxTriangles, "triangle") + " (every instance counted)");
        if (vertices > vertexLimit(options_))
            fail(source_.path, made + std::to_string(vertices) + " vertices, more than the limit of " +
                                   std::to_string(vertexLimit(options_)) +
                                   " vertices (3 per triangle of the triangle limit)");
        checkTexturePixels();
    }

  private:
    struct MeshTotals {
        uint64_t triangles = 0;
        uint64_t vertices = 0; // as the World keeps them: 3 per triangle where flat normals are made
    };

    const MeshTotals& meshTotals(int mesh) {
        std::optional<MeshTotals>& known = meshes_[size_t(mesh)];
        if (known) return *known;
        MeshTotals totals;
        const auto& primitives = source_.model.meshes[size_t(mesh)].primitives;
        for (size_t p = 0; p < primitives.size(); ++p) {
            const PrimitiveShape shape = primitiveShape(source_, mesh, int(p));
            if (shape.triangles == 0) continue;
            // POSITION is read whole; an accessor without a buffer view (zeros) is backed by no bytes.
            if (shape.vertices > vertexLimit(options_))
                fail(source_.path, meshName(mesh) + ".primitives[" + std::to_string(p) +
                                       "].attributes.POSITION has " + std::to_string(shape.vertices) +
                                       " vertices" + ", more than the limit of " +
                                       std::to_string(vertexLimit(options_)));
            const bool flat = primitives[p].attributes.count("NORMAL") == 0;
            totals.triangles = saturatingAdd(totals.triangles, shape.triangles);
            totals.vertices =
                saturatingAdd(totals.vertices, flat ? 3 * uint64_t(shape.triangles) : shape.vertices);
            materials_.insert(primitives[p].material);
        }
        return *(known = totals);
    }

    // The pixels of the images the used materials' textures name, from their headers. Indices that
    // name nothing are left to SceneBuilder, which refuses them in its words.
    void checkTexturePixels() const {
        const tinygltf::Model& model = source_.model;
        std::set<int> images;
        for (int material : materials_) {
            if (material < 0 || size_t(material) >= model.materials.size()) continue;
            const tinygltf::Material& m = model.materials[size_t(material)];
            for (int texture : {m.pbrMetallicRoughness.baseColorTexture.index, m.emissiveTexture.index}) {
                if (texture < 0 || size_t(texture) >= model.textures.size()) continue;
                const int image = model.textures[size_t(texture)].source;
                if (image >= 0 && size_t(image) < model.images.size()) images.insert(image);
            }
        }
        int64_t pixels = 0;
        for (int image : images) {
            std::string file;
            pixels +=
                colourTexturePixels(imageBytes(model, image, source_.path, file), options_.maxTexturePixels,
                                    source_.path + ": images[" + std::to_string(image) + "]");
        }
        if (pixels > options_.maxSceneTexturePixels)
            fail(source_.path, "the " + counted(images.size(), "texture") +
                                   " the scene's materials use have " + std::to_string(pixels) +
                                   " pixels, more than the limit of " +
                                   std::to_string(options_.maxSceneTexturePixels) + " pixels in all");
    }

    const GltfGeometrySource& source_;
    const GltfLoadOptions& options_;
    std::vector<std::optional<MeshTotals>> meshes_;
    std::set<int> materials_; // of the primitives drawn (-1: the default material)
};

// ---- The World ----------------------------------------------------------------------------------

class SceneBuilder {
  public:
    SceneBuilder(const tinygltf::Model& model, const std::string& path, const GltfLoadOptions& options)
        : model_(model), path_(path),
          options_(options), source_{model, path, usesExtension(model, "KHR_mesh_quantization")} {}

    // Before anything is read, the scene's totals against the limits (SceneTotals).
    void checkTotals(const std::vector<PlacedNode>& placed) const {
        SceneTotals(source_, options_).check(placed);
    }

    void addNode(const PlacedNode& placed) {
        const tinygltf::Node& node = model_.nodes[size_t(placed.node)];
        if (node.mesh >= 0) addMesh(placed, node.mesh);
        auto light = node.extensions.find("KHR_lights_punctual");
        if (light != node.extensions.end() && light->second.Has("light"))
            addLight(placed, light->second.Get("light").GetNumberAsInt());
    }

    World finish() {
        if (world_.indices.empty())
            fail(path_, "the scene has no triangles" + (notes_.empty() ? "" : " (" + notesText() + ")"));
        world_.boundsMin = world_.boundsMax = world_.positions[0];
        for (const glm::vec3& p : world_.positions) {
            world_.boundsMin = glm::min(world_.boundsMin, p);
            world_.boundsMax = glm::max(world_.boundsMax, p);
        }
        world_.description = path_ + " (" + counted(world_.triangleCount(), "triangle") + ", " +
                             counted(world_.materials.size(), "material") + ", " +
                             counted(world_.suns.size(), "sun") + (notes_.empty() ? "" : "; " + notesText()) +
                             ")";
        return std::move(world_);
    }

  private:
    // `mesh` exists: SceneTotals checked.
    void addMesh(const PlacedNode& placed, int mesh) {
        const auto& primitives = model_.meshes[size_t(mesh)].primitives;
        for (size_t p = 0; p < primitives.size(); ++p) {
            const PrimitiveShape shape = primitiveShape(source_, mesh, int(p));
            if (shape.pointsOrLines) ++notes_["line or point primitive"];
            if (shape.triangles == 0) continue;
            const uint32_t material = materialSlot(primitives[p].material, mesh, int(p));
            const SceneMaterial& scene = world_.materials[material];
            if ((scene.albedoTexture >= 0 || scene.emissionTexture >= 0) &&
                !primitives[p].attributes.count("TEXCOORD_0"))
                fail(path_, "meshes[" + std::to_string(mesh) + "].primitives[" + std::to_string(p) +
                                "] has a textured material but no TEXCOORD_0");
            const PrimitiveGeometry geometry = readPrimitive(source_, mesh, int(p));
            const uint32_t firstVertex = uint32_t(world_.positions.size());
            appendPrimitive(world_, geometry, placed.world, material,
                            path_ + ": " + nodeName(placed.node) + " (meshes[" + std::to_string(mesh) +
                                "].primitives[" + std::to_string(p) + "])");
            placedPrimitives_.push_back(placement(placed, mesh, int(p), geometry, firstVertex));
        }
    }

    // The World vertices appendPrimitive added from `firstVertex` on, by their POSITION elements: in
    // order, or a flat primitive's triangle corners (their order turned as appendPrimitive turns it).
    GltfPlacedPrimitive placement(const PlacedNode& placed, int mesh, int primitive,
                                  const PrimitiveGeometry& geometry, uint32_t firstVertex) const {
        GltfPlacedPrimitive record{placed.node, mesh, primitive,
                                   firstVertex, {},   uint32_t(geometry.positions.size())};
        if (!geometry.normals.empty()) {
            for (uint32_t v = 0; v < record.positionCount; ++v)
                record.sourceVertices.push_back(v);
            return record;
        }
        const bool flip = glm::determinant(glm::dmat3(placed.world)) < 0.0;
        for (size_t i = 0; i < geometry.indices.size(); i += 3)
            for (size_t c : {size_t(0), size_t(flip ? 2 : 1), size_t(flip ? 1 : 2)})
                record.sourceVertices.push_back(geometry.indices[i + c]);
        return record;
    }

  public:
    std::vector<GltfPlacedPrimitive> takePlacedPrimitives() { return std::move(placedPrimitives_); }

  private:
    // The World material of a glTF material (-1: glTF's default), added on first use.
    uint32_t materialSlot(int material, int mesh, int primitive) {
        if (auto found = materialSlots_.find(material); found != materialSlots_.end()) return found->second;
        if (material >= 0 && size_t(material) >= model_.materials.size())
            fail(path_, "meshes[" + std::to_string(mesh) + "].primitives[" + std::to_string(primitive) +
                            "].material is " + std::to_string(material) + ", but the file has " +
                            counted(model_.materials.size(), "material"));
        SceneMaterial scene;
        if (material >= 0) scene = sceneMaterial(material);
        world_.materials.push_back(scene);
        return materialSlots_[material] = uint32_t(world_.materials.size() - 1);
    }

    SceneMaterial sceneMaterial(int index) {
        const tinygltf::Material& material = model_.materials[size_t(index)];
        const std::string where = "materials[" + std::to_string(index) + "]";
        SceneMaterial scene;
        const std::vector<double>& base = material.pbrMetallicRoughness.baseColorFactor;
        requireUnitFactors(base, where + ".pbrMetallicRoughness.baseColorFactor");
        requireUnitFactors(material.emissiveFactor, where + ".emissiveFactor");
        if (base.size() >= 3) scene.albedo = glm::vec3(float(base[0]), float(base[1]), float(base[2]));
        if (material.emissiveFactor.size() == 3)
            scene.emission = glm::vec3(glm::make_vec3(material.emissiveFactor.data()));
        scene.emission *= float(emissiveStrength(material, where));
        scene.doubleSided = material.doubleSided;
        scene.albedoTexture = textureSlot(material.pbrMetallicRoughness.baseColorTexture,
                                          where + ".pbrMetallicRoughness.baseColorTexture");
        scene.emissionTexture = textureSlot(material.emissiveTexture, where + ".emissiveTexture");
        return scene;
    }

    // glTF's colour factors lie in 0..1 (an albedo above 1 would reflect more light than it
    // receives, and the bounces would grow without end); a brighter emission takes
    // KHR_materials_emissive_strength.
    void requireUnitFactors(const std::vector<double>& factors, const std::string& where) const {
        for (size_t i = 0; i < factors.size(); ++i) {
            if (factors[i] >= 0.0 && factors[i] <= 1.0) continue;
            fail(path_, where + "[" + std::to_string(i) + "] is " + shortNumber(factors[i]) +
                            ", outside the 0..1 glTF allows");
        }
    }

    double emissiveStrength(const tinygltf::Material& material, const std::string& where) const {
        auto extension = material.extensions.find("KHR_materials_emissive_strength");
        if (extension == material.extensions.end() || !extension->second.Has("emissiveStrength")) return 1.0;
        const double strength = extension->second.Get("emissiveStrength").GetNumberAsDouble();
        if (strength < 0.0)
            fail(path_, where + ".extensions.KHR_materials_emissive_strength.emissiveStrength is " +
                            std::to_string(strength) + "; it must be at least 0");
        return strength;
    }

    // The World texture of a texture reference (-1: none), decoded on first use.
    int textureSlot(const tinygltf::TextureInfo& info, const std::string& where) {
        if (info.index < 0) return -1;
        if (size_t(info.index) >= model_.textures.size())
            fail(path_, where + ".index is " + std::to_string(info.index) + ", but the file has " +
                            counted(model_.textures.size(), "texture"));
        if (info.texCoord != 0)
            fail(path_,
                 where + " uses TEXCOORD_" + std::to_string(info.texCoord) + "; only TEXCOORD_0 is read");
        const int image = model_.textures[size_t(info.index)].source;
        if (image < 0 || size_t(image) >= model_.images.size())
            fail(path_, "textures[" + std::to_string(info.index) + "] has no image of the file's " +
                            counted(model_.images.size(), "image") +
                            " (the images of extensions, such as KHR_texture_basisu, are not read)");
        if (auto found = textureSlots_.find(image); found != textureSlots_.end()) return found->second;
        world_.textures.push_back(decodeImage(image));
        return textureSlots_[image] = int(world_.textures.size() - 1);
    }

    SceneTexture decodeImage(int index) {
        std::string file;
        return decodeColourTexture(imageBytes(model_, index, path_, file), options_.maxTexturePixels,
                                   path_ + ": images[" + std::to_string(index) + "]");
    }

    // KHR_lights_punctual: a directional light shines along its node's -Z, so the direction
    // towards it is the node's world +Z. Point and spot lights are counted and left out.
    void addLight(const PlacedNode& placed, int index) {
        const std::string where = nodeName(placed.node) + ".extensions.KHR_lights_punctual.light";
        if (index < 0 || size_t(index) >= model_.lights.size())
            fail(path_, where + " is " + std::to_string(index) + ", but the file has " +
                            counted(model_.lights.size(), "light"));
        const tinygltf::Light& light = model_.lights[size_t(index)];
        if (light.type != "directional") {
            ++notes_[light.type + " light"];
            return;
        }
        const glm::dvec3 axis = glm::dmat3(placed.world) * glm::dvec3(0.0, 0.0, 1.0);
        if (!(glm::length(axis) > 0.0))
            fail(path_,
                 nodeName(placed.node) + ": the directional light has no direction (the node's scale is 0)");
        if (light.intensity < 0.0)
            fail(path_, "lights[" + std::to_string(index) + "].intensity is " +
                            std::to_string(light.intensity) + "; it must be at least 0");
        const glm::dvec3 colour =
            light.color.size() == 3 ? glm::make_vec3(light.color.data()) : glm::dvec3(1.0);
        const glm::vec3 irradiance(colour * light.intensity);
        if (!std::isfinite(irradiance.r) || !std::isfinite(irradiance.g) || !std::isfinite(irradiance.b))
            fail(path_, "lights[" + std::to_string(index) +
                            "]: its colour times its intensity is past what float holds; make it weaker");
        world_.suns.push_back({glm::vec3(glm::normalize(axis)), irradiance});
    }

    // "2 point lights ignored, 1 line or point primitive ignored"
    std::string notesText() const {
        std::string text;
        for (const auto& [what, count] : notes_)
            text += (text.empty() ? "" : ", ") + counted(count, what) + " ignored";
        return text;
    }

    const tinygltf::Model& model_;
    const std::string& path_;
    const GltfLoadOptions& options_;
    GltfGeometrySource source_;
    World world_;
    std::map<int, uint32_t> materialSlots_; // glTF material (-1: the default) -> World::materials
    std::map<int, int> textureSlots_;       // glTF image -> World::textures
    std::map<std::string, size_t> notes_;   // what was left out, and how many
    std::vector<GltfPlacedPrimitive> placedPrimitives_;
};

// The scene file's bytes. Not standard input ("-"): a scene's buffers and images are found beside
// its file, and its bytes are read more than once (checked, hashed, parsed).
std::string readGltfFile(const std::string& path) {
    if (path == "-")
        fail(path, "a scene is read from its file, not standard input: its buffers and images lie beside it");
    return readInputFile(path, kMaxGltfFileBytes, "a glTF file");
}

} // namespace

std::vector<std::string> gltfExternalFiles(const std::string& path) {
    const std::string bytes = readGltfFile(path);
    const std::string_view json = isGlb(bytes) ? glbParts(bytes, path).second : std::string_view(bytes);
    if (!isGlb(bytes) && !looksLikeJson(json)) return {}; // loadGltfScene says what it is
    checkGltfJson(json, path);
    return uriFiles(json, path);
}

std::string gltfSceneHash(const std::string& path) {
    const std::string bytes = readGltfFile(path);
    Fnv1a64 hash;
    hash.addLength(bytes.size());
    hash.add(bytes);
    const std::string_view json = isGlb(bytes) ? glbParts(bytes, path).second : std::string_view(bytes);
    if (!isGlb(bytes) && !looksLikeJson(json)) return hash.text(); // no scene: loadGltfScene says why
    checkGltfJson(json, path);
    for (const std::string& file : uriFiles(json, path)) {
        try {
            const std::string content = readInputFile(file, kMaxGltfFileBytes, "a glTF buffer or image file");
            hash.addLength(content.size());
            hash.add(content);
        } catch (const Error&) {
            hash.addLength(UINT64_MAX);
        }
    }
    return hash.text();
}

namespace {

// The World and where its vertices come from; `model` is the model they were read from. The JSON is
// kept only where asked (the .glb writer of transfer needs it, and it may be the whole file).
GltfSceneSource readScene(const std::string& path, const GltfLoadOptions& options,
                          std::shared_ptr<tinygltf::Model>& model, bool keepJson) {
    const std::string bytes = readGltfFile(path);
    model = std::make_shared<tinygltf::Model>(parseModel(path, bytes));
    const std::vector<int> parents = checkedParents(*model, path);
    SceneBuilder builder(*model, path, options);
    const std::vector<PlacedNode> placed = placeNodes(*model, sceneRoots(*model, parents, path), path);
    builder.checkTotals(placed);
    for (const PlacedNode& node : placed)
        builder.addNode(node);
    GltfSceneSource source{builder.finish(), builder.takePlacedPrimitives(), nullptr, {}};
    if (keepJson) source.json = isGlb(bytes) ? glbParts(bytes, path).second : std::string_view(bytes);
    return source;
}

} // namespace

World loadGltfScene(const std::string& path, const GltfLoadOptions& options) {
    std::shared_ptr<tinygltf::Model> model;
    return std::move(readScene(path, options, model, false).world);
}

GltfSceneSource loadGltfSceneSource(const std::string& path, const GltfLoadOptions& options) {
    std::shared_ptr<tinygltf::Model> model;
    GltfSceneSource source = readScene(path, options, model, true);
    for (size_t i = 0; i < model->images.size(); ++i) {
        tinygltf::Image& image = model->images[i];
        if (!image.image.empty() || image.bufferView >= 0) continue;
        std::string file;
        const std::span<const unsigned char> read = imageBytes(*model, int(i), path, file);
        image.image.assign(read.begin(), read.end());
    }
    source.model = std::move(model);
    return source;
}

} // namespace shprobe
