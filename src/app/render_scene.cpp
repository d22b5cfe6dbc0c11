// `shprobe render --scene SCENE --volume VOLUME`: a glTF scene lit by its probe volume, as its
// probes see it (gpu/scene_capture.h recordSceneView), tonemapped like every render.
#include "app/commands.h"
#include "app/parsed_option.h"
#include "app/stopwatch.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "formats/probe_volume.h"
#include "render/display_readback.h"
#include "render/image_output.h"
#include "render/lit_scene.h"
#include "render/offscreen.h"
#include "render/scene.h"
#include "render/scene_view.h"
#include "scene/gltf_scene.h"
#include "vk/context.h"
#include "vk/graphics.h"
#include "vk/vulkan_commands.h"

#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>

namespace shprobe {

namespace {

ProbeVolume readWholeVolume(const std::string& path) {
    ProbeVolume volume = readProbeVolume(path);
    if (volume.begin != 0 || volume.end != volume.grid.probeCount())
        throw Error(ErrorKind::Input, path + ": a brick of a volume; merge the bricks first (shprobe merge)");
    if (volume.irradiance.empty()) throw Error(ErrorKind::Input, path + ": the volume holds no irradiance");
    return volume;
}

RenderedImage renderFrame(const Context& context, const SceneCapture& capture, const SceneCamera& camera,
                          const SceneViewOptions& viewOptions, VkExtent2D extent, float exposure) {
    SceneViewTarget view = createSceneViewTarget(
        context, capture, extent, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
    ScopeExit releaseView([&] { destroySceneViewTarget(context, view); });
    DisplayReadback readback = createDisplayReadback(context, view.color.view, extent);
    ScopeExit releaseReadback([&] { destroyDisplayReadback(context, readback); });
    submitAndWait(context, [&](VkCommandBuffer commands) {
        recordLitSceneView(commands, capture, view, camera, viewOptions);
        recordDisplayReadback(commands, readback, view.color, exposure);
    });
    return readRenderedImage(context, readback);
}

} // namespace

void addLitSceneOptions(CLI::App& command, LitSceneOptions& options,
                        std::initializer_list<const char*> sphereOnly) {
    CLI::Option* scene = command.add_option(
        "--scene", options.scene, "A glTF scene lit by --volume instead of a sphere (docs/scene-probes.md)");
    for (const char* name : sphereOnly)
        scene->excludes(command.get_option(name));
    command.add_option("--volume", options.volume, "The scene's probe volume (`shprobe scene`)")
        ->check(nonEmptyName())
        ->needs(scene);
    CLI::Option* transfer =
        command
            .add_flag("--transfer", options.transfer,
                      "Relight the scene's per-vertex transfer (shprobe transfer) by --sky or --probe")
            ->needs(scene)
            ->excludes(command.get_option("--volume"));
    CLI::Option* sky =
        command.add_option("--sky", options.sky, "The scene's sky (default: the built-in sky)")
            ->check(nonEmptyName())
            ->needs(scene);
    command
        .add_option(
            "--probe", options.probe,
            "With --transfer: the light's radiance coefficients (a probe file: JSON, or binary of one probe)")
        ->needs(transfer)
        ->excludes(sky);
    command
        .add_option("--light-yaw", options.lightYaw, "With --transfer: the light's turn about +Y, degrees")
        ->check(numberFrom(-360.0, 360.0))
        ->needs(transfer);
    command
        .add_option("--light-pitch", options.lightPitch,
                    "With --transfer: the light's turn about +X, degrees")
        ->check(numberFrom(-360.0, 360.0))
        ->needs(transfer);
    command
        .add_flag("--show-probes", options.showProbes,
                  "The volume's probes as spheres shaded by their own SH")
        ->needs(scene)
        ->excludes(transfer);
}

std::vector<std::string> litSceneInputs(const LitSceneOptions& options) {
    std::vector<std::string> inputs = sceneInputs(options.scene, options.sky);
    inputs.push_back(options.transfer ? options.probe : options.volume);
    return inputs;
}

LitScene loadLitScene(const LitSceneOptions& options, const SkyReading& sky) {
    if (options.scene.empty() || options.volume.empty())
        throw Error(ErrorKind::Input, "--scene and --volume go together");
    LitScene lit{.volume = readWholeVolume(options.volume)};
    lit.world = loadGltfScene(options.scene);
    if (const std::string mismatch =
            sceneMismatch(lit.volume, gltfSceneHash(options.scene), lit.world.description);
        !mismatch.empty())
        throw Error(ErrorKind::Input, options.volume + ": " + mismatch);
    lit.sky = loadSceneSky(options.sky, sky).cubemap;
    return lit;
}

void runSceneRender(const RenderOptions& options, uint32_t width, uint32_t height) {
    checkOutputsAreNotInputs({&options.output, 1}, litSceneInputs(options.scene));
    const LitScene scene =
        loadLitScene(options.scene, {.sanitize = options.sanitize, .maxPixels = options.maxPixels});
    const ProbeVolume& volume = scene.volume;

    Context context = createRenderContext(options, {width, height});
    ScopeExit releaseContext([&] { destroyContext(context); });
    SceneCapture capture = createLitSceneCapture(context, scene);
    ScopeExit releaseCapture([&] { destroySceneCapture(context, capture); });
    const Clock::time_point start = Clock::now();
    const RenderedImage image =
        renderFrame(context, capture, orbitSceneCamera(scene.world, options.yaw, options.pitch),
                    {.showProbes = options.scene.showProbes}, {width, height},
                    volumeExposure(volume) * std::exp2(options.exposure));
    const double milliseconds = millisecondsSince(start);
    if (uint32_t messages = context.validationMessages(); messages > 0)
        throw Error(ErrorKind::Device, counted(messages, "Vulkan validation message") + " (above)");
    writeRenderedImage(options.output, image);
    std::printf("shprobe render: %s lit by %s -> %s (%ux%u)\n", scene.world.description.c_str(),
                options.scene.volume.c_str(), options.output.c_str(), width, height);
    std::printf("  volume   %dx%dx%d probes, order %d, bounce %d%s\n", volume.grid.counts.x,
                volume.grid.counts.y, volume.grid.counts.z, volume.order, volume.bounces,
                options.scene.showProbes ? ", probes shown" : "");
    std::printf("  time     render %.1f ms\n", milliseconds);
}

} // namespace shprobe
