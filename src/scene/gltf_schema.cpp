// glTF 2.0's JSON schema (the specification's "JSON Schema Reference"), as far as property types
// go, as tables: one list of fields per kind of object, walked from the root.
#include "scene/gltf_schema.h"

#include "common/error.h"
#include "common/quoted.h"
#include "common/short_number.h"
#include "formats/json_reading.h"
#include "scene/gltf_limits.h"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <utility>

namespace shprobe {

namespace {

using nlohmann::json;

constexpr int64_t kMaxIndex = kMaxGltfIndex;
constexpr int64_t kMaxSize = kMaxGltfSize;

enum class Type {
    String,
    Number, // finite
    Boolean,
    Index,   // an integer from 0 to kMaxIndex (indices, enums such as componentType and mode)
    Size,    // an integer from 0 to kMaxSize
    Object,  // with `fields`
    Objects, // an array of objects, each with `fields`
    Numbers, // of `length` elements when it is not 0
    Indices,
    Strings,
    IndexMap,  // an object whose members are indices (a primitive's attributes)
    IndexMaps, // an array of them (morph targets)
};

struct Field {
    std::string_view name;
    Type type;
    std::span<const Field> fields{};
    size_t length = 0;
};

// Every object may also have "name" (a string), "extensions" (an object of objects) and "extras"
// (anything): checked for every object, listed only where an extension read here is described.
constexpr Field kTextureInfo[] = {{"index", Type::Index}, {"texCoord", Type::Index}};
constexpr Field kNormalTextureInfo[] = {
    {"index", Type::Index}, {"texCoord", Type::Index}, {"scale", Type::Number}};
constexpr Field kOcclusionTextureInfo[] = {
    {"index", Type::Index}, {"texCoord", Type::Index}, {"strength", Type::Number}};
constexpr Field kPbr[] = {{"baseColorFactor", Type::Numbers, {}, 4},
                          {"baseColorTexture", Type::Object, kTextureInfo},
                          {"metallicFactor", Type::Number},
                          {"roughnessFactor", Type::Number},
                          {"metallicRoughnessTexture", Type::Object, kTextureInfo}};
constexpr Field kEmissiveStrength[] = {{"emissiveStrength", Type::Number}};
constexpr Field kMaterialExtensions[] = {
    {"KHR_materials_emissive_strength", Type::Object, kEmissiveStrength}};
constexpr Field kMaterial[] = {{"pbrMetallicRoughness", Type::Object, kPbr},
                               {"normalTexture", Type::Object, kNormalTextureInfo},
                               {"occlusionTexture", Type::Object, kOcclusionTextureInfo},
                               {"emissiveTexture", Type::Object, kTextureInfo},
                               {"emissiveFactor", Type::Numbers, {}, 3},
                               {"alphaMode", Type::String},
                               {"alphaCutoff", Type::Number},
                               {"doubleSided", Type::Boolean},
                               {"extensions", Type::Object, kMaterialExtensions}};

constexpr Field kSparseIndices[] = {
    {"bufferView", Type::Index}, {"byteOffset", Type::Index}, {"componentType", Type::Index}};
constexpr Field kSparseValues[] = {{"bufferView", Type::Index}, {"byteOffset", Type::Index}};
constexpr Field kSparse[] = {{"count", Type::Index},
                             {"indices", Type::Object, kSparseIndices},
                             {"values", Type::Object, kSparseValues}};
constexpr Field kAccessor[] = {
    {"bufferView", Type::Index},   {"byteOffset", Type::Size}, {"componentType", Type::Index},
    {"normalized", Type::Boolean}, {"count", Type::Size},      {"type", Type::String},
    {"max", Type::Numbers},        {"min", Type::Numbers},     {"sparse", Type::Object, kSparse}};

constexpr Field kAnimationTarget[] = {{"node", Type::Index}, {"path", Type::String}};
constexpr Field kAnimationChannel[] = {{"sampler", Type::Index}, {"target", Type::Object, kAnimationTarget}};
constexpr Field kAnimationSampler[] = {
    {"input", Type::Index}, {"interpolation", Type::String}, {"output", Type::Index}};
constexpr Field kAnimation[] = {{"channels", Type::Objects, kAnimationChannel},
                                {"samplers", Type::Objects, kAnimationSampler}};

constexpr Field kAsset[] = {{"copyright", Type::String},
                            {"generator", Type::String},
                            {"version", Type::String},
                            {"minVersion", Type::String}};
constexpr Field kBuffer[] = {{"uri", Type::String}, {"byteLength", Type::Size}};
constexpr Field kBufferView[] = {{"buffer", Type::Index},
                                 {"byteOffset", Type::Size},
                                 {"byteLength", Type::Size},
                                 {"byteStride", Type::Index},
                                 {"target", Type::Index}};

constexpr Field kOrthographic[] = {
    {"xmag", Type::Number}, {"ymag", Type::Number}, {"zfar", Type::Number}, {"znear", Type::Number}};
constexpr Field kPerspective[] = {
    {"aspectRatio", Type::Number}, {"yfov", Type::Number}, {"zfar", Type::Number}, {"znear", Type::Number}};
constexpr Field kCamera[] = {{"orthographic", Type::Object, kOrthographic},
                             {"perspective", Type::Object, kPerspective},
                             {"type", Type::String}};

constexpr Field kImage[] = {{"uri", Type::String}, {"mimeType", Type::String}, {"bufferView", Type::Index}};
constexpr Field kPrimitive[] = {{"attributes", Type::IndexMap},
                                {"indices", Type::Index},
                                {"material", Type::Index},
                                {"mode", Type::Index},
                                {"targets", Type::IndexMaps}};
constexpr Field kMesh[] = {{"primitives", Type::Objects, kPrimitive}, {"weights", Type::Numbers}};

constexpr Field kNodeLight[] = {{"light", Type::Index}};
constexpr Field kNodeExtensions[] = {{"KHR_lights_punctual", Type::Object, kNodeLight}};
constexpr Field kNode[] = {{"camera", Type::Index},         {"children", Type::Indices},
                           {"skin", Type::Index},           {"matrix", Type::Numbers, {}, 16},
                           {"mesh", Type::Index},           {"rotation", Type::Numbers, {}, 4},
                           {"scale", Type::Numbers, {}, 3}, {"translation", Type::Numbers, {}, 3},
                           {"weights", Type::Numbers},      {"extensions", Type::Object, kNodeExtensions}};

constexpr Field kSampler[] = {
    {"magFilter", Type::Index}, {"minFilter", Type::Index}, {"wrapS", Type::Index}, {"wrapT", Type::Index}};
constexpr Field kScene[] = {{"nodes", Type::Indices}};
constexpr Field kSkin[] = {
    {"inverseBindMatrices", Type::Index}, {"skeleton", Type::Index}, {"joints", Type::Indices}};
constexpr Field kTexture[] = {{"sampler", Type::Index}, {"source", Type::Index}};

constexpr Field kSpot[] = {{"innerConeAngle", Type::Number}, {"outerConeAngle", Type::Number}};
constexpr Field kLight[] = {{"color", Type::Numbers, {}, 3},
                            {"intensity", Type::Number},
                            {"type", Type::String},
                            {"range", Type::Number},
                            {"spot", Type::Object, kSpot}};
constexpr Field kLights[] = {{"lights", Type::Objects, kLight}};
constexpr Field kRootExtensions[] = {{"KHR_lights_punctual", Type::Object, kLights}};

constexpr Field kRoot[] = {{"extensionsUsed", Type::Strings},
                           {"extensionsRequired", Type::Strings},
                           {"accessors", Type::Objects, kAccessor},
                           {"animations", Type::Objects, kAnimation},
                           {"asset", Type::Object, kAsset},
                           {"buffers", Type::Objects, kBuffer},
                           {"bufferViews", Type::Objects, kBufferView},
                           {"cameras", Type::Objects, kCamera},
                           {"images", Type::Objects, kImage},
                           {"materials", Type::Objects, kMaterial},
                           {"meshes", Type::Objects, kMesh},
                           {"nodes", Type::Objects, kNode},
                           {"samplers", Type::Objects, kSampler},
                           {"scene", Type::Index},
                           {"scenes", Type::Objects, kScene},
                           {"skins", Type::Objects, kSkin},
                           {"textures", Type::Objects, kTexture},
                           {"extensions", Type::Object, kRootExtensions}};

// The extensions a file may require: those read here (gltf_scene.h). Checked before tinygltf reads
// the file, which fails on some of the others (Draco's accessors have no buffer view) in its own words.
constexpr std::string_view kSupportedExtensions[] = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                                     "KHR_mesh_quantization"};

const char* typeName(const json& value) {
    switch (value.type()) {
    case json::value_t::null:
        return "null";
    case json::value_t::boolean:
        return "a boolean";
    case json::value_t::string:
        return "a string";
    case json::value_t::array:
        return "an array";
    case json::value_t::object:
        return "an object";
    default:
        return "a number";
    }
}

class Checker {
  public:
    explicit Checker(const std::string& path) : path_(path) {}

    void checkObject(const json& object, std::span<const Field> fields, const std::string& where) {
        for (const Field& field : fields) {
            auto member = object.find(field.name);
            if (member != object.end()) checkValue(*member, field, child(where, field.name));
        }
        checkCommon(object, where);
    }

    [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
        throw Error(ErrorKind::Input, path_ + ": " + where + " " + problem);
    }

  private:
    static std::string child(const std::string& where, std::string_view name) {
        return where.empty() ? std::string(name) : where + "." + std::string(name);
    }
    static std::string element(const std::string& where, size_t i) {
        return where + "[" + std::to_string(i) + "]";
    }

    // The members every glTF object may have.
    void checkCommon(const json& object, const std::string& where) {
        if (auto name = object.find("name"); name != object.end() && !name->is_string())
            mustBe(*name, child(where, "name"), "a string");
        auto extensions = object.find("extensions");
        if (extensions == object.end()) return;
        const std::string at = child(where, "extensions");
        if (!extensions->is_object()) mustBe(*extensions, at, "an object");
        for (auto extension = extensions->begin(); extension != extensions->end(); ++extension)
            if (!extension->is_object()) mustBe(*extension, child(at, clipped(extension.key())), "an object");
    }

    [[noreturn]] void mustBe(const json& value, const std::string& where, const char* expected) const {
        std::string found = typeName(value);
        if (value.is_number()) found += " (" + value.dump() + ")";
        fail(where, std::string("must be ") + expected + ", not " + found);
    }

    void checkInteger(const json& value, int64_t largest, const std::string& where) const {
        const char* expected =
            largest == kMaxIndex ? "an integer from 0 to 2147483647" : "an integer from 0 to 2^53";
        if (value.is_number_unsigned() && value.get<uint64_t>() <= uint64_t(largest)) return;
        if (value.is_number_integer() && !value.is_number_unsigned() && value.get<int64_t>() >= 0 &&
            value.get<int64_t>() <= largest)
            return;
        mustBe(value, where, expected);
    }

    void checkNumber(const json& value, const std::string& where) const {
        if (!value.is_number()) mustBe(value, where, "a number");
        if (!std::isfinite(value.get<double>())) mustBe(value, where, "a finite number");
    }

    void checkArray(const json& value, const Field& field, const std::string& where) {
        if (!value.is_array()) mustBe(value, where, "an array");
        if (field.length != 0 && value.size() != field.length)
            fail(where, "must have " + std::to_string(field.length) + " elements, not " +
                            std::to_string(value.size()));
        for (size_t i = 0; i < value.size(); ++i) {
            const json& item = value[i];
            const std::string at = element(where, i);
            switch (field.type) {
            case Type::Objects:
                if (!item.is_object()) mustBe(item, at, "an object");
                checkObject(item, field.fields, at);
                break;
            case Type::Numbers:
                checkNumber(item, at);
                break;
            case Type::Indices:
                checkInteger(item, kMaxIndex, at);
                break;
            case Type::Strings:
                if (!item.is_string()) mustBe(item, at, "a string");
                break;
            default: // IndexMaps
                checkIndexMap(item, at);
                break;
            }
        }
    }

    void checkIndexMap(const json& value, const std::string& where) const {
        if (!value.is_object()) mustBe(value, where, "an object");
        for (auto member = value.begin(); member != value.end(); ++member)
            checkInteger(*member, kMaxIndex, child(where, clipped(member.key())));
    }

    void checkValue(const json& value, const Field& field, const std::string& where) {
        switch (field.type) {
        case Type::String:
            if (!value.is_string()) mustBe(value, where, "a string");
            return;
        case Type::Number:
            return checkNumber(value, where);
        case Type::Boolean:
            if (!value.is_boolean()) mustBe(value, where, "a boolean");
            return;
        case Type::Index:
            return checkInteger(value, kMaxIndex, where);
        case Type::Size:
            return checkInteger(value, kMaxSize, where);
        case Type::Object:
            if (!value.is_object()) mustBe(value, where, "an object");
            return checkObject(value, field.fields, where);
        case Type::IndexMap:
            return checkIndexMap(value, where);
        default:
            return checkArray(value, field, where);
        }
    }

    const std::string& path_;
};

// A JSON array member of the root, or an empty one.
const json& arrayOf(const json& root, const char* name) {
    static const json empty = json::array();
    auto member = root.find(name);
    return member == root.end() ? empty : *member;
}

uint64_t sizeOr(const json& object, const char* name, uint64_t fallback) {
    auto member = object.find(name);
    return member == object.end() ? fallback : member->get<uint64_t>();
}

// Buffers and views of at least a byte (the schema's minimum), each view within its buffer.
// Missing required members are left to tinygltf, which names them.
void checkBufferViews(const json& root, const Checker& checker) {
    const json& buffers = arrayOf(root, "buffers");
    for (size_t i = 0; i < buffers.size(); ++i)
        if (sizeOr(buffers[i], "byteLength", 1) < 1)
            checker.fail("buffers[" + std::to_string(i) + "].byteLength", "must be at least 1");
    const json& views = arrayOf(root, "bufferViews");
    for (size_t i = 0; i < views.size(); ++i) {
        const std::string where = "bufferViews[" + std::to_string(i) + "]";
        const json& view = views[i];
        if (!view.contains("buffer") || !view.contains("byteLength")) continue;
        const uint64_t length = sizeOr(view, "byteLength", 0);
        if (length < 1) checker.fail(where + ".byteLength", "must be at least 1");
        if (const uint64_t stride = sizeOr(view, "byteStride", 4);
            stride < 4 || stride > uint64_t(kMaxGltfByteStride) || stride % 4 != 0)
            checker.fail(where + ".byteStride", "is " + std::to_string(stride) +
                                                    "; it must be a multiple of 4 from 4 to " +
                                                    std::to_string(kMaxGltfByteStride));
        const uint64_t buffer = view["buffer"].get<uint64_t>();
        if (buffer >= buffers.size())
            checker.fail(where + ".buffer", "is " + std::to_string(buffer) + ", but the file has " +
                                                std::to_string(buffers.size()) + " buffers");
        const uint64_t end = sizeOr(view, "byteOffset", 0) + length; // both below 2^53: no overflow
        const uint64_t bufferLength = sizeOr(buffers[buffer], "byteLength", 0);
        if (end > bufferLength)
            checker.fail(where, "ends at byte " + std::to_string(end) + ", past the end of buffer " +
                                    std::to_string(buffer) + " (" + std::to_string(bufferLength) + " bytes)");
    }
}

// Bytes of an element of an accessor (the specification's 3.6.2, "Accessors"); 0 for a type or
// component type glTF does not have, left to the readers to name. Matrix columns start on 4-byte
// boundaries (3.6.2.4), so MAT2 and MAT3 of 1-byte and MAT3 of 2-byte components are padded.
uint64_t elementBytes(const std::string& type, uint64_t componentType) {
    const uint64_t component = componentType == 5120 || componentType == 5121   ? 1
                               : componentType == 5122 || componentType == 5123 ? 2
                               : componentType == 5125 || componentType == 5126 ? 4
                                                                                : 0;
    if (type == "SCALAR") return component;
    if (type == "VEC2") return 2 * component;
    if (type == "VEC3") return 3 * component;
    if (type == "VEC4") return 4 * component;
    if (type == "MAT2") return component == 1 ? 8 : 4 * component;
    if (type == "MAT3") return component == 1 ? 12 : component == 2 ? 24 : 9 * component;
    if (type == "MAT4") return 16 * component;
    return 0;
}

// The view of index `view` (checked by checkBufferViews), or null when there is none such.
const json* viewAt(const json& views, uint64_t view) {
    return view < views.size() && views[view].contains("byteLength") ? &views[view] : nullptr;
}

// `count` elements of `size` bytes, `stride` apart from byte `offset` of a buffer view must end
// within its byteLength (3.6.2.4: offset + stride * (count - 1) + size <= byteLength). Offset and
// count are below 2^53, stride and size at most 252 (checkBufferViews): the end is below 2^62.
void checkElementsInView(const Checker& checker, const std::string& where, uint64_t count, uint64_t size,
                         uint64_t stride, uint64_t offset, uint64_t view, const json& bufferView) {
    if (count == 0) return;
    const uint64_t length = sizeOr(bufferView, "byteLength", 0);
    const uint64_t end = offset + stride * (count - 1) + size;
    if (end <= length) return;
    checker.fail(where, "claims " + std::to_string(count) + (count == 1 ? " element of " : " elements of ") +
                            std::to_string(size) + " bytes" +
                            (count > 1 ? ", " + std::to_string(stride) + " apart," : "") + " from byte " +
                            std::to_string(offset) + ": they need " + std::to_string(end) +
                            " bytes of bufferViews[" + std::to_string(view) + "], which has " +
                            std::to_string(length));
}

// Every accessor's elements, and its sparse indices and values, within the buffer views that hold
// them, so that a count a file claims is never allocated unless its bytes are there (the buffer
// views were checked within their buffers, and tinygltf checks each buffer's bytes against its
// byteLength). An accessor without a buffer view is zeros: its count is bounded by the scene's
// vertex limit (gltf_scene.cpp) before it is read.
void checkAccessors(const json& root, const Checker& checker) {
    const json& views = arrayOf(root, "bufferViews");
    const json& accessors = arrayOf(root, "accessors");
    for (size_t i = 0; i < accessors.size(); ++i) {
        const json& accessor = accessors[i];
        const std::string where = "accessors[" + std::to_string(i) + "]";
        if (!accessor.contains("type") || !accessor.contains("componentType")) continue; // tinygltf says
        const uint64_t size =
            elementBytes(accessor["type"].get<std::string>(), accessor["componentType"].get<uint64_t>());
        if (size == 0) continue;
        const uint64_t count = sizeOr(accessor, "count", 0);
        if (accessor.contains("bufferView")) {
            const uint64_t view = accessor["bufferView"].get<uint64_t>();
            if (const json* bufferView = viewAt(views, view)) {
                const uint64_t byteStride = sizeOr(*bufferView, "byteStride", 0);
                if (byteStride != 0 && byteStride < size)
                    checker.fail(where, "has elements of " + std::to_string(size) +
                                            " bytes, but bufferViews[" + std::to_string(view) +
                                            "].byteStride is " + std::to_string(byteStride));
                checkElementsInView(checker, where, count, size, byteStride ? byteStride : size,
                                    sizeOr(accessor, "byteOffset", 0), view, *bufferView);
            }
        }
        if (!accessor.contains("sparse")) continue;
        const json& sparse = accessor["sparse"];
        const uint64_t sparseCount = sizeOr(sparse, "count", 0);
        if (sparseCount > count)
            checker.fail(where + ".sparse.count", "is " + std::to_string(sparseCount) + ", more than the " +
                                                      std::to_string(count) + " elements of the accessor");
        for (const char* part : {"indices", "values"}) {
            if (!sparse.contains(part) || !sparse[part].contains("bufferView")) continue; // tinygltf says
            const json& of = sparse[part];
            uint64_t partSize = size;
            if (part == std::string_view("indices")) {
                const uint64_t type = sizeOr(of, "componentType", 0);
                partSize = type == 5121 ? 1 : type == 5123 ? 2 : type == 5125 ? 4 : 0;
                if (partSize == 0) continue; // the reader names the type
            }
            const uint64_t view = of["bufferView"].get<uint64_t>();
            if (const json* bufferView = viewAt(views, view))
                checkElementsInView(checker, where + ".sparse." + part, sparseCount, partSize, partSize,
                                    sizeOr(of, "byteOffset", 0), view, *bufferView);
        }
    }
}

void checkRequiredExtensions(const json& root, const std::string& path) {
    for (const json& name : arrayOf(root, "extensionsRequired"))
        if (std::find(std::begin(kSupportedExtensions), std::end(kSupportedExtensions),
                      name.get<std::string>()) == std::end(kSupportedExtensions))
            throw Error(ErrorKind::Input,
                        path + ": the file requires extension " + quotedInput(name.get<std::string>()) +
                            ", which is not read (only KHR_lights_punctual, "
                            "KHR_materials_emissive_strength and KHR_mesh_quantization are)");
}

// The glTF version an asset states, "<major>.<minor>" (glTF 2.0, "asset"), as two numbers; none for
// another form.
std::optional<std::pair<int, int>> gltfVersion(const std::string& text) {
    const size_t dot = text.find('.');
    const auto digits = [](std::string_view part) {
        return !part.empty() && part.size() < 9 &&
               std::all_of(part.begin(), part.end(), [](char c) { return c >= '0' && c <= '9'; });
    };
    if (dot == std::string::npos || !digits(std::string_view(text).substr(0, dot)) ||
        !digits(std::string_view(text).substr(dot + 1)))
        return std::nullopt;
    return std::pair{std::stoi(text.substr(0, dot)), std::stoi(text.substr(dot + 1))};
}

// This reader reads glTF 2.0: asset.version must name glTF 2, and asset.minVersion, where an asset
// needs more than 2.0 to be read right, no more than 2.0.
void checkVersion(const json& root, const std::string& path) {
    const auto asset = root.find("asset");
    if (asset == root.end() || !asset->contains("version"))
        throw Error(ErrorKind::Input,
                    path + ": no asset.version, which every glTF file states; not a glTF file");
    for (const char* field : {"version", "minVersion"}) {
        if (!asset->contains(field)) continue;
        const std::string text = (*asset)[field].get<std::string>();
        const auto version = gltfVersion(text);
        if (!version)
            throw Error(ErrorKind::Input,
                        path + ": asset." + field + " is " + quotedInput(text) + ", not <major>.<minor>");
        const bool readable = version->first == 2 && (field[0] == 'v' || version->second == 0);
        if (!readable)
            throw Error(ErrorKind::Input,
                        path + ": asset." + field + " is " + text + "; this reader reads glTF 2.0");
    }
}

// A node's matrix is affine (glTF 2.0, "Transformations": translation, rotation and scale): its last
// row, elements 3, 7, 11 and 15 of the column-major array, is 0, 0, 0, 1, to float rounding (1e-6).
// Another would be read as if it were (the projective part dropped).
void checkNodeMatrices(const json& root, const std::string& path) {
    const json& nodes = arrayOf(root, "nodes");
    for (size_t n = 0; n < nodes.size(); ++n) {
        const auto matrix = nodes[n].find("matrix");
        if (matrix == nodes[n].end()) continue;
        const double row[4] = {(*matrix)[3], (*matrix)[7], (*matrix)[11], (*matrix)[15]};
        constexpr double kRounding = 1e-6;
        if (std::abs(row[0]) <= kRounding && std::abs(row[1]) <= kRounding && std::abs(row[2]) <= kRounding &&
            std::abs(row[3] - 1.0) <= kRounding)
            continue;
        throw Error(ErrorKind::Input, path + ": nodes[" + std::to_string(n) + "].matrix ends in the row " +
                                          shortNumber(row[0]) + ", " + shortNumber(row[1]) + ", " +
                                          shortNumber(row[2]) + ", " + shortNumber(row[3]) +
                                          ", not 0, 0, 0, 1: glTF's node matrices are affine");
    }
}

// The parser's problem with the bytes it quotes kept printable (a binary file is not text) and
// short (it quotes the whole token it stopped in, a string of megabytes perhaps).
std::string parseProblem(const json::exception& error) {
    std::string text = clipped(jsonProblem(error), 2 * kMaxQuotedBytes);
    for (char& c : text)
        if (static_cast<unsigned char>(c) >= 0x7f) c = '?';
    return text;
}

} // namespace

void checkGltfJson(std::string_view text, const std::string& path) {
    json root;
    try {
        root = parseBoundedJson(text, kMaxGltfJsonDepth);
    } catch (const json::exception& error) {
        throw Error(ErrorKind::Input, path + ": not valid JSON (" + parseProblem(error) + ")");
    } catch (const JsonTooDeep&) {
        throw Error(ErrorKind::Input, path + ": JSON nested deeper than " +
                                          std::to_string(kMaxGltfJsonDepth) + " levels; not a glTF file");
    }
    if (!root.is_object())
        throw Error(ErrorKind::Input, path + ": the top level must be a JSON object, not " +
                                          std::string(typeName(root)) + "; not a glTF file");
    Checker checker(path);
    checker.checkObject(root, kRoot, "");
    checkVersion(root, path);
    checkNodeMatrices(root, path);
    checkRequiredExtensions(root, path);
    checkBufferViews(root, checker);
    checkAccessors(root, checker);
}

} // namespace shprobe
