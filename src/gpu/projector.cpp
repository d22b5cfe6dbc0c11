#include "shprobe/gpu/projector.h"

#include "shprobe/glsl/gpu_interface.h"
#include "shprobe/sh/basis.h"
#include "shprobe/sh/error.h"
#include "shprobe/vk/check.h"
#include "shprobe/vk/image.h"
#include "shprobe/vk/resources.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/gtc/packing.hpp>

namespace shprobe {

namespace {

constexpr VkDeviceSize kCoefficientBytes = sizeof(glm::vec4); // rgb + padding, std430 vec4
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
std::vector<BakeGroup> groupByFaceSize(const Context& context, std::span<const Cubemap* const> cubemaps) {
    const size_t maxProbes = std::max<size_t>(1, context.info.limits.maxImageArrayLayers / kFaceCount);
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

void destroyGroups(const Context& context, std::vector<BakeGroup>& groups) {
    for (BakeGroup& group : groups) {
        destroyProbeBakeSet(context, group.set);
        destroyCubemapUpload(context, group.upload);
    }
}

// Throws when a coefficient is not finite: finite inputs whose sums overflow fp32 (values near
// 1e38), or a device that computed garbage; either way no such probe is handed on.
ShCoefficients readCoefficients(const Buffer& output, VkDeviceSize offset, int order, Quantity quantity) {
    ShCoefficients coefficients = makeCoefficients(order, quantity);
    auto* values = reinterpret_cast<const glm::vec4*>(static_cast<const char*>(output.mapped) + offset);
    for (size_t i = 0; i < coefficients.rgb.size(); ++i) {
        glm::vec3 value(values[i]);
        if (!std::isfinite(value.r) || !std::isfinite(value.g) || !std::isfinite(value.b))
            throw Error(ErrorKind::Input, "GPU bake: coefficient " + std::to_string(i) +
                                              " is not finite (input values too large for fp32 sums?)");
        coefficients.rgb[i] = glm::dvec3(value);
    }
    return coefficients;
}

// Probe k of a bake whose output starts at `offset` (probe_baker.h's layout); `failure` says why
// its coefficients cannot be used, if they cannot.
GpuBake readProbe(const Buffer& output, VkDeviceSize offset, int order, size_t probes, size_t k) {
    const VkDeviceSize setBytes = VkDeviceSize(coefficientCount(order)) * kCoefficientBytes;
    GpuBake bake;
    try {
        bake.radiance = readCoefficients(output, offset + k * setBytes, order, Quantity::Radiance);
        bake.irradiance =
            readCoefficients(output, offset + (probes + k) * setBytes, order, Quantity::Irradiance);
    } catch (const Error& error) {
        bake.failure = error.what();
    }
    return bake;
}

GpuBake usableOrThrow(GpuBake bake) {
    if (!bake.failure.empty()) throw Error(ErrorKind::Input, bake.failure);
    return bake;
}

} // namespace

CubemapBinding uploadBinding(const Context& context, TexelFormat format) {
    // Vulkan requires storage-image support with optimal tiling for both formats; checked anyway.
    VkFormatProperties properties{};
    vkGetPhysicalDeviceFormatProperties(context.physicalDevice, imageFormat(format), &properties);
    if (!(properties.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT))
        return CubemapBinding::SampledImage;
    return format == TexelFormat::Rgba16F ? CubemapBinding::StorageRgba16F : CubemapBinding::StorageRgba32F;
}

CubemapUpload createCubemapUpload(const Context& context, std::span<const Cubemap* const> cubemaps,
                                  TexelFormat format) {
    CubemapUpload upload;
    upload.binding = uploadBinding(context, format);
    const VkImageUsageFlags readUsage = upload.binding == CubemapBinding::SampledImage
                                            ? VK_IMAGE_USAGE_SAMPLED_BIT
                                            : VK_IMAGE_USAGE_STORAGE_BIT;
    upload.faceSize = uint32_t(cubemaps.front()->faceSize);
    upload.probeCount = uint32_t(cubemaps.size());
    const VkDeviceSize cubemapBytes =
        kFaceCount * VkDeviceSize(upload.faceSize) * upload.faceSize * texelBytes(format);
    try {
        upload.staging = createBuffer(context, cubemapBytes * cubemaps.size(),
                                      VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload, "cube-map upload");
        for (size_t k = 0; k < cubemaps.size(); ++k) {
            checkCubemap(*cubemaps[k]);
            if (uint32_t(cubemaps[k]->faceSize) != upload.faceSize)
                throw Error(ErrorKind::Input, "GPU bake: cube maps of one upload must share their face size");
            packTexels(*cubemaps[k], format, static_cast<char*>(upload.staging.mapped) + k * cubemapBytes);
        }
        upload.image = createImage(context, {.format = imageFormat(format),
                                             .extent = {upload.faceSize, upload.faceSize},
                                             .usage = readUsage | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                             .what = "cube maps to bake",
                                             .layers = kFaceCount * upload.probeCount});
    } catch (...) {
        destroyCubemapUpload(context, upload);
        throw;
    }
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

void destroyCubemapUpload(const Context& context, CubemapUpload& upload) {
    destroyImage(context, upload.image);
    destroyBuffer(context, upload.staging);
    upload = CubemapUpload{};
}

Projector createProjector(const Context& context, const ProjectorOptions& options) {
    Projector projector;
    projector.options = options;
    projector.baker = createProbeBaker(context, {.order = options.order,
                                                 .cubemaps = uploadBinding(context, options.texelFormat),
                                                 .workgroupSize = options.workgroupSize,
                                                 .texelsPerInvocation = options.texelsPerInvocation,
                                                 .pipelineCache = options.pipelineCache});
    return projector;
}

void destroyProjector(const Context& context, Projector& projector) {
    destroyProbeBaker(context, projector.baker);
}

VkDeviceSize batchTexelBytes(const Context& context) {
    VkDeviceSize largestHeap = 0;
    for (uint32_t h = 0; h < context.memory.memoryHeapCount; ++h)
        if (context.memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
            largestHeap = std::max(largestHeap, context.memory.memoryHeaps[h].size);
    // A quarter of the heap leaves room for the staging copy and whatever else the device holds.
    return std::min<VkDeviceSize>(VkDeviceSize(1) << 30, largestHeap / 4);
}

std::vector<GpuBake> bakeCubemaps(const Context& context, const Projector& projector,
                                  std::span<const Cubemap* const> cubemaps, std::span<const double> window) {
    const int order = projector.options.order;
    for (const Cubemap* cubemap : cubemaps)
        checkCubemap(*cubemap);
    if (cubemaps.empty()) return {};

    std::vector<BakeGroup> groups = groupByFaceSize(context, cubemaps);
    Buffer output;
    VkQueryPool timestamps = VK_NULL_HANDLE;
    std::vector<GpuBake> bakes(cubemaps.size());
    try {
        VkDeviceSize outputBytes = 0;
        for (BakeGroup& group : groups) {
            group.outputOffset = outputBytes;
            outputBytes = alignUp(outputBytes + probeBakeOutputBytes(order, uint32_t(group.members.size())),
                                  context.info.limits.minStorageBufferOffsetAlignment);
        }
        output = createBuffer(context, outputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback,
                              "coefficients");
        for (BakeGroup& group : groups) {
            std::vector<const Cubemap*> members;
            for (size_t index : group.members)
                members.push_back(cubemaps[index]);
            group.upload = createCubemapUpload(context, members, projector.options.texelFormat);
            if (group.upload.binding != projector.baker.options.cubemaps)
                throw Error(ErrorKind::Device, "GPU bake: cube maps uploaded for another binding than the "
                                               "projector's pipelines read");
            group.set =
                createProbeBakeSet(context, projector.baker,
                                   {group.upload.image.view, group.faceSize, uint32_t(group.members.size()),
                                    output.buffer, group.outputOffset});
        }
        timestamps = createTimestampPool(context);

        submitAndWait(context, [&](VkCommandBuffer commands) {
            for (const BakeGroup& group : groups)
                recordCubemapUpload(commands, group.upload);
            if (timestamps) {
                vkCmdResetQueryPool(commands, timestamps, 0, 2);
                vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timestamps, 0);
            }
            for (const BakeGroup& group : groups)
                recordProbeBake(commands, projector.baker, group.set, window);
            if (timestamps)
                vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps, 1);
            computeWriteBarrier(commands); // the coefficients, to the host
        });

        invalidateBuffer(context, output);
        const double deviceMs = timestampMilliseconds(context, timestamps);
        for (const BakeGroup& group : groups)
            for (size_t k = 0; k < group.members.size(); ++k) {
                GpuBake& bake = bakes[group.members[k]];
                bake = readProbe(output, group.outputOffset, order, group.members.size(), k);
                bake.deviceMilliseconds = deviceMs;
                bake.workgroups = group.set.groupsPerProbe;
            }
    } catch (...) {
        if (timestamps) vkDestroyQueryPool(context.device, timestamps, nullptr);
        destroyGroups(context, groups);
        destroyBuffer(context, output);
        throw;
    }
    if (timestamps) vkDestroyQueryPool(context.device, timestamps, nullptr);
    destroyGroups(context, groups);
    destroyBuffer(context, output);
    return bakes;
}

GpuBake bakeCubemap(const Context& context, const Projector& projector, const Cubemap& cubemap,
                    std::span<const double> window) {
    const Cubemap* one[] = {&cubemap};
    return usableOrThrow(bakeCubemaps(context, projector, one, window).front());
}

GpuBake convolveOnGpu(const Context& context, const Projector& projector, const ShCoefficients& radiance,
                      std::span<const double> window) {
    const int order = projector.options.order;
    if (radiance.order != order || radiance.quantity != Quantity::Radiance)
        throw Error(ErrorKind::Input,
                    "GPU convolution: expected order-" + std::to_string(order) + " radiance");
    std::vector<glm::vec4> raw;
    for (const glm::dvec3& c : radiance.rgb)
        raw.emplace_back(glm::vec3(c), 0.0f);
    const VkDeviceSize setBytes = raw.size() * kCoefficientBytes;
    const VkDeviceSize outputBytes = probeBakeOutputBytes(order, 1);

    Buffer input, output;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    auto release = [&] {
        if (pool) vkDestroyDescriptorPool(context.device, pool, nullptr);
        destroyBuffer(context, output);
        destroyBuffer(context, input);
    };
    GpuBake bake;
    try {
        input = createBuffer(context, setBytes,
                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                             MemoryUse::Device, "radiance to convolve");
        output = createBuffer(context, outputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback,
                              "coefficients");
        uploadBuffer(context, input, raw.data(), setBytes);
        pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 2});
        const BindingTarget targets[] = {{input.buffer, 0, setBytes}, {output.buffer, 0, outputBytes}};
        VkDescriptorSet set = createDescriptorSet(context, pool, projector.baker.convolve, targets);
        submitAndWait(context, [&](VkCommandBuffer commands) {
            recordConvolutions(commands, projector.baker, set, 1, window);
            computeWriteBarrier(commands);
        });
        invalidateBuffer(context, output);
        bake = usableOrThrow(readProbe(output, 0, order, 1, 0));
    } catch (...) {
        release();
        throw;
    }
    release();
    return bake;
}

} // namespace shprobe
