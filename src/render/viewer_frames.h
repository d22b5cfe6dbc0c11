// The viewer's per-frame Vulkan work, without the window system: the swapchain, the HDR scene
// targets at its size, one command buffer, its fence and the acquire semaphore (one frame in
// flight), and screenshots read back from the presented image.
#pragma once
#include "shprobe/render/scene_renderer.h"
#include "shprobe/render/swapchain.h"
#include "shprobe/render/tonemap.h"

#include <cstdint>
#include <vector>

namespace shprobe {

struct ViewerFrames {
    Tonemapper tonemapper; // into the swapchain's format, ending in PRESENT_SRC_KHR
    Swapchain swapchain;
    SceneTargets targets;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkSemaphore acquired = VK_NULL_HANDLE;
    VkFence frameDone = VK_NULL_HANDLE; // signalled when the last submitted frame finished
    Buffer capture;                     // readback of the presented image, when asked for
};

ViewerFrames createViewerFrames(const Context& context, const SceneRenderer& renderer,
                                VkExtent2D windowExtent);
void destroyViewerFrames(const Context& context, ViewerFrames& frames);

// After a resize, or when presentation reports the swapchain stale. Waits for the device.
void recreateSwapchain(const Context& context, const SceneRenderer& renderer, ViewerFrames& frames,
                       VkExtent2D windowExtent);

// Waits until the previous frame is done, so the renderer's uniforms, probe and environment may change.
void waitForFrame(const Context& context, const ViewerFrames& frames);

struct FrameRequest {
    const Scene* scene = nullptr;
    float exposure = 1.0f;
    bool capture = false; // read the presented image back (see readCapture)
};

enum class FrameResult {
    Presented,
    PresentedStale, // rendered and presented (or at least submitted), but recreate the swapchain
    NotDrawn,       // the swapchain was out of date: recreate it and draw again
};

// Renders and presents one frame.
FrameResult drawFrame(const Context& context, SceneRenderer& renderer, ViewerFrames& frames,
                      const FrameRequest& request);

// The last captured frame as RGBA8 sRGB bytes, rows top down (waits for it).
std::vector<uint8_t> readCapture(const Context& context, const ViewerFrames& frames);

} // namespace shprobe
