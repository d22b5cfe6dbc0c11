#include "app/bake_steps.h"

#include "app/toolkit.h"
#include "shprobe/io/probe_export.h"
#include "shprobe/sh/fast_projection.h"
#include "shprobe/sh/folding.h"
#include "shprobe/sh/irradiance.h"
#include "shprobe/sh/lights.h"
#include "shprobe/sh/projection.h"
#include "shprobe/sh/windowing.h"

#include <cctype>
#include <filesystem>

namespace shprobe {

namespace {

constexpr int kDefaultSkyFaceSize = 256;

// The steps after the projection, the same on either backend: add the analytic lights, then choose
// the window (de-ringing looks at the radiance with the lights in it).
struct Finished {
    ShCoefficients radiance;
    std::vector<double> window; // empty: none
};

bool needsFinishing(const BakeOptions& options) {
    return hasLights(options.lights) || options.window != "none";
}

Finished finish(const BakeOptions& options, ShCoefficients radiance) {
    addLights(radiance, options.lights);
    std::optional<std::vector<double>> window = windowFactorsFor(options.window, radiance);
    return {std::move(radiance), window.value_or(std::vector<double>{})};
}

bool isHeaderFormat(const std::string& format) {
    return format == "glsl" || format == "cpp";
}

// The format an output name's extension names; empty when it names none (".txt", "/dev/null").
std::string formatOfExtension(const std::string& path) {
    std::string extension = std::filesystem::path(path).extension().string();
    for (char& c : extension)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    if (extension == ".json") return "json";
    if (extension == ".bin") return "binary";
    if (extension == ".glsl") return "glsl";
    if (extension == ".h" || extension == ".hpp") return "cpp";
    if (extension == ".exr") return "irradiance-equirect";
    return "";
}

bool extensionAgrees(const std::string& named, const std::string& format) {
    return named.empty() || named == format ||
           (named == "irradiance-equirect" && format == "irradiance-cross");
}

} // namespace

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

VkDeviceSize cubemapBytes(const Cubemap& cubemap) {
    return VkDeviceSize(cubemap.texels.size()) * sizeof(glm::vec4);
}

std::vector<BakeResult> bakeOnGpu(const BakeOptions& options, const Context& context,
                                  const Projector& projector, std::span<const Cubemap* const> cubemaps) {
    std::vector<GpuBake> bakes;
    if (cubemaps.size() == 1 && cubemapBytes(*cubemaps[0]) > batchTexelBytes(context))
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

const char* cpuBackendName(const BakeOptions& options) {
    return options.backend == "reference" ? "cpu reference (double)" : "cpu (float, all cores)";
}

BakeResult bakeOnCpu(const BakeOptions& options, const Cubemap& cubemap) {
    ShCoefficients radiance = options.backend == "reference" ? projectCubemap(cubemap, options.order)
                                                             : projectCubemapFast(cubemap, options.order);
    Finished finished = finish(options, radiance);
    BakeResult result;
    result.radiance =
        finished.window.empty() ? finished.radiance : applyWindow(finished.radiance, finished.window);
    result.irradiance = convolveIrradiance(result.radiance);
    result.device = cpuBackendName(options);
    return result;
}

std::optional<ProbeSun> takeOutSun(const BakeOptions& options, Environment& environment) {
    if (!options.extractSun) return std::nullopt;
    SunExtraction sun = extractSun(environment.cubemap);
    if (!sun.found) return std::nullopt;
    SphericalLight light = sunAsSphericalLight(sun);
    return ProbeSun{light.direction, light.radiance, light.angularRadius};
}

const char* formatExtension(const std::string& format) {
    if (format == "json") return ".json";
    if (format == "binary") return ".bin";
    if (format == "glsl") return ".glsl";
    if (format == "cpp") return ".h";
    return ".exr"; // irradiance-equirect, irradiance-cross
}

BakeOptions withFormatAndOutput(BakeOptions options) {
    const std::string named = options.output.empty() ? "" : formatOfExtension(options.output);
    if (options.format.empty()) options.format = named.empty() ? "json" : named;
    if (!extensionAgrees(named, options.format))
        throw Error(ErrorKind::Input, "-o " + options.output + " names a " + named +
                                          " file but --format is " + options.format + "; use the extension " +
                                          formatExtension(options.format) + " or leave out --format");
    if (options.output.empty()) options.output = std::string("probe") + formatExtension(options.format);
    return options;
}

OutputContent formatContent(const std::string& format) {
    return format == "json" || isHeaderFormat(format) ? OutputContent::Text : OutputContent::Binary;
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

} // namespace shprobe
