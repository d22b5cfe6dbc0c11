// `shprobe scene`: a grid of light probes baked inside a glTF scene by rays, on the GPU
// (gpu/ray_capture.h) or the CPU (scene/ray_bake.h), into a probe volume (formats/probe_volume.h); `shprobe
// merge` joins the bricks of one bake (docs/scene-probes.md).
#include "app/commands.h"
#include "app/parsed_option.h"
#include "app/program.h"

#include "app/bake_steps.h"
#include "app/progress_line.h"
#include "app/stopwatch.h"
#include "common/content_hash.h"
#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "formats/json_reading.h"
#include "formats/probe_volume.h"
#include "gpu/ray_capture.h"
#include "gpu/scene_capture.h"
#include "image/environment.h"
#include "scene/gltf_scene.h"
#include "scene/probe_grid.h"
#include "scene/ray_bake.h"
#include "scene/surface_cache.h"
#include "scene/volume_bake.h"
#include "sh/basis.h"
#include "sh/lights.h"
#include "sh/projection.h"
#include "vk/context.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>
#include <unistd.h>

namespace shprobe {

namespace {

BrickOption parseBrickOption(const std::string& text) {
    return {parseBrick(text), text};
}

} // namespace

void addSceneOptions(CLI::App& command, SceneOptions& options) {
    command.add_option("scene", options.scene, "glTF scene (.gltf or .glb)")
        ->required()
        ->check(nonEmptyName());
    command.add_option("-o,--output", options.output, "Probe volume to write (docs/probe-volume.md)")
        ->capture_default_str()
        ->check(nonEmptyName());
    addParsedOption(command, "--grid", options.grid, parseGridCounts, "Probes per axis, NX,NY,NZ")
        ->required();
    addParsedOption(command, "--bounds", options.bounds, parseGridBounds,
                    "Grid box X0,Y0,Z0,X1,Y1,Z1, probes on its corners (default: the scene's box, "
                    "inset by half a cell)");
    addRangeOption(command, "--order", options.order, "SH order", 1, kMaxOrder);
    addRangeOption(command, "--face-size", options.faceSize, "Each probe's cube-map face size", 1, 4096);
    addRangeOption(command, "--bounces", options.bounces,
                   "Indirect bounces: 0 is what the probes see directly (sky, emission); each "
                   "bounce adds the light the surfaces reflect from the one before",
                   0, 64);
    command
        .add_option(
            "--sky", options.sky,
            "Environment seen where no geometry is (any input `bake` takes; default: the built-in sky)")
        ->check(nonEmptyName());
    command
        .add_option("--sky-face-size", options.skyFaceSize,
                    "Face size the sky is resampled to (0: its own; 128 for the built-in sky)")
        ->transform(wholeNumberFrom(0, 4096));
    addSkyReadingOptions(command, options.sanitize, options.maxPixels);
    addParsedOption(command, "--brick", options.brick, parseBrickOption,
                    "Bake only brick I of N (0 <= I < N) of the grid, every bounce of its probes; "
                    "`shprobe merge` joins the bricks");
    command
        .add_option("--previous", options.previous,
                    "gpu: the whole volume of the previous bounce: bake the bounce after it (the whole "
                    "transport again, the volume checked to be this bake's)")
        ->check(nonEmptyName());
    command
        .add_option("--backend", options.backend,
                    "gpu: rays on the Vulkan device; cpu: rays on all cores, by Embree; both bake the same "
                    "transport (--bounce-light); auto: cpu where no GPU is (lavapipe), else gpu")
        ->check(CLI::IsMember({"auto", "gpu", "cpu"}))
        ->capture_default_str();
    command
        .add_option("--invalid-back-faces", options.invalidBackFaces,
                    "A probe is invalid (inside geometry) where more than this fraction of its view "
                    "meets back faces")
        ->check(numberFrom(0.0, 1.0))
        ->capture_default_str();
    command
        .add_option("--relocation-limit", options.relocationLimit,
                    "A probe inside geometry is moved out (through the nearest back face its rays "
                    "meet) by at most this fraction of the grid's smallest cell side, and captured there; "
                    "0: not moved. At most 0.5, so that a probe stays nearest its own grid point")
        ->check(numberFrom(0.0, 0.5))
        ->capture_default_str();
    command.add_flag("--transfer", options.transfer,
                     "cpu: store each probe's radiance transfer, so that `shprobe relight` makes the volume "
                     "for another sky, or the sky turned, without a capture (emission and the scene's suns "
                     "stay as baked); the volume's light is the sky's band-limited to --order");
    command.add_flag("!--no-dilation", options.dilate,
                     "Leave invalid probes empty, not filled from their valid neighbours");
    addRangeOption(command, "--probes-per-batch", options.probesPerBatch,
                   "gpu: probes captured per command buffer", 1, 4096);
    addRangeOption(command, "--rays-per-texel", options.raysPerTexel,
                   "Jittered rays per cube-map texel, rounded up to a square (0: " +
                       std::to_string(kDefaultRaysPerTexel) + "; 1: the texel's centre)",
                   0, 1024);
    command
        .add_option("--probe-directions", options.probeDirections,
                    "cpu: a probe's view as rays through its cube map's texels, or as many directions "
                    "stratified over the sphere (6 N^2 s^2, N the face size, s^2 the rays per texel)")
        ->check(CLI::IsMember({"texels", "sphere"}))
        ->capture_default_str();
    command
        .add_option("--cache-spacing", options.cacheSpacing,
                    "The largest distance between the surface points that gather bounced light "
                    "(0: the scene's diagonal / 64)")
        ->check(numberFrom(0.0, 1e30));
    addRangeOption(command, "--gather-rays", options.gatherRays,
                   "Rays each surface point gathers a bounce with", 1, 1 << 20);
    addRangeOption(command, "--cache-refinement", options.cacheRefinement,
                   "cpu: the most times a cell of surface points is halved where a shadow's edge or a "
                   "surface crosses it (0: never)",
                   0, kMaxCacheRefinement);
    command
        .add_option("--bounce-light", options.bounceLight,
                    "Where a surface's bounced light comes from: the cache of surface points, "
                    "or a path from each probe ray's hit; auto: paths unless the cache would cast under "
                    "a quarter of their rays for the grid (at 2 x 2 a texel), the cache with --transfer or "
                    "--cache-refinement")
        ->check(CLI::IsMember({"auto", "cache", "paths"}))
        ->capture_default_str();
    addDeviceOptions(command, options.device, options.validation);
    command.add_flag("-q,--quiet", options.quiet, "No report");
}

void addMergeOptions(CLI::App& command, MergeOptions& options) {
    command.add_option("bricks", options.bricks, "Probe volumes of the bricks, in any order")
        ->required()
        ->check(nonEmptyName());
    command.add_option("-o,--output", options.output, "Whole volume to write")
        ->required()
        ->check(nonEmptyName());
    command.add_flag("-q,--quiet", options.quiet, "No report");
}

void requireFiniteLight(const ProbeVolume& volume, const std::string& light) {
    if (const std::string probe = nonFiniteLight(volume); !probe.empty())
        throw Error(ErrorKind::Input, probe + " overflows float: " + light + " is far too strong");
}

void addSkyReadingOptions(CLI::App& command, bool& sanitize, int64_t& maxPixels) {
    command.add_flag("--sanitize", sanitize,
                     "Replace the sky's NaN and infinite texels with 0 instead of failing");
    addImageLimitOption(command, maxPixels);
}

Environment loadSceneSky(const std::string& path, const SkyReading& reading) {
    const int faceSize = reading.faceSize;
    if (path.empty()) {
        const int size = faceSize > 0 ? faceSize : 128;
        Environment sky;
        sky.cubemap = makeDefaultSky(size);
        sky.description = "built-in sky (" + std::to_string(size) + "^2 faces)";
        return sky;
    }
    Environment sky = loadEnvironment(
        path, {.faceSize = faceSize,
               .nonFinite = reading.sanitize ? NonFinitePolicy::Replace : NonFinitePolicy::Refuse,
               .maxPixels = reading.maxPixels});
    // Said, so that two bakes of one file at two sizes (two lights, two hashes) are told apart.
    if (faceSize > 0) sky.description += " resampled to " + std::to_string(faceSize) + "^2 faces";
    if (sky.replacedTexels > 0)
        sky.description += ", " + counted(sky.replacedTexels, "NaN/Inf texel") + " replaced with 0";
    return sky;
}

std::string skyContentHash(const Cubemap& sky) {
    Fnv1a64 hash;
    hash.addLength(uint64_t(sky.faceSize));
    for (const glm::vec4& texel : sky.texels)
        hash.add({reinterpret_cast<const char*>(&texel), 3 * sizeof(float)});
    return hash.text();
}

std::string skyContentHash(const ShCoefficients& radiance) {
    Fnv1a64 hash;
    hash.addLength(uint64_t(radiance.order));
    for (const glm::dvec3& coefficient : radiance.rgb)
        hash.add({reinterpret_cast<const char*>(&coefficient), sizeof(coefficient)});
    return hash.text();
}

SplitSky splitSceneSky(const Environment& sky) {
    SplitSky split{sky.cubemap, {}};
    const SunExtraction sun = extractSun(split.residual);
    if (sun.found) split.suns.push_back({glm::vec3(sun.direction), glm::vec3(sun.power)});
    return split;
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

// A relocated probe keeps this many smallest cell sides from the front faces near it (ProbeRelocation
// in scene/ray_bake.h), and passes the back face it leaves through by half as much: the sampler's
// normal bias (scene/volume_sampling.h), so that the surface it left lies behind the points a
// sampler tests it against.
constexpr double kRelocationFrontCells = 0.1;

// Both backends' default is the same (kDefaultRaysPerTexel), so that a volume is as close to the
// transport whichever bakes it.
// As cast: rounded up to a square (3 and 4 cast the same 2 x 2), so that the summary, the volume's
// settings and the sky's averaging say the rays the bake cast.
int raysPerTexel(const SceneOptions& options) {
    const int side = squareSide(options.raysPerTexel > 0 ? options.raysPerTexel : kDefaultRaysPerTexel);
    return side * side;
}

// The face size of a texel a ray: one of the s x s jittered rays of a texel.
int rayFootprintFaceSize(const SceneOptions& options) {
    return options.faceSize * int(std::sqrt(double(raysPerTexel(options))));
}

// The face size of the sky as the probes' rays see it: a texel a ray, never finer than the sky's own.
int skyFaceSizeForProbes(const SceneOptions& options, int skyFaceSize) {
    return std::min(skyFaceSize, rayFootprintFaceSize(options));
}

// The sky averaged over the probes' ray footprints where it is finer (docs/scene-probes.md, "Small
// bright patches of a sky"): a patch smaller than a ray's share of the sphere counts by its area,
// not by whether a ray happened to meet it.
Cubemap skySeenByProbes(const Cubemap& sky, const SceneOptions& options) {
    return averageCubemap(sky, skyFaceSizeForProbes(options, sky.faceSize));
}

ProbeGrid chosenGrid(const SceneOptions& options, const World& world) {
    return options.bounds ? makeProbeGrid(options.grid, *options.bounds)
                          : probeGridInWorld(options.grid, world);
}

// The cpu's options as the command line gives them, the cache for bounced light.
RayBakeOptions rayOptionsAsked(const SceneOptions& options, const ProbeGrid& grid) {
    const double cell = smallestCellEdge(grid);
    return {.order = options.order,
            .faceSize = options.faceSize,
            .raysPerTexel = raysPerTexel(options),
            .bounces = options.bounces,
            .cacheSpacing = options.cacheSpacing,
            .gatherRays = options.gatherRays,
            .cacheRefinement = options.cacheRefinement,
            .relocation = {.limit = options.relocationLimit * cell,
                           .minFrontDistance = kRelocationFrontCells * cell,
                           .invalidBackFaces = options.invalidBackFaces},
            .directions =
                options.probeDirections == "sphere" ? ProbeDirections::Sphere : ProbeDirections::Texels};
}

const char* bounceLightName(BounceLight light) {
    return light == BounceLight::Paths ? "paths" : "cache";
}

// The bounce light of either backend; auto's is the cache where refinement or --transfer asks for it
// (paths sample the sky where it is bright, so that their bake is not linear in it), else
// autoBounceLight's for the whole grid (not the brick's probes, so that bricks agree).
BounceLight chosenBounceLight(const SceneOptions& options, const ProbeGrid& grid, const World& world) {
    if (options.bounceLight != "auto")
        return options.bounceLight == "paths" ? BounceLight::Paths : BounceLight::Cache;
    if (options.cacheRefinement > 0 || options.transfer) return BounceLight::Cache;
    return autoBounceLight(world, rayOptionsAsked(options, grid), grid.probeCount());
}

// What decides the probes' values besides the grid, order and bounces: bricks merge only when it
// is the same.
std::string bakeSettings(const SceneOptions& options, const std::string& backend, const Environment& sky,
                         BounceLight bounceLight) {
    nlohmann::json settings{{"backend", backend},
                            {"face_size", options.faceSize},
                            {"invalid_back_faces", options.invalidBackFaces},
                            {"sky", skyContentHash(sky.cubemap)}};
    settings["cache_spacing"] = options.cacheSpacing;
    settings["gather_rays"] = options.gatherRays;
    if (options.relocationLimit > 0.0) settings["relocation_limit"] = options.relocationLimit;
    settings["rays_per_texel"] = raysPerTexel(options);
    settings["dilation"] = options.dilate;
    if (backend == "cpu") {
        if (options.cacheRefinement > 0) settings["cache_refinement"] = options.cacheRefinement;
        if (options.transfer) settings["transfer"] = true;
        if (options.probeDirections != "texels") settings["probe_directions"] = options.probeDirections;
    }
    // The gpu's at bounce 0 too: a --previous bounce continues it with the same settings.
    if (options.bounces > 0 || backend == "gpu") settings["bounce_light"] = bounceLightName(bounceLight);
    return settings.dump();
}

// The previous bounce: the whole volume of this very bake (the same scene, sky, grid, order and
// settings), with irradiance. A volume written before volumes held sky_source names its sky by
// description, and is matched so.
ProbeVolume readPreviousBounce(const SceneOptions& options, const ProbeGrid& grid, const World& world,
                               const Environment& sky, const std::string& settings) {
    ProbeVolume previous = readProbeVolume(options.previous);
    auto refuse = [&](const std::string& what) {
        throw Error(ErrorKind::Input, options.previous + ": " + what);
    };
    if (previous.begin != 0 || previous.end != previous.grid.probeCount())
        refuse("--previous needs the whole volume (merge the bricks first)");
    if (const std::string difference = gridDifference(previous.grid, grid, "the volume", "this bake");
        !difference.empty())
        refuse(difference);
    if (previous.order != options.order)
        refuse("order " + std::to_string(previous.order) + ", this bake's is " +
               std::to_string(options.order));
    if (const std::string mismatch = sceneMismatch(previous, gltfSceneHash(options.scene), world.description);
        !mismatch.empty())
        refuse(mismatch);
    BakeSky thisBake{settings, sky.description};
    if (previous.skySource.empty()) {
        nlohmann::json described = nlohmann::json::parse(settings);
        described["sky"] = sky.description;
        thisBake = {jsonText(described), ""};
    }
    if (const std::string difference =
            skyDifference({previous.settings, previous.skySource}, thisBake, "the volume", "this bake");
        !difference.empty())
        refuse(difference);
    if (const std::string difference =
            settingsDifference(previous.settings, thisBake.settings, "the volume", "this bake");
        !difference.empty())
        refuse(difference);
    if (previous.irradiance.empty()) refuse("the volume holds no irradiance");
    return previous;
}

// What one `shprobe scene` bakes: the scene and its sky, the grid and the part of it (a brick or
// the whole), and how, with the settings' JSON that a volume's bricks must share.
struct SceneJob {
    const SceneOptions& options;
    const World& world;
    const Environment& sky;
    ProbeGrid grid;
    ProbeRange range;
    BounceLight bounceLight;
    std::string settings;
};

// Every bounce of probes [range.begin, range.end) by rays (scene/volume_bake.h), the progress on a
// terminal; with --transfer the volume's transfer, and its light the sky's band-limited to the order.
ProbeVolume bakeByRays(const SceneJob& job, VolumeBakeReport& report) {
    const auto& [options, world, sky, grid, range, bounceLight, settings] = job;
    RayBakeOptions rayOptions = rayOptionsAsked(options, grid);
    rayOptions.bounceLight = bounceLight;
    const VolumeBakeOptions bakeOptions{rayOptions, options.dilate};
    const uint64_t probes =
        options.transfer ? transferProbeCount(options.order, range) : range.end - range.begin;
    ProgressLine line("probes", probes, options.quiet);
    auto progress = [&](uint64_t done, uint64_t rays) { line.update(done, double(rays), "rays"); };
    if (!options.transfer) {
        const SplitSky split = splitSceneSky(sky);
        const ProbeSky probeSky{skySeenByProbes(split.residual, options), split.suns};
        return bakeVolumeByRays(world, probeSky, bakeOptions, grid, range, report, progress);
    }
    ProbeVolume volume =
        bakeVolumeTransfer(world, rayFootprintFaceSize(options), bakeOptions, grid, range, report, progress);
    relightVolume(volume, projectCubemap(sky.cubemap, options.order));
    return volume;
}

// An option only the cpu backend bakes (none: option null), and what the gpu does instead.
struct CpuOnly {
    const char* option = nullptr;
    const char* gpu = "";
};
CpuOnly cpuOnlyOption(const SceneOptions& options) {
    if (options.cacheRefinement > 0)
        return {"--cache-refinement", "the gpu gathers every lattice point, unrefined"};
    if (options.probeDirections != "texels")
        return {"--probe-directions sphere", "the gpu captures through texels"};
    return {};
}

// auto means gpu where the options ask for Vulkan (--device, --validation) or continue a gpu bake
// (--previous), cpu where no GPU can be (no device file) or the Vulkan device is a CPU (lavapipe:
// rays on the cores are faster than llvmpipe's), else gpu.
RayBackend chooseSceneBackend(const SceneOptions& options) {
    const bool asksForVulkan = !options.device.empty() || options.validation || !options.previous.empty();
    if (options.backend == "cpu") return {"cpu", "", std::nullopt};
    if (options.transfer) return {"cpu", "--transfer bakes by rays on the cpu", std::nullopt};
    return chooseRayBackend(options.backend == "auto" && !asksForVulkan,
                            [&] { return createGraphicsContext(options.device, options.validation); });
}

// What the options ask for that no scene can give, before the scene is read: a bounce count with
// one bounce's options, a cpu option for the gpu, bounds that make no grid of these counts, more
// bricks than probes.
void checkSceneOptions(const SceneOptions& options) {
    requireDeviceUsed(options.backend, options.device, options.validation);
    if (options.transfer && (!options.device.empty() || options.validation))
        throw Error(ErrorKind::Input, std::string(options.validation ? "--validation" : "--device") +
                                          " is for a Vulkan device, and --transfer bakes on the cpu");
    if (options.bouncesGiven && !options.previous.empty())
        throw Error(ErrorKind::Input, "scene: --previous bakes one bounce; --bounces is for whole bakes");
    if (!options.previous.empty() && options.backend == "cpu")
        throw Error(ErrorKind::Input, "scene: --previous continues a gpu bake; the cpu backend bakes every "
                                      "bounce in one run (a --brick too)");
    if (options.transfer && (options.backend == "gpu" || !options.previous.empty()))
        throw Error(ErrorKind::Input, "scene: --transfer bakes every bounce by rays on the cpu backend "
                                      "(not --backend gpu, not --previous)");
    if (options.transfer && options.cacheRefinement > 0)
        throw Error(ErrorKind::Input, "scene: --cache-refinement halves cells where their light differs, so "
                                      "its bake is not linear in the sky; --transfer needs it off");
    if (options.transfer && options.bounceLight == "paths")
        throw Error(ErrorKind::Input, "scene: --bounce-light paths samples the sky where it is bright, so "
                                      "its bake is not linear in the sky; --transfer bakes from the cache");
    if (options.cacheRefinement > 0 && options.bounceLight == "paths")
        throw Error(ErrorKind::Input, "scene: --cache-refinement halves the cache's cells; --bounce-light "
                                      "paths keeps no cache");
    if (const CpuOnly asked = cpuOnlyOption(options); asked.option && options.backend == "gpu")
        throw Error(ErrorKind::Input,
                    std::string("scene: ") + asked.option + " is for the cpu backend; " + asked.gpu);
    if (options.bounds) makeProbeGrid(options.grid, *options.bounds);
    if (options.brick) brickRange(ProbeGrid{.counts = options.grid}, options.brick->brick);
    checkOutputPath(options.output, OutputContent::Binary);
    std::vector<std::string> inputs = sceneInputs(options.scene, options.sky);
    if (!options.previous.empty()) inputs.push_back(options.previous);
    checkOutputsAreNotInputs({&options.output, 1}, inputs);
}

// Every bounce of probes [range.begin, range.end) by rays on the GPU, as the cpu backend bakes
// them (the sky's sun taken out as a sun, the sky averaged to the rays' footprints), the cache
// gathered whole or bounces by paths (`bounceLight`): a brick is exactly its part of the whole
// bake. Probes still inside geometry are filled as the cpu fills them (dilateInvalidProbes), the
// counts in `report`. After --previous, the bounce after that volume's.
ProbeVolume bakeOnGpu(const Context& context, const SceneJob& job, VolumeBakeReport& report) {
    const auto& [options, world, sky, grid, range, bounceLight, settings] = job;
    const int bounces = options.previous.empty()
                            ? options.bounces
                            : readPreviousBounce(options, grid, world, sky, settings).bounces + 1;
    const SplitSky split = splitSceneSky(sky);
    const World lit = withSuns(world, split.suns);
    const Cubemap seen = skySeenByProbes(split.residual, options);
    // The rays cast shadow rays: the raster capture's shadow maps are not read.
    SceneCapture capture = createSceneCapture(
        context, lit, seen, {.faceSize = options.faceSize, .order = options.order, .shadowMapSize = 1});
    ScopeExit releaseCapture([&] { destroySceneCapture(context, capture); });
    RayCapture rays = createRayCapture(context, capture, SceneShading(lit, seen),
                                       {.bounces = bounces,
                                        .raysPerTexel = raysPerTexel(options),
                                        .cacheSpacing = options.cacheSpacing,
                                        .gatherRays = options.gatherRays,
                                        .relocation = rayOptionsAsked(options, grid).relocation,
                                        .skySuns = split.suns,
                                        .bounceLight = bounceLight});
    ScopeExit releaseRays([&] { destroyRayCapture(context, rays); });
    const SceneBakeOptions bakeOptions{.order = options.order, .probesPerBatch = options.probesPerBatch};
    std::vector<SceneProbe> probes =
        bakeRayProbes(context, capture, rays, probePositions(grid, range), bakeOptions);
    report.counts.sunlitSuns = rays.sunlitSuns;
    report.relocated = size_t(std::count_if(probes.begin(), probes.end(), [](const SceneProbe& probe) {
        return probe.offset != glm::vec3(0.0f);
    }));
    const std::vector<uint32_t> filled =
        options.dilate
            ? dilateInvalidProbes(probes, options.faceSize, options.invalidBackFaces, grid, range,
                                  [&](std::span<const glm::dvec3> beyond) {
                                      return bakeRayProbes(context, capture, rays, beyond, bakeOptions);
                                  })
            : std::vector<uint32_t>{};
    report.filled = filled.size();
    const std::span<const SceneProbe> baked(probes);
    ProbeVolume volume =
        volumeOfProbes(baked, options.order, options.faceSize, options.invalidBackFaces, grid, range);
    volume.bounces = bounces;
    volume.visibilitySize = rays.options.visibilitySize;
    for (const SceneProbe& probe : probes) {
        volume.visibility.insert(volume.visibility.end(), probe.visibility.begin(), probe.visibility.end());
        if (rays.options.relocation.limit > 0.0) volume.offsets.push_back(probe.offset); // as on the cpu
    }
    storeFilledProbes(volume, baked, filled, float(rays.visibilityRange));
    if (context.validationMessages() > 0)
        throw Error(ErrorKind::Device, "scene: the Vulkan validation layer reported " +
                                           counted(context.validationMessages(), "message"));
    return volume;
}

// The summary of a bake: the scene, sky, grid, backend and what the rays found.
void printSceneSummary(const SceneJob& job, const RayBackend& backend, const ProbeVolume& volume,
                       const VolumeBakeReport& rays, double seconds) {
    const auto& [options, world, sky, grid, range, bounceLight, settings] = job;
    FILE* report = reportStream(options.output); // stderr where the volume goes to standard output
    const size_t inside = std::count(volume.valid.begin(), volume.valid.end(), uint8_t(0)) + rays.filled;
    std::fprintf(report, "scene    %s\n", world.description.c_str());
    const int skySeen = skyFaceSizeForProbes(options, sky.faceSize());
    const std::string averaged = skySeen < sky.faceSize() ? ", averaged to " + std::to_string(skySeen) +
                                                                "^2 faces for the probes' rays"
                                                          : "";
    if (options.transfer)
        std::fprintf(
            report,
            "sky      %s, band-limited to order %d: the volume holds its transfer (`shprobe relight` "
            "lights it anew; emission and the scene's suns stay as baked)\n",
            sky.description.c_str(), options.order);
    else
        std::fprintf(report, "sky      %s%s\n", sky.description.c_str(), averaged.c_str());
    std::fprintf(report, "probes   %u of a %dx%dx%d grid (%s), order %d, faces %d^2, bounce %d\n",
                 volume.probeCount(), grid.counts.x, grid.counts.y, grid.counts.z,
                 options.brick ? ("brick " + options.brick->text).c_str() : "whole", options.order,
                 options.faceSize, volume.bounces);
    std::fprintf(report, "invalid  %zu inside geometry (more than %g of their view is back faces)\n",
                 inside + rays.relocated, options.invalidBackFaces);
    const std::string reason = backend.reason.empty() ? "" : " (auto: " + backend.reason + ")";
    const std::string byPaths =
        "bounces by paths from the probes' hits" +
        (rays.counts.sunlitSuns > 0 ? ", sampling the lit points of " + counted(rays.counts.sunlitSuns, "sun")
                                    : std::string());
    if (backend.context) {
        std::fprintf(report, "backend  gpu: %s%s: rays, %d per texel, %s\n",
                     backend.context->info.name.c_str(), reason.c_str(), raysPerTexel(options),
                     bounceLight == BounceLight::Paths ? byPaths.c_str() : "every cache point gathered");
    } else {
        const std::string bounced =
            bounceLight == BounceLight::Paths
                ? byPaths
                : counted(rays.counts.cachePoints, "cache point") + " (" +
                      counted(rays.counts.halvedCells, "cell halved", "cells halved") + ")";
        std::fprintf(report, "backend  cpu: rays by Embree, %d per texel%s, %s%s\n", raysPerTexel(options),
                     options.probeDirections == "sphere" ? "'s worth over the sphere" : "", bounced.c_str(),
                     reason.c_str());
        std::fprintf(report, "rays     %.3g (%.3g probes', %.3g gathering bounces)\n",
                     double(rays.counts.probeRays + rays.counts.cacheRays), double(rays.counts.probeRays),
                     double(rays.counts.cacheRays));
    }
    if (options.relocationLimit > 0.0)
        std::fprintf(report,
                     "moved    %zu out of geometry (by at most %g of the smallest cell side), %zu stayed "
                     "inside\n",
                     rays.relocated, options.relocationLimit, inside);
    std::fprintf(report, "filled   %s from valid neighbours\n",
                 counted(rays.filled, "invalid probe").c_str());
    std::fprintf(report, "wrote    %s in %.2f s\n", options.output.c_str(), seconds);
}

// A --cache-spacing finer than a large triangle's lattice may be is kept where it can be, and said
// where it cannot: the user asked for a finer cache than they get there.
void warnOfCappedLattices(const World& world, double spacing) {
    if (!(spacing > 0.0)) return; // the default, the scene's diagonal / 64, is never capped
    const CappedLattices capped = cappedLattices(world, spacing);
    if (capped.triangles == 0) return;
    std::fprintf(stderr,
                 "shprobe: warning: --cache-spacing %g: %s would need more than %d subdivisions of an "
                 "edge; they have %d, their points up to %.3g apart\n",
                 spacing, counted(capped.triangles, "triangle").c_str(), kMaxCacheSubdivisions,
                 kMaxCacheSubdivisions, capped.widestSpacing);
}

} // namespace

void runScene(const SceneOptions& options) {
    checkSceneOptions(options);
    const Clock::time_point start = Clock::now();
    const World world = loadGltfScene(options.scene);
    const ProbeGrid grid = chosenGrid(options, world);
    const ProbeRange range =
        options.brick ? brickRange(grid, options.brick->brick) : ProbeRange{0, grid.probeCount()};
    const Environment sky = loadSceneSky(
        options.sky,
        {.faceSize = options.skyFaceSize, .sanitize = options.sanitize, .maxPixels = options.maxPixels});

    RayBackend backend = chooseSceneBackend(options);
    ScopeExit releaseContext([&] {
        if (backend.context) destroyContext(*backend.context);
    });
    if (const CpuOnly asked = cpuOnlyOption(options); asked.option && backend.name == "gpu")
        throw Error(ErrorKind::Input, "scene: auto chose the gpu backend (" + backend.reason + "), where " +
                                          asked.gpu + "; " + asked.option + " is for the cpu backend");
    const BounceLight bounceLight = chosenBounceLight(options, grid, world);
    if (bounceLight == BounceLight::Cache && options.bounces > 0)
        warnOfCappedLattices(world, options.cacheSpacing);
    const SceneJob job{
        options, world, sky, grid, range, bounceLight, bakeSettings(options, backend.name, sky, bounceLight)};
    VolumeBakeReport rays;
    ProbeVolume volume = backend.context ? bakeOnGpu(*backend.context, job, rays) : bakeByRays(job, rays);
    volume.source = world.description;
    volume.sourceHash = gltfSceneHash(options.scene);
    volume.skySource = sky.description;
    volume.settings = job.settings;
    requireFiniteLight(volume,
                       "the light of " + world.description + " and its sky, " + sky.description + ",");
    writeProbeVolume(options.output, volume);
    if (!options.quiet) printSceneSummary(job, backend, volume, rays, millisecondsSince(start) / 1000.0);
}

void runMerge(const MergeOptions& options) {
    checkOutputPath(options.output, OutputContent::Binary);
    checkOutputsAreNotInputs({&options.output, 1}, options.bricks);
    std::vector<ProbeVolume> bricks;
    for (const std::string& path : options.bricks)
        bricks.push_back(readProbeVolume(path));
    const ProbeVolume whole = mergeProbeVolumes(bricks, options.bricks);
    writeProbeVolume(options.output, whole);
    if (options.quiet) return;
    std::fprintf(reportStream(options.output), "merged   %s into %s (%s)\n",
                 counted(bricks.size(), "brick").c_str(), options.output.c_str(),
                 counted(whole.probeCount(), "probe").c_str());
}

} // namespace shprobe
