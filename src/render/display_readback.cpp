#include "render/display_readback.h"

#include "common/scope_exit.h"
#include "vk/graphics.h"
#include "vk/vulkan_commands.h"

#include <cstring>
#include <glm/vec4.hpp>

namespace shprobe {

DisplayReadback createDisplayReadback(const Context& context, VkImageView hdrView, VkExtent2D extent) {
    DisplayReadback readback;
    OnFailure undo([&] { destroyDisplayReadback(context, readback); });
    readback.extent = extent;
    readback.tonemapper = createTonemapper(context, kDisplayFormat, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    readback.tonemapInput = createTonemapInput(context, readback.tonemapper, hdrView);
    readback.display =
        createImage(context, {.format = kDisplayFormat,
                              .extent = extent,
                              .usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                              .what = "display image"});
    readback.displayFramebuffer =
        createFramebuffer(context, readback.tonemapper.renderPass, {&readback.display.view, 1}, extent);
    const VkDeviceSize pixels = VkDeviceSize(extent.width) * extent.height;
    readback.colorReadback = createBuffer(context, pixels * 16, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                          MemoryUse::Readback, "colour readback");
    readback.displayReadback = createBuffer(context, pixels * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                            MemoryUse::Readback, "display readback");
    return readback;
}

void destroyDisplayReadback(const Device& device, DisplayReadback& readback) {
    destroyBuffer(device, readback.displayReadback);
    destroyBuffer(device, readback.colorReadback);
    if (readback.displayFramebuffer)
        vkDestroyFramebuffer(device.device, readback.displayFramebuffer, nullptr);
    destroyImage(device, readback.display);
    if (readback.tonemapInput) freeTonemapInput(device, readback.tonemapper, readback.tonemapInput);
    destroyTonemapper(device, readback.tonemapper);
    readback = DisplayReadback{};
}

void recordDisplayReadback(VkCommandBuffer commands, const DisplayReadback& readback, const GpuImage& hdr,
                           float exposure) {
    recordTonemap(commands, readback.tonemapper, readback.tonemapInput, readback.displayFramebuffer,
                  readback.extent, exposure);
    changeLayout(commands, hdr,
                 {VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                  VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT});
    copyImageToBuffer(commands, hdr, readback.colorReadback);
    copyImageToBuffer(commands, readback.display, readback.displayReadback);
}

RenderedImage readRenderedImage(const Device& device, const DisplayReadback& readback) {
    RenderedImage image;
    invalidateBuffer(device, readback.colorReadback);
    image.linear = makeImage(int(readback.extent.width), int(readback.extent.height));
    std::memcpy(image.linear.texels.data(), readback.colorReadback.mapped,
                image.linear.texels.size() * sizeof(glm::vec4));
    invalidateBuffer(device, readback.displayReadback);
    const auto* bytes = static_cast<const uint8_t*>(readback.displayReadback.mapped);
    image.display.assign(bytes, bytes + readback.displayReadback.size);
    return image;
}

} // namespace shprobe
