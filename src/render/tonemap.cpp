#include "render/tonemap.h"

#include "common/scope_exit.h"
#include "glsl/render_interface.h"
#include "vk/check.h"
#include "vk/graphics.h"
#include "vk/image.h"
#include "vk/pipeline.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_render_spirv.h>
#include <shprobe/shprobe_spirv.h>

#include <array>

namespace shprobe {

namespace {

bool isSrgb(VkFormat format) {
    return format == VK_FORMAT_R8G8B8A8_SRGB || format == VK_FORMAT_B8G8R8A8_SRGB ||
           format == VK_FORMAT_A8B8G8R8_SRGB_PACK32;
}

VkRenderPass createTonemapRenderPass(const Device& device, VkFormat format, VkImageLayout finalLayout) {
    const VkAttachmentDescription attachment =
        attachmentDescription(format, VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_STORE,
                              finalLayout); // every pixel is written
    const VkAttachmentReference color{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
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
    return createRenderPass(device, {{&attachment, 1}, {&color, 1}, nullptr, dependencies});
}

VkPipeline createTonemapPipeline(const Device& device, const Tonemapper& tonemapper, VkShaderModule vertex,
                                 VkShaderModule fragment) {
    uint32_t encodeSrgb = isSrgb(tonemapper.format) ? 0u : 1u;
    VkSpecializationMapEntry entry{SHPROBE_SPEC_ENCODE_SRGB, 0, 4};
    VkSpecializationInfo specialization{1, &entry, sizeof(encodeSrgb), &encodeSrgb};
    GraphicsPipelineDesc desc;
    desc.vertex = vertex;
    desc.fragment = fragment;
    desc.fragmentSpecialization = &specialization;
    desc.layout = tonemapper.layout;
    desc.renderPass = tonemapper.renderPass;
    return createGraphicsPipeline(device, desc);
}

} // namespace

Tonemapper createTonemapper(const Device& device, VkFormat format, VkImageLayout finalLayout) {
    constexpr uint32_t kMaxInputs = 16; // one per live HDR target
    Tonemapper tonemapper;
    tonemapper.format = format;
    OnFailure undo([&] { destroyTonemapper(device, tonemapper); });
    tonemapper.renderPass = createTonemapRenderPass(device, format, finalLayout);
    const LayoutBinding input{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_SHADER_STAGE_FRAGMENT_BIT};
    tonemapper.setLayout = createSetLayout(device, {&input, 1});
    tonemapper.layout = createPipelineLayout(device, tonemapper.setLayout, VK_SHADER_STAGE_FRAGMENT_BIT,
                                             sizeof(glsl::TonemapConstants));
    tonemapper.sampler = createSampler(device, VK_FILTER_NEAREST);
    tonemapper.pool =
        createDescriptorPool(device, {.sets = kMaxInputs, .imageSamplers = kMaxInputs, .freeSets = true});
    // The pipeline keeps what it needs of the modules.
    VkShaderModule vertex = createShaderModule(device, spirv::fullscreen_vert);
    ScopeExit releaseVertex([&] { vkDestroyShaderModule(device.device, vertex, nullptr); });
    VkShaderModule fragment = createShaderModule(device, spirv::tonemap_frag);
    ScopeExit releaseFragment([&] { vkDestroyShaderModule(device.device, fragment, nullptr); });
    tonemapper.pipeline = createTonemapPipeline(device, tonemapper, vertex, fragment);
    return tonemapper;
}

void destroyTonemapper(const Device& device, Tonemapper& tonemapper) {
    if (tonemapper.pipeline) vkDestroyPipeline(device.device, tonemapper.pipeline, nullptr);
    if (tonemapper.pool) vkDestroyDescriptorPool(device.device, tonemapper.pool, nullptr);
    if (tonemapper.sampler) vkDestroySampler(device.device, tonemapper.sampler, nullptr);
    if (tonemapper.layout) vkDestroyPipelineLayout(device.device, tonemapper.layout, nullptr);
    if (tonemapper.setLayout) vkDestroyDescriptorSetLayout(device.device, tonemapper.setLayout, nullptr);
    if (tonemapper.renderPass) vkDestroyRenderPass(device.device, tonemapper.renderPass, nullptr);
    tonemapper = Tonemapper{};
}

VkDescriptorSet createTonemapInput(const Device& device, const Tonemapper& tonemapper, VkImageView hdrView) {
    VkDescriptorSet set = allocateDescriptorSet(device, tonemapper.pool, tonemapper.setLayout);
    writeDescriptor(device, set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                    {.imageView = hdrView, .sampler = tonemapper.sampler});
    return set;
}

void freeTonemapInput(const Device& device, const Tonemapper& tonemapper, VkDescriptorSet& set) {
    if (set) VK_CHECK(vkFreeDescriptorSets(device.device, tonemapper.pool, 1, &set));
    set = VK_NULL_HANDLE;
}

void recordTonemap(VkCommandBuffer commands, const Tonemapper& tonemapper, VkDescriptorSet input,
                   VkFramebuffer framebuffer, VkExtent2D extent, float exposure) {
    beginRenderPass(commands, tonemapper.renderPass, framebuffer, extent);
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, tonemapper.pipeline);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, tonemapper.layout, 0, 1, &input, 0,
                            nullptr);
    glsl::TonemapConstants constants{glm::vec4(exposure, 0.0f, 0.0f, 0.0f)};
    vkCmdPushConstants(commands, tonemapper.layout, VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(constants),
                       &constants);
    vkCmdDraw(commands, 3, 1, 0, 0);
    vkCmdEndRenderPass(commands);
}

} // namespace shprobe
