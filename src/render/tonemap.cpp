#include "shprobe/render/tonemap.h"

#include "shprobe/glsl/render_interface.h"
#include "shprobe/render/gpu_image.h"
#include "shprobe/render/scene_pipelines.h"
#include "shprobe/shprobe_render_spirv.h"
#include "shprobe/vk/check.h"

#include <array>

namespace shprobe {

namespace {

bool isSrgb(VkFormat format) {
    return format == VK_FORMAT_R8G8B8A8_SRGB || format == VK_FORMAT_B8G8R8A8_SRGB ||
           format == VK_FORMAT_A8B8G8R8_SRGB_PACK32;
}

VkRenderPass createTonemapRenderPass(const Context& context, VkFormat format, VkImageLayout finalLayout) {
    VkAttachmentDescription attachment{};
    attachment.format = format;
    attachment.samples = VK_SAMPLE_COUNT_1_BIT;
    attachment.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE; // every pixel is written
    attachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachment.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachment.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachment.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    attachment.finalLayout = finalLayout;
    VkAttachmentReference reference{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &reference;
    std::array<VkSubpassDependency, 2> dependencies{};
    // Waits for the image: the swapchain's acquire semaphore waits at this stage; earlier copies.
    dependencies[0] = {VK_SUBPASS_EXTERNAL,
                       0,
                       VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                       0,
                       VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                       0};
    dependencies[1] = {0,
                       VK_SUBPASS_EXTERNAL,
                       VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                       VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT,
                       VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                       VK_ACCESS_TRANSFER_READ_BIT,
                       0};
    VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    info.attachmentCount = 1;
    info.pAttachments = &attachment;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = uint32_t(dependencies.size());
    info.pDependencies = dependencies.data();
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VK_CHECK(vkCreateRenderPass(context.device, &info, nullptr, &renderPass));
    return renderPass;
}

VkDescriptorSetLayout createTonemapSetLayout(const Context& context) {
    VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                                         VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
    VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    info.bindingCount = 1;
    info.pBindings = &binding;
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorSetLayout(context.device, &info, nullptr, &layout));
    return layout;
}

VkPipelineLayout createTonemapPipelineLayout(const Context& context, VkDescriptorSetLayout setLayout) {
    VkPushConstantRange range{VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(gpu::TonemapConstants)};
    VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    info.setLayoutCount = 1;
    info.pSetLayouts = &setLayout;
    info.pushConstantRangeCount = 1;
    info.pPushConstantRanges = &range;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreatePipelineLayout(context.device, &info, nullptr, &layout));
    return layout;
}

VkPipeline createTonemapPipeline(const Context& context, const Tonemapper& tonemapper, VkShaderModule vertex,
                                 VkShaderModule fragment) {
    uint32_t encodeSrgb = isSrgb(tonemapper.format) ? 0u : 1u;
    VkSpecializationMapEntry entry{SHPROBE_SPEC_ENCODE_SRGB, 0, 4};
    VkSpecializationInfo specialization{1, &entry, sizeof(encodeSrgb), &encodeSrgb};
    std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
    stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                 nullptr,
                 0,
                 VK_SHADER_STAGE_VERTEX_BIT,
                 vertex,
                 "main",
                 nullptr};
    stages[1] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                 nullptr,
                 0,
                 VK_SHADER_STAGE_FRAGMENT_BIT,
                 fragment,
                 "main",
                 &specialization};

    VkPipelineVertexInputStateCreateInfo vertexInput{
        VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    VkPipelineInputAssemblyStateCreateInfo assembly{
        VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkPipelineViewportStateCreateInfo viewport{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
    viewport.viewportCount = 1;
    viewport.scissorCount = 1;
    VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
    raster.polygonMode = VK_POLYGON_MODE_FILL;
    raster.cullMode = VK_CULL_MODE_NONE;
    raster.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo multisample{
        VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineColorBlendAttachmentState attachment{};
    attachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo blend{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    blend.attachmentCount = 1;
    blend.pAttachments = &attachment;
    std::array<VkDynamicState, 2> dynamicStates{VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
    dynamic.dynamicStateCount = uint32_t(dynamicStates.size());
    dynamic.pDynamicStates = dynamicStates.data();

    VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    info.stageCount = uint32_t(stages.size());
    info.pStages = stages.data();
    info.pVertexInputState = &vertexInput;
    info.pInputAssemblyState = &assembly;
    info.pViewportState = &viewport;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pColorBlendState = &blend;
    info.pDynamicState = &dynamic;
    info.layout = tonemapper.layout;
    info.renderPass = tonemapper.renderPass;
    VkPipeline pipeline = VK_NULL_HANDLE;
    VK_CHECK(vkCreateGraphicsPipelines(context.device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    return pipeline;
}

VkDescriptorPool createInputPool(const Context& context) {
    constexpr uint32_t kMaxInputs = 16; // one per live HDR target
    VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, kMaxInputs};
    VkDescriptorPoolCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    info.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    info.maxSets = kMaxInputs;
    info.poolSizeCount = 1;
    info.pPoolSizes = &size;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorPool(context.device, &info, nullptr, &pool));
    return pool;
}

} // namespace

Tonemapper createTonemapper(const Context& context, VkFormat format, VkImageLayout finalLayout) {
    Tonemapper tonemapper;
    tonemapper.format = format;
    VkShaderModule vertex = VK_NULL_HANDLE, fragment = VK_NULL_HANDLE;
    try {
        tonemapper.renderPass = createTonemapRenderPass(context, format, finalLayout);
        tonemapper.setLayout = createTonemapSetLayout(context);
        tonemapper.layout = createTonemapPipelineLayout(context, tonemapper.setLayout);
        tonemapper.sampler = createSampler(context, VK_FILTER_NEAREST);
        tonemapper.pool = createInputPool(context);
        vertex = createShaderModule(context, spirv::fullscreen_vert.data(), spirv::fullscreen_vert.size());
        fragment = createShaderModule(context, spirv::tonemap_frag.data(), spirv::tonemap_frag.size());
        tonemapper.pipeline = createTonemapPipeline(context, tonemapper, vertex, fragment);
    } catch (...) {
        if (vertex) vkDestroyShaderModule(context.device, vertex, nullptr);
        if (fragment) vkDestroyShaderModule(context.device, fragment, nullptr);
        destroyTonemapper(context, tonemapper);
        throw;
    }
    vkDestroyShaderModule(context.device, vertex, nullptr); // the pipeline keeps what it needs
    vkDestroyShaderModule(context.device, fragment, nullptr);
    return tonemapper;
}

void destroyTonemapper(const Context& context, Tonemapper& tonemapper) {
    if (tonemapper.pipeline) vkDestroyPipeline(context.device, tonemapper.pipeline, nullptr);
    if (tonemapper.pool) vkDestroyDescriptorPool(context.device, tonemapper.pool, nullptr);
    if (tonemapper.sampler) vkDestroySampler(context.device, tonemapper.sampler, nullptr);
    if (tonemapper.layout) vkDestroyPipelineLayout(context.device, tonemapper.layout, nullptr);
    if (tonemapper.setLayout) vkDestroyDescriptorSetLayout(context.device, tonemapper.setLayout, nullptr);
    if (tonemapper.renderPass) vkDestroyRenderPass(context.device, tonemapper.renderPass, nullptr);
    tonemapper = Tonemapper{};
}

VkDescriptorSet createTonemapInput(const Context& context, const Tonemapper& tonemapper,
                                   VkImageView hdrView) {
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = tonemapper.pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &tonemapper.setLayout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateDescriptorSets(context.device, &allocate, &set));
    VkDescriptorImageInfo image{tonemapper.sampler, hdrView, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    write.dstSet = set;
    write.dstBinding = 0;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    write.pImageInfo = &image;
    vkUpdateDescriptorSets(context.device, 1, &write, 0, nullptr);
    return set;
}

void freeTonemapInput(const Context& context, const Tonemapper& tonemapper, VkDescriptorSet& set) {
    if (set) VK_CHECK(vkFreeDescriptorSets(context.device, tonemapper.pool, 1, &set));
    set = VK_NULL_HANDLE;
}

void recordTonemap(VkCommandBuffer commands, const Tonemapper& tonemapper, VkDescriptorSet input,
                   VkFramebuffer framebuffer, VkExtent2D extent, float exposure) {
    VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    begin.renderPass = tonemapper.renderPass;
    begin.framebuffer = framebuffer;
    begin.renderArea = {{0, 0}, extent};
    vkCmdBeginRenderPass(commands, &begin, VK_SUBPASS_CONTENTS_INLINE);
    VkViewport viewport{0.0f, 0.0f, float(extent.width), float(extent.height), 0.0f, 1.0f};
    VkRect2D scissor{{0, 0}, extent};
    vkCmdSetViewport(commands, 0, 1, &viewport);
    vkCmdSetScissor(commands, 0, 1, &scissor);
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, tonemapper.pipeline);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, tonemapper.layout, 0, 1, &input, 0,
                            nullptr);
    gpu::TonemapConstants constants{glm::vec4(exposure, 0.0f, 0.0f, 0.0f)};
    vkCmdPushConstants(commands, tonemapper.layout, VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(constants),
                       &constants);
    vkCmdDraw(commands, 3, 1, 0, 0);
    vkCmdEndRenderPass(commands);
}

} // namespace shprobe
