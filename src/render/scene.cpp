#include "render/scene.h"

#include "common/error.h"

#include <cmath>
#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>

namespace shprobe {

const char* backgroundName(Background background) {
    switch (background) {
    case Background::Color:
        return "color";
    case Background::Environment:
        return "environment";
    case Background::Radiance:
        return "radiance";
    case Background::Shading:
        return "shading";
    }
    return "?";
}

Background parseBackground(const std::string& name) {
    if (name == "sh") return Background::Radiance;
    for (Background background :
         {Background::Color, Background::Environment, Background::Radiance, Background::Shading})
        if (name == backgroundName(background)) return background;
    throw Error(ErrorKind::Input,
                "unknown background '" + name + "' (environment, radiance or sh, shading, color)");
}

Camera orbitCamera(float yawDegrees, float pitchDegrees, float distance, float verticalFovDegrees) {
    float yaw = glm::radians(yawDegrees), pitch = glm::radians(pitchDegrees);
    Camera camera;
    camera.position = distance * glm::vec3(std::cos(pitch) * std::sin(yaw), std::sin(pitch),
                                           std::cos(pitch) * std::cos(yaw));
    camera.verticalFovDegrees = verticalFovDegrees;
    return camera;
}

glm::mat4 viewProjection(const Camera& camera, float aspect) {
    glm::mat4 projection = glm::perspectiveRH_ZO(glm::radians(camera.verticalFovDegrees), aspect,
                                                 camera.nearPlane, camera.farPlane);
    projection[1][1] = -projection[1][1]; // Vulkan's clip space has y down
    return projection * glm::lookAtRH(camera.position, camera.target, camera.up);
}

Scene sphereScene(const Camera& camera, int order, ShadingMode shading, Background background) {
    Scene scene;
    scene.camera = camera;
    scene.objects.push_back(SceneObject{});
    scene.order = order;
    scene.shading = shading;
    scene.background = background;
    return scene;
}

Scene viewerScene(const Camera& camera, int order, ShadingMode shading, Background background) {
    Scene scene = sphereScene(camera, order, shading, background);
    SceneObject torus;
    torus.shape = Shape::Torus;
    torus.model = glm::rotate(glm::mat4(1.0f), glm::radians(25.0f), glm::vec3(1.0f, 0.0f, 0.0f));
    torus.albedo = glm::vec3(0.8f, 0.55f, 0.35f);
    scene.objects.push_back(torus);
    scene.objects[0].model = glm::scale(glm::mat4(1.0f), glm::vec3(0.75f));
    return scene;
}

} // namespace shprobe
