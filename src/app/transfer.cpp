// `shprobe transfer`: per-vertex radiance transfer of a glTF scene (scene/transfer.h), its rays cast
// on all cores or on a Vulkan device (gpu/transfer_rays.h), written into the scene as vertex
// attributes or into the binary file (scene/transfer_gltf.h).
#include "app/commands.h"
#include "app/parsed_option.h"
#include "app/program.h"

#include "app/bake_steps.h"
#include "app/progress_line.h"
#include "app/stopwatch.h"
#include "common/counted.h"
#include "common/error.h"
#include "common/file_extension.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "gpu/transfer_rays.h"
#include "scene/gltf_scene.h"
#include "scene/transfer.h"
#include "scene/transfer_gltf.h"
#include "sh/basis.h"

#include <algorithm>
#include <cstdio>
#include <optional>

namespace shprobe {

namespace {

bool writesBinary(const TransferCommandOptions& options) {
    if (!options.format.empty()) return options.format == "binary";
    return hasExtension(options.output, ".shpt");
}

// The file -o names must be what is written: .shpt the transfer alone, .glb the scene (binary glTF;
// a .gltf name would tell readers to expect JSON).
void checkOutputName(const TransferCommandOptions& options) {
    const std::string& output = options.output;
    if (hasExtension(output, ".gltf"))
        throw Error(ErrorKind::Input,
                    "-o " + output +
                        " names a JSON glTF file, but transfer writes binary glTF (.glb) or "
                        "the transfer alone (.shpt)");
    const char* named = hasExtension(output, ".shpt")  ? "binary"
                        : hasExtension(output, ".glb") ? "glb"
                                                       : nullptr;
    const std::string name = output.substr(output.find_last_of('/') + 1);
    const size_t dot = name.find_last_of('.');
    if (!named && dot != std::string::npos && dot > 0) // a name without one: a device, or -
        throw Error(ErrorKind::Input,
                    "-o " + output +
                        " names neither a .glb nor a .shpt file; transfer writes binary glTF "
                        "(.glb) or the transfer alone (.shpt)");
    if (named && !options.format.empty() && options.format != named)
        throw Error(ErrorKind::Input, "-o " + output + " names a file of --format " + named +
                                          ", but --format is " + options.format + "; use the extension " +
                                          (options.format == "binary" ? ".shpt" : ".glb") +
                                          " or leave out --format");
}

// Every refusal the options and paths allow, before the scene is read.
void checkTransferOptions(const TransferCommandOptions& options) {
    const TransferModel model = parseTransferModel(options.model);
    if (options.bouncesGiven && model != TransferModel::Interreflected)
        throw Error(ErrorKind::Input,
                    "transfer: --bounces is for the interreflected model, not " + options.model);
    const char* forRays = options.raysGiven          ? "--rays"
                          : options.backend == "gpu" ? "--backend gpu"
                          : !options.device.empty()  ? "--device"
                          : options.validation       ? "--validation"
                                                     : nullptr;
    if (forRays && model == TransferModel::Unshadowed)
        throw Error(ErrorKind::Input,
                    std::string("transfer: ") + forRays +
                        " is for the models that cast rays; the unshadowed model casts none");
    requireDeviceUsed(options.backend, options.device, options.validation);
    checkOutputName(options);
    checkOutputPath(options.output, OutputContent::Binary);
    std::vector<std::string> inputs{options.scene};
    try {
        const std::vector<std::string> external = gltfExternalFiles(options.scene);
        inputs.insert(inputs.end(), external.begin(), external.end());
    } catch (const Error&) { // loadGltfSceneSource says why
    }
    checkOutputsAreNotInputs({&options.output, 1}, inputs);
}

// auto means gpu where the options ask for Vulkan (--device, --validation), cpu where no GPU can
// be (no device file) or the Vulkan device is a CPU (lavapipe: the cores cast the same rays
// faster than llvmpipe runs the shader, docs/benchmark.md), else gpu. Unshadowed transfer casts no
// rays: always cpu.
RayBackend chooseTransferBackend(const TransferCommandOptions& options) {
    if (options.backend == "cpu") return {"cpu", "", std::nullopt};
    if (options.model == "unshadowed") return {"cpu", "the unshadowed model casts no rays", std::nullopt};
    return chooseRayBackend(options.backend == "auto" && options.device.empty() && !options.validation, [&] {
        return createContext({.device = options.device, .validation = options.validation});
    });
}

void report(const TransferCommandOptions& options, const GltfSceneSource& source, const RayBackend& backend,
            const VertexTransfer& transfer, double seconds) {
    FILE* out = reportStream(options.output);
    const int channels = transferChannels(transfer);
    const std::string reason = backend.reason.empty() ? "" : " (" + backend.reason + ")";
    std::fprintf(out, "scene    %s\n", source.world.description.c_str());
    std::fprintf(out, "backend  %s: %s%s\n", backend.name.c_str(),
                 backend.context ? backend.context->info.name.c_str() : "all cores, rays by Embree",
                 reason.c_str());
    std::fprintf(
        out, "model    %s, order %d%s, %s\n", options.model.c_str(), options.order,
        options.model == "interreflected" ? (", " + counted(size_t(options.bounces), "bounce")).c_str() : "",
        channels == 3 ? "RGB" : "grey (one channel)");
    std::fprintf(out, "vertices %zu in %s\n", transfer.vertexCount(),
                 counted(source.primitives.size(), "primitive").c_str());
    if (transfer.rays > 0)
        std::fprintf(out, "rays     %d per vertex and bounce, %.3g in all, %.3g Mrays/s\n", transfer.rays,
                     double(transfer.raysCast), double(transfer.raysCast) / std::max(seconds, 1e-9) / 1e6);
    std::fprintf(out, "wrote    %s (%s) in %.2f s\n", options.output.c_str(),
                 writesBinary(options)
                     ? "binary"
                     : (counted(size_t(transferAttributeCount(options.order, channels)), "VEC4 attribute") +
                        " per vertex")
                           .c_str(),
                 seconds);
}

} // namespace

void addTransferOptions(CLI::App& command, TransferCommandOptions& options) {
    command.add_option("scene", options.scene, "glTF scene (.gltf or .glb)")
        ->required()
        ->check(nonEmptyName());
    command
        .add_option("-o,--output", options.output,
                    "The scene with the transfer as vertex attributes (.glb), or the binary file (.shpt)")
        ->required()
        ->check(nonEmptyName());
    command
        .add_option("--model", options.model,
                    "unshadowed: exact, no rays; shadowed: the sky each vertex sees; interreflected: "
                    "shadowed plus --bounces of the light the surfaces reflect")
        ->check(CLI::IsMember({"unshadowed", "shadowed", "interreflected"}))
        ->capture_default_str();
    addRangeOption(command, "--order", options.order, "SH order", 1, kMaxOrder);
    addRangeOption(command, "--rays", options.rays,
                   "Rays per vertex (and bounce), stratified, rounded up to a square", 1, kMaxTransferRays);
    addRangeOption(command, "--bounces", options.bounces, "interreflected: bounces off the surfaces", 0,
                   kMaxTransferBounces);
    command
        .add_option("--format", options.format,
                    "glb: the scene with the attributes; binary: the transfer alone (default: binary for a "
                    ".shpt output, else glb)")
        ->check(CLI::IsMember({"glb", "binary"}));
    command
        .add_option("--backend", options.backend,
                    "gpu: rays cast on the Vulkan device; cpu: on all cores; auto: cpu where no GPU is "
                    "(lavapipe), else gpu")
        ->check(CLI::IsMember({"auto", "gpu", "cpu"}))
        ->capture_default_str();
    addDeviceOptions(command, options.device, options.validation);
    command.add_flag("-q,--quiet", options.quiet, "No report");
}

void runTransfer(const TransferCommandOptions& options) {
    checkTransferOptions(options);
    const Clock::time_point start = Clock::now();
    const GltfSceneSource source = loadGltfSceneSource(options.scene);
    if (!writesBinary(options)) requireTransferGlbSource(source, options.scene);
    const TransferModel model = parseTransferModel(options.model);
    const TransferOptions transferOptions{.model = model,
                                          .order = options.order,
                                          .rays = options.rays,
                                          .bounces =
                                              model == TransferModel::Interreflected ? options.bounces : 0};
    RayBackend backend = chooseTransferBackend(options);
    ScopeExit release([&] {
        if (backend.context) destroyContext(*backend.context);
    });
    std::optional<ProgressLine> line; // made at the first pass, which knows the total
    const TransferProgress progress = [&](uint64_t done, uint64_t total) {
        if (!line) line.emplace("vertex passes", total, options.quiet).startedAt(start);
        line->update(done);
    };
    const VertexTransfer transfer =
        backend.context ? computeTransferOnGpu(*backend.context, source.world, transferOptions, progress)
                        : computeTransfer(source.world, transferOptions, progress);
    if (line) line->disable();
    if (backend.context && backend.context->validationMessages() > 0)
        throw Error(
            ErrorKind::Device,
            "transfer: " + counted(backend.context->validationMessages(), "Vulkan validation message") +
                " (above)");
    const TransferDescription description{model, transferOptions.bounces};
    writeOutputFile(options.output,
                    writesBinary(options) ? transferBinary(source, transfer, description)
                                          : transferGlb(source, transfer, description),
                    OutputContent::Binary);
    if (!options.quiet) report(options, source, backend, transfer, millisecondsSince(start) / 1000.0);
}

} // namespace shprobe
