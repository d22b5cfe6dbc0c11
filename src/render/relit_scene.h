// A scene with per-vertex transfer (`shprobe transfer`) relit by a light's radiance coefficients,
// turned on the device each frame by the rotation module (gpu/rotator.h): rotate.comp writes the
// turned coefficients into a storage buffer and relight.vert sums L_out = sum_i T_i L_i per vertex
// from the _SH_TRANSFER_k attributes (src/glsl/relight_vertex.glsl). `render --scene --transfer`
// and `view --scene --transfer` draw it.
//
//   RelitScene relit = createRelitScene(context, mesh, light);      // light: mesh.order radiance
//   RelitTarget target = createRelitTarget(context, relit, {640, 480}, VK_IMAGE_USAGE_SAMPLED_BIT);
//   setLightRotation(relit, R);
//   recordRelitView(commands, relit, target, clipFromWorld);        // colour left for the tonemap
#pragma once
#include "gpu/rotator.h"
#include "scene/transfer_mesh.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"
#include "vk/context.h"
#include "vk/graphics.h"
#include "vk/resources.h"

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <optional>
#include <string>

namespace shprobe {

// What a relit scene is lit by: a probe's radiance coefficients (cut or padded with zeros to the
// transfer's order by the caller) or a sky, baked on the device at the transfer's order.
struct RelitLight {
    std::string name; // the probe's or sky's path, or "the built-in sky"
    std::optional<ShCoefficients> probe;
    Cubemap sky; // when there is no probe
};
// The light's radiance coefficients at `order`.
ShCoefficients relitLightCoefficients(const Context& context, const RelitLight& light, int order);

// The transfer attributes a device can give relight.vert (or relight_wide.vert): the largest of
// their capacities that fits maxVertexInputAttributes beside the position.
int maxTransferAttributes(const Device& device);

struct RelitScene {
    int order = 0;
    int channels = 0;
    int attributes = 0; // the file's; the pipeline pads to the shader's capacity
    Buffer positions;
    Buffer transfer;
    Buffer zeros; // the attributes the file has not, read at stride 0
    Buffer indices;
    uint32_t indexCount = 0;
    Rotator rotator;
    RotatedProbe light;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VkShaderModule vertex = VK_NULL_HANDLE;
    VkShaderModule fragment = VK_NULL_HANDLE;
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    float nearPlane = 0.0f;
};

// Throws Error(Input), naming maxVertexInputAttributes, for a transfer that needs more attributes
// than the device gives; `light` must be radiance of the mesh's order.
RelitScene createRelitScene(const Context& context, const TransferMesh& mesh, const ShCoefficients& light);
void destroyRelitScene(const Device& device, RelitScene& relit);
// The light turned by R (a light from d comes from R d); not while a recorded view may run.
void setLightRotation(const RelitScene& relit, const glm::dmat3& R);

// The picture: colour (RGBA32F, linear, ending in SHADER_READ_ONLY_OPTIMAL) and depth.
using RelitTarget = ColorDepthTarget;
RelitTarget createRelitTarget(const Context& context, const RelitScene& relit, VkExtent2D extent,
                              VkImageUsageFlags colorUsage);

// Records the light's rotation and the draw (background black) into target.color.
void recordRelitView(VkCommandBuffer commands, const RelitScene& relit, const RelitTarget& target,
                     const glm::mat4& clipFromWorld);

} // namespace shprobe
