// The viewer in a real window: ctest runs this under xvfb-run, so GLFW opens an X window and
// lavapipe presents to it through a swapchain. Each test runs `shprobe view` as a child (validation
// on) with --frames and --screenshot, and compares the saved frame with the offscreen renderer's
// image of the same view, rendered here: the two must be the same bytes (both go through the same
// scene pass and tonemap shader; only the target differs, BGRA swapchain vs RGBA image).
#include "render_test.h"
#include "run_program.h"
#include "scene_fixtures.h"
#include "test_inputs.h"

#include "render/render_input.h"
#include "render/view_state.h"
#include "sh/rotation.h"

#include <OpenImageIO/imageio.h>
#include <cstdlib>

namespace shprobe::testing {
namespace {

struct Screenshot {
    int width = 0, height = 0;
    std::vector<uint8_t> rgb;
};

Screenshot readScreenshot(const std::string& path) {
    Screenshot shot;
    std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path);
    if (!input) return shot;
    shot.width = input->spec().width;
    shot.height = input->spec().height;
    shot.rgb.resize(size_t(shot.width) * shot.height * 3);
    input->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, shot.rgb.data());
    return shot;
}

// Largest difference of any channel of any pixel.
int largestDifference(const Screenshot& shot, const RenderedImage& image) {
    int worst = 0;
    for (size_t p = 0; p < shot.rgb.size() / 3; ++p)
        for (int c = 0; c < 3; ++c)
            worst = std::max(
                worst, std::abs(int(shot.rgb[p * 3 + size_t(c)]) - int(image.display[p * 4 + size_t(c)])));
    return worst;
}

// Largest difference of any channel of any pixel of two pictures of one size.
int largestDifference(const Screenshot& a, const Screenshot& b) {
    int worst = 0;
    for (size_t i = 0; i < a.rgb.size(); ++i)
        worst = std::max(worst, std::abs(int(a.rgb[i]) - int(b.rgb[i])));
    return worst;
}

class Viewer : public RenderTest {
  protected:
    TemporaryFolder folder{"shprobe_render_viewer"};

    void runOk(const std::vector<std::string>& args) {
        RunResult result = runProgram(args, folder.path() / "logs");
        EXPECT_EQ(result.exitCode, 0) << describe(result);
    }

    Screenshot runViewer(const std::vector<std::string>& args) {
        if (!std::getenv("DISPLAY")) {
            ADD_FAILURE() << "no DISPLAY: run this test under xvfb-run (ctest does)";
            return {};
        }
        std::string shot = folder / "shot.png";
        std::vector<std::string> all{"view"};
        all.insert(all.end(), args.begin(), args.end());
        all.insert(all.end(), {"--size", "160x120", "--screenshot", shot});
        RunResult result = runProgram(all, folder.path() / "logs");
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_NE(result.out.find("saved to " + shot), std::string::npos) << describe(result);
        return readScreenshot(shot);
    }

    // The offscreen image of `view` lit by `probe` in front of `environment` (if any).
    RenderedImage renderView(const ShCoefficients& probe, const ShCoefficients& exposureProbe,
                             const Cubemap* environment, const ViewState& view, const Screenshot& size) {
        setProbe(renderer().scene, foldProbe(probe, 5, "probe"));
        if (environment) setEnvironment(context(), renderer().scene, *environment);
        float exposure = autoExposure(exposureProbe) * std::exp2(view.exposureStops);
        return renderOffscreen(context(), renderer(), viewScene(view),
                               {uint32_t(size.width), uint32_t(size.height)}, exposure);
    }
};

TEST_F(Viewer, ScreenshotIsTheOffscreenRenderOfTheSameView) {
    std::string environment = folder / "env.exr";
    writeTestEnvironment(environment);
    Screenshot shot = runViewer({environment, "--frames", "3"});
    ASSERT_EQ(shot.width, 160);
    ASSERT_EQ(shot.height, 120);

    RenderInput input = loadRenderInput(context(), environment, {}); // the same deterministic GPU bake
    RenderedImage image = renderView(input.probe, input.probe, &*input.environment, ViewState{}, shot);
    EXPECT_EQ(largestDifference(shot, image), 0);
}

TEST_F(Viewer, KeysChangeOrderModeAndRotateTheEnvironment) {
    std::string environment = folder / "env.exr";
    writeTestEnvironment(environment);
    Screenshot shot = runViewer({environment, "--keys", "5,m,right,+", "--frames", "5"});
    ASSERT_EQ(shot.width, 160);

    RenderInput input = loadRenderInput(context(), environment, {});
    ViewState view;
    view.order = 5;
    view.shading = ShadingMode::L1NonLinear;
    view.environmentRotationDegrees = 15.0f;
    view.exposureStops = 0.5f;
    Cubemap rotated = rotateCubemap(*input.environment, environmentRotation(15.0f));
    ProbeBaker baker = createRenderBaker(context());
    double milliseconds = 0.0;
    ShCoefficients probe = bakeRadiance(context(), baker, rotated, milliseconds);
    destroyProbeBaker(context(), baker);
    RenderedImage image = renderView(probe, input.probe, &rotated, view, shot);
    EXPECT_EQ(largestDifference(shot, image), 0);

    RenderedImage unrotated = renderView(input.probe, input.probe, &*input.environment, view, shot);
    EXPECT_GT(largestDifference(shot, unrotated), 10) << "the rotation shows";
}

TEST_F(Viewer, ProbeFilesRotateTheirCoefficients) {
    std::string path = folder / "probe.json";
    ShCoefficients probe = testProbe(5);
    writeProbeFile(path, probe, {});
    Screenshot shot = runViewer({path, "--keys", "left", "--frames", "2"});
    ASSERT_EQ(shot.width, 160);

    ViewState view;
    view.background = Background::Radiance; // a probe file has no environment
    view.environmentRotationDegrees = -15.0f;
    ShCoefficients rotated = rotate(makeShRotation(environmentRotation(-15.0f), 5), probe);
    RenderedImage image = renderView(rotated, probe, nullptr, view, shot);
    EXPECT_EQ(largestDifference(shot, image), 0);
}

// A scene lit by its volume: the viewer's frame, after P (probes shown) and + (half a stop up), is
// `shprobe render --scene` of the same view (the viewer starts at yaw 35, pitch 15) byte for byte:
// the same capture view pass and tonemap. The picture without the probes differs, so P took effect.
TEST_F(Viewer, SceneScreenshotIsTheSceneRenderOfTheSameView) {
    const std::string scene = folder / "cornell.glb", volume = folder / "v.shpv";
    writeCornellBoxGltf(scene, {.innerBoxes = true});
    runOk({"scene", scene, "--grid", "2,2,2", "--face-size", "16", "--bounces", "1", "-q", "-o", volume});
    Screenshot shot = runViewer({"--scene", scene, "--volume", volume, "--keys", "p,+", "--frames", "3"});
    ASSERT_EQ(shot.width, 160);

    const std::vector<std::string> render{"render", "--scene",    scene,   "--volume", volume,
                                          "--size", "160x120",    "--yaw", "35",       "--pitch",
                                          "15",     "--exposure", "0.5"};
    std::vector<std::string> withProbes = render, withoutProbes = render;
    withProbes.insert(withProbes.end(), {"--show-probes", "-o", folder / "probes.png"});
    withoutProbes.insert(withoutProbes.end(), {"-o", folder / "plain.png"});
    runOk(withProbes);
    runOk(withoutProbes);
    const Screenshot probes = readScreenshot(folder / "probes.png"),
                     plain = readScreenshot(folder / "plain.png");
    ASSERT_EQ(probes.width, 160);
    ASSERT_EQ(plain.width, 160);
    EXPECT_EQ(largestDifference(shot, probes), 0);
    EXPECT_GT(largestDifference(shot, plain), 10) << "the probes show";
}

// A scene relit from its transfer: the viewer's frame after L, L, K (the light turned by 30 degrees
// about +Y and 15 about +X, on the device each frame) is `shprobe render --scene --transfer` with
// --light-yaw 30 --light-pitch 15 of the same view byte for byte: the same relight pass and tonemap.
// The unturned render differs, so the keys took effect.
TEST_F(Viewer, RelitSceneKeysTurnTheLightAsRenderDoes) {
    const std::string box = folder / "box.glb", scene = folder / "relit.glb", probe = folder / "probe.json";
    writeBoxGltf(box, {.albedo = {0.8f, 0.6f, 0.4f}, .inwardFacing = false});
    ShCoefficients light = testProbe(3);
    light.rgb[1] = glm::dvec3(-2.0); // mostly from above, so that turning it shows
    writeProbeFile(probe, light, {});
    runOk({"transfer", box, "--model", "unshadowed", "-o", scene});
    Screenshot shot =
        runViewer({"--scene", scene, "--transfer", "--probe", probe, "--keys", "l,right,k", "--frames", "4"});
    ASSERT_EQ(shot.width, 160);

    const std::vector<std::string> render{"render", "--scene", scene,   "--transfer", "--probe", probe,
                                          "--size", "160x120", "--yaw", "35",         "--pitch", "15"};
    std::vector<std::string> turned = render, unturned = render;
    turned.insert(turned.end(), {"--light-yaw", "30", "--light-pitch", "15", "-o", folder / "turned.png"});
    unturned.insert(unturned.end(), {"-o", folder / "unturned.png"});
    runOk(turned);
    runOk(unturned);
    EXPECT_EQ(largestDifference(shot, readScreenshot(folder / "turned.png")), 0);
    EXPECT_GT(largestDifference(shot, readScreenshot(folder / "unturned.png")), 10) << "the turn shows";
}

// Scene inputs are checked before a window opens: a scene without its volume, a sphere option
// with a scene, each one line and exit 2.
TEST_F(Viewer, BadSceneInputsAreRefusedBeforeAWindowOpens) {
    const std::string scene = folder / "cornell.glb";
    writeCornellBoxGltf(scene);
    const std::pair<std::vector<std::string>, std::string> cases[] = {
        {{"view", "--scene", scene}, "--volume"},
        {{"view", "--scene", scene, "--volume", scene, "--order", "5"}, "--order"},
        {{"view", "--volume", scene}, "--scene"},
        {{"view", "--show-probes"}, "--scene"},
        {{"view", "--sky", scene}, "--scene"},
    };
    for (const auto& [args, named] : cases) {
        RunResult result = runProgram(args, folder.path() / "logs", {{"DISPLAY", std::nullopt}});
        EXPECT_EQ(result.exitCode, 2) << describe(result);
        EXPECT_NE(result.err.find(named), std::string::npos) << describe(result);
    }
}

} // namespace
} // namespace shprobe::testing
