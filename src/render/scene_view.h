// A view of a scene's world through a camera, drawn with its capture's pipelines (gpu/scene_capture.h):
//
//   SceneViewTarget target = createSceneViewTarget(context, capture, {640, 480}, VK_IMAGE_USAGE_SAMPLED_BIT);
//   recordSceneView(commands, capture, target, camera, {.showProbes = true});
#pragma once
#include "gpu/scene_capture.h"
#include "vk/context.h"
#include "vk/graphics.h"
#include "vk/resources.h"

#include <cstdint>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

namespace shprobe {

// A picture of the world lit by the capture's bounce source: what a probe there would see, through
// a camera (reversed depth, infinitely far), with the probes as small spheres if asked.
struct SceneCamera {
    glm::dvec3 eye{0.0, 0.0, 3.0};
    glm::dvec3 target{0.0};
    glm::dvec3 up{0.0, 1.0, 0.0};
    double verticalFovDegrees = 45.0;
};

// World -> clip of a camera: as faceProjection, with the camera's axes (y down, as Vulkan's clip
// space is) scaled by the field of view; reversed depth, the near plane at 1, infinitely far at 0.
glm::mat4 cameraProjection(const SceneCamera& camera, VkExtent2D extent, float nearPlane);

struct SceneViewOptions {
    bool showProbes = false;  // each probe of the bounce source, shaded by its own SH (red: invalid)
    double probeRadius = 0.0; // 0: a tenth of the grid's smallest cell
};

// The view's colour (RGBA32F, left in GENERAL) and depth, its framebuffer, and the pipeline and
// sphere mesh of the probes.
struct SceneViewTarget : ColorDepthTarget {
    VkShaderModule probeVertex = VK_NULL_HANDLE;
    VkShaderModule probeFragment = VK_NULL_HANDLE;
    VkPipeline probes = VK_NULL_HANDLE;
    Buffer sphereVertices;
    Buffer sphereIndices;
    uint32_t sphereIndexCount = 0;
};
// `colorUsage` is added to the colour image's (e.g. SAMPLED for a tonemap pass, TRANSFER_SRC).
SceneViewTarget createSceneViewTarget(const Context& context, const SceneCapture& capture, VkExtent2D extent,
                                      VkImageUsageFlags colorUsage);
void destroySceneViewTarget(const Device& device, SceneViewTarget& target);
// Records the view into target.color, left in GENERAL, visible to fragment-shader reads and
// transfers.
void recordSceneView(VkCommandBuffer commands, const SceneCapture& capture, const SceneViewTarget& target,
                     const SceneCamera& camera, const SceneViewOptions& options);

} // namespace shprobe
