// `shprobe bake`: environments in, SH radiance or irradiance coefficients out, on the GPU, the fast
// CPU path or the double-precision CPU reference (bake_steps.h). One input is written to -o;
// several (or a --list) are a batch written to --out-dir (bake_batch.cpp).
#include "app/bake_steps.h"
#include "app/parsed_option.h"
#include "app/program.h"
#include "app/progress_line.h"
#include "app/stopwatch.h"
#include "app/toolkit.h"
#include "common/counted.h"
#include "common/output_file.h"
#include "formats/engine_export.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <cmath>
#include <cstdio>
#include <future>
#include <string>
#include <system_error>

namespace shprobe {

namespace {

void printSun(FILE* report, const std::optional<ProbeSun>& sun) {
    if (!sun) {
        std::fprintf(
            report,
            "  sun      no sun found (no compact light dominates the environment; see --extract-sun)\n");
        return;
    }
    std::fprintf(report,
                 "  sun      direction (%.4f, %.4f, %.4f), radius %.3f deg, radiance (%.4g, %.4g, %.4g): "
                 "written as \"sun\", not in the coefficients\n",
                 sun->direction.x, sun->direction.y, sun->direction.z, sun->angularRadius * 180.0 / M_PI,
                 sun->radiance.r, sun->radiance.g, sun->radiance.b);
}

void printCoefficients(FILE* report, const ShCoefficients& coefficients) {
    std::fprintf(report, "%s coefficients (r g b):\n", quantityName(coefficients.quantity));
    for (int i = 0; i < int(coefficients.rgb.size()); ++i) {
        int l = shBand(i);
        const glm::dvec3& c = coefficients.rgb[i];
        std::fprintf(report, "  l=%d m=%+d  %14.6f %14.6f %14.6f\n", l, i - l * (l + 1), c.r, c.g, c.b);
    }
}

void printSummary(FILE* report, const BakeOptions& options, const Environment& environment,
                  const Backend& backend, const BakeResult& result, double loadMs, double bakeMs) {
    std::fprintf(report, "shprobe bake: %s -> %s\n", environment.description.c_str(), options.output.c_str());
    std::fprintf(report, "%s\n", backendLine(backend, result.device).c_str());
    std::fprintf(report, "  input    %s%s, order %d (%s)\n", inputSize(environment).c_str(),
                 environment.keptEquirect() ? " projected directly"
                 : environment.keptCross()  ? " projected where they lie in the cross"
                                            : "",
                 options.order, counted(coefficientCount(options.order), "coefficient").c_str());
    if (environment.replacedTexels > 0)
        std::fprintf(report, "  sanitize replaced %s with 0\n",
                     counted(environment.replacedTexels, "NaN/Inf texel").c_str());
    if (hasLights(options.lights)) std::fprintf(report, "  lights   added to the environment's radiance\n");
    if (!options.window.none()) std::fprintf(report, "  window   %s\n", options.window.text.c_str());
    std::fprintf(report, "  time     load %.1f ms, bake %.1f ms", loadMs, bakeMs);
    if (result.deviceMilliseconds > 0.0) std::fprintf(report, " (GPU %.1f ms)", result.deviceMilliseconds);
    std::fprintf(report, "\n");
}

const char* uploadRouteText(UploadRoute route) {
    switch (route) {
    case UploadRoute::InPlace:
        return "texels read in place, no copy";
    case UploadRoute::Packed:
        return "texels packed into the image's own memory, no copy";
    case UploadRoute::Staged:
        return "texels copied through staging slots, the last with the dispatch";
    }
    return "";
}

// --timings: the phases of a GPU bake, one a line. The instance and the device start beside the
// load; the pipelines are created in the bake; "dispatch" is the submission's wall time (copies,
// the bake's dispatches; llvmpipe compiles each shader at its first dispatch), of which the device's
// timestamps time the dispatches.
std::string gpuTimings(const GpuSession& session, const BakeResult& result) {
    const Context& context = session.context();
    const bool cached = session.loadedCacheBytes() > sizeof(VkPipelineCacheHeaderVersionOne);
    const GpuBake& phases = result.phases;
    char text[1024];
    std::snprintf(text, sizeof(text),
                  "  timing   instance %10.1f ms\n"
                  "  timing   device   %10.1f ms\n"
                  "  timing   pipelines %9.1f ms (%s)\n"
                  "  timing   upload   %10.1f ms (%s)\n"
                  "  timing   dispatch %10.1f ms (device %.1f ms)\n"
                  "  timing   readback %10.1f ms\n",
                  context.instanceMilliseconds, context.deviceMilliseconds, session.pipelineMilliseconds(),
                  cached ? "from the pipeline cache" : "cold: the pipeline cache held none",
                  phases.uploadMilliseconds, uploadRouteText(phases.route), phases.submitMilliseconds,
                  result.deviceMilliseconds, phases.readbackMilliseconds);
    return text;
}

// Before any work: a failed write must not waste a bake, nor may the output be an input.
void checkSingleOutput(const BakeOptions& options) {
    checkOutputPath(options.output, formatContent(options.format));
    if (!options.inputs.empty())
        checkOutputsAreNotInputs({&options.output, 1}, filesReadBy(options.inputs[0]));
}

void runSingleBake(const BakeOptions& options) {
    checkSingleOutput(options);

    // Vulkan asked for: the device starts while the input decodes (vkCreateInstance alone takes tens
    // of milliseconds); a failed load is reported once that start is over. auto waits for the
    // input, whose size it chooses by. Where no thread can be started, the device starts after.
    std::future<std::unique_ptr<GpuSession>> starting;
    if (requestsVulkan(options)) {
        try {
            starting = std::async(std::launch::async, [&] { return std::make_unique<GpuSession>(options); });
        } catch (const std::system_error&) { // no thread: chooseBackend starts it after the load
        }
    }

    CountedProgress progress(options.quiet);
    Clock::time_point start = Clock::now();
    Environment environment =
        loadInput(options, options.inputs.empty() ? std::string() : options.inputs[0], progress.counter());
    std::optional<ProbeSun> sun = takeOutSun(options, environment);
    double loadMs = millisecondsSince(start);

    start = Clock::now();
    Backend backend = starting.valid() ? gpuBackend(starting.get())
                                       : chooseBackend(options, projectionWork(options, environment));
    fitBackend(backend, environment);
    const Environment* environments[] = {&environment};
    BakeResult result = bake(options, backend, environments, progress.counter())[0];
    const std::string timings =
        options.timings && backend.session ? gpuTimings(*backend.session, result) : "";
    if (backend.session) backend.session->finish();
    double bakeMs = millisecondsSince(start);
    progress.stop();
    requireUsable(backend, result, options.irradiance, environment.description);

    const ShCoefficients& written = options.irradiance ? result.irradiance : result.radiance;
    writeOutput(options, options.output, written, metadataFor(backend, options, environment, result, sun),
                environment);

    // With the probe on standard output, the report goes to stderr.
    FILE* report = reportStream(options.output);
    printSummary(report, options, environment, backend, result, loadMs, bakeMs);
    std::fputs(timings.c_str(), report);
    if (options.extractSun) printSun(report, sun);
    if (!options.quiet) printCoefficients(report, written);
}

} // namespace

void addBakeOptions(CLI::App& command, BakeOptions& options) {
    command
        .add_option("input", options.inputs,
                    "Environment: an equirect (2:1) or cross (4:3, 3:4) image, a folder holding px nx py ny "
                    "pz nz images, or a pattern with {face}; default: the built-in sky. Several inputs "
                    "are a batch and need --out-dir")
        ->check(nonEmptyName());
    CLI::Option* output =
        command
            .add_option(
                "-o,--output", options.output,
                "Output file of a single input (default: probe and the format's extension, probe.json); "
                "- writes to standard output. A link is followed and its target replaced; a device or "
                "FIFO is written through")
            ->check(nonEmptyName());
    command
        .add_option("--out-dir", options.outDir,
                    "Batch: write each input's probe into this folder, named after the input (its stem and "
                    "the format's extension: sky.exr -> DIR/sky.json); the folder is created if its parent "
                    "exists. Bad inputs are reported and skipped, the others written (exit code 2)")
        ->type_name("DIR")
        ->check(nonEmptyName())
        ->excludes(output);
    command
        .add_option("--list", options.listFile,
                    "Batch: more inputs from this file, one path a line (blank lines and # comments "
                    "ignored); needs --out-dir")
        ->type_name("FILE")
        ->check(nonEmptyName());
    command
        .add_option(
            "--batch-bytes", options.batchBytes,
            "Batch: most texel bytes (16 a texel: 6 x N^2 x 16 per cube map, W x H x 16 per equirect) "
            "one GPU submission bakes; default and upper bound: the device's limit")
        ->type_name("N")
        ->transform(wholeNumberFrom(1, INT64_MAX));
    addRangeOption(command, "--order", options.order, "SH order = number of bands (3: 9 coefficients)", 1,
                   kMaxOrder);
    command.add_option("--layout", options.layout, "Input layout")
        ->check(CLI::IsMember({"auto", "equirect", "hcross", "vcross", "faces"}))
        ->capture_default_str();
    command
        .add_option("--face-size", options.faceSize,
                    "Cube-map face size: crosses and face files are resized to it, equirect inputs resampled "
                    "to a cube map of it (default: the cross's or the faces' own size; equirect inputs are "
                    "projected directly, each pixel weighted by its solid angle)")
        ->transform(wholeNumberFrom(1, kMaxGpuFaceSize));
    command
        .add_option(
            "--backend", options.backend,
            "auto (the default: the fast CPU path for a job done sooner than Vulkan starts, or where the "
            "only Vulkan device is a CPU, such as lavapipe, as on a machine without a GPU device file in "
            "/dev; else Vulkan; --device and --validation ask for Vulkan), gpu "
            "(Vulkan compute), cpu (float, all cores) or reference (the double-precision reference)")
        ->check(CLI::IsMember({"auto", "gpu", "cpu", "reference"}))
        ->capture_default_str();
    command.add_flag("--irradiance", options.irradiance,
                     "Write irradiance E_lm = A_l L_lm instead of radiance");
    command.add_flag("--sanitize", options.sanitize,
                     "Replace NaN and infinite texels with 0 instead of failing");
    addImageLimitOption(command, options.maxPixels);
    addDeviceOptions(command, options.device, options.validation);
    addRangeOption(command, "--workgroup-size", options.workgroupSize, "GPU projection workgroup width", 1,
                   1024);
    addRangeOption(command, "--texels-per-invocation", options.texelsPerInvocation,
                   "GPU projection texels per invocation (sets the workgroup count)", 1, 1 << 20);
    command.add_flag("--timings", options.timings,
                     "GPU bake of one input: print the time of each phase (instance, device, pipelines, "
                     "upload, dispatch, readback)");
    command.add_flag("-q,--quiet", options.quiet,
                     "Print the summary only, not the coefficients (batch: not the line per probe)");
    addFormatOptions(command, options.format, options.mapSize, options.mirror);
    command.add_flag(
        "--extract-sun", options.extractSun,
        "Take the sun out of the environment and write it beside the probe of the rest, as \"sun\" "
        "(direction, radiance, angular radius). Only a compact light that clearly dominates is a sun: "
        "the texels brighter than 20 times the median and 1/1000 of the brightest, connected to the "
        "brightest, must lie within 5 degrees of their centre, hold at least 80% of the light of all "
        "such texels and 1% of the whole map's, and peak at least 1000 times the median; otherwise "
        "\"no sun found\" and the environment stays whole");
    addLightOptions(command, options.lights);
    addWindowOption(command, options.window);
}

void addFormatOptions(CLI::App& command, std::string& format, int& mapSize, std::optional<bool>& mirror) {
    std::vector<std::string> names;
    std::string help = "Output format (docs/exports.md):";
    for (const ExportFormat& each : exportFormats()) {
        names.push_back(each.name);
        help += std::string(" ") + each.name + " (" + each.what + ", " + each.extension + ");";
    }
    help += " default: from -o's extension, else json. The engine formats hold bands 0..2. gltf's "
            "specularImages are GGX-prefiltered mips (roughness 0 to 1) of the environment's radiance "
            "(bake; --directional is refused, --sphere draws a light) or of the probe's own radiance "
            "from its coefficients (convert)";
    command.add_option("--format", format, help)->check(CLI::IsMember(names));
    command
        .add_option("--map-size", mapSize,
                    "Irradiance maps: equirect width (even; default 512) or cross face size (default 128); "
                    "gltf: specularImageSize, mip 0's face size (a power of two from 32 to 512; default "
                    "128)")
        ->transform(wholeNumberFrom(1, 16384));
    // CLI11 would read any number, yes and no as a bool: on and off alone are taken.
    addParsedOption(
        command, "--mirror", mirror,
        [](const std::string& value) {
            if (value != "on" && value != "off")
                throw Error(ErrorKind::Input, "--mirror: " + value + " is not on or off");
            return value == "on";
        },
        "filament: on (default) matches cmgen's default mirroring of the cube map (x -> -x), off matches "
        "cmgen --no-mirror")
        ->type_name("on|off");
}

void requireFormatOptionsUsed(const std::string& format, int mapSize, const std::optional<bool>& mirror) {
    if (mapSize != 0 && format != "irradiance-equirect" && format != "irradiance-cross" && format != "gltf")
        throw Error(ErrorKind::Input, "--map-size sizes the maps of --format irradiance-equirect, "
                                      "irradiance-cross and gltf; --format " +
                                          format + " has none");
    if (mirror && format != "filament")
        throw Error(ErrorKind::Input, "--mirror is for --format filament, not " + format);
}

void runBake(const BakeOptions& given) {
    const BakeOptions options = withFormatAndOutput(given);
    checkFormatOptions(options);
    requireDeviceUsed(options.backend, options.device, options.validation);
    if (!options.outDir.empty()) return runBatchBake(options);
    if (options.inputs.size() > 1 || !options.listFile.empty())
        throw Error(ErrorKind::Input,
                    std::string(options.listFile.empty() ? "several inputs need" : "--list needs") +
                        " --out-dir DIR (one output per input); -o names the output of a "
                        "single input");
    runSingleBake(options);
}

} // namespace shprobe
