#include "vk/check.h"

#include <string_view>
#include <vector>

namespace shprobe {

namespace {

thread_local std::vector<std::string> deviceSteps;

std::string currentSteps() {
    std::string steps;
    for (const std::string& step : deviceSteps) steps += (steps.empty() ? "" : ": ") + step;
    return steps;
}

// The path from the source tree's src/ on ("src/vk/resources.cpp"), not the build machine's.
std::string sourcePath(std::string_view file) {
    size_t at = file.rfind("/src/");
    return std::string(at == std::string_view::npos ? file : file.substr(at + 1));
}

// What the result means for the user, and what to try.
const char* explanation(VkResult result) {
    switch (result) {
    case VK_ERROR_DEVICE_LOST:
        return ": the Vulkan device was lost (a driver crash or GPU reset; a watchdog may stop long dispatches: "
               "try a smaller --face-size or --texels-per-invocation, or --backend cpu)";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
        return ": out of device memory; try a smaller --face-size (or --backend cpu)";
    case VK_ERROR_OUT_OF_HOST_MEMORY:
        return ": out of host memory; try a smaller --face-size";
    default: return "";
    }
}

} // namespace

const char* vkResultName(VkResult result) {
    switch (result) {
#define SHPROBE_RESULT_NAME(name) case name: return #name;
        SHPROBE_RESULT_NAME(VK_SUCCESS)
        SHPROBE_RESULT_NAME(VK_NOT_READY)
        SHPROBE_RESULT_NAME(VK_TIMEOUT)
        SHPROBE_RESULT_NAME(VK_EVENT_SET)
        SHPROBE_RESULT_NAME(VK_EVENT_RESET)
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
        SHPROBE_RESULT_NAME(VK_ERROR_UNKNOWN)
        SHPROBE_RESULT_NAME(VK_ERROR_OUT_OF_POOL_MEMORY)
        SHPROBE_RESULT_NAME(VK_ERROR_INVALID_EXTERNAL_HANDLE)
        SHPROBE_RESULT_NAME(VK_ERROR_FRAGMENTATION)
        SHPROBE_RESULT_NAME(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
        SHPROBE_RESULT_NAME(VK_PIPELINE_COMPILE_REQUIRED)
        SHPROBE_RESULT_NAME(VK_ERROR_SURFACE_LOST_KHR)
        SHPROBE_RESULT_NAME(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
        SHPROBE_RESULT_NAME(VK_SUBOPTIMAL_KHR)
        SHPROBE_RESULT_NAME(VK_ERROR_OUT_OF_DATE_KHR)
        SHPROBE_RESULT_NAME(VK_ERROR_VALIDATION_FAILED_EXT)
#undef SHPROBE_RESULT_NAME
    default: return "VkResult";
    }
}

DeviceStep::DeviceStep(std::string what) { deviceSteps.push_back(std::move(what)); }

DeviceStep::~DeviceStep() { deviceSteps.pop_back(); }

std::string vkErrorMessage(VkResult result, const char* call, const char* file, int line) {
    std::string message =
        std::string(call) + " failed with " + vkResultName(result) + " (" + std::to_string(int(result)) + ")";
    std::string steps = currentSteps();
    if (!steps.empty()) message += " while " + steps;
    return message + " (" + sourcePath(file) + ":" + std::to_string(line) + ")" + explanation(result);
}

void throwVkError(VkResult result, const char* call, const char* file, int line) {
    throw Error(ErrorKind::Device, vkErrorMessage(result, call, file, line));
}

} // namespace shprobe
