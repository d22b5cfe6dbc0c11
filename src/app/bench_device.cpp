#include "app/bench_device.h"
#include "app/stopwatch.h"

#include "common/scope_exit.h"
#include "glsl/gpu_interface.h"
#include "gpu/probe_baker.h"
#include "vk/check.h"
#include "vk/pipeline.h"
#include "vk/pipeline_cache.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_bench_spirv.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unistd.h>

namespace shprobe {

double deviceReadMilliseconds(const Context& context, const Cubemap& cubemap, TexelFormat format,
                              int repeat) {
    if (!context.info.timestamps) return 0.0;
    // read_texels reads as the storage-image projection does, the one the program uses.
    if (uploadBinding(context, format) == CubemapBinding::SampledImage) return 0.0;
    static constexpr VkDescriptorType kBindings[] = {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                                     VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
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
    Buffer sums = createBuffer(context, VkDeviceSize(groups) * plan.workgroupSize * 16,
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device, "read sums");
    ScopeExit destroySums([&] { destroyBuffer(context, sums); });
    ComputeProgram read = createComputeProgram(
        context, {.name = half ? "read_texels_rgba16f.comp" : "read_texels_rgba32f.comp",
                  .spirv = half ? spirv::read_texels_rgba16f_comp : spirv::read_texels_rgba32f_comp,
                  .bindings = kBindings,
                  .pushConstantSize = sizeof(glsl::ProjectParams),
                  .localSize = plan.workgroupSize});
    ScopeExit destroyRead([&] { destroyComputeProgram(context, read); });
    VkDescriptorPool pool =
        createDescriptorPool(context, {.sets = 1, .storageBuffers = 1, .storageImages = 1});
    ScopeExit destroyPool([&] { vkDestroyDescriptorPool(context.device, pool, nullptr); });
    const BindingTarget targets[] = {{.imageView = upload.image.view}, {sums.buffer, 0, VK_WHOLE_SIZE}};
    VkDescriptorSet set = createDescriptorSet(context, pool, read, targets);
    VkQueryPool timestamps = createTimestampPool(context);
    ScopeExit destroyTimestamps([&] { vkDestroyQueryPool(context.device, timestamps, nullptr); });
    // Run 0 is not timed: it uploads, and llvmpipe compiles a shader at its first dispatch.
    double best = INFINITY;
    for (int run = 0; run <= repeat; ++run) {
        submitAndWait(context, [&](VkCommandBuffer commands) {
            if (run == 0) recordCubemapUpload(commands, upload);
            vkCmdResetQueryPool(commands, timestamps, 0, 2);
            vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timestamps, 0);
            dispatch(commands, read, set, glsl::ProjectParams{upload.faceSize}, {groups, 1});
            vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps, 1);
        });
        if (run > 0) best = std::min(best, timestampMilliseconds(context, timestamps));
    }
    return best;
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
