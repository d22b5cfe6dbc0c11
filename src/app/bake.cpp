// `shprobe bake`: environments in, SH radiance or irradiance coefficients out, on the GPU or with
// the double-precision CPU reference. One input is written to -o; several (or a --list) are a
// batch written to --out-dir, baked in chunks of as many cube maps as one GPU submission takes.
#include "app/commands.h"
#include "app/toolkit.h"
#include "gpu/projector.h"
#include "image/environment.h"
#include "io/atomic_file.h"
#include "io/probe_export.h"
#include "io/probe_file.h"
#include "sh/basis.h"
#include "sh/error.h"
#include "sh/fast_projection.h"
#include "sh/folding.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/projection.h"
#include "sh/windowing.h"
#include "vk/check.h"
#include "vk/context.h"
#include "vk/pipeline_cache.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <unistd.h>
#include <utility>

namespace shprobe {

namespace {

namespace fs = std::filesystem;

constexpr int kDefaultSkyFaceSize = 256;

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct BakeResult {
    ShCoefficients radiance;
    ShCoefficients irradiance;
    std::string device; // "cpu reference" or the GPU's name
    double deviceMilliseconds = 0.0;
    std::string failure; // why this probe cannot be written (its sums overflowed); empty if fine
};

// An empty input is the built-in sky.
Environment loadInput(const BakeOptions& options, const std::string& input) {
    if (!input.empty()) {
        LoadOptions load;
        load.layout = parseLayout(options.layout);
        load.faceSize = options.faceSize;
        load.nonFinite = options.sanitize ? NonFinitePolicy::Replace : NonFinitePolicy::Refuse;
        load.maxPixels = options.maxPixels;
        return loadEnvironment(input, load);
    }
    Environment sky;
    int faceSize = options.faceSize > 0 ? options.faceSize : kDefaultSkyFaceSize;
    sky.cubemap = makeDefaultSky(faceSize);
    sky.description = "built-in sky";
    return sky;
}

// The steps after the projection, the same on either backend: add the analytic lights, then choose
// the window (de-ringing looks at the radiance with the lights in it).
struct Finished {
    ShCoefficients radiance;
    std::vector<double> window; // empty: none
};

bool needsFinishing(const BakeOptions& options) { return hasLights(options.lights) || options.window != "none"; }

Finished finish(const BakeOptions& options, ShCoefficients radiance) {
    addLights(radiance, options.lights);
    std::optional<std::vector<double>> window = windowFactorsFor(options.window, radiance);
    return {std::move(radiance), window.value_or(std::vector<double>{})};
}

VkDeviceSize texelBytes(const Cubemap& cubemap) {
    return VkDeviceSize(cubemap.texels.size()) * sizeof(glm::vec4);
}

// Runs work(context, projector) with a device and the pipelines of the options' order, created once
// for any number of bakes and released here; any validation message fails the run. The pipelines
// come through the on-disk pipeline cache (vk/pipeline_cache.h), saved right after they exist.
template <typename Work> void withGpu(const BakeOptions& options, Work&& work) {
    ContextOptions contextOptions;
    contextOptions.device = options.device;
    contextOptions.validation = options.validation;
    Context context = createContext(contextOptions);
    VkPipelineCache cache = VK_NULL_HANDLE;
    try {
        const std::string cachePath = pipelineCachePath(context);
        cache = loadPipelineCache(context, cachePath);
        std::optional<DeviceStep> creating(std::in_place, "creating the bake pipelines");
        Projector projector = createProjector(context, {.order = options.order,
                                                        .workgroupSize = options.workgroupSize,
                                                        .texelsPerInvocation = options.texelsPerInvocation,
                                                        .pipelineCache = cache});
        savePipelineCache(context, cache, cachePath);
        creating.reset();
        try {
            work(std::as_const(context), std::as_const(projector));
        } catch (...) {
            destroyProjector(context, projector);
            throw;
        }
        destroyProjector(context, projector);
    } catch (...) {
        if (cache) vkDestroyPipelineCache(context.device, cache, nullptr);
        destroyContext(context);
        throw;
    }
    vkDestroyPipelineCache(context.device, cache, nullptr);
    uint32_t validationMessages = context.validationMessages();
    destroyContext(context);
    if (validationMessages > 0)
        throw Error(ErrorKind::Device, std::to_string(validationMessages) + " Vulkan validation messages (above)");
}

// The cube maps of a chunk in one submission (bakeCubemaps), or alone through bakeCubemap when one
// is larger than a chunk may be; then, per probe, the lights and
// the window (convolve.comp).
std::vector<BakeResult> bakeOnGpu(const BakeOptions& options, const Context& context,
                                  const Projector& projector, std::span<const Cubemap* const> cubemaps) {
    std::vector<GpuBake> bakes;
    if (cubemaps.size() == 1 && texelBytes(*cubemaps[0]) > batchTexelBytes(context))
        bakes.push_back(bakeCubemap(context, projector, *cubemaps[0]));
    else
        bakes = bakeCubemaps(context, projector, cubemaps);
    std::vector<BakeResult> results;
    for (GpuBake& bake : bakes) {
        double deviceMs = bake.deviceMilliseconds;
        if (!bake.failure.empty()) {
            results.push_back({{}, {}, context.info.name, deviceMs, bake.failure});
            continue;
        }
        if (needsFinishing(options)) {
            Finished finished = finish(options, bake.radiance);
            bake = convolveOnGpu(context, projector, finished.radiance, finished.window);
        }
        results.push_back({bake.radiance, bake.irradiance, context.info.name, deviceMs});
    }
    return results;
}

// "cpu": the fast float path on all cores; "reference": the double-precision reference.
const char* cpuBackendName(const BakeOptions& options) {
    return options.backend == "reference" ? "cpu reference (double)" : "cpu (float, all cores)";
}

BakeResult bakeOnCpu(const BakeOptions& options, const Cubemap& cubemap) {
    ShCoefficients radiance = options.backend == "reference" ? projectCubemap(cubemap, options.order)
                                                             : projectCubemapFast(cubemap, options.order);
    Finished finished = finish(options, radiance);
    BakeResult result;
    result.radiance = finished.window.empty() ? finished.radiance : applyWindow(finished.radiance, finished.window);
    result.irradiance = convolveIrradiance(result.radiance);
    result.device = cpuBackendName(options);
    return result;
}

// Takes the sun out of the environment when asked; the probe is then of the rest.
std::optional<ProbeSun> takeOutSun(const BakeOptions& options, Environment& environment) {
    if (!options.extractSun) return std::nullopt;
    SunExtraction sun = extractSun(environment.cubemap);
    if (!sun.found) return std::nullopt;
    SphericalLight light = sunAsSphericalLight(sun);
    return ProbeSun{light.direction, light.radiance, light.angularRadius};
}

bool isHeaderFormat(const std::string& format) {
    return format == "glsl" || format == "cpp";
}

// Option combinations the writers would refuse, checked before any work.
void checkFormatOptions(const BakeOptions& options) {
    if (isHeaderFormat(options.format) && options.order > kMaxFoldedOrder)
        throw Error(ErrorKind::Input, "--format " + options.format + " holds orders 1 to " +
                                          std::to_string(kMaxFoldedOrder) +
                                          " (what sh_irradiance.glsl evaluates), "
                                          "not --order " +
                                          std::to_string(options.order));
    if (isHeaderFormat(options.format) && options.extractSun)
        throw Error(ErrorKind::Input,
                    "--extract-sun: --format " + options.format +
                        " holds the coefficients only and would drop the sun; use --format json");
    if (options.format == "irradiance-equirect" && options.mapSize % 2 != 0)
        throw Error(ErrorKind::Input, "--map-size: an equirect map's width must be even");
}

// Writes the probe in the chosen format (probe_file.h, probe_export.h); every writer is atomic.
void writeOutput(const BakeOptions& options, const std::string& path, const ShCoefficients& probe,
                 const ProbeMetadata& metadata) {
    if (options.format == "json") return writeProbeFile(path, probe, metadata);
    if (options.format == "binary") return writeBinaryProbes(path, std::span(&probe, 1));
    if (options.format == "glsl") return writeProbeHeader(path, probe, HeaderLanguage::Glsl, metadata.source);
    if (options.format == "cpp") return writeProbeHeader(path, probe, HeaderLanguage::C, metadata.source);
    if (options.format == "irradiance-equirect")
        return writeIrradianceEquirect(path, probe, options.mapSize > 0 ? options.mapSize : 512);
    writeIrradianceCross(path, probe, options.mapSize > 0 ? options.mapSize : 128);
}

ProbeMetadata metadataFor(const BakeOptions& options, const Environment& environment,
                          const BakeResult& result, const std::optional<ProbeSun>& sun) {
    ProbeMetadata metadata;
    metadata.source = environment.description;
    metadata.faceSize = environment.cubemap.faceSize;
    metadata.backend = options.backend;
    metadata.device = result.device;
    metadata.window = options.window == "none" ? "" : options.window;
    metadata.sun = sun;
    return metadata;
}

// ---- One input to -o --------------------------------------------------------------------------

void printSun(const std::optional<ProbeSun>& sun) {
    if (!sun) {
        std::printf("  sun      none found (nothing compact and far brighter than the sky)\n");
        return;
    }
    std::printf("  sun      direction (%.4f, %.4f, %.4f), radius %.3f deg, radiance (%.4g, %.4g, %.4g): "
                "written as \"sun\", not in the coefficients\n",
                sun->direction.x, sun->direction.y, sun->direction.z, sun->angularRadius * 180.0 / M_PI,
                sun->radiance.r, sun->radiance.g, sun->radiance.b);
}

void printCoefficients(const ShCoefficients& coefficients) {
    std::printf("%s coefficients (r g b):\n", quantityName(coefficients.quantity));
    for (int i = 0; i < int(coefficients.rgb.size()); ++i) {
        int l = shBand(i);
        const glm::dvec3& c = coefficients.rgb[i];
        std::printf("  l=%d m=%+d  %14.6f %14.6f %14.6f\n", l, i - l * (l + 1), c.r, c.g, c.b);
    }
}

void printSummary(const BakeOptions& options, const Environment& environment, const BakeResult& result,
                  double loadMs, double bakeMs) {
    int n = environment.cubemap.faceSize;
    std::printf("shprobe bake: %s -> %s\n", environment.description.c_str(), options.output.c_str());
    std::printf("  backend  %s: %s\n", options.backend.c_str(), result.device.c_str());
    std::printf("  input    6 x %d x %d texels, order %d (%d coefficients)\n", n, n, options.order,
                coefficientCount(options.order));
    if (environment.replacedTexels > 0)
        std::printf("  sanitize replaced %zu NaN/Inf texels with 0\n", environment.replacedTexels);
    if (hasLights(options.lights)) std::printf("  lights   added to the environment's radiance\n");
    if (options.window != "none") std::printf("  window   %s\n", options.window.c_str());
    std::printf("  time     load %.1f ms, bake %.1f ms", loadMs, bakeMs);
    if (result.deviceMilliseconds > 0.0) std::printf(" (GPU %.1f ms)", result.deviceMilliseconds);
    std::printf("\n");
}

void runSingleBake(const BakeOptions& options) {
    checkOutputPath(options.output); // before any work: a failed write must not waste a bake

    Clock::time_point start = Clock::now();
    Environment environment = loadInput(options, options.inputs.empty() ? std::string() : options.inputs[0]);
    std::optional<ProbeSun> sun = takeOutSun(options, environment);
    double loadMs = millisecondsSince(start);

    start = Clock::now();
    BakeResult result;
    if (options.backend == "gpu") {
        withGpu(options, [&](const Context& context, const Projector& projector) {
            DeviceStep step("baking " + environment.description);
            const Cubemap* cubemap = &environment.cubemap;
            result = bakeOnGpu(options, context, projector, std::span(&cubemap, 1))[0];
        });
    } else {
        result = bakeOnCpu(options, environment.cubemap);
    }
    double bakeMs = millisecondsSince(start);
    if (!result.failure.empty()) throw Error(ErrorKind::Input, environment.description + ": " + result.failure);

    const ShCoefficients& written = options.irradiance ? result.irradiance : result.radiance;
    writeOutput(options, options.output, written, metadataFor(options, environment, result, sun));

    printSummary(options, environment, result, loadMs, bakeMs);
    if (options.extractSun) printSun(sun);
    if (!options.quiet) printCoefficients(written);
}

// ---- A batch to --out-dir ---------------------------------------------------------------------

struct BatchItem {
    std::string input;
    std::string output;
};

// Paths as given on the command line, one a line; blank lines and '#' comments are skipped.
std::vector<std::string> readInputList(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw Error(ErrorKind::Input, "--list " + path + ": cannot read the file");
    std::vector<std::string> inputs;
    for (std::string line; std::getline(in, line);) {
        size_t first = line.find_first_not_of(" \t\r");
        if (first == std::string::npos || line[first] == '#') continue;
        size_t last = line.find_last_not_of(" \t\r");
        inputs.push_back(line.substr(first, last - first + 1));
    }
    return inputs;
}

// The name an input's output takes: the file's stem; a faces folder's own name; a {face} pattern's
// name without {face} and the separators around it (sky_{face}.exr -> sky), or its folder's name.
std::string outputStem(const std::string& input) {
    fs::path path = fs::absolute(input).lexically_normal();
    if (!path.has_filename()) path = path.parent_path();
    std::error_code error;
    std::string stem = fs::is_directory(path, error) ? path.filename().string() : path.stem().string();
    if (size_t at = stem.find("{face}"); at != std::string::npos) {
        stem.erase(at, 6);
        size_t first = stem.find_first_not_of("_-. "), last = stem.find_last_not_of("_-. ");
        stem = first == std::string::npos ? path.parent_path().filename().string()
                                          : stem.substr(first, last - first + 1);
    }
    return stem.empty() ? "probe" : stem;
}

const char* formatExtension(const std::string& format) {
    if (format == "json") return ".json";
    if (format == "binary") return ".bin";
    if (format == "glsl") return ".glsl";
    if (format == "cpp") return ".h";
    return ".exr"; // irradiance-equirect, irradiance-cross
}

// Inputs and their outputs; two inputs with one output name are refused, naming both.
std::vector<BatchItem> planBatch(const BakeOptions& options) {
    std::vector<std::string> inputs = options.inputs;
    if (!options.listFile.empty()) {
        std::vector<std::string> listed = readInputList(options.listFile);
        inputs.insert(inputs.end(), listed.begin(), listed.end());
    }
    if (inputs.empty())
        throw Error(ErrorKind::Input,
                    "--out-dir: no inputs (give image files, or --list FILE with at least one)");
    std::vector<BatchItem> items;
    std::map<std::string, std::string> inputOf; // output -> input
    for (const std::string& input : inputs) {
        std::string output =
            (fs::path(options.outDir) / (outputStem(input) + formatExtension(options.format))).string();
        auto [at, fresh] = inputOf.emplace(output, input);
        if (!fresh)
            throw Error(ErrorKind::Input, "inputs " + at->second + " and " + input +
                                              " would both be written to " + output +
                                              "; rename one or bake them separately");
        items.push_back({input, output});
    }
    return items;
}

// The output folder is created when its parent exists; it and every output path are checked here,
// before any GPU work, so that a bake is never wasted on an output that cannot be written.
void prepareOutputFolder(const std::string& folder, const std::vector<BatchItem>& items) {
    fs::path path = fs::path(folder).lexically_normal();
    if (!path.has_filename()) path = path.parent_path();
    std::error_code error;
    if (!fs::exists(path, error)) {
        fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
        if (!fs::is_directory(parent, error))
            throw Error(ErrorKind::Output,
                        "cannot write to " + folder + ": folder " + parent.string() + " does not exist");
        if (!fs::create_directory(path, error) && !fs::is_directory(path))
            throw Error(ErrorKind::Output, "cannot create " + folder + ": " + error.message());
    }
    if (!fs::is_directory(path, error))
        throw Error(ErrorKind::Output, "cannot write to " + folder + ": it is not a folder");
    for (const BatchItem& item : items)
        checkOutputPath(item.output);
}

// A progress bar on stderr, drawn only when stderr is a terminal: "[#####-----] 12/40 probes".
struct ProgressBar {
    size_t total = 0;
    size_t done = 0;
    bool enabled = isatty(STDERR_FILENO) == 1;
    bool drawn = false;

    void draw() {
        if (!enabled) return;
        constexpr size_t kWidth = 30;
        size_t filled = total > 0 ? done * kWidth / total : kWidth;
        std::string bar = std::string(filled, '#') + std::string(kWidth - filled, '-');
        std::fprintf(stderr, "\r[%s] %zu/%zu probes", bar.c_str(), done, total);
        std::fflush(stderr);
        drawn = true;
    }
    void clear() {
        if (!drawn) return;
        std::fputs("\r\033[K", stderr);
        std::fflush(stderr);
        drawn = false;
    }
    ~ProgressBar() { clear(); }
};

struct Batch {
    const BakeOptions& options;
    ProgressBar progress;
    size_t baked = 0;
    size_t failed = 0;
    bool inputFailed = false; // an input error among the failures (exit code 2, else 3)
    uint64_t texels = 0;
    size_t submissions = 0;
};

// A line on stdout or stderr between redraws of the progress bar.
void printLine(Batch& batch, FILE* stream, const std::string& line) {
    batch.progress.clear();
    std::fprintf(stream, "%s\n", line.c_str());
    std::fflush(stream);
    batch.progress.draw();
}

void reportFailure(Batch& batch, const BatchItem& item, const Error& error) {
    std::string message = error.what();
    if (message.find(item.input) == std::string::npos) message = item.input + ": " + message;
    ++batch.failed;
    batch.inputFailed = batch.inputFailed || error.kind() == ErrorKind::Input;
    ++batch.progress.done;
    printLine(batch, stderr, "shprobe: error: " + message);
}

struct Loaded {
    const BatchItem* item = nullptr;
    Environment environment;
    std::optional<ProbeSun> sun;
};

// A bad input is reported and skipped; any other failure ends the batch.
std::optional<Loaded> loadItem(Batch& batch, const BatchItem& item) {
    try {
        Loaded loaded{&item, loadInput(batch.options, item.input), std::nullopt};
        loaded.sun = takeOutSun(batch.options, loaded.environment);
        return loaded;
    } catch (const Error& error) {
        if (error.kind() != ErrorKind::Input) throw;
        reportFailure(batch, item, error);
        return std::nullopt;
    }
}

void writeItem(Batch& batch, const Loaded& loaded, const BakeResult& result) {
    const BakeOptions& options = batch.options;
    if (!result.failure.empty()) {
        reportFailure(batch, *loaded.item, Error(ErrorKind::Input, result.failure));
        return;
    }
    const ShCoefficients& written = options.irradiance ? result.irradiance : result.radiance;
    try {
        writeOutput(options, loaded.item->output, written,
                    metadataFor(options, loaded.environment, result, loaded.sun));
    } catch (const Error& error) {
        if (error.kind() != ErrorKind::Output) throw;
        reportFailure(batch, *loaded.item, error);
        return;
    }
    ++batch.baked;
    ++batch.progress.done;
    batch.texels += loaded.environment.cubemap.texels.size();
    if (options.quiet) {
        batch.progress.draw();
        return;
    }
    int n = loaded.environment.cubemap.faceSize;
    std::string line = "  " + loaded.environment.description + " -> " + loaded.item->output + ", 6 x " +
                       std::to_string(n) + " x " + std::to_string(n) + " texels";
    if (loaded.environment.replacedTexels > 0)
        line += ", " + std::to_string(loaded.environment.replacedTexels) + " NaN/Inf texels replaced with 0";
    if (options.extractSun) line += loaded.sun ? ", sun taken out" : ", no sun found";
    printLine(batch, stdout, line);
}

// Loads the inputs in order and bakes them in chunks of at most chunkBytes texel bytes (a larger
// cube map alone), one bakeChunk call each, writing each chunk's outputs before loading further:
// at most one chunk and the cube map that opens the next are in memory.
template <typename BakeChunk>
void bakeInChunks(Batch& batch, const std::vector<BatchItem>& items, VkDeviceSize chunkBytes,
                  BakeChunk&& bakeChunk) {
    std::vector<Loaded> chunk;
    VkDeviceSize bytes = 0;
    auto flush = [&] {
        if (chunk.empty()) return;
        std::vector<const Cubemap*> cubemaps;
        for (const Loaded& loaded : chunk)
            cubemaps.push_back(&loaded.environment.cubemap);
        std::vector<BakeResult> results = bakeChunk(std::span<const Cubemap* const>(cubemaps));
        ++batch.submissions;
        for (size_t i = 0; i < chunk.size(); ++i)
            writeItem(batch, chunk[i], results[i]);
        chunk.clear();
        bytes = 0;
    };
    batch.progress.draw();
    for (const BatchItem& item : items) {
        std::optional<Loaded> loaded = loadItem(batch, item);
        if (!loaded) continue;
        VkDeviceSize itemBytes = texelBytes(loaded->environment.cubemap);
        if (!chunk.empty() && bytes + itemBytes > chunkBytes) flush();
        bytes += itemBytes;
        chunk.push_back(std::move(*loaded));
    }
    flush();
}

std::string texelCount(uint64_t texels) {
    char text[32];
    if (texels >= 1000000)
        std::snprintf(text, sizeof(text), "%.1fM", double(texels) / 1e6);
    else
        std::snprintf(text, sizeof(text), "%llu", static_cast<unsigned long long>(texels));
    return text;
}

void printBatchStart(const BakeOptions& options, size_t count, const std::string& device) {
    std::printf("shprobe bake: %zu inputs -> %s (%s: %s, order %d, %s)\n", count, options.outDir.c_str(),
                options.backend.c_str(), device.c_str(), options.order, options.format.c_str());
    std::fflush(stdout);
}

// The summary line; then, if an input failed, the error that gives the exit code.
void finishBatch(Batch& batch, size_t count, double seconds) {
    batch.progress.clear();
    batch.progress.enabled = false;
    std::string submissions = batch.options.backend == "gpu"
                                  ? " in " + std::to_string(batch.submissions) +
                                        (batch.submissions == 1 ? " GPU submission" : " GPU submissions")
                                  : std::string();
    std::printf("shprobe bake: %zu %s baked, %zu failed; %s texels%s; %.2f s, %.1f probes/s\n", batch.baked,
                batch.baked == 1 ? "probe" : "probes", batch.failed, texelCount(batch.texels).c_str(),
                submissions.c_str(), seconds, seconds > 0.0 ? double(batch.baked) / seconds : 0.0);
    std::fflush(stdout);
    if (batch.failed == 0) return;
    std::string written = batch.baked == 0   ? "nothing was written"
                          : batch.baked == 1 ? "the other probe was written to " + batch.options.outDir
                                             : "the other " + std::to_string(batch.baked) +
                                                   " probes were written to " + batch.options.outDir;
    throw Error(batch.inputFailed ? ErrorKind::Input : ErrorKind::Output,
                std::to_string(batch.failed) + " of " + std::to_string(count) + " inputs failed (above); " +
                    written);
}

void runBatchBake(const BakeOptions& options) {
    std::vector<BatchItem> items = planBatch(options);
    prepareOutputFolder(options.outDir, items);

    Clock::time_point start = Clock::now();
    Batch batch{options, ProgressBar{items.size()}};
    if (options.backend == "gpu") {
        withGpu(options, [&](const Context& context, const Projector& projector) {
            printBatchStart(options, items.size(), context.info.name);
            VkDeviceSize chunkBytes = batchTexelBytes(context);
            if (options.batchBytes > 0) chunkBytes = std::min<VkDeviceSize>(chunkBytes, options.batchBytes);
            bakeInChunks(batch, items, chunkBytes, [&](std::span<const Cubemap* const> cubemaps) {
                DeviceStep step("baking a chunk of " + std::to_string(cubemaps.size()) + " probes");
                return bakeOnGpu(options, context, projector, cubemaps);
            });
        });
    } else {
        printBatchStart(options, items.size(), cpuBackendName(options));
        bakeInChunks(batch, items, 0, [&](std::span<const Cubemap* const> cubemaps) {
            return std::vector<BakeResult>{bakeOnCpu(options, *cubemaps[0])}; // chunks of one
        });
    }
    finishBatch(batch, items.size(), millisecondsSince(start) / 1000.0);
}

} // namespace

void addBakeCommand(CLI::App& app, BakeOptions& options) {
    CLI::App* command = app.add_subcommand("bake", "Project environments onto SH and write the coefficients");
    command->add_option(
        "input", options.inputs,
        "Environment: an equirect (2:1) or cross (4:3, 3:4) image, a folder holding px nx py ny "
        "pz nz images, or a pattern with {face}; default: the built-in sky. Several inputs "
        "are a batch and need --out-dir");
    CLI::Option* output = command->add_option("-o,--output", options.output, "Output file of a single input")
                              ->capture_default_str();
    command
        ->add_option("--out-dir", options.outDir,
                     "Batch: write each input's probe into this folder, named after the input (its stem and "
                     "the format's extension: sky.exr -> DIR/sky.json); the folder is created if its parent "
                     "exists. Bad inputs are reported and skipped, the others written (exit code 2)")
        ->type_name("DIR")
        ->excludes(output);
    command
        ->add_option("--list", options.listFile,
                     "Batch: more inputs from this file, one path a line (blank lines and # comments "
                     "ignored); needs --out-dir")
        ->type_name("FILE");
    command
        ->add_option("--batch-bytes", options.batchBytes,
                     "Batch: most texel bytes (6 x N^2 x 16 per cube map) one GPU submission bakes; default "
                     "and upper bound: the device's limit")
        ->type_name("N")
        ->check(CLI::PositiveNumber);
    command->add_option("--order", options.order, "SH order = number of bands (3: 9 coefficients)")
        ->check(CLI::Range(1, kMaxOrder))
        ->capture_default_str();
    command->add_option("--layout", options.layout, "Input layout")
        ->check(CLI::IsMember({"auto", "equirect", "hcross", "vcross", "faces"}))
        ->capture_default_str();
    command->add_option("--face-size", options.faceSize, "Cube-map face size (default: from the input)")
        ->check(CLI::Range(1, kMaxGpuFaceSize));
    command
        ->add_option("--backend", options.backend,
                     "gpu (Vulkan compute), cpu (float, all cores) or reference (the double-precision reference)")
        ->check(CLI::IsMember({"gpu", "cpu", "reference"}))
        ->capture_default_str();
    command->add_flag("--irradiance", options.irradiance, "Write irradiance E_lm = A_l L_lm instead of radiance");
    command->add_flag("--sanitize", options.sanitize, "Replace NaN and infinite texels with 0 instead of failing");
    addImageLimitOption(*command, options.maxPixels);
    addDeviceOptions(*command, options.device, options.validation);
    command->add_option("--workgroup-size", options.workgroupSize, "GPU projection workgroup width")
        ->check(CLI::Range(1, 1024))
        ->capture_default_str();
    command->add_option("--texels-per-invocation", options.texelsPerInvocation,
                        "GPU projection texels per invocation (sets the workgroup count)")
        ->check(CLI::Range(1, 1 << 20))
        ->capture_default_str();
    command->add_flag("-q,--quiet", options.quiet,
                      "Print the summary only, not the coefficients (batch: not the line per probe)");
    command
        ->add_option("--format", options.format,
                     "json (CONVENTIONS' coefficient file), binary (packed float32, see README), glsl or cpp "
                     "(a GLSL or C/C++ header of coefficients folded for sh_irradiance.glsl: radiance for "
                     "shRadiance, with --irradiance for shIrradianceOverPi; orders 1-5), or the irradiance "
                     "drawn as an EXR map: irradiance-equirect, irradiance-cross")
        ->check(CLI::IsMember({"json", "binary", "glsl", "cpp", "irradiance-equirect", "irradiance-cross"}))
        ->capture_default_str();
    command->add_option("--map-size", options.mapSize,
                        "Irradiance maps: equirect width (even; default 512) or cross face size (default 128)")
        ->check(CLI::Range(1, 16384));
    command->add_flag("--extract-sun", options.extractSun,
                      "Take the sun (the brightest compact region) out of the environment and write it beside the "
                      "probe of the rest, as \"sun\" (direction, radiance, angular radius)");
    addLightOptions(*command, options.lights);
    addWindowOption(*command, options.window);
}

void runBake(const BakeOptions& options) {
    checkFormatOptions(options);
    if (!options.outDir.empty()) return runBatchBake(options);
    if (options.inputs.size() > 1 || !options.listFile.empty())
        throw Error(ErrorKind::Input,
                    std::string(options.listFile.empty() ? "several inputs need" : "--list needs") +
                        " --out-dir DIR (one output per input); -o names the output of a "
                        "single input");
    runSingleBake(options);
}

} // namespace shprobe
