// The viewer's swapchain: images, views and framebuffers for the tonemap pass, and one
// "rendering done" semaphore per image. No window-system code: the surface comes from the context.
#pragma once
#include "vk/context.h"

#include <vector>

namespace shprobe {

struct Swapchain {
    VkSwapchainKHR swapchain = VK_NULL_HANDLE;
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkExtent2D extent{};
    bool copyable = false; // images can be copied from (screenshots)
    std::vector<VkImage> images;
    std::vector<VkImageView> views;
    std::vector<VkFramebuffer> framebuffers;
    std::vector<VkSemaphore> renderDone;
};

// B8G8R8A8_SRGB or R8G8B8A8_SRGB with the sRGB colour space where offered, else the first format.
VkFormat pickSwapchainFormat(const Context& context);

// `extent`: the window's framebuffer size, used when the surface leaves the choice to us.
// `renderPass`: the tonemap pass the framebuffers are made for. FIFO presentation.
Swapchain createSwapchain(const Context& context, VkExtent2D extent, VkFormat format, VkRenderPass renderPass,
                          VkSwapchainKHR oldSwapchain = VK_NULL_HANDLE);
void destroySwapchain(const Device& device, Swapchain& swapchain);

} // namespace shprobe
