// VK_CHECK stays on in every build: a failed call throws Error(Device) naming the call, the
// result and where it happened. The caller's message says what was being done.
#pragma once
#include "sh/error.h"
#include <string>
#include <vulkan/vulkan.h>

namespace shprobe {

const char* vkResultName(VkResult result);
[[noreturn]] void throwVkError(VkResult result, const char* call, const char* file, int line);

} // namespace shprobe

#define VK_CHECK(call)                                                                                       \
    do {                                                                                                     \
        VkResult vkCheckResult_ = (call);                                                                    \
        if (vkCheckResult_ != VK_SUCCESS) ::shprobe::throwVkError(vkCheckResult_, #call, __FILE__, __LINE__); \
    } while (0)
