// Mesh primitives read from tinygltf's model: accessors (the glTF 2.0 specification, 3.6 "Binary
// Data Storage"), primitive modes (3.7.2.1) and their placement by the node's transform.
#include "scene/gltf_geometry.h"

#include "common/error.h"
#include "scene/gltf_limits.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <limits>
#include <span>
#include <tiny_gltf.h>
#include <type_traits>

namespace shprobe {

namespace {

// glTF's binary data is little-endian; values are copied as they are stored.
static_assert(std::endian::native == std::endian::little, "glTF buffers are read as little-endian");

// A triangle of no area is never hit by a ray: any unit vector keeps World's normals unit.
constexpr glm::vec3 kDegenerateNormal{0.0f, 0.0f, 1.0f};

[[noreturn]] void fail(const GltfGeometrySource& source, const std::string& where,
                       const std::string& problem) {
    throw Error(ErrorKind::Input, source.path + ": " + where + ": " + problem);
}

std::string primitiveName(int mesh, int primitive) {
    return "meshes[" + std::to_string(mesh) + "].primitives[" + std::to_string(primitive) + "]";
}

// ---- Accessor formats ---------------------------------------------------------------------------

constexpr int kByte = TINYGLTF_COMPONENT_TYPE_BYTE, kUbyte = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
              kShort = TINYGLTF_COMPONENT_TYPE_SHORT, kUshort = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
              kUint = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT;
constexpr int kVec2 = TINYGLTF_TYPE_VEC2, kVec3 = TINYGLTF_TYPE_VEC3, kScalar = TINYGLTF_TYPE_SCALAR;

struct Format {
    int type;
    int componentType;
    bool normalized;
};

// Bytes of a component; 0 for the types glTF does not have.
size_t componentSize(int componentType) {
    return componentType == kByte || componentType == kUbyte     ? 1
           : componentType == kShort || componentType == kUshort ? 2
           : componentType == kUint || componentType == kFloat   ? 4
                                                                 : 0;
}

// Components of the vector types; matrices (padded columns) are never read here.
int componentCount(int type) {
    return type == kScalar ? 1 : type >= kVec2 && type <= TINYGLTF_TYPE_VEC4 ? type : 0;
}

const char* componentName(int componentType) {
    switch (componentType) {
    case kByte:
        return "BYTE";
    case kUbyte:
        return "UNSIGNED_BYTE";
    case kShort:
        return "SHORT";
    case kUshort:
        return "UNSIGNED_SHORT";
    case kUint:
        return "UNSIGNED_INT";
    case kFloat:
        return "FLOAT";
    default:
        return "an unknown componentType";
    }
}

// "VEC3 of normalized SHORT", in the specification's names.
std::string formatText(const Format& format) {
    const int count = componentCount(format.type);
    const std::string type = count == 1 ? "SCALAR" : count > 1 ? "VEC" + std::to_string(count) : "MAT";
    return type + " of " + (format.normalized ? "normalized " : "") + componentName(format.componentType);
}

// The formats glTF 2.0 allows (3.7.2.1, "Meshes overview"), then those KHR_mesh_quantization adds.
constexpr Format kPositionFormats[] = {
    {kVec3, kFloat, false}, {kVec3, kByte, false},   {kVec3, kByte, true},
    {kVec3, kUbyte, false}, {kVec3, kUbyte, true},   {kVec3, kShort, false},
    {kVec3, kShort, true},  {kVec3, kUshort, false}, {kVec3, kUshort, true}};
constexpr Format kNormalFormats[] = {{kVec3, kFloat, false}, {kVec3, kByte, true}, {kVec3, kShort, true}};
constexpr Format kUvFormats[] = {{kVec2, kFloat, false}, {kVec2, kUbyte, true}, {kVec2, kUshort, true},
                                 {kVec2, kByte, false},  {kVec2, kByte, true},  {kVec2, kUbyte, false},
                                 {kVec2, kShort, false}, {kVec2, kShort, true}, {kVec2, kUshort, false}};
constexpr Format kIndexFormats[] = {
    {kScalar, kUbyte, false}, {kScalar, kUshort, false}, {kScalar, kUint, false}};

struct AllowedFormats {
    std::span<const Format> formats;
    size_t core; // the first `core` are glTF 2.0's own
};
constexpr AllowedFormats kPosition{kPositionFormats, 1};
constexpr AllowedFormats kNormal{kNormalFormats, 1};
constexpr AllowedFormats kUv{kUvFormats, 3};
constexpr AllowedFormats kIndex{kIndexFormats, 3};

bool sameFormat(const Format& a, const Format& b) {
    return a.type == b.type && a.componentType == b.componentType && a.normalized == b.normalized;
}

// ---- Accessor bytes -----------------------------------------------------------------------------

// The elements of an accessor or of a sparse part: `count` of them, `stride` bytes apart from
// `first` on, or zeros where `first` is null (an accessor without a buffer view).
struct Elements {
    const unsigned char* first = nullptr;
    size_t stride = 0;
    size_t count = 0;
};

struct AccessorReader {
    const GltfGeometrySource& source;
    const std::string& where; // "meshes[0].primitives[0].attributes.POSITION"
    int index;

    const tinygltf::Accessor& accessor() const { return source.model.accessors[size_t(index)]; }
    std::string name() const { return "accessor " + std::to_string(index); }

    [[noreturn]] void fail(const std::string& problem) const {
        shprobe::fail(source, where, name() + " " + problem);
    }

    // Bytes [offset, offset + length) of a buffer view, checked against its buffer.
    const unsigned char* viewBytes(int view, size_t offset, uint64_t length, const char* part) const {
        const tinygltf::Model& model = source.model;
        if (view < 0 || size_t(view) >= model.bufferViews.size())
            fail(std::string(part) + "names buffer view " + std::to_string(view) + ", but the file has " +
                 std::to_string(model.bufferViews.size()));
        const tinygltf::BufferView& bufferView = model.bufferViews[size_t(view)];
        if (bufferView.buffer < 0 || size_t(bufferView.buffer) >= model.buffers.size())
            fail(std::string(part) + "uses buffer view " + std::to_string(view) + ", whose buffer " +
                 std::to_string(bufferView.buffer) + " does not exist");
        const std::vector<unsigned char>& data = model.buffers[size_t(bufferView.buffer)].data;
        if (bufferView.byteOffset > data.size() ||
            bufferView.byteLength > data.size() - bufferView.byteOffset)
            fail(std::string(part) + "uses buffer view " + std::to_string(view) +
                 ", which reaches past its buffer");
        if (offset > bufferView.byteLength || length > bufferView.byteLength - offset)
            fail(std::string(part) + "reaches byte " + std::to_string(uint64_t(offset) + length) +
                 " of buffer view " + std::to_string(view) + ", which has " +
                 std::to_string(bufferView.byteLength) + " bytes");
        return data.data() + bufferView.byteOffset + offset;
    }

    // The accessor's own elements, all within its buffer view.
    Elements elements(size_t elementSize) const {
        const tinygltf::Accessor& a = accessor();
        Elements elements{nullptr, elementSize, a.count};
        if (a.bufferView < 0 || a.count == 0) return elements;
        const size_t byteStride = source.model.bufferViews.size() > size_t(a.bufferView)
                                      ? source.model.bufferViews[size_t(a.bufferView)].byteStride
                                      : 0;
        if (byteStride != 0 && (byteStride < elementSize || byteStride > size_t(kMaxGltfByteStride)))
            fail("has a byte stride of " + std::to_string(byteStride) + ", but its elements take " +
                 std::to_string(elementSize) + " bytes (and glTF's stride is at most 252)");
        if (byteStride != 0) elements.stride = byteStride;
        // count < 2^53 and stride <= 252: the span fits in 64 bits.
        const uint64_t span = uint64_t(elements.stride) * (a.count - 1) + elementSize;
        elements.first = viewBytes(a.bufferView, a.byteOffset, span, "");
        return elements;
    }

    // The sparse part's indices (tightly packed unsigned integers) and values (tightly packed elements).
    std::pair<Elements, Elements> sparseElements(size_t elementSize) const {
        const auto& sparse = accessor().sparse;
        if (sparse.count < 1 || size_t(sparse.count) > accessor().count)
            fail("has " + std::to_string(sparse.count) + " sparse values for its " +
                 std::to_string(accessor().count) + " elements");
        const int indexType = sparse.indices.componentType;
        if (indexType != kUbyte && indexType != kUshort && indexType != kUint)
            fail("has sparse indices of componentType " + std::to_string(indexType) +
                 "; they must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT");
        const size_t count = size_t(sparse.count), indexSize = componentSize(indexType);
        Elements indices{viewBytes(sparse.indices.bufferView, size_t(sparse.indices.byteOffset),
                                   count * indexSize, "(sparse indices) "),
                         indexSize, count};
        Elements values{viewBytes(sparse.values.bufferView, size_t(sparse.values.byteOffset),
                                  count * elementSize, "(sparse values) "),
                        elementSize, count};
        return {indices, values};
    }
};

template <typename Stored, typename Out> Out convertComponent(Stored stored, bool normalized) {
    if constexpr (std::is_integral_v<Out>) {
        return Out(stored); // indices: unsigned integers only reach here
    } else if constexpr (std::is_floating_point_v<Stored>) {
        return Out(stored);
    } else if (!normalized) {
        return Out(stored);
    } else if constexpr (std::is_signed_v<Stored>) { // 3.11: max(c / (2^(b-1) - 1), -1)
        return std::max(Out(stored) / Out(std::numeric_limits<Stored>::max()), Out(-1));
    } else { // c / (2^b - 1)
        return Out(stored) / Out(std::numeric_limits<Stored>::max());
    }
}

template <typename Stored, typename Out>
void convertElements(const Elements& elements, int components, bool normalized, Out* out) {
    if (!elements.first) return; // zeros, as `out` already holds
    for (size_t i = 0; i < elements.count; ++i) {
        const unsigned char* element = elements.first + i * elements.stride;
        for (int c = 0; c < components; ++c) {
            Stored stored;
            std::memcpy(&stored, element + size_t(c) * sizeof(Stored), sizeof(Stored));
            out[i * size_t(components) + size_t(c)] = convertComponent<Stored, Out>(stored, normalized);
        }
    }
}

template <typename Out> void convert(const Elements& elements, const Format& format, Out* out) {
    const int components = componentCount(format.type);
    switch (format.componentType) {
    case kByte:
        return convertElements<int8_t>(elements, components, format.normalized, out);
    case kUbyte:
        return convertElements<uint8_t>(elements, components, format.normalized, out);
    case kShort:
        return convertElements<int16_t>(elements, components, format.normalized, out);
    case kUshort:
        return convertElements<uint16_t>(elements, components, format.normalized, out);
    case kUint:
        return convertElements<uint32_t>(elements, components, format.normalized, out);
    default:
        return convertElements<float>(elements, components, format.normalized, out);
    }
}

// The accessor's values, components of each element in turn, converted to Out (float, or
// uint32_t for indices), sparse values substituted. Its format must be one of `allowed`.
template <typename Out>
std::vector<Out> readAccessor(const AccessorReader& reader, const AllowedFormats& allowed) {
    const tinygltf::Accessor& accessor = reader.accessor();
    const Format format{accessor.type, accessor.componentType, accessor.normalized};
    const size_t usable = reader.source.quantized ? allowed.formats.size() : allowed.core;
    const auto formats = allowed.formats.first(usable);
    if (std::none_of(formats.begin(), formats.end(),
                     [&](const Format& f) { return sameFormat(f, format); })) {
        std::string expected;
        for (const Format& f : formats)
            expected += (expected.empty() ? "" : ", ") + formatText(f);
        reader.fail("is " + formatText(format) + "; it must be " + (usable > 1 ? "one of " : "") + expected);
    }
    const size_t components = size_t(componentCount(format.type));
    const size_t elementSize = componentSize(format.componentType) * components;
    std::vector<Out> values(accessor.count * components);
    convert(reader.elements(elementSize), format, values.data());
    if (!accessor.sparse.isSparse) return values;
    const auto [indices, sparseValues] = reader.sparseElements(elementSize);
    std::vector<uint32_t> at(indices.count);
    convert(indices, Format{kScalar, accessor.sparse.indices.componentType, false}, at.data());
    std::vector<Out> substitutes(indices.count * components);
    convert(sparseValues, format, substitutes.data());
    for (size_t i = 0; i < at.size(); ++i) {
        if (at[i] >= accessor.count)
            reader.fail("has sparse index " + std::to_string(at[i]) + ", past its " +
                        std::to_string(accessor.count) + " elements");
        // glTF 2.0 3.6.2.3: the indices strictly increase, so no element is given twice.
        if (i > 0 && at[i] <= at[i - 1])
            reader.fail("has sparse index " + std::to_string(at[i]) + " after " + std::to_string(at[i - 1]) +
                        "; sparse indices must strictly increase");
        std::copy_n(substitutes.begin() + ptrdiff_t(i * components), components,
                    values.begin() + ptrdiff_t(at[i] * components));
    }
    return values;
}

template <typename Vector>
std::vector<Vector> readVectors(const AccessorReader& reader, const AllowedFormats& allowed) {
    static_assert(sizeof(Vector) == Vector::length() * sizeof(float), "copied from packed floats");
    std::vector<float> values = readAccessor<float>(reader, allowed);
    const size_t bad =
        size_t(std::find_if(values.begin(), values.end(), [](float v) { return !std::isfinite(v); }) -
               values.begin());
    if (bad < values.size())
        reader.fail("holds a value that is not finite (" + std::to_string(values[bad]) + " in element " +
                    std::to_string(bad / Vector::length()) + ")");
    std::vector<Vector> vectors(values.size() / Vector::length());
    if (!values.empty()) // an empty vector's data() may be null, which memcpy may not be given
        std::memcpy(vectors.data(), values.data(), values.size() * sizeof(float));
    return vectors;
}

// ---- Primitives ---------------------------------------------------------------------------------

// The accessor named by attribute `name`, or -1 when the primitive has none.
int attributeAccessor(const tinygltf::Primitive& primitive, const char* name) {
    auto found = primitive.attributes.find(name);
    return found == primitive.attributes.end() ? -1 : found->second;
}

// An accessor index that exists, with the reader of its values.
AccessorReader checkedAccessor(const GltfGeometrySource& source, int index, const std::string& where) {
    if (index < 0 || size_t(index) >= source.model.accessors.size())
        fail(source, where,
             "accessor " + std::to_string(index) + " does not exist (the file has " +
                 std::to_string(source.model.accessors.size()) + ")");
    return {source, where, index};
}

// Vertex indices of a triangle list, strip or fan as a list (3.7.2.1: strips alternate their winding).
std::vector<uint32_t> triangleList(const std::vector<uint32_t>& drawn, int mode) {
    if (mode == TINYGLTF_MODE_TRIANGLES) return drawn;
    std::vector<uint32_t> list;
    for (size_t i = 0; i + 2 < drawn.size(); ++i) {
        if (mode == TINYGLTF_MODE_TRIANGLE_FAN)
            list.insert(list.end(), {drawn[i + 1], drawn[i + 2], drawn[0]});
        else if (i % 2 == 0)
            list.insert(list.end(), {drawn[i], drawn[i + 1], drawn[i + 2]});
        else
            list.insert(list.end(), {drawn[i + 1], drawn[i], drawn[i + 2]});
    }
    return list;
}

} // namespace

PrimitiveShape primitiveShape(const GltfGeometrySource& source, int mesh, int primitiveIndex) {
    const tinygltf::Primitive& primitive =
        source.model.meshes[size_t(mesh)].primitives[size_t(primitiveIndex)];
    const std::string where = primitiveName(mesh, primitiveIndex);
    if (primitive.mode < TINYGLTF_MODE_POINTS || primitive.mode > TINYGLTF_MODE_TRIANGLE_FAN)
        fail(source, where,
             "mode " + std::to_string(primitive.mode) + " is not a glTF primitive mode (0 to 6)");
    if (primitive.mode < TINYGLTF_MODE_TRIANGLES) return {true, 0, 0};
    const int position = attributeAccessor(primitive, "POSITION");
    if (position < 0) fail(source, where, "the primitive has no POSITION attribute");
    const size_t vertices =
        checkedAccessor(source, position, where + ".attributes.POSITION").accessor().count;
    const bool indexed = primitive.indices >= 0;
    const AccessorReader drawn = checkedAccessor(source, indexed ? primitive.indices : position,
                                                 where + (indexed ? ".indices" : ".attributes.POSITION"));
    const size_t count = drawn.accessor().count;
    if (primitive.mode == TINYGLTF_MODE_TRIANGLES && count % 3 != 0)
        fail(source, where,
             std::to_string(count) + (indexed ? " indices" : " vertices") +
                 " drawn as a triangle list, which is not a multiple of 3: the last triangle is incomplete");
    return {false,
            primitive.mode == TINYGLTF_MODE_TRIANGLES ? count / 3
            : count < 3                               ? 0
                                                      : count - 2,
            vertices};
}

PrimitiveGeometry readPrimitive(const GltfGeometrySource& source, int mesh, int primitiveIndex) {
    const tinygltf::Primitive& primitive =
        source.model.meshes[size_t(mesh)].primitives[size_t(primitiveIndex)];
    const std::string where = primitiveName(mesh, primitiveIndex);
    PrimitiveGeometry geometry;
    const std::string positionWhere = where + ".attributes.POSITION";
    geometry.positions = readVectors<glm::vec3>(
        checkedAccessor(source, attributeAccessor(primitive, "POSITION"), positionWhere), kPosition);
    const size_t vertices = geometry.positions.size();
    auto readAttribute = [&](const char* name, const AllowedFormats& allowed, auto& out) {
        const int index = attributeAccessor(primitive, name);
        if (index < 0) return;
        const std::string at = where + ".attributes." + name;
        const AccessorReader reader = checkedAccessor(source, index, at);
        if (reader.accessor().count != vertices)
            reader.fail("has " + std::to_string(reader.accessor().count) + " elements, but POSITION has " +
                        std::to_string(vertices));
        out = readVectors<typename std::decay_t<decltype(out)>::value_type>(reader, allowed);
    };
    readAttribute("NORMAL", kNormal, geometry.normals);
    readAttribute("TEXCOORD_0", kUv, geometry.uvs);

    std::vector<uint32_t> drawn;
    if (primitive.indices >= 0) {
        const std::string at = where + ".indices";
        drawn = readAccessor<uint32_t>(checkedAccessor(source, primitive.indices, at), kIndex);
        for (size_t i = 0; i < drawn.size(); ++i)
            if (drawn[i] >= vertices)
                fail(source, at,
                     "index " + std::to_string(drawn[i]) + " (element " + std::to_string(i) +
                         ") is out of range: the primitive has " + std::to_string(vertices) + " vertices");
    } else {
        drawn.resize(vertices);
        for (size_t i = 0; i < vertices; ++i)
            drawn[i] = uint32_t(i);
    }
    geometry.indices = triangleList(drawn, primitive.mode);
    return geometry;
}

namespace {

// Maps normals as the inverse transpose of the linear part does, up to a positive factor: the
// cofactor matrix (columns b x c, c x a, a x b of the columns a, b, c) times the determinant's
// sign, which exists for singular transforms too.
glm::dmat3 normalMatrix(const glm::dmat3& linear) {
    const glm::dmat3 cofactor(glm::cross(linear[1], linear[2]), glm::cross(linear[2], linear[0]),
                              glm::cross(linear[0], linear[1]));
    return glm::determinant(linear) < 0.0 ? -cofactor : cofactor;
}

glm::vec3 unitOr(const glm::dvec3& v, const glm::vec3& fallback) {
    const double length = glm::length(v);
    return length > 0.0 && std::isfinite(length) ? glm::vec3(v / length) : fallback;
}

// Twice the area times the unit normal of a triangle, counter-clockwise seen from its front.
glm::dvec3 faceNormal(const World& world, uint32_t a, uint32_t b, uint32_t c) {
    const glm::dvec3 pa(world.positions[a]);
    return glm::cross(glm::dvec3(world.positions[b]) - pa, glm::dvec3(world.positions[c]) - pa);
}

// The vertices of no normal (zero, or zero once transformed) get the area-weighted mean of the face
// normals of their triangles, from `firstIndex` on.
void repairNormals(World& world, const std::vector<bool>& missing, size_t firstVertex, size_t firstIndex) {
    std::vector<glm::dvec3> sums(missing.size(), glm::dvec3(0.0));
    for (size_t i = firstIndex; i < world.indices.size(); i += 3) {
        const uint32_t* t = &world.indices[i];
        const glm::dvec3 normal = faceNormal(world, t[0], t[1], t[2]);
        for (int k = 0; k < 3; ++k)
            if (missing[t[k] - firstVertex]) sums[t[k] - firstVertex] += normal;
    }
    for (size_t v = 0; v < missing.size(); ++v)
        if (missing[v]) world.normals[firstVertex + v] = unitOr(sums[v], kDegenerateNormal);
}

} // namespace

void appendPrimitive(World& world, const PrimitiveGeometry& geometry, const glm::dmat4& transform,
                     uint32_t material, const std::string& where) {
    const glm::dmat3 linear(transform);
    const glm::dmat3 normals = normalMatrix(linear);
    const bool flip = glm::determinant(linear) < 0.0;
    const bool flat = geometry.normals.empty();
    const size_t firstVertex = world.positions.size(), firstIndex = world.indices.size();
    auto place = [&](uint32_t v) {
        const glm::dvec3 p = glm::dvec3(transform * glm::dvec4(glm::dvec3(geometry.positions[v]), 1.0));
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            throw Error(ErrorKind::Input,
                        where + ": the node's transform takes vertex " + std::to_string(v) + " to infinity");
        world.positions.push_back(glm::vec3(p));
        world.uvs.push_back(geometry.uvs.empty() ? glm::vec2(0.0f) : geometry.uvs[v]);
    };
    std::vector<bool> missing;
    if (!flat) {
        for (uint32_t v = 0; v < geometry.positions.size(); ++v) {
            place(v);
            const glm::vec3 n = unitOr(normals * glm::dvec3(geometry.normals[v]), glm::vec3(0.0f));
            missing.push_back(n == glm::vec3(0.0f));
            world.normals.push_back(n);
        }
    }
    for (size_t i = 0; i < geometry.indices.size(); i += 3) {
        uint32_t t[3] = {geometry.indices[i], geometry.indices[i + 1], geometry.indices[i + 2]};
        if (flip) std::swap(t[1], t[2]);
        if (flat) { // three vertices of its own, with the face's normal
            const uint32_t first = uint32_t(world.positions.size());
            for (uint32_t v : t)
                place(v);
            const glm::vec3 n = unitOr(faceNormal(world, first, first + 1, first + 2), kDegenerateNormal);
            world.normals.insert(world.normals.end(), {n, n, n});
            world.indices.insert(world.indices.end(), {first, first + 1, first + 2});
        } else {
            for (uint32_t v : t)
                world.indices.push_back(uint32_t(firstVertex + v));
        }
        world.triangleMaterials.push_back(material);
    }
    if (std::find(missing.begin(), missing.end(), true) != missing.end())
        repairNormals(world, missing, firstVertex, firstIndex);
}

} // namespace shprobe
