#include "app/bench_device.h"
#include "app/stopwatch.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/gpu_interface.h"
#include "gpu/probe_baker.h"
#include "vk/check.h"
#include "vk/pipeline.h"
#include "vk/pipeline_cache.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_bench_spirv.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <glm/common.hpp>
#include <glm/vector_relational.hpp>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

namespace shprobe {

namespace {

// Best device milliseconds of `repeat` submissions of `record` between two timestamps, after an
// untimed one (llvmpipe compiles a shader at its first dispatch); `first` is recorded before the
// untimed run's commands only (an upload). INFINITY without timestamps.
double bestDeviceMilliseconds(const Context& context, int repeat,
                              const std::function<void(VkCommandBuffer)>& record,
                              const std::function<void(VkCommandBuffer)>& first = {}) {
    VkQueryPool timestamps = createTimestampPool(context);
    if (!timestamps) return INFINITY;
    ScopeExit destroyTimestamps([&] { vkDestroyQueryPool(context.device, timestamps, nullptr); });
    double best = INFINITY;
    for (int run = 0; run <= repeat; ++run) {
        submitAndWait(context, [&](VkCommandBuffer commands) {
            if (run == 0 && first) first(commands);
            computeWriteBarrier(commands); // what earlier submissions wrote, to this one's reads
            vkCmdResetQueryPool(commands, timestamps, 0, 2);
            vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timestamps, 0);
            record(commands);
            vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps, 1);
        });
        if (run > 0) best = std::min(best, timestampMilliseconds(context, timestamps));
    }
    return best;
}

void recordCopy(VkCommandBuffer commands, const Buffer& from, const Buffer& to) {
    VkBufferCopy region{0, 0, from.size};
    vkCmdCopyBuffer(commands, from.buffer, to.buffer, 1, &region);
}

// read_buffer.comp over the whole buffer, in ranges of at most maxStorageBufferRange (one set each).
double bufferReadMilliseconds(const Context& context, const Buffer& words, int repeat) {
    constexpr uint32_t kLocalSize = 256;
    constexpr uint32_t kPerGroup = 1u << 12; // vec4s each workgroup reads: 64 KiB
    const VkDeviceSize largest = VkDeviceSize(context.info.limits.maxStorageBufferRange) / (kPerGroup * 16) *
                                 (kPerGroup * 16); // whole workgroups per range
    const VkDeviceSize range = std::min(words.size, largest);
    const uint32_t ranges = uint32_t((words.size + range - 1) / range);
    const uint32_t groups = uint32_t((range / 16 + kPerGroup - 1) / kPerGroup);
    static constexpr VkDescriptorType kBindings[] = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                                     VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    ComputeProgram read = createComputeProgram(context, {.name = "read_buffer.comp",
                                                         .spirv = spirv::read_buffer_comp,
                                                         .bindings = kBindings,
                                                         .pushConstantSize = 8,
                                                         .localSize = kLocalSize});
    ScopeExit destroyRead([&] { destroyComputeProgram(context, read); });
    Buffer sums = createBuffer(context, VkDeviceSize(groups) * kLocalSize * 16,
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device, "read sums");
    ScopeExit destroySums([&] { destroyBuffer(context, sums); });
    VkDescriptorPool pool = createDescriptorPool(context, {.sets = ranges, .storageBuffers = 2 * ranges});
    ScopeExit destroyPool([&] { vkDestroyDescriptorPool(context.device, pool, nullptr); });
    std::vector<VkDescriptorSet> sets;
    for (uint32_t r = 0; r < ranges; ++r) {
        const VkDeviceSize size = std::min(range, words.size - r * range);
        const BindingTarget targets[] = {{words.buffer, r * range, size}, {sums.buffer, 0, VK_WHOLE_SIZE}};
        sets.push_back(createDescriptorSet(context, pool, read, targets));
    }
    return bestDeviceMilliseconds(context, repeat, [&](VkCommandBuffer commands) {
        for (uint32_t r = 0; r < ranges; ++r) {
            const uint32_t count = uint32_t(std::min(range, words.size - r * range) / 16);
            const uint32_t push[] = {count, kPerGroup};
            dispatch(commands, read, sets[r], push, {(count + kPerGroup - 1) / kPerGroup, 1});
            computeWriteBarrier(commands); // the ranges' sums share one buffer
        }
    });
}

// Each invocation of both read_texels variants sums the same texels in the same order, so their
// sums agree (to rounding, should a driver reorder the additions): the buffer variant reads what the
// image holds. Throws Error(Device) where they do not.
void requireSameSums(const Context& context, const Buffer& imageSums, const Buffer& bufferSums) {
    Buffer readback = createBuffer(context, 2 * imageSums.size, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                   MemoryUse::Readback, "read sums to compare");
    ScopeExit destroyReadback([&] { destroyBuffer(context, readback); });
    submitAndWait(context, [&](VkCommandBuffer commands) {
        computeWriteBarrier(commands);
        const VkBufferCopy first{0, 0, imageSums.size}, second{0, imageSums.size, imageSums.size};
        vkCmdCopyBuffer(commands, imageSums.buffer, readback.buffer, 1, &first);
        vkCmdCopyBuffer(commands, bufferSums.buffer, readback.buffer, 1, &second);
        computeWriteBarrier(commands);
    });
    invalidateBuffer(context, readback);
    const size_t count = size_t(imageSums.size / sizeof(glm::vec4));
    const auto* image = static_cast<const glm::vec4*>(readback.mapped);
    const glm::vec4* buffer = image + count;
    for (size_t i = 0; i < count; ++i)
        if (glm::any(glm::greaterThan(glm::abs(image[i] - buffer[i]), 1e-5f * glm::abs(image[i]))))
            throw Error(ErrorKind::Device, "bench: read_texels from a buffer summed other texels than from "
                                           "the image (invocation " +
                                               std::to_string(i) + ")");
}

// A read_texels module.
struct ReadShader {
    const char* name;
    std::span<const uint32_t> spirv;
};

} // namespace

DeviceBounds measureDeviceBounds(const Context& context, std::span<const std::byte> bytes, int repeat) {
    if (!context.info.timestamps) return {};
    const VkDeviceSize size = bytes.size();
    constexpr VkBufferUsageFlags kBoth = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    Buffer staging =
        createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload, "bound staging");
    ScopeExit destroyStaging([&] { destroyBuffer(context, staging); });
    Buffer words = createBuffer(context, size, kBoth | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device,
                                "bound source");
    ScopeExit destroyWords([&] { destroyBuffer(context, words); });
    Buffer copy =
        createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Device, "bound copy");
    ScopeExit destroyCopy([&] { destroyBuffer(context, copy); });
    std::memcpy(staging.mapped, bytes.data(), bytes.size());
    DeviceBounds bounds;
    bounds.transferMilliseconds = bestDeviceMilliseconds(
        context, repeat, [&](VkCommandBuffer commands) { recordCopy(commands, staging, words); });
    bounds.copyMilliseconds = bestDeviceMilliseconds(
        context, repeat, [&](VkCommandBuffer commands) { recordCopy(commands, words, copy); });
    bounds.readMilliseconds = bufferReadMilliseconds(context, words, repeat);
    return bounds;
}

TexelReads deviceTexelReads(const Context& context, const Cubemap& cubemap, std::span<const std::byte> bytes,
                            TexelFormat format, int repeat) {
    if (!context.info.timestamps) return {};
    // read_texels reads as the storage-image projection does, the one the program uses.
    if (uploadBinding(context, format) == CubemapBinding::SampledImage) return {};
    const ProbeBakerOptions plan{.order = 3,
                                 .cubemaps = uploadBinding(context, format)}; // an order-3 projection's plan
    const bool half = format == TexelFormat::Rgba16F;
    const Cubemap* one[] = {&cubemap};
    CubemapUpload upload = createCubemapUpload(context, one, plan.cubemaps);
    ScopeExit destroyUpload([&] { destroyCubemapUpload(context, upload); });
    // The projection's own workgroup count for this cube map, from a bake set over a one-probe output.
    uint32_t groups = 0;
    {
        ProbeBaker baker = createProbeBaker(context, plan);
        ScopeExit destroyBaker([&] { destroyProbeBaker(context, baker); });
        Buffer placeholder =
            createBuffer(context, probeBakeOutputBytes(plan.order, 1), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                         MemoryUse::Device, "placeholder");
        ScopeExit destroyPlaceholder([&] { destroyBuffer(context, placeholder); });
        ProbeBakeSet set = createProbeBakeSet(context, baker,
                                              {upload.image.view, upload.faceSize, 1, placeholder.buffer, 0});
        groups = set.groupsPerProbe;
        destroyProbeBakeSet(context, set);
    }
    const VkDeviceSize sumBytes = VkDeviceSize(groups) * plan.workgroupSize * 16;
    // read_texels over `texels` (an image view or a buffer) with the projection's dispatch, into `sums`.
    auto readMilliseconds = [&](const ReadShader& shader, VkDescriptorType type, const BindingTarget& texels,
                                const Buffer& sums, const std::function<void(VkCommandBuffer)>& first) {
        const VkDescriptorType bindings[] = {type, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
        ComputeProgram read = createComputeProgram(context, {.name = shader.name,
                                                             .spirv = shader.spirv,
                                                             .bindings = bindings,
                                                             .pushConstantSize = sizeof(glsl::ProjectParams),
                                                             .localSize = plan.workgroupSize});
        ScopeExit destroyRead([&] { destroyComputeProgram(context, read); });
        const bool image = type == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
        VkDescriptorPool pool = createDescriptorPool(
            context, {.sets = 1, .storageBuffers = image ? 1u : 2u, .storageImages = image ? 1u : 0u});
        ScopeExit destroyPool([&] { vkDestroyDescriptorPool(context.device, pool, nullptr); });
        const BindingTarget targets[] = {texels, {sums.buffer, 0, VK_WHOLE_SIZE}};
        VkDescriptorSet set = createDescriptorSet(context, pool, read, targets);
        return bestDeviceMilliseconds(
            context, repeat,
            [&](VkCommandBuffer commands) {
                dispatch(commands, read, set, glsl::ProjectParams{upload.faceSize}, {groups, 1});
            },
            first);
    };
    constexpr VkBufferUsageFlags kSumUsage =
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    Buffer imageSums = createBuffer(context, sumBytes, kSumUsage, MemoryUse::Device, "read sums");
    ScopeExit destroyImageSums([&] { destroyBuffer(context, imageSums); });
    TexelReads reads;
    reads.imageMilliseconds =
        readMilliseconds(half ? ReadShader{"read_texels_rgba16f.comp", spirv::read_texels_rgba16f_comp}
                              : ReadShader{"read_texels_rgba32f.comp", spirv::read_texels_rgba32f_comp},
                         VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {.imageView = upload.image.view}, imageSums,
                         [&](VkCommandBuffer commands) { recordCubemapUpload(commands, upload); });
    if (bytes.size() > context.info.limits.maxStorageBufferRange) return reads;
    Buffer texels = createBuffer(context, bytes.size(),
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                 MemoryUse::Device, "texels to read");
    ScopeExit destroyTexels([&] { destroyBuffer(context, texels); });
    uploadBuffer(context, texels, bytes.data(), bytes.size());
    Buffer bufferSums = createBuffer(context, sumBytes, kSumUsage, MemoryUse::Device, "read sums");
    ScopeExit destroyBufferSums([&] { destroyBuffer(context, bufferSums); });
    reads.bufferMilliseconds = readMilliseconds(
        half ? ReadShader{"read_texels_buffer_rgba16f.comp", spirv::read_texels_buffer_rgba16f_comp}
             : ReadShader{"read_texels_buffer_rgba32f.comp", spirv::read_texels_buffer_rgba32f_comp},
        VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, {texels.buffer, 0, VK_WHOLE_SIZE}, bufferSums, {});
    requireSameSums(context, imageSums, bufferSums);
    return reads;
}

double multiplyAddsPerSecond(const Context& context, int repeat) {
    if (!context.info.timestamps) return 0.0;
    constexpr uint32_t kLocalSize = 64;
    constexpr uint32_t kSteps = 1u << 14;                         // within llvmpipe's loop cap
    constexpr double kPerInvocation = double(kSteps) * 8.0 * 4.0; // eight vec4 chains a step
    constexpr double kLongEnoughMs = 10.0;
    static constexpr VkDescriptorType kBindings[] = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    ComputeProgram program = createComputeProgram(context, {.name = "multiply_adds.comp",
                                                            .spirv = spirv::multiply_adds_comp,
                                                            .bindings = kBindings,
                                                            .pushConstantSize = 12,
                                                            .localSize = kLocalSize});
    ScopeExit destroyProgram([&] { destroyComputeProgram(context, program); });
    VkDescriptorPool pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 1});
    ScopeExit destroyPool([&] { vkDestroyDescriptorPool(context.device, pool, nullptr); });
    const uint32_t maxGroups = context.info.limits.maxComputeWorkGroupCount[0];
    // The largest dispatch the search may reach, and its sums (16 MiB): 2^39 multiply-adds, 16 ms at
    // the 33 T/s of an NVIDIA H200 (67 TFLOPS).
    const uint32_t largest = std::min(maxGroups, 1u << 14);
    Buffer sums = createBuffer(context, VkDeviceSize(largest) * kLocalSize * 16,
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device, "multiply-add sums");
    ScopeExit destroySums([&] { destroyBuffer(context, sums); });
    const BindingTarget targets[] = {{sums.buffer, 0, VK_WHOLE_SIZE}};
    VkDescriptorSet set = createDescriptorSet(context, pool, program, targets);
    struct Push {
        uint32_t steps;
        float factor, term;
    };
    auto milliseconds = [&](uint32_t groups, int runs) {
        return bestDeviceMilliseconds(context, runs, [&](VkCommandBuffer commands) {
            dispatch(commands, program, set, Push{kSteps, 1.0f, 1e-7f}, {groups, 1});
        });
    };
    // Grow the dispatch until it fills the device long enough for the timestamps to be exact, and
    // to 16 workgroups a CPU thread at least: on a CPU device, whose threads each run whole
    // workgroups, the last round's idle threads then cost under a sixteenth.
    const uint32_t leastGroups = 16 * std::max(1u, std::thread::hardware_concurrency());
    uint32_t groups = 1;
    double ms = milliseconds(groups, 1);
    while ((ms < kLongEnoughMs || groups < leastGroups) && groups < largest) {
        const double scale = ms > 0.0 ? std::ceil(kLongEnoughMs / ms) : 16.0;
        groups = uint32_t(std::min(double(largest), std::max(2.0, std::min(scale, 16.0)) * groups));
        ms = milliseconds(groups, 1);
    }
    ms = std::min(ms, milliseconds(groups, repeat));
    return double(groups) * kLocalSize * kPerInvocation / (ms * 1e-3);
}

PipelineCreation measurePipelineCreation(const Device& device, int order) {
    std::error_code noTemporaryFolder; // TMPDIR naming no folder
    std::filesystem::path folder = std::filesystem::temp_directory_path(noTemporaryFolder);
    const std::string path = ((noTemporaryFolder ? "/tmp" : folder) /
                              ("shprobe-bench-pipelines-" + std::to_string(getpid()) + ".bin"))
                                 .string();
    PipelineCreation result;
    // The bake's pipelines on the device, through `cache` in place of its own.
    auto createWith = [&](VkPipelineCache cache) {
        Device cached = device;
        cached.pipelineCache = cache;
        Clock::time_point start = Clock::now();
        ProbeBaker baker = createProbeBaker(
            cached, {.order = order, .cubemaps = uploadBinding(cached, TexelFormat::Rgba32F)});
        double ms = millisecondsSince(start);
        destroyProbeBaker(cached, baker);
        return ms;
    };
    {
        VkPipelineCache empty = loadPipelineCache(device, "");
        ScopeExit destroyEmpty([&] { vkDestroyPipelineCache(device.device, empty, nullptr); });
        result.firstMilliseconds = createWith(empty);
        savePipelineCache(device, empty, path);
    }
    std::error_code ignored;
    result.cacheBytes = size_t(std::filesystem::file_size(path, ignored));
    VkPipelineCache loaded = loadPipelineCache(device, path);
    ScopeExit destroyLoaded([&] { vkDestroyPipelineCache(device.device, loaded, nullptr); });
    result.cachedMilliseconds = createWith(loaded);
    std::filesystem::remove(path, ignored);
    return result;
}

} // namespace shprobe
