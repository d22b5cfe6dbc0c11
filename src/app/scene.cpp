// `shprobe scene`: a grid of light probes baked inside a glTF scene on the GPU (capture, bake and
// bounces: gpu/scene_capture.h) into a probe volume (formats/probe_volume.h); `shprobe merge` joins the
// bricks of one bake (docs/scene-probes.md).
#include "app/commands.h"
#include "app/parsed_option.h"
#include "app/program.h"

#include "app/stopwatch.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "formats/probe_volume.h"
#include "gpu/scene_capture.h"
#include "image/environment.h"
#include "scene/gltf_scene.h"
#include "scene/probe_grid.h"
#include "vk/context.h"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>

namespace shprobe {

namespace {

BrickOption parseBrickOption(const std::string& text) {
    return {parseBrick(text), text};
}

} // namespace

void addSceneOptions(CLI::App& command, SceneOptions& options) {
    command.add_option("scene", options.scene, "glTF scene (.gltf or .glb)")->required();
    command.add_option("-o,--output", options.output, "Probe volume to write (docs/probe-volume.md)")
        ->capture_default_str();
    addParsedOption(command, "--grid", options.grid, parseGridCounts, "Probes per axis, NX,NY,NZ")
        ->required();
    addParsedOption(command, "--bounds", options.bounds, parseGridBounds,
                    "Grid box X0,Y0,Z0,X1,Y1,Z1, probes on its corners (default: the scene's box, "
                    "inset by half a cell)");
    addRangeOption(command, "--order", options.order, "SH order, 1..8", 1, 8);
    addRangeOption(command, "--face-size", options.faceSize, "Each probe's cube-map face size", 1, 4096);
    addRangeOption(command, "--bounces", options.bounces,
                   "Indirect bounces: 0 is what the probes see directly (sky, emission); each "
                   "bounce adds the light the surfaces reflect from the one before",
                   0, 64);
    command.add_option("--sky", options.sky,
                       "Environment seen where no geometry is (any input `bake` "
                       "takes; default: the built-in sky)");
    command
        .add_option("--sky-face-size", options.skyFaceSize,
                    "Face size the sky is resampled to (0: its own; 128 for the built-in sky)")
        ->check(CLI::Range(0, 4096));
    addParsedOption(command, "--brick", options.brick, parseBrickOption,
                    "Bake only brick I of N (0 <= I < N) of the grid, one bounce: with --previous the "
                    "bounce after that volume's, else bounce 0; `shprobe merge` joins the bricks");
    command.add_option("--previous", options.previous,
                       "The whole volume of the previous bounce: bake the one bounce after it");
    addRangeOption(command, "--probes-per-batch", options.probesPerBatch,
                   "Probes captured per command buffer", 1, 4096);
    addDeviceOptions(command, options.device, options.validation);
    command.add_flag("-q,--quiet", options.quiet, "No report");
}

void addMergeOptions(CLI::App& command, MergeOptions& options) {
    command.add_option("bricks", options.bricks, "Probe volumes of the bricks, in any order")->required();
    command.add_option("-o,--output", options.output, "Whole volume to write")->required();
}

Environment loadSceneSky(const std::string& path, int faceSize) {
    if (path.empty()) {
        const int size = faceSize > 0 ? faceSize : 128;
        Environment sky;
        sky.cubemap = makeDefaultSky(size);
        sky.description = "built-in sky (" + std::to_string(size) + "^2 faces)";
        return sky;
    }
    return loadEnvironment(path, {.faceSize = faceSize});
}

std::vector<std::string> sceneInputs(const std::string& scene, const std::string& sky) {
    std::vector<std::string> files{scene};
    try {
        const std::vector<std::string> external = gltfExternalFiles(scene);
        files.insert(files.end(), external.begin(), external.end());
    } catch (const Error&) { // loadGltfScene says why
    }
    const std::vector<std::string> skyFiles = filesReadBy(sky);
    files.insert(files.end(), skyFiles.begin(), skyFiles.end());
    return files;
}

namespace {

// A probe sees mostly back faces when more than half of its texels do: it is inside something.
bool insideGeometry(uint32_t backFaceTexels, int faceSize) {
    return 2 * uint64_t(backFaceTexels) > 6 * uint64_t(faceSize) * uint64_t(faceSize);
}

ProbeGrid chosenGrid(const SceneOptions& options, const World& world) {
    return options.bounds ? makeProbeGrid(options.grid, *options.bounds)
                          : probeGridInWorld(options.grid, world);
}

// What decides the probes' values besides the grid, order and bounces: bricks merge only when it
// is the same.
std::string bakeSettings(const SceneOptions& options, const Environment& sky) {
    return nlohmann::json{{"face_size", options.faceSize}, {"sky", sky.description}}.dump();
}

// The previous bounce as the capture reads it: the whole grid, the same grid and order.
// The previous bounce as the capture reads it: the whole volume of this very bake (the same scene,
// grid, order and settings), with irradiance.
ProbeVolume readPreviousBounce(const SceneOptions& options, const ProbeGrid& grid, const World& world,
                               const std::string& settings) {
    ProbeVolume previous = readProbeVolume(options.previous);
    auto refuse = [&](const std::string& what) {
        throw Error(ErrorKind::Input, options.previous + ": " + what);
    };
    if (previous.begin != 0 || previous.end != previous.grid.probeCount())
        refuse("--previous needs the whole volume (merge the bricks first)");
    if (previous.grid.counts != grid.counts || previous.grid.boundsMin != grid.boundsMin ||
        previous.grid.boundsMax != grid.boundsMax)
        refuse("its grid of " + std::to_string(previous.grid.probeCount()) + " probes is not this bake's");
    if (previous.order != options.order)
        refuse("order " + std::to_string(previous.order) + ", this bake's is " +
               std::to_string(options.order));
    if (previous.source != world.description)
        refuse("baked in " + previous.source + ", not " + world.description);
    if (nlohmann::json::parse(previous.settings) != nlohmann::json::parse(settings))
        refuse("baked with " + previous.settings + ", this bake is " + settings);
    if (previous.irradiance.empty()) refuse("the volume holds no irradiance");
    return previous;
}

BounceSource bounceSourceOf(const ProbeVolume& volume, std::vector<glm::dvec3>& irradiance) {
    irradiance.assign(volume.irradiance.begin(), volume.irradiance.end());
    return {volume.grid.boundsMin, volume.grid.boundsMax, volume.grid.counts, volume.order, irradiance,
            volume.valid};
}

// One bounce of probes [range.begin, range.end) into a volume: coefficients of valid probes,
// zeros for those inside geometry.
ProbeVolume bakeBounce(const Context& context, const SceneCapture& capture, const SceneOptions& options,
                       const ProbeGrid& grid, ProbeRange range) {
    std::vector<glm::dvec3> positions;
    for (uint32_t p = range.begin; p < range.end; ++p)
        positions.push_back(probePosition(grid, probeCell(grid, p)));
    const std::vector<SceneProbe> probes = bakeSceneProbes(
        context, capture, positions, {.order = options.order, .probesPerBatch = options.probesPerBatch});
    ProbeVolume volume;
    volume.grid = grid;
    volume.order = options.order;
    volume.begin = range.begin;
    volume.end = range.end;
    const size_t perProbe = size_t(options.order) * options.order;
    volume.radiance.assign(probes.size() * perProbe, glm::vec3(0.0f));
    volume.irradiance.assign(probes.size() * perProbe, glm::vec3(0.0f));
    volume.valid.assign(probes.size(), 0);
    for (size_t p = 0; p < probes.size(); ++p) {
        if (insideGeometry(probes[p].backFaceTexels, options.faceSize)) continue;
        volume.valid[p] = 1;
        for (size_t i = 0; i < perProbe; ++i) {
            volume.radiance[p * perProbe + i] = glm::vec3(probes[p].radiance.rgb[i]);
            volume.irradiance[p * perProbe + i] = glm::vec3(probes[p].irradiance.rgb[i]);
        }
    }
    return volume;
}

// What the options ask for that no scene can give, before the scene is read: a bounce count with
// one bounce's options, bounds that make no grid of these counts, more bricks than probes.
void checkSceneOptions(const SceneOptions& options, bool bouncesGiven) {
    if (bouncesGiven && (options.brick || !options.previous.empty()))
        throw Error(ErrorKind::Input,
                    "scene: --brick and --previous bake one bounce; --bounces is for whole bakes");
    if (options.bounds) makeProbeGrid(options.grid, *options.bounds);
    if (options.brick) brickRange(ProbeGrid{.counts = options.grid}, options.brick->brick);
    checkOutputPath(options.output, OutputContent::Binary);
    std::vector<std::string> inputs = sceneInputs(options.scene, options.sky);
    if (!options.previous.empty()) inputs.push_back(options.previous);
    checkOutputsAreNotInputs({&options.output, 1}, inputs);
}

} // namespace

void runScene(const SceneOptions& options, bool bouncesGiven) {
    checkSceneOptions(options, bouncesGiven);
    const Clock::time_point start = Clock::now();
    const World world = loadGltfScene(options.scene);
    const ProbeGrid grid = chosenGrid(options, world);
    const ProbeRange range =
        options.brick ? brickRange(grid, options.brick->brick) : ProbeRange{0, grid.probeCount()};
    const Environment sky = loadSceneSky(options.sky, options.skyFaceSize);
    const std::string settings = bakeSettings(options, sky);
    const std::optional<ProbeVolume> previous =
        options.previous.empty() ? std::nullopt
                                 : std::optional(readPreviousBounce(options, grid, world, settings));

    Context context = createGraphicsContext(options.device, options.validation);
    ScopeExit releaseContext([&] { destroyContext(context); });
    SceneCapture capture = createSceneCapture(context, world, sky.cubemap,
                                              {.faceSize = options.faceSize, .order = options.order});
    ScopeExit releaseCapture([&] { destroySceneCapture(context, capture); });

    std::vector<glm::dvec3> irradiance;
    const int first = previous ? previous->bounces + 1 : 0;
    const int last = !options.brick && !previous ? options.bounces : first;
    if (previous) setBounceSource(context, capture, bounceSourceOf(*previous, irradiance));
    ProbeVolume volume;
    for (int bounce = first; bounce <= last; ++bounce) {
        const bool whole = bounce < last; // an earlier bounce of a whole bake lights the next one
        volume =
            bakeBounce(context, capture, options, grid, whole ? ProbeRange{0, grid.probeCount()} : range);
        volume.bounces = bounce;
        if (bounce < last) setBounceSource(context, capture, bounceSourceOf(volume, irradiance));
    }
    if (context.validationMessages() > 0)
        throw Error(ErrorKind::Device, "scene: the Vulkan validation layer reported " +
                                           std::to_string(context.validationMessages()) + " messages");
    volume.source = world.description;
    volume.settings = settings;
    writeProbeVolume(options.output, volume);
    if (options.quiet) return;
    const size_t inside = std::count(volume.valid.begin(), volume.valid.end(), uint8_t(0));
    std::printf("scene    %s\n", world.description.c_str());
    std::printf("sky      %s\n", sky.description.c_str());
    std::printf("probes   %u of a %dx%dx%d grid (%s), order %d, faces %d^2, bounce %d\n", volume.probeCount(),
                grid.counts.x, grid.counts.y, grid.counts.z,
                options.brick ? ("brick " + options.brick->text).c_str() : "whole", options.order,
                options.faceSize, volume.bounces);
    std::printf("invalid  %zu inside geometry (more than half of their view is back faces)\n", inside);
    std::printf("device   %s\n", context.info.name.c_str());
    std::printf("wrote    %s in %.2f s\n", options.output.c_str(), millisecondsSince(start) / 1000.0);
}

void runMerge(const MergeOptions& options) {
    checkOutputPath(options.output, OutputContent::Binary);
    checkOutputsAreNotInputs({&options.output, 1}, options.bricks);
    std::vector<ProbeVolume> bricks;
    for (const std::string& path : options.bricks)
        bricks.push_back(readProbeVolume(path));
    const ProbeVolume whole = mergeProbeVolumes(bricks, options.bricks);
    writeProbeVolume(options.output, whole);
    std::printf("merged   %zu bricks into %s (%u probes)\n", bricks.size(), options.output.c_str(),
                whole.probeCount());
}

} // namespace shprobe
