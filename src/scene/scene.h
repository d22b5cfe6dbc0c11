// The world to bake light probes in (a glTF scene): triangles in world space, diffuse materials, directional
// suns. Plain data, no Vulkan: the glTF reader (scene/gltf_scene.h) fills it, the GPU capture
// (gpu/scene_capture.h) and the ray-traced reference (scene/reference_tracer.h) read it.
//
// The light transport both follow (docs/scene-probes.md): a probe at p looking along w sees the
// first surface the ray p + t w hits, or the sky's radiance along w where it hits none. A front
// face (geometric normal against w; either face of a double-sided material, its normal flipped)
// leaves
//   L = emission + albedo / pi * (sum over suns of E_sun max(0, n.l) V(x, l) + E_bounce(x, n))
// where V is 1 where nothing lies between x and the sun, and E_bounce is the irradiance of the
// previous bounce (none for bounce 0). A back face of a one-sided material leaves nothing: it is
// the inside of something.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <string>
#include <vector>

namespace shprobe {

// A texture decoded to linear RGBA (sRGB-encoded images decoded as glTF says for colour
// textures), rows top to bottom as stored; sampled bilinearly with repeat, as glTF's default
// sampler does.
struct SceneTexture {
    int width = 0;
    int height = 0;
    std::vector<glm::vec4> texels; // width * height
};

// glTF's metallic-roughness material seen as a diffuse surface: base colour as albedo.
struct SceneMaterial {
    glm::vec3 albedo{1.0f};   // baseColorFactor.rgb
    int albedoTexture = -1;   // index into World::textures, multiplied by albedo; -1: none
    glm::vec3 emission{0.0f}; // emissiveFactor times KHR_materials_emissive_strength
    int emissionTexture = -1; // multiplied by emission; -1: none
    bool doubleSided = false;
};

// KHR_lights_punctual's directional light: irradiance `irradiance` (colour times intensity, lux
// as the extension says) on a surface facing it, arriving from `direction`.
struct SceneSun {
    glm::vec3 direction{0.0f, 1.0f, 0.0f}; // unit vector towards the light
    glm::vec3 irradiance{1.0f};
};

// Every triangle of every mesh instance, flattened into world space (node transforms applied,
// normals by the inverse transpose and normalized). Vertex i has positions[i], normals[i] and
// uvs[i]; triangle t is indices[3t..3t+2], counter-clockwise seen from its front, with material
// triangleMaterials[t].
struct World {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;
    std::vector<glm::vec2> uvs; // TEXCOORD_0; (0, 0) where the mesh has none
    std::vector<uint32_t> indices;
    std::vector<uint32_t> triangleMaterials;
    std::vector<SceneMaterial> materials;
    std::vector<SceneTexture> textures;
    std::vector<SceneSun> suns;
    glm::vec3 boundsMin{0.0f}; // of every position
    glm::vec3 boundsMax{0.0f};
    std::string description; // e.g. "box.glb (12 triangles, 1 material, 1 sun)"

    size_t triangleCount() const { return indices.size() / 3; }
};

// Triangle t's corners, in double: areas, normals and edge lengths are taken in double.
inline std::array<glm::dvec3, 3> triangleCorners(const World& world, size_t triangle) {
    const uint32_t* vertex = &world.indices[3 * triangle];
    return {glm::dvec3(world.positions[vertex[0]]), glm::dvec3(world.positions[vertex[1]]),
            glm::dvec3(world.positions[vertex[2]])};
}

// Whether triangle t has any area: no ray meets one whose corners lie on a line, so it neither
// shades nor gathers anything.
inline bool hasArea(const World& world, size_t triangle) {
    const auto [p0, p1, p2] = triangleCorners(world, triangle);
    return glm::cross(p1 - p0, p2 - p0) != glm::dvec3(0.0);
}

} // namespace shprobe
