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
VkRenderPass createSceneRenderPass(const Context& context, VkFormat depthFormat) {
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

    const VkPipelineStageFlags attachmentStages = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                                                  VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                                                  VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    const VkAccessFlags attachmentWrites =
        VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    std::array<VkSubpassDependency, 2> dependencies{};
    // Earlier reads of the targets (tonemap, readback) and writes finish before this pass writes.
    dependencies[0] = {VK_SUBPASS_EXTERNAL,
                       0,
                       attachmentStages | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT |
                           VK_PIPELINE_STAGE_TRANSFER_BIT,
                       attachmentStages,
                       attachmentWrites,
                       attachmentWrites | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
                       0};
    // The results reach the tonemap pass and copies.
    dependencies[1] = {0,
                       VK_SUBPASS_EXTERNAL,
                       VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                       VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                       VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT,
                       0};
    return createRenderPass(context, {attachments, colors, &depth, dependencies});
}

VkDescriptorSetLayout createSceneSetLayout(const Context& context) {
    const std::array<LayoutBinding, 2> bindings{
        {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT},
         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_SHADER_STAGE_FRAGMENT_BIT}}};
    return createSetLayout(context, bindings);
}

// Meshes read vertices and write depth; the background draws at the far plane where nothing was
// drawn.
VkPipeline createScenePipeline(const Context& context, const ScenePipelines& pipelines, PassKind kind,
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
    return createGraphicsPipeline(context, desc);
}

VkPipeline findOrCreate(const Context& context, ScenePipelines& pipelines, PassKind kind,
                        const Scene& scene) {
    if (scene.order < kMinRenderOrder || scene.order > kMaxRenderOrder)
        throw Error(ErrorKind::Input, "render order " + std::to_string(scene.order) + " is outside " +
                                          std::to_string(kMinRenderOrder) + ".." +
                                          std::to_string(kMaxRenderOrder));
    uint32_t key = pipelineKey(kind, scene);
    auto found = pipelines.pipelines.find(key);
    if (found != pipelines.pipelines.end()) return found->second;
    VkPipeline pipeline = createScenePipeline(context, pipelines, kind, scene);
    pipelines.pipelines[key] = pipeline;
    return pipeline;
}

} // namespace

ScenePipelines createScenePipelines(const Context& context) {
    ScenePipelines pipelines;
    OnFailure undo([&] { destroyScenePipelines(context, pipelines); });
    pipelines.depthFormat = pickDepthFormat(context);
    pipelines.renderPass = createSceneRenderPass(context, pipelines.depthFormat);
    pipelines.setLayout = createSceneSetLayout(context);
    pipelines.layout = createPipelineLayout(context, pipelines.setLayout,
                                            VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                                            sizeof(glsl::ObjectConstants));
    pipelines.sceneVertex = createShaderModule(context, spirv::scene_vert);
    pipelines.sceneFragment = createShaderModule(context, spirv::scene_frag);
    pipelines.fullscreenVertex = createShaderModule(context, spirv::fullscreen_vert);
    pipelines.backgroundFragment = createShaderModule(context, spirv::background_frag);
    return pipelines;
}

void destroyScenePipelines(const Context& context, ScenePipelines& pipelines) {
    for (auto& [key, pipeline] : pipelines.pipelines)
        vkDestroyPipeline(context.device, pipeline, nullptr);
    for (VkShaderModule module : {pipelines.backgroundFragment, pipelines.fullscreenVertex,
                                  pipelines.sceneFragment, pipelines.sceneVertex})
        if (module) vkDestroyShaderModule(context.device, module, nullptr);
    if (pipelines.layout) vkDestroyPipelineLayout(context.device, pipelines.layout, nullptr);
    if (pipelines.setLayout) vkDestroyDescriptorSetLayout(context.device, pipelines.setLayout, nullptr);
    if (pipelines.renderPass) vkDestroyRenderPass(context.device, pipelines.renderPass, nullptr);
    pipelines = ScenePipelines{};
}

VkPipeline meshPipeline(const Context& context, ScenePipelines& pipelines, const Scene& scene) {
    return findOrCreate(context, pipelines, PassKind::Mesh, scene);
}

VkPipeline backgroundPipeline(const Context& context, ScenePipelines& pipelines, const Scene& scene) {
    return findOrCreate(context, pipelines, PassKind::Background, scene);
}

} // namespace shprobe
