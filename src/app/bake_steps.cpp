#include "app/bake_steps.h"

#include "app/toolkit.h"
#include "shprobe/io/engine_export.h"
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

const ExportFormat& formatNamed(const std::string& name) {
    const ExportFormat* format = findExportFormat(name);
    if (!format) throw Error(ErrorKind::Input, "--format " + name + " is not one of " + exportFormatNames());
    return *format;
}

// The format an output name's extension names; empty when it names none (".txt", "/dev/null").
std::string formatOfExtension(const std::string& path) {
    const ExportFormat* format = formatOfOutputName(path);
    return format ? format->name : "";
}

// The extension names no format, the format itself, the other irradiance map, or the last part of
// the format's extension (-o x.json --format threejs: ".three.json" ends in ".json").
bool extensionAgrees(const std::string& output, const std::string& named, const std::string& format) {
    const std::string extension = std::filesystem::path(output).extension().string();
    return named.empty() || named == format ||
           (named == "irradiance-equirect" && format == "irradiance-cross") ||
           (!extension.empty() && std::string_view(formatNamed(format).extension).ends_with(extension));
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

std::vector<BakeResult> bakeOnGpu(const BakeOptions& options, const Context& context, const ProbeBaker& baker,
                                  std::span<const Cubemap* const> cubemaps) {
    std::vector<BakeResult> results;
    for (GpuBake& bake : bakeCubemaps(context, baker, cubemaps)) {
        BakeResult result{bake.radiance, bake.irradiance, context.info.name, bake.deviceMilliseconds};
        if (needsFinishing(options) && isFinite(bake)) {
            Finished finished = finish(options, bake.radiance);
            GpuBake convolved = convolveOnGpu(context, baker, finished.radiance, finished.window);
            result.radiance = convolved.radiance;
            result.irradiance = convolved.irradiance;
        }
        results.push_back(std::move(result));
    }
    return results;
}

void requireUsable(const BakeOptions& options, const BakeResult& result, const std::string& input) {
    if (options.backend == "gpu") requireFinite(GpuBake{result.radiance, result.irradiance}, input);
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
    return formatNamed(format).extension;
}

void settleFormatAndOutput(std::string& format, std::string& output) {
    const std::string named = output.empty() ? "" : formatOfExtension(output);
    if (format.empty()) format = named.empty() ? "json" : named;
    if (!extensionAgrees(output, named, format))
        throw Error(ErrorKind::Input, "-o " + output + " names a " + named + " file but --format is " +
                                          format + "; use the extension " + formatExtension(format) +
                                          " or leave out --format");
    if (output.empty()) output = std::string("probe") + formatExtension(format);
}

BakeOptions withFormatAndOutput(BakeOptions options) {
    settleFormatAndOutput(options.format, options.output);
    return options;
}

OutputContent formatContent(const std::string& format) {
    return formatNamed(format).content;
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
                        " holds the coefficients only and would drop the sun; use --format json");
    if (options.format == "irradiance-equirect" && options.mapSize % 2 != 0)
        throw Error(ErrorKind::Input, "--map-size: an equirect map's width must be even");
}

void writeOutput(const BakeOptions& options, const std::string& path, const ShCoefficients& probe,
                 const ProbeMetadata& metadata) {
    ExportOptions exportOptions{.metadata = metadata, .mapSize = options.mapSize, .mirror = options.mirror};
    formatNamed(options.format).write(path, probe, exportOptions);
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
