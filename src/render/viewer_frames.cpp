#include "render/viewer_frames.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "render/gpu_image.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#include <algorithm>
#include <cstring>

namespace shprobe {

namespace {

// The presented image goes PRESENT_SRC -> TRANSFER_SRC, is copied, and goes back.
void recordCapture(VkCommandBuffer commands, ViewerFrames& frames, uint32_t imageIndex) {
    GpuImage image;
    image.image = frames.swapchain.images[imageIndex];
    image.format = frames.swapchain.format;
    image.extent = frames.swapchain.extent;
    changeLayout(commands, image,
                 {VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                  VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT});
    copyImageToBuffer(commands, image, frames.capture);
    changeLayout(commands, image,
                 {VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, 0, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0});
}

void prepareCapture(const Device& device, ViewerFrames& frames) {
    if (!frames.swapchain.copyable)
        throw Error(ErrorKind::Device, "this window's swapchain images cannot be copied: no screenshots here "
                                       "(`shprobe render` writes the same view offscreen)");
    VkDeviceSize size = VkDeviceSize(frames.swapchain.extent.width) * frames.swapchain.extent.height * 4;
    if (frames.capture.size == size) return;
    destroyBuffer(device, frames.capture);
    frames.capture =
        createBuffer(device, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Readback, "screenshot");
}

void submit(const Context& context, ViewerFrames& frames, uint32_t imageIndex) {
    VK_CHECK(vkResetFences(context.device, 1, &frames.frameDone));
    submitCommands(context, frames.commands, frames.frameDone,
                   {frames.acquired, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                    frames.swapchain.renderDone[imageIndex]});
}

bool present(const Context& context, const ViewerFrames& frames, uint32_t imageIndex) {
    VkPresentInfoKHR info{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
    info.waitSemaphoreCount = 1;
    info.pWaitSemaphores = &frames.swapchain.renderDone[imageIndex];
    info.swapchainCount = 1;
    info.pSwapchains = &frames.swapchain.swapchain;
    info.pImageIndices = &imageIndex;
    VkResult result = vkQueuePresentKHR(context.queue, &info);
    if (result == VK_ERROR_OUT_OF_DATE_KHR || result == VK_SUBOPTIMAL_KHR) return false;
    VK_CHECK(result);
    return true;
}

} // namespace

ViewerFrames createViewerFrames(const Context& context, VkExtent2D windowExtent) {
    ViewerFrames frames;
    OnFailure undo([&] { destroyViewerFrames(context, frames); });
    frames.tonemapper =
        createTonemapper(context, pickSwapchainFormat(context), VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
    frames.swapchain = createSwapchain(context, windowExtent, frames.tonemapper.format,
                                       frames.tonemapper.renderPass, VK_NULL_HANDLE);
    frames.commands = allocateCommandBuffer(context);
    frames.acquired = createSemaphore(context);
    frames.frameDone = createFence(context, true); // the first frame has nothing to wait for
    return frames;
}

void destroyViewerFrames(const Context& context, ViewerFrames& frames) {
    if (context.device) vkDeviceWaitIdle(context.device);
    destroyBuffer(context, frames.capture);
    if (frames.frameDone) vkDestroyFence(context.device, frames.frameDone, nullptr);
    if (frames.acquired) vkDestroySemaphore(context.device, frames.acquired, nullptr);
    if (frames.commands) vkFreeCommandBuffers(context.device, context.commandPool, 1, &frames.commands);
    destroySwapchain(context, frames.swapchain);
    destroyTonemapper(context, frames.tonemapper);
    frames = ViewerFrames{};
}

void recreateSwapchain(const Context& context, ViewerFrames& frames, VkExtent2D windowExtent) {
    VK_CHECK(vkDeviceWaitIdle(context.device));
    Swapchain old = frames.swapchain;
    frames.swapchain = Swapchain{};
    ScopeExit releaseOld([&] { destroySwapchain(context, old); }); // once the new one replaced it
    frames.swapchain = createSwapchain(context, windowExtent, frames.tonemapper.format,
                                       frames.tonemapper.renderPass, old.swapchain);
}

void waitForFrame(const Context& context, const ViewerFrames& frames) {
    VK_CHECK(vkWaitForFences(context.device, 1, &frames.frameDone, VK_TRUE, UINT64_MAX));
}

FrameResult drawFrame(const Context& context, ViewerFrames& frames, const FrameRequest& request) {
    waitForFrame(context, frames);
    uint32_t imageIndex = 0;
    VkResult acquired = vkAcquireNextImageKHR(context.device, frames.swapchain.swapchain, UINT64_MAX,
                                              frames.acquired, VK_NULL_HANDLE, &imageIndex);
    if (acquired == VK_ERROR_OUT_OF_DATE_KHR) return FrameResult::NotDrawn;
    if (acquired != VK_SUBOPTIMAL_KHR) VK_CHECK(acquired);
    if (request.capture) prepareCapture(context, frames);

    VK_CHECK(vkResetCommandBuffer(frames.commands, 0));
    beginCommands(frames.commands);
    request.recordPicture(frames.commands);
    recordTonemap(frames.commands, frames.tonemapper, request.tonemapInput,
                  frames.swapchain.framebuffers[imageIndex], frames.swapchain.extent, request.exposure);
    if (request.capture) recordCapture(frames.commands, frames, imageIndex);
    VK_CHECK(vkEndCommandBuffer(frames.commands));
    submit(context, frames, imageIndex);
    bool current = present(context, frames, imageIndex) && acquired == VK_SUCCESS;
    return current ? FrameResult::Presented : FrameResult::PresentedStale;
}

std::vector<uint8_t> readCapture(const Context& context, const ViewerFrames& frames) {
    waitForFrame(context, frames);
    invalidateBuffer(context, frames.capture);
    const auto* bytes = static_cast<const uint8_t*>(frames.capture.mapped);
    std::vector<uint8_t> rgba(bytes, bytes + frames.capture.size);
    bool bgra = frames.swapchain.format == VK_FORMAT_B8G8R8A8_SRGB ||
                frames.swapchain.format == VK_FORMAT_B8G8R8A8_UNORM;
    if (bgra)
        for (size_t i = 0; i < rgba.size(); i += 4)
            std::swap(rgba[i], rgba[i + 2]);
    return rgba;
}

} // namespace shprobe
