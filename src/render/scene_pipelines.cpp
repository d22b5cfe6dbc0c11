#include "render/scene_pipelines.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/render_interface.h"
#include "render/gpu_image.h"
#include "render/meshes.h"
#include "vk/graphics.h"
#include "vk/pipeline.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_render_spirv.h>
#include <shprobe/shprobe_spirv.h>

#include <array>
#include <cstddef>

namespace shprobe {

namespace {

enum class PassKind : uint32_t { Mesh, Background };

// Meshes do not depend on the background kind.
uint32_t pipelineKey(PassKind kind, const Scene& scene) {
    uint32_t background = kind == PassKind::Background ? uint32_t(scene.background) : 0u;
    return uint32_t(kind) | uint32_t(scene.order) << 4 | uint32_t(scene.shading) << 8 | background << 12;
}

// Colour ends ready for the tonemap pass, the direction for readback; depth is not kept.
VkRenderPass createSceneRenderPass(const Device& device, VkFormat depthFormat) {
    const std::array<VkAttachmentDescription, 3> attachments{
        attachmentDescription(kSceneColorFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_STORE,
                              VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL),
        attachmentDescription(kSceneDirectionFormat, VK_ATTACHMENT_LOAD_OP_CLEAR,
                              VK_ATTACHMENT_STORE_OP_STORE, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
        attachmentDescription(depthFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_DONT_CARE,
                              VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)};
    const std::array<VkAttachmentReference, 2> colors{
        {{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}, {1, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}}};
    const VkAttachmentReference depth{2, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    // The targets are read by the tonemap pass and copies, before this pass and after it.
    const VkPipelineStageFlags readers =
        VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
    const std::array<VkSubpassDependency, 2> dependencies = attachmentDependencies(readers, readers);
    return createRenderPass(device, {attachments, colors, &depth, dependencies});
}

VkDescriptorSetLayout createSceneSetLayout(const Device& device) {
    const std::array<LayoutBinding, 2> bindings{
        {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT},
         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_SHADER_STAGE_FRAGMENT_BIT}}};
    return createSetLayout(device, bindings);
}

// Meshes read vertices and write depth; the background draws at the far plane where nothing was
// drawn.
VkPipeline createScenePipeline(const Device& device, const ScenePipelines& pipelines, PassKind kind,
                               const Scene& scene) {
    // Specialization constants SHPROBE_SPEC_RENDER_ORDER, _SHADING, _BACKGROUND (render_interface.h).
    std::array<uint32_t, 3> values{uint32_t(scene.order), uint32_t(scene.shading),
                                   uint32_t(scene.background)};
    std::array<VkSpecializationMapEntry, 3> entries{
        {{SHPROBE_SPEC_RENDER_ORDER, 0, 4}, {SHPROBE_SPEC_SHADING, 4, 4}, {SHPROBE_SPEC_BACKGROUND, 8, 4}}};
    VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(), sizeof(values),
                                        values.data()};
    const VkVertexInputBindingDescription binding{0, sizeof(MeshVertex), VK_VERTEX_INPUT_RATE_VERTEX};
    const std::array<VkVertexInputAttributeDescription, 2> attributes{
        {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, position)},
         {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, normal)}}};
    const bool mesh = kind == PassKind::Mesh;
    GraphicsPipelineDesc desc;
    desc.vertex = mesh ? pipelines.sceneVertex : pipelines.fullscreenVertex;
    desc.fragment = mesh ? pipelines.sceneFragment : pipelines.backgroundFragment;
    desc.vertexSpecialization = &specialization;
    desc.fragmentSpecialization = &specialization;
    if (mesh) {
        desc.vertexBindings = {&binding, 1};
        desc.vertexAttributes = attributes;
    }
    // The y-flipped projection keeps counter-clockwise front faces counter-clockwise on screen.
    desc.cullMode = mesh ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE;
    desc.depthTest = true;
    desc.depthWrite = mesh;
    desc.depthCompare = mesh ? VK_COMPARE_OP_LESS : VK_COMPARE_OP_LESS_OR_EQUAL;
    desc.colorAttachments = 2;
    desc.layout = pipelines.layout;
    desc.renderPass = pipelines.renderPass;
    return createGraphicsPipeline(device, desc);
}

VkPipeline findOrCreate(const Device& device, ScenePipelines& pipelines, PassKind kind, const Scene& scene) {
    if (scene.order < kMinRenderOrder || scene.order > kMaxRenderOrder)
        throw Error(ErrorKind::Input, "render order " + std::to_string(scene.order) + " is outside " +
                                          std::to_string(kMinRenderOrder) + ".." +
                                          std::to_string(kMaxRenderOrder));
    uint32_t key = pipelineKey(kind, scene);
    auto found = pipelines.pipelines.find(key);
    if (found != pipelines.pipelines.end()) return found->second;
    VkPipeline pipeline = createScenePipeline(device, pipelines, kind, scene);
    pipelines.pipelines[key] = pipeline;
    return pipeline;
}

} // namespace

ScenePipelines createScenePipelines(const Device& device) {
    ScenePipelines pipelines;
    OnFailure undo([&] { destroyScenePipelines(device, pipelines); });
    pipelines.depthFormat = pickDepthFormat(device);
    pipelines.renderPass = createSceneRenderPass(device, pipelines.depthFormat);
    pipelines.setLayout = createSceneSetLayout(device);
    pipelines.layout = createPipelineLayout(device, pipelines.setLayout,
                                            VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                                            sizeof(glsl::ObjectConstants));
    pipelines.sceneVertex = createShaderModule(device, spirv::scene_vert);
    pipelines.sceneFragment = createShaderModule(device, spirv::scene_frag);
    pipelines.fullscreenVertex = createShaderModule(device, spirv::fullscreen_vert);
    pipelines.backgroundFragment = createShaderModule(device, spirv::background_frag);
    return pipelines;
}

void destroyScenePipelines(const Device& device, ScenePipelines& pipelines) {
    for (auto& [key, pipeline] : pipelines.pipelines)
        vkDestroyPipeline(device.device, pipeline, nullptr);
    for (VkShaderModule module : {pipelines.backgroundFragment, pipelines.fullscreenVertex,
                                  pipelines.sceneFragment, pipelines.sceneVertex})
        if (module) vkDestroyShaderModule(device.device, module, nullptr);
    if (pipelines.layout) vkDestroyPipelineLayout(device.device, pipelines.layout, nullptr);
    if (pipelines.setLayout) vkDestroyDescriptorSetLayout(device.device, pipelines.setLayout, nullptr);
    if (pipelines.renderPass) vkDestroyRenderPass(device.device, pipelines.renderPass, nullptr);
    pipelines = ScenePipelines{};
}

VkPipeline meshPipeline(const Device& device, ScenePipelines& pipelines, const Scene& scene) {
    return findOrCreate(device, pipelines, PassKind::Mesh, scene);
}

VkPipeline backgroundPipeline(const Device& device, ScenePipelines& pipelines, const Scene& scene) {
    return findOrCreate(device, pipelines, PassKind::Background, scene);
}

} // namespace shprobe
