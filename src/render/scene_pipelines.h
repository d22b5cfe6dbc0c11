// The scene pass's Vulkan objects: its render pass (linear colour RGBA32F, direction RGBA32F,
// depth), descriptor-set and pipeline layouts, and graphics pipelines for meshes and the background,
// specialized by SH order, shading mode and background kind (created on first use).
#pragma once
#include "render/scene.h"
#include "vk/context.h"

#include <cstdint>
#include <map>

namespace shprobe {

constexpr VkFormat kSceneColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;     // linear radiance
constexpr VkFormat kSceneDirectionFormat = VK_FORMAT_R32G32B32A32_SFLOAT; // see render_interface.h

struct ScenePipelines {
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VkFormat depthFormat = VK_FORMAT_UNDEFINED;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE; // 0: RenderUniforms, 1: environment cube
    VkPipelineLayout layout = VK_NULL_HANDLE;         // + ObjectConstants push constants
    VkShaderModule sceneVertex = VK_NULL_HANDLE;
    VkShaderModule sceneFragment = VK_NULL_HANDLE;
    VkShaderModule fullscreenVertex = VK_NULL_HANDLE;
    VkShaderModule backgroundFragment = VK_NULL_HANDLE;
    std::map<uint32_t, VkPipeline> pipelines; // by pipelineKey
};

ScenePipelines createScenePipelines(const Device& device);
void destroyScenePipelines(const Device& device, ScenePipelines& pipelines);

// The pipeline that draws meshes (or the background) of the scene's order and shading (and
// background kind); created on first use.
VkPipeline meshPipeline(const Device& device, ScenePipelines& pipelines, const Scene& scene);
VkPipeline backgroundPipeline(const Device& device, ScenePipelines& pipelines, const Scene& scene);

} // namespace shprobe
