// Images in host memory, for a CPU device such as lavapipe, which reads host memory where it lies:
// over memory the program already holds (VK_EXT_external_memory_host), whose texels are then read in
// place, or over mapped memory of their own, into which the program writes the texels. Either way
// there is no staging copy and no copy into an image: on lavapipe, 6 x 4096^2 RGBA32F (1.6 GB) would
// otherwise be copied twice into fresh pages, which the kernel clears first. Where the device cannot,
// the caller stages the texels as on a GPU.
#pragma once
#include "vk/context.h"
#include "vk/image.h"

#include <optional>

namespace shprobe {

// A linear-tiled image of `layers` layers of `extent` in `format` whose texels are the `bytes`
// bytes at `texels` (rows tightly packed, layer after layer), bound to that memory imported, in
// VK_IMAGE_LAYOUT_UNDEFINED (an image of external memory starts there; on a CPU device the
// transition out of it keeps the texels); nullopt where the device cannot: it is not a CPU device,
// the extension is not enabled, the imported memory is not device-local, the driver's linear layout
// of this size has padding or the format's linear tiling lacks `usage`. The memory must outlive the image and
// must not change while the device reads it. destroyImage releases both.
std::optional<GpuImage> importHostImage(const Device& device, const void* texels, VkDeviceSize bytes,
                                        VkFormat format, VkExtent2D extent, uint32_t layers,
                                        VkImageUsageFlags usage);

// Where a linear image's rows lie in its memory: row r of layer l at l layerPitch + r rowPitch.
struct LinearRows {
    VkDeviceSize rowPitch = 0;
    VkDeviceSize layerPitch = 0;
};

// A linear-tiled image of `layers` layers of `extent` in `format` in host-visible, coherent memory of
// a CPU device, mapped at `texels` with its rows where `rows` says (the driver may pad them), in
// VK_IMAGE_LAYOUT_PREINITIALIZED (what the host writes there before the first transition stays):
// texels written there are read by the device where they lie, with no staging copy and no copy into
// an image. nullopt where the device cannot: it is not a CPU device, the format's linear tiling lacks
// `usage` or these layers, or no memory type is host-visible and coherent. `what` names the image in
// errors. destroyImage releases it and the mapping.
struct MappedImage {
    GpuImage image;
    void* texels = nullptr;
    LinearRows rows;
};
std::optional<MappedImage> createMappedImage(const Device& device, VkFormat format, VkExtent2D extent,
                                             uint32_t layers, VkImageUsageFlags usage, const char* what);

} // namespace shprobe
