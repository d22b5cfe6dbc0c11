#include "render/lit_scene.h"

#include "common/scope_exit.h"
#include "render/scene.h"
#include "vk/image.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace shprobe {

namespace {
constexpr double kFovDegrees = 45.0;
}

SceneCapture createLitSceneCapture(const Context& context, const LitScene& scene) {
    SceneCapture capture = createSceneCapture(context, scene.world, scene.sky, {.order = scene.volume.order});
    OnFailure undo([&] { destroySceneCapture(context, capture); });
    const ProbeVolume& volume = scene.volume;
    const std::vector<glm::dvec3> irradiance(volume.irradiance.begin(), volume.irradiance.end());
    setBounceSource(context, capture,
                    {volume.grid.boundsMin, volume.grid.boundsMax, volume.grid.counts, volume.order,
                     irradiance, volume.valid, volume.visibilitySize, volume.visibility, volume.offsets});
    return capture;
}

SceneCamera orbitSceneCamera(const World& world, float yawDegrees, float pitchDegrees, float zoom) {
    const glm::dvec3 centre = 0.5 * glm::dvec3(world.boundsMin + world.boundsMax);
    const double radius = 0.5 * glm::length(glm::dvec3(world.boundsMax - world.boundsMin));
    // The bounding sphere fills the vertical field of view at this distance, at any scale (a point
    // of a scene: a unit sphere).
    const double distance = (radius > 0.0 ? radius : 1.0) / std::sin(kFovDegrees * 0.5 * M_PI / 180.0);
    const Camera orbit = orbitCamera(yawDegrees, pitchDegrees, float(distance * zoom), float(kFovDegrees));
    return {centre + glm::dvec3(orbit.position), centre, glm::dvec3(0.0, 1.0, 0.0), kFovDegrees};
}

float volumeExposure(const ProbeVolume& volume) {
    const size_t perProbe = size_t(volume.order) * volume.order;
    double sum = 0.0;
    size_t valid = 0;
    for (size_t p = 0; p < volume.valid.size(); ++p) {
        if (!volume.valid[p]) continue;
        const glm::vec3 l00 = volume.radiance.empty() ? volume.irradiance[p * perProbe] / float(M_PI)
                                                      : volume.radiance[p * perProbe];
        sum += glm::dot(glm::dvec3(l00), glm::dvec3(0.2126, 0.7152, 0.0722)) / std::sqrt(4.0 * M_PI);
        ++valid;
    }
    const double mean = valid > 0 ? sum / double(valid) : 0.0;
    return mean > 0.0 ? float(0.18 / mean) : 1.0f;
}

void recordLitSceneView(VkCommandBuffer commands, const SceneCapture& capture, const SceneViewTarget& target,
                        const SceneCamera& camera, const SceneViewOptions& options) {
    recordSceneView(commands, capture, target, camera, options);
    changeLayout(commands, target.color,
                 {VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                  VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                  VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT});
}

} // namespace shprobe
