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

// Whether a linear image of this format, usage and size can be made, over imported host memory
// (handleTypes kHostAllocation) or over memory of its own (0).
bool linearSupported(const Device& device, VkFormat format, VkExtent2D extent, uint32_t layers,
                     VkImageUsageFlags usage, VkExternalMemoryHandleTypeFlags handleTypes) {
    const bool imported = handleTypes != 0;
    VkPhysicalDeviceExternalImageFormatInfo external{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_IMAGE_FORMAT_INFO};
    external.handleType = kHostAllocation;
    VkPhysicalDeviceImageFormatInfo2 info{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_IMAGE_FORMAT_INFO_2,
                                          imported ? &external : nullptr};
    info.format = format;
    info.type = VK_IMAGE_TYPE_2D;
    info.tiling = VK_IMAGE_TILING_LINEAR;
    info.usage = usage;
    VkExternalImageFormatProperties externalProperties{VK_STRUCTURE_TYPE_EXTERNAL_IMAGE_FORMAT_PROPERTIES};
    VkImageFormatProperties2 properties{VK_STRUCTURE_TYPE_IMAGE_FORMAT_PROPERTIES_2,
                                        imported ? &externalProperties : nullptr};
    if (vkGetPhysicalDeviceImageFormatProperties2(device.physicalDevice, &info, &properties) != VK_SUCCESS)
        return false;
    const VkImageFormatProperties& limits = properties.imageFormatProperties;
    const bool importable = (externalProperties.externalMemoryProperties.externalMemoryFeatures &
                             VK_EXTERNAL_MEMORY_FEATURE_IMPORTABLE_BIT) != 0;
    return (importable || !imported) && limits.maxArrayLayers >= layers &&
           limits.maxExtent.width >= extent.width && limits.maxExtent.height >= extent.height;
}

// An image of external host memory (handleTypes kHostAllocation) must start in UNDEFINED; one of its
// own memory (0) starts in PREINITIALIZED, which keeps what the host writes before the first
// transition.
VkImage createLinearImage(const Device& device, VkFormat format, VkExtent2D extent, uint32_t layers,
                          VkImageUsageFlags usage, VkExternalMemoryHandleTypeFlags handleTypes) {
    const bool imported = handleTypes != 0;
    VkExternalMemoryImageCreateInfo external{VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO};
    external.handleTypes = handleTypes;
    VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO, imported ? &external : nullptr};
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {extent.width, extent.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_LINEAR;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = imported ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_PREINITIALIZED;
    VkImage image = VK_NULL_HANDLE;
    VK_CHECK(vkCreateImage(device.device, &info, nullptr, &image));
    return image;
}

// The driver's layout of the first layer (rowPitch, arrayPitch: the same for every layer).
VkSubresourceLayout firstLayerLayout(const Device& device, VkImage image) {
    VkImageSubresource first{VK_IMAGE_ASPECT_COLOR_BIT, 0, 0};
    VkSubresourceLayout layout{};
    vkGetImageSubresourceLayout(device.device, image, &first, &layout);
    return layout;
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

// A view of all the image's layers: 2D for one, a 2D array for more.
VkImageView createLayersView(const Device& device, const GpuImage& image) {
    const VkImageViewType type = image.layers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
    return createImageView(device, image.image, type, image.format, image.layers);
}

} // namespace

std::optional<GpuImage> importHostImage(const Device& device, const void* texels, VkDeviceSize bytes,
                                        VkFormat format, VkExtent2D extent, uint32_t layers,
                                        VkImageUsageFlags usage) {
    // A CPU device only: its layouts are all one and its transitions touch no memory, so the texels
    // survive the transition from UNDEFINED, which Vulkan does not promise in general.
    if (!device.hostMemoryImport || device.info.type != VK_PHYSICAL_DEVICE_TYPE_CPU ||
        !linearSupported(device, format, extent, layers, usage, kHostAllocation))
        return std::nullopt;
    GpuImage image{.format = format, .extent = extent, .layers = layers};
    OnFailure undo([&] { destroyImage(device, image); });
    image.image = createLinearImage(device, format, extent, layers, usage, kHostAllocation);
    const VkDeviceSize layerBytes = bytes / layers;
    const VkSubresourceLayout layout = firstLayerLayout(device, image.image);
    const VkDeviceSize rowBytes = layerBytes / extent.height;
    if (layout.offset != 0 || layout.rowPitch != rowBytes ||
        (layers > 1 && layout.arrayPitch != layerBytes)) {
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
    image.view = createLayersView(device, image);
    return image;
}

std::optional<MappedImage> createMappedImage(const Device& device, VkFormat format, VkExtent2D extent,
                                             uint32_t layers, VkImageUsageFlags usage, const char* what) {
    // A CPU device only: there, a linear image in host memory is read as fast as any, and the
    // driver's layout is what the host writes; on a GPU it would be read across the bus.
    if (device.info.type != VK_PHYSICAL_DEVICE_TYPE_CPU ||
        !linearSupported(device, format, extent, layers, usage, 0))
        return std::nullopt;
    MappedImage mapped{.image = {.format = format, .extent = extent, .layers = layers}};
    GpuImage& image = mapped.image;
    OnFailure undo([&] { destroyImage(device, image); });
    image.image = createLinearImage(device, format, extent, layers, usage, 0);
    const VkSubresourceLayout layout = firstLayerLayout(device, image.image);
    mapped.rows = {.rowPitch = layout.rowPitch, .layerPitch = layout.arrayPitch};
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(device.device, image.image, &requirements);
    const uint32_t type =
        imageMemoryType(device, requirements.memoryTypeBits,
                        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    if (layout.offset != 0 || type == UINT32_MAX) {
        destroyImage(device, image);
        return std::nullopt;
    }
    bindImageMemory(device, image, type, what);
    VK_CHECK(vkMapMemory(device.device, image.memory, 0, VK_WHOLE_SIZE, 0, &mapped.texels));
    image.view = createLayersView(device, image);
    return mapped;
}

} // namespace shprobe
