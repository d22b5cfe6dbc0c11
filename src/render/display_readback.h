// An HDR picture made into what `render` writes: the tonemap pass into an sRGB image, and both the
// linear colour and the display bytes read back (render --scene and render --scene --transfer).
#pragma once
#include "render/offscreen.h"
#include "render/tonemap.h"
#include "vk/context.h"
#include "vk/image.h"
#include "vk/resources.h"

namespace shprobe {

struct DisplayReadback {
    VkExtent2D extent{};
    Tonemapper tonemapper;
    VkDescriptorSet tonemapInput = VK_NULL_HANDLE;
    GpuImage display;
    VkFramebuffer displayFramebuffer = VK_NULL_HANDLE;
    Buffer colorReadback;
    Buffer displayReadback;
};

// Reads `hdrView`, an RGBA32F image of `extent` made with SAMPLED and TRANSFER_SRC usage.
DisplayReadback createDisplayReadback(const Context& context, VkImageView hdrView, VkExtent2D extent);
void destroyDisplayReadback(const Device& device, DisplayReadback& readback);
// `hdr` in SHADER_READ_ONLY_OPTIMAL: the tonemap, then copies of hdr (left in TRANSFER_SRC_OPTIMAL)
// and of the display image into the readback buffers.
void recordDisplayReadback(VkCommandBuffer commands, const DisplayReadback& readback, const GpuImage& hdr,
                           float exposure);
// After the commands ran.
RenderedImage readRenderedImage(const Device& device, const DisplayReadback& readback);

} // namespace shprobe
