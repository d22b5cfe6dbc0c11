// The steps of `shprobe bake` that a single bake (bake.cpp) and a batch (bake_batch.cpp) share:
// loading an input, baking cube maps on the GPU or the CPU, finishing and writing a probe.
#pragma once
#include "app/commands.h"
#include "shprobe/gpu/host_bake.h"
#include "shprobe/image/environment.h"
#include "shprobe/io/output_file.h"
#include "shprobe/io/probe_file.h"
#include "shprobe/sh/error.h"
#include "shprobe/sh/scope_exit.h"
#include "shprobe/vk/check.h"
#include "shprobe/vk/context.h"
#include "shprobe/vk/pipeline_cache.h"

#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace shprobe {

struct BakeResult {
    ShCoefficients radiance;
    ShCoefficients irradiance;
    std::string device; // "cpu reference" or the GPU's name
    double deviceMilliseconds = 0.0;
};

// An empty input is the built-in sky.
Environment loadInput(const BakeOptions& options, const std::string& input);

VkDeviceSize cubemapBytes(const Cubemap& cubemap);

// Runs work(context, baker) with a device and the bake pipelines of the options' order, created
// once for any number of bakes and released here; any validation message fails the run. The
// pipelines come through the on-disk pipeline cache (vk/pipeline_cache.h), saved right after they
// exist.
template <typename Work> void withGpu(const BakeOptions& options, Work&& work) {
    uint32_t validationMessages = 0;
    {
        ContextOptions contextOptions;
        contextOptions.device = options.device;
        contextOptions.validation = options.validation;
        Context context = createContext(contextOptions);
        ScopeExit destroy([&] {
            validationMessages = context.validationMessages();
            destroyContext(context);
        });
        const std::string cachePath = pipelineCachePath(context);
        context.pipelineCache = loadPipelineCache(context, cachePath);
        ScopeExit destroyCache(
            [&] { vkDestroyPipelineCache(context.device, context.pipelineCache, nullptr); });
        std::optional<DeviceStep> creating(std::in_place, "creating the bake pipelines", DeviceWork::Setup);
        ProbeBaker baker =
            createProbeBaker(context, {.order = options.order,
                                       .cubemaps = uploadBinding(context, TexelFormat::Rgba32F),
                                       .workgroupSize = options.workgroupSize,
                                       .texelsPerInvocation = options.texelsPerInvocation});
        ScopeExit destroyBaker([&] { destroyProbeBaker(context, baker); });
        savePipelineCache(context, context.pipelineCache, cachePath);
        creating.reset();
        work(std::as_const(context), std::as_const(baker));
    }
    if (validationMessages > 0)
        throw Error(ErrorKind::Device,
                    std::to_string(validationMessages) + " Vulkan validation messages (above)");
}

// The cube maps of a chunk in one submission (bakeCubemaps); then, per probe, the lights and the
// window (convolve.comp). A probe whose sums overflowed comes back as computed, for
// requireUsable to refuse.
std::vector<BakeResult> bakeOnGpu(const BakeOptions& options, const Context& context, const ProbeBaker& baker,
                                  std::span<const Cubemap* const> cubemaps);

// Throws Error(Input) naming the input when a GPU bake's coefficients are not finite (its fp32
// sums overflowed). The CPU paths sum in double; the probe writers refuse what is not finite.
void requireUsable(const BakeOptions& options, const BakeResult& result, const std::string& input);

// "cpu": the fast float path on all cores; "reference": the double-precision reference.
const char* cpuBackendName(const BakeOptions& options);
BakeResult bakeOnCpu(const BakeOptions& options, const Cubemap& cubemap);

// Takes the sun out of the environment when asked; the probe is then of the rest.
std::optional<ProbeSun> takeOutSun(const BakeOptions& options, Environment& environment);

// The extension a format's files get: ".json", ".bin", ".glsl", ".h", ".exr".
const char* formatExtension(const std::string& format);

// The options with --format and -o settled: without --format, -o's extension chooses it (json
// when the extension names none); without -o, the output is "probe" and the format's extension.
// An -o extension that names another format than --format is refused (Error(Input)).
BakeOptions withFormatAndOutput(BakeOptions options);
// The same rule on a format and an output name (convert).
void settleFormatAndOutput(std::string& format, std::string& output);

// Whether the format's files are text (json, glsl, cpp) or binary (standard output takes both;
// a terminal only text).
OutputContent formatContent(const std::string& format);

// Option combinations the writers would refuse, checked before any work.
void checkFormatOptions(const BakeOptions& options);

// Writes the probe in the chosen format (probe_file.h, probe_export.h); every writer is atomic.
void writeOutput(const BakeOptions& options, const std::string& path, const ShCoefficients& probe,
                 const ProbeMetadata& metadata);

ProbeMetadata metadataFor(const BakeOptions& options, const Environment& environment,
                          const BakeResult& result, const std::optional<ProbeSun>& sun);

// Every input to its own file in options.outDir (bake_batch.cpp).
void runBatchBake(const BakeOptions& options);

} // namespace shprobe
