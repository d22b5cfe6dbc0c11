// VK_CHECK stays on in every build: a failed call throws Error(Device) naming the call, the
// result, what the program was doing (DeviceStep) and where it happened; a lost device and a lack
// of memory are said in words, with what to try.
#pragma once
#include "sh/error.h"
#include <string>
#include <vulkan/vulkan.h>

namespace shprobe {

const char* vkResultName(VkResult result);

// Names what the program uses the device for while it lives ("projecting the environment"); the
// error of any Vulkan call that fails meanwhile says so. Steps nest (the error names them outer to
// inner, "baking sky.exr: projecting the environment"); each thread has its own.
class DeviceStep {
public:
    explicit DeviceStep(std::string what);
    ~DeviceStep();
    DeviceStep(const DeviceStep&) = delete;
    DeviceStep& operator=(const DeviceStep&) = delete;
};

// The message VK_CHECK throws when `call` (its source text) returned `result`, e.g.
// "vkQueueSubmit(...) failed with VK_ERROR_DEVICE_LOST (-4) while projecting the environment
// (src/gpu/projector.cpp:120): the Vulkan device was lost ...".
std::string vkErrorMessage(VkResult result, const char* call, const char* file, int line);
[[noreturn]] void throwVkError(VkResult result, const char* call, const char* file, int line);

} // namespace shprobe

#define VK_CHECK(call)                                                                                       \
    do {                                                                                                     \
        VkResult vkCheckResult_ = (call);                                                                    \
        if (vkCheckResult_ != VK_SUCCESS) ::shprobe::throwVkError(vkCheckResult_, #call, __FILE__, __LINE__); \
    } while (0)
