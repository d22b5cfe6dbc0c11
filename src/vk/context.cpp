#include "vk/context.h"

#include "common/scope_exit.h"
#include "common/stopwatch.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <span>
#include <string_view>
#include <tuple>

namespace shprobe {

namespace {

constexpr const char* kHostMemoryExtension = VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME;

const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
// What a user can do when the devices there cannot run the shaders: nothing is baked on them.
const char* kCpuBackendHint =
    "; nothing was run on the device (`shprobe bake --backend cpu` bakes without one)";

// Vulkan's count-then-fill lists, `enumerate(&count, items)`, for the queries below: asked again
// where the list grew in between (VK_INCOMPLETE); a list that cannot be read counts as empty, so
// that what it would name counts as absent (a layer's extension, a device's).
template <class Item, class Enumerate> std::vector<Item> listed(const Enumerate& enumerate) {
    std::vector<Item> items;
    VkResult result = VK_INCOMPLETE;
    while (result == VK_INCOMPLETE) {
        uint32_t count = 0;
        if (enumerate(&count, nullptr) != VK_SUCCESS) return {};
        items.resize(count);
        result = enumerate(&count, items.data());
        items.resize(count);
    }
    return result == VK_SUCCESS ? items : std::vector<Item>{};
}

bool envFlag(const char* name) {
    const char* value = std::getenv(name);
    return value && *value && std::strcmp(value, "0") != 0;
}

// Synchronization validation (hazards between commands: missing barriers) comes with the layer's
// VK_EXT_validation_features, which Debian 12's layer (1.3.239) has; without it, the plain checks.
bool layerHasExtension(const char* layer, const char* extension) {
    const auto extensions = listed<VkExtensionProperties>([&](uint32_t* count, VkExtensionProperties* items) {
        return vkEnumerateInstanceExtensionProperties(layer, count, items);
    });
    return std::any_of(extensions.begin(), extensions.end(), [&](const VkExtensionProperties& e) {
        return std::strcmp(e.extensionName, extension) == 0;
    });
}

bool hasInstanceLayer(const char* name) {
    const auto layers = listed<VkLayerProperties>(vkEnumerateInstanceLayerProperties);
    return std::any_of(layers.begin(), layers.end(), [&](const VkLayerProperties& layer) {
        return std::strcmp(layer.layerName, name) == 0;
    });
}

// The loader reports through the messenger too, e.g. why it skipped a driver manifest. Those are
// not validation messages: they are neither counted (a bake must not fail for a driver list the
// loader copes with) nor printed (a failure stays one line); VK_LOADER_DEBUG=error prints them.
bool isLoaderMessage(const VkDebugUtilsMessengerCallbackDataEXT* data) {
    return data->pMessageIdName && std::strcmp(data->pMessageIdName, "Loader Message") == 0;
}

VKAPI_ATTR VkBool32 VKAPI_CALL onValidationMessage(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                                   VkDebugUtilsMessageTypeFlagsEXT,
                                                   const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                   void* user) {
    if (isLoaderMessage(data)) return VK_FALSE;
    static_cast<ValidationLog*>(user)->messages++;
    std::fprintf(stderr, "vulkan validation: %s\n", data->pMessage);
    return VK_FALSE;
}

VkDebugUtilsMessengerCreateInfoEXT messengerInfo(ValidationLog* log) {
    VkDebugUtilsMessengerCreateInfoEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    info.messageSeverity =
        VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    info.pfnUserCallback = onValidationMessage;
    info.pUserData = log;
    return info;
}

// The loader reads the driver list (VK_DRIVER_FILES, VK_ICD_FILENAMES or the icd.d folders) here,
// so a failure is said as the list's, whatever result the loader gives.
VkInstance createLoaderInstance(const VkInstanceCreateInfo& info) {
    DeviceStep step("loading the Vulkan driver list", DeviceWork::DriverLoading);
    VkInstance instance = VK_NULL_HANDLE;
    VkResult result = vkCreateInstance(&info, nullptr, &instance);
    // No driver installed and none named: the usual case on a machine without a GPU, in plain words.
    if (result == VK_ERROR_INCOMPATIBLE_DRIVER && driverListVariable().empty())
        throw Error(ErrorKind::Device, "no Vulkan driver found: " + driverListAdvice());
    if (result != VK_SUCCESS) throwVkError(result, "vkCreateInstance", __FILE__, __LINE__);
    return instance;
}

VkInstance createInstance(bool validation, ValidationLog* log,
                          const std::vector<std::string>& extraExtensions = {}) {
    uint32_t loaderVersion = 0;
    if (vkEnumerateInstanceVersion(&loaderVersion) != VK_SUCCESS || loaderVersion < VK_API_VERSION_1_1)
        throw Error(ErrorKind::Device, "no Vulkan 1.1 loader: install libvulkan1 1.1 or newer, or bake with "
                                       "`--backend cpu`");
    if (validation && !hasInstanceLayer(kValidationLayer))
        throw Error(ErrorKind::Device,
                    "validation requested but the Khronos validation layer is not installed "
                    "(Debian: apt-get install vulkan-validationlayers)");

    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "shprobe";
    app.apiVersion = VK_API_VERSION_1_3; // the highest version used; 1.1 devices work with it too

    std::vector<const char*> extensions;
    for (const std::string& extension : extraExtensions)
        extensions.push_back(extension.c_str());
    std::vector<const char*> layers;
    VkDebugUtilsMessengerCreateInfoEXT debugInfo = messengerInfo(log);
    const VkValidationFeatureEnableEXT synchronization =
        VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
    VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = &synchronization;
    VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    if (validation) {
        layers.push_back(kValidationLayer);
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
        info.pNext = &debugInfo; // also reports problems in vkCreateInstance / vkDestroyInstance
        if (layerHasExtension(kValidationLayer, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME)) {
            extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
            debugInfo.pNext = &features;
        }
    }
    info.pApplicationInfo = &app;
    info.enabledLayerCount = uint32_t(layers.size());
    info.ppEnabledLayerNames = layers.data();
    info.enabledExtensionCount = uint32_t(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    return createLoaderInstance(info);
}

std::vector<VkQueueFamilyProperties> queueFamilies(VkPhysicalDevice physicalDevice) {
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physicalDevice, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(physicalDevice, &count, families.data());
    return families;
}

std::optional<uint32_t> findComputeQueueFamily(VkPhysicalDevice physicalDevice) {
    const std::vector<VkQueueFamilyProperties> families = queueFamilies(physicalDevice);
    // Prefer a compute queue that also does graphics: it is the main queue of most devices.
    std::optional<uint32_t> computeOnly;
    for (uint32_t i = 0; i < families.size(); ++i) {
        if (!(families[i].queueFlags & VK_QUEUE_COMPUTE_BIT)) continue;
        if (families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) return i;
        if (!computeOnly) computeOnly = i;
    }
    return computeOnly;
}

int typeRank(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return 1; // lavapipe: slower, but a real device
    default:
        return 0;
    }
}

std::string lowercase(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return text;
}

bool isIndex(const std::string& text) {
    return !text.empty() &&
           std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
}

// Whether an index as typed ("0", "01") names device `index`; numbers too large for one never do.
bool requestsIndex(const std::string& request, uint32_t index) {
    uint32_t value = 0;
    auto [end, error] = std::from_chars(request.data(), request.data() + request.size(), value);
    return error == std::errc() && end == request.data() + request.size() && value == index;
}

const DeviceInfo& findRequestedDevice(const std::vector<DeviceInfo>& devices, const std::string& request) {
    for (const DeviceInfo& device : devices) {
        bool matches = isIndex(request)
                           ? requestsIndex(request, device.index)
                           : lowercase(device.name).find(lowercase(request)) != std::string::npos;
        if (matches) return device;
    }
    throw Error(ErrorKind::Device, "no Vulkan device matches '" + request + "' (see `shprobe info`)");
}

std::vector<VkPhysicalDevice> enumeratePhysicalDevices(VkInstance instance) {
    // The loader starts the listed drivers here; their failures are the driver list's too.
    DeviceStep step("listing the Vulkan devices", DeviceWork::DriverLoading);
    uint32_t count = 0;
    VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr));
    std::vector<VkPhysicalDevice> physicalDevices(count);
    VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, physicalDevices.data()));
    return physicalDevices;
}

std::vector<DeviceInfo> describeDevices(const std::vector<VkPhysicalDevice>& physicalDevices) {
    std::vector<DeviceInfo> devices;
    for (uint32_t i = 0; i < physicalDevices.size(); ++i)
        devices.push_back(describeDevice(physicalDevices[i], i, findComputeQueueFamily(physicalDevices[i])));
    return devices;
}

VkDevice createLogicalDevice(VkPhysicalDevice physicalDevice, uint32_t queueFamily,
                             const std::vector<std::string>& extensions) {
    std::vector<const char*> names;
    for (const std::string& extension : extensions)
        names.push_back(extension.c_str());
    float priority = 1.0f;
    VkDeviceQueueCreateInfo queue{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    queue.queueFamilyIndex = queueFamily;
    queue.queueCount = 1;
    queue.pQueuePriorities = &priority;
    VkDeviceCreateInfo info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queue;
    info.enabledExtensionCount = uint32_t(names.size());
    info.ppEnabledExtensionNames = names.data();
    VkDevice device = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDevice(physicalDevice, &info, nullptr, &device));
    return device;
}

VkDebugUtilsMessengerEXT createMessenger(VkInstance instance, ValidationLog* log) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
    if (!create) throw Error(ErrorKind::Device, "validation: VK_EXT_debug_utils is not available");
    VkDebugUtilsMessengerCreateInfoEXT info = messengerInfo(log);
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    VK_CHECK(create(instance, &info, nullptr, &messenger));
    return messenger;
}

bool hasDeviceExtension(VkPhysicalDevice physicalDevice, const std::string& name) {
    const auto extensions = listed<VkExtensionProperties>([&](uint32_t* count, VkExtensionProperties* items) {
        return vkEnumerateDeviceExtensionProperties(physicalDevice, nullptr, count, items);
    });
    return std::any_of(extensions.begin(), extensions.end(),
                       [&](const VkExtensionProperties& e) { return name == e.extensionName; });
}

// Why a device that can bake cannot do what the options add (graphics, extensions, presenting to
// the surface); empty when it can.
std::string renderingShortfall(VkPhysicalDevice physicalDevice, const ContextOptions& options,
                               VkSurfaceKHR surface) {
    uint32_t family = *findComputeQueueFamily(physicalDevice); // exists: the device can bake
    if (options.graphics && !(queueFamilies(physicalDevice)[family].queueFlags & VK_QUEUE_GRAPHICS_BIT))
        return "no queue that does both compute and graphics";
    for (const std::string& extension : options.deviceExtensions)
        if (!hasDeviceExtension(physicalDevice, extension)) return "no " + extension;
    VkBool32 presents = VK_FALSE;
    if (surface) VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(physicalDevice, family, surface, &presents));
    if (surface && !presents) return "its queue cannot present to the window";
    return {};
}

void applyRenderingRequirements(std::vector<DeviceInfo>& devices,
                                const std::vector<VkPhysicalDevice>& physicalDevices,
                                const ContextOptions& options, VkSurfaceKHR surface) {
    for (DeviceInfo& device : devices)
        if (device.unsupportedReason.empty())
            device.unsupportedReason = renderingShortfall(physicalDevices[device.index], options, surface);
}

} // namespace

std::string findGpuFile(const std::string& root) {
    namespace fs = std::filesystem;
    constexpr std::string_view kRenderNodes[] = {"renderD"};
    constexpr std::string_view kVendorNodes[] = {"nvidia", "nvhost", "nvmap",   "nvgpu",   "dxg",
                                                 "mali",   "kgsl",   "galcore", "pvrsrvkm"};
    constexpr std::string_view kNvidiaModule[] = {"nvidia"};
    const std::pair<const char*, std::span<const std::string_view>> kPlaces[] = {
        {"dev/dri", kRenderNodes}, {"dev", kVendorNodes}, {"proc/driver", kNvidiaModule}};
    for (const auto& [folder, prefixes] : kPlaces) {
        // A folder that cannot be listed holds nothing found: the iterator ends at once.
        std::error_code error;
        for (fs::directory_iterator it(fs::path(root) / folder, error), end; !error && it != end;
             it.increment(error)) {
            const std::string name = it->path().filename().string();
            if (std::any_of(prefixes.begin(), prefixes.end(),
                            [&](std::string_view prefix) { return name.starts_with(prefix); }))
                return it->path().string();
        }
    }
    return "";
}

const char* deviceTypeName(VkPhysicalDeviceType type) {
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return "CPU";
    default:
        return "other";
    }
}

std::string versionString(uint32_t version) {
    return std::to_string(VK_API_VERSION_MAJOR(version)) + "." +
           std::to_string(VK_API_VERSION_MINOR(version)) + "." +
           std::to_string(VK_API_VERSION_PATCH(version));
}

std::string missingRequirement(const DeviceCapabilities& device) {
    if (device.apiVersion < VK_API_VERSION_1_1)
        return "Vulkan " + versionString(device.apiVersion) + " (shprobe needs 1.1)";
    if (!device.computeQueue) return "no compute queue";
    if (!(device.subgroupStages & VK_SHADER_STAGE_COMPUTE_BIT))
        return "no subgroup operations in compute shaders (subgroup supportedStages lacks "
               "VK_SHADER_STAGE_COMPUTE_BIT)";
    const std::tuple<VkSubgroupFeatureFlagBits, const char*, const char*> operations[] = {
        {VK_SUBGROUP_FEATURE_BASIC_BIT, "VK_SUBGROUP_FEATURE_BASIC_BIT", "subgroupElect"},
        {VK_SUBGROUP_FEATURE_ARITHMETIC_BIT, "VK_SUBGROUP_FEATURE_ARITHMETIC_BIT", "subgroupAdd"}};
    for (const auto& [bit, name, use] : operations)
        if (!(device.subgroupOperations & bit))
            return std::string("no ") + name + " subgroup operations (" + use + ") in compute shaders";
    return {};
}

DeviceInfo describeDevice(VkPhysicalDevice physicalDevice, uint32_t index,
                          std::optional<uint32_t> computeFamily) {
    VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    properties.pNext = &subgroup;
    vkGetPhysicalDeviceProperties(physicalDevice, &properties.properties);
    if (properties.properties.apiVersion >= VK_API_VERSION_1_2) subgroup.pNext = &driver;
    vkGetPhysicalDeviceProperties2(physicalDevice, &properties);

    const VkPhysicalDeviceProperties& p = properties.properties;
    DeviceInfo info;
    info.index = index;
    info.name = p.deviceName;
    info.type = p.deviceType;
    info.apiVersion = p.apiVersion;
    info.driver = driver.driverName[0] ? std::string(driver.driverName) + " " + driver.driverInfo
                                       : "driver " + std::to_string(p.driverVersion);
    info.subgroupSize = subgroup.subgroupSize;
    info.limits = p.limits;
    info.timestampPeriod = p.limits.timestampPeriod;

    const VkSubgroupFeatureFlags needed = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
    info.subgroupArithmetic = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) &&
                              (subgroup.supportedOperations & needed) == needed;
    if (computeFamily) {
        info.timestampValidBits = queueFamilies(physicalDevice)[*computeFamily].timestampValidBits;
        info.timestamps = info.timestampValidBits > 0 && p.limits.timestampPeriod > 0.0f;
    }

    info.unsupportedReason = missingRequirement(
        {p.apiVersion, computeFamily.has_value(), subgroup.supportedStages, subgroup.supportedOperations});
    return info;
}

bool isComputeFamily(VkPhysicalDevice physicalDevice, uint32_t family) {
    const std::vector<VkQueueFamilyProperties> families = queueFamilies(physicalDevice);
    return family < families.size() && (families[family].queueFlags & VK_QUEUE_COMPUTE_BIT);
}

const DeviceInfo& pickDevice(const std::vector<DeviceInfo>& devices, const std::string& request) {
    if (devices.empty()) throw Error(ErrorKind::Device, "no Vulkan device found: " + driverListAdvice());
    if (!request.empty()) {
        const DeviceInfo& device = findRequestedDevice(devices, request);
        if (!device.unsupportedReason.empty())
            throw Error(ErrorKind::Device, "device " + device.name + " cannot be used: " +
                                               device.unsupportedReason + kCpuBackendHint);
        return device;
    }
    const DeviceInfo* best = nullptr;
    for (const DeviceInfo& device : devices)
        if (device.unsupportedReason.empty() && (!best || typeRank(device.type) > typeRank(best->type)))
            best = &device;
    if (best) return *best;
    std::string reasons;
    for (const DeviceInfo& device : devices)
        reasons += (reasons.empty() ? "" : "; ") + device.name + ": " + device.unsupportedReason;
    throw Error(ErrorKind::Device, "no usable Vulkan device (" + reasons + ")" + kCpuBackendHint);
}

std::string requestedDevice(const ContextOptions& options) {
    const char* fromEnvironment = std::getenv("SHPROBE_DEVICE");
    return options.device.empty() && fromEnvironment ? fromEnvironment : options.device;
}

std::vector<DeviceInfo> listDevices(const ContextOptions& options) {
    ValidationLog log;
    bool validation = options.validation || envFlag("SHPROBE_VALIDATION");
    VkInstance instance = createInstance(validation, &log);
    ScopeExit destroyInstance([&] { vkDestroyInstance(instance, nullptr); });
    return describeDevices(enumeratePhysicalDevices(instance));
}

Context createContext(const ContextOptions& options) {
    DeviceStep step("creating the Vulkan device", DeviceWork::Setup);
    Context context;
    auto start = Clock::now();
    bool validation = options.validation || envFlag("SHPROBE_VALIDATION");
    context.validationLog = std::make_unique<ValidationLog>();
    context.instance = createInstance(validation, context.validationLog.get(), options.instanceExtensions);
    OnFailure undo([&] { destroyContext(context); });
    if (validation) context.messenger = createMessenger(context.instance, context.validationLog.get());
    if (options.createSurface) context.surface = options.createSurface(context.instance);
    std::vector<VkPhysicalDevice> physicalDevices = enumeratePhysicalDevices(context.instance);
    context.instanceMilliseconds = millisecondsSince(start);
    start = Clock::now();
    std::vector<DeviceInfo> devices = describeDevices(physicalDevices);
    applyRenderingRequirements(devices, physicalDevices, options, context.surface);
    context.info = pickDevice(devices, requestedDevice(options));
    context.physicalDevice = physicalDevices[context.info.index];
    context.queueFamily = *findComputeQueueFamily(context.physicalDevice);
    vkGetPhysicalDeviceMemoryProperties(context.physicalDevice, &context.memory);
    // Bakes read host memory in place where the device can (vk/host_memory.h).
    std::vector<std::string> extensions = options.deviceExtensions;
    context.hostMemoryImport = hasDeviceExtension(context.physicalDevice, kHostMemoryExtension);
    if (context.hostMemoryImport) extensions.push_back(kHostMemoryExtension);
    context.device = createLogicalDevice(context.physicalDevice, context.queueFamily, extensions);
    vkGetDeviceQueue(context.device, context.queueFamily, 0, &context.queue);

    VkCommandPoolCreateInfo pool{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pool.queueFamilyIndex = context.queueFamily;
    VK_CHECK(vkCreateCommandPool(context.device, &pool, nullptr, &context.commandPool));
    context.deviceMilliseconds = millisecondsSince(start);
    return context;
}

void destroyContext(Context& context) {
    if (context.commandPool) vkDestroyCommandPool(context.device, context.commandPool, nullptr);
    if (context.device) vkDestroyDevice(context.device, nullptr);
    if (context.surface) vkDestroySurfaceKHR(context.instance, context.surface, nullptr);
    if (context.messenger) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(context.instance, "vkDestroyDebugUtilsMessengerEXT"));
        destroy(context.instance, context.messenger, nullptr);
    }
    if (context.instance) vkDestroyInstance(context.instance, nullptr);
    context.commandPool = VK_NULL_HANDLE;
    context.device = VK_NULL_HANDLE;
    context.surface = VK_NULL_HANDLE;
    context.messenger = VK_NULL_HANDLE;
    context.instance = VK_NULL_HANDLE;
}

} // namespace shprobe
