// `shprobe render` and `shprobe view` end to end, as child processes on lavapipe with the
// validation layer on (SHPROBE_VALIDATION=1 from ctest): the images written, the grid, every bad
// probe file and bad option (exit code 2, one error line naming the file and the field, no output
// left behind), the sun of `bake --extract-sun` added back by `render`, and the viewer without a
// display. The viewer with a display: test_render_viewer.
#include "run_program.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "test_inputs.h"

#include <OpenImageIO/imageio.h>
#include <glm/trigonometric.hpp>
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

    // Extensions are told apart case aside, as the tools that name such files do.
    fs::copy_file(probe, folder / "PROBE.JSON");
    RunResult upper = run({"render", folder / "PROBE.JSON", "--size", "8", "-o", folder / "SPHERE.PNG"});
    ASSERT_EQ(upper.exitCode, 0) << describe(upper);
    EXPECT_FALSE(imageInfo(folder / "SPHERE.PNG").floating);
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
    EXPECT_CONTAINS(grid.out, "grid     environment | order-3 radiance | order-5 radiance; spheres: "
                              "l1-nonlinear | irradiance 3 | irradiance 5, in front of the environment");
}

// The grid's summary names what its cells show where a probe file stands in for the environment:
// the order-5 E/pi map top left, and E/pi maps for an irradiance probe of order 5, which has no
// order-5 radiance (A_3 = 0). It said "environment | order 3 | order 5" for every input.
TEST_F(RenderCli, TheGridSaysWhatItsCellsShow) {
    const std::string radiance = folder / "radiance5.json", irradiance = folder / "irradiance5.json";
    writeProbeFile(radiance, testProbe(5), {});
    writeProbeFile(irradiance, testProbe(5, Quantity::Irradiance), {});
    RunResult grid = run({"render", radiance, "--grid", "--size", "16", "-o", folder / "grid.png"});
    ASSERT_EQ(grid.exitCode, 0) << describe(grid);
    EXPECT_CONTAINS(grid.out, "grid     order-5 E/pi | order-3 radiance | order-5 radiance; spheres: "
                              "l1-nonlinear | irradiance 3 | irradiance 5, in front of the radiance");
    grid = run({"render", irradiance, "--grid", "--size", "16", "-o", folder / "grid.png"});
    ASSERT_EQ(grid.exitCode, 0) << describe(grid);
    EXPECT_CONTAINS(grid.out, "grid     order-5 E/pi | order-3 E/pi | order-5 E/pi; spheres: "
                              "l1-nonlinear | irradiance 3 | irradiance 5, in front of the color");
}

// ---- The sun: bake --extract-sun, then render -------------------------------------------------

struct LinearImage {
    int width = 0, height = 0;
    std::vector<float> rgb; // 3 floats per pixel
    glm::dvec3 at(size_t p) const { return {rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2]}; }
};

LinearImage readExr(const std::string& path) {
    LinearImage image;
    std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path);
    if (!input) return image;
    image.width = input->spec().width;
    image.height = input->spec().height;
    std::vector<float> all(size_t(image.width) * image.height * input->spec().nchannels);
    input->read_image(0, 0, 0, -1, OIIO::TypeDesc::FLOAT, all.data());
    for (size_t p = 0; p < size_t(image.width) * image.height; ++p)
        for (int c = 0; c < 3; ++c)
            image.rgb.push_back(all[p * input->spec().nchannels + c]);
    return image;
}

// Radiance at order 3 needs bands 0..2, which an irradiance probe of any order gives back (E / A_l,
// A_l != 0 for l <= 2): an order-5 irradiance probe draws the same picture as its first 9
// coefficients alone, and as the radiance probe it was made from. It was refused ("band 3 is
// lost"), which only order 5 needs.
TEST_F(RenderCli, AnIrradianceProbeOfOrder5HasRadianceAtOrder3) {
    const ShCoefficients radiance = testProbe(5);
    ShCoefficients irradiance = convolveIrradiance(radiance), first9 = irradiance;
    first9.order = 3;
    first9.rgb.resize(9);
    const std::string files[] = {folder / "radiance5.json", folder / "irradiance5.json",
                                 folder / "irradiance3.json"};
    writeProbeFile(files[0], radiance, {});
    writeProbeFile(files[1], irradiance, {});
    writeProbeFile(files[2], first9, {});
    std::vector<LinearImage> images;
    for (const std::string& file : files) {
        const std::string out = file + ".exr";
        RunResult result =
            run({"render", file, "--order", "3", "--mode", "radiance", "--size", "24", "-o", out});
        ASSERT_EQ(result.exitCode, 0) << describe(result);
        images.push_back(readExr(out));
    }
    ASSERT_EQ(images[0].rgb.size(), 24u * 24u * 3u);
    double worst = 0.0;
    for (size_t i = 0; i < images[0].rgb.size(); ++i) {
        EXPECT_EQ(images[1].rgb[i], images[2].rgb[i]) << "float " << i;
        worst = std::max(worst, double(std::abs(images[1].rgb[i] - images[0].rgb[i])));
    }
    EXPECT_LT(worst, 1e-5) << "E / A_l gives the radiance back, to float rounding";
}

// The largest error, as a fraction of the light's power, of the order-n irradiance of a delta light:
// max over cos of |sum_{l<n} A_l (2l+1)/(4pi) P_l(cos) - max(0, cos)| (3/32 at order 3, at the
// terminator).
double deltaIrradianceWorstError(int order) {
    double worst = 0.0;
    for (int k = 0; k <= 20000; ++k) {
        double x = -1.0 + 2.0 * k / 20000.0, previous = 1.0, legendre = x, sum = 0.0;
        for (int l = 0; l < order; ++l) {
            double p = l == 0 ? 1.0 : legendre;
            sum += irradianceBandFactor(l) * (2 * l + 1) / (4.0 * M_PI) * p;
            if (l >= 1) {
                double next = ((2 * l + 1) * x * legendre - l * previous) / (l + 1);
                previous = legendre;
                legendre = next;
            }
        }
        worst = std::max(worst, std::abs(sum - std::max(x, 0.0)));
    }
    return worst;
}

// The built-in sky baked whole (full.json) and with its sun taken out (rest.json, with "sun"),
// rendered to EXR from the sun's side, and rest.json without its "sun" field (nosun.json):
//  - rest - nosun is what the renderer adds: at the pixel facing the sun, albedo L sin^2 r, the exact
//    irradiance of the cap over pi (the pixel's normal is within 0.3 degree of the sun: cos >
//    0.99998, and the sky under it is the same in both);
//  - full - rest is the SH truncation error of the sun alone, since both hold the same sky and the
//    same sun power (P = L 2 pi (1 - cos r)): the full probe has the sun as an order-n expansion of an
//    almost-delta light (1.1 degrees: its bands 0..4 are those of a delta within l(l+1) r^2 / 4 <
//    2e-3), rest the exact cap. Facing the sun that is (s_n - 1) P / pi = +1/16 at order 3 and
//    -1/32 at order 5 of the sun's peak (Sloan's 17/16 and 31/32), and nowhere more than the delta
//    light's worst error, 3/32 at order 3 (at the terminator), which a view from 90 degrees to the
//    side shows. What else differs (the fill of the sun's texels by the ring around them against the
//    sky they covered, the cap against a delta, fp32) measures 5e-5 of the sun's peak; the test
//    allows 2e-3 at the facing pixel and 1e-2 over the image.
TEST_F(RenderCli, ExtractedSunIsAddedBackAnalytically) {
    std::string full = folder / "full.json", rest = folder / "rest.json", nosun = folder / "nosun.json";
    RunResult bake = run({"bake", "--order", "5", "-q", "-o", full});
    ASSERT_EQ(bake.exitCode, 0) << describe(bake);
    bake = run({"bake", "--order", "5", "-q", "--extract-sun", "-o", rest});
    ASSERT_EQ(bake.exitCode, 0) << describe(bake);
    Probe probe = readProbe(rest);
    ASSERT_TRUE(probe.sun.has_value());
    writeProbeFile(nosun, probe.coefficients, {});
    const ProbeSun& sun = *probe.sun;
    const double s = std::sin(sun.angularRadius), albedo = 0.8; // the sphere's albedo (scene.h)
    const glm::dvec3 peak = albedo * sun.radiance * s * s;      // albedo E_sun / pi facing the sun
    const double power = 2.0 * (1.0 - std::cos(sun.angularRadius)) / (s * s); // P / (pi L s^2)

    const double sunYaw = glm::degrees(std::atan2(sun.direction.x, sun.direction.z));
    const std::string pitch = std::to_string(glm::degrees(std::asin(sun.direction.y)));
    for (int order : {3, 5}) {
        const double expectedTruncation = (deltaLightPeak(order) - 1.0) * power;
        const double bound = deltaIrradianceWorstError(order) * power;
        for (double yawOffset : {0.0, 90.0}) {
            auto render = [&](const std::string& input, const std::string& name) {
                std::string output = folder / (name + std::to_string(order) + ".exr");
                RunResult result = run({"render", input, "--order", std::to_string(order), "--size", "256",
                                        "--background", "color", "--yaw", std::to_string(sunYaw + yawOffset),
                                        "--pitch", yawOffset == 0.0 ? pitch : "0", "-o", output});
                EXPECT_EQ(result.exitCode, 0) << describe(result);
                return readExr(output);
            };
            LinearImage withSun = render(rest, "rest"), whole = render(full, "full");
            ASSERT_EQ(withSun.rgb.size(), size_t(256 * 256 * 3));
            ASSERT_EQ(whole.rgb.size(), withSun.rgb.size());
            double worst = 0.0; // the largest |full - rest| anywhere
            for (size_t p = 0; p < size_t(256 * 256); ++p)
                for (int c = 0; c < 3; ++c)
                    worst = std::max(worst, std::abs(whole.at(p)[c] - withSun.at(p)[c]) / peak[c]);
            std::printf("  order %d, view %2.0f deg from the sun: worst |full - rest| %.4f of the sun's peak "
                        "(bound %.4f + 0.01)\n",
                        order, yawOffset, worst, bound);
            EXPECT_LT(worst, bound + 0.01) << "order " << order;
            if (yawOffset != 0.0) {
                EXPECT_GT(worst, bound - 0.01) << "the terminator, where the truncation error peaks, shows";
                continue;
            }
            // Facing the sun: the pixel the sun adds most to.
            LinearImage withoutSun = render(nosun, "nosun");
            ASSERT_EQ(withoutSun.rgb.size(), withSun.rgb.size());
            size_t brightest = 0;
            for (size_t p = 0; p < size_t(256 * 256); ++p)
                if ((withSun.at(p) - withoutSun.at(p)).g >
                    (withSun.at(brightest) - withoutSun.at(brightest)).g)
                    brightest = p;
            glm::dvec3 added = (withSun.at(brightest) - withoutSun.at(brightest)) / peak;
            glm::dvec3 truncation = (whole.at(brightest) - withSun.at(brightest)) / peak;
            std::printf(
                "  order %d: facing the sun it adds (%.6f %.6f %.6f) of albedo L sin^2 r; full - rest "
                "there (%.5f %.5f %.5f), expected %.5f\n",
                order, added.r, added.g, added.b, truncation.r, truncation.g, truncation.b,
                expectedTruncation);
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(added[c], 1.0, 1e-4) << "order " << order << " channel " << c;
                EXPECT_NEAR(truncation[c], expectedTruncation, 2e-3) << "order " << order << " channel " << c;
            }
        }
    }
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
        // Light the shaders' float sums cannot hold, which they would draw as infinity: a coefficient
        // past float, a sun past it, and an irradiance probe within float whose radiance, E / A_2,
        // is not (3e38 / (pi / 4)).
        {"beyond-float.json",
         "{" + header +
             R"("convention": "real-orthonormal-condon-shortley", "order": 3, "quantity": "radiance", )" +
             R"("coefficients": [[1,1,1],[0,0,0],[0,-4e38,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0]]})",
         "its light is past the float range the shaders take"},
        {"sun-beyond-float.json",
         "{" + header +
             R"("convention": "real-orthonormal-condon-shortley", "order": 3, "quantity": "radiance", )" +
             rows +
             R"(, "sun": {"direction": [0,1,0], "radiance": [1e39,1,1], "angular_radius_degrees": 1}})",
         "its light is past the float range the shaders take"},
        {"irradiance-beyond-float.json",
         "{" + header +
             R"("convention": "real-orthonormal-condon-shortley", "order": 3, "quantity": "irradiance", )" +
             R"("coefficients": [[1,1,1],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[3e38,0,0],[0,0,0],[0,0,0]]})",
         "its light is past the float range the shaders take"},
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
    // Options the picture would not use were ignored, exit 0: the grid's cells have their own orders,
    // modes, backgrounds and camera, and a probe file is not baked into a cube map.
    std::string order5 = folder / "order5.json";
    writeProbeFile(order5, testProbe(5), {});
    for (const char* option : {"--order", "--mode", "--background", "--yaw", "--pitch"}) {
        const std::string value = option == std::string("--order")        ? "3"
                                  : option == std::string("--mode")       ? "radiance"
                                  : option == std::string("--background") ? "color"
                                                                          : "10";
        expectInputError({"render", order5, "--grid", option, value, "-o", out}, {"--grid", option}, out);
    }
    expectInputError({"render", order3, "--face-size", "8", "-o", out}, {"--face-size", order3, "probe file"},
                     out);
    // A target larger than one allocation may hold (3 GiB at 16384x12288 against lavapipe's 2 GiB,
    // the device the tests run on): the advice names the option that sizes it.
    const std::string exr = folder / "out.exr";
    const RunResult huge = run({"render", order3, "--size", "16384x12288", "-o", exr});
    EXPECT_EQ(huge.exitCode, 4) << describe(huge);
    EXPECT_CONTAINS(huge.err, "try a smaller --size");
    EXPECT_FALSE(fs::exists(exr));
}

// Sizes the output's format cannot hold are refused before any work (stb_image_write's PNG, JPEG
// and HDR count bytes in int: at most 134217727 RGB pixels), the grid's whole picture counted; EXR
// has no such limit. Sizes whose render targets the device cannot create (lavapipe: RGBA32F of at
// most 4294967295 bytes, one byte short of 16384^2 texels) are refused before the image is made.
TEST_F(RenderCli, SizesTheFormatOrTheDeviceCannotHoldAreRefusedFirst) {
    std::string order5 = folder / "order5.json";
    writeProbeFile(order5, testProbe(5), {});
    for (const char* name : {"big.png", "big.jpg", "big.hdr"}) {
        const std::string out = folder / name;
        expectInputError(
            {"render", order5, "--size", "16384x8192", "-o", out},
            {"--size 16384x8192", out, "16384x8192, 134217728 pixels", "at most 134217727 pixels"}, out);
    }
    const std::string grid = folder / "grid.png";
    expectInputError({"render", order5, "--grid", "--size", "8192", "-o", grid},
                     {"--size 8192 with --grid", "24576x8192", "at most 134217727 pixels"}, grid);
    const std::string exr = folder / "big.exr";
    expectInputError({"render", order5, "--size", "16384", "-o", exr},
                     {"--size 16384x16384", "RGBA32F render targets", "4294967295 bytes", "4294967296 bytes"},
                     exr);
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
