// The test scenes of scene_fixtures.h: glTF 2.0 written by hand (the specification's JSON and the
// .glb layout of its section 4.4), so that the reader is checked against an independent writer.
#include "scene_fixtures.h"

#include "scene/gltf_scene.h"
#include "scene/volume_sampling.h"

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <unistd.h>

namespace shprobe::testing {

namespace {

using nlohmann::json;

constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// RFC 4648 base64, for the data URI of a .gltf's buffer.
std::string base64(const std::string& bytes) {
    static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string text;
    for (size_t i = 0; i < bytes.size(); i += 3) {
        uint32_t group = uint32_t(uint8_t(bytes[i])) << 16;
        if (i + 1 < bytes.size()) group |= uint32_t(uint8_t(bytes[i + 1])) << 8;
        if (i + 2 < bytes.size()) group |= uint32_t(uint8_t(bytes[i + 2]));
        for (size_t k = 0; k < 4; ++k)
            text += i + k <= bytes.size() ? digits[(group >> (18 - 6 * k)) & 63] : '=';
    }
    return text;
}

// The buffer and its views and accessors, each view starting at a multiple of 4 bytes.
struct BufferBuilder {
    std::string bytes;
    json views = json::array();
    json accessors = json::array();

    int add(const void* data, size_t size, size_t count, const char* type, int componentType, int target) {
        bytes.resize((bytes.size() + 3) / 4 * 4, '\0');
        views.push_back(
            {{"buffer", 0}, {"byteOffset", bytes.size()}, {"byteLength", size}, {"target", target}});
        bytes.append(static_cast<const char*>(data), size);
        accessors.push_back({{"bufferView", views.size() - 1},
                             {"componentType", componentType},
                             {"count", count},
                             {"type", type}});
        return int(accessors.size() - 1);
    }

    int addVectors(const std::vector<glm::vec3>& values, bool bounds) {
        const int index = add(values.data(), values.size() * sizeof(glm::vec3), values.size(), "VEC3", kFloat,
                              kArrayBuffer);
        if (bounds && !values.empty()) { // POSITION must state its bounds
            glm::vec3 low = values[0], high = values[0];
            for (const glm::vec3& v : values) {
                low = glm::min(low, v);
                high = glm::max(high, v);
            }
            accessors[size_t(index)]["min"] = {low.x, low.y, low.z};
            accessors[size_t(index)]["max"] = {high.x, high.y, high.z};
        }
        return index;
    }
};

json primitiveJson(const FixtureMesh& mesh, BufferBuilder& buffer) {
    json primitive = {{"attributes", {{"POSITION", buffer.addVectors(mesh.positions, true)}}},
                      {"mode", mesh.mode}};
    if (!mesh.normals.empty()) primitive["attributes"]["NORMAL"] = buffer.addVectors(mesh.normals, false);
    if (!mesh.indices.empty())
        primitive["indices"] = buffer.add(mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t),
                                          mesh.indices.size(), "SCALAR", kUnsignedInt, kElementArrayBuffer);
    if (mesh.material >= 0) primitive["material"] = mesh.material;
    return primitive;
}

json materialJson(const FixtureMaterial& material) {
    json out = {{"pbrMetallicRoughness",
                 {{"baseColorFactor", {material.albedo.r, material.albedo.g, material.albedo.b, 1.0f}},
                  {"metallicFactor", 0.0f}}},
                {"doubleSided", material.doubleSided}};
    const float largest = std::max({material.emission.r, material.emission.g, material.emission.b});
    const glm::vec3 factor = largest > 1.0f ? material.emission / largest : material.emission;
    out["emissiveFactor"] = {factor.r, factor.g, factor.b};
    if (largest > 1.0f) out["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = largest;
    return out;
}

json nodeJson(const FixtureNode& node) {
    json out = json::object();
    if (node.mesh >= 0) out["mesh"] = node.mesh;
    if (node.light >= 0) out["extensions"]["KHR_lights_punctual"]["light"] = node.light;
    if (!node.children.empty()) out["children"] = node.children;
    if (node.matrix) {
        const float* m = glm::value_ptr(*node.matrix); // column-major, as glTF
        out["matrix"] = std::vector<float>(m, m + 16);
        return out;
    }
    out["translation"] = {node.translation.x, node.translation.y, node.translation.z};
    out["rotation"] = {node.rotation.x, node.rotation.y, node.rotation.z, node.rotation.w};
    out["scale"] = {node.scale.x, node.scale.y, node.scale.z};
    return out;
}

json lightJson(const FixtureLight& light) {
    json out = {{"type", light.type},
                {"color", {light.colour.r, light.colour.g, light.colour.b}},
                {"intensity", light.intensity}};
    if (light.type == "spot") out["spot"] = json::object(); // required for spots; its cone angles default
    return out;
}

// The document and its binary buffer.
std::pair<json, std::string> documentOf(const FixtureScene& scene) {
    BufferBuilder buffer;
    json document = {{"asset", {{"version", "2.0"}, {"generator", "shprobe test fixtures"}}},
                     {"scene", 0},
                     {"scenes", {{{"nodes", scene.roots}}}}};
    json meshes = json::array(), materials = json::array(), nodes = json::array(), lights = json::array();
    for (const FixtureMesh& mesh : scene.meshes)
        meshes.push_back({{"primitives", {primitiveJson(mesh, buffer)}}});
    for (const FixtureMaterial& material : scene.materials)
        materials.push_back(materialJson(material));
    for (const FixtureNode& node : scene.nodes)
        nodes.push_back(nodeJson(node));
    for (const FixtureLight& light : scene.lights)
        lights.push_back(lightJson(light));
    document["meshes"] = meshes;
    document["nodes"] = nodes;
    if (!materials.empty()) document["materials"] = materials;
    json used = json::array();
    if (!lights.empty()) {
        document["extensions"]["KHR_lights_punctual"]["lights"] = lights;
        used.push_back("KHR_lights_punctual");
    }
    if (document.dump().find("KHR_materials_emissive_strength") != std::string::npos)
        used.push_back("KHR_materials_emissive_strength");
    if (!used.empty()) document["extensionsUsed"] = used;
    document["bufferViews"] = buffer.views;
    document["accessors"] = buffer.accessors;
    document["buffers"] = {{{"byteLength", buffer.bytes.size()}}};
    return {document, buffer.bytes};
}

void appendLittleEndian32(std::string& out, uint32_t value) {
    char bytes[4];
    std::memcpy(bytes, &value, 4); // the tests run on little-endian machines, as glTF's data is
    out.append(bytes, 4);
}

} // namespace

// Section 4.4: header (magic, version 2, length), the JSON chunk padded with spaces, the BIN chunk
// padded with zeros.
std::string glbOf(const Glb& glb) {
    std::string text = glb.json.dump(), bin = glb.bin;
    text.resize((text.size() + 3) / 4 * 4, ' ');
    bin.resize((bin.size() + 3) / 4 * 4, '\0');
    std::string file = "glTF";
    appendLittleEndian32(file, 2);
    appendLittleEndian32(file, uint32_t(12 + 8 + text.size() + 8 + bin.size()));
    appendLittleEndian32(file, uint32_t(text.size()));
    file += "JSON" + text;
    appendLittleEndian32(file, uint32_t(bin.size()));
    file += std::string("BIN\0", 4) + bin;
    return file;
}

Glb readGlb(const std::string& bytes) {
    auto word = [&](size_t at) {
        uint32_t w;
        std::memcpy(&w, bytes.data() + at, 4);
        return w;
    };
    const uint32_t jsonLength = word(12);
    Glb glb{json::parse(bytes.substr(20, jsonLength)), {}};
    const size_t binAt = 20 + jsonLength;
    if (binAt + 8 <= bytes.size()) glb.bin = bytes.substr(binAt + 8, word(binAt));
    return glb;
}

void writeGltf(const std::string& path, const FixtureScene& scene, GltfContainer container) {
    if (container == GltfContainer::Gltf) return writeText(path, gltfText(scene));
    const auto [document, bin] = documentOf(scene);
    writeText(path, glbOf({document, bin}));
}

std::string gltfText(const FixtureScene& scene) {
    auto [document, bin] = documentOf(scene);
    document["buffers"][0]["uri"] = dataUri(bin);
    return document.dump(2);
}

std::string dataUri(const std::string& bytes) {
    return "data:application/octet-stream;base64," + base64(bytes);
}

void writeText(const std::string& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(text.data(), std::streamsize(text.size()));
    if (!out) throw std::runtime_error("cannot write " + path);
}

glm::quat rotationTowards(const glm::vec3& towardsLight) {
    const glm::vec3 z(0.0f, 0.0f, 1.0f), to = glm::normalize(towardsLight);
    const float cosine = glm::dot(z, to);
    if (cosine < -0.999999f) return glm::angleAxis(glm::pi<float>(), glm::vec3(1.0f, 0.0f, 0.0f));
    return glm::angleAxis(std::acos(std::min(cosine, 1.0f)), cosine > 0.999999f
                                                                 ? glm::vec3(1.0f, 0.0f, 0.0f)
                                                                 : glm::normalize(glm::cross(z, to)));
}

void addQuad(FixtureMesh& mesh, const glm::vec3& centre, const glm::vec3& u, const glm::vec3& v) {
    const uint32_t first = uint32_t(mesh.positions.size());
    const glm::vec3 normal = glm::normalize(glm::cross(u, v));
    for (const glm::vec3& corner : {centre - u - v, centre + u - v, centre + u + v, centre - u + v}) {
        mesh.positions.push_back(corner);
        mesh.normals.push_back(normal);
    }
    mesh.indices.insert(mesh.indices.end(), {first, first + 1, first + 2, first, first + 2, first + 3});
}

void addBox(FixtureMesh& mesh, const glm::vec3& centre, const glm::vec3& size, bool inward) {
    const glm::vec3 half = size * 0.5f;
    for (int axis = 0; axis < 3; ++axis)
        for (float side : {-1.0f, 1.0f}) {
            glm::vec3 normal(0.0f), u(0.0f), v(0.0f);
            normal[axis] = side;
            u[(axis + 1) % 3] = half[(axis + 1) % 3];
            v[(axis + 2) % 3] = half[(axis + 2) % 3];
            // cross(u, v) points along +axis: swap them where the front must face the other way.
            const bool outwardIsPositive = side > 0.0f;
            if (outwardIsPositive == inward) std::swap(u, v);
            addQuad(mesh, centre + normal * half[axis], u, v);
        }
}

FixtureScene cornellBoxScene(const CornellBoxOptions& options) {
    const float s = options.size, h = s * 0.5f;
    FixtureScene scene;
    scene.materials = {
        {kCornellWhite}, {kCornellRed}, {kCornellGreen}, {glm::vec3(0.0f), options.lightEmission}};
    FixtureMesh white, red, green, light;
    white.material = 0, red.material = 1, green.material = 2, light.material = 3;
    const glm::vec3 x(h, 0.0f, 0.0f), y(0.0f, h, 0.0f), z(0.0f, 0.0f, h);
    addQuad(white, {0.0f, 0.0f, 0.0f}, z, x);               // floor, facing +y
    addQuad(white, {0.0f, s, 0.0f}, x, z);                  // ceiling, facing -y
    addQuad(white, {0.0f, h, -h}, x, y);                    // back wall, facing +z
    if (options.closed) addQuad(white, {0.0f, h, h}, y, x); // front wall, facing -z
    addQuad(red, {-h, h, 0.0f}, y, z);                      // left wall, facing +x
    addQuad(green, {h, h, 0.0f}, z, y);                     // right wall, facing -x
    const float l = options.lightSide * 0.5f;
    addQuad(light, {0.0f, s * 0.999f, 0.0f}, glm::vec3(l, 0.0f, 0.0f), glm::vec3(0.0f, 0.0f, l)); // facing -y
    if (options.innerBoxes) { // the classic blocks, scaled from the 5.5 m original, axis-aligned
        addBox(white, {0.19f * s, 0.15f * s, 0.12f * s}, glm::vec3(0.3f * s), false);
        addBox(white, {-0.17f * s, 0.3f * s, -0.15f * s}, {0.3f * s, 0.6f * s, 0.3f * s}, false);
    }
    scene.meshes = {white, red, green, light};
    for (int mesh = 0; mesh < 4; ++mesh) {
        scene.nodes.push_back({.mesh = mesh});
        scene.roots.push_back(mesh);
    }
    if (options.sun) {
        scene.lights.push_back({"directional", options.sun->colour, options.sun->intensity});
        scene.nodes.push_back({.light = 0, .rotation = rotationTowards(options.sun->towardsLight)});
        scene.roots.push_back(int(scene.nodes.size() - 1));
    }
    return scene;
}

void writeCornellBoxGltf(const std::string& path, const CornellBoxOptions& options) {
    writeGltf(path, cornellBoxScene(options), options.container);
}

World loadFixtureWorld(const FixtureScene& scene) {
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("shprobe_fixture_" + std::to_string(getpid()) + ".glb");
    writeGltf(path.string(), scene, GltfContainer::Glb);
    World world = loadGltfScene(path.string());
    std::filesystem::remove(path);
    return world;
}

World loadCornellBoxWorld(const CornellBoxOptions& options) {
    return loadFixtureWorld(cornellBoxScene(options));
}

World furnaceWorld() {
    World furnace = loadCornellBoxWorld({.closed = true});
    for (SceneMaterial& material : furnace.materials) { // the light's back too
        material.albedo = glm::vec3(0.5f);
        material.emission = glm::vec3(1.0f);
        material.doubleSided = true;
    }
    return furnace;
}

World furnaceBesideAFarGround() {
    World world = furnaceWorld();
    for (const glm::vec3& p : {glm::vec3(-1e5f, -100.0f, -1e5f), glm::vec3(0.0f, -100.0f, 1e5f),
                               glm::vec3(1e5f, -100.0f, -1e5f)}) {
        world.indices.push_back(uint32_t(world.positions.size()));
        world.positions.push_back(p);
        world.normals.push_back(glm::vec3(0.0f, 1.0f, 0.0f));
        world.uvs.push_back(glm::vec2(0.0f));
        world.boundsMin = glm::min(world.boundsMin, p);
        world.boundsMax = glm::max(world.boundsMax, p);
    }
    world.triangleMaterials.push_back(uint32_t(world.materials.size()));
    world.materials.push_back(SceneMaterial{.albedo = glm::vec3(0.0f)}); // black, one-sided
    return world;
}

const World& engineWorld(const std::string& modelsFolder) {
    static const World world =
        loadGltfScene(modelsFolder + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
    return world;
}

const World& openCornellBoxWithBlocks() {
    static const World world = loadCornellBoxWorld({.innerBoxes = true});
    return world;
}

FixtureScene twoRoomsScene() {
    FixtureMesh mesh;
    mesh.material = 0;
    addQuad(mesh, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, {2.0f, 0.0f, 0.0f});   // floor
    addQuad(mesh, {0.0f, 1.0f, -1.0f}, {2.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f});  // back
    addQuad(mesh, {0.0f, 1.0f, 1.0f}, {0.0f, 1.0f, 0.0f}, {2.0f, 0.0f, 0.0f});   // front
    addQuad(mesh, {-2.0f, 1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f});  // left
    addQuad(mesh, {2.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f});   // right
    addQuad(mesh, {-0.01f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f}); // the wall, lit side
    addQuad(mesh, {0.01f, 1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f});  // the wall, closed side
    addQuad(mesh, {1.0f, 2.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f});   // closed room's ceiling
    // The lit room's ceiling around a 0.5 m square opening centred above (-1, 0).
    addQuad(mesh, {-1.625f, 2.0f, 0.0f}, {0.375f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f});
    addQuad(mesh, {-0.375f, 2.0f, 0.0f}, {0.375f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f});
    addQuad(mesh, {-1.0f, 2.0f, -0.625f}, {0.25f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.375f});
    addQuad(mesh, {-1.0f, 2.0f, 0.625f}, {0.25f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.375f});
    FixtureScene scene;
    scene.meshes = {mesh};
    scene.materials = {{glm::vec3(0.7f)}};
    scene.nodes = {
        FixtureNode{.mesh = 0},
        FixtureNode{.light = 0, .rotation = rotationTowards(glm::normalize(glm::vec3(-0.2f, 1.0f, 0.1f)))}};
    scene.lights = {FixtureLight{.intensity = 3.0f}};
    scene.roots = {0, 1};
    return scene;
}

double twoRoomsIrradiance(const ProbeVolume& volume, double x0, double x1) {
    double sum = 0.0;
    int count = 0;
    for (int a = 0; a < 16; ++a) {
        for (int b = 0; b < 16; ++b) {
            const double u = (a + 0.5) / 16.0, v = (b + 0.5) / 16.0;
            const double x = x0 + (x1 - x0) * u;
            const std::array<std::pair<glm::dvec3, glm::dvec3>, 3> points{{
                {{x, 0.01, -1.0 + 2.0 * v}, {0.0, 1.0, 0.0}},  // floor
                {{x, 2.0 * v, -0.99}, {0.0, 0.0, 1.0}},        // back wall
                {{x, 1.99, -1.0 + 2.0 * v}, {0.0, -1.0, 0.0}}, // ceiling
            }};
            for (const auto& point : points) {
                sum += sampleVolumeIrradiance(volume, point.first, point.second).g;
                ++count;
            }
        }
    }
    return sum / count;
}

FixtureScene boxScene(const BoxOptions& options) {
    FixtureScene scene;
    scene.materials = {{options.albedo, options.emission, options.doubleSided}};
    FixtureMesh box;
    box.material = 0;
    addBox(box, glm::vec3(0.0f), options.size, options.inwardFacing);
    scene.meshes = {box};
    scene.nodes = {{.mesh = 0}};
    scene.roots = {0};
    return scene;
}

void writeBoxGltf(const std::string& path, const BoxOptions& options) {
    writeGltf(path, boxScene(options), options.container);
}

HierarchyFixture hierarchyFixture() {
    HierarchyFixture fixture;
    FixtureScene& scene = fixture.scene;
    FixtureMesh triangle;
    triangle.positions = {{0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}};
    triangle.normals = {glm::vec3(0.0f, 0.0f, 1.0f), glm::vec3(0.0f, 0.0f, 1.0f),
                        glm::vec3(0.0f, 0.0f, 1.0f)};
    scene.meshes = {triangle};
    scene.lights = {{"directional", {1.0f, 0.5f, 0.25f}, 4.0f}};

    FixtureNode root{.translation = {10.0f, 0.0f, 0.0f},
                     .rotation = glm::angleAxis(glm::radians(90.0f), glm::vec3(0.0f, 1.0f, 0.0f)),
                     .scale = {2.0f, 1.0f, 0.5f},
                     .children = {1, 3}};
    const glm::mat4 childMatrix = glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 5.0f, 0.0f)) *
                                  glm::scale(glm::mat4(1.0f), glm::vec3(1.0f, 3.0f, 1.0f));
    FixtureNode child{.matrix = childMatrix, .children = {2}};
    FixtureNode grandchild{
        .mesh = 0,
        .translation = {1.0f, 2.0f, 3.0f},
        .rotation = glm::angleAxis(glm::radians(30.0f), glm::normalize(glm::vec3(1.0f, 1.0f, 0.0f)))};
    FixtureNode sun{.light = 0,
                    .rotation = glm::angleAxis(glm::radians(-45.0f), glm::vec3(1.0f, 0.0f, 0.0f))};
    scene.nodes = {root, child, grandchild, sun};
    scene.roots = {0};

    auto trs = [](const FixtureNode& node) {
        return glm::translate(glm::mat4(1.0f), node.translation) * glm::mat4_cast(node.rotation) *
               glm::scale(glm::mat4(1.0f), node.scale);
    };
    fixture.meshWorld = trs(root) * childMatrix * trs(grandchild);
    const glm::mat4 sunWorld = trs(root) * trs(sun);
    fixture.sunTowards = glm::normalize(glm::vec3(sunWorld * glm::vec4(0.0f, 0.0f, 1.0f, 0.0f)));
    fixture.sunIrradiance = scene.lights[0].colour * scene.lights[0].intensity;
    return fixture;
}

Cubemap directionalSky(int faceSize) {
    Cubemap sky = makeCubemap(faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < faceSize; ++j)
            for (int i = 0; i < faceSize; ++i) {
                const glm::dvec3 d = texelDirection(face, i, j, faceSize);
                sky.at(face, i, j) = glm::vec4(glm::vec3(1.0 + d.x, 2.0 + d.y, 3.0 + d.z), 1.0f);
            }
    return sky;
}

} // namespace shprobe::testing
