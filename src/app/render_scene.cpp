// `shprobe render --scene SCENE --volume VOLUME`: a glTF scene lit by its probe volume, as its
// probes see it (gpu/scene_capture.h recordSceneView), tonemapped like every render.
#include "app/commands.h"
#include "app/stopwatch.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "formats/probe_volume.h"
#include "render/gpu_image.h"
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
#include <cstring>
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

// Everything one picture allocates beside the capture.
struct SceneFrame {
    SceneViewTarget view;
    Tonemapper tonemapper;
    VkDescriptorSet tonemapInput = VK_NULL_HANDLE;
    GpuImage display;
    VkFramebuffer displayFramebuffer = VK_NULL_HANDLE;
    Buffer colorReadback;
    Buffer displayReadback;
};

void destroyFrame(const Device& device, SceneFrame& frame) {
    destroyBuffer(device, frame.displayReadback);
    destroyBuffer(device, frame.colorReadback);
    if (frame.displayFramebuffer) vkDestroyFramebuffer(device.device, frame.displayFramebuffer, nullptr);
    destroyImage(device, frame.display);
    if (frame.tonemapInput) freeTonemapInput(device, frame.tonemapper, frame.tonemapInput);
    destroyTonemapper(device, frame.tonemapper);
    destroySceneViewTarget(device, frame.view);
}

SceneFrame createFrame(const Context& context, const SceneCapture& capture, VkExtent2D extent) {
    SceneFrame frame;
    OnFailure undo([&] { destroyFrame(context, frame); });
    frame.view = createSceneViewTarget(context, capture, extent,
                                       VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
    frame.tonemapper = createTonemapper(context, kDisplayFormat, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    frame.tonemapInput = createTonemapInput(context, frame.tonemapper, frame.view.color.view);
    frame.display =
        createImage(context, {.format = kDisplayFormat,
                              .extent = extent,
                              .usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                              .what = "display image"});
    frame.displayFramebuffer =
        createFramebuffer(context, frame.tonemapper.renderPass, {&frame.display.view, 1}, extent);
    const VkDeviceSize pixels = VkDeviceSize(extent.width) * extent.height;
    frame.colorReadback = createBuffer(context, pixels * 16, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                       MemoryUse::Readback, "colour readback");
    frame.displayReadback = createBuffer(context, pixels * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                         MemoryUse::Readback, "display readback");
    return frame;
}

RenderedImage renderFrame(const Context& context, const SceneCapture& capture, const SceneCamera& camera,
                          const SceneViewOptions& viewOptions, VkExtent2D extent, float exposure) {
    SceneFrame frame = createFrame(context, capture, extent);
    ScopeExit releaseFrame([&] { destroyFrame(context, frame); });
    submitAndWait(context, [&](VkCommandBuffer commands) {
        recordLitSceneView(commands, capture, frame.view, camera, viewOptions);
        recordTonemap(commands, frame.tonemapper, frame.tonemapInput, frame.displayFramebuffer, extent,
                      exposure);
        changeLayout(commands, frame.view.color,
                     {VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                      VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT,
                      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT});
        copyImageToBuffer(commands, frame.view.color, frame.colorReadback);
        copyImageToBuffer(commands, frame.display, frame.displayReadback);
    });
    RenderedImage image;
    invalidateBuffer(context, frame.colorReadback);
    image.linear = makeImage(int(extent.width), int(extent.height));
    std::memcpy(image.linear.texels.data(), frame.colorReadback.mapped,
                image.linear.texels.size() * sizeof(glm::vec4));
    invalidateBuffer(context, frame.displayReadback);
    const auto* bytes = static_cast<const uint8_t*>(frame.displayReadback.mapped);
    image.display.assign(bytes, bytes + frame.displayReadback.size);
    return image;
}

} // namespace

void addLitSceneOptions(CLI::App& command, LitSceneOptions& options,
                        std::initializer_list<const char*> sphereOnly) {
    CLI::Option* scene = command.add_option(
        "--scene", options.scene, "A glTF scene lit by --volume instead of a sphere (docs/scene-probes.md)");
    for (const char* name : sphereOnly)
        scene->excludes(command.get_option(name));
    command.add_option("--volume", options.volume, "The scene's probe volume (`shprobe scene`)")
        ->needs(scene);
    command.add_option("--sky", options.sky, "The scene's sky (default: the built-in sky)")->needs(scene);
    command
        .add_flag("--show-probes", options.showProbes,
                  "The volume's probes as spheres shaded by their own SH")
        ->needs(scene);
}

std::vector<std::string> litSceneInputs(const LitSceneOptions& options) {
    std::vector<std::string> inputs = sceneInputs(options.scene, options.sky);
    inputs.push_back(options.volume);
    return inputs;
}

LitScene loadLitScene(const LitSceneOptions& options) {
    if (options.scene.empty() || options.volume.empty())
        throw Error(ErrorKind::Input, "--scene and --volume go together");
    LitScene lit{.volume = readWholeVolume(options.volume)};
    lit.world = loadGltfScene(options.scene);
    if (const std::string mismatch =
            sceneMismatch(lit.volume, gltfSceneHash(options.scene), lit.world.description);
        !mismatch.empty())
        throw Error(ErrorKind::Input, options.volume + ": " + mismatch);
    lit.sky = loadSceneSky(options.sky, 0).cubemap;
    return lit;
}

void runSceneRender(const RenderOptions& options, uint32_t width, uint32_t height) {
    checkOutputsAreNotInputs({&options.output, 1}, litSceneInputs(options.scene));
    const LitScene scene = loadLitScene(options.scene);
    const ProbeVolume& volume = scene.volume;

    Context context = createGraphicsContext(options.device, options.validation);
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
