// `shprobe render --scene OUT.glb --transfer`: a scene written by `shprobe transfer` relit by a sky
// or a probe, the light turned on the device (render/relit_scene.h), through render --scene's orbit
// camera and tonemapped like every render.
#include "app/commands.h"
#include "app/stopwatch.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "render/display_readback.h"
#include "render/image_output.h"
#include "render/lit_scene.h"
#include "render/probe_shading.h"
#include "render/relit_scene.h"
#include "render/render_input.h"
#include "render/scene_view.h"
#include "scene/transfer_mesh.h"
#include "sh/rotation.h"
#include "vk/context.h"

#include <cmath>
#include <cstdio>

namespace shprobe {

namespace {

RenderedImage renderRelit(const Context& context, const RelitScene& relit, const glm::mat4& clipFromWorld,
                          VkExtent2D extent, float exposure) {
    RelitTarget target = createRelitTarget(context, relit, extent,
                                           VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
    ScopeExit releaseTarget([&] { destroyColorDepthTarget(context, target); });
    DisplayReadback readback = createDisplayReadback(context, target.color.view, extent);
    ScopeExit releaseReadback([&] { destroyDisplayReadback(context, readback); });
    submitAndWait(context, [&](VkCommandBuffer commands) {
        recordRelitView(commands, relit, target, clipFromWorld);
        recordDisplayReadback(commands, readback, target.color, exposure);
    });
    return readRenderedImage(context, readback);
}

} // namespace

ShCoefficients probeFileRadiance(const std::string& path, int order) {
    const RenderInput input = readProbeInput(path);
    if (input.probe.quantity != Quantity::Radiance)
        throw Error(ErrorKind::Input, path + ": holds irradiance; relighting transfer needs radiance");
    if (input.sun)
        throw Error(ErrorKind::Input,
                    path + ": has a sun apart from its coefficients; transfer relights SH only");
    ShCoefficients light = makeCoefficients(order, Quantity::Radiance);
    for (size_t i = 0; i < light.rgb.size() && i < input.probe.rgb.size(); ++i)
        light.rgb[i] = input.probe.rgb[i];
    return light;
}

RelitLight loadRelitLight(const LitSceneOptions& options, int order, const SkyReading& sky) {
    if (!options.probe.empty()) {
        ShCoefficients light = probeFileRadiance(options.probe, order);
        requireFloatLight(light, options.probe); // the device relights in float
        return {options.probe, std::move(light), {}};
    }
    Environment environment = loadSceneSky(options.sky, sky);
    return {options.sky.empty() ? std::string("the built-in sky") : options.sky, std::nullopt,
            std::move(environment.cubemap)};
}

void runTransferRender(const RenderOptions& options, uint32_t width, uint32_t height) {
    checkOutputsAreNotInputs({&options.output, 1}, litSceneInputs(options.scene));
    const TransferMesh mesh = loadTransferMesh(options.scene.scene);
    const RelitLight source = loadRelitLight(options.scene, mesh.order,
                                             {.sanitize = options.sanitize, .maxPixels = options.maxPixels});

    Context context = createRenderContext(options, {width, height});
    ScopeExit releaseContext([&] { destroyContext(context); });
    const ShCoefficients light = relitLightCoefficients(context, source, mesh.order);
    RelitScene relit = createRelitScene(context, mesh, light);
    ScopeExit releaseRelit([&] { destroyRelitScene(context, relit); });
    setLightRotation(relit, lightRotation(options.scene.lightYaw, options.scene.lightPitch));
    const VkExtent2D extent{width, height};
    const glm::mat4 clipFromWorld =
        cameraProjection(orbitSceneCamera(mesh.world, options.yaw, options.pitch), extent, relit.nearPlane);
    const Clock::time_point start = Clock::now();
    const RenderedImage image =
        renderRelit(context, relit, clipFromWorld, extent, autoExposure(light) * std::exp2(options.exposure));
    const double milliseconds = millisecondsSince(start);
    if (uint32_t messages = context.validationMessages(); messages > 0)
        throw Error(ErrorKind::Device, counted(messages, "Vulkan validation message") + " (above)");
    writeRenderedImage(options.output, image);
    std::printf("shprobe render: %s relit by %s -> %s (%ux%u)\n", mesh.world.description.c_str(),
                source.name.c_str(), options.output.c_str(), width, height);
    std::printf(
        "  transfer order %d, %s, %d attributes; light turned yaw %.1f, pitch %.1f deg on the device\n",
        mesh.order, mesh.channels == 3 ? "RGB" : "grey", mesh.attributes, double(options.scene.lightYaw),
        double(options.scene.lightPitch));
    std::printf("  time     render %.1f ms\n", milliseconds);
}

} // namespace shprobe
