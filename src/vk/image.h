// Images: create, destroy, and change layouts with their memory dependencies. Plain handles;
// createImage / destroyImage.
#pragma once
#include "vk/context.h"

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

GpuImage createImage(const Device& device, const GpuImageDesc& desc);
void destroyImage(const Device& device, GpuImage& image);

// A memory type of typeBits (an image's memory requirements) with every flag of `required`,
// device-local where one is; UINT32_MAX where none.
uint32_t imageMemoryType(const Device& device, uint32_t typeBits, VkMemoryPropertyFlags required = 0);

// Allocates memory of `memoryType` for image.image (created elsewhere) and binds it; Error(Device)
// naming `what` where the size exceeds what the memory type allows or the device is out of memory.
void bindImageMemory(const Device& device, GpuImage& image, uint32_t memoryType, const char* what);

// A view of `layers` layers of mip 0, from firstLayer on, of an image of `format` (depth formats:
// the depth aspect, others colour), for images created elsewhere too (a swapchain's).
VkImageView createImageView(const Device& device, VkImage image, VkImageViewType type, VkFormat format,
                            uint32_t layers = 1, uint32_t firstLayer = 0);

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

// The two transitions around copies into an image: from whatever it held (discarded) to
// TRANSFER_DST_OPTIMAL, ready for copies; then from there to `layout`, the copies' writes visible to
// shader reads at `readStage`.
void beginImageCopies(VkCommandBuffer commands, const GpuImage& image);
void endImageCopies(VkCommandBuffer commands, const GpuImage& image, VkImageLayout layout,
                    VkPipelineStageFlags readStage);

// Records the copy of every layer of the image from the buffer (rows tightly packed, layer after
// layer, from offset 0) between those transitions.
void recordImageUpload(VkCommandBuffer commands, VkBuffer staging, const GpuImage& image,
                       VkImageLayout layout, VkPipelineStageFlags readStage);

// A sampler with the given filter for magnification and minification, clamped to the edges.
VkSampler createSampler(const Device& device, VkFilter filter);

} // namespace shprobe
