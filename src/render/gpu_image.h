// Images for rendering: render targets, the environment cube map, host readback.
#pragma once
#include "sh/cubemap.h"
#include "vk/context.h"
#include "vk/image.h"
#include "vk/resources.h"

#include <cstdint>

namespace shprobe {

// The environment as a sampled cube image (layers in Vulkan face order, which Cubemap shares),
// RGBA32F where the device filters it linearly, else RGBA16F (values clamped to the half range).
// Left in SHADER_READ_ONLY_OPTIMAL.
GpuImage createCubeTexture(const Context& context, const Cubemap& cubemap);

// D32_SFLOAT where supported as a depth attachment, else D16_UNORM (always supported).
VkFormat pickDepthFormat(const Device& device);

// Records a copy of a 2D colour image (in TRANSFER_SRC_OPTIMAL) into a buffer, rows tightly packed,
// and makes it visible to the host.
void copyImageToBuffer(VkCommandBuffer commands, const GpuImage& image, const Buffer& buffer);

} // namespace shprobe
