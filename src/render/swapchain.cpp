#include "render/swapchain.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "vk/check.h"
#include "vk/graphics.h"
#include "vk/image.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"

#include <algorithm>

namespace shprobe {

namespace {

std::vector<VkSurfaceFormatKHR> surfaceFormats(const Context& context) {
    uint32_t count = 0;
    VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(context.physicalDevice, context.surface, &count, nullptr));
    std::vector<VkSurfaceFormatKHR> formats(count);
    VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(context.physicalDevice, context.surface, &count,
                                                  formats.data()));
    if (formats.empty()) throw Error(ErrorKind::Device, "the window surface offers no format");
    return formats;
}

VkExtent2D chooseExtent(const VkSurfaceCapabilitiesKHR& capabilities, VkExtent2D wanted) {
    if (capabilities.currentExtent.width != UINT32_MAX) return capabilities.currentExtent;
    return {
        std::clamp(wanted.width, capabilities.minImageExtent.width, capabilities.maxImageExtent.width),
        std::clamp(wanted.height, capabilities.minImageExtent.height, capabilities.maxImageExtent.height)};
}

VkSwapchainKHR createHandle(const Context& context, const VkSurfaceCapabilitiesKHR& capabilities,
                            const Swapchain& swapchain, VkSwapchainKHR oldSwapchain) {
    VkSwapchainCreateInfoKHR info{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
    info.surface = context.surface;
    info.minImageCount = std::max(2u, capabilities.minImageCount);
    if (capabilities.maxImageCount > 0)
        info.minImageCount = std::min(info.minImageCount, capabilities.maxImageCount);
    info.imageFormat = swapchain.format;
    info.imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
    info.imageExtent = swapchain.extent;
    info.imageArrayLayers = 1;
    info.imageUsage =
        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | (swapchain.copyable ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0);
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = capabilities.currentTransform;
    info.compositeAlpha =
        (capabilities.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
            ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
            : VkCompositeAlphaFlagBitsKHR(capabilities.supportedCompositeAlpha &
                                          -capabilities.supportedCompositeAlpha); // lowest bit
    info.presentMode = VK_PRESENT_MODE_FIFO_KHR;                                  // always supported
    info.clipped = VK_TRUE;
    info.oldSwapchain = oldSwapchain;
    VkSwapchainKHR handle = VK_NULL_HANDLE;
    VK_CHECK(vkCreateSwapchainKHR(context.device, &info, nullptr, &handle));
    return handle;
}

} // namespace

VkFormat pickSwapchainFormat(const Context& context) {
    std::vector<VkSurfaceFormatKHR> formats = surfaceFormats(context);
    for (VkFormat wanted : {VK_FORMAT_B8G8R8A8_SRGB, VK_FORMAT_R8G8B8A8_SRGB})
        for (const VkSurfaceFormatKHR& format : formats)
            if (format.format == wanted && format.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR)
                return wanted;
    return formats.front().format == VK_FORMAT_UNDEFINED ? VK_FORMAT_B8G8R8A8_UNORM : formats.front().format;
}

Swapchain createSwapchain(const Context& context, VkExtent2D extent, VkFormat format, VkRenderPass renderPass,
                          VkSwapchainKHR oldSwapchain) {
    VkSurfaceCapabilitiesKHR capabilities;
    VK_CHECK(
        vkGetPhysicalDeviceSurfaceCapabilitiesKHR(context.physicalDevice, context.surface, &capabilities));
    Swapchain swapchain;
    swapchain.format = format;
    swapchain.extent = chooseExtent(capabilities, extent);
    swapchain.copyable = capabilities.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    OnFailure undo([&] { destroySwapchain(context, swapchain); });
    swapchain.swapchain = createHandle(context, capabilities, swapchain, oldSwapchain);
    uint32_t count = 0;
    VK_CHECK(vkGetSwapchainImagesKHR(context.device, swapchain.swapchain, &count, nullptr));
    swapchain.images.resize(count);
    VK_CHECK(vkGetSwapchainImagesKHR(context.device, swapchain.swapchain, &count, swapchain.images.data()));
    for (VkImage image : swapchain.images) {
        swapchain.views.push_back(createImageView(context, image, VK_IMAGE_VIEW_TYPE_2D, format));
        swapchain.framebuffers.push_back(
            createFramebuffer(context, renderPass, {&swapchain.views.back(), 1}, swapchain.extent));
        swapchain.renderDone.push_back(createSemaphore(context));
    }
    return swapchain;
}

void destroySwapchain(const Device& device, Swapchain& swapchain) {
    for (VkSemaphore semaphore : swapchain.renderDone)
        if (semaphore) vkDestroySemaphore(device.device, semaphore, nullptr);
    for (VkFramebuffer framebuffer : swapchain.framebuffers)
        vkDestroyFramebuffer(device.device, framebuffer, nullptr);
    for (VkImageView view : swapchain.views)
        vkDestroyImageView(device.device, view, nullptr);
    if (swapchain.swapchain) vkDestroySwapchainKHR(device.device, swapchain.swapchain, nullptr);
    swapchain = Swapchain{};
}

} // namespace shprobe
