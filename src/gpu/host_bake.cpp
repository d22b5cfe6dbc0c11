#include "shprobe/gpu/host_bake.h"

#include "shprobe/glsl/gpu_interface.h"
#include "shprobe/sh/basis.h"
#include "shprobe/sh/error.h"
#include "shprobe/sh/scope_exit.h"
#include "shprobe/vk/check.h"
#include "shprobe/vk/image.h"
#include "shprobe/vk/resources.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/gtc/packing.hpp>
#include <optional>

namespace shprobe {

namespace {

constexpr float kHalfMax = 65504.0f;

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

VkFormat imageFormat(TexelFormat format) {
    return format == TexelFormat::Rgba16F ? VK_FORMAT_R16G16B16A16_SFLOAT : VK_FORMAT_R32G32B32A32_SFLOAT;
}

void checkCubemap(const Cubemap& cubemap) {
    if (cubemap.faceSize < 1 || cubemap.faceSize > kMaxGpuFaceSize)
        throw Error(ErrorKind::Input, "GPU bake: face size " + std::to_string(cubemap.faceSize) +
                                          " is outside 1.." + std::to_string(kMaxGpuFaceSize));
    if (cubemap.texels.size() != size_t(kFaceCount) * cubemap.faceSize * cubemap.faceSize)
        throw Error(ErrorKind::Input, "GPU bake: the cube map holds " +
                                          std::to_string(cubemap.texels.size()) + " texels, not 6 x " +
                                          std::to_string(cubemap.faceSize) + "^2");
}

// Copies the texels into the staging memory in the image's format (faces follow each other, as
// layers do). RGBA16F refuses values a half cannot hold rather than clamping them silently.
void packTexels(const Cubemap& cubemap, TexelFormat format, void* destination) {
    if (format == TexelFormat::Rgba32F) {
        std::memcpy(destination, cubemap.texels.data(), cubemap.texels.size() * sizeof(glm::vec4));
        return;
    }
    auto* out = static_cast<uint64_t*>(destination);
    for (const glm::vec4& texel : cubemap.texels) {
        glm::vec3 rgb(texel);
        if (glm::any(glm::greaterThan(glm::abs(rgb), glm::vec3(kHalfMax))))
            throw Error(ErrorKind::Input, "GPU bake: a texel of " +
                                              std::to_string(std::max({rgb.r, rgb.g, rgb.b})) +
                                              " does not fit RGBA16F (at most 65504); use RGBA32F");
        *out++ = glm::packHalf4x16(glm::vec4(rgb, 0.0f));
    }
}

// Cube maps of one face size, baked from one image (one layer per face) with one bake set.
struct BakeGroup {
    std::vector<size_t> members; // indices into the batch
    uint32_t faceSize = 0;
    VkDeviceSize outputOffset = 0;
    CubemapUpload upload;
    ProbeBakeSet set;
};

// Groups by face size, in order of first appearance, at most maxImageArrayLayers / 6 probes each.
std::vector<BakeGroup> groupByFaceSize(const Device& device, std::span<const Cubemap* const> cubemaps) {
    const size_t maxProbes = std::max<size_t>(1, device.info.limits.maxImageArrayLayers / kFaceCount);
    std::vector<BakeGroup> groups;
    for (size_t i = 0; i < cubemaps.size(); ++i) {
        uint32_t faceSize = uint32_t(cubemaps[i]->faceSize);
        auto open = std::find_if(groups.begin(), groups.end(), [&](const BakeGroup& group) {
            return group.faceSize == faceSize && group.members.size() < maxProbes;
        });
        if (open == groups.end()) open = groups.insert(groups.end(), BakeGroup{{}, faceSize});
        open->members.push_back(i);
    }
    return groups;
}

void destroyGroups(const Device& device, std::vector<BakeGroup>& groups) {
    for (BakeGroup& group : groups) {
        destroyProbeBakeSet(device, group.set);
        destroyCubemapUpload(device, group.upload);
    }
}

// Probe k's coefficients of one quantity in a bake output that starts at `offset`.
ShCoefficients readCoefficients(const Buffer& output, VkDeviceSize offset, int order, uint32_t probes,
                                uint32_t k, Quantity quantity) {
    ShCoefficients coefficients = makeCoefficients(order, quantity);
    offset += probeOutputOffset(order, probes, k, quantity);
    auto* values = reinterpret_cast<const glm::vec4*>(static_cast<const char*>(output.mapped) + offset);
    for (size_t i = 0; i < coefficients.rgb.size(); ++i)
        coefficients.rgb[i] = glm::dvec3(glm::vec3(values[i]));
    return coefficients;
}

// Probe k of a bake whose output starts at `offset` (probe_baker.h's layout).
GpuBake readProbe(const Buffer& output, VkDeviceSize offset, int order, uint32_t probes, uint32_t k) {
    return {readCoefficients(output, offset, order, probes, k, Quantity::Radiance),
            readCoefficients(output, offset, order, probes, k, Quantity::Irradiance)};
}

std::optional<size_t> firstNonFinite(const ShCoefficients& coefficients) {
    for (size_t i = 0; i < coefficients.rgb.size(); ++i)
        if (glm::any(glm::isnan(coefficients.rgb[i])) || glm::any(glm::isinf(coefficients.rgb[i]))) return i;
    return std::nullopt;
}

TexelFormat uploadFormat(CubemapBinding binding) {
    return binding == CubemapBinding::StorageRgba16F ? TexelFormat::Rgba16F : TexelFormat::Rgba32F;
}

} // namespace

CubemapBinding uploadBinding(const Device& device, TexelFormat format) {
    // Vulkan requires storage-image support with optimal tiling for both formats; checked anyway.
    VkFormatProperties properties{};
    vkGetPhysicalDeviceFormatProperties(device.physicalDevice, imageFormat(format), &properties);
    if (!(properties.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT))
        return CubemapBinding::SampledImage;
    return format == TexelFormat::Rgba16F ? CubemapBinding::StorageRgba16F : CubemapBinding::StorageRgba32F;
}

CubemapUpload createCubemapUpload(const Device& device, std::span<const Cubemap* const> cubemaps,
                                  CubemapBinding binding) {
    const TexelFormat format = uploadFormat(binding);
    CubemapUpload upload;
    upload.binding = binding;
    const VkImageUsageFlags readUsage =
        binding == CubemapBinding::SampledImage ? VK_IMAGE_USAGE_SAMPLED_BIT : VK_IMAGE_USAGE_STORAGE_BIT;
    upload.faceSize = uint32_t(cubemaps.front()->faceSize);
    upload.probeCount = uint32_t(cubemaps.size());
    const VkDeviceSize cubemapBytes =
        kFaceCount * VkDeviceSize(upload.faceSize) * upload.faceSize * texelBytes(format);
    OnFailure undo([&] { destroyCubemapUpload(device, upload); });
    upload.staging = createBuffer(device, cubemapBytes * cubemaps.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                  MemoryUse::Upload, "cube-map upload");
    for (size_t k = 0; k < cubemaps.size(); ++k) {
        checkCubemap(*cubemaps[k]);
        if (uint32_t(cubemaps[k]->faceSize) != upload.faceSize)
            throw Error(ErrorKind::Input, "GPU bake: cube maps of one upload must share their face size");
        packTexels(*cubemaps[k], format, static_cast<char*>(upload.staging.mapped) + k * cubemapBytes);
    }
    upload.image = createImage(device, {.format = imageFormat(format),
                                        .extent = {upload.faceSize, upload.faceSize},
                                        .usage = readUsage | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                        .what = "cube maps to bake",
                                        .layers = kFaceCount * upload.probeCount});
    return upload;
}

void recordCubemapUpload(VkCommandBuffer commands, const CubemapUpload& upload) {
    changeLayout(commands, upload.image,
                 {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_ACCESS_TRANSFER_WRITE_BIT});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, upload.image.layers};
    region.imageExtent = {upload.faceSize, upload.faceSize, 1};
    vkCmdCopyBufferToImage(commands, upload.staging.buffer, upload.image.image,
                           VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    changeLayout(commands, upload.image,
                 {VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, cubemapLayout(upload.binding),
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT});
}

void destroyCubemapUpload(const Device& device, CubemapUpload& upload) {
    destroyImage(device, upload.image);
    destroyBuffer(device, upload.staging);
    upload = CubemapUpload{};
}

VkDeviceSize batchTexelBytes(const Device& device) {
    VkDeviceSize largestHeap = 0;
    for (uint32_t h = 0; h < device.memory.memoryHeapCount; ++h)
        if (device.memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
            largestHeap = std::max(largestHeap, device.memory.memoryHeaps[h].size);
    // A quarter of the heap leaves room for the staging copy and whatever else the device holds.
    return std::min<VkDeviceSize>(VkDeviceSize(1) << 30, largestHeap / 4);
}

std::vector<GpuBake> bakeCubemaps(const Context& context, const ProbeBaker& baker,
                                  std::span<const Cubemap* const> cubemaps, std::span<const double> window) {
    const int order = baker.options.order;
    for (const Cubemap* cubemap : cubemaps)
        checkCubemap(*cubemap);
    if (cubemaps.empty()) return {};

    std::vector<BakeGroup> groups = groupByFaceSize(context, cubemaps);
    ScopeExit releaseGroups([&] { destroyGroups(context, groups); });
    VkDeviceSize outputBytes = 0;
    for (BakeGroup& group : groups) {
        group.outputOffset = outputBytes;
        outputBytes = alignUp(outputBytes + probeBakeOutputBytes(order, uint32_t(group.members.size())),
                              context.info.limits.minStorageBufferOffsetAlignment);
    }
    Buffer output = createBuffer(context, outputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 MemoryUse::Readback, "coefficients");
    ScopeExit releaseOutput([&] { destroyBuffer(context, output); });
    for (BakeGroup& group : groups) {
        std::vector<const Cubemap*> members;
        for (size_t index : group.members)
            members.push_back(cubemaps[index]);
        group.upload = createCubemapUpload(context, members, baker.options.cubemaps);
        group.set = createProbeBakeSet(context, baker,
                                       {group.upload.image.view, group.faceSize,
                                        uint32_t(group.members.size()), output.buffer, group.outputOffset});
    }
    VkQueryPool timestamps = createTimestampPool(context);
    ScopeExit releaseTimestamps([&] {
        if (timestamps) vkDestroyQueryPool(context.device, timestamps, nullptr);
    });

    submitAndWait(context, [&](VkCommandBuffer commands) {
        for (const BakeGroup& group : groups)
            recordCubemapUpload(commands, group.upload);
        if (timestamps) {
            vkCmdResetQueryPool(commands, timestamps, 0, 2);
            vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timestamps, 0);
        }
        for (const BakeGroup& group : groups)
            recordProbeBake(commands, baker, group.set, window);
        if (timestamps) vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps, 1);
        computeWriteBarrier(commands); // the coefficients, to the host
    });

    invalidateBuffer(context, output);
    const double deviceMs = timestampMilliseconds(context, timestamps);
    std::vector<GpuBake> bakes(cubemaps.size());
    for (const BakeGroup& group : groups)
        for (size_t k = 0; k < group.members.size(); ++k) {
            GpuBake& bake = bakes[group.members[k]];
            bake = readProbe(output, group.outputOffset, order, uint32_t(group.members.size()), uint32_t(k));
            bake.deviceMilliseconds = deviceMs;
            bake.workgroups = group.set.groupsPerProbe;
        }
    return bakes;
}

GpuBake bakeCubemap(const Context& context, const ProbeBaker& baker, const Cubemap& cubemap,
                    std::span<const double> window) {
    const Cubemap* one[] = {&cubemap};
    GpuBake bake = bakeCubemaps(context, baker, one, window).front();
    requireFinite(bake, "the cube map");
    return bake;
}

GpuBake convolveOnGpu(const Context& context, const ProbeBaker& baker, const ShCoefficients& radiance,
                      std::span<const double> window) {
    const int order = baker.options.order;
    if (radiance.order != order || radiance.quantity != Quantity::Radiance)
        throw Error(ErrorKind::Input,
                    "GPU convolution: expected order-" + std::to_string(order) + " radiance");
    std::vector<glm::vec4> raw;
    for (const glm::dvec3& c : radiance.rgb)
        raw.emplace_back(glm::vec3(c), 0.0f);
    const VkDeviceSize setBytes = coefficientSetBytes(order);
    const VkDeviceSize outputBytes = probeBakeOutputBytes(order, 1);

    Buffer input =
        createBuffer(context, setBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                     MemoryUse::Device, "radiance to convolve");
    ScopeExit releaseInput([&] { destroyBuffer(context, input); });
    Buffer output = createBuffer(context, outputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 MemoryUse::Readback, "coefficients");
    ScopeExit releaseOutput([&] { destroyBuffer(context, output); });
    uploadBuffer(context, input, raw.data(), setBytes);
    VkDescriptorPool pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 2});
    ScopeExit releasePool([&] { vkDestroyDescriptorPool(context.device, pool, nullptr); });
    const BindingTarget targets[] = {{input.buffer, 0, setBytes}, {output.buffer, 0, outputBytes}};
    VkDescriptorSet set = createDescriptorSet(context, pool, baker.convolve, targets);
    submitAndWait(context, [&](VkCommandBuffer commands) {
        recordConvolutions(commands, baker, set, 1, window);
        computeWriteBarrier(commands);
    });
    invalidateBuffer(context, output);
    GpuBake bake = readProbe(output, 0, order, 1, 0);
    requireFinite(bake, "the convolved radiance");
    return bake;
}

bool isFinite(const GpuBake& bake) {
    return !firstNonFinite(bake.radiance) && !firstNonFinite(bake.irradiance);
}

void requireFinite(const GpuBake& bake, const std::string& what) {
    const std::optional<size_t> radiance = firstNonFinite(bake.radiance);
    const std::optional<size_t> irradiance = firstNonFinite(bake.irradiance);
    if (!radiance && !irradiance) return;
    const size_t index = radiance ? *radiance : *irradiance;
    throw Error(ErrorKind::Input, what + ": GPU bake: " + (radiance ? "radiance" : "irradiance") +
                                      " coefficient " + std::to_string(index) +
                                      " is not finite (input values too large for fp32 sums?)");
}

} // namespace shprobe
