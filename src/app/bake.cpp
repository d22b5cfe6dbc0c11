// `shprobe bake`: environment in, SH radiance or irradiance coefficients out (JSON), on the GPU
// or with the double-precision CPU reference.
#include "app/commands.h"
#include "app/toolkit.h"
#include "gpu/projector.h"
#include "image/environment.h"
#include "io/atomic_file.h"
#include "io/probe_export.h"
#include "io/probe_file.h"
#include "sh/basis.h"
#include "sh/error.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/projection.h"
#include "sh/windowing.h"
#include "vk/context.h"

#include <chrono>
#include <cstdio>

namespace shprobe {

namespace {

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
};

Environment loadInput(const BakeOptions& options) {
    if (!options.input.empty()) {
        LoadOptions load;
        load.layout = parseLayout(options.layout);
        load.faceSize = options.faceSize;
        load.nonFinite = options.sanitize ? NonFinitePolicy::Replace : NonFinitePolicy::Refuse;
        return loadEnvironment(options.input, load);
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

BakeResult bakeWithContext(const BakeOptions& options, const Context& context, const Cubemap& cubemap) {
    Projector projector = createProjector(context, {options.order, options.workgroupSize, options.texelsPerInvocation});
    BakeResult result;
    try {
        GpuBake bake = bakeCubemap(context, projector, cubemap);
        double deviceMs = bake.deviceMilliseconds;
        if (needsFinishing(options)) {
            Finished finished = finish(options, bake.radiance);
            bake = convolveOnGpu(context, projector, finished.radiance, finished.window); // convolve.comp
        }
        result = {bake.radiance, bake.irradiance, context.info.name, deviceMs};
    } catch (...) {
        destroyProjector(context, projector);
        throw;
    }
    destroyProjector(context, projector);
    return result;
}

BakeResult bakeOnGpu(const BakeOptions& options, const Cubemap& cubemap) {
    ContextOptions contextOptions;
    contextOptions.device = options.device;
    contextOptions.validation = options.validation;
    Context context = createContext(contextOptions);
    BakeResult result;
    try {
        result = bakeWithContext(options, context, cubemap);
    } catch (...) {
        destroyContext(context);
        throw;
    }
    uint32_t validationMessages = context.validationMessages();
    destroyContext(context);
    if (validationMessages > 0)
        throw Error(ErrorKind::Device, std::to_string(validationMessages) + " Vulkan validation messages (above)");
    return result;
}

BakeResult bakeOnCpu(const BakeOptions& options, const Cubemap& cubemap) {
    Finished finished = finish(options, projectCubemap(cubemap, options.order));
    BakeResult result;
    result.radiance = finished.window.empty() ? finished.radiance : applyWindow(finished.radiance, finished.window);
    result.irradiance = convolveIrradiance(result.radiance);
    result.device = "cpu reference (double)";
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

// Writes the probe in the chosen format (probe_file.h, probe_export.h); every writer is atomic.
void writeOutput(const BakeOptions& options, const ShCoefficients& probe, const ProbeMetadata& metadata) {
    if (options.format == "json") return writeProbeFile(options.output, probe, metadata);
    if (options.format == "binary") return writeBinaryProbes(options.output, std::span(&probe, 1));
    if (options.format == "irradiance-equirect")
        return writeIrradianceEquirect(options.output, probe, options.mapSize > 0 ? options.mapSize : 512);
    writeIrradianceCross(options.output, probe, options.mapSize > 0 ? options.mapSize : 128);
}

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

} // namespace

void addBakeCommand(CLI::App& app, BakeOptions& options) {
    CLI::App* command = app.add_subcommand("bake", "Project an environment onto SH and write the coefficients");
    command->add_option("input", options.input,
                        "Environment: an equirect (2:1) or cross (4:3, 3:4) image, a folder holding px nx py ny "
                        "pz nz images, or a pattern with {face}; default: the built-in sky");
    command->add_option("-o,--output", options.output, "Coefficient file (JSON)")->capture_default_str();
    command->add_option("--order", options.order, "SH order = number of bands (3: 9 coefficients)")
        ->check(CLI::Range(1, kMaxOrder))
        ->capture_default_str();
    command->add_option("--layout", options.layout, "Input layout")
        ->check(CLI::IsMember({"auto", "equirect", "hcross", "vcross", "faces"}))
        ->capture_default_str();
    command->add_option("--face-size", options.faceSize, "Cube-map face size (default: from the input)")
        ->check(CLI::Range(1, kMaxGpuFaceSize));
    command->add_option("--backend", options.backend, "gpu (Vulkan compute) or cpu (double reference)")
        ->check(CLI::IsMember({"gpu", "cpu"}))
        ->capture_default_str();
    command->add_flag("--irradiance", options.irradiance, "Write irradiance E_lm = A_l L_lm instead of radiance");
    command->add_flag("--sanitize", options.sanitize, "Replace NaN and infinite texels with 0 instead of failing");
    addDeviceOptions(*command, options.device, options.validation);
    command->add_option("--workgroup-size", options.workgroupSize, "GPU projection workgroup width")
        ->check(CLI::Range(1, 1024))
        ->capture_default_str();
    command->add_option("--texels-per-invocation", options.texelsPerInvocation,
                        "GPU projection texels per invocation (sets the workgroup count)")
        ->check(CLI::Range(1, 1 << 20))
        ->capture_default_str();
    command->add_flag("-q,--quiet", options.quiet, "Print the summary only, not the coefficients");
    command->add_option("--format", options.format,
                        "json (CONVENTIONS' coefficient file), binary (packed float32, see README), or the "
                        "irradiance drawn as an EXR map: irradiance-equirect, irradiance-cross")
        ->check(CLI::IsMember({"json", "binary", "irradiance-equirect", "irradiance-cross"}))
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
    checkOutputPath(options.output); // before any work: a failed write must not waste a bake

    Clock::time_point start = Clock::now();
    Environment environment = loadInput(options);
    std::optional<ProbeSun> sun = takeOutSun(options, environment);
    double loadMs = millisecondsSince(start);

    start = Clock::now();
    BakeResult result = options.backend == "gpu" ? bakeOnGpu(options, environment.cubemap)
                                                 : bakeOnCpu(options, environment.cubemap);
    double bakeMs = millisecondsSince(start);

    const ShCoefficients& written = options.irradiance ? result.irradiance : result.radiance;
    ProbeMetadata metadata;
    metadata.source = environment.description;
    metadata.faceSize = environment.cubemap.faceSize;
    metadata.backend = options.backend;
    metadata.device = result.device;
    metadata.window = options.window == "none" ? "" : options.window;
    metadata.sun = sun;
    writeOutput(options, written, metadata);

    printSummary(options, environment, result, loadMs, bakeMs);
    if (options.extractSun) printSun(sun);
    if (!options.quiet) printCoefficients(written);
}

} // namespace shprobe
