// `shprobe render`: a sphere lit by a probe (or an environment, baked first), rendered offscreen
// to EXR (linear) or PNG (tonemapped sRGB); `--grid` puts the environment and its order-3 and
// order-5 reconstructions and lit spheres side by side.
#include "app/commands.h"
#include "app/parsed_option.h"
#include "app/stopwatch.h"
#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "render/grid.h"
#include "render/image_output.h"
#include "render/offscreen.h"
#include "render/render_input.h"
#include "vk/check.h"
#include "vk/context.h"

#include <cmath>
#include <cstdio>
#include <regex>

namespace shprobe {

Context createGraphicsContext(const std::string& device, bool validation) {
    ContextOptions options;
    options.device = device;
    options.validation = validation;
    options.graphics = true;
    return createContext(options);
}

namespace {

// The size as the refusals of a size name it.
std::string sizeAsked(const RenderOptions& options, ImageSize size) {
    if (options.grid) return "--size " + std::to_string(size.width) + " with --grid";
    return "--size " + std::to_string(size.width) + "x" + std::to_string(size.height);
}

// The picture's pixels: --size, or with --grid its cells side by side (render/grid.h).
VkExtent2D pictureExtent(const RenderOptions& options, ImageSize size) {
    if (!options.grid) return {size.width, size.height};
    const VkExtent2D cell = gridCellExtent(size.width);
    return {cell.width * kGridColumns, cell.height * kGridRows};
}

} // namespace

Context createRenderContext(const RenderOptions& options, ImageSize size) {
    Context context = createGraphicsContext(options.device, options.validation);
    OnFailure release([&] { destroyContext(context); });
    const VkExtent2D targets =
        options.grid ? gridCellExtent(size.width) : VkExtent2D{size.width, size.height};
    requireRenderTargetExtent(context, targets, sizeAsked(options, size));
    return context;
}

namespace {

constexpr uint32_t kDefaultSize = 512;
constexpr uint32_t kDefaultGridCell = 384;
constexpr uint32_t kMaxSize = 16384;

// The background the user asked for, or the best one the input allows.
Background chooseBackground(const RenderOptions& options, const RenderInput& input,
                            const ProbeShading& probe) {
    if (options.background != "auto") return parseBackground(options.background);
    if (input.environment) return Background::Environment;
    return probe.hasRadiance ? Background::Radiance : Background::Color;
}

struct RenderResult {
    RenderedImage image;
    RenderInput input;
    Background background = Background::Color;
    std::string grid; // with --grid: what its cells show
    double renderMilliseconds = 0.0;
};

// The bands drawn: those of --order, or the grid's 5. Only those: an irradiance probe of order 5 has
// no radiance at order 5 (A_3 = 0) but has it at order 3, where radiance was refused.
int foldOrder(const RenderOptions& options) {
    return options.grid ? kMaxRenderOrder : options.order;
}

void renderInput(const Context& context, const RenderOptions& options, ImageSize size, RenderResult& result) {
    ProbeShading probe =
        foldProbe(result.input.probe, foldOrder(options), result.input.name, result.input.sun);
    float exposure = autoExposure(result.input.probe, result.input.sun) * std::exp2(options.exposure);
    OffscreenRenderer renderer = createOffscreenRenderer(context);
    ScopeExit releaseRenderer([&] { destroyOffscreenRenderer(context, renderer); });
    setProbe(renderer.scene, probe);
    if (result.input.environment) setEnvironment(context, renderer.scene, *result.input.environment);
    Clock::time_point start = Clock::now();
    if (options.grid) {
        result.image = renderGrid(context, renderer, {size.width, exposure});
        result.grid = describeGrid(renderer);
    } else {
        result.background = chooseBackground(options, result.input, probe);
        Scene scene = sphereScene(orbitCamera(options.yaw, options.pitch, 3.2f), options.order,
                                  parseShadingMode(options.mode), result.background);
        scene.backgroundColor = glm::vec3(0.05f);
        result.image = renderOffscreen(context, renderer, scene, {size.width, size.height}, exposure);
    }
    result.renderMilliseconds = millisecondsSince(start);
}

// Probe files are read and checked before any device work, environments baked on the device.
RenderResult renderOnDevice(const RenderOptions& options, ImageSize size) {
    RenderResult result;
    if (isProbeFile(options.input)) {
        result.input = readProbeInput(options.input);
        foldProbe(result.input.probe, foldOrder(options), result.input.name,
                  result.input.sun); // throws early
    }
    Context context = createRenderContext(options, size);
    ScopeExit releaseContext([&] { destroyContext(context); });
    if (!isProbeFile(options.input)) {
        DeviceStep step("baking " +
                        (options.input.empty() ? std::string("the built-in sky") : options.input));
        result.input =
            loadRenderInput(context, options.input, {options.faceSize, options.sanitize, options.maxPixels});
    }
    {
        // An environment input's cube map is uploaded in this step too: --face-size sizes that.
        DeviceStep step("rendering " + options.output, DeviceWork::Sized,
                        isProbeFile(options.input) ? "--size" : "--size or --face-size");
        renderInput(context, options, size, result);
    }
    if (uint32_t messages = context.validationMessages(); messages > 0)
        throw Error(ErrorKind::Device, counted(messages, "Vulkan validation message") + " (above)");
    return result;
}

void printSummary(const RenderOptions& options, const RenderResult& result) {
    std::printf("shprobe render: %s -> %s (%dx%d)\n", result.input.name.c_str(), options.output.c_str(),
                result.image.linear.width, result.image.linear.height);
    if (options.grid)
        std::printf("  grid     %s\n", result.grid.c_str());
    else
        std::printf("  shading  order %d, %s, background %s\n", options.order, options.mode.c_str(),
                    backgroundName(result.background));
    if (const auto& sun = result.input.sun)
        std::printf("  sun      direction (%.4f, %.4f, %.4f), radius %.3f deg: added analytically\n",
                    sun->direction.x, sun->direction.y, sun->direction.z, sun->angularRadius * 180.0 / M_PI);
    std::printf("  time     ");
    if (result.input.bakeMilliseconds > 0.0) std::printf("bake %.1f ms, ", result.input.bakeMilliseconds);
    std::printf("render %.1f ms\n", result.renderMilliseconds);
}

} // namespace

ImageSize parseImageSize(const std::string& text, const char* option) {
    std::smatch match;
    ImageSize size;
    if (std::regex_match(text, match, std::regex(R"((\d{1,5}))"))) {
        size.width = size.height = uint32_t(std::stoul(match[1]));
    } else if (std::regex_match(text, match, std::regex(R"((\d{1,5})[xX](\d{1,5}))"))) {
        size.width = uint32_t(std::stoul(match[1]));
        size.height = uint32_t(std::stoul(match[2]));
    }
    if (size.width < 1 || size.height < 1 || size.width > kMaxSize || size.height > kMaxSize)
        throw Error(ErrorKind::Input, std::string(option) + " must be N or WxH with sides 1.." +
                                          std::to_string(kMaxSize) + ", not '" + text + "'");
    return size;
}

void addRenderOptions(CLI::App& command, RenderOptions& options) {
    command
        .add_option("input", options.input,
                    "Probe file (.json, or .bin of one probe) or environment image (baked first); "
                    "default: the built-in sky")
        ->check(nonEmptyName());
    command
        .add_option("-o,--output", options.output, "Image: .png/.jpg (tonemapped sRGB) or .exr/.hdr (linear)")
        ->capture_default_str()
        ->check(nonEmptyName());
    command.add_option("--order", options.order, "SH order: 3 (9 coefficients) or 5 (25)")
        ->check(CLI::IsMember({3, 5}))
        ->capture_default_str();
    command.add_option("--mode", options.mode, "What the sphere shows")
        ->check(CLI::IsMember({"radiance", "irradiance", "l1-nonlinear"}))
        ->capture_default_str();
    addSizeOption(command, options.size,
                  "Image size N or WxH (default 512; with --grid the cell width, 384)");
    command.add_flag("--grid", options.grid,
                     "Environment, order-3 and order-5 reconstructions and lit spheres in one image");
    command
        .add_option("--background", options.background,
                    "Background behind the sphere: environment (auto's for an image input), "
                    "radiance or sh (the SH reconstruction; auto's for a probe with radiance), "
                    "shading (a white surface facing each direction), color (flat)")
        ->check(CLI::IsMember({"auto", "environment", "radiance", "sh", "shading", "color"}))
        ->capture_default_str();
    addExposureOption(command, options.exposure);
    command.add_option("--yaw", options.yaw, "Camera yaw around +Y, degrees (0 looks along -Z)")
        ->check(numberFrom(-360.0, 360.0))
        ->capture_default_str();
    command.add_option("--pitch", options.pitch, "Camera pitch, degrees")
        ->check(numberFrom(-85.0, 85.0))
        ->capture_default_str();
    addEnvironmentInputOptions(command, options.faceSize, options.sanitize, options.maxPixels);
    addDeviceOptions(command, options.device, options.validation);
    // The scene's own picture: none of the sphere's settings apply to it.
    addLitSceneOptions(command, options.scene,
                       {"input", "--order", "--mode", "--grid", "--background", "--face-size"});
    // The grid draws both orders, its own modes and backgrounds, from its own camera.
    CLI::Option* grid = command.get_option("--grid");
    for (const char* name : {"--order", "--mode", "--background", "--yaw", "--pitch"})
        grid->excludes(command.get_option(name));
}

CLI::Option* addSizeOption(CLI::App& command, std::optional<ImageSize>& size, const std::string& help) {
    return addParsedOption(
        command, "--size", size, [](const std::string& text) { return parseImageSize(text, "--size"); },
        help);
}

void addEnvironmentInputOptions(CLI::App& command, int& faceSize, bool& sanitize, int64_t& maxPixels) {
    command.add_option("--face-size", faceSize, "Cube-map face size of an environment input")
        ->transform(wholeNumberFrom(1, kMaxGpuFaceSize));
    command.add_flag("--sanitize", sanitize, "Replace NaN and infinite texels with 0 instead of failing");
    addImageLimitOption(command, maxPixels);
}

void runRender(const RenderOptions& options) {
    const uint32_t side = options.grid ? kDefaultGridCell : kDefaultSize;
    const ImageSize size = options.size.value_or(ImageSize{side, side});
    if (options.grid && size.width != size.height) // the cells' shape is the grid's
        throw Error(ErrorKind::Input, "--size " + std::to_string(size.width) + "x" +
                                          std::to_string(size.height) +
                                          " with --grid: the size is the cell width, one number");
    checkRenderOutputPath(options.output); // before any work
    const VkExtent2D picture = pictureExtent(options, size);
    checkRenderOutputSize(options.output, picture.width, picture.height, sizeAsked(options, size));
    if (options.scene.transfer) return runTransferRender(options, size.width, size.height);
    if (options.scene.drawn()) return runSceneRender(options, size.width, size.height);
    checkOutputsAreNotInputs({&options.output, 1}, filesReadBy(options.input));
    if (options.faceSize != 0 && isProbeFile(options.input))
        throw Error(ErrorKind::Input, "--face-size sizes the cube map an environment image is baked into; " +
                                          options.input + " is a probe file");
    RenderResult result = renderOnDevice(options, size);
    writeRenderedImage(options.output, result.image);
    printSummary(options, result);
}

} // namespace shprobe
