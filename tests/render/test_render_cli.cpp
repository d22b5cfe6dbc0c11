// `shprobe render` and `shprobe view` end to end, as child processes on lavapipe with the
// validation layer on (SHPROBE_VALIDATION=1 from ctest): the images written, the grid, every bad
// probe file and bad option (exit code 2, one error line naming the file and the field, no output
// left behind), and the viewer without a display. The viewer with a display: test_render_viewer.
#include "run_program.h"
#include "test_inputs.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

namespace shprobe::testing {
namespace {

namespace fs = std::filesystem;

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "in: " << (text)

struct ImageInfo {
    int width = 0, height = 0, channels = 0;
    bool floating = false;
};

ImageInfo imageInfo(const std::string& path) {
    std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path);
    if (!input) return {};
    const OIIO::ImageSpec& spec = input->spec();
    return {spec.width, spec.height, spec.nchannels, spec.format.is_floating_point()};
}

class RenderCli : public ::testing::Test {
  protected:
    TemporaryFolder folder{"shprobe_render_cli"};
    fs::path logs() const { return folder.path() / "logs"; }
    RunResult run(const std::vector<std::string>& args, const EnvironmentChanges& changes = {}) {
        return runProgram(args, logs(), changes);
    }
    // Exit code 2 and a single line "shprobe: error: ..." holding every part; no output written.
    void expectInputError(const std::vector<std::string>& args, const std::vector<std::string>& parts,
                          const std::string& output) {
        RunResult result = run(args);
        EXPECT_EQ(result.exitCode, 2) << describe(result);
        EXPECT_EQ(result.err.rfind("shprobe: error: ", 0), 0u) << describe(result);
        EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << describe(result);
        for (const std::string& part : parts)
            EXPECT_CONTAINS(result.err, part);
        EXPECT_FALSE(fs::exists(output)) << output;
    }
};

TEST_F(RenderCli, ProbeToPngAndExr) {
    std::string probe = folder / "probe.json";
    writeProbeFile(probe, testProbe(5), {});
    RunResult png = run({"render", probe, "--order", "5", "--size", "40x30", "-o", folder / "sphere.png"});
    ASSERT_EQ(png.exitCode, 0) << describe(png);
    EXPECT_CONTAINS(png.out, "shprobe render: " + probe);
    EXPECT_CONTAINS(png.out, "order 5, irradiance, background radiance");
    ImageInfo pngInfo = imageInfo(folder / "sphere.png");
    EXPECT_EQ(pngInfo.width, 40);
    EXPECT_EQ(pngInfo.height, 30);
    EXPECT_EQ(pngInfo.channels, 3);
    EXPECT_FALSE(pngInfo.floating);

    RunResult exr =
        run({"render", probe, "--mode", "l1-nonlinear", "--size", "24", "-o", folder / "sphere.exr"});
    ASSERT_EQ(exr.exitCode, 0) << describe(exr);
    ImageInfo exrInfo = imageInfo(folder / "sphere.exr");
    EXPECT_EQ(exrInfo.width, 24);
    EXPECT_EQ(exrInfo.height, 24);
    EXPECT_TRUE(exrInfo.floating) << "EXR keeps the linear floats";
}

TEST_F(RenderCli, EnvironmentIsBakedFirstAndTheGridHasSixCells) {
    std::string environment = folder / "env.exr";
    writeTestEnvironment(environment);
    RunResult single = run({"render", environment, "--size", "32", "-o", folder / "env.png"});
    ASSERT_EQ(single.exitCode, 0) << describe(single);
    EXPECT_CONTAINS(single.out, "background environment");
    EXPECT_CONTAINS(single.out, "bake ");

    RunResult grid = run({"render", environment, "--grid", "--size", "48", "-o", folder / "grid.png"});
    ASSERT_EQ(grid.exitCode, 0) << describe(grid);
    ImageInfo info = imageInfo(folder / "grid.png");
    EXPECT_EQ(info.width, 3 * 48) << "three columns of cells 48 wide";
    EXPECT_EQ(info.height, 2 * 24) << "two rows of cells 24 high";
}

TEST_F(RenderCli, BadProbeFilesNameTheFileAndTheField) {
    const std::string header = R"("format": "shprobe.sh", "version": 1, )";
    const std::string rows =
        R"("coefficients": [[1,1,1],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0]])";
    struct BadFile {
        const char* name;
        std::string text;
        std::string field;
    };
    const BadFile files[] = {
        {"count.json",
         "{" + header +
             R"("convention": "real-orthonormal-condon-shortley", "order": 3, "quantity": "radiance", )" +
             R"("coefficients": [[1,1,1],[0,0,0]]})",
         "\"coefficients\""},
        {"convention.json",
         "{" + header + R"("convention": "real-orthonormal-no-phase", "order": 3, "quantity": "radiance", )" +
             rows + "}",
         "\"convention\""},
        {"quantity.json",
         "{" + header +
             R"("convention": "real-orthonormal-condon-shortley", "order": 3, "quantity": "luminance", )" +
             rows + "}",
         "\"quantity\""},
        {"malformed.json", "{" + header + R"("order": 3, "coefficients": [[1,1,1], )", "not valid JSON"},
    };
    for (const BadFile& file : files) {
        std::string path = folder / file.name;
        writeText(path, file.text);
        expectInputError({"render", path, "-o", folder / "out.png"}, {path, file.field}, folder / "out.png");
    }
}

TEST_F(RenderCli, BadOptionsAreRefusedBeforeAnyOutput) {
    std::string order3 = folder / "order3.json";
    writeProbeFile(order3, testProbe(3), {});
    std::string irradiance5 = folder / "irradiance5.json";
    writeProbeFile(irradiance5, testProbe(5, Quantity::Irradiance), {});
    std::string out = folder / "out.png";
    expectInputError({"render", order3, "--order", "5", "-o", out}, {order3, "order 3", "order 5"}, out);
    expectInputError({"render", order3, "-o", folder / "out.bmp"}, {"out.bmp", ".exr", ".png"},
                     folder / "out.bmp");
    expectInputError({"render", irradiance5, "--order", "5", "--mode", "radiance", "-o", out}, {"irradiance"},
                     out);
    expectInputError({"render", order3, "--background", "environment", "-o", out}, {"environment"}, out);
    expectInputError({"render", folder / "missing.exr", "-o", out}, {"missing.exr"}, out);
    expectInputError({"render", order3, "--size", "0", "-o", out}, {"--size"}, out);
    expectInputError({"render", order3, "--grid", "-o", out}, {"order 5"}, out);
}

TEST_F(RenderCli, ViewWithoutADisplaySaysSoAndPointsToRender) {
    RunResult result =
        run({"view", "--frames", "1"}, {{"DISPLAY", std::nullopt}, {"WAYLAND_DISPLAY", std::nullopt}});
    EXPECT_EQ(result.exitCode, 4) << describe(result);
    EXPECT_CONTAINS(result.err, "display");
    EXPECT_CONTAINS(result.err, "shprobe render");
    expectInputError({"view", "--screenshot", folder / "shot.png"}, {"--frames"}, folder / "shot.png");
}

} // namespace
} // namespace shprobe::testing
