#include "vk/check.h"

#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <vector>

namespace shprobe {

namespace {

struct Step {
    std::string what;
    DeviceWork work;
    std::string sizedBy;
};

thread_local std::vector<Step> deviceSteps;

std::string currentSteps() {
    std::string steps;
    for (const Step& step : deviceSteps)
        steps += (steps.empty() ? "" : ": ") + step.what;
    return steps;
}

// Outside any step the work is unknown, so nothing that depends on it is suggested.
DeviceWork currentWork() {
    return deviceSteps.empty() ? DeviceWork::Setup : deviceSteps.back().work;
}

// The path from the source tree's src/ on ("src/vk/resources.cpp"), not the build machine's.
std::string sourcePath(std::string_view file) {
    size_t at = file.rfind("/src/");
    return std::string(at == std::string_view::npos ? file : file.substr(at + 1));
}

const char* kLavapipeHint =
    "without a GPU, Mesa's lavapipe works (Debian: apt-get install mesa-vulkan-drivers), "
    "or bake with `--backend cpu`";

// Sized work is always inside a step: the options that size it, for the advice.
std::string trySmaller() {
    return "try a smaller " + deviceSteps.back().sizedBy;
}

// Work whose size follows the options: a smaller one may fit, or finish before a watchdog.
std::string sizedWorkExplanation(VkResult result) {
    const std::string smaller = trySmaller();
    switch (result) {
    case VK_ERROR_DEVICE_LOST:
        return ": the Vulkan device was lost (a driver crash or GPU reset; a watchdog may stop long "
               "dispatches: " +
               smaller + " or --texels-per-invocation, or --backend cpu)";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
        return ": out of device memory; " + smaller + " (or --backend cpu)";
    case VK_ERROR_OUT_OF_HOST_MEMORY:
        return ": out of host memory; " + smaller;
    default:
        return "";
    }
}

// Work of a fixed size: no option makes it smaller, only the CPU backend avoids it.
std::string setupExplanation(VkResult result) {
    switch (result) {
    case VK_ERROR_DEVICE_LOST:
        return ": the Vulkan device was lost (a driver crash or GPU reset; `--backend cpu` bakes without it)";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
        return ": out of device memory (`--backend cpu` bakes without the device)";
    case VK_ERROR_OUT_OF_HOST_MEMORY:
        return ": out of host memory";
    default:
        return "";
    }
}

// The loader's results while it reads the driver list say what is wrong with the list: a manifest
// it cannot parse comes back as VK_ERROR_OUT_OF_HOST_MEMORY, a list with no loadable driver (missing
// manifest, missing library, a library that is no driver) as VK_ERROR_INCOMPATIBLE_DRIVER.
std::string driverLoadingExplanation(VkResult result) {
    std::string cause;
    if (result == VK_ERROR_OUT_OF_HOST_MEMORY)
        cause = " (a driver manifest that is not valid JSON reads as out of host memory)";
    if (result == VK_ERROR_INCOMPATIBLE_DRIVER) cause = " (no driver it names could be loaded)";
    return ": the Vulkan driver list could not be loaded" + cause + "; " + driverListAdvice();
}

// What the result means for the user, and what to try.
std::string explanation(VkResult result, DeviceWork work) {
    switch (work) {
    case DeviceWork::Sized:
        return sizedWorkExplanation(result);
    case DeviceWork::Setup:
        return setupExplanation(result);
    case DeviceWork::DriverLoading:
        return driverLoadingExplanation(result);
    }
    return "";
}

} // namespace

const char* vkResultName(VkResult result) {
    switch (result) {
#define SHPROBE_RESULT_NAME(name)                                                                            \
    case name:                                                                                               \
        return #name;
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
    default:
        return "VkResult";
    }
}

DeviceStep::DeviceStep(std::string what, DeviceWork work, std::string sizedBy) {
    deviceSteps.push_back({std::move(what), work, std::move(sizedBy)});
}

std::string sizeAdvice() {
    return currentWork() == DeviceWork::Sized ? "; " + trySmaller() : "";
}

DeviceStep::~DeviceStep() {
    deviceSteps.pop_back();
}

std::string vkErrorMessage(VkResult result, const char* call) {
    std::string message =
        std::string(call) + " failed with " + vkResultName(result) + " (" + std::to_string(int(result)) + ")";
    std::string steps = currentSteps();
    if (!steps.empty()) message += " while " + steps;
    return message + explanation(result, currentWork());
}

void throwVkError(VkResult result, const char* call, const char* file, int line) {
    if (const char* debug = std::getenv("SHPROBE_DEBUG"); debug && *debug && std::string_view(debug) != "0")
        std::fprintf(stderr, "shprobe: debug: %s failed at %s:%d\n", call, sourcePath(file).c_str(), line);
    throw Error(ErrorKind::Device, vkErrorMessage(result, call));
}

std::string driverListVariable() {
    const char* driverFiles = std::getenv("VK_DRIVER_FILES");
    const char* icdFilenames = std::getenv("VK_ICD_FILENAMES");
    bool hasDriverFiles = driverFiles && *driverFiles, hasIcdFilenames = icdFilenames && *icdFilenames;
    // The loader reads VK_ICD_FILENAMES, the older name, only when VK_DRIVER_FILES is not set (set
    // but empty, it lists no driver: emptyDriverListVariable).
    if (driverFiles && !hasDriverFiles) return {};
    if (hasDriverFiles)
        return std::string("VK_DRIVER_FILES=") + driverFiles +
               (hasIcdFilenames ? " (it overrides VK_ICD_FILENAMES)" : "");
    return hasIcdFilenames ? std::string("VK_ICD_FILENAMES=") + icdFilenames : std::string();
}

std::string emptyDriverListVariable() {
    const char* driverFiles = std::getenv("VK_DRIVER_FILES");
    const char* icdFilenames = std::getenv("VK_ICD_FILENAMES");
    if (driverFiles) return *driverFiles ? std::string() : "VK_DRIVER_FILES";
    return icdFilenames && !*icdFilenames ? "VK_ICD_FILENAMES" : std::string();
}

std::string driverListAdvice() {
    const std::string variable = driverListVariable(), empty = emptyDriverListVariable();
    std::string check = "install a Vulkan driver or check the installed ones";
    if (!variable.empty())
        check = "check " + variable;
    else if (!empty.empty())
        check = empty + " is set but empty, which lists no driver" +
                (empty == "VK_DRIVER_FILES" && std::getenv("VK_ICD_FILENAMES")
                     ? " (it overrides VK_ICD_FILENAMES)"
                     : "") +
                ": unset it or name a driver manifest in it";
    return check + " (VK_LOADER_DEBUG=error says why a driver is refused); " + kLavapipeHint;
}

} // namespace shprobe
