#include "vk/check.h"

namespace shprobe {

const char* vkResultName(VkResult result) {
    switch (result) {
#define SHPROBE_RESULT_NAME(name) case name: return #name;
        SHPROBE_RESULT_NAME(VK_NOT_READY)
        SHPROBE_RESULT_NAME(VK_TIMEOUT)
        SHPROBE_RESULT_NAME(VK_INCOMPLETE)
        SHPROBE_RESULT_NAME(VK_ERROR_OUT_OF_HOST_MEMORY)
        SHPROBE_RESULT_NAME(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        SHPROBE_RESULT_NAME(VK_ERROR_INITIALIZATION_FAILED)
        SHPROBE_RESULT_NAME(VK_ERROR_DEVICE_LOST)
        SHPROBE_RESULT_NAME(VK_ERROR_MEMORY_MAP_FAILED)
        SHPROBE_RESULT_NAME(VK_ERROR_LAYER_NOT_PRESENT)
        SHPROBE_RESULT_NAME(VK_ERROR_EXTENSION_NOT_PRESENT)
        SHPROBE_RESULT_NAME(VK_ERROR_FEATURE_NOT_PRESENT)
        SHPROBE_RESULT_NAME(VK_ERROR_INCOMPATIBLE_DRIVER)
        SHPROBE_RESULT_NAME(VK_ERROR_TOO_MANY_OBJECTS)
        SHPROBE_RESULT_NAME(VK_ERROR_FORMAT_NOT_SUPPORTED)
        SHPROBE_RESULT_NAME(VK_ERROR_FRAGMENTED_POOL)
        SHPROBE_RESULT_NAME(VK_ERROR_OUT_OF_POOL_MEMORY)
        SHPROBE_RESULT_NAME(VK_ERROR_UNKNOWN)
#undef SHPROBE_RESULT_NAME
    default: return "VkResult";
    }
}

void throwVkError(VkResult result, const char* call, const char* file, int line) {
    std::string where = std::string(file) + ":" + std::to_string(line);
    std::string message = std::string(call) + " failed with " + vkResultName(result) + " (" +
                          std::to_string(int(result)) + ") at " + where;
    if (result == VK_ERROR_DEVICE_LOST) message += ": the Vulkan device was lost";
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY)
        message += ": out of memory; try a smaller --face-size";
    throw Error(ErrorKind::Device, message);
}

} // namespace shprobe
