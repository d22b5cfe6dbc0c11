// The viewer's command line, shprobe-view's (view_main.cpp), which `shprobe view` runs: the interactive
// GLFW viewer (src/render/viewer.h); `--screenshot FILE --frames N` saves frame N and exits, for tests
// and scripts.
#include "app/commands.h"
#include "app/parsed_option.h"
#include "common/output_file.h"
#include "gpu/host_bake.h"
#include "render/relit_scene.h"
#include "render/render_input.h"
#include "render/viewer.h"
#include "scene/transfer_mesh.h"
#include "vk/check.h"

namespace shprobe {

namespace {

constexpr ImageSize kDefaultWindowSize{960, 600};

// Everything the viewer is given but the input it shows, which is read once these are checked.
ViewerOptions viewerSettings(const ViewOptions& options) {
    ViewerOptions viewer;
    viewer.input = options.input;
    viewer.showProbes = options.scene.showProbes;
    viewer.inputOptions = {options.faceSize, options.sanitize, options.maxPixels};
    const ImageSize size = options.size.value_or(kDefaultWindowSize);
    viewer.width = size.width;
    viewer.height = size.height;
    viewer.view.order = options.order;
    viewer.view.shading = parseShadingMode(options.mode);
    viewer.view.exposureStops = options.exposure;
    viewer.screenshot = options.screenshot;
    viewer.frames = options.frames;
    viewer.keys = options.keys;
    viewer.device = options.device;
    viewer.validation = options.validation;
    return viewer;
}

} // namespace

void addViewOptions(CLI::App& command, ViewOptions& options) {
    command
        .add_option("input", options.input,
                    "Probe file (.json, or .bin of one probe) or environment image (baked first); "
                    "default: the built-in sky")
        ->check(nonEmptyName());
    addSizeOption(command, options.size, "Window size, N or WxH")
        ->default_str(std::to_string(kDefaultWindowSize.width) + "x" +
                      std::to_string(kDefaultWindowSize.height));
    command.add_option("--order", options.order, "Initial SH order: 3 or 5 (keys 3, 5)")
        ->check(CLI::IsMember({3, 5}))
        ->capture_default_str();
    command.add_option("--mode", options.mode, "Initial shading mode (key M)")
        ->check(CLI::IsMember({"radiance", "irradiance", "l1-nonlinear"}))
        ->capture_default_str();
    command.add_option("--screenshot", options.screenshot, "Save frame --frames to this PNG and exit");
    command.add_option("--frames", options.frames, "Exit after this many frames")
        ->transform(wholeNumberFrom(1, 1 << 30));
    addParsedOption<std::vector<std::string>>(
        command, "--keys", options.keys, scriptedKeys,
        "Key presses to replay, one before each frame: 3 5 m b left right up down j l i k + - r q p")
        ->delimiter(',');
    addExposureOption(command, options.exposure);
    addEnvironmentInputOptions(command, options.faceSize, options.sanitize, options.maxPixels);
    addDeviceOptions(command, options.device, options.validation);
    // The scene's own view: none of the sphere's settings apply to it. Key P shows or hides the probes.
    addLitSceneOptions(command, options.scene, {"input", "--order", "--mode", "--face-size"});
}

void runView(const ViewOptions& options) {
    ViewerOptions viewer = viewerSettings(options);
    checkViewerOptions(viewer); // before any input is read
    const bool showsScene = options.scene.drawn();
    if (!options.screenshot.empty())
        checkOutputsAreNotInputs({&options.screenshot, 1},
                                 showsScene ? litSceneInputs(options.scene) : filesReadBy(options.input));
    // Bad inputs are refused before a window opens (and where there is no display).
    if (options.scene.transfer) {
        viewer.relitMesh = loadTransferMesh(options.scene.scene);
        viewer.relitLight = loadRelitLight(options.scene, viewer.relitMesh->order,
                                           {.sanitize = options.sanitize, .maxPixels = options.maxPixels});
        viewer.lightYaw = options.scene.lightYaw;
        viewer.lightPitch = options.scene.lightPitch;
    } else if (showsScene) {
        viewer.scene =
            loadLitScene(options.scene, {.sanitize = options.sanitize, .maxPixels = options.maxPixels});
    } else if (isProbeFile(options.input)) {
        viewer.probe = readProbeInput(options.input);
    }
    const std::string shown = showsScene              ? options.scene.scene
                              : options.input.empty() ? std::string("the built-in sky")
                                                      : options.input;
    // The window is sized by --size; an environment's cube map, uploaded in this step, by --face-size.
    const bool environment = !showsScene && !isProbeFile(options.input);
    DeviceStep step("showing " + shown, DeviceWork::Sized, environment ? "--size or --face-size" : "--size");
    runViewer(viewer);
}

} // namespace shprobe
