// `shprobe scene` and `shprobe merge` end to end, on lavapipe with the validation layer on: a
// Cornell box written by the test (scene_fixtures.h) baked whole and in bricks, the bricks merged
// to the whole bake byte for byte, bounce after bounce; a real scene (Debian's assimp-testmodels)
// baked; and every broken glTF there refused in one line, leaving no file.
#include "child_program.h"
#include "scene_fixtures.h"

#include "formats/probe_volume.h"
#include "image/environment.h"

#include <glm/geometric.hpp>

#include <gtest/gtest.h>

namespace shprobe {
namespace {

class SceneCommand : public ProgramTest {
  protected:
    std::string cornellBox() const {
        const std::string path = file("cornell.glb");
        testing::writeCornellBoxGltf(path, {.closed = true, .innerBoxes = true});
        return path;
    }
};

std::string bytesOf(const std::string& path) {
    return readText(path);
}

// Bricks bake one bounce each: bounce 0 in three bricks, merged, must be the whole bounce-0 bake
// byte for byte (each probe's capture and bake do not depend on which probes share its batch); so
// must bounce 1 in bricks reading the merged bounce 0 (--previous), against the whole --bounces 1
// bake. The grid is 3x3x3 inside the box, faces 16^2: small enough for lavapipe, and the bricks
// cut through batches of 4 probes.
TEST_F(SceneCommand, BricksMergeToTheWholeBake) {
    const std::string scene = cornellBox();
    const std::vector<std::string> common{
        "scene", scene, "--grid", "3,3,3", "--face-size", "16", "--probes-per-batch", "4", "-q"};
    auto bake = [&](std::vector<std::string> extra, const std::string& output) {
        std::vector<std::string> args = common;
        args.insert(args.end(), extra.begin(), extra.end());
        args.insert(args.end(), {"-o", output});
        runOk(args);
    };
    bake({"--bounces", "0"}, file("whole0.shpv"));
    bake({"--bounces", "1"}, file("whole1.shpv"));
    std::vector<std::string> merge0{"merge"}, merge1{"merge"};
    for (const char* brick : {"2/3", "0/3", "1/3"}) {
        const std::string name = file(std::string("b0_") + brick[0] + ".shpv");
        bake({"--brick", brick}, name);
        merge0.push_back(name);
    }
    std::vector<std::string> args = merge0;
    args.insert(args.end(), {"-o", file("merged0.shpv")});
    runOk(args);
    EXPECT_EQ(bytesOf(file("merged0.shpv")), bytesOf(file("whole0.shpv")));
    for (const char* brick : {"1/3", "0/3", "2/3"}) {
        const std::string name = file(std::string("b1_") + brick[0] + ".shpv");
        bake({"--brick", brick, "--previous", file("merged0.shpv")}, name);
        merge1.push_back(name);
    }
    merge1.insert(merge1.end(), {"-o", file("merged1.shpv")});
    runOk(merge1);
    EXPECT_EQ(bytesOf(file("merged1.shpv")), bytesOf(file("whole1.shpv")));

    // The closed box's light reaches every probe, and bounce 1 adds light to bounce 0 everywhere.
    const ProbeVolume zero = readProbeVolume(file("whole0.shpv"));
    const ProbeVolume one = readProbeVolume(file("whole1.shpv"));
    ASSERT_EQ(zero.probeCount(), 27u);
    EXPECT_EQ(one.bounces, 1);
    for (uint32_t p = 0; p < zero.probeCount(); ++p) {
        if (!zero.valid[p]) continue; // inside an inner block
        EXPECT_GT(one.radiance[p * 9].g, zero.radiance[p * 9].g) << "probe " << p;
    }
}

// The real engine model bakes with the defaults but a small grid; some probes lie inside its parts
// and are reported invalid, others not.
TEST_F(SceneCommand, RealSceneBakes) {
    const std::string engine = SHPROBE_GLTF_MODELS_DIR "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
    const RunResult result = runOk({"scene", engine, "--grid", "2,2,2", "--face-size", "8", "--bounces", "0",
                                    "-o", file("engine.shpv")});
    EXPECT_CONTAINS(result.out, "121496 triangles");
    const ProbeVolume volume = readProbeVolume(file("engine.shpv"));
    EXPECT_EQ(volume.probeCount(), 8u);
}

// `shprobe render --scene` draws the scene lit by its volume: the surfaces reflect the volume's
// irradiance (the Cornell box's walls are lit, so the picture is not black), and --show-probes adds
// the probes' spheres (the picture changes). A brick is refused, and so are --scene without
// --volume, the sphere's options (--order, --grid, --face-size) with it, and the scene's options
// (--volume, --sky, --show-probes) without it.
TEST_F(SceneCommand, RenderDrawsTheSceneLitByItsVolume) {
    const std::string scene = file("open.glb");
    testing::writeCornellBoxGltf(scene, {.innerBoxes = true});
    runOk({"scene", scene, "--grid", "3,3,3", "--face-size", "16", "--bounces", "1", "-q", "-o",
           file("v.shpv")});
    runOk({"scene", scene, "--grid", "3,3,3", "--face-size", "16", "--brick", "0/2", "-q", "-o",
           file("brick.shpv")});
    runOk(
        {"render", "--scene", scene, "--volume", file("v.shpv"), "--size", "64x48", "-o", file("plain.exr")});
    runOk({"render", "--scene", scene, "--volume", file("v.shpv"), "--size", "64x48", "--show-probes", "-o",
           file("probes.exr")});
    const Image plain = readImage(file("plain.exr")), probes = readImage(file("probes.exr"));
    ASSERT_EQ(plain.width, 64);
    size_t lit = 0, changed = 0;
    for (size_t t = 0; t < plain.texels.size(); ++t) {
        lit += glm::length(glm::vec3(plain.texels[t])) > 0.0f;
        changed += glm::vec3(plain.texels[t]) != glm::vec3(probes.texels[t]);
    }
    EXPECT_GT(lit, plain.texels.size() / 2);
    EXPECT_GT(changed, 0u);
    expectFailure({{"render", "--scene", scene, "-o", "OUT"}, 2, {"--volume"}, "out.png"});
    for (const std::vector<std::string>& sphereOnly :
         std::vector<std::vector<std::string>>{{"--order", "5"}, {"--grid"}, {"--face-size", "16"}}) {
        std::vector<std::string> args{"render", "--scene", scene, "--volume", file("v.shpv"), "-o", "OUT"};
        args.insert(args.end(), sphereOnly.begin(), sphereOnly.end());
        expectFailure({args, 2, {sphereOnly[0]}, "out.png"});
    }
    // The scene's options without a scene would be ignored: they are refused.
    for (const std::vector<std::string>& sceneOnly : std::vector<std::vector<std::string>>{
             {"--sky", scene}, {"--show-probes"}, {"--volume", file("v.shpv")}}) {
        std::vector<std::string> args{"render", "-o", "OUT"};
        args.insert(args.end(), sceneOnly.begin(), sceneOnly.end());
        expectFailure({args, 2, {sceneOnly[0], "--scene"}, "out.png"});
    }
    expectFailure(
        {{"render", "--scene", scene, "--volume", file("brick.shpv"), "-o", "OUT"}, 2, {"brick"}, "out.png"});
}

// Each broken glTF of assimp-testmodels: one line naming the file, exit 2, nothing written.
TEST_F(SceneCommand, BrokenScenesAreRefused) {
    const std::string models = SHPROBE_GLTF_MODELS_DIR;
    for (const char* broken :
         {"/IndexOutOfRange/IndexOutOfRange.gltf", "/IndexOutOfRange/AllIndicesOutOfRange.gltf",
          "/MissingBin/BoxTextured.gltf", "/RecursiveNodes/RecursiveNodes.gltf",
          "/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "/IncorrectVertexArrays/Box.gltf",
          "/wrongTypes/badArray.gltf"})
        expectFailure(
            {{"scene", models + broken, "--grid", "2,2,2", "-o", "OUT"}, 2, {models + broken}, "out.shpv"});
}

// Bad options get one line each before any work: a grid that is not three counts, bricks without a
// whole previous bounce's volume, --bounces with --brick.
TEST_F(SceneCommand, BadOptionsAreRefused) {
    const std::string scene = cornellBox();
    expectFailure({{"scene", scene, "--grid", "3,3", "-o", "OUT"}, 2, {"--grid"}, "out.shpv"});
    expectFailure(
        {{"scene", scene, "--grid", "2,2,2", "--brick", "2/2", "-o", "OUT"}, 2, {"--brick"}, "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "2,2,2", "--brick", "0/2", "--bounces", "2", "-o", "OUT"},
                   2,
                   {"--bounces"},
                   "out.shpv"});
    expectFailure(
        {{"scene", scene, "--grid", "2,2,2", "--previous", scene, "-o", "OUT"}, 2, {scene}, "out.shpv"});
}

} // namespace
} // namespace shprobe
