// VK_CHECK stays on in every build: a failed call throws Error(Device) naming the call, the
// result and what the program was doing (DeviceStep); a lost device and a lack of memory are said
// in words, with what to try where that depends on what was being done. The source file and line
// stay out of the message (it is the user's); SHPROBE_DEBUG=1 prints them on a line of their own.
#pragma once
#include "common/error.h"
#include <string>
#include <vulkan/vulkan.h>

namespace shprobe {

const char* vkResultName(VkResult result);

// What kind of work a step is; the advice a failed call gets depends on it, since the same result
// means different things: VK_ERROR_OUT_OF_HOST_MEMORY from vkCreateInstance is how the loader
// reports a driver manifest that is not JSON, where "try a smaller --face-size" would mislead.
enum class DeviceWork {
    Sized,         // allocations, uploads and dispatches whose size follows the options (--face-size)
    Setup,         // creating the logical device and its pools: their size is fixed
    DriverLoading, // creating the instance and listing devices: the loader reads the driver list
};

// Names what the program uses the device for while it lives ("projecting the environment"); the
// error of any Vulkan call that fails meanwhile says so. Steps nest (the error names them outer to
// inner, "baking sky.exr: projecting the environment") and the innermost one's work decides the
// advice; each thread has its own. Outside any step a failure is said in words, without advice.
// `sizedBy` names the options a smaller value of which makes Sized work smaller ("--size" for a
// render target), for the advice.
class DeviceStep {
  public:
    explicit DeviceStep(std::string what, DeviceWork work = DeviceWork::Sized,
                        std::string sizedBy = "--face-size");
    ~DeviceStep();
    DeviceStep(const DeviceStep&) = delete;
    DeviceStep& operator=(const DeviceStep&) = delete;
};

// "; try a smaller OPTIONS" for the innermost step's options where its work is Sized, else empty
// (fixed-size work, or outside any step: no option makes it smaller).
std::string sizeAdvice();

// The message VK_CHECK throws when `call` (its source text) returned `result`, e.g.
// "vkQueueSubmit(...) failed with VK_ERROR_DEVICE_LOST (-4) while projecting the environment: the
// Vulkan device was lost ...".
std::string vkErrorMessage(VkResult result, const char* call);
// Throws vkErrorMessage's Error(Device); with SHPROBE_DEBUG set (not 0), first prints
// "shprobe: debug: CALL failed at src/FILE.cpp:LINE" to stderr.
[[noreturn]] void throwVkError(VkResult result, const char* call, const char* file, int line);

// The variable that replaces the loader's search of the icd.d folders (VK_DRIVER_FILES, or else
// VK_ICD_FILENAMES) with its value, "VK_ICD_FILENAMES=/tmp/x.json"; empty when neither is set to a
// list (one set but empty: emptyDriverListVariable).
std::string driverListVariable();
// The variable the loader reads that is set but empty, which lists no driver (the loader reads it
// as an empty list, not as unset): "VK_DRIVER_FILES", or else "VK_ICD_FILENAMES"; empty if none.
std::string emptyDriverListVariable();
// What to check when the driver list gives no usable driver: that variable and its value, the one
// set but empty, or the installed manifests; then lavapipe and `--backend cpu`.
std::string driverListAdvice();

} // namespace shprobe

#define VK_CHECK(call)                                                                                       \
    do {                                                                                                     \
        VkResult vkCheckResult_ = (call);                                                                    \
        if (vkCheckResult_ != VK_SUCCESS)                                                                    \
            ::shprobe::throwVkError(vkCheckResult_, #call, __FILE__, __LINE__);                              \
    } while (0)
