// The Vulkan commands shprobe calls, as pointers taken from the Vulkan loader (libvulkan.so.1) at
// the first call of any of them (loadVulkanCommands), not as symbols that the program links: a run
// that makes no device (`shprobe --help`, a bake on the CPU, `convert`) neither loads the loader
// nor needs one installed. The project compiles with VK_NO_PROTOTYPES, so
// that a command missing from the list below is a compile error, not a silent link to the loader.
//
// Private to the libraries and their tests (not installed): the names are the commands' own, in
// namespace shprobe, where a program that includes this and also calls Vulkan itself would see two
// of each. An engine that lends its device (borrowDevice) keeps calling its loader as it does.
#pragma once
#include <vulkan/vulkan.h>

// Every command is exported by the Linux loader (1.1 and later): core 1.0 and 1.1, surface, swapchain.
#define SHPROBE_VULKAN_COMMANDS(X)                                                                           \
    /* the loader, instances and physical devices */                                                         \
    X(vkGetInstanceProcAddr)                                                                                 \
    X(vkEnumerateInstanceVersion)                                                                            \
    X(vkEnumerateInstanceLayerProperties)                                                                    \
    X(vkEnumerateInstanceExtensionProperties)                                                                \
    X(vkCreateInstance)                                                                                      \
    X(vkDestroyInstance)                                                                                     \
    X(vkEnumeratePhysicalDevices)                                                                            \
    X(vkEnumerateDeviceExtensionProperties)                                                                  \
    X(vkGetPhysicalDeviceProperties)                                                                         \
    X(vkGetPhysicalDeviceProperties2)                                                                        \
    X(vkGetPhysicalDeviceQueueFamilyProperties)                                                              \
    X(vkGetPhysicalDeviceMemoryProperties)                                                                   \
    X(vkGetPhysicalDeviceFormatProperties)                                                                   \
    X(vkGetPhysicalDeviceImageFormatProperties2)                                                             \
    X(vkGetDeviceProcAddr)                                                                                   \
    X(vkCreateDevice)                                                                                        \
    X(vkDestroyDevice)                                                                                       \
    X(vkGetDeviceQueue)                                                                                      \
    X(vkDeviceWaitIdle)                                                                                      \
    /* memory, buffers and images */                                                                         \
    X(vkAllocateMemory)                                                                                      \
    X(vkFreeMemory)                                                                                          \
    X(vkMapMemory)                                                                                           \
    X(vkFlushMappedMemoryRanges)                                                                             \
    X(vkInvalidateMappedMemoryRanges)                                                                        \
    X(vkCreateBuffer)                                                                                        \
    X(vkDestroyBuffer)                                                                                       \
    X(vkGetBufferMemoryRequirements)                                                                         \
    X(vkBindBufferMemory)                                                                                    \
    X(vkCreateImage)                                                                                         \
    X(vkDestroyImage)                                                                                        \
    X(vkGetImageMemoryRequirements)                                                                          \
    X(vkGetImageSubresourceLayout)                                                                           \
    X(vkBindImageMemory)                                                                                     \
    X(vkCreateImageView)                                                                                     \
    X(vkDestroyImageView)                                                                                    \
    X(vkCreateSampler)                                                                                       \
    X(vkDestroySampler)                                                                                      \
    /* pipelines and their resources */                                                                      \
    X(vkCreateShaderModule)                                                                                  \
    X(vkDestroyShaderModule)                                                                                 \
    X(vkCreatePipelineCache)                                                                                 \
    X(vkGetPipelineCacheData)                                                                                \
    X(vkDestroyPipelineCache)                                                                                \
    X(vkCreateDescriptorSetLayout)                                                                           \
    X(vkDestroyDescriptorSetLayout)                                                                          \
    X(vkCreatePipelineLayout)                                                                                \
    X(vkDestroyPipelineLayout)                                                                               \
    X(vkCreateComputePipelines)                                                                              \
    X(vkCreateGraphicsPipelines)                                                                             \
    X(vkDestroyPipeline)                                                                                     \
    X(vkCreateDescriptorPool)                                                                                \
    X(vkDestroyDescriptorPool)                                                                               \
    X(vkAllocateDescriptorSets)                                                                              \
    X(vkFreeDescriptorSets)                                                                                  \
    X(vkUpdateDescriptorSets)                                                                                \
    X(vkCreateRenderPass)                                                                                    \
    X(vkDestroyRenderPass)                                                                                   \
    X(vkCreateFramebuffer)                                                                                   \
    X(vkDestroyFramebuffer)                                                                                  \
    X(vkCreateQueryPool)                                                                                     \
    X(vkDestroyQueryPool)                                                                                    \
    X(vkGetQueryPoolResults)                                                                                 \
    /* command buffers, submission and synchronization */                                                    \
    X(vkCreateCommandPool)                                                                                   \
    X(vkDestroyCommandPool)                                                                                  \
    X(vkAllocateCommandBuffers)                                                                              \
    X(vkFreeCommandBuffers)                                                                                  \
    X(vkResetCommandBuffer)                                                                                  \
    X(vkBeginCommandBuffer)                                                                                  \
    X(vkEndCommandBuffer)                                                                                    \
    X(vkQueueSubmit)                                                                                         \
    X(vkCreateFence)                                                                                         \
    X(vkDestroyFence)                                                                                        \
    X(vkResetFences)                                                                                         \
    X(vkWaitForFences)                                                                                       \
    X(vkCreateSemaphore)                                                                                     \
    X(vkDestroySemaphore)                                                                                    \
    /* recorded commands */                                                                                  \
    X(vkCmdPipelineBarrier)                                                                                  \
    X(vkCmdBindPipeline)                                                                                     \
    X(vkCmdBindDescriptorSets)                                                                               \
    X(vkCmdPushConstants)                                                                                    \
    X(vkCmdDispatch)                                                                                         \
    X(vkCmdCopyBuffer)                                                                                       \
    X(vkCmdCopyBufferToImage)                                                                                \
    X(vkCmdCopyImageToBuffer)                                                                                \
    X(vkCmdResetQueryPool)                                                                                   \
    X(vkCmdWriteTimestamp)                                                                                   \
    X(vkCmdBeginRenderPass)                                                                                  \
    X(vkCmdEndRenderPass)                                                                                    \
    X(vkCmdSetViewport)                                                                                      \
    X(vkCmdSetScissor)                                                                                       \
    X(vkCmdBindVertexBuffers)                                                                                \
    X(vkCmdBindIndexBuffer)                                                                                  \
    X(vkCmdDraw)                                                                                             \
    X(vkCmdDrawIndexed)                                                                                      \
    /* window surfaces and swapchains (the viewer) */                                                        \
    X(vkDestroySurfaceKHR)                                                                                   \
    X(vkGetPhysicalDeviceSurfaceSupportKHR)                                                                  \
    X(vkGetPhysicalDeviceSurfaceCapabilitiesKHR)                                                             \
    X(vkGetPhysicalDeviceSurfaceFormatsKHR)                                                                  \
    X(vkCreateSwapchainKHR)                                                                                  \
    X(vkDestroySwapchainKHR)                                                                                 \
    X(vkGetSwapchainImagesKHR)                                                                               \
    X(vkAcquireNextImageKHR)                                                                                 \
    X(vkQueuePresentKHR)

namespace shprobe {

#define SHPROBE_DECLARE_VULKAN_COMMAND(name) extern PFN_##name name;
SHPROBE_VULKAN_COMMANDS(SHPROBE_DECLARE_VULKAN_COMMAND)
#undef SHPROBE_DECLARE_VULKAN_COMMAND

// Loads libvulkan.so.1 and every command above, once per process (thread-safe; a failed load is
// tried again at the next call). Throws Error(Device) when there is no loader ("no Vulkan loader:
// ...; install libvulkan1, or bake with `--backend cpu`") or it lacks a command (a loader older
// than Vulkan 1.1). The first call of any command calls it: creating an instance, borrowing a
// device, or any other.
void loadVulkanCommands();

} // namespace shprobe
