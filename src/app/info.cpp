// `shprobe info`: the Vulkan devices, which one a bake would use, and the features it relies on.
#include "app/commands.h"
#include "gpu/host_bake.h"
#include "vk/context.h"

#include <cstdio>

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

} // namespace

void runInfo(const InfoOptions& options) {
    ContextOptions contextOptions;
    contextOptions.validation = options.validation;
    for (const DeviceInfo& device : listDevices(contextOptions))
        printDevice(device);

    Context context = createContext(contextOptions);
    std::printf("bake uses device %u: %s (choose another with --device INDEX|NAME or SHPROBE_DEVICE)\n",
                context.info.index, context.info.name.c_str());
    std::printf("shaders need: Vulkan 1.1, subgroup basic + arithmetic in compute, storage buffers; "
                "GPU faces up to %d^2\n",
                kMaxGpuFaceSize);
    destroyContext(context);
}

} // namespace shprobe
