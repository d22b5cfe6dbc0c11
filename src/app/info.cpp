// `shprobe info`: the Vulkan devices, what `bake` and `scene` would run on, and the features the
// shaders rely on.
#include "app/bake_steps.h"
#include "app/commands.h"
#include "gpu/host_bake.h"
#include "vk/context.h"

#include <cstdio>
#include <string>
#include <thread>

namespace shprobe {

void addInfoOptions(CLI::App& command, InfoOptions& options) {
    command.add_flag("--validation", options.validation, "Enable the Khronos validation layer");
}

namespace {

void printDevice(const DeviceInfo& device) {
    const VkPhysicalDeviceLimits& limits = device.limits;
    std::printf("device %u: %s (%s)\n", device.index, device.name.c_str(), deviceTypeName(device.type));
    std::printf("  Vulkan %s, %s\n", versionString(device.apiVersion).c_str(), device.driver.c_str());
    std::printf("  subgroup size %u, subgroup arithmetic in compute: %s\n", device.subgroupSize,
                device.subgroupArithmetic ? "yes" : "no");
    std::printf("  max workgroup invocations %u, shared memory %u KiB, storage buffer range %u MiB\n",
                limits.maxComputeWorkGroupInvocations, limits.maxComputeSharedMemorySize / 1024,
                limits.maxStorageBufferRange >> 20);
    std::printf("  timestamps: %s\n", device.timestamps ? "yes" : "no (bake reports wall time only)");
    std::printf("  usable: %s\n",
                device.unsupportedReason.empty() ? "yes" : device.unsupportedReason.c_str());
}

// What --backend auto runs for a job too large for the CPU-at-once rule, by the rule bake and scene
// share (bake_steps.h): "cpu (why)" or "gpu: device N: NAME".
std::string autoChoice(const DeviceInfo* device, const std::string& cpuSuffix) {
    std::string reason = cpuReasonWithoutVulkan();
    if (reason.empty()) reason = cpuReasonForDevice(device);
    if (!reason.empty()) return "cpu (" + reason + (device ? cpuSuffix : "") + ")";
    return "gpu: device " + std::to_string(device->index) + ": " + device->name;
}

void printBackends(const std::vector<DeviceInfo>& devices, const ContextOptions& contextOptions) {
    const DeviceInfo* device = nullptr;
    std::string unusable;
    try {
        device = &pickDevice(devices, requestedDevice(contextOptions));
    } catch (const Error& error) {
        if (error.kind() != ErrorKind::Device) throw;
        unusable = error.what();
    }
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    std::printf("bake     --backend auto (the default): cpu for a job under %.3gM texels x coefficients "
                "(the CPU path on %u %s is done before Vulkan could start); a larger one: %s\n",
                smallJobWork() / 1e6, cores, cores == 1 ? "core" : "cores",
                autoChoice(device, ", where the CPU path is faster").c_str());
    if (device)
        std::printf("         --backend gpu, --device, --validation: device %u: %s (choose another with "
                    "--device INDEX|NAME or SHPROBE_DEVICE)\n",
                    device->index, device->name.c_str());
    else
        std::printf("         --backend gpu: %s\n", unusable.c_str());
    std::printf("scene    --backend auto (the default): %s\n", autoChoice(device, "").c_str());
}

} // namespace

void runInfo(const InfoOptions& options) {
    ContextOptions contextOptions;
    contextOptions.validation = options.validation;
    const std::vector<DeviceInfo> devices = listDevices(contextOptions);
    for (const DeviceInfo& device : devices)
        printDevice(device);
    printBackends(devices, contextOptions);
    std::printf("shaders need: Vulkan 1.1, subgroup basic + arithmetic in compute, storage buffers; "
                "GPU faces up to %d^2\n",
                kMaxGpuFaceSize);
}

} // namespace shprobe
