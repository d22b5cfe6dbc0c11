#include "vk/image.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "vk/check.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"

#include <string>

namespace shprobe {

namespace {

bool isDepthFormat(VkFormat format) {
    return format == VK_FORMAT_D32_SFLOAT || format == VK_FORMAT_D16_UNORM;
}

VkImageAspectFlags aspectOf(VkFormat format) {
    return isDepthFormat(format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
}

} // namespace

uint32_t imageMemoryType(const Device& device, uint32_t typeBits, VkMemoryPropertyFlags required) {
    uint32_t fallback = UINT32_MAX;
    for (uint32_t i = 0; i < device.memory.memoryTypeCount; ++i) {
        const VkMemoryPropertyFlags flags = device.memory.memoryTypes[i].propertyFlags;
        if (!(typeBits & (1u << i)) || (flags & required) != required) continue;
        if (flags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) return i;
        if (fallback == UINT32_MAX) fallback = i;
    }
    return fallback;
}

void bindImageMemory(const Device& device, GpuImage& image, uint32_t memoryType, const char* what) {
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(device.device, image.image, &requirements);
    checkAllocationSize(device, requirements.size, memoryType, what);
    VkMemoryAllocateInfo allocate{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    allocate.allocationSize = requirements.size;
    allocate.memoryTypeIndex = memoryType;
    VkResult result = vkAllocateMemory(device.device, &allocate, nullptr, &image.memory);
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY)
        throw Error(ErrorKind::Device, std::string("out of memory for ") + what + " on " + device.info.name);
    VK_CHECK(result);
    VK_CHECK(vkBindImageMemory(device.device, image.image, image.memory, 0));
}

GpuImage createImage(const Device& device, const GpuImageDesc& desc) {
    GpuImage image;
    image.format = desc.format;
    image.extent = desc.extent;
    image.layers = desc.cube ? 6 : desc.layers;
    OnFailure undo([&] { destroyImage(device, image); });
    VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    info.flags = desc.cube ? VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT : 0;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = desc.format;
    info.extent = {desc.extent.width, desc.extent.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = image.layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = desc.usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VK_CHECK(vkCreateImage(device.device, &info, nullptr, &image.image));
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(device.device, image.image, &requirements);
    const uint32_t memoryType = imageMemoryType(device, requirements.memoryTypeBits);
    if (memoryType == UINT32_MAX)
        throw Error(ErrorKind::Device, std::string("no memory type for ") + desc.what);
    bindImageMemory(device, image, memoryType, desc.what);

    const VkImageViewType viewType = desc.cube          ? VK_IMAGE_VIEW_TYPE_CUBE
                                     : image.layers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY
                                                        : VK_IMAGE_VIEW_TYPE_2D;
    image.view = createImageView(device, image.image, viewType, desc.format, image.layers);
    return image;
}

VkImageView createImageView(const Device& device, VkImage image, VkImageViewType type, VkFormat format,
                            uint32_t layers, uint32_t firstLayer) {
    VkImageViewCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    info.image = image;
    info.viewType = type;
    info.format = format;
    info.subresourceRange = {aspectOf(format), 0, 1, firstLayer, layers};
    VkImageView view = VK_NULL_HANDLE;
    VK_CHECK(vkCreateImageView(device.device, &info, nullptr, &view));
    return view;
}

void destroyImage(const Device& device, GpuImage& image) {
    if (image.view) vkDestroyImageView(device.device, image.view, nullptr);
    if (image.image) vkDestroyImage(device.device, image.image, nullptr);
    if (image.memory) vkFreeMemory(device.device, image.memory, nullptr);
    image = GpuImage{};
}

void changeLayout(VkCommandBuffer commands, VkImage image, VkImageAspectFlags aspect, uint32_t layers,
                  const LayoutChange& change) {
    VkImageMemoryBarrier barrier{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    barrier.srcAccessMask = change.srcAccess;
    barrier.dstAccessMask = change.dstAccess;
    barrier.oldLayout = change.from;
    barrier.newLayout = change.to;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange = {aspect, 0, 1, 0, layers};
    vkCmdPipelineBarrier(commands, change.srcStage, change.dstStage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

void changeLayout(VkCommandBuffer commands, const GpuImage& image, const LayoutChange& change) {
    changeLayout(commands, image.image, aspectOf(image.format), image.layers, change);
}

void beginImageCopies(VkCommandBuffer commands, const GpuImage& image) {
    changeLayout(commands, image,
                 {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_ACCESS_TRANSFER_WRITE_BIT});
}

void endImageCopies(VkCommandBuffer commands, const GpuImage& image, VkImageLayout layout,
                    VkPipelineStageFlags readStage) {
    changeLayout(commands, image,
                 {VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, layout, VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_ACCESS_TRANSFER_WRITE_BIT, readStage, VK_ACCESS_SHADER_READ_BIT});
}

void recordImageUpload(VkCommandBuffer commands, VkBuffer staging, const GpuImage& image,
                       VkImageLayout layout, VkPipelineStageFlags readStage) {
    beginImageCopies(commands, image);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, image.layers};
    region.imageExtent = {image.extent.width, image.extent.height, 1};
    vkCmdCopyBufferToImage(commands, staging, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    endImageCopies(commands, image, layout, readStage);
}

VkSampler createSampler(const Device& device, VkFilter filter) {
    VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    info.magFilter = filter;
    info.minFilter = filter;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    info.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    VkSampler sampler = VK_NULL_HANDLE;
    VK_CHECK(vkCreateSampler(device.device, &info, nullptr, &sampler));
    return sampler;
}

} // namespace shprobe
