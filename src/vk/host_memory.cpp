#include "vk/host_memory.h"

#include "common/scope_exit.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#include <cstdint>

namespace shprobe {

namespace {

constexpr VkExternalMemoryHandleTypeFlagBits kHostAllocation =
    VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT;

VkDeviceSize minImportAlignment(const Device& device) {
    VkPhysicalDeviceExternalMemoryHostPropertiesEXT host{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_MEMORY_HOST_PROPERTIES_EXT};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &host};
    vkGetPhysicalDeviceProperties2(device.physicalDevice, &properties);
    return host.minImportedHostPointerAlignment;
}

// Whether a linear image of this format, usage and size can be made over imported host memory.
bool linearImportable(const Device& device, VkFormat format, VkExtent2D extent, uint32_t layers,
                      VkImageUsageFlags usage) {
    VkPhysicalDeviceExternalImageFormatInfo external{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_IMAGE_FORMAT_INFO};
    external.handleType = kHostAllocation;
    VkPhysicalDeviceImageFormatInfo2 info{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_IMAGE_FORMAT_INFO_2, &external};
    info.format = format;
    info.type = VK_IMAGE_TYPE_2D;
    info.tiling = VK_IMAGE_TILING_LINEAR;
    info.usage = usage;
    VkExternalImageFormatProperties externalProperties{VK_STRUCTURE_TYPE_EXTERNAL_IMAGE_FORMAT_PROPERTIES};
    VkImageFormatProperties2 properties{VK_STRUCTURE_TYPE_IMAGE_FORMAT_PROPERTIES_2, &externalProperties};
    if (vkGetPhysicalDeviceImageFormatProperties2(device.physicalDevice, &info, &properties) != VK_SUCCESS)
        return false;
    const VkImageFormatProperties& limits = properties.imageFormatProperties;
    return (externalProperties.externalMemoryProperties.externalMemoryFeatures &
            VK_EXTERNAL_MEMORY_FEATURE_IMPORTABLE_BIT) &&
           limits.maxArrayLayers >= layers && limits.maxExtent.width >= extent.width &&
           limits.maxExtent.height >= extent.height;
}

VkImage createLinearImage(const Device& device, VkFormat format, VkExtent2D extent, uint32_t layers,
                          VkImageUsageFlags usage) {
    VkExternalMemoryImageCreateInfo external{VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO};
    external.handleTypes = kHostAllocation;
    VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO, &external};
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {extent.width, extent.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_LINEAR;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED; // what an image of external memory must start in
    VkImage image = VK_NULL_HANDLE;
    VK_CHECK(vkCreateImage(device.device, &info, nullptr, &image));
    return image;
}

// Whether the driver lays the image out as the texels lie: rows of `rowBytes`, layer after layer.
bool tightlyPacked(const Device& device, VkImage image, VkDeviceSize rowBytes, uint32_t height,
                   uint32_t layers) {
    VkImageSubresource first{VK_IMAGE_ASPECT_COLOR_BIT, 0, 0};
    VkSubresourceLayout layout{};
    vkGetImageSubresourceLayout(device.device, image, &first, &layout);
    return layout.offset == 0 && layout.rowPitch == rowBytes &&
           (layers == 1 || layout.arrayPitch == rowBytes * height);
}

// A device-local memory type that can hold host memory at `pointer` and the image, or UINT32_MAX.
uint32_t importMemoryType(const Device& device, void* pointer, uint32_t imageTypes) {
    auto properties = reinterpret_cast<PFN_vkGetMemoryHostPointerPropertiesEXT>(
        vkGetDeviceProcAddr(device.device, "vkGetMemoryHostPointerPropertiesEXT"));
    VkMemoryHostPointerPropertiesEXT host{VK_STRUCTURE_TYPE_MEMORY_HOST_POINTER_PROPERTIES_EXT};
    if (!properties || properties(device.device, kHostAllocation, pointer, &host) != VK_SUCCESS)
        return UINT32_MAX;
    for (uint32_t i = 0; i < device.memory.memoryTypeCount; ++i)
        if ((host.memoryTypeBits & imageTypes & (1u << i)) &&
            (device.memory.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT))
            return i;
    return UINT32_MAX;
}

} // namespace

std::optional<GpuImage> importHostImage(const Device& device, const void* texels, VkDeviceSize bytes,
                                        VkFormat format, VkExtent2D extent, uint32_t layers,
                                        VkImageUsageFlags usage) {
    // A CPU device only: its layouts are all one and its transitions touch no memory, so the texels
    // survive the transition from UNDEFINED, which Vulkan does not promise in general.
    if (!device.hostMemoryImport || device.info.type != VK_PHYSICAL_DEVICE_TYPE_CPU ||
        !linearImportable(device, format, extent, layers, usage))
        return std::nullopt;
    GpuImage image{.format = format, .extent = extent, .layers = layers};
    OnFailure undo([&] { destroyImage(device, image); });
    image.image = createLinearImage(device, format, extent, layers, usage);
    const VkDeviceSize layerBytes = bytes / layers;
    if (!tightlyPacked(device, image.image, layerBytes / extent.height, extent.height, layers)) {
        destroyImage(device, image);
        return std::nullopt;
    }
    // The import covers the whole pages around the texels: its start and size must be multiples of
    // minImportedHostPointerAlignment, and the image is bound where the texels begin.
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(device.device, image.image, &requirements);
    const VkDeviceSize pageSize = minImportAlignment(device);
    const auto address = reinterpret_cast<uintptr_t>(texels);
    const VkDeviceSize offset = address % pageSize;
    const uint32_t type =
        importMemoryType(device, reinterpret_cast<void*>(address - offset), requirements.memoryTypeBits);
    if (requirements.size > bytes || offset % requirements.alignment != 0 || type == UINT32_MAX) {
        destroyImage(device, image);
        return std::nullopt;
    }
    VkImportMemoryHostPointerInfoEXT import{VK_STRUCTURE_TYPE_IMPORT_MEMORY_HOST_POINTER_INFO_EXT};
    import.handleType = kHostAllocation;
    import.pHostPointer = reinterpret_cast<void*>(address - offset);
    VkMemoryAllocateInfo allocate{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, &import};
    allocate.allocationSize = (offset + bytes + pageSize - 1) / pageSize * pageSize;
    allocate.memoryTypeIndex = type;
    if (vkAllocateMemory(device.device, &allocate, nullptr, &image.memory) != VK_SUCCESS) {
        destroyImage(device, image);
        return std::nullopt;
    }
    VK_CHECK(vkBindImageMemory(device.device, image.image, image.memory, offset));
    image.view =
        createImageView(device, image.image, layers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D,
                        format, layers);
    return image;
}

} // namespace shprobe
