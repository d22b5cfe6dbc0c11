#include "app/bake_steps.h"

#include "app/toolkit.h"
#include "common/counted.h"
#include "common/scope_exit.h"
#include "common/short_number.h"
#include "common/stopwatch.h"
#include "formats/engine_export.h"
#include "image/specular_prefilter.h"
#include "sh/basis.h"
#include "sh/fast_projection.h"
#include "sh/folding.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/projection.h"
#include "sh/windowing.h"
#include "vk/vulkan_commands.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <limits>
#include <thread>

namespace shprobe {

namespace {

constexpr int kDefaultSkyFaceSize = 256;

// --backend auto: the fast CPU path's speed, texels x coefficients per second per core, taken at
// half of what a 2-core VM does to stand for slower cores, and the least a Vulkan start-up takes
// before any device, pipeline or upload (docs/benchmark.md). A job whose CPU projection takes less
// is baked on the CPU at once.
constexpr double kCpuWorkPerCoreSecond = 1e9;
constexpr double kVulkanStartSeconds = 0.02;

// The steps after the projection, the same on either backend: add the analytic lights, then choose
// the window (de-ringing looks at the radiance with the lights in it).
struct Finished {
    ShCoefficients radiance;
    std::vector<double> window; // empty: none
};

bool needsFinishing(const BakeOptions& options) {
    return hasLights(options.lights) || !options.window.none();
}

Finished finish(const BakeOptions& options, ShCoefficients radiance, const std::string& input) {
    addLights(radiance, options.lights, input);
    std::optional<std::vector<double>> window = windowFactorsFor(options.window, radiance);
    return {std::move(radiance), window.value_or(std::vector<double>{})};
}

} // namespace

// On Linux a GPU's driver needs its device file (or makes it from its kernel module), so that the
// answer without one is known without the Vulkan start-up, which loads every installed driver.
// Elsewhere only the device itself tells.
bool mayHaveGpu() {
#if defined(__linux__)
    return !findGpuFile().empty();
#else
    return true;
#endif
}

Environment loadInput(const BakeOptions& options, const std::string& input, WorkCounter* progress) {
    if (!input.empty()) {
        LoadOptions load;
        load.progress = progress;
        load.layout = parseLayout(options.layout);
        load.faceSize = options.faceSize;
        load.nonFinite = options.sanitize ? NonFinitePolicy::Replace : NonFinitePolicy::Refuse;
        load.maxPixels = options.maxPixels;
        load.keepEquirect = !options.extractSun; // the sun is found on a cube map
        load.keepCross = !options.extractSun;
        try {
            return loadEnvironment(input, load);
        } catch (const Error& error) { // the allocation does not know the file it is for
            if (error.kind() != ErrorKind::Memory) throw;
            throw Error(ErrorKind::Memory, input + ": " + error.what());
        }
    }
    Environment sky;
    int faceSize = options.faceSize > 0 ? options.faceSize : kDefaultSkyFaceSize;
    sky.cubemap = makeDefaultSky(faceSize);
    sky.description = "built-in sky";
    return sky;
}

GpuSession::GpuSession(const BakeOptions& options) : options_(options) {
    ContextOptions contextOptions;
    contextOptions.device = options.device;
    contextOptions.validation = options.validation;
    context_ = createContext(contextOptions);
    OnFailure destroy([&] { destroyContext(context_); });
    cachePath_ = pipelineCachePath(context_);
    context_.pipelineCache = loadPipelineCache(context_, cachePath_);
    VK_CHECK(vkGetPipelineCacheData(context_.device, context_.pipelineCache, &loadedCacheBytes_, nullptr));
}

GpuSession::~GpuSession() {
    release();
}

const ProbeBaker& GpuSession::baker(ProbeSource source) {
    std::optional<ProbeBaker>& baker = source == ProbeSource::Equirect ? equirectBaker_ : cubemapBaker_;
    if (baker) return *baker;
    DeviceStep step("creating the bake pipelines", DeviceWork::Setup);
    Clock::time_point start = Clock::now();
    baker = createProbeBaker(context_, {.order = options_.order,
                                        .cubemaps = uploadBinding(context_, TexelFormat::Rgba32F),
                                        .workgroupSize = options_.workgroupSize,
                                        .texelsPerInvocation = options_.texelsPerInvocation,
                                        .source = source});
    pipelineMilliseconds_ += millisecondsSince(start);
    savePipelineCache(context_, context_.pipelineCache, cachePath_);
    return *baker;
}

void GpuSession::release() {
    if (released_) return;
    released_ = true;
    for (std::optional<ProbeBaker>* baker : {&cubemapBaker_, &equirectBaker_})
        if (*baker) destroyProbeBaker(context_, **baker);
    vkDestroyPipelineCache(context_.device, context_.pipelineCache, nullptr);
    destroyContext(context_);
}

void GpuSession::finish() {
    uint32_t messages = context_.validationMessages();
    release();
    if (messages > 0)
        throw Error(ErrorKind::Device, counted(messages, "Vulkan validation message") + " (above)");
}

double projectionWork(const BakeOptions& options, const Environment& environment) {
    return double(environment.texelCount()) * coefficientCount(options.order);
}

bool requestsVulkan(const BakeOptions& options) {
    return options.backend == "gpu" ||
           (options.backend == "auto" && (!options.device.empty() || options.validation));
}

Backend gpuBackend(std::unique_ptr<GpuSession> session) {
    return Backend{"gpu", "", std::move(session)};
}

std::string cpuReasonWithoutVulkan() {
    return mayHaveGpu() ? "" : "no GPU device file: any Vulkan device here is a CPU";
}

std::string cpuReasonForDevice(const DeviceInfo* device) {
    if (!device) return "no usable Vulkan device";
    if (device->type == VK_PHYSICAL_DEVICE_TYPE_CPU)
        return "the Vulkan device is a CPU (" + device->name + ")";
    return "";
}

double smallJobWork() {
    return kVulkanStartSeconds * kCpuWorkPerCoreSecond * std::max(1u, std::thread::hardware_concurrency());
}

Backend chooseBackend(const BakeOptions& options, double work) {
    if (requestsVulkan(options)) return gpuBackend(std::make_unique<GpuSession>(options));
    Backend backend{options.backend, "", nullptr};
    if (options.backend == "cpu" || options.backend == "reference") return backend;
    backend.name = "cpu";
    if (work < smallJobWork()) {
        backend.reason = "a job this small is done on the CPU before Vulkan could start";
        return backend;
    }
    if (std::string reason = cpuReasonWithoutVulkan(); !reason.empty()) {
        backend.reason = reason + ", where this path is faster";
        return backend;
    }
    try {
        backend.session = std::make_unique<GpuSession>(options);
    } catch (const Error& error) {
        if (error.kind() != ErrorKind::Device) throw;
        backend.reason = cpuReasonForDevice(nullptr); // `--backend gpu` says why in full
        return backend;
    }
    if (std::string reason = cpuReasonForDevice(&backend.session->context().info); !reason.empty()) {
        backend.reason = reason + ", where this path is faster";
        backend.session->finish();
        backend.session.reset();
        return backend;
    }
    backend.name = "gpu";
    backend.reason = "a GPU";
    return backend;
}

VkDeviceSize environmentBytes(const Environment& environment) {
    return VkDeviceSize(environment.texelCount()) * sizeof(glm::vec4);
}

void fitBackend(const Backend& backend, Environment& environment) {
    // The fast CPU path alone reads a cross's faces where they lie.
    if (backend.name != "cpu") copyCrossToCubemap(environment);
    if (!backend.session || !environment.keptEquirect()) return;
    const uint32_t largest = backend.session->context().info.limits.maxImageDimension2D;
    const Image& equirect = environment.equirect;
    if (uint32_t(equirect.width) <= largest && uint32_t(equirect.height) <= largest) return;
    environment.cubemap = equirectToCubemap(equirect, std::max(1, equirect.width / 4));
    environment.equirect = Image{};
}

std::string inputSize(const Environment& environment) {
    if (environment.keptEquirect())
        return std::to_string(environment.equirect.width) + " x " +
               std::to_string(environment.equirect.height) + " pixels";
    std::string n = std::to_string(environment.faceSize());
    return "6 x " + n + " x " + n + " texels";
}

std::string backendLine(const Backend& backend, const std::string& device) {
    std::string line = "  backend  " + backend.name + ": " + device;
    return backend.reason.empty() ? line : line + " (auto: " + backend.reason + ")";
}

std::vector<BakeResult> bakeOnGpu(const BakeOptions& options, GpuSession& session,
                                  std::span<const Environment* const> environments) {
    std::vector<const Cubemap*> cubemaps;
    std::vector<const Image*> equirects;
    for (const Environment* environment : environments) {
        if (environment->keptEquirect())
            equirects.push_back(&environment->equirect);
        else
            cubemaps.push_back(&environment->cubemap);
    }
    std::vector<GpuBake> cubemapBakes, equirectBakes;
    if (!cubemaps.empty())
        cubemapBakes = bakeCubemaps(session.context(), session.baker(ProbeSource::Cubemaps), cubemaps);
    if (!equirects.empty())
        equirectBakes = bakeEquirects(session.context(), session.baker(ProbeSource::Equirect), equirects);

    std::vector<BakeResult> results;
    size_t nextCubemap = 0, nextEquirect = 0;
    for (const Environment* environment : environments) {
        bool equirect = environment->keptEquirect();
        const GpuBake& bake = equirect ? equirectBakes[nextEquirect++] : cubemapBakes[nextCubemap++];
        BakeResult result{bake.radiance, bake.irradiance, session.context().info.name,
                          bake.deviceMilliseconds, bake};
        if (needsFinishing(options) && isFinite(bake)) {
            Finished finished = finish(options, bake.radiance, environment->description);
            const ProbeBaker& baker = session.baker(equirect ? ProbeSource::Equirect : ProbeSource::Cubemaps);
            GpuBake convolved = convolveOnGpu(session.context(), baker, finished.radiance, finished.window);
            result.radiance = convolved.radiance;
            result.irradiance = convolved.irradiance;
        }
        results.push_back(std::move(result));
    }
    return results;
}

void requireUsable(const Backend& backend, const BakeResult& result, bool irradiance,
                   const std::string& input) {
    const GpuBake coefficients{result.radiance, result.irradiance};
    if (backend.name == "gpu") return requireFinite(coefficients, input);
    if (!isFinite(coefficients))
        throw Error(ErrorKind::Input,
                    input + ": CPU bake: the coefficients are not finite (input values too large for " +
                        (backend.name == "reference" ? "double" : "fp32") + " sums?)");
    // The reference sums in double, but every file holds floats: a larger coefficient written (the
    // radiance, or the irradiance with --irradiance) would be a number no reader of the file takes.
    const double largest = largestMagnitude(irradiance ? result.irradiance : result.radiance);
    if (largest <= double(std::numeric_limits<float>::max())) return;
    throw Error(ErrorKind::Input, input + ": CPU bake: a coefficient is " + shortNumber(largest) +
                                      ", past the float range (3.4e+38) the probe files hold");
}

const char* cpuBackendName(const std::string& backend) {
    return backend == "reference" ? "cpu reference (double)" : "cpu (float, all cores)";
}

ShCoefficients projectOnCpu(const std::string& backend, const Environment& environment, int order,
                            WorkCounter* progress) {
    bool reference = backend == "reference";
    if (environment.keptEquirect())
        return reference ? projectEquirect(environment.equirect, order, progress)
                         : projectEquirectFast(environment.equirect, order);
    if (environment.keptCross() && !reference) {
        std::vector<glm::vec4> turned;
        const FaceRows faces = crossFaceRows(environment.cross, environment.layout, turned);
        return projectFacesFast(faces, TexelFormat::Rgba32F, environment.faceSize(), order);
    }
    return reference ? projectCubemap(environment.cubemap, order, progress)
                     : projectCubemapFast(environment.cubemap, order);
}

BakeResult bakeOnCpu(const BakeOptions& options, const std::string& backend, const Environment& environment,
                     WorkCounter* progress) {
    Finished finished =
        finish(options, projectOnCpu(backend, environment, options.order, progress), environment.description);
    BakeResult result;
    result.radiance =
        finished.window.empty() ? finished.radiance : applyWindow(finished.radiance, finished.window);
    result.irradiance = convolveIrradiance(result.radiance);
    result.device = cpuBackendName(backend);
    return result;
}

std::vector<BakeResult> bake(const BakeOptions& options, Backend& backend,
                             std::span<const Environment* const> environments, WorkCounter* progress) {
    if (backend.session) {
        const bool batch = environments.size() > 1;
        DeviceStep step(batch ? "baking a chunk of " + std::to_string(environments.size()) + " probes"
                              : "baking " + environments[0]->description,
                        DeviceWork::Sized, batch ? "--face-size or --batch-bytes" : "--face-size");
        return bakeOnGpu(options, *backend.session, environments);
    }
    std::vector<BakeResult> results;
    for (const Environment* environment : environments)
        results.push_back(bakeOnCpu(options, backend.name, *environment, progress));
    return results;
}

std::optional<ProbeSun> takeOutSun(const BakeOptions& options, Environment& environment) {
    if (!options.extractSun) return std::nullopt;
    SunExtraction sun = extractSun(environment.cubemap);
    if (!sun.found) return std::nullopt;
    SphericalLight light = sunAsSphericalLight(sun);
    return ProbeSun{light.direction, light.radiance, light.angularRadius};
}

BakeOptions withFormatAndOutput(BakeOptions options) {
    settleFormatAndOutput(options.format, options.output);
    return options;
}

std::vector<std::string> filesReadBy(const std::string& input) {
    if (input.empty()) return {};
    try {
        if (isFacesSource(input)) {
            std::array<std::string, kFaceCount> faces = resolveFaceFiles(input);
            return {faces.begin(), faces.end()};
        }
    } catch (const Error&) { // the load reports it
    }
    return {input};
}

void checkFormatOptions(const BakeOptions& options) {
    const ExportFormat& format = formatNamed(options.format);
    if (isHeaderFormat(options.format) && options.order > kMaxFoldedOrder)
        throw Error(ErrorKind::Input, "--format " + options.format + " holds orders 1 to " +
                                          std::to_string(kMaxFoldedOrder) +
                                          " (what sh_irradiance.glsl evaluates), "
                                          "not --order " +
                                          std::to_string(options.order));
    if (options.extractSun && format.sun == SunHandling::Refused)
        throw Error(ErrorKind::Input,
                    "--extract-sun: --format " + options.format +
                        " cannot hold the sun; use --format json, which keeps it beside the coefficients");
    requireFormatOptionsUsed(options.format, options.mapSize, options.mirror);
    requireMapSizeFits(options.format, options.mapSize);
    if (options.format == "gltf" && !options.lights.directional.empty())
        throw Error(ErrorKind::Input,
                    "--directional: --format gltf's specularImages cannot hold a delta light (its mirror "
                    "image has no size); give the light a size with --sphere X,Y,Z RADIUS R,G,B");
}

namespace {

// gltf's specularImages source: the environment's radiance at the specularImageSize (an area
// average: equirect maps by each pixel's share of a texel, cube maps by resizeCubemap) with
// the analytic lights drawn in: --ambient everywhere, each --sphere's cap by texel coverage.
Cubemap specularRadianceOf(const BakeOptions& options, const Environment& environment, int size) {
    Cubemap radiance = environment.keptEquirect() ? equirectToCubemap(environment.equirect, size)
                       : environment.keptCross()
                           ? resizeCubemap(crossToCubemap(environment.cross, environment.layout), size)
                           : resizeCubemap(environment.cubemap, size);
    for (const glm::dvec3& ambient : options.lights.ambient)
        addUniformRadiance(radiance, ambient);
    for (const SphericalLight& light : options.lights.spheres)
        drawSphericalLight(radiance, light);
    return radiance;
}

std::string lightsDrawnIn(const LightOptions& lights) {
    if (lights.ambient.empty() && lights.spheres.empty()) return "";
    if (lights.spheres.empty()) return " with --ambient added";
    return lights.ambient.empty() ? " with --sphere drawn in" : " with --ambient added and --sphere drawn in";
}

} // namespace

void writeOutput(const BakeOptions& options, const std::string& path, const ShCoefficients& probe,
                 const ProbeMetadata& metadata, const Environment& environment) {
    ExportOptions exportOptions{
        .metadata = metadata, .mapSize = options.mapSize, .mirror = options.mirror.value_or(true)};
    Cubemap specular;
    if (options.format == "gltf") {
        specular = specularRadianceOf(options, environment,
                                      options.mapSize > 0 ? options.mapSize : kDefaultSpecularSize);
        exportOptions.specular = {&specular, environment.description + lightsDrawnIn(options.lights)};
    }
    formatNamed(options.format).write(path, probe, exportOptions);
}

ProbeMetadata metadataFor(const Backend& backend, const BakeOptions& options, const Environment& environment,
                          const BakeResult& result, const std::optional<ProbeSun>& sun) {
    ProbeMetadata metadata;
    metadata.source = environment.description;
    metadata.faceSize = environment.faceSize(); // 0 (not written) for an equirect map kept as it is
    metadata.backend = backend.name;
    metadata.device = result.device;
    metadata.window = options.window.none() ? "" : options.window.text;
    metadata.sun = sun;
    return metadata;
}

RayBackend chooseRayBackend(bool automatic, const std::function<Context()>& create) {
    if (std::string reason = automatic ? cpuReasonWithoutVulkan() : ""; !reason.empty())
        return {"cpu", reason, std::nullopt};
    Context context;
    try {
        context = create();
    } catch (const Error& error) {
        if (!automatic || error.kind() != ErrorKind::Device) throw;
        return {"cpu", cpuReasonForDevice(nullptr), std::nullopt};
    }
    if (std::string reason = automatic ? cpuReasonForDevice(&context.info) : ""; !reason.empty()) {
        destroyContext(context);
        return {"cpu", reason, std::nullopt};
    }
    return {"gpu", automatic ? "a GPU" : "", std::move(context)};
}

} // namespace shprobe
