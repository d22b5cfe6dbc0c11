// The steps of `shprobe bake` that a single bake (bake.cpp) and a batch (bake_batch.cpp) share:
// loading an input, choosing the backend, baking cube maps and equirect maps on the GPU or the CPU,
// finishing and writing a probe.
#pragma once
#include "app/commands.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/work_counter.h"
#include "formats/output_format.h"
#include "formats/probe_file.h"
#include "gpu/host_bake.h"
#include "image/environment.h"
#include "vk/check.h"
#include "vk/context.h"
#include "vk/pipeline_cache.h"

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace shprobe {

struct BakeResult {
    ShCoefficients radiance;
    ShCoefficients irradiance;
    std::string device; // cpuBackendName or the GPU's name
    double deviceMilliseconds = 0.0;
    GpuBake phases; // GPU only: its upload, submit and readback times (coefficients unused)
};

// An empty input is the built-in sky. An equirect input is kept as decoded (projected directly)
// unless a cube map is asked for (--face-size) or needed (--extract-sun). A resampling is counted
// into `progress`.
Environment loadInput(const BakeOptions& options, const std::string& input, WorkCounter* progress = nullptr);

// The device and the bake pipelines of a run, for any number of bakes. The pipelines of each source
// (cube maps, equirect maps) are created the first time a bake needs them, so a run compiles only
// what it bakes; they come through the on-disk pipeline cache (vk/pipeline_cache.h), saved right
// after they exist. finish() fails the run if the validation layer printed any message.
class GpuSession {
  public:
    explicit GpuSession(const BakeOptions& options);
    ~GpuSession();
    GpuSession(const GpuSession&) = delete;
    GpuSession& operator=(const GpuSession&) = delete;

    const Context& context() const { return context_; }
    const ProbeBaker& baker(ProbeSource source);
    // Wall time of creating the bake pipelines so far, and the bytes of pipeline data the on-disk
    // cache held when loaded (a bare header when it held none: the pipelines were compiled cold).
    double pipelineMilliseconds() const { return pipelineMilliseconds_; }
    size_t loadedCacheBytes() const { return loadedCacheBytes_; }
    // Releases everything; throws Error(Device) when validation messages were printed.
    void finish();

  private:
    void release();

    const BakeOptions& options_;
    Context context_;
    std::string cachePath_;
    std::optional<ProbeBaker> cubemapBaker_;
    std::optional<ProbeBaker> equirectBaker_;
    double pipelineMilliseconds_ = 0.0;
    size_t loadedCacheBytes_ = 0;
    bool released_ = false;
};

// The backend a run bakes on and, for --backend auto, why: "gpu" (with its session), "cpu" or
// "reference".
struct Backend {
    std::string name;
    std::string reason;                  // auto only: why this backend
    std::unique_ptr<GpuSession> session; // gpu only
};

// --backend gpu, cpu, reference as given; auto (the default) chooses by the job and the device:
// the fast CPU path when the job's projection (work: texels x coefficients, all inputs) takes less
// on the CPU than a Vulkan start-up alone (then no Vulkan instance is created), when the device is a
// CPU (lavapipe: the fast CPU path projects faster than llvmpipe runs the shaders), or when no
// Vulkan device can be used; Vulkan on a GPU. With --device or --validation auto means gpu.
Backend chooseBackend(const BakeOptions& options, double work);
// The work (texels x coefficients, all inputs) under which auto bakes on the CPU at once: what the
// fast CPU path does on this machine's cores in less time than a Vulkan start-up takes.
double smallJobWork();
// auto's rule on the machine, the same for `bake` and `scene` (and what `info` reports): the CPU
// where no GPU device file is (known before Vulkan starts: cpuReasonWithoutVulkan), where no Vulkan
// device can be used or the device is a CPU (cpuReasonForDevice; `device`: the one a context would
// use, nullptr where none is usable); else the GPU. Each returns why the CPU, or "" for the GPU.
std::string cpuReasonWithoutVulkan();
std::string cpuReasonForDevice(const DeviceInfo* device);
// The device a job of rays (`scene`, `transfer`) runs on, and why where auto chose: cpu (no
// context) or gpu (its context).
struct RayBackend {
    std::string name;
    std::string reason;
    std::optional<Context> context;
};
// auto's rule for it (`automatic`; else the gpu asked for): cpu where no GPU can be, where Vulkan
// has no usable device or the device is a CPU, else gpu on the context `create` makes.
RayBackend chooseRayBackend(bool automatic, const std::function<Context()>& create);
// Whether a Vulkan device here may be a GPU: false where none can be (then any is a CPU, where the
// CPU paths are faster), without starting Vulkan.
bool mayHaveGpu();
// Whether the options ask for Vulkan whatever the job: --backend gpu, a --device named, or
// --validation (which checks Vulkan's use).
bool requestsVulkan(const BakeOptions& options);
// The gpu backend on a session started beforehand (while the input decoded).
Backend gpuBackend(std::unique_ptr<GpuSession> session);
// The projection work of one input: texels times coefficients.
double projectionWork(const BakeOptions& options, const Environment& environment);

// The environments of a chunk baked together: the cube maps in one submission (bakeCubemaps), the
// equirect maps in another (bakeEquirects); then, per probe, the lights and the window
// (convolve.comp). A probe whose sums overflowed comes back as computed, for requireUsable to refuse.
std::vector<BakeResult> bakeOnGpu(const BakeOptions& options, GpuSession& session,
                                  std::span<const Environment* const> environments);

// Throws Error(Input) naming the input when a bake's coefficients are not finite: finite inputs
// near 1e38 overflow the fp32 sums of the GPU and of the fast CPU path (the reference's double sums
// only hold more), and no probe file holds infinities; nor where the reference's written quantity
// (the irradiance where `irradiance`, else the radiance) is past float.
void requireUsable(const Backend& backend, const BakeResult& result, bool irradiance,
                   const std::string& input);

// "cpu": the fast float path on all cores; "reference": the double-precision reference.
const char* cpuBackendName(const std::string& backend);
// The reference projection's rows are counted into `progress` (the fast path takes tens of
// milliseconds where the reference takes seconds).
BakeResult bakeOnCpu(const BakeOptions& options, const std::string& backend, const Environment& environment,
                     WorkCounter* progress = nullptr);

// Bakes on the chosen backend, one environment or (gpu) a chunk; a cpu bake counts into `progress`.
std::vector<BakeResult> bake(const BakeOptions& options, Backend& backend,
                             std::span<const Environment* const> environments,
                             WorkCounter* progress = nullptr);

// The bytes one environment's texels take in a GPU submission (the chunks of a batch).
VkDeviceSize environmentBytes(const Environment& environment);

// On the GPU, an equirect map with a side beyond the device's image limit is resampled to a cube map
// (of width / 4); elsewhere nothing changes.
void fitBackend(const Backend& backend, Environment& environment);

// "6 x 256 x 256 texels" of a cube map, "1024 x 512 pixels" of an equirect map projected directly.
std::string inputSize(const Environment& environment);
// "  backend  cpu: cpu (float, all cores) (auto: ...)", without the line's end.
std::string backendLine(const Backend& backend, const std::string& device);

// Takes the sun out of the environment when asked; the probe is then of the rest.
std::optional<ProbeSun> takeOutSun(const BakeOptions& options, Environment& environment);

// The options with --format and -o settled (settleFormatAndOutput, formats/output_format.h).
BakeOptions withFormatAndOutput(BakeOptions options);

// Option combinations the writers would refuse, checked before any work.
void checkFormatOptions(const BakeOptions& options);

// Writes the probe in the chosen format (probe_file.h, probe_export.h); every writer is atomic.
// gltf's specularImages are prefiltered from the environment's radiance, its --ambient and --sphere
// lights drawn in.
void writeOutput(const BakeOptions& options, const std::string& path, const ShCoefficients& probe,
                 const ProbeMetadata& metadata, const Environment& environment);

ProbeMetadata metadataFor(const Backend& backend, const BakeOptions& options, const Environment& environment,
                          const BakeResult& result, const std::optional<ProbeSun>& sun);

// Every input to its own file in options.outDir (bake_batch.cpp).
void runBatchBake(const BakeOptions& options);

} // namespace shprobe
