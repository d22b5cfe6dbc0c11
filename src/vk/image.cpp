#include "shprobe/vk/image.h"

#include "shprobe/sh/error.h"
#include "shprobe/vk/check.h"
#include "shprobe/vk/resources.h"

#include <string>

namespace shprobe {

namespace {

// Device-local memory when the image allows it, else any type it allows.
uint32_t imageMemoryType(const Context& context, uint32_t typeBits) {
    uint32_t fallback = UINT32_MAX;
    for (uint32_t i = 0; i < context.memory.memoryTypeCount; ++i) {
        if (!(typeBits & (1u << i))) continue;
        if (context.memory.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) return i;
        if (fallback == UINT32_MAX) fallback = i;
    }
    return fallback;
}

bool isDepthFormat(VkFormat format) {
    return format == VK_FORMAT_D32_SFLOAT || format == VK_FORMAT_D16_UNORM;
}

VkImageAspectFlags aspectOf(VkFormat format) {
    return isDepthFormat(format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
}

void allocateAndBind(const Context& context, GpuImage& image, const char* what) {
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(context.device, image.image, &requirements);
    VkMemoryAllocateInfo allocate{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    allocate.allocationSize = requirements.size;
    allocate.memoryTypeIndex = imageMemoryType(context, requirements.memoryTypeBits);
    if (allocate.memoryTypeIndex == UINT32_MAX)
        throw Error(ErrorKind::Device, std::string("no memory type for ") + what);
    checkAllocationSize(context, requirements.size, allocate.memoryTypeIndex, what);
    VkResult result = vkAllocateMemory(context.device, &allocate, nullptr, &image.memory);
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY)
        throw Error(ErrorKind::Device, std::string("out of memory for ") + what + " on " + context.info.name);
    VK_CHECK(result);
    VK_CHECK(vkBindImageMemory(context.device, image.image, image.memory, 0));
}

} // namespace

GpuImage createImage(const Context& context, const GpuImageDesc& desc) {
    GpuImage image;
    image.format = desc.format;
    image.extent = desc.extent;
    image.layers = desc.cube ? 6 : desc.layers;
    try {
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
        VK_CHECK(vkCreateImage(context.device, &info, nullptr, &image.image));
        allocateAndBind(context, image, desc.what);

        VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
        view.image = image.image;
        view.viewType = desc.cube          ? VK_IMAGE_VIEW_TYPE_CUBE
                        : image.layers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY
                                           : VK_IMAGE_VIEW_TYPE_2D;
        view.format = desc.format;
        view.subresourceRange = {aspectOf(desc.format), 0, 1, 0, image.layers};
        VK_CHECK(vkCreateImageView(context.device, &view, nullptr, &image.view));
    } catch (...) {
        destroyImage(context, image);
        throw;
    }
    return image;
}

void destroyImage(const Context& context, GpuImage& image) {
    if (image.view) vkDestroyImageView(context.device, image.view, nullptr);
    if (image.image) vkDestroyImage(context.device, image.image, nullptr);
    if (image.memory) vkFreeMemory(context.device, image.memory, nullptr);
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

VkSampler createSampler(const Context& context, VkFilter filter) {
    VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    info.magFilter = filter;
    info.minFilter = filter;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    info.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    VkSampler sampler = VK_NULL_HANDLE;
    VK_CHECK(vkCreateSampler(context.device, &info, nullptr, &sampler));
    return sampler;
}

} // namespace shprobe
