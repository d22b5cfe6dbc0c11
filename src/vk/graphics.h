// Graphics plumbing of one subpass: render passes, framebuffers, graphics pipelines and beginning
// a pass. Plain handles, destroyed with the vkDestroy* of their type. Set layouts, pipeline layouts,
// shader modules and descriptor sets come from vk/pipeline.h, as compute programs' do.
#pragma once
#include "vk/context.h"
#include "vk/image.h"

#include <array>
#include <cstdint>
#include <span>

namespace shprobe {

// An attachment whose old contents are not kept (initial layout UNDEFINED), without stencil.
VkAttachmentDescription attachmentDescription(VkFormat format, VkAttachmentLoadOp load,
                                              VkAttachmentStoreOp store, VkImageLayout finalLayout);

// The dependencies of a pass that writes colour and depth attachments between readers of them:
// what `earlierReaders` (stages) read, and earlier attachment writes, finish before the pass writes;
// its colour writes are visible to shader and transfer reads at `laterReaders` after it.
std::array<VkSubpassDependency, 2> attachmentDependencies(VkPipelineStageFlags earlierReaders,
                                                          VkPipelineStageFlags laterReaders);

// A render pass of one subpass writing `colors` (and `depth`, if any) of `attachments`.
struct RenderPassDesc {
    std::span<const VkAttachmentDescription> attachments;
    std::span<const VkAttachmentReference> colors;
    const VkAttachmentReference* depth = nullptr;
    std::span<const VkSubpassDependency> dependencies;
};
VkRenderPass createRenderPass(const Device& device, const RenderPassDesc& desc);

// One layer of `views`, in attachment order, for passes of renderPass.
VkFramebuffer createFramebuffer(const Device& device, VkRenderPass renderPass,
                                std::span<const VkImageView> views, VkExtent2D extent);

// A colour and a depth image of one size and their framebuffer, for a render pass whose attachments
// are that colour and that depth.
struct ColorDepthTarget {
    VkExtent2D extent{};
    GpuImage color;
    GpuImage depth;
    VkFramebuffer framebuffer = VK_NULL_HANDLE;
};
struct ColorDepthTargetDesc {
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VkExtent2D extent{};
    VkFormat colorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
    VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;
    VkImageUsageFlags colorUsage = 0; // besides COLOR_ATTACHMENT (e.g. SAMPLED, TRANSFER_SRC)
    const char* what = "";            // the colour image, for error messages
    const char* depthWhat = "";
};
ColorDepthTarget createColorDepthTarget(const Device& device, const ColorDepthTargetDesc& desc);
void destroyColorDepthTarget(const Device& device, ColorDepthTarget& target);

// What varies between the graphics pipelines here; the rest is fixed: triangle lists, filled,
// counter-clockwise front faces, one sample, no blending (every colour attachment written whole),
// dynamic viewport and scissor (beginRenderPass sets them).
struct GraphicsPipelineDesc {
    VkShaderModule vertex = VK_NULL_HANDLE;
    VkShaderModule fragment = VK_NULL_HANDLE; // none: depth only (colorAttachments = 0)
    const VkSpecializationInfo* vertexSpecialization = nullptr;
    const VkSpecializationInfo* fragmentSpecialization = nullptr;
    std::span<const VkVertexInputBindingDescription> vertexBindings; // none: the shader makes its vertices
    std::span<const VkVertexInputAttributeDescription> vertexAttributes;
    VkCullModeFlags cullMode = VK_CULL_MODE_NONE;
    bool depthTest = false; // the subpass has a depth attachment
    bool depthWrite = false;
    VkCompareOp depthCompare = VK_COMPARE_OP_LESS;
    uint32_t colorAttachments = 1; // of the subpass
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkRenderPass renderPass = VK_NULL_HANDLE; // subpass 0
};
// Goes through Device::pipelineCache.
VkPipeline createGraphicsPipeline(const Device& device, const GraphicsPipelineDesc& desc);

// Begins the pass over the whole framebuffer (commands inline) and sets the viewport and scissor
// to it. `clears`: one per attachment up to the last one that is cleared.
void beginRenderPass(VkCommandBuffer commands, VkRenderPass renderPass, VkFramebuffer framebuffer,
                     VkExtent2D extent, std::span<const VkClearValue> clears = {});

} // namespace shprobe
