#include "shprobe/render/scene_pipelines.h"

#include "shprobe/glsl/render_interface.h"
#include "shprobe/render/gpu_image.h"
#include "shprobe/render/meshes.h"
#include "shprobe/sh/error.h"
#include "shprobe/shprobe_render_spirv.h"
#include "shprobe/vk/check.h"

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

VkAttachmentDescription colorAttachment(VkFormat format, VkImageLayout finalLayout) {
    VkAttachmentDescription attachment{};
    attachment.format = format;
    attachment.samples = VK_SAMPLE_COUNT_1_BIT;
    attachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachment.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachment.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachment.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    attachment.finalLayout = finalLayout;
    return attachment;
}

// Colour ends ready for the tonemap pass, the direction for readback; depth is not kept.
VkRenderPass createSceneRenderPass(const Context& context, VkFormat depthFormat) {
    VkAttachmentDescription depth =
        colorAttachment(depthFormat, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
    depth.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    std::array<VkAttachmentDescription, 3> attachments{
        colorAttachment(kSceneColorFormat, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL),
        colorAttachment(kSceneDirectionFormat, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL), depth};
    std::array<VkAttachmentReference, 2> colors{
        {{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}, {1, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}}};
    VkAttachmentReference depthReference{2, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = uint32_t(colors.size());
    subpass.pColorAttachments = colors.data();
    subpass.pDepthStencilAttachment = &depthReference;

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

    VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    info.attachmentCount = uint32_t(attachments.size());
    info.pAttachments = attachments.data();
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = uint32_t(dependencies.size());
    info.pDependencies = dependencies.data();
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VK_CHECK(vkCreateRenderPass(context.device, &info, nullptr, &renderPass));
    return renderPass;
}

VkDescriptorSetLayout createSceneSetLayout(const Context& context) {
    std::array<VkDescriptorSetLayoutBinding, 2> bindings{
        {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
          nullptr},
         {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr}}};
    VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    info.bindingCount = uint32_t(bindings.size());
    info.pBindings = bindings.data();
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorSetLayout(context.device, &info, nullptr, &layout));
    return layout;
}

VkPipelineLayout createScenePipelineLayout(const Context& context, VkDescriptorSetLayout setLayout) {
    VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                              sizeof(gpu::ObjectConstants)};
    VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    info.setLayoutCount = 1;
    info.pSetLayouts = &setLayout;
    info.pushConstantRangeCount = 1;
    info.pPushConstantRanges = &range;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreatePipelineLayout(context.device, &info, nullptr, &layout));
    return layout;
}

// Fixed-function state of a scene pipeline; meshes read vertices and write depth, the background
// draws at the far plane where nothing was drawn.
struct FixedState {
    VkPipelineVertexInputStateCreateInfo vertexInput{
        VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    VkVertexInputBindingDescription binding{0, sizeof(MeshVertex), VK_VERTEX_INPUT_RATE_VERTEX};
    std::array<VkVertexInputAttributeDescription, 2> attributes{
        {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, position)},
         {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, normal)}}};
    VkPipelineInputAssemblyStateCreateInfo assembly{
        VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
    VkPipelineViewportStateCreateInfo viewport{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
    VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
    VkPipelineMultisampleStateCreateInfo multisample{
        VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
    VkPipelineDepthStencilStateCreateInfo depth{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
    std::array<VkPipelineColorBlendAttachmentState, 2> blendAttachments{};
    VkPipelineColorBlendStateCreateInfo blend{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    std::array<VkDynamicState, 2> dynamicStates{VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};

    explicit FixedState(PassKind kind) {
        const bool mesh = kind == PassKind::Mesh;
        vertexInput.vertexBindingDescriptionCount = mesh ? 1 : 0;
        vertexInput.pVertexBindingDescriptions = &binding;
        vertexInput.vertexAttributeDescriptionCount = mesh ? uint32_t(attributes.size()) : 0;
        vertexInput.pVertexAttributeDescriptions = attributes.data();
        assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
        viewport.viewportCount = 1;
        viewport.scissorCount = 1;
        raster.polygonMode = VK_POLYGON_MODE_FILL;
        raster.cullMode = mesh ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE;
        raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE; // y-flipped projection keeps CCW on screen
        raster.lineWidth = 1.0f;
        multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
        depth.depthTestEnable = VK_TRUE;
        depth.depthWriteEnable = mesh ? VK_TRUE : VK_FALSE;
        depth.depthCompareOp = mesh ? VK_COMPARE_OP_LESS : VK_COMPARE_OP_LESS_OR_EQUAL;
        for (VkPipelineColorBlendAttachmentState& attachment : blendAttachments)
            attachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                        VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
        blend.attachmentCount = uint32_t(blendAttachments.size());
        blend.pAttachments = blendAttachments.data();
        dynamic.dynamicStateCount = uint32_t(dynamicStates.size());
        dynamic.pDynamicStates = dynamicStates.data();
    }
};

VkPipeline createScenePipeline(const Context& context, const ScenePipelines& pipelines, PassKind kind,
                               const Scene& scene) {
    // Specialization constants SHPROBE_SPEC_RENDER_ORDER, _SHADING, _BACKGROUND (render_interface.h).
    std::array<uint32_t, 3> values{uint32_t(scene.order), uint32_t(scene.shading),
                                   uint32_t(scene.background)};
    std::array<VkSpecializationMapEntry, 3> entries{
        {{SHPROBE_SPEC_RENDER_ORDER, 0, 4}, {SHPROBE_SPEC_SHADING, 4, 4}, {SHPROBE_SPEC_BACKGROUND, 8, 4}}};
    VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(), sizeof(values),
                                        values.data()};
    const bool mesh = kind == PassKind::Mesh;
    std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
    for (VkPipelineShaderStageCreateInfo& stage : stages) {
        stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
        stage.pName = "main";
        stage.pSpecializationInfo = &specialization;
    }
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = mesh ? pipelines.sceneVertex : pipelines.fullscreenVertex;
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = mesh ? pipelines.sceneFragment : pipelines.backgroundFragment;

    FixedState state(kind);
    VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    info.stageCount = uint32_t(stages.size());
    info.pStages = stages.data();
    info.pVertexInputState = &state.vertexInput;
    info.pInputAssemblyState = &state.assembly;
    info.pViewportState = &state.viewport;
    info.pRasterizationState = &state.raster;
    info.pMultisampleState = &state.multisample;
    info.pDepthStencilState = &state.depth;
    info.pColorBlendState = &state.blend;
    info.pDynamicState = &state.dynamic;
    info.layout = pipelines.layout;
    info.renderPass = pipelines.renderPass;
    VkPipeline pipeline = VK_NULL_HANDLE;
    VK_CHECK(vkCreateGraphicsPipelines(context.device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    return pipeline;
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

VkShaderModule createShaderModule(const Context& context, const uint32_t* words, size_t wordCount) {
    VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    info.codeSize = wordCount * sizeof(uint32_t);
    info.pCode = words;
    VkShaderModule module = VK_NULL_HANDLE;
    VK_CHECK(vkCreateShaderModule(context.device, &info, nullptr, &module));
    return module;
}

ScenePipelines createScenePipelines(const Context& context) {
    ScenePipelines pipelines;
    try {
        pipelines.depthFormat = pickDepthFormat(context);
        pipelines.renderPass = createSceneRenderPass(context, pipelines.depthFormat);
        pipelines.setLayout = createSceneSetLayout(context);
        pipelines.layout = createScenePipelineLayout(context, pipelines.setLayout);
        pipelines.sceneVertex =
            createShaderModule(context, spirv::scene_vert.data(), spirv::scene_vert.size());
        pipelines.sceneFragment =
            createShaderModule(context, spirv::scene_frag.data(), spirv::scene_frag.size());
        pipelines.fullscreenVertex =
            createShaderModule(context, spirv::fullscreen_vert.data(), spirv::fullscreen_vert.size());
        pipelines.backgroundFragment =
            createShaderModule(context, spirv::background_frag.data(), spirv::background_frag.size());
    } catch (...) {
        destroyScenePipelines(context, pipelines);
        throw;
    }
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
