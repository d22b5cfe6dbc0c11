// Images for rendering: render targets, the environment cube map, host readback. Plain handles;
// createImage / destroyImage.
#pragma once
#include "sh/cubemap.h"
#include "vk/context.h"
#include "vk/resources.h"

#include <cstdint>

namespace shprobe {

struct GpuImage {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkExtent2D extent{};
    uint32_t layers = 1;
};

struct GpuImageDesc {
    VkFormat format = VK_FORMAT_R32G32B32A32_SFLOAT;
    VkExtent2D extent{};
    VkImageUsageFlags usage = 0;
    bool cube = false;     // 6 layers viewed as a cube
    const char* what = ""; // for error messages
};

GpuImage createImage(const Context& context, const GpuImageDesc& desc);
void destroyImage(const Context& context, GpuImage& image);

// A layout transition of all layers and mips of the image, with its memory dependency.
struct LayoutChange {
    VkImageLayout from;
    VkImageLayout to;
    VkPipelineStageFlags srcStage;
    VkAccessFlags srcAccess;
    VkPipelineStageFlags dstStage;
    VkAccessFlags dstAccess;
};
void changeLayout(VkCommandBuffer commands, const GpuImage& image, const LayoutChange& change);
void changeLayout(VkCommandBuffer commands, VkImage image, VkImageAspectFlags aspect, uint32_t layers,
                  const LayoutChange& change);

// The environment as a sampled cube image (layers in Vulkan face order, which Cubemap shares),
// RGBA32F where the device filters it linearly, else RGBA16F (values clamped to the half range).
// Left in SHADER_READ_ONLY_OPTIMAL.
GpuImage createCubeTexture(const Context& context, const Cubemap& cubemap);

// D32_SFLOAT where supported as a depth attachment, else D16_UNORM (always supported).
VkFormat pickDepthFormat(const Context& context);

// A sampler with the given filter for magnification and minification, clamped to the edges.
VkSampler createSampler(const Context& context, VkFilter filter);

// Records a copy of a 2D colour image (in TRANSFER_SRC_OPTIMAL) into a buffer, rows tightly packed,
// and makes it visible to the host.
void copyImageToBuffer(VkCommandBuffer commands, const GpuImage& image, const Buffer& buffer);

} // namespace shprobe
