// Images: create, destroy, and change layouts with their memory dependencies. Plain handles;
// createImage / destroyImage.
#pragma once
#include "shprobe/vk/context.h"

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
    bool cube = false;     // 6 layers viewed as a cube (layers is then ignored)
    const char* what = ""; // for error messages
    uint32_t layers = 1;   // array layers, viewed as a 2D array when more than one
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

// A sampler with the given filter for magnification and minification, clamped to the edges.
VkSampler createSampler(const Context& context, VkFilter filter);

} // namespace shprobe
