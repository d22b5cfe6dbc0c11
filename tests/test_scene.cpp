// The glTF scene reader (scene/gltf_scene.h) on real files (Debian's assimp-testmodels: a real
// model, textured boxes in the three containers, and the broken files of its glTF2 folder) and on
// scenes written by scene_fixtures.h: transforms, normals, materials, lights, and every way a file
// can be refused, each as one line naming the file and the problem.
#include "common/error.h"
#include "image/codec.h"
#include "image/environment.h"
#include "scene/gltf_scene.h"
#include "scene/scene_images.h"
#include "scene_fixtures.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <unistd.h>

namespace shprobe {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace shprobe::testing;

const fs::path kModels = SHPROBE_GLTF_MODELS_DIR;

std::string readBytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    return bytes.str();
}

// The JSON of a .gltf, or of a .glb's first chunk (length at byte 12, data from byte 20).
json documentOf(const fs::path& path) {
    const std::string bytes = readBytes(path);
    if (bytes.compare(0, 4, "glTF") != 0) return json::parse(bytes);
    uint32_t length;
    std::memcpy(&length, bytes.data() + 12, 4);
    return json::parse(bytes.substr(20, length));
}

// The message of the Error(Input) that `call` throws; a test failure if it throws nothing else.
std::string inputError(const std::function<void()>& call) {
    try {
        call();
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Input) << error.what();
        return error.what();
    }
    ADD_FAILURE() << "nothing was thrown";
    return "";
}

std::string lowered(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return text;
}

// Loading `path` is refused with one line "PATH: REASON", the reason naming each key word
// (case-insensitive).
void expectRefused(const std::string& path, const std::vector<std::string>& keywords,
                   const GltfLoadOptions& options = {}) {
    SCOPED_TRACE(path);
    const std::string message = inputError([&] { loadGltfScene(path, options); });
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    for (const std::string& keyword : keywords)
        EXPECT_NE(lowered(message).find(lowered(keyword)), std::string::npos)
            << "no \"" << keyword << "\" in: " << message;
}

// A folder of its own for each test's files.
class SceneTest : public ::testing::Test {
  protected:
    void SetUp() override {
        const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
        folder_ = fs::temp_directory_path() /
                  ("shprobe_test_scene_" + std::to_string(getpid()) + "_" + test->name());
        fs::remove_all(folder_);
        fs::create_directories(folder_);
    }
    void TearDown() override { fs::remove_all(folder_); }
    std::string file(const std::string& name) const { return (folder_ / name).string(); }

    fs::path folder_;
};

// The geometric normal of triangle t, counter-clockwise seen from its front (unnormalized).
glm::vec3 faceNormal(const World& world, size_t t) {
    const glm::vec3 a = world.positions[world.indices[3 * t]];
    return glm::cross(world.positions[world.indices[3 * t + 1]] - a,
                      world.positions[world.indices[3 * t + 2]] - a);
}

// Every array of the World consistent with every other: one normal and uv per position, unit
// normals, indices within the positions, one material per triangle and materials that exist.
void expectConsistent(const World& world) {
    ASSERT_EQ(world.normals.size(), world.positions.size());
    ASSERT_EQ(world.uvs.size(), world.positions.size());
    ASSERT_EQ(world.indices.size() % 3, 0u);
    ASSERT_EQ(world.triangleMaterials.size(), world.triangleCount());
    for (const glm::vec3& n : world.normals)
        ASSERT_NEAR(glm::length(n), 1.0f, 1e-5f); // float rounding of a normalized vector
    for (uint32_t index : world.indices)
        ASSERT_LT(index, world.positions.size());
    for (uint32_t material : world.triangleMaterials)
        ASSERT_LT(material, world.materials.size());
    for (const glm::vec3& p : world.positions)
        for (int c = 0; c < 3; ++c) {
            ASSERT_TRUE(std::isfinite(p[c]));
            ASSERT_GE(p[c], world.boundsMin[c]);
            ASSERT_LE(p[c], world.boundsMax[c]);
        }
}

// ---- Real files -----------------------------------------------------------------------------------

// The install script installs assimp-testmodels: without it the real-file tests cannot run, which
// is a failure, not a skip.
TEST(SceneModels, FolderIsInstalled) {
    ASSERT_TRUE(fs::is_directory(kModels)) << kModels << " is missing: install assimp-testmodels "
                                           << "(scripts/install-deps.sh)";
}

// The node transform of a JSON node (matrix, or T * R * S), for the independent count below.
glm::dmat4 jsonLocal(const json& node) {
    if (node.contains("matrix")) return glm::make_mat4(node["matrix"].get<std::vector<double>>().data());
    glm::dmat4 m(1.0);
    if (node.contains("translation"))
        m = glm::translate(m, glm::make_vec3(node["translation"].get<std::vector<double>>().data()));
    if (node.contains("rotation")) {
        const auto q = node["rotation"].get<std::vector<double>>();
        m *= glm::mat4_cast(glm::dquat(q[3], q[0], q[1], q[2]));
    }
    if (node.contains("scale"))
        m = glm::scale(m, glm::make_vec3(node["scale"].get<std::vector<double>>().data()));
    return m;
}

// 2CylinderEngine (82 nodes, 29 meshes, 34 materials, matrices and TRS): the triangles are every
// instance's index count / 3, counted here from the JSON by a walk of its own; the bounds lie within
// the transformed boxes of the accessors' min and max (which enclose every vertex) and fill at least
// half of them on each axis (a box rotated off the axes grows its enclosing box by at most sqrt(3)).
TEST(SceneModels, TwoCylinderEngineLoads) {
    const fs::path path = kModels / "2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
    const json document = documentOf(path);
    size_t triangles = 0;
    glm::dvec3 low(INFINITY), high(-INFINITY);
    std::vector<std::pair<int, glm::dmat4>> stack;
    for (int root : document["scenes"][document.value("scene", 0)]["nodes"])
        stack.push_back({root, glm::dmat4(1.0)});
    while (!stack.empty()) {
        const auto [index, parent] = stack.back();
        stack.pop_back();
        const json& node = document["nodes"][size_t(index)];
        const glm::dmat4 world = parent * jsonLocal(node);
        for (int child : node.value("children", std::vector<int>{}))
            stack.push_back({child, world});
        if (!node.contains("mesh")) continue;
        for (const json& primitive : document["meshes"][node["mesh"].get<size_t>()]["primitives"]) {
            ASSERT_EQ(primitive.value("mode", 4), 4);
            triangles += document["accessors"][primitive["indices"].get<size_t>()]["count"].get<size_t>() / 3;
            const json& position = document["accessors"][primitive["attributes"]["POSITION"].get<size_t>()];
            const auto lo = position["min"].get<std::vector<double>>(),
                       hi = position["max"].get<std::vector<double>>();
            for (int corner = 0; corner < 8; ++corner) {
                const glm::dvec3 p(corner & 1 ? hi[0] : lo[0], corner & 2 ? hi[1] : lo[1],
                                   corner & 4 ? hi[2] : lo[2]);
                const glm::dvec3 q(world * glm::dvec4(p, 1.0));
                low = glm::min(low, q);
                high = glm::max(high, q);
            }
        }
    }
    const World world = loadGltfScene(path.string());
    expectConsistent(world);
    EXPECT_EQ(world.triangleCount(), triangles);
    EXPECT_GT(triangles, 100000u);
    EXPECT_LE(world.materials.size(), document["materials"].size());
    EXPECT_TRUE(world.suns.empty());
    for (int c = 0; c < 3; ++c) {
        const double slack = 1e-4 * (high[c] - low[c]); // float positions, double corners
        EXPECT_GE(world.boundsMin[c], low[c] - slack) << "axis " << c;
        EXPECT_LE(world.boundsMax[c], high[c] + slack) << "axis " << c;
        EXPECT_GT(world.boundsMax[c] - world.boundsMin[c], 0.5 * (high[c] - low[c])) << "axis " << c;
    }
    EXPECT_EQ(world.description.rfind(path.string() + " (" + std::to_string(triangles) + " triangles, ", 0),
              0u)
        << world.description;
}

// BoxTextured in its three containers (an external PNG beside the .gltf, a data URI, a .glb
// buffer view): 12 triangles, one material whose albedo texture is the PNG as readImage decodes it
// (sRGB to linear with the same EOTF: equal to float rounding), alpha 1, and the uvs of
// BoxTextured0.bin, read here from the accessor's view and stride (they run to 6: the texture
// repeats).
TEST(SceneModels, BoxTexturedLoadsItsTexture) {
    const Image png = readImage((kModels / "BoxTextured-glTF/CesiumLogoFlat.png").string());
    const json document = documentOf(kModels / "BoxTextured-glTF/BoxTextured.gltf");
    const std::string bin = readBytes(kModels / "BoxTextured-glTF/BoxTextured0.bin");
    const json& accessor =
        document["accessors"]
                [document["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"].get<size_t>()];
    ASSERT_EQ(accessor["componentType"], 5126);
    const json& view = document["bufferViews"][accessor["bufferView"].get<size_t>()];
    std::vector<glm::vec2> uvs(accessor["count"].get<size_t>());
    for (size_t i = 0; i < uvs.size(); ++i)
        std::memcpy(&uvs[i],
                    bin.data() + view.value("byteOffset", size_t(0)) +
                        accessor.value("byteOffset", size_t(0)) + i * view.value("byteStride", size_t(8)),
                    8);
    for (const char* name :
         {"BoxTextured-glTF/BoxTextured.gltf", "BoxTextured-glTF-Embedded/BoxTextured.gltf",
          "BoxTextured-glTF-Binary/BoxTextured.glb"}) {
        SCOPED_TRACE(name);
        const World world = loadGltfScene((kModels / name).string());
        expectConsistent(world);
        EXPECT_EQ(world.triangleCount(), 12u);
        ASSERT_EQ(world.materials.size(), 1u);
        ASSERT_EQ(world.textures.size(), 1u);
        EXPECT_EQ(world.materials[0].albedoTexture, 0);
        EXPECT_EQ(world.materials[0].emissionTexture, -1);
        EXPECT_EQ(world.materials[0].albedo, glm::vec3(1.0f));
        const SceneTexture& texture = world.textures[0];
        ASSERT_EQ(texture.width, png.width);
        ASSERT_EQ(texture.height, png.height);
        float largest = 0.0f;
        for (size_t i = 0; i < texture.texels.size(); ++i) {
            largest = std::max(largest, glm::length(glm::vec3(texture.texels[i]) - glm::vec3(png.texels[i])));
            ASSERT_EQ(texture.texels[i].a, 1.0f);
        }
        EXPECT_LE(largest, 1e-6f);
        EXPECT_EQ(world.uvs, uvs);
    }
}

// BoxBadNormals: zero normals, and normals not of unit length. Those are normalized and the zero
// ones replaced by their faces' normal, so every vertex normal agrees with its triangle's face.
TEST(SceneModels, BadNormalsAreRepaired) {
    const World world = loadGltfScene((kModels / "BoxBadNormals-glTF-Binary/BoxBadNormals.glb").string());
    expectConsistent(world);
    for (size_t t = 0; t < world.triangleCount(); ++t)
        for (int k = 0; k < 3; ++k)
            EXPECT_GT(glm::dot(world.normals[world.indices[3 * t + k]], glm::normalize(faceNormal(world, t))),
                      0.999f)
                << "triangle " << t;
}

// Every scene file of the broken folders is refused with one line that names it and its fault.
// A file with no row here fails the test, so that a new file in the package is not left out.
TEST(SceneModels, BrokenFilesAreRefused) {
    const std::map<std::string, std::vector<std::string>> expected = {
        {"IndexOutOfRange/IndexOutOfRange.gltf", {"indices", "out of range", "24 vertices"}},
        {"IndexOutOfRange/AllIndicesOutOfRange.gltf", {"indices", "out of range"}},
        {"MissingBin/BoxTextured.gltf", {"BoxTextured0.bin", "no such file"}},
        {"RecursiveNodes/RecursiveNodes.gltf", {"cycle", "0 -> 1 -> 0"}},
        {"BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", {"POSITION", "not finite"}},
        // Its buffer views 2 to 4 (unused) lie past its 514 bytes, before its truncated arrays.
        {"IncorrectVertexArrays/Cube.gltf", {"bufferViews[2]", "past the end of buffer 0 (514 bytes)"}},
        {"wrongTypes/badArray.gltf", {"meshes[0].primitives must be an array"}},
        {"wrongTypes/badExtension.gltf", {"extensions.KHR_texture_transform must be an object"}},
        {"wrongTypes/badNumber.gltf", {"normalTexture.scale must be a number"}},
        {"wrongTypes/badObject.gltf", {"pbrMetallicRoughness must be an object"}},
        {"wrongTypes/badString.gltf", {"scenes[0].name must be a string"}},
        {"wrongTypes/badUint.gltf", {"baseColorTexture.index must be an integer", "-1"}},
    };
    size_t seen = 0;
    for (const char* folder : {"IndexOutOfRange", "MissingBin", "RecursiveNodes",
                               "BoxWithInfinites-glTF-Binary", "IncorrectVertexArrays", "wrongTypes"})
        for (const fs::directory_entry& entry : fs::directory_iterator(kModels / folder)) {
            const std::string extension = entry.path().extension().string();
            if (extension != ".gltf" && extension != ".glb") continue; // buffers and images
            const std::string name = std::string(folder) + "/" + entry.path().filename().string();
            auto row = expected.find(name);
            if (row == expected.end()) {
                ADD_FAILURE() << name << " has no expected error";
                continue;
            }
            expectRefused(entry.path().string(), row->second);
            ++seen;
        }
    EXPECT_EQ(seen, expected.size());
}

// TestNoRootNode: a scene with no nodes holds no triangles; a file with no scenes names default
// scene 0 all the same, which glTF forbids (its schema: "scene" MUST NOT be defined when "scenes" is
// undefined).
TEST(SceneModels, ScenesWithoutTrianglesAreRefused) {
    expectRefused((kModels / "TestNoRootNode/SceneWithoutNodes.gltf").string(), {"no triangles"});
    expectRefused((kModels / "TestNoRootNode/NoScene.gltf").string(),
                  {"the default scene is 0, but the file has 0 scenes"});
}

// glTF-Asset-Generator's Mesh_PrimitiveMode: the unit square facing +z drawn in every mode, indexed
// (index components of each size) or not. Strips, fans and lists give its two triangles, each facing
// +z, of total area 1 (exact in float: halves of the unit square); points and lines give none.
TEST(SceneModels, EveryPrimitiveModeOfTheAssetGenerator) {
    size_t files = 0;
    for (const fs::directory_entry& entry :
         fs::directory_iterator(kModels / "glTF-Asset-Generator/Mesh_PrimitiveMode")) {
        if (entry.path().extension() != ".gltf") continue;
        ++files;
        SCOPED_TRACE(entry.path().filename().string());
        const json document = documentOf(entry.path());
        if (document["meshes"][0]["primitives"][0].value("mode", 4) < 4) {
            expectRefused(entry.path().string(), {"no triangles", "1 line or point primitive ignored"});
            continue;
        }
        const World world = loadGltfScene(entry.path().string());
        expectConsistent(world);
        ASSERT_EQ(world.triangleCount(), 2u);
        float area = 0.0f;
        for (size_t t = 0; t < 2; ++t) {
            EXPECT_GT(faceNormal(world, t).z, 0.0f) << "triangle " << t;
            area += 0.5f * glm::length(faceNormal(world, t));
        }
        EXPECT_EQ(area, 1.0f);
    }
    EXPECT_EQ(files, 16u);
}

// A file that requires an extension not read (Draco's compressed meshes) is refused by its name,
// before tinygltf meets the accessors without buffer views that Draco leaves.
TEST(SceneModels, RequiredExtensionsThatAreNotReadAreRefused) {
    expectRefused((kModels / "draco/2CylinderEngine.gltf").string(),
                  {"requires extension \"KHR_draco_mesh_compression\""});
}

// ---- Fixtures: transforms, normals, winding ------------------------------------------------------

// glTF's local transform is T * R * S: the vertex (1, 0, 0) under scale (2, 1, 0.5), a rotation of
// 90 degrees about +Y and a translation (10, 0, 0) goes to (2, 0, 0), then (0, 0, -2) (about +Y, x
// turns towards -z), then (10, 0, -2). Worked by hand, not by glm; 1e-5 is float rounding.
TEST_F(SceneTest, NodeTransformIsTranslationRotationScale) {
    FixtureScene scene;
    FixtureMesh triangle;
    triangle.positions = {{1.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 0.0f}, {1.0f, 0.0f, 1.0f}};
    scene.meshes = {triangle};
    scene.nodes = {{.mesh = 0,
                    .translation = {10.0f, 0.0f, 0.0f},
                    .rotation = glm::quat(std::sqrt(0.5f), 0.0f, std::sqrt(0.5f), 0.0f),
                    .scale = {2.0f, 1.0f, 0.5f}}};
    scene.roots = {0};
    writeGltf(file("trs.glb"), scene, GltfContainer::Glb);
    const World world = loadGltfScene(file("trs.glb"));
    ASSERT_EQ(world.positions.size(), 3u); // no normals: flat, three vertices of its own
    EXPECT_NEAR(world.positions[0].x, 10.0f, 1e-5f);
    EXPECT_NEAR(world.positions[0].y, 0.0f, 1e-5f);
    EXPECT_NEAR(world.positions[0].z, -2.0f, 1e-5f);
}

// The hierarchy fixture (TRS -> matrix -> TRS, non-uniform scales): every vertex lands where the
// composed matrix puts it, the normal stays perpendicular to the transformed triangle (the inverse
// transpose, not the matrix, maps normals) and on its front side, and the sun arrives from the
// light node's world +Z. Both containers give the same World. Tolerances: float rounding of values
// up to about 20 (1e-4), of unit vectors (1e-5).
TEST_F(SceneTest, HierarchyComposesTransformsAndLights) {
    const HierarchyFixture fixture = hierarchyFixture();
    writeGltf(file("hierarchy.gltf"), fixture.scene, GltfContainer::Gltf);
    writeGltf(file("hierarchy.glb"), fixture.scene, GltfContainer::Glb);
    const World world = loadGltfScene(file("hierarchy.gltf"));
    expectConsistent(world);
    ASSERT_EQ(world.triangleCount(), 1u);
    for (size_t v = 0; v < 3; ++v) {
        const glm::vec3 expected(fixture.meshWorld * glm::vec4(fixture.scene.meshes[0].positions[v], 1.0f));
        EXPECT_LT(glm::length(world.positions[v] - expected), 1e-4f) << "vertex " << v;
    }
    const glm::vec3 face = glm::normalize(faceNormal(world, 0));
    const glm::vec3 edge1 = world.positions[1] - world.positions[0],
                    edge2 = world.positions[2] - world.positions[0];
    for (const glm::vec3& n : world.normals) {
        EXPECT_LT(std::abs(glm::dot(n, glm::normalize(edge1))), 1e-5f);
        EXPECT_LT(std::abs(glm::dot(n, glm::normalize(edge2))), 1e-5f);
        EXPECT_GT(glm::dot(n, face), 0.9999f);
    }
    // The matrix's own image of the normal is not perpendicular here: the test can tell the two apart.
    const glm::vec3 naive = glm::normalize(glm::mat3(fixture.meshWorld) * glm::vec3(0.0f, 0.0f, 1.0f));
    EXPECT_GT(std::abs(glm::dot(naive, glm::normalize(edge1))), 0.05f);
    ASSERT_EQ(world.suns.size(), 1u);
    EXPECT_LT(glm::length(world.suns[0].direction - fixture.sunTowards), 1e-5f);
    EXPECT_EQ(world.suns[0].irradiance, fixture.sunIrradiance);
    const World binary = loadGltfScene(file("hierarchy.glb"));
    EXPECT_EQ(binary.positions, world.positions);
    EXPECT_EQ(binary.normals, world.normals);
    EXPECT_EQ(binary.suns[0].direction, world.suns[0].direction);
}

// A mirroring transform (scale -1 on x) turns counter-clockwise triangles clockwise; glTF says the
// winding then flips, so each World triangle stays counter-clockwise seen from the side its normals
// face. Checked with and without normals (flat ones are made from the flipped winding), on an
// outward box: every face normal points away from the centre.
TEST_F(SceneTest, MirroringTransformsKeepFrontsOutward) {
    for (bool withNormals : {true, false})
        for (float mirror : {1.0f, -1.0f}) {
            SCOPED_TRACE(std::string(withNormals ? "normals" : "flat") + (mirror < 0 ? ", mirrored" : ""));
            FixtureScene scene = boxScene({.inwardFacing = false});
            if (!withNormals) scene.meshes[0].normals.clear();
            scene.nodes[0].scale = {mirror * 2.0f, 1.0f, 1.0f};
            writeGltf(file("box.glb"), scene, GltfContainer::Glb);
            const World world = loadGltfScene(file("box.glb"));
            expectConsistent(world);
            ASSERT_EQ(world.triangleCount(), 12u);
            for (size_t t = 0; t < 12; ++t) {
                const glm::vec3 face = glm::normalize(faceNormal(world, t));
                const glm::vec3 centre =
                    (world.positions[world.indices[3 * t]] + world.positions[world.indices[3 * t + 1]] +
                     world.positions[world.indices[3 * t + 2]]) /
                    3.0f;
                EXPECT_GT(glm::dot(face, centre), 0.0f) << "triangle " << t;
                for (int k = 0; k < 3; ++k)
                    EXPECT_GT(glm::dot(world.normals[world.indices[3 * t + k]], face), 0.9999f)
                        << "triangle " << t;
            }
        }
}

// Triangle strips and fans become lists with the winding of their first triangle (strips
// alternate, glTF 3.7.2.1): a square drawn either way gives two triangles facing +z. Points and
// lines are left out and said in the description; a scene of lines only has no triangles.
TEST_F(SceneTest, StripsFansAndLines) {
    const std::vector<glm::vec3> strip = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    const std::vector<glm::vec3> fan = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    FixtureScene scene;
    scene.meshes = {
        {.positions = strip, .mode = 5}, {.positions = fan, .mode = 6}, {.positions = fan, .mode = 1}};
    scene.nodes = {{.mesh = 0}, {.mesh = 1}, {.mesh = 2}};
    scene.roots = {0, 1, 2};
    writeGltf(file("modes.gltf"), scene, GltfContainer::Gltf);
    const World world = loadGltfScene(file("modes.gltf"));
    expectConsistent(world);
    ASSERT_EQ(world.triangleCount(), 4u);
    for (size_t t = 0; t < 4; ++t)
        EXPECT_GT(faceNormal(world, t).z, 0.0f) << "triangle " << t;
    EXPECT_NE(world.description.find("1 line or point primitive ignored"), std::string::npos)
        << world.description;

    scene.roots = {2};
    writeGltf(file("lines.gltf"), scene, GltfContainer::Gltf);
    expectRefused(file("lines.gltf"), {"no triangles", "1 line or point primitive ignored"});
}

// ---- Fixtures: materials and lights --------------------------------------------------------------

// The Cornell box: the materials in order of first use (white, red, green, light), their albedo
// and emission exact (the light's 10 is emissiveFactor 1 times strength 10), every wall one-sided
// and facing inward; the closed variant has the front wall too; the sun arrives from where it was
// put. The bounds are the box's, exactly (its corners are sums of +-1 and 0 and 2).
TEST_F(SceneTest, CornellBoxMaterialsAndSun) {
    const glm::vec3 towards = glm::normalize(glm::vec3(0.3f, 1.0f, 0.2f));
    writeCornellBoxGltf(
        file("cornell.glb"),
        {.closed = true, .innerBoxes = true, .sun = FixtureSun{towards, {1.0f, 0.9f, 0.8f}, 3.0f}});
    const World world = loadGltfScene(file("cornell.glb"));
    expectConsistent(world);
    EXPECT_EQ(world.triangleCount(), 6u * 2 + 2 + 2 * 12); // walls, light, two blocks
    ASSERT_EQ(world.materials.size(), 4u);
    EXPECT_EQ(world.materials[0].albedo, kCornellWhite);
    EXPECT_EQ(world.materials[1].albedo, kCornellRed);
    EXPECT_EQ(world.materials[2].albedo, kCornellGreen);
    EXPECT_EQ(world.materials[3].emission, glm::vec3(10.0f));
    for (const SceneMaterial& material : world.materials) {
        EXPECT_FALSE(material.doubleSided);
        EXPECT_EQ(material.albedoTexture, -1);
    }
    EXPECT_EQ(world.boundsMin, glm::vec3(-1.0f, 0.0f, -1.0f));
    EXPECT_EQ(world.boundsMax, glm::vec3(1.0f, 2.0f, 1.0f));
    // The walls and the light face the box's inside, towards its centre (0, 1, 0): triangles 0 to 7
    // (the white walls; the white blocks follow them) and 32 to 37 (red, green, light).
    for (size_t t : {0, 1, 2, 3, 4, 5, 6, 7, 32, 33, 34, 35, 36, 37})
        EXPECT_GT(glm::dot(faceNormal(world, t),
                           glm::vec3(0.0f, 1.0f, 0.0f) - world.positions[world.indices[3 * t]]),
                  0.0f)
            << "triangle " << t;
    ASSERT_EQ(world.suns.size(), 1u);
    EXPECT_LT(glm::length(world.suns[0].direction - towards), 1e-6f); // a unit vector through a quaternion
    EXPECT_LT(glm::length(world.suns[0].irradiance - glm::vec3(3.0f, 2.7f, 2.4f)), 1e-6f);
    const std::string name = file("cornell.glb");
    EXPECT_EQ(world.description, name + " (38 triangles, 4 materials, 1 sun)");
}

// The furnace box: one double-sided material of the given albedo and emission (2.5 > 1: written
// as factor 1 times KHR_materials_emissive_strength 2.5), normals towards the inside; a primitive
// without a material gets glTF's default (albedo 1, no emission, one-sided).
TEST_F(SceneTest, BoxMaterialsAndDefaultMaterial) {
    writeBoxGltf(file("furnace.gltf"), {.size = glm::vec3(4.0f),
                                        .albedo = glm::vec3(0.5f),
                                        .emission = {2.5f, 1.0f, 0.5f},
                                        .doubleSided = true,
                                        .container = GltfContainer::Gltf});
    EXPECT_NE(readBytes(file("furnace.gltf")).find("KHR_materials_emissive_strength"), std::string::npos);
    const World world = loadGltfScene(file("furnace.gltf"));
    expectConsistent(world);
    ASSERT_EQ(world.materials.size(), 1u);
    EXPECT_EQ(world.materials[0].albedo, glm::vec3(0.5f));
    EXPECT_LT(glm::length(world.materials[0].emission - glm::vec3(2.5f, 1.0f, 0.5f)),
              1e-6f); // (x / 2.5) * 2.5
    EXPECT_TRUE(world.materials[0].doubleSided);
    for (size_t v = 0; v < world.positions.size(); ++v)
        EXPECT_GT(glm::dot(world.normals[v], -world.positions[v]), 0.0f) << "vertex " << v;

    FixtureScene scene = boxScene();
    scene.meshes[0].material = -1;
    writeGltf(file("plain.glb"), scene, GltfContainer::Glb);
    const World plain = loadGltfScene(file("plain.glb"));
    ASSERT_EQ(plain.materials.size(), 1u);
    EXPECT_EQ(plain.materials[0].albedo, glm::vec3(1.0f));
    EXPECT_EQ(plain.materials[0].emission, glm::vec3(0.0f));
    EXPECT_FALSE(plain.materials[0].doubleSided);
}

// Point and spot lights are left out, and the description says how many.
TEST_F(SceneTest, PunctualLightsAreCounted) {
    FixtureScene scene = boxScene();
    scene.lights = {{"point"}, {"spot"}, {"directional"}};
    for (int light : {0, 0, 1, 2}) {
        scene.nodes.push_back({.light = light});
        scene.roots.push_back(int(scene.nodes.size() - 1));
    }
    writeGltf(file("lights.glb"), scene, GltfContainer::Glb);
    const World world = loadGltfScene(file("lights.glb"));
    ASSERT_EQ(world.suns.size(), 1u);
    EXPECT_EQ(world.description, file("lights.glb") +
                                     " (12 triangles, 1 material, 1 sun; 2 point lights ignored, "
                                     "1 spot light ignored)");
}

// ---- Edited files: what the reader must refuse or support ---------------------------------------

// A sparse accessor replaces vertex 2 of a triangle with (5, 6, 7): indices and values in a second
// buffer (a data URI), glTF 3.6.2.3.
TEST_F(SceneTest, SparseAccessorsAreApplied) {
    FixtureScene scene;
    scene.meshes = {{.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}};
    scene.nodes = {{.mesh = 0}};
    scene.roots = {0};
    json document = json::parse(gltfText(scene));
    const uint32_t index = 2;
    const float value[3] = {5.0f, 6.0f, 7.0f};
    std::string bytes(reinterpret_cast<const char*>(&index), 4);
    bytes.append(reinterpret_cast<const char*>(value), 12);
    document["buffers"].push_back({{"byteLength", bytes.size()}, {"uri", dataUri(bytes)}});
    document["bufferViews"].push_back({{"buffer", 1}, {"byteOffset", 0}, {"byteLength", 4}});
    document["bufferViews"].push_back({{"buffer", 1}, {"byteOffset", 4}, {"byteLength", 12}});
    const size_t views = document["bufferViews"].size();
    document["accessors"][0]["sparse"] = {{"count", 1},
                                          {"indices", {{"bufferView", views - 2}, {"componentType", 5125}}},
                                          {"values", {{"bufferView", views - 1}}}};
    document["accessors"][0]["max"] = {5.0, 6.0, 7.0};
    writeText(file("sparse.gltf"), document.dump());
    const World world = loadGltfScene(file("sparse.gltf"));
    ASSERT_EQ(world.positions.size(), 3u);
    EXPECT_EQ(world.positions[2], glm::vec3(5.0f, 6.0f, 7.0f));

    // Indices that do not strictly increase (2, then 1) are refused: a repeated one would give an
    // element two values, whichever an engine takes last.
    const uint32_t indices[2] = {2, 1};
    const float values[6] = {5.0f, 6.0f, 7.0f, 8.0f, 9.0f, 10.0f};
    bytes.assign(reinterpret_cast<const char*>(indices), 8);
    bytes.append(reinterpret_cast<const char*>(values), 24);
    document["buffers"][1] = {{"byteLength", bytes.size()}, {"uri", dataUri(bytes)}};
    document["bufferViews"][views - 2]["byteLength"] = 8;
    document["bufferViews"][views - 1] = {{"buffer", 1}, {"byteOffset", 8}, {"byteLength", 24}};
    document["accessors"][0]["sparse"]["count"] = 2;
    document["accessors"][0]["max"] = {8.0, 9.0, 10.0};
    writeText(file("unordered.gltf"), document.dump());
    expectRefused(file("unordered.gltf"), {"sparse index 1 after 2", "strictly increase"});
}

// One edit of the box fixture's JSON each, and the words its refusal must hold.
struct Edit {
    const char* what;
    std::function<void(json&)> edit;
    std::vector<std::string> keywords;
};

TEST_F(SceneTest, MalformedScenesAreRefused) {
    const std::vector<Edit> edits = {
        {"an accessor past its buffer view",
         [](json& d) { d["accessors"][0]["byteOffset"] = 100000; },
         {"accessors[0] claims 24 elements", "from byte 100000", "bufferViews[0], which has 288"}},
        {"an accessor whose count its buffer view cannot hold",
         [](json& d) { d["accessors"][0]["count"] = 1'000'000'000; },
         {"accessors[0] claims 1000000000 elements of 12 bytes", "which has 288"}},
        {"a byte stride past glTF's",
         [](json& d) { d["bufferViews"][0]["byteStride"] = 256; },
         {"bufferViews[0].byteStride is 256", "multiple of 4 from 4 to 252"}},
        {"a byte stride of 0, below glTF's 4",
         [](json& d) { d["bufferViews"][0]["byteStride"] = 0; },
         {"bufferViews[0].byteStride is 0", "multiple of 4 from 4 to 252"}},
        {"a buffer view past its buffer",
         [](json& d) { d["bufferViews"][0]["byteLength"] = 100000; },
         {"bufferViews[0]", "past the end of buffer 0"}},
        {"POSITION of two components",
         [](json& d) { d["accessors"][0]["type"] = "VEC2"; },
         {"POSITION", "VEC2 of FLOAT", "must be VEC3 of FLOAT"}},
        {"indices of floats",
         [](json& d) { d["accessors"][2]["componentType"] = 5126; },
         {"indices", "SCALAR of FLOAT"}},
        {"an unknown mode", [](json& d) { d["meshes"][0]["primitives"][0]["mode"] = 9; }, {"mode 9"}},
        {"an accessor that does not exist",
         [](json& d) { d["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 50; },
         {"NORMAL", "accessor 50 does not exist"}},
        {"a node with two parents",
         [](json& d) {
             d["nodes"] = {{{"children", {2}}}, {{"children", {2}}}, {{"mesh", 0}}};
         },
         {"node 2", "node 0", "node 1", "one parent"}},
        {"a node of its own child", [](json& d) { d["nodes"][0]["children"] = {0}; }, {"cycle", "0 -> 0"}},
        {"a scene root that is a child",
         [](json& d) {
             d["nodes"].push_back({{"children", {0}}});
         },
         {"scenes[0].nodes", "child of node 1"}},
        {"a required extension that is not read",
         [](json& d) { d["extensionsRequired"] = {"KHR_draco_mesh_compression"}; },
         {"KHR_draco_mesh_compression"}},
        {"a matrix of 15 numbers",
         [](json& d) { d["nodes"][0]["matrix"] = std::vector<double>(15, 1.0); },
         {"nodes[0].matrix", "16 elements"}},
        {"a projective matrix",
         [](json& d) { d["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 2}; },
         {"nodes[0].matrix ends in the row 0, 0, 0, 2, not 0, 0, 0, 1"}},
        {"a matrix off affine by more than float rounding",
         [](json& d) { d["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1e-5, 0, 0, 0, 1}; },
         {"nodes[0].matrix ends in the row 0, 0, 1e-05, 1"}},
        {"a missing material",
         [](json& d) { d["meshes"][0]["primitives"][0]["material"] = 7; },
         {"material is 7", "1 material"}},
        {"a negative emissive strength",
         [](json& d) {
             d["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = -1.0;
         },
         {"emissiveStrength", "at least 0"}},
        {"an albedo above 1, which would reflect more light than it receives",
         [](json& d) {
             d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {10.0, 0.5, 0.5, 1.0};
         },
         {"materials[0].pbrMetallicRoughness.baseColorFactor[0] is 10", "outside the 0..1"}},
        {"a negative albedo",
         [](json& d) {
             d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {0.5, -1.0, 0.5, 1.0};
         },
         {"baseColorFactor[1] is -1", "outside the 0..1"}},
        {"an emissive factor outside 0..1",
         [](json& d) {
             d["materials"][0]["emissiveFactor"] = {-1.0, 1.0, 1.0};
         },
         {"materials[0].emissiveFactor[0] is -1", "outside the 0..1"}},
        {"a triangle list of 35 indices",
         [](json& d) { d["accessors"][2]["count"] = 35; },
         {"indices", "35 indices", "multiple of 3"}},
        {"NORMAL of another count",
         [](json& d) { d["accessors"][1]["count"] = 23; },
         {"NORMAL", "23 elements", "24"}},
        {"no asset", [](json& d) { d.erase("asset"); }, {"no asset.version"}},
        {"glTF 1",
         [](json& d) { d["asset"]["version"] = "1.0"; },
         {"asset.version is 1.0", "reads glTF 2.0"}},
        {"a version of another form",
         [](json& d) { d["asset"]["version"] = "banana"; },
         {"asset.version is \"banana\", not <major>.<minor>"}},
        {"a newer minimum version",
         [](json& d) { d["asset"]["minVersion"] = "2.1"; },
         {"asset.minVersion is 2.1", "reads glTF 2.0"}},
    };
    for (const Edit& edit : edits) {
        SCOPED_TRACE(edit.what);
        json document = json::parse(gltfText(boxScene()));
        edit.edit(document);
        writeText(file("edited.gltf"), document.dump());
        expectRefused(file("edited.gltf"), edit.keywords);
    }
    // A last row of float rounding away from 0, 0, 0, 1 (an exporter's float32 round trip) is affine.
    json document = json::parse(gltfText(boxScene()));
    document["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0.99999994};
    writeText(file("rounded.gltf"), document.dump());
    EXPECT_NO_THROW(loadGltfScene(file("rounded.gltf")));
}

// A NaN coordinate in the buffer (the BIN chunk edited in place) is refused as infinities are.
TEST_F(SceneTest, NanPositionsAreRefused) {
    writeBoxGltf(file("box.glb"));
    std::string bytes = readBytes(file("box.glb"));
    const json document = documentOf(file("box.glb"));
    uint32_t jsonLength;
    std::memcpy(&jsonLength, bytes.data() + 12, 4);
    const size_t at =
        20 + jsonLength + 8 + document["bufferViews"][0]["byteOffset"].get<size_t>() + 4; // vertex 0's y
    const float nan = std::nanf("");
    std::memcpy(bytes.data() + at, &nan, 4);
    writeText(file("nan.glb"), bytes);
    expectRefused(file("nan.glb"), {"POSITION", "not finite", "element 0"});
}

// The limits are checked before anything is read: 12 triangles under a limit of 10; a texture of
// 211x211 pixels under a limit of 1000.
TEST_F(SceneTest, LimitsAreEnforced) {
    writeBoxGltf(file("box.glb"));
    expectRefused(file("box.glb"), {"limit of 10 triangles"}, {.maxTriangles = 10});
    const std::string textured = (kModels / "BoxTextured-glTF-Binary/BoxTextured.glb").string();
    expectRefused(textured, {"images[0]", "211x211", "1000 pixels"}, {.maxTexturePixels = 1000});
}

// A material with a texture on a primitive without TEXCOORD_0 (BoxTextured copied, its TEXCOORD_0
// removed) has nothing to sample the texture with: refused.
TEST_F(SceneTest, TexturesNeedTexCoords) {
    for (const char* name : {"BoxTextured.gltf", "BoxTextured0.bin", "CesiumLogoFlat.png"})
        fs::copy_file(kModels / "BoxTextured-glTF" / name, folder_ / name);
    json document = documentOf(folder_ / "BoxTextured.gltf");
    document["meshes"][0]["primitives"][0]["attributes"].erase("TEXCOORD_0");
    writeText(file("BoxTextured.gltf"), document.dump());
    expectRefused(file("BoxTextured.gltf"),
                  {"meshes[0].primitives[0]", "textured material", "no TEXCOORD_0"});
}

// The sRGB EOTF of IEC 61966-2-1, written out here again.
float srgbDecoded(int code) {
    const double c = code / 255.0;
    return float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

// Texture images (scene/scene_images.h): a PNG's codes decoded as sRGB (glTF's colour textures),
// alpha dropped for 1 (equal to float rounding: the same formula in double); a uniform JPEG within
// a code of its value (its one DC coefficient is quantized); bytes of another format, or an image
// over the pixel limit, refused naming what was decoded.
TEST(SceneTextures, ColourTexturesAreDecodedFromSrgb) {
    const uint8_t codes[2 * 2 * 4] = {0, 10, 128, 0, 255, 64, 3, 255, 200, 100, 50, 17, 1, 2, 254, 128};
    const std::string png = encodePng({2, 2, 4, 4, codes}, "test.png");
    const SceneTexture texture = decodeColourTexture(
        std::span(reinterpret_cast<const unsigned char*>(png.data()), png.size()), 100, "test.png");
    ASSERT_EQ(texture.width, 2);
    ASSERT_EQ(texture.height, 2);
    for (size_t i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(texture.texels[i][c], srgbDecoded(codes[4 * i + size_t(c)]), 1e-7f) << i << ", " << c;
            EXPECT_EQ(texture.texels[i].a, 1.0f);
        }

    const std::vector<uint8_t> grey(16 * 16 * 3, 90);
    const std::string jpeg = encodeJpeg({16, 16, 3, 3, grey.data()}, "test.jpg");
    const SceneTexture decoded = decodeColourTexture(
        std::span(reinterpret_cast<const unsigned char*>(jpeg.data()), jpeg.size()), 1000, "test.jpg");
    for (const glm::vec4& texel : decoded.texels)
        for (int c = 0; c < 3; ++c) {
            EXPECT_GE(texel[c], srgbDecoded(89));
            EXPECT_LE(texel[c], srgbDecoded(91));
        }

    const std::string text = "GIF89a, not a texture";
    const auto bytes = std::span(reinterpret_cast<const unsigned char*>(text.data()), text.size());
    EXPECT_EQ(inputError([&] { decodeColourTexture(bytes, 100, "x.gltf: images[1]"); }),
              "x.gltf: images[1]: not a PNG or JPEG image (the texture formats of glTF 2.0)");
    const std::string message = inputError([&] {
        decodeColourTexture(std::span(reinterpret_cast<const unsigned char*>(png.data()), png.size()), 3,
                            "t.png");
    });
    EXPECT_EQ(message, "t.png: the image is 2x2, more than the limit of 3 pixels per texture");
}

// ---- Files that are not scenes --------------------------------------------------------------------

// Missing, a folder, empty, not JSON, a .glb cut short, JSON that is not an object: one line each.
TEST_F(SceneTest, FilesThatAreNotScenesAreRefused) {
    expectRefused(file("missing.glb"), {"no such file"});
    expectRefused(folder_.string(), {"is a folder"});
    writeText(file("empty.gltf"), "");
    expectRefused(file("empty.gltf"), {"empty"});
    writeText(file("array.gltf"), "[1, 2]");
    expectRefused(file("array.gltf"), {"top level must be a JSON object"});
    writeText(file("broken.gltf"), "{\"asset\": {\"version\": \"2.0\"},");
    expectRefused(file("broken.gltf"), {"not valid JSON"});
    std::mt19937 random(7);
    std::string noise(4096, '\0');
    for (char& c : noise)
        c = char(random() % 256);
    noise[0] = 'x'; // neither '{' nor "glTF"
    writeText(file("noise.glb"), noise);
    expectRefused(file("noise.glb"), {"not a glTF file"});
    writeCornellBoxGltf(file("cornell.glb"));
    const std::string whole = readBytes(file("cornell.glb"));
    writeText(file("cut.glb"), whole.substr(0, whole.size() / 2));
    expectRefused(file("cut.glb"), {"cut short", std::to_string(whole.size()) + " bytes"});
    writeText(file("header.glb"), whole.substr(0, 10));
    expectRefused(file("header.glb"), {"cut short"});
}

// Every cut of a .glb and 300 random byte changes (seeded) are read or refused with Error(Input):
// no crash, no hang, no other exception. The edits hit the header, the JSON and the BIN chunk.
TEST_F(SceneTest, DamagedFilesNeverCrash) {
    writeCornellBoxGltf(file("cornell.glb"), {.innerBoxes = true});
    const std::string whole = readBytes(file("cornell.glb"));
    auto loadOrRefuse = [&](const std::string& bytes, const std::string& what) {
        writeText(file("damaged.glb"), bytes);
        try {
            loadGltfScene(file("damaged.glb"));
        } catch (const Error& error) {
            EXPECT_EQ(error.kind(), ErrorKind::Input) << what;
            EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos) << what;
        }
    };
    for (size_t size = 1; size < whole.size(); size += 37)
        loadOrRefuse(whole.substr(0, size), "cut at " + std::to_string(size));
    std::mt19937 random(11);
    for (int trial = 0; trial < 300; ++trial) {
        std::string bytes = whole;
        const size_t at = random() % bytes.size();
        bytes[at] = char(random() % 256);
        loadOrRefuse(bytes, "byte " + std::to_string(at));
    }
}

} // namespace
} // namespace shprobe
