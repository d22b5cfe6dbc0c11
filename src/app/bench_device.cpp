#include "app/bench_device.h"
#include "app/stopwatch.h"

#include "shprobe/glsl/gpu_interface.h"
#include "shprobe/gpu/probe_baker.h"
#include "shprobe/shprobe_bench_spirv.h"
#include "shprobe/vk/check.h"
#include "shprobe/vk/pipeline.h"
#include "shprobe/vk/pipeline_cache.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unistd.h>

namespace shprobe {

namespace {

// Everything one read measurement creates, destroyed in one place.
struct ReadResources {
    CubemapUpload upload;
    ProbeBaker baker; // the workgroup plan of the projection being compared with
    ProbeBakeSet set;
    ComputeProgram read;
    Buffer sums;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkQueryPool timestamps = VK_NULL_HANDLE;
};

void destroyReadResources(const Context& context, ReadResources& r) {
    if (r.timestamps) vkDestroyQueryPool(context.device, r.timestamps, nullptr);
    if (r.pool) vkDestroyDescriptorPool(context.device, r.pool, nullptr);
    destroyBuffer(context, r.sums);
    destroyComputeProgram(context, r.read);
    destroyProbeBakeSet(context, r.set);
    destroyProbeBaker(context, r.baker);
    destroyCubemapUpload(context, r.upload);
}

} // namespace

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
    ReadResources r;
    double best = INFINITY;
    try {
        const Cubemap* one[] = {&cubemap};
        r.upload = createCubemapUpload(context, one, format);
        r.baker = createProbeBaker(context, plan);
        r.sums =
            createBuffer(context, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device, "placeholder");
        r.set = createProbeBakeSet(context, r.baker,
                                   {r.upload.image.view, r.upload.faceSize, 1, r.sums.buffer, 0});
        destroyBuffer(context, r.sums);
        const uint32_t groups = r.set.groupsPerProbe;
        r.sums = createBuffer(context, VkDeviceSize(groups) * plan.workgroupSize * 16,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device, "read sums");
        r.read = createComputeProgram(
            context, {.name = half ? "read_texels_rgba16f.comp" : "read_texels_rgba32f.comp",
                      .spirv = half ? spirv::read_texels_rgba16f_comp : spirv::read_texels_rgba32f_comp,
                      .bindings = kBindings,
                      .pushConstantSize = sizeof(gpu::ProjectParams),
                      .localSize = plan.workgroupSize});
        r.pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 1, .storageImages = 1});
        const BindingTarget targets[] = {{.imageView = r.upload.image.view},
                                         {r.sums.buffer, 0, VK_WHOLE_SIZE}};
        VkDescriptorSet set = createDescriptorSet(context, r.pool, r.read, targets);
        r.timestamps = createTimestampPool(context);
        // Run 0 is not timed: it uploads, and llvmpipe compiles a shader at its first dispatch.
        for (int run = 0; run <= repeat; ++run) {
            submitAndWait(context, [&](VkCommandBuffer commands) {
                if (run == 0) recordCubemapUpload(commands, r.upload);
                vkCmdResetQueryPool(commands, r.timestamps, 0, 2);
                vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, r.timestamps, 0);
                dispatch(commands, r.read, set, gpu::ProjectParams{r.upload.faceSize}, {groups, 1});
                vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, r.timestamps, 1);
            });
            if (run > 0) best = std::min(best, timestampMilliseconds(context, r.timestamps));
        }
    } catch (...) {
        destroyReadResources(context, r);
        throw;
    }
    destroyReadResources(context, r);
    return best;
}

PipelineCreation measurePipelineCreation(const Context& context, int order) {
    std::error_code noTemporaryFolder; // TMPDIR naming no folder
    std::filesystem::path folder = std::filesystem::temp_directory_path(noTemporaryFolder);
    const std::string path = ((noTemporaryFolder ? "/tmp" : folder) /
                              ("shprobe-bench-pipelines-" + std::to_string(getpid()) + ".bin"))
                                 .string();
    PipelineCreation result;
    auto createWith = [&](VkPipelineCache cache) {
        Clock::time_point start = Clock::now();
        Projector projector = createProjector(context, {.order = order, .pipelineCache = cache});
        double ms = millisecondsSince(start);
        destroyProjector(context, projector);
        return ms;
    };
    VkPipelineCache empty = loadPipelineCache(context, "");
    result.firstMilliseconds = createWith(empty);
    savePipelineCache(context, empty, path);
    vkDestroyPipelineCache(context.device, empty, nullptr);
    std::error_code ignored;
    result.cacheBytes = size_t(std::filesystem::file_size(path, ignored));
    VkPipelineCache loaded = loadPipelineCache(context, path);
    result.cachedMilliseconds = createWith(loaded);
    vkDestroyPipelineCache(context.device, loaded, nullptr);
    std::filesystem::remove(path, ignored);
    return result;
}

} // namespace shprobe
