// What to render: a camera, shapes lit by the probe, and what the background shows. Plain data;
// the renderer (scene_renderer.h) draws it.
#pragma once
#include "render/probe_shading.h"

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <string>
#include <vector>

namespace shprobe {

enum class Shape { Sphere, Torus };

enum class Background {
    Color,       // Scene::backgroundColor
    Environment, // the environment cube map
    Radiance,    // the SH reconstruction L(d) at the scene's order
    Shading,     // what a white surface of normal d shows in the scene's shading mode
};

// "color", "environment", "radiance" ("sh"), "shading"; parse throws Error(Input) otherwise.
const char* backgroundName(Background background);
Background parseBackground(const std::string& name);

enum class Projection {
    Perspective,
    Panorama, // every direction in the equirect layout of docs/conventions.md; shapes are not drawn
};

struct Camera {
    Projection projection = Projection::Perspective;
    glm::vec3 position{0.0f, 0.0f, 3.2f};
    glm::vec3 target{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float verticalFovDegrees = 40.0f;
    float nearPlane = 0.05f;
    float farPlane = 100.0f;
};

// A camera on a sphere around the origin: yaw about +Y from +Z towards +X, pitch up from the
// horizon, both in degrees.
Camera orbitCamera(float yawDegrees, float pitchDegrees, float distance, float verticalFovDegrees = 40.0f);

// World -> clip for Vulkan (y down, depth 0..1) at the given aspect ratio (width / height).
glm::mat4 viewProjection(const Camera& camera, float aspect);

struct SceneObject {
    Shape shape = Shape::Sphere;
    glm::mat4 model{1.0f}; // rotation, uniform scale, translation
    glm::vec3 albedo{0.8f};
};

struct Scene {
    Camera camera;
    std::vector<SceneObject> objects;
    Background background = Background::Environment;
    glm::vec3 backgroundColor{0.0f};
    int order = 3; // 3 or 5 (4 works too)
    ShadingMode shading = ShadingMode::Irradiance;
};

// One unit sphere at the origin, seen by `camera`.
Scene sphereScene(const Camera& camera, int order, ShadingMode shading, Background background);

// The viewer's scene: the sphere and a torus around it, tilted so both sides show.
Scene viewerScene(const Camera& camera, int order, ShadingMode shading, Background background);

} // namespace shprobe
