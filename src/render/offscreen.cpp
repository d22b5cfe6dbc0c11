#include "render/offscreen.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "vk/check.h"
#include "vk/graphics.h"
#include "vk/vulkan_commands.h"

#include <cstring>

namespace shprobe {

namespace {

constexpr uint32_t kMaxExtent = 16384;

// Everything one offscreen frame allocates, destroyed in one place.
struct OffscreenFrame {
    SceneTargets targets;
    GpuImage display;
    VkFramebuffer displayFramebuffer = VK_NULL_HANDLE;
    Buffer colorReadback;
    Buffer directionReadback;
    Buffer displayReadback;
};

void destroyFrame(const Device& device, const OffscreenRenderer& renderer, OffscreenFrame& frame) {
    destroyBuffer(device, frame.displayReadback);
    destroyBuffer(device, frame.directionReadback);
    destroyBuffer(device, frame.colorReadback);
    if (frame.displayFramebuffer) vkDestroyFramebuffer(device.device, frame.displayFramebuffer, nullptr);
    destroyImage(device, frame.display);
    destroySceneTargets(device, renderer.tonemapper, frame.targets);
}

OffscreenFrame createFrame(const Device& device, const OffscreenRenderer& renderer, VkExtent2D extent) {
    OffscreenFrame frame;
    OnFailure undo([&] { destroyFrame(device, renderer, frame); });
    frame.targets = createSceneTargets(device, renderer.scene, renderer.tonemapper, extent);
    frame.display =
        createImage(device, {kDisplayFormat, extent,
                             VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, false,
                             "display image"});
    frame.displayFramebuffer =
        createFramebuffer(device, renderer.tonemapper.renderPass, {&frame.display.view, 1}, extent);
    const VkDeviceSize pixels = VkDeviceSize(extent.width) * extent.height;
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    frame.colorReadback = createBuffer(device, pixels * 16, usage, MemoryUse::Readback, "colour readback");
    frame.directionReadback =
        createBuffer(device, pixels * 16, usage, MemoryUse::Readback, "direction readback");
    frame.displayReadback = createBuffer(device, pixels * 4, usage, MemoryUse::Readback, "display readback");
    return frame;
}

Image readFloatImage(const Device& device, const Buffer& buffer, VkExtent2D extent) {
    invalidateBuffer(device, buffer);
    Image image = makeImage(int(extent.width), int(extent.height));
    std::memcpy(image.texels.data(), buffer.mapped, image.texels.size() * sizeof(glm::vec4));
    return image;
}

std::string extentText(uint64_t width, uint64_t height) {
    return std::to_string(width) + "x" + std::to_string(height);
}

} // namespace

void requireRenderTargetExtent(const Device& device, VkExtent2D extent, const std::string& asked) {
    VkPhysicalDeviceImageFormatInfo2 info{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_IMAGE_FORMAT_INFO_2};
    info.format = VK_FORMAT_R32G32B32A32_SFLOAT;
    info.type = VK_IMAGE_TYPE_2D;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage =
        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    VkImageFormatProperties2 properties{VK_STRUCTURE_TYPE_IMAGE_FORMAT_PROPERTIES_2};
    VK_CHECK(vkGetPhysicalDeviceImageFormatProperties2(device.physicalDevice, &info, &properties));
    const VkImageFormatProperties& limits = properties.imageFormatProperties;
    const uint64_t bytes = uint64_t(extent.width) * extent.height * 16;
    if (extent.width <= limits.maxExtent.width && extent.height <= limits.maxExtent.height &&
        bytes <= limits.maxResourceSize)
        return;
    throw Error(ErrorKind::Input, asked + ": " + device.info.name +
                                      " makes RGBA32F render targets of at most " +
                                      extentText(limits.maxExtent.width, limits.maxExtent.height) +
                                      " pixels and " + std::to_string(limits.maxResourceSize) +
                                      " bytes, and one of " + extentText(extent.width, extent.height) +
                                      " is " + std::to_string(bytes) + " bytes: ask a smaller size");
}

OffscreenRenderer createOffscreenRenderer(const Context& context) {
    OffscreenRenderer renderer;
    OnFailure undo([&] { destroyOffscreenRenderer(context, renderer); });
    renderer.scene = createSceneRenderer(context);
    renderer.tonemapper = createTonemapper(context, kDisplayFormat, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    return renderer;
}

void destroyOffscreenRenderer(const Device& device, OffscreenRenderer& renderer) {
    destroyTonemapper(device, renderer.tonemapper);
    destroySceneRenderer(device, renderer.scene);
}

RenderedImage renderOffscreen(const Context& context, OffscreenRenderer& renderer, const Scene& scene,
                              VkExtent2D extent, float exposure) {
    if (extent.width < 1 || extent.height < 1 || extent.width > kMaxExtent || extent.height > kMaxExtent)
        throw Error(ErrorKind::Input, "image size " + std::to_string(extent.width) + "x" +
                                          std::to_string(extent.height) + " is outside 1.." +
                                          std::to_string(kMaxExtent));
    OffscreenFrame frame = createFrame(context, renderer, extent);
    ScopeExit releaseFrame([&] { destroyFrame(context, renderer, frame); });
    submitAndWait(context, [&](VkCommandBuffer commands) {
        recordScene(context, commands, renderer.scene, frame.targets, scene);
        recordTonemap(commands, renderer.tonemapper, frame.targets.tonemapInput, frame.displayFramebuffer,
                      extent, exposure);
        changeLayout(commands, frame.targets.color,
                     {VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                      VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT,
                      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT});
        copyImageToBuffer(commands, frame.targets.color, frame.colorReadback);
        copyImageToBuffer(commands, frame.targets.direction, frame.directionReadback);
        copyImageToBuffer(commands, frame.display, frame.displayReadback);
    });
    RenderedImage result;
    result.linear = readFloatImage(context, frame.colorReadback, extent);
    result.directions = readFloatImage(context, frame.directionReadback, extent);
    invalidateBuffer(context, frame.displayReadback);
    const auto* bytes = static_cast<const uint8_t*>(frame.displayReadback.mapped);
    result.display.assign(bytes, bytes + frame.displayReadback.size);
    return result;
}

} // namespace shprobe
