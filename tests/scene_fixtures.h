// glTF scenes written for the tests, independently of the reader (scene/gltf_scene.h): the JSON by
// nlohmann-json, the binary buffer laid out here, as a base64 data URI (.gltf) or the BIN chunk of
// a .glb. A scene is described as plain data (FixtureScene) and written by writeGltf; the Cornell
// box, the single box and the node hierarchy are such descriptions, in metres.
#pragma once
#include "formats/probe_volume.h"
#include "scene/scene.h"
#include "sh/cubemap.h"

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace shprobe::testing {

enum class GltfContainer {
    Gltf, // JSON, its buffer a base64 data URI
    Glb,  // binary glTF: the JSON chunk and the BIN chunk
};

// A diffuse glTF material. An emission with a component above 1 is written as emissiveFactor
// (the emission over its largest component) times KHR_materials_emissive_strength (that component),
// as glTF's emissiveFactor stops at 1.
struct FixtureMaterial {
    glm::vec3 albedo{1.0f}; // baseColorFactor.rgb
    glm::vec3 emission{0.0f};
    bool doubleSided = false;
};

// One primitive. Without normals the reader makes flat ones; without indices it draws the vertices
// in order.
struct FixtureMesh {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;
    std::vector<uint32_t> indices;
    int material = -1; // -1: none (glTF's default material)
    int mode = 4;      // TRIANGLES; 5 TRIANGLE_STRIP, 6 TRIANGLE_FAN, 0 to 3 points and lines
};

// A node: its matrix when it has one, else translation, rotation and scale.
struct FixtureNode {
    int mesh = -1;
    int light = -1; // KHR_lights_punctual light
    std::optional<glm::mat4> matrix;
    glm::vec3 translation{0.0f};
    glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f}; // w, x, y, z
    glm::vec3 scale{1.0f};
    std::vector<int> children;
};

struct FixtureLight {
    std::string type = "directional"; // or "point", "spot"
    glm::vec3 colour{1.0f};
    float intensity = 1.0f;
};

struct FixtureScene {
    std::vector<FixtureMesh> meshes;
    std::vector<FixtureMaterial> materials;
    std::vector<FixtureNode> nodes;
    std::vector<FixtureLight> lights;
    std::vector<int> roots; // scene 0's nodes, the default scene
};

// Writes the scene; throws std::runtime_error if the file cannot be written.
void writeGltf(const std::string& path, const FixtureScene& scene, GltfContainer container);
// The scene's JSON document, its buffer a data URI (what writeGltf writes for GltfContainer::Gltf),
// for tests that edit it before writing it (writeText).
std::string gltfText(const FixtureScene& scene);
// "data:application/octet-stream;base64,..." holding `bytes`: a further buffer for edited documents.
std::string dataUri(const std::string& bytes);
// Writes `text` (any bytes) to path; throws std::runtime_error if it cannot.
void writeText(const std::string& path, const std::string& text);

// A .glb's two chunks (section 4.4): the JSON and the binary buffer.
struct Glb {
    nlohmann::json json;
    std::string bin;
};
// The chunks of a .glb's bytes, and the bytes of a .glb of chunks: for tests that read a written
// file by the specification, or damage it.
Glb readGlb(const std::string& bytes);
std::string glbOf(const Glb& glb);

// The rotation of a node whose directional light (which shines along the node's -Z) arrives from
// `towardsLight`: it takes +Z to that unit vector.
glm::quat rotationTowards(const glm::vec3& towardsLight);

// Appends a quad centred at `centre` with half-extents `u` and `v`: two triangles, counter-clockwise
// seen from the side cross(u, v) points to, which is also its normal.
void addQuad(FixtureMesh& mesh, const glm::vec3& centre, const glm::vec3& u, const glm::vec3& v);

// Appends the six faces of an axis-aligned box of full extents `size` centred at `centre`, their
// fronts (and normals) outward or, with `inward`, towards the inside.
void addBox(FixtureMesh& mesh, const glm::vec3& centre, const glm::vec3& size, bool inward);

// A directional light, in the scene's terms.
struct FixtureSun {
    glm::vec3 towardsLight{0.0f, 1.0f, 0.0f}; // normalized on use
    glm::vec3 colour{1.0f};
    float intensity = 1.0f; // lux: the irradiance is colour * intensity
};

// The Cornell box: the interior of a cube of side `size` standing on y = 0 (x and z from -size/2 to
// size/2), its floor, ceiling and back wall (z = -size/2) white, its left wall (x = -size/2) red
// and its right wall green, every wall facing inward and one-sided; an emissive square of side
// `lightSide` just below the ceiling (1/1000 of the size), facing down; with `closed`, a white
// front wall too (no ray from inside escapes); with `innerBoxes`, the short and the tall white
// block, facing outward; with a sun, a directional light.
struct CornellBoxOptions {
    float size = 2.0f;
    float lightSide = 0.5f;
    glm::vec3 lightEmission{10.0f}; // emissiveFactor times emissive strength
    bool closed = false;
    bool innerBoxes = false;
    std::optional<FixtureSun> sun;
    GltfContainer container = GltfContainer::Glb;
};
// The materials in order: white, red, green, light (kCornellWhite, ...).
constexpr glm::vec3 kCornellWhite{0.73f, 0.73f, 0.73f};
constexpr glm::vec3 kCornellRed{0.65f, 0.05f, 0.05f};
constexpr glm::vec3 kCornellGreen{0.12f, 0.45f, 0.15f};
FixtureScene cornellBoxScene(const CornellBoxOptions& options = {});
void writeCornellBoxGltf(const std::string& path, const CornellBoxOptions& options = {});
// A scene as loadGltfScene reads it (written to a temporary .glb, read, removed).
World loadFixtureWorld(const FixtureScene& scene);
World loadCornellBoxWorld(const CornellBoxOptions& options = {});
// The closed Cornell box as a furnace: every material double-sided, albedo 1/2 and emission 1, so
// that every ray meets a wall leaving 1 + 1/2 + ... + 1/2^k at bounce k.
World furnaceWorld();
// The furnace beside a ground triangle 2e5 across, 100 below it, that no ray from inside meets: rays
// leaving a wall start off it by the wall's own scale, not the ground's (3 units, past the walls).
World furnaceBesideAFarGround();

// Loaded once per process and kept, for tests that cast many rays at one scene: 2CylinderEngine.glb
// (121,496 triangles) from the glTF2 folder of Debian's assimp-testmodels, and the Cornell box with
// its two blocks, open at the front so that some rays leave it.
const World& engineWorld(const std::string& modelsFolder);
const World& openCornellBoxWithBlocks();

// Two rooms side by side, each 2 m wide, high and deep: the lit one (x from -2 to 0) open to the
// sky through a 0.5 m square in its ceiling above (-1, 2, 0), with a sun shining in, the closed one
// (x from 0 to 2) shut; between them a wall 2 cm thick. One white material (albedo 0.7), every
// surface facing into its room, one-sided.
FixtureScene twoRoomsScene();
// The mean irradiance (green) a volume gives the floor, back wall and ceiling of the two rooms
// between x0 and x1: points on a 16 x 16 grid of each surface, 1 cm off it (sampleVolumeIrradiance).
double twoRoomsIrradiance(const ProbeVolume& volume, double x0, double x1);

// One axis-aligned box centred at the origin, of one material: with inward faces, closed and of
// uniform emission and albedo, the white furnace of scene probes.
struct BoxOptions {
    glm::vec3 size{1.0f}; // full extents
    glm::vec3 albedo{1.0f};
    glm::vec3 emission{0.0f};
    bool inwardFacing = true;
    bool doubleSided = false;
    GltfContainer container = GltfContainer::Glb;
};
FixtureScene boxScene(const BoxOptions& options = {});
void writeBoxGltf(const std::string& path, const BoxOptions& options = {});

// A hierarchy of transforms: root (translation, rotation and non-uniform scale) -> child (a
// matrix) -> grandchild (translation and rotation) holding a triangle; and, under the root, a node
// holding a directional light. What the reader must give, composed here with glm's matrices:
struct HierarchyFixture {
    FixtureScene scene;
    glm::mat4 meshWorld;  // the triangle's world transform (root * child * grandchild)
    glm::vec3 sunTowards; // unit, towards the light in world space
    glm::vec3 sunIrradiance;
};
HierarchyFixture hierarchyFixture();

// A sky whose every texel differs: radiance (1 + x, 2 + y, 3 + z) from the texel's own direction.
Cubemap directionalSky(int faceSize);

} // namespace shprobe::testing
