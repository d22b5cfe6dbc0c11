#include "render/scene_view.h"

#include "common/scope_exit.h"
#include "glsl/capture_interface.h"
#include "render/meshes.h"
#include "vk/graphics.h"
#include "vk/pipeline.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_scene_spirv.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <glm/geometric.hpp>

namespace shprobe {

namespace {

VkPipeline createProbePipeline(const Device& device, const SceneCapture& capture,
                               const SceneViewTarget& target) {
    const uint32_t order = uint32_t(capture.options.order);
    const VkSpecializationInfo specialization = orderSpecialization(order);
    const VkVertexInputBindingDescription binding{0, sizeof(MeshVertex), VK_VERTEX_INPUT_RATE_VERTEX};
    const std::array<VkVertexInputAttributeDescription, 2> attributes{
        {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, position)},
         {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, normal)}}};
    GraphicsPipelineDesc desc;
    desc.vertex = target.probeVertex;
    desc.fragment = target.probeFragment;
    desc.vertexSpecialization = &specialization;
    desc.fragmentSpecialization = &specialization;
    desc.vertexBindings = {&binding, 1};
    desc.vertexAttributes = attributes;
    desc.depthTest = true;
    desc.depthWrite = true;
    desc.depthCompare = VK_COMPARE_OP_GREATER;
    desc.layout = capture.layout;
    desc.renderPass = capture.renderPass;
    return createGraphicsPipeline(device, desc);
}

double defaultProbeRadius(const BounceGrid& grid) {
    double cell = INFINITY;
    for (int a = 0; a < 3; ++a)
        if (grid.counts[a] > 1)
            cell = std::min(cell, (grid.boundsMax[a] - grid.boundsMin[a]) / (grid.counts[a] - 1));
    return std::isfinite(cell) ? 0.1 * cell : 0.05;
}

} // namespace

glm::mat4 cameraProjection(const SceneCamera& camera, VkExtent2D extent, float nearPlane) {
    const glm::vec3 forward = glm::normalize(glm::vec3(camera.target - camera.eye));
    const glm::vec3 right = glm::normalize(glm::cross(forward, glm::vec3(camera.up)));
    const glm::vec3 down = glm::cross(forward, right);
    const float f = 1.0f / std::tan(float(camera.verticalFovDegrees) * 0.5f * 3.14159265f / 180.0f);
    const float aspect = float(extent.width) / float(extent.height);
    return clipFromRows({right * (f / aspect), down * f, forward}, camera.eye, nearPlane);
}

SceneViewTarget createSceneViewTarget(const Context& context, const SceneCapture& capture, VkExtent2D extent,
                                      VkImageUsageFlags colorUsage) {
    SceneViewTarget target;
    OnFailure undo([&] { destroySceneViewTarget(context, target); });
    static_cast<ColorDepthTarget&>(target) =
        createColorDepthTarget(context, {.renderPass = capture.renderPass,
                                         .extent = extent,
                                         .colorFormat = kCaptureFormat,
                                         .depthFormat = capture.depthFormat,
                                         .colorUsage = colorUsage,
                                         .what = "scene view",
                                         .depthWhat = "scene view depth"});
    target.probeVertex = createShaderModule(context, spirv::capture_probe_vert);
    target.probeFragment = createShaderModule(context, spirv::capture_probe_frag);
    target.probes = createProbePipeline(context, capture, target);
    const MeshData sphere = makeSphereMesh(24, 12);
    const VkBufferUsageFlags upload = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    target.sphereVertices =
        createBuffer(context, sphere.vertices.size() * sizeof(MeshVertex),
                     VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | upload, MemoryUse::Device, "sphere vertices");
    uploadBuffer(context, target.sphereVertices, sphere.vertices.data(), target.sphereVertices.size);
    target.sphereIndices =
        createBuffer(context, sphere.indices.size() * sizeof(uint32_t),
                     VK_BUFFER_USAGE_INDEX_BUFFER_BIT | upload, MemoryUse::Device, "sphere indices");
    uploadBuffer(context, target.sphereIndices, sphere.indices.data(), target.sphereIndices.size);
    target.sphereIndexCount = uint32_t(sphere.indices.size());
    return target;
}

void destroySceneViewTarget(const Device& device, SceneViewTarget& target) {
    destroyBuffer(device, target.sphereIndices);
    destroyBuffer(device, target.sphereVertices);
    if (target.probes) vkDestroyPipeline(device.device, target.probes, nullptr);
    for (VkShaderModule module : {target.probeVertex, target.probeFragment})
        if (module) vkDestroyShaderModule(device.device, module, nullptr);
    destroyColorDepthTarget(device, target);
    target = SceneViewTarget{};
}

void recordSceneView(VkCommandBuffer commands, const SceneCapture& capture, const SceneViewTarget& target,
                     const SceneCamera& camera, const SceneViewOptions& options) {
    const BounceGrid& grid = capture.bounceGrid;
    const float radius = float(options.probeRadius > 0.0 ? options.probeRadius : defaultProbeRadius(grid));
    const glsl::CaptureConstants constants{
        cameraProjection(camera, target.extent, capture.nearPlane), glm::vec4(glm::vec3(camera.eye), radius),
        glm::uvec4(SHPROBE_CAPTURE_CAMERA, 0u, capture.skyFaceSize, uint32_t(capture.suns.size())),
        glm::vec4(float(target.extent.width), float(target.extent.height), 1.0f, 0.0f)};
    const VkClearValue clears[2] = {{}, {.depthStencil = {0.0f, 0}}};
    beginRenderPass(commands, capture.renderPass, target.framebuffer, target.extent, clears);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, capture.layout, 0, 1, &capture.set, 0,
                            nullptr);
    vkCmdPushConstants(commands, capture.layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                       sizeof(constants), &constants);
    recordSkyAndSurfaces(commands, capture);
    const uint32_t probes = uint32_t(grid.counts.x) * uint32_t(grid.counts.y) * uint32_t(grid.counts.z);
    if (options.showProbes && probes > 0) {
        const VkDeviceSize offset = 0;
        vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, target.probes);
        vkCmdBindVertexBuffers(commands, 0, 1, &target.sphereVertices.buffer, &offset);
        vkCmdBindIndexBuffer(commands, target.sphereIndices.buffer, 0, VK_INDEX_TYPE_UINT32);
        vkCmdDrawIndexed(commands, target.sphereIndexCount, probes, 0, 0, 0);
    }
    vkCmdEndRenderPass(commands);
}

} // namespace shprobe
