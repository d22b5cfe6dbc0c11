#include "render/gpu_image.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "vk/vulkan_commands.h"

#include <algorithm>
#include <cstring>
#include <glm/gtc/packing.hpp>
#include <vector>

namespace shprobe {

namespace {

bool filtersLinearly(const Device& device, VkFormat format) {
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(device.physicalDevice, format, &properties);
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
    std::vector<uint8_t> bytes(count * sizeof(uint64_t));
    for (size_t i = 0; i < count; ++i) {
        glm::vec4 texel(glm::clamp(glm::vec3(cubemap.texels[i]), -kHalfMax, kHalfMax), 1.0f);
        uint64_t half = glm::packHalf4x16(texel);
        std::memcpy(bytes.data() + i * sizeof(half), &half, sizeof(half));
    }
    return bytes;
}

} // namespace

GpuImage createCubeTexture(const Context& context, const Cubemap& cubemap) {
    const VkFormat format = filtersLinearly(context, VK_FORMAT_R32G32B32A32_SFLOAT)
                                ? VK_FORMAT_R32G32B32A32_SFLOAT
                                : VK_FORMAT_R16G16B16A16_SFLOAT;
    const uint32_t size = uint32_t(cubemap.faceSize);
    std::vector<uint8_t> bytes = packTexels(cubemap, format);
    Buffer staging = createBuffer(context, bytes.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload,
                                  "environment upload");
    ScopeExit releaseStaging([&] { destroyBuffer(context, staging); });
    std::memcpy(staging.mapped, bytes.data(), bytes.size());
    GpuImage image = createImage(context, {format,
                                           {size, size},
                                           VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                           true,
                                           "environment cube map"});
    OnFailure releaseImage([&] { destroyImage(context, image); });
    submitAndWait(context, [&](VkCommandBuffer commands) { // faces follow each other in the buffer
        recordImageUpload(commands, staging.buffer, image, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                          VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT);
    });
    return image;
}

VkFormat pickDepthFormat(const Device& device) {
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(device.physicalDevice, VK_FORMAT_D32_SFLOAT, &properties);
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

} // namespace shprobe
