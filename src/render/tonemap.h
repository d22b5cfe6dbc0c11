// The display pass: linear HDR colour -> exposure, filmic curve, sRGB (tonemap.frag), into an 8-bit
// target: an offscreen R8G8B8A8_SRGB image for PNG output, or a swapchain image in the viewer, so
// both show the same bytes.
#pragma once
#include "vk/context.h"

namespace shprobe {

struct Tonemapper {
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE; // 0: HDR colour (combined image sampler)
    VkPipelineLayout layout = VK_NULL_HANDLE;         // + TonemapConstants push constants
    VkPipeline pipeline = VK_NULL_HANDLE;
    VkSampler sampler = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE; // input sets, freed one by one
};

// `format`: the target's; _SRGB formats encode in hardware, UNORM ones in the shader. The target
// ends in `finalLayout` (TRANSFER_SRC_OPTIMAL for readback, PRESENT_SRC_KHR for a swapchain).
Tonemapper createTonemapper(const Device& device, VkFormat format, VkImageLayout finalLayout);
void destroyTonemapper(const Device& device, Tonemapper& tonemapper);

// A descriptor set reading `hdrView` (in SHADER_READ_ONLY_OPTIMAL); free it before the view.
VkDescriptorSet createTonemapInput(const Device& device, const Tonemapper& tonemapper, VkImageView hdrView);
void freeTonemapInput(const Device& device, const Tonemapper& tonemapper, VkDescriptorSet& set);

// Records the pass into `framebuffer` (one attachment of the tonemapper's format) of `extent`,
// the size of the HDR image.
void recordTonemap(VkCommandBuffer commands, const Tonemapper& tonemapper, VkDescriptorSet input,
                   VkFramebuffer framebuffer, VkExtent2D extent, float exposure);

} // namespace shprobe
