#include "render/gpu_image.h"

#include "sh/error.h"
#include "vk/check.h"

#include <algorithm>
#include <cstring>
#include <glm/gtc/packing.hpp>
#include <vector>

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
    VkResult result = vkAllocateMemory(context.device, &allocate, nullptr, &image.memory);
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY)
        throw Error(ErrorKind::Device, std::string("out of memory for ") + what + " on " + context.info.name);
    VK_CHECK(result);
    VK_CHECK(vkBindImageMemory(context.device, image.image, image.memory, 0));
}

bool filtersLinearly(const Context& context, VkFormat format) {
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(context.physicalDevice, format, &properties);
    return properties.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;
}

// Texels as the image stores them: RGBA32F as they are, or RGBA16F within the half range.
std::vector<uint8_t> packTexels(const Cubemap& cubemap, VkFormat format) {
    const size_t count = cubemap.texels.size();
    if (format == VK_FORMAT_R32G32B32A32_SFLOAT) {
        std::vector<uint8_t> bytes(count * sizeof(glm::vec4));
        std::memcpy(bytes.data(), cubemap.texels.data(), bytes.size());
        return bytes;
    }
    constexpr float kHalfMax = 65504.0f;
    std::vector<uint8_t> bytes(count * sizeof(uint64_t));
    for (size_t i = 0; i < count; ++i) {
        glm::vec4 texel(glm::clamp(glm::vec3(cubemap.texels[i]), -kHalfMax, kHalfMax), 1.0f);
        uint64_t half = glm::packHalf4x16(texel);
        std::memcpy(bytes.data() + i * sizeof(half), &half, sizeof(half));
    }
    return bytes;
}

} // namespace

GpuImage createImage(const Context& context, const GpuImageDesc& desc) {
    GpuImage image;
    image.format = desc.format;
    image.extent = desc.extent;
    image.layers = desc.cube ? 6 : 1;
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
        view.viewType = desc.cube ? VK_IMAGE_VIEW_TYPE_CUBE : VK_IMAGE_VIEW_TYPE_2D;
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

GpuImage createCubeTexture(const Context& context, const Cubemap& cubemap) {
    const VkFormat format = filtersLinearly(context, VK_FORMAT_R32G32B32A32_SFLOAT)
                                ? VK_FORMAT_R32G32B32A32_SFLOAT
                                : VK_FORMAT_R16G16B16A16_SFLOAT;
    const uint32_t size = uint32_t(cubemap.faceSize);
    std::vector<uint8_t> bytes = packTexels(cubemap, format);
    Buffer staging = createBuffer(context, bytes.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload,
                                  "environment upload");
    GpuImage image;
    try {
        std::memcpy(staging.mapped, bytes.data(), bytes.size());
        image = createImage(context, {format,
                                      {size, size},
                                      VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                      true,
                                      "environment cube map"});
        submitAndWait(context, [&](VkCommandBuffer commands) {
            changeLayout(commands, image,
                         {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                          VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT,
                          VK_ACCESS_TRANSFER_WRITE_BIT});
            VkBufferImageCopy region{};
            region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 6}; // faces follow each other
            region.imageExtent = {size, size, 1};
            vkCmdCopyBufferToImage(commands, staging.buffer, image.image,
                                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
            changeLayout(commands, image,
                         {VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                          VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT});
        });
    } catch (...) {
        destroyImage(context, image);
        destroyBuffer(context, staging);
        throw;
    }
    destroyBuffer(context, staging);
    return image;
}

VkFormat pickDepthFormat(const Context& context) {
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(context.physicalDevice, VK_FORMAT_D32_SFLOAT, &properties);
    return properties.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT
               ? VK_FORMAT_D32_SFLOAT
               : VK_FORMAT_D16_UNORM;
}

void copyImageToBuffer(VkCommandBuffer commands, const GpuImage& image, const Buffer& buffer) {
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {image.extent.width, image.extent.height, 1};
    vkCmdCopyImageToBuffer(commands, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer.buffer, 1,
                           &region);
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier,
                         0, nullptr, 0, nullptr);
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
