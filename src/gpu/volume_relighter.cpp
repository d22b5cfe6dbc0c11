#include "gpu/volume_relighter.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/gpu_interface.h"
#include "sh/basis.h"
#include "sh/irradiance.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_spirv.h>

#include <cstring>

namespace shprobe {

namespace {

template <typename T> VkDeviceSize bytesOf(const std::vector<T>& values) {
    return values.size() * sizeof(T);
}

void checkVolume(const Device& device, const VolumeRelighter& relighter, const ProbeVolume& volume) {
    if (volume.transfer.empty()) throw Error(ErrorKind::Input, "GPU relight: the volume holds no transfer");
    if (volume.order != relighter.order)
        throw Error(ErrorKind::Input, "GPU relight: a volume of order " + std::to_string(volume.order) +
                                          " for a relighter of order " + std::to_string(relighter.order));
    if (bytesOf(volume.transfer) > device.info.limits.maxStorageBufferRange)
        throw Error(ErrorKind::Input,
                    "GPU relight: the volume's transfer (" + std::to_string(bytesOf(volume.transfer) >> 20) +
                        " MiB) is more than " + device.info.name + " binds as one storage buffer (" +
                        std::to_string(device.info.limits.maxStorageBufferRange >> 20) +
                        " MiB); relight it in bricks");
    const uint64_t groups =
        workgroupsFor(relighter.program, uint64_t(volume.probeCount()) * coefficientCount(volume.order));
    if (groups > device.info.limits.maxComputeWorkGroupCount[0])
        throw Error(ErrorKind::Input, "GPU relight: " + std::to_string(volume.probeCount()) +
                                          " probes are more than one dispatch relights on " +
                                          device.info.name + "; relight the volume in bricks");
}

// The validity bytes, four a word (the shader reads them so), the last word padded with zeros.
std::vector<uint32_t> packedValidity(const std::vector<uint8_t>& valid) {
    std::vector<uint32_t> words((valid.size() + 3) / 4, 0u);
    std::memcpy(words.data(), valid.data(), valid.size());
    return words;
}

Buffer uploaded(const Context& context, const void* data, VkDeviceSize size, const char* what) {
    Buffer buffer =
        createBuffer(context, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                     MemoryUse::Device, what);
    OnFailure undo([&] { destroyBuffer(context, buffer); });
    uploadBuffer(context, buffer, data, size);
    return buffer;
}

glsl::RelightVolumeParams relightParams(const VolumeRelighter& relighter, uint32_t probes) {
    glsl::RelightVolumeParams params{};
    for (int l = 0; l < relighter.order; ++l)
        params.bandScale[l / 4][l % 4] = float(irradianceBandFactor(l));
    params.probeCount = probes;
    return params;
}

} // namespace

VolumeRelighter createVolumeRelighter(const Device& device, int order) {
    requireOrder(order);
    static constexpr VkDescriptorType kBindings[] = {
        VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
        VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
        VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    return {order, createComputeProgram(device, {.name = "relight_volume.comp",
                                                 .spirv = spirv::relight_volume_comp,
                                                 .bindings = kBindings,
                                                 .pushConstantSize = sizeof(glsl::RelightVolumeParams),
                                                 .order = uint32_t(order)})};
}

void destroyVolumeRelighter(const Device& device, VolumeRelighter& relighter) {
    destroyComputeProgram(device, relighter.program);
}

RelitVolume createRelitVolume(const Context& context, const VolumeRelighter& relighter,
                              const ProbeVolume& volume) {
    checkVolume(context, relighter, volume);
    RelitVolume relit;
    OnFailure undo([&] { destroyRelitVolume(context, relit); });
    relit.probes = volume.probeCount();
    const std::vector<uint32_t> validity = packedValidity(volume.valid);
    relit.transfer = uploaded(context, volume.transfer.data(), bytesOf(volume.transfer), "volume transfer");
    relit.staticRadiance = uploaded(context, volume.staticRadiance.data(), bytesOf(volume.staticRadiance),
                                    "volume static radiance");
    relit.validity = uploaded(context, validity.data(), bytesOf(validity), "volume validity");
    const VkDeviceSize skyBytes = VkDeviceSize(coefficientCount(relighter.order)) * sizeof(glm::vec4);
    relit.sky =
        createBuffer(context, skyBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Upload, "relight sky");
    const VkDeviceSize irradianceBytes = VkDeviceSize(relit.probes) * skyBytes;
    relit.irradiance = createBuffer(context, irradianceBytes,
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                    MemoryUse::Device, "relit irradiance");
    relit.pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 5});
    const BindingTarget targets[] = {{relit.transfer.buffer, 0, relit.transfer.size},
                                     {relit.staticRadiance.buffer, 0, relit.staticRadiance.size},
                                     {relit.validity.buffer, 0, relit.validity.size},
                                     {relit.sky.buffer, 0, skyBytes},
                                     {relit.irradiance.buffer, 0, irradianceBytes}};
    relit.set = createDescriptorSet(context, relit.pool, relighter.program, targets);
    setRelitVolumeSky(relit, makeCoefficients(relighter.order, Quantity::Radiance));
    return relit;
}

void destroyRelitVolume(const Device& device, RelitVolume& relit) {
    if (relit.pool) vkDestroyDescriptorPool(device.device, relit.pool, nullptr);
    for (Buffer* buffer :
         {&relit.irradiance, &relit.sky, &relit.validity, &relit.staticRadiance, &relit.transfer})
        destroyBuffer(device, *buffer);
    relit = RelitVolume{};
}

void setRelitVolumeSky(const RelitVolume& relit, const ShCoefficients& sky) {
    if (VkDeviceSize(sky.rgb.size()) * sizeof(glm::vec4) != relit.sky.size)
        throw Error(ErrorKind::Input, "GPU relight: a sky of order " + std::to_string(sky.order) +
                                          " for a volume of another order");
    auto* values = static_cast<glm::vec4*>(relit.sky.mapped);
    for (const glm::dvec3& coefficient : sky.rgb)
        *values++ = glm::vec4(glm::vec3(coefficient), 0.0f);
}

void recordVolumeRelight(VkCommandBuffer commands, const VolumeRelighter& relighter, const RelitVolume& relit,
                         VkPipelineStageFlags readers) {
    const uint64_t coefficients = uint64_t(relit.probes) * uint64_t(coefficientCount(relighter.order));
    dispatch(commands, relighter.program, relit.set, relightParams(relighter, relit.probes),
             {uint32_t(workgroupsFor(relighter.program, coefficients))});
    // Shaders read it, or a copy does (relightVolumeOnGpu's readback).
    const VkAccessFlags reads = (readers & VK_PIPELINE_STAGE_TRANSFER_BIT ? VK_ACCESS_TRANSFER_READ_BIT : 0) |
                                (readers & ~VK_PIPELINE_STAGE_TRANSFER_BIT ? VK_ACCESS_SHADER_READ_BIT : 0);
    const VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT,
                                  reads};
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, readers, 0, 1, &barrier, 0, nullptr,
                         0, nullptr);
}

std::vector<glm::vec4> relightVolumeOnGpu(const Context& context, const VolumeRelighter& relighter,
                                          const ProbeVolume& volume, const ShCoefficients& sky) {
    RelitVolume relit = createRelitVolume(context, relighter, volume);
    ScopeExit release([&] { destroyRelitVolume(context, relit); });
    setRelitVolumeSky(relit, sky);
    Buffer readback = createBuffer(context, relit.irradiance.size, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                   MemoryUse::Readback, "relit irradiance readback");
    ScopeExit releaseReadback([&] { destroyBuffer(context, readback); });
    submitAndWait(context, [&](VkCommandBuffer commands) {
        recordVolumeRelight(commands, relighter, relit, VK_PIPELINE_STAGE_TRANSFER_BIT);
        const VkBufferCopy region{0, 0, relit.irradiance.size};
        vkCmdCopyBuffer(commands, relit.irradiance.buffer, readback.buffer, 1, &region);
        const VkMemoryBarrier toHost{VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_TRANSFER_WRITE_BIT,
                                     VK_ACCESS_HOST_READ_BIT};
        vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                             &toHost, 0, nullptr, 0, nullptr);
    });
    invalidateBuffer(context, readback);
    const auto* values = static_cast<const glm::vec4*>(readback.mapped);
    return std::vector<glm::vec4>(values, values + relit.irradiance.size / sizeof(glm::vec4));
}

} // namespace shprobe
