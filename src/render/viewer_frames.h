// The viewer's per-frame Vulkan work, without the window system: the swapchain, one command
// buffer, its fence and the acquire semaphore (one frame in flight), the tonemap pass into the
// swapchain, and screenshots read back from the presented image. What is drawn, into an HDR image
// of the swapchain's size, is the caller's.
#pragma once
#include "render/swapchain.h"
#include "render/tonemap.h"
#include "vk/resources.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace shprobe {

struct ViewerFrames {
    Tonemapper tonemapper; // into the swapchain's format, ending in PRESENT_SRC_KHR
    Swapchain swapchain;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkSemaphore acquired = VK_NULL_HANDLE;
    VkFence frameDone = VK_NULL_HANDLE; // signalled when the last submitted frame finished
    Buffer capture;                     // readback of the presented image, when asked for
};

ViewerFrames createViewerFrames(const Context& context, VkExtent2D windowExtent);
void destroyViewerFrames(const Context& context, ViewerFrames& frames);

// After a resize, or when presentation reports the swapchain stale. Waits for the device; the
// caller then sizes its HDR image to the new swapchain.extent.
void recreateSwapchain(const Context& context, ViewerFrames& frames, VkExtent2D windowExtent);

// Waits until the previous frame is done, so what it read (uniforms, probe, images) may change.
void waitForFrame(const Context& context, const ViewerFrames& frames);

struct FrameRequest {
    // Records the picture into the HDR image (swapchain.extent) that tonemapInput reads, leaving
    // it in SHADER_READ_ONLY_OPTIMAL.
    std::function<void(VkCommandBuffer)> recordPicture;
    VkDescriptorSet tonemapInput = VK_NULL_HANDLE;
    float exposure = 1.0f;
    bool capture = false; // read the presented image back (see readCapture)
};

enum class FrameResult {
    Presented,
    PresentedStale, // rendered and presented (or at least submitted), but recreate the swapchain
    NotDrawn,       // the swapchain was out of date: recreate it and draw again
};

// Renders and presents one frame.
FrameResult drawFrame(const Context& context, ViewerFrames& frames, const FrameRequest& request);

// The last captured frame as RGBA8 sRGB bytes, rows top down (waits for it).
std::vector<uint8_t> readCapture(const Context& context, const ViewerFrames& frames);

} // namespace shprobe
