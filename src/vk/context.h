// The Vulkan device the GPU passes work on (Device), and the program's own instance, device and
// queue around it (Context). Plain handles; createContext / destroyContext.
// Rendering asks for more through ContextOptions: a queue that also does graphics, extra instance
// and device extensions, and a window surface the queue must present to.
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include <vulkan/vulkan.h>

namespace shprobe {

struct ContextOptions {
    // Device to use: an index into listDevices(), or a case-insensitive part of its name.
    // Empty: the best one (discrete > integrated > virtual > CPU); SHPROBE_DEVICE overrides.
    std::string device;
    // Enable the Khronos validation layer (also with SHPROBE_VALIDATION=1). Every message is
    // printed to stderr and counted; creating the context fails if the layer is missing.
    bool validation = false;

    // Rendering: the queue must also do graphics; devices without such a queue are not used.
    bool graphics = false;
    // Extensions to enable beyond the ones shprobe needs (e.g. the window system's surface
    // extensions and VK_KHR_swapchain). Devices without the device extensions are not used.
    std::vector<std::string> instanceExtensions;
    std::vector<std::string> deviceExtensions;
    // Presentation: called once the instance exists, before a device is chosen. The surface it
    // returns is kept in Context::surface (destroyed by destroyContext) and the chosen queue must
    // be able to present to it; devices whose queue cannot are not used.
    std::function<VkSurfaceKHR(VkInstance)> createSurface;
};

struct DeviceInfo {
    uint32_t index = 0;
    std::string name;
    VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
    uint32_t apiVersion = 0;
    std::string driver; // driver name and info
    uint32_t subgroupSize = 0;
    bool subgroupArithmetic = false; // basic + arithmetic subgroup ops in compute shaders
    bool timestamps = false;         // the compute queue can write timestamps
    uint32_t timestampValidBits = 0; // bits of a timestamp that count (the rest are undefined)
    float timestampPeriod = 0.0f;    // nanoseconds per tick
    VkPhysicalDeviceLimits limits{};
    // Why the device cannot run shprobe (empty when it can).
    std::string unsupportedReason;
};

// What decides whether a device can run shprobe's compute shaders: Vulkan 1.1, a compute queue, and
// the subgroup operations of the projection's reduction (subgroupElect, subgroupAdd). Rendering
// adds its own requirements (ContextOptions). No optional VkPhysicalDeviceFeatures are enabled.
struct DeviceCapabilities {
    uint32_t apiVersion = 0;
    bool computeQueue = false;
    VkShaderStageFlags subgroupStages = 0;         // VkPhysicalDeviceSubgroupProperties::supportedStages
    VkSubgroupFeatureFlags subgroupOperations = 0; // ...::supportedOperations
};

// Why a device with these capabilities cannot run shprobe, naming what it lacks as Vulkan names it
// (e.g. VK_SUBGROUP_FEATURE_ARITHMETIC_BIT); empty when it can. `shprobe info` prints it.
std::string missingRequirement(const DeviceCapabilities& device);

// What a device is and why it cannot run shprobe (DeviceInfo::unsupportedReason, missingRequirement)
// with its work on `computeFamily`, a family that does compute work; none: the device has none.
// Every device is checked with it: createContext's, and an engine's lent one (borrowDevice).
DeviceInfo describeDevice(VkPhysicalDevice physicalDevice, uint32_t index,
                          std::optional<uint32_t> computeFamily);
// Whether the device has queue family `family` and it does compute work.
bool isComputeFamily(VkPhysicalDevice physicalDevice, uint32_t family);

// Counts validation messages; owned by the context and shared with the messenger callback.
struct ValidationLog {
    std::atomic<uint32_t> messages{0};
};

// What the GPU passes create their objects on: a logical device, what it is, and the pipeline
// cache its pipelines go through. Nothing here submits work: whoever owns the device's queue does.
// The program's own device (Context) is one, and so is an engine's device lent to shprobe
// (borrowDevice, gpu/probe_baker.h).
struct Device {
    VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    uint32_t queueFamily = 0; // where the work recorded for this device runs
    DeviceInfo info;
    VkPhysicalDeviceMemoryProperties memory{};
    VkPipelineCache pipelineCache = VK_NULL_HANDLE; // optional; destroyed by whoever set it
    bool hostMemoryImport = false; // VK_EXT_external_memory_host is enabled (vk/host_memory.h)
};

// The program's own Vulkan: the instance, the validation messenger, a window surface if asked
// for, and the device it created, with that device's queue and a command pool for the
// submissions of vk/resources.h. createContext / destroyContext. What submits work (or waits for
// it, or needs the surface or the pool) takes a Context; what only creates or destroys objects takes
// a Device.
struct Context : Device {
    VkInstance instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    VkSurfaceKHR surface = VK_NULL_HANDLE; // from ContextOptions::createSurface, if any
    VkQueue queue = VK_NULL_HANDLE;
    VkCommandPool commandPool = VK_NULL_HANDLE;
    std::unique_ptr<ValidationLog> validationLog;
    double instanceMilliseconds = 0.0; // createContext's wall time: the instance (and the driver list),
    double deviceMilliseconds = 0.0;   // then choosing the device and creating it with its queue and pool

    uint32_t validationMessages() const { return validationLog ? validationLog->messages.load() : 0; }
};

// Throws Error(Device) with a hint when there is no Vulkan loader, the driver list cannot be loaded
// (naming VK_DRIVER_FILES / VK_ICD_FILENAMES when set), or there is no device, or none usable.
Context createContext(const ContextOptions& options);
void destroyContext(Context& context);

// Every physical device with its properties, for `shprobe info` and device selection.
std::vector<DeviceInfo> listDevices(const ContextOptions& options);

// The device the options ask for: ContextOptions::device, else SHPROBE_DEVICE, else "" (the best).
std::string requestedDevice(const ContextOptions& options);

// The device to use: the one `request` names (an index or a part of the name; see ContextOptions)
// or else the best usable one. Throws Error(Device) when there is none, or when the one requested
// or every one cannot be used, naming each device and what it lacks: the run is refused, and the
// message points to `bake --backend cpu`.
const DeviceInfo& pickDevice(const std::vector<DeviceInfo>& devices, const std::string& request);

// The first file under `root` that shows a GPU a Vulkan driver on Linux could use: a device file by
// which a driver reaches its GPU (a DRM render node, dev/dri/renderD*: Mesa's drivers, AMD's,
// virtio-gpu's; a card node alone may be a display without a GPU; NVIDIA's dev/nvidia*, its Tegra
// ones dev/nvhost*, nvmap, nvgpu; WSL's dev/dxg; Arm's, Qualcomm's, Vivante's and Imagination's
// dev/mali*, kgsl*, galcore, pvrsrvkm), or NVIDIA's kernel module (proc/driver/nvidia), whose
// device files its Vulkan driver makes at its first use where none exist yet. "" where there is
// none: then any Vulkan device is a CPU one (lavapipe, SwiftShader), which needs no such file.
// Lists three folders: no Vulkan.
std::string findGpuFile(const std::string& root = "/");

const char* deviceTypeName(VkPhysicalDeviceType type);
std::string versionString(uint32_t version);

} // namespace shprobe
