// The shprobe program end to end: it is run as a child process (child_program.h: arguments passed
// as an argv array so no path is ever parsed by a shell, stdout and stderr captured into files, the
// environment passed explicitly). Checks the bake summary and coefficient table, the files it
// writes (read back with readProbeFile), GPU = CPU through the program, determinism, the exit codes
// and one-line error messages of docs/commands.md, that failures leave no file behind and never touch
// an existing one, `shprobe info`, layout detection, batches (equal to single bakes, chunked or not;
// bad inputs, output folders, ambiguous names, the progress bar on a terminal) and the header
// formats. Test images are written by each test into its own temporary folder; no binary file is
// checked in.
//
// ctest runs this with VK_ICD_FILENAMES = lavapipe and SHPROBE_VALIDATION=1, which the children
// inherit: any validation message fails their bake. Each GPU bake costs a process start with the
// validation layer (~0.3-1 s), so images are tiny and the runs a few dozen.
#include "child_program.h"
#include "common/error.h"
#include "formats/probe_export.h"
#include "formats/probe_file.h"
#include "image/environment.h"
#include "image/image_write.h"
#include "render/run_program.h"
#include "sh/basis.h"
#include "sh/folding.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/rotation.h"
#include "sh/windowing.h"
#include "terminal_run.h"
#include "test_images.h"
#include "vk/context.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <regex>
#include <sstream>
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace shprobe {
namespace {
using testing::filledImage;
namespace fs = std::filesystem;
using testing::EnvironmentChanges;
using testing::readText;
using testing::runOnTerminal;
using testing::TerminalRun;

// ---- Reading what it prints ------------------------------------------------------------------

bool startsWith(const std::string& text, const std::string& prefix) {
    return text.rfind(prefix, 0) == 0;
}

// The rows of the coefficient table printed after the summary: "  l=1 m=-1  r g b".
struct PrintedRow {
    int l, m;
    glm::dvec3 rgb;
};
std::vector<PrintedRow> printedRows(const std::string& out) {
    static const std::regex row(R"(^  l=(\d) m=([+-]\d)\s+(\S+)\s+(\S+)\s+(\S+)$)");
    std::vector<PrintedRow> rows;
    std::smatch match;
    for (const std::string& line : linesOf(out))
        if (std::regex_match(line, match, row))
            rows.push_back({std::stoi(match[1]),
                            std::stoi(match[2]),
                            {std::stod(match[3]), std::stod(match[4]), std::stod(match[5])}});
    return rows;
}

// The file's text from "coefficients" on: the rows as written, byte for byte.
std::string coefficientRowsText(const std::string& json) {
    size_t at = json.find("\"coefficients\"");
    return at == std::string::npos ? std::string() : json.substr(at);
}

// ---- Test images ------------------------------------------------------------------------------

// A smooth, positive, coloured environment with energy in bands 0 to 3, sampled as an equirect.
Image smoothEquirect(int width, int height) {
    return filledImage(width, height, [&](int i, int j) {
        glm::dvec3 d = equirectDirection(i, j, width, height);
        double base = 2.0 + 0.8 * d.x - 0.5 * d.y + 0.6 * d.z + 0.7 * d.x * d.y + 0.3 * d.z * d.z * d.x;
        return glm::vec3(float(base), float(base + 0.4 * d.y), float(0.5 * base - 0.3 * d.x * d.z));
    });
}

// Raw 8-bit RGB through OpenImageIO (writeImage writes floats); PNG pixels are sRGB-encoded bytes.
void writeRgb8(const fs::path& path, int width, int height, const std::vector<uint8_t>& rgb) {
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(output) << OIIO::geterror();
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    ASSERT_TRUE(output->open(path.string(), spec)) << output->geterror();
    ASSERT_TRUE(output->write_image(OIIO::TypeDesc::UINT8, rgb.data())) << output->geterror();
    ASSERT_TRUE(output->close()) << output->geterror();
}

// The exact sRGB EOTF, written here independently of the code under test.
double srgbDecoded(double c) {
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

constexpr double kY00 = 0.28209479177387814; // 1 / (2 sqrt(pi))

// ---- Fixture ----------------------------------------------------------------------------------

// A folder of its own for each test (inputs, outputs and the children's logs), removed afterwards.
// Runs in a folder of its own (ProgramTest, child_program.h); runOk asks for exit 0 and nothing on
// stderr (with the validation layer on, any message would show there and fail the bake anyway).
class Cli : public ProgramTest {};

// ---- 1. The built-in sky ----------------------------------------------------------------------

// `shprobe bake -o OUT.json` (built-in sky, order 3, radiance; the default backend, auto, bakes a
// job this small on the CPU) exits 0, prints the summary and the 9 coefficient rows, and writes a file
// readProbeFile accepts (order 3, radiance, 9 rows) holding the printed values. `--order 5 --irradiance`
// gives 25 rows of E_lm = A_l L_lm.
TEST_F(Cli, BakesTheBuiltInSky) {
    std::string out = file("sky.json");
    RunResult radiance = runOk({"bake", "-o", out});
    EXPECT_CONTAINS(radiance.out, "shprobe bake: built-in sky -> " + out);
    EXPECT_CONTAINS(radiance.out,
                    "backend  cpu: cpu (float, all cores) (auto: a job this small is done on the "
                    "CPU before Vulkan could start)");
    EXPECT_CONTAINS(radiance.out, "6 x 256 x 256 texels, order 3 (9 coefficients)");
    EXPECT_CONTAINS(radiance.out, "radiance coefficients (r g b):");
    std::vector<PrintedRow> rows = printedRows(radiance.out);
    ASSERT_EQ(rows.size(), 9u) << radiance.out;
    for (int i = 0; i < 9; ++i) {
        EXPECT_EQ(rows[i].l, shBand(i));
        EXPECT_EQ(rows[i].m, i - shBand(i) * (shBand(i) + 1));
    }

    ShCoefficients file3 = readProbeFile(out);
    EXPECT_EQ(file3.order, 3);
    EXPECT_EQ(file3.quantity, Quantity::Radiance);
    ASSERT_EQ(file3.rgb.size(), 9u);
    for (int i = 0; i < 9; ++i)
        for (int c = 0; c < 3; ++c) // the table has 6 decimals
            EXPECT_NEAR(file3.rgb[i][c], rows[i].rgb[c], 5.1e-7 + 1e-9 * std::abs(rows[i].rgb[c])) << i;
    EXPECT_GT(file3.rgb[0].r, 0.0);

    // Counts agree with their nouns: order 1 holds 1 coefficient.
    EXPECT_CONTAINS(runOk({"bake", "--order", "1", "-o", file("sky1.json")}).out,
                    "order 1 (1 coefficient)\n");

    std::string out5 = file("sky5.json");
    RunResult irradiance = runOk({"bake", "--order", "5", "--irradiance", "-o", out5});
    EXPECT_CONTAINS(irradiance.out, "order 5 (25 coefficients)");
    EXPECT_CONTAINS(irradiance.out, "irradiance coefficients (r g b):");
    EXPECT_EQ(printedRows(irradiance.out).size(), 25u) << irradiance.out;
    ShCoefficients file5 = readProbeFile(out5);
    EXPECT_EQ(file5.order, 5);
    EXPECT_EQ(file5.quantity, Quantity::Irradiance);
    ASSERT_EQ(file5.rgb.size(), 25u);
    // Same sky: bands 0-2 of the irradiance are A_l times the radiance of the first bake (the two
    // runs sum in different orders, hence the fp32-level tolerance); A_3 = 0.
    const double a[3] = {std::numbers::pi, 2.0 * std::numbers::pi / 3.0, std::numbers::pi / 4.0};
    double scale = std::abs(file3.rgb[0].r) * std::numbers::pi;
    for (int i = 0; i < 9; ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(file5.rgb[i][c], a[shBand(i)] * file3.rgb[i][c], 1e-5 * scale) << i;
    for (int i = 9; i < 16; ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(file5.rgb[i][c], 0.0, 1e-5 * scale) << i;
}

// ---- 2. GPU = CPU through the program ---------------------------------------------------------

// The same 64x32 equirect EXR (a smooth coloured function) baked with --backend gpu, cpu and
// reference at order 5 gives the same coefficients to 2e-6 of |L00|. Each process integrates the
// decoded pixels directly (no cube map: "projected directly"), each weighted by its row's exact
// solid angle; they differ only in arithmetic: the GPU and the fast CPU path sum 2048 fp32 products
// L y dOmega (basis functions to a few fp32 ulps, compensated reduction) against the double
// reference. For this smooth positive input every term is a few times L00 / pixel count at most, so
// the fp32 error is a few 1e-7 of |L00|; 2e-6 leaves margin while any mistake of weighting,
// orientation or basis moves a coefficient by far more. The file keeps 9 significant digits, well
// below that. With --face-size the input is resampled to a cube map of that size first.
TEST_F(Cli, GpuAndCpuBackendsAgree) {
    writeImage(file("smooth.exr"), smoothEquirect(64, 32));
    RunResult gpu =
        runOk({"bake", file("smooth.exr"), "--order", "5", "--backend", "gpu", "-o", file("gpu.json")});
    RunResult cpu =
        runOk({"bake", file("smooth.exr"), "--order", "5", "--backend", "reference", "-o", file("cpu.json")});
    RunResult fast =
        runOk({"bake", file("smooth.exr"), "--order", "5", "--backend", "cpu", "-o", file("fast.json")});
    EXPECT_CONTAINS(gpu.out, "(equirect 64x32)");
    EXPECT_CONTAINS(gpu.out, "64 x 32 pixels projected directly, order 5 (25 coefficients)");
    EXPECT_CONTAINS(gpu.out, "backend  gpu: llvmpipe");
    RunResult resampled = runOk({"bake", file("smooth.exr"), "--order", "5", "--face-size", "16", "--backend",
                                 "gpu", "-o", file("resampled.json")});
    EXPECT_CONTAINS(resampled.out, "6 x 16 x 16 texels, order 5 (25 coefficients)");
    EXPECT_CONTAINS(cpu.out, "backend  reference: cpu reference");
    EXPECT_CONTAINS(fast.out, "backend  cpu: cpu (float, all cores)");

    ShCoefficients c = readProbeFile(file("cpu.json"));
    ASSERT_EQ(c.rgb.size(), 25u);
    double tolerance = 2e-6 * std::abs(c.rgb[0].r); // the fast float path has the GPU's error budget
    ASSERT_GT(tolerance, 0.0);
    for (const char* name : {"gpu.json", "fast.json"}) {
        ShCoefficients g = readProbeFile(file(name));
        ASSERT_EQ(g.rgb.size(), 25u);
        double worst = 0.0;
        for (int i = 0; i < 25; ++i)
            for (int k = 0; k < 3; ++k) {
                EXPECT_NEAR(g.rgb[i][k], c.rgb[i][k], tolerance)
                    << name << " coefficient " << i << " channel " << k;
                worst = std::max(worst, std::abs(g.rgb[i][k] - c.rgb[i][k]));
            }
        std::printf("[ info     ] %s: worst |x - reference| = %.3g |L00|\n", name,
                    worst / std::abs(c.rgb[0].r));
    }
    // The input has energy beyond band 0: the comparison is not of zeros.
    EXPECT_GT(std::abs(c.rgb[3].r), 0.1 * std::abs(c.rgb[0].r)); // l=1 m=+1, from the x term
}

// How the projection splits the texels among invocations (bake --workgroup-size, the workgroup's
// width; --texels-per-invocation, which sets the workgroup count) changes the order the partial sums
// are added in, not the result: every shape, from one invocation a workgroup to the most lavapipe
// allows, agrees with the reference within GpuAndCpuBackendsAgree's 2e-6 of |L00|, for the
// equirect's direct projection and for a cube map's (--face-size): the cube's 1,536 texels are
// fewer float terms than the equirect's 2,048 pixels, and both paths measure 1e-7 at most.
TEST_F(Cli, EveryWorkgroupShapeAgreesWithTheReference) {
    writeImage(file("smooth.exr"), smoothEquirect(64, 32));
    auto bake = [&](const std::vector<std::string>& extra) {
        std::vector<std::string> args = {"bake", file("smooth.exr"), "--order", "5", "-q",
                                         "-o",   file("p.json")};
        args.insert(args.end(), extra.begin(), extra.end());
        runOk(args);
        return readProbeFile(file("p.json"));
    };
    for (const std::vector<std::string>& input : {std::vector<std::string>{}, {"--face-size", "16"}}) {
        std::vector<std::string> referenceArgs = input;
        referenceArgs.insert(referenceArgs.end(), {"--backend", "reference"});
        const ShCoefficients reference = bake(referenceArgs);
        for (const char* width : {"1", "33", "1024"}) {
            for (const char* texels : {"1", "7"}) {
                SCOPED_TRACE(joined(input) + " --workgroup-size " + width + " --texels-per-invocation " +
                             texels);
                std::vector<std::string> args = input;
                args.insert(args.end(), {"--backend", "gpu", "--workgroup-size", width,
                                         "--texels-per-invocation", texels});
                const ShCoefficients gpu = bake(args);
                ASSERT_EQ(gpu.rgb.size(), reference.rgb.size());
                for (size_t i = 0; i < gpu.rgb.size(); ++i)
                    for (int k = 0; k < 3; ++k)
                        EXPECT_NEAR(gpu.rgb[i][k], reference.rgb[i][k], 2e-6 * std::abs(reference.rgb[0].r))
                            << "coefficient " << i << " channel " << k;
            }
        }
    }
}

// --backend auto, the default: a job whose CPU projection takes less than a Vulkan start-up (the
// program's constants: 1e9 texel-coefficients per core-second, 20 ms) is baked on the CPU without
// Vulkan: it bakes with no driver at all. A larger one (an equirect map of 4 times that work at
// order 8, sized from this machine's core count) runs on the CPU too, saying why: where this
// machine has no GPU device file, without asking Vulkan; else the device is asked: lavapipe is a
// CPU, and with no usable driver there is none (tests/auto_backend.sh makes both cases in a /dev
// of its own). --device asks for Vulkan, and the device is what runs.
TEST_F(Cli, AutoBackendChoosesByJobAndDevice) {
    const std::string small = "(auto: a job this small is done on the CPU before Vulkan could start)";
    EnvironmentChanges noDriver{{"VK_ICD_FILENAMES", file("no_such_icd.json")},
                                {"VK_DRIVER_FILES", std::nullopt}};
    EXPECT_CONTAINS(runOk({"bake", "-q", "-o", file("sky.json")}).out,
                    "backend  cpu: cpu (float, all cores) " + small);
    RunResult withoutDriver = run({"bake", "-q", "-o", file("sky.json")}, {.environment = noDriver});
    EXPECT_EQ(withoutDriver.exitCode, 0) << describe(withoutDriver);
    EXPECT_CONTAINS(withoutDriver.out, small);

    const double work = 4.0 * 2e7 * std::max(1u, std::thread::hardware_concurrency());
    const int height = 16 * int(std::ceil(std::sqrt(work / 64.0 / 2.0) / 16.0));
    writeImage(file("large.exr"), smoothEquirect(2 * height, height));
    const std::vector<std::string> large = {"bake", file("large.exr"), "--order", "8", "-q",
                                            "-o",   file("large.json")};
    const bool gpuFile = !findGpuFile().empty();
    const std::string noGpu =
        "(auto: no GPU device file: any Vulkan device here is a CPU, where this path is "
        "faster)";
    EXPECT_CONTAINS(runOk(large).out, "backend  cpu: cpu (float, all cores) " +
                                          (gpuFile ? "(auto: the Vulkan device is a CPU (llvmpipe" : noGpu));
    RunResult largeWithoutDriver = run(large, {.environment = noDriver});
    EXPECT_EQ(largeWithoutDriver.exitCode, 0) << describe(largeWithoutDriver);
    EXPECT_CONTAINS(largeWithoutDriver.out, gpuFile ? "(auto: no usable Vulkan device)" : noGpu);

    RunResult named = runOk({"bake", "--device", "0", "-q", "-o", file("named.json")});
    EXPECT_CONTAINS(named.out, "backend  gpu: llvmpipe");
    EXPECT_EQ(named.out.find("auto:"), std::string::npos) << named.out;
}

// `shprobe info` says what `bake` and `scene` run under auto, by the same rule and with the same
// reason as the bake itself: the CPU at once for a small job; for a larger one on lavapipe the CPU
// (a CPU device, or no GPU device file), as the large bake's summary says. Never "bake uses device
// N" while the bake runs on the CPU.
TEST_F(Cli, InfoSaysWhatAutoRuns) {
    const std::string info = runOk({"info"}).out;
    EXPECT_EQ(info.find("bake uses device"), std::string::npos) << info;
    std::smatch bakeLine, sceneLine;
    ASSERT_TRUE(std::regex_search(
        info, bakeLine,
        std::regex(R"(bake +--backend auto \(the default\): cpu for a job under ([0-9.]+)M )"
                   R"(texels x coefficients.*; a larger one: cpu \((.*), where the CPU path )"
                   R"(is faster\)\n)")))
        << info;
    const double cores = std::max(1u, std::thread::hardware_concurrency());
    EXPECT_NEAR(std::stod(bakeLine[1]), 20.0 * cores, 0.5) << info; // 20 ms at 1e9 per core-second
    ASSERT_TRUE(std::regex_search(info, sceneLine,
                                  std::regex(R"(scene +--backend auto \(the default\): cpu \((.*)\)\n)")))
        << info;
    const std::string reason = bakeLine[2];
    EXPECT_EQ(std::string(sceneLine[1]), reason) << info;

    const double work = 4.0 * 2e7 * cores;
    const int height = 16 * int(std::ceil(std::sqrt(work / 64.0 / 2.0) / 16.0));
    writeImage(file("large.exr"), smoothEquirect(2 * height, height));
    RunResult large = runOk({"bake", file("large.exr"), "--order", "8", "-q", "-o", file("large.json")});
    EXPECT_CONTAINS(large.out,
                    "backend  cpu: cpu (float, all cores) (auto: " + reason + ", where this path is faster)");
}

// ---- 3. Determinism ---------------------------------------------------------------------------

// The same input baked twice on the GPU gives byte-identical coefficient rows in the file (the
// reduction sums in a fixed order on the GPU).
TEST_F(Cli, GpuBakeIsDeterministic) {
    writeImage(file("smooth.exr"), smoothEquirect(64, 32));
    for (const char* backend : {"gpu", "cpu"}) {
        runOk({"bake", file("smooth.exr"), "--order", "8", "--backend", backend, "-q", "-o",
               file("first.json")});
        runOk({"bake", file("smooth.exr"), "--order", "8", "--backend", backend, "-q", "-o",
               file("second.json")});
        std::string first = coefficientRowsText(readText(file("first.json")));
        std::string second = coefficientRowsText(readText(file("second.json")));
        ASSERT_FALSE(first.empty());
        EXPECT_EQ(first, second) << backend;
    }
    EXPECT_EQ(readProbeFile(file("first.json")).rgb.size(), 64u);
}

// ---- 4. Failures ------------------------------------------------------------------------------

// Failures follow ProgramTest::expectFailure's rules: the exit code, exactly one line "shprobe: error:
// ..." holding the mentions, no file left in an empty folder, an existing output untouched.
// `bench --json -` writes the JSON alone to standard output and its table to stderr, so that the
// output can be piped to a JSON reader (the table was printed around it).
TEST_F(Cli, BenchJsonOnStandardOutputIsTheJsonAlone) {
    const RunResult result = run({"bench", "--sizes", "4", "--orders", "3", "--repeat", "1",
                                  "--reference-max-size", "4", "--json", "-"});
    ASSERT_EQ(result.exitCode, 0) << describe(result);
    EXPECT_TRUE(result.out.starts_with("{") && result.out.ends_with("}\n")) << result.out;
    EXPECT_EQ(result.out.find("pipeline creation"), std::string::npos) << result.out;
    EXPECT_CONTAINS(result.err, "pipeline creation");
}

class CliFailures : public Cli {};

// A missing input file: exit 2, the message names the file.
TEST_F(CliFailures, MissingInputFile) {
    expectFailure({{"bake", file("nowhere.exr"), "-o", "OUT"}, 2, {file("nowhere.exr"), "no such file"}});
}

// An empty file named .exr: exit 2, the message names the file and says it is empty.
TEST_F(CliFailures, EmptyFile) {
    writeText(file("empty.exr"), "");
    expectFailure({{"bake", file("empty.exr"), "-o", "OUT"}, 2, {file("empty.exr"), "empty"}});
}

// A text file named .exr: exit 2, one line naming the file and the format it is not (the reader's
// reason included), not the library that tried to read it.
TEST_F(CliFailures, TextFileNamedExr) {
    writeText(file("notes.exr"), "these are not the pixels you are looking for\n");
    expectFailure({{"bake", file("notes.exr"), "-o", "OUT"},
                   2,
                   {file("notes.exr"), "not an image the EXR reader can read"}});
    RunResult result = run({"bake", file("notes.exr"), "-o", file("notes.json")});
    EXPECT_EQ(result.err.find("OpenImageIO"), std::string::npos) << result.err;
}

// shprobe's own files given where an image is read (a probe where a sky goes, a volume, a scene)
// are named for what they are, not offered to OpenImageIO's readers ("not an image the JSON reader
// can read (OpenImageIO could not find a format reader ...)").
TEST_F(CliFailures, OwnFilesAreNamedWhereAnImageIsRead) {
    writeText(file("probe.json"), "{\n  \"format\": \"shprobe.sh\"\n}\n");
    writeText(file("volume.shpv"), std::string("SHPROBEV") + std::string(64, '\0'));
    writeText(file("scene.glb"), std::string("glTF") + std::string(64, '\0'));
    for (const auto& [name, kind] : std::vector<std::pair<std::string, std::string>>{
             {"probe.json", "JSON (a probe file or a glTF scene), not an image"},
             {"volume.shpv", "a probe volume (shprobe scene), not an image"},
             {"scene.glb", "a binary glTF scene, not an image"}})
        expectFailure({{"bake", file(name), "-o", "OUT"}, 2, {file(name) + ": " + kind}});
}

// A 50x40 PNG matches no layout (2:1, 4:3, 3:4): exit 2, the message names the file and its size.
TEST_F(CliFailures, AspectRatioMatchingNoLayout) {
    writeImage(file("odd.png"), filledImage(50, 40, [](int, int) { return glm::vec3(0.5f); }));
    expectFailure(
        {{"bake", file("odd.png"), "-o", "OUT"}, 2, {file("odd.png"), "50x40", "matches no layout"}});
}

// A faces folder whose -Z face is 8x8 while the others are 4x4: exit 2, naming the odd face file.
TEST_F(CliFailures, FacesOfDifferentSizes) {
    const char* names[] = {"px", "nx", "py", "ny", "pz", "nz"};
    fs::create_directories(folder() / "faces");
    for (const char* name : names) {
        int n = std::string(name) == "nz" ? 8 : 4;
        writeImage(file(std::string("faces/") + name + ".exr"),
                   filledImage(n, n, [](int, int) { return glm::vec3(1.0f); }));
    }
    expectFailure({{"bake", file("faces"), "-o", "OUT"}, 2, {file("faces/nz.exr"), "8x8", "same size"}});
}

// An EXR with 5 NaN texels is refused with the count (exit 2); with --sanitize it bakes, says how
// many texels it replaced, and writes finite coefficients.
TEST_F(CliFailures, NanTexelsRefusedOrSanitized) {
    Image image = smoothEquirect(64, 32);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (int k = 0; k < 5; ++k)
        image.at(7 + 11 * k, 3 + 5 * k).g = nan;
    writeImage(file("nan.exr"), image);
    expectFailure({{"bake", file("nan.exr"), "-o", "OUT"}, 2, {file("nan.exr"), "5 texels", "--sanitize"}});

    RunResult sanitized = runOk({"bake", file("nan.exr"), "--sanitize", "-q", "-o", file("sanitized.json")});
    EXPECT_CONTAINS(sanitized.out, "replaced 5 NaN/Inf texels");
    ShCoefficients coefficients = readProbeFile(file("sanitized.json")); // rejects non-finite values
    EXPECT_EQ(coefficients.rgb.size(), 9u);
}

// Out-of-range options are usage errors reported by CLI11 before anything runs: non-zero exit,
// the option named, and no file.
TEST_F(CliFailures, OptionsOutOfRange) {
    expectFailure({{"bake", "--order", "0", "-o", "OUT"}, 2, {"--order"}});
    expectFailure({{"bake", "--order", "9", "-o", "OUT"}, 2, {"--order"}});
    expectFailure({{"bake", "--face-size", "0", "-o", "OUT"}, 2, {"--face-size"}});
}

// Output into a missing folder: exit 3, naming the folder, and checked before anything else: with
// a missing input it is still exit 3 (not 2), without any Vulkan driver still exit 3 (not 4), and
// the message comes without waiting for a bake.
TEST_F(CliFailures, OutputIntoMissingFolder) {
    std::string missing = file("no_such_folder");
    std::string out = missing + "/probe.json";

    RunResult sky = run({"bake", "-o", out});
    Failure failure{{}, 3, {missing, "does not exist"}};
    expectMessage(failure, sky);
    EXPECT_LT(sky.seconds, 5.0) << "the output folder must be checked before the bake";

    RunResult badInput = run({"bake", file("nowhere.exr"), "-o", out});
    expectMessage(failure, badInput);

    RunResult noDriver =
        run({"bake", "-o", out}, {.environment = {{"VK_ICD_FILENAMES", file("no_such_icd.json")}}});
    expectMessage(failure, noDriver);
    EXPECT_FALSE(fs::exists(missing));
}

// No Vulkan driver (VK_ICD_FILENAMES names a missing file, passed to the child explicitly) for a
// --backend gpu bake: exit 4 and one line that suggests installing a driver / lavapipe; no file. The plain
// run has the validation layer off, as a user's would be.
TEST_F(CliFailures, NoVulkanDevice) {
    EnvironmentChanges noDriver{{"VK_ICD_FILENAMES", file("no_such_icd.json")},
                                {"VK_DRIVER_FILES", std::nullopt},
                                {"SHPROBE_VALIDATION", std::nullopt}};
    expectFailure({{"bake", "--backend", "gpu", "--face-size", "8", "-o", "OUT"},
                   4,
                   {"Vulkan", "lavapipe", "mesa-vulkan-drivers"},
                   "out.json",
                   noDriver});

    // With validation on (as ctest runs), the loader's own diagnostics may come first through the
    // debug messenger, as "vulkan validation: ..." lines; the error itself is still one line, last.
    noDriver["SHPROBE_VALIDATION"] = "1";
    RunResult validated = run({"bake", "--backend", "gpu", "--face-size", "8", "-o", file("validated.json")},
                              {.environment = noDriver});
    EXPECT_EQ(validated.exitCode, 4) << describe(validated);
    std::vector<std::string> lines = linesOf(validated.err);
    ASSERT_FALSE(lines.empty());
    EXPECT_TRUE(startsWith(lines.back(), "shprobe: error: ")) << validated.err;
    EXPECT_CONTAINS(lines.back(), "lavapipe");
    for (size_t i = 0; i + 1 < lines.size(); ++i)
        EXPECT_TRUE(startsWith(lines[i], "vulkan validation: ")) << validated.err;
    EXPECT_FALSE(fs::exists(file("validated.json")));
}

// --device picks a device by its index in `shprobe info` or by a case-insensitive part of its name,
// and so does SHPROBE_DEVICE where --device is not given; a request that matches no device is a
// device error (exit 4) naming what was asked for.
TEST_F(Cli, DeviceIsChosenByIndexOrName) {
    const std::vector<std::string> bake = {"bake", "--face-size", "4",  "--backend",
                                           "gpu",  "-q",          "-o", file("device.json")};
    auto withDevice = [&](const std::string& device) {
        std::vector<std::string> args = bake;
        args.insert(args.end(), {"--device", device});
        return args;
    };
    for (const char* device : {"0", "LLVMpipe"}) {
        EXPECT_CONTAINS(runOk(withDevice(device)).out, "llvmpipe");
        const RunResult fromEnvironment = run(bake, {.environment = {{"SHPROBE_DEVICE", device}}});
        EXPECT_EQ(fromEnvironment.exitCode, 0) << describe(fromEnvironment);
        EXPECT_CONTAINS(fromEnvironment.out, "llvmpipe");
    }
    const RunResult optionFirst = run(withDevice("0"), {.environment = {{"SHPROBE_DEVICE", "no-such-gpu"}}});
    EXPECT_EQ(optionFirst.exitCode, 0) << "--device goes before SHPROBE_DEVICE: " << describe(optionFirst);
}

TEST_F(CliFailures, UnknownDevice) {
    expectFailure({{"bake", "--face-size", "4", "--device", "no-such-gpu", "-o", "OUT"},
                   4,
                   {"no-such-gpu", "shprobe info"}});
    expectFailure({{"bake", "--face-size", "4", "--backend", "gpu", "-o", "OUT"},
                   4,
                   {"no-such-gpu", "shprobe info"},
                   "out.json",
                   {{"SHPROBE_DEVICE", "no-such-gpu"}}});
}

// ---- The toolkit through the program: windows, lights, sun extraction, rotate, light ---------

// Largest |a - b| over coefficients and channels, relative to a's largest |L_00| channel.
double relativeDifference(const ShCoefficients& a, const ShCoefficients& b) {
    double worst = 0.0, dc = std::max({std::abs(a.rgb[0].r), std::abs(a.rgb[0].g), std::abs(a.rgb[0].b)});
    for (size_t i = 0; i < a.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(a.rgb[i][c] - b.rgb[i][c]));
    return worst / dc;
}

// The built-in sky's sun rings: its order-5 irradiance goes negative somewhere. `--window dering`
// finds the weakest window that removes that, on the GPU as on the CPU (the GPU applies it in the
// convolution shader; both agree to the GPU's fp32 accuracy, 2e-6 of |L_00|), and the written
// irradiance is non-negative (on 4096 directions plus local refinement, minimumOnSphere).
TEST_F(Cli, DeringingMakesIrradianceNonNegative) {
    runOk({"bake", "--order", "5", "--irradiance", "-o", file("plain.json")});
    runOk({"bake", "--order", "5", "--irradiance", "--window", "dering", "-o", file("gpu.json")});
    runOk({"bake", "--order", "5", "--irradiance", "--window", "dering", "--backend", "cpu", "-o",
           file("cpu.json")});
    ShCoefficients plain = readProbeFile(file("plain.json"));
    ShCoefficients gpu = readProbeFile(file("gpu.json"));
    EXPECT_LT(minimumOnSphere(plain).value, 0.0) << "the test needs a sky whose irradiance rings negative";
    EXPECT_GE(minimumOnSphere(gpu).value, -1e-6 * plain.rgb[0].r);
    EXPECT_LT(relativeDifference(gpu, readProbeFile(file("cpu.json"))), 2e-6);
    EXPECT_NEAR(gpu.rgb[0].g, plain.rgb[0].g, 2e-6 * plain.rgb[0].g) << "a window keeps L_00";
}

// Lights given to `bake` are added to the environment's radiance: the difference between the bakes
// with and without them is exactly the probe `shprobe light` writes for the same lights (fp32
// coefficients: 1e-6 relative).
TEST_F(Cli, BakeLightsEqualTheLightCommand) {
    std::vector<std::string> lights = {"--directional", "0.3,0.8,-0.5", "3,2,1",
                                       "--sphere",      "0,1,0",        "10",
                                       "1,1,2",         "--ambient",    "0.1,0.2,0.3"};
    std::vector<std::string> withLights = {"bake", "--order", "5", "-o", file("lit.json")};
    withLights.insert(withLights.end(), lights.begin(), lights.end());
    std::vector<std::string> lightOnly = {"light", "--order", "5", "-o", file("lights.json")};
    lightOnly.insert(lightOnly.end(), lights.begin(), lights.end());
    runOk({"bake", "--order", "5", "-o", file("sky.json")});
    runOk(withLights);
    runOk(lightOnly);
    ShCoefficients sky = readProbeFile(file("sky.json")), lit = readProbeFile(file("lit.json"));
    ShCoefficients expected = readProbeFile(file("lights.json"));
    for (size_t i = 0; i < sky.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(lit.rgb[i][c] - sky.rgb[i][c], expected.rgb[i][c], 1e-6 * std::abs(lit.rgb[0][c]))
                << "coefficient " << i;
}

// `--extract-sun` on the built-in sky finds its sun (SkyParameters: direction normalize(0.32, 0.72,
// -0.61), radius 0.02 rad): direction within 0.1 degree, radius within 2%, written as "sun", and
// the coefficients are those of the sky without it (L_00 far below the bake with the sun).
TEST_F(Cli, ExtractSunFindsTheBuiltInSun) {
    RunResult result = runOk({"bake", "--extract-sun", "-q", "-o", file("rest.json")});
    EXPECT_CONTAINS(result.out, "sun ");
    std::ifstream in(file("rest.json"));
    nlohmann::json json = nlohmann::json::parse(in);
    ASSERT_TRUE(json.contains("sun")) << json.dump();
    glm::dvec3 direction(json["sun"]["direction"][0], json["sun"]["direction"][1],
                         json["sun"]["direction"][2]);
    glm::dvec3 expected = glm::normalize(SkyParameters{}.sunDirection);
    EXPECT_LT(std::acos(std::min(1.0, glm::dot(direction, expected))) * 180.0 / M_PI, 0.1);
    EXPECT_NEAR(json["sun"]["angular_radius_degrees"].get<double>(),
                SkyParameters{}.sunAngularRadius * 180.0 / M_PI,
                0.02 * SkyParameters{}.sunAngularRadius * 180.0 / M_PI);
    runOk({"bake", "-q", "-o", file("whole.json")});
    EXPECT_LT(readProbeFile(file("rest.json")).rgb[0].r, 0.5 * readProbeFile(file("whole.json")).rgb[0].r);
}

// `shprobe rotate` equals the library's rotation (src/sh/rotation.h, tested against projections of
// rotated environments) for the Euler, quaternion and matrix forms of the same rotation, a quarter
// turn about +Y: R = Rz(0) Ry(90) Rz(0) = quaternion (cos 45, 0, sin 45, 0) = [[0,0,1],[0,1,0],[-1,0,0]].
TEST_F(Cli, RotateTakesEulerQuaternionOrMatrix) {
    runOk({"bake", "--order", "4", "-q", "-o", file("sky.json")});
    ShCoefficients sky = readProbeFile(file("sky.json"));
    ShCoefficients expected = rotate(makeShRotation(rotationFromEulerZYZ(0.0, 90.0, 0.0), 4), sky);
    const std::vector<std::vector<std::string>> forms = {
        {"--euler", "0,90,0"},
        {"--quat", "0.7071067811865476,0,0.7071067811865476,0"},
        {"--matrix", "0,0,1,0,1,0,-1,0,0"}};
    for (const std::vector<std::string>& form : forms) {
        runOk({"rotate", file("sky.json"), form[0], form[1], "-o", file("rotated.json")});
        EXPECT_LT(relativeDifference(readProbeFile(file("rotated.json")), expected), 1e-8) << form[0];
    }
}

// light and rotate write the format -o's extension names, as bake does: a .bin holds the JSON
// file's probe as float32 (readProbeFile reads either), a .h a header; a probe with a sun (from
// --extract-sun) goes to .json only (RotateRefusesBadRotations); .txt, which names no format, is
// JSON.
TEST_F(Cli, LightAndRotateWriteTheFormatTheirOutputNames) {
    const std::vector<std::string> lights{"--directional", "0,1,0", "3,2,1", "--ambient", "0.1,0.1,0.1"};
    auto light = [&](const std::string& output) {
        std::vector<std::string> args{"light"};
        args.insert(args.end(), lights.begin(), lights.end());
        args.insert(args.end(), {"-o", file(output)});
        runOk(args);
    };
    light("lights.json");
    light("lights.bin");
    light("lights.h");
    light("lights.txt");
    const ShCoefficients json = readProbeFile(file("lights.json"));
    EXPECT_LT(relativeDifference(readProbeFile(file("lights.bin")), json), 1e-7); // float32
    EXPECT_EQ(readText(file("lights.bin")).substr(0, 4), "SHPB");
    EXPECT_NE(readText(file("lights.h")).find("static const float lights_sh[25][4]"), std::string::npos);
    EXPECT_EQ(readProbeFile(file("lights.txt")).rgb, json.rgb);
    runOk({"rotate", file("lights.bin"), "--euler", "0,90,0", "-o", file("turned.bin")});
    runOk({"rotate", file("lights.json"), "--euler", "0,90,0", "-o", file("turned.json")});
    EXPECT_LT(relativeDifference(readProbeFile(file("turned.bin")), readProbeFile(file("turned.json"))),
              1e-7);
}

TEST_F(CliFailures, RotateRefusesBadRotations) {
    run({"light", "--ambient", "1,1,1", "-o", file("probe.json")});
    expectFailure(
        {{"rotate", file("probe.json"), "--matrix", "1,0,0,0,1,0,0,0,2", "-o", "OUT"}, 2, {"orthonormal"}});
    expectFailure({{"rotate", file("probe.json"), "-o", "OUT"}, 2, {"--euler", "--quat", "--matrix"}});
    expectFailure({{"rotate", file("missing.json"), "--euler", "0,90,0", "-o", "OUT"}, 2, {"missing.json"}});
    runOk({"bake", "--extract-sun", "-q", "-o", file("sunny.json")});
    expectFailure({{"rotate", file("sunny.json"), "--euler", "0,90,0", "-o", "OUT"},
                   2,
                   {"has a sun", "the binary format cannot hold", "an output name ending in .json"},
                   "turned.bin"});
}

TEST_F(CliFailures, BadLightsAndWindows) {
    expectFailure(
        {{"bake", "--directional", "0,1", "1,1,1", "-o", "OUT"}, 2, {"--directional", "3 numbers"}});
    expectFailure({{"bake", "--sphere", "0,1,0", "-5", "1,1,1", "-o", "OUT"}, 2, {"--sphere", "radius"}});
    expectFailure({{"bake", "--window", "gauss:3", "-o", "OUT"}, 2, {"--window"}});
    expectFailure({{"light", "-o", "OUT"}, 2, {"at least one"}});
}

// --timings prints each phase of a GPU bake once, named and with a time that is a non-negative
// number; without --timings no phase is printed.
TEST_F(Cli, TimingsNameEachPhaseOfAGpuBake) {
    RunResult timed = runOk({"bake", "--backend", "gpu", "-q", "--timings", "-o", file("timed.json")});
    for (const char* phase : {"instance", "device", "pipelines", "upload", "dispatch", "readback"}) {
        const std::string label = std::string("  timing   ") + phase;
        const size_t at = timed.out.find(label);
        ASSERT_NE(at, std::string::npos) << phase << " in: " << timed.out;
        EXPECT_EQ(timed.out.find(label, at + 1), std::string::npos) << phase << " twice in: " << timed.out;
        double ms = -1.0;
        EXPECT_EQ(std::sscanf(timed.out.c_str() + at + label.size(), " %lf ms", &ms), 1) << phase;
        EXPECT_GE(ms, 0.0) << phase;
    }
    RunResult plain = runOk({"bake", "--backend", "gpu", "-q", "-o", file("plain.json")});
    EXPECT_EQ(plain.out.find("timing"), std::string::npos) << plain.out;
}

// --format binary writes the same coefficients as the JSON file (both hold the GPU's float values:
// JSON with 9 significant digits, so they agree to 5e-9 relative), and an irradiance map has the
// documented size; a format the program does not know is a usage error.
TEST_F(Cli, FormatsHoldTheSameProbe) {
    runOk({"bake", "--order", "4", "--backend", "gpu", "-q", "-o", file("probe.json")});
    runOk({"bake", "--order", "4", "--backend", "gpu", "-q", "--format", "binary", "-o", file("probe.bin")});
    runOk({"bake", "-q", "--format", "irradiance-cross", "--map-size", "16", "-o", file("cross.exr")});
    ShCoefficients json = readProbeFile(file("probe.json"));
    std::vector<ShCoefficients> binary = readBinaryProbes(file("probe.bin"));
    ASSERT_EQ(binary.size(), 1u);
    ASSERT_EQ(binary[0].order, 4);
    for (size_t i = 0; i < json.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(binary[0].rgb[i][c], json.rgb[i][c], 5e-9 * std::abs(json.rgb[0][c]))
                << "coefficient " << i;
    Image cross = readImage(file("cross.exr"));
    EXPECT_EQ(cross.width, 64);
    EXPECT_EQ(cross.height, 48);
    RunResult unknown = run({"bake", "--format", "yaml", "-o", file("probe.yaml")});
    EXPECT_NE(unknown.exitCode, 0);
    EXPECT_FALSE(fs::exists(file("probe.yaml")));
}

// ---- 5. shprobe info --------------------------------------------------------------------------

// `shprobe info` exits 0, lists the llvmpipe device with its subgroup size (LP_NATIVE_VECTOR_WIDTH
// / 32 when that is set) and says that `--backend gpu` uses it.
TEST_F(Cli, InfoNamesTheDeviceAndItsSubgroupSize) {
    RunResult info = runOk({"info"});
    EXPECT_CONTAINS(info.out, "llvmpipe");
    EXPECT_TRUE(std::regex_search(
        info.out, std::regex(R"(--backend gpu, --device, --validation: device \d+: llvmpipe)")))
        << info.out;
    std::smatch match;
    ASSERT_TRUE(std::regex_search(info.out, match, std::regex(R"(subgroup size (\d+))"))) << info.out;
    int subgroupSize = std::stoi(match[1]);
    EXPECT_TRUE(subgroupSize >= 4 && subgroupSize <= 64 && (subgroupSize & (subgroupSize - 1)) == 0)
        << subgroupSize;
    if (const char* width = std::getenv("LP_NATIVE_VECTOR_WIDTH")) {
        EXPECT_EQ(subgroupSize, std::atoi(width) / 32);
    }
}

// ---- 6. Layouts -------------------------------------------------------------------------------

// A 64x48 PNG (4:3) is detected as a horizontal cross and baked at its face size 16, its faces
// read where they lie in the image (the same probe as their copy into a cube map). +Y (top of
// the cross) is white, the five other faces grey sRGB 0x80, the unused corners red (never read):
// L00 = Y00 (4 pi / 6) (sum of the six faces' linear values) exactly, since each face subtends
// 4 pi / 6, and the only first-band term is along -y_1,-1 = 0.488603 y: L1,-1 < 0, L1,0 = L1,1 = 0.
TEST_F(Cli, HorizontalCrossIsDetectedAndBaked) {
    const int n = 16, width = 4 * n, height = 3 * n;
    std::vector<uint8_t> rgb(size_t(width) * height * 3);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            int column = x / n, row = y / n;
            bool face = row == 1 || column == 1;
            bool top = row == 0 && column == 1;
            uint8_t value = top ? 0xff : 0x80;
            uint8_t* texel = &rgb[(size_t(y) * width + x) * 3];
            texel[0] = face ? value : 0xff;
            texel[1] = face ? value : 0x00;
            texel[2] = face ? value : 0x00;
        }
    writeRgb8(folder() / "cross.png", width, height, rgb);

    RunResult baked = runOk({"bake", file("cross.png"), "-q", "-o", file("cross.json")});
    EXPECT_CONTAINS(baked.out, "(hcross 64x48)");
    EXPECT_CONTAINS(baked.out, "6 x 16 x 16 texels projected where they lie in the cross");
    // Read where they lie, the faces give the probe of their copy into a cube map (--face-size 16).
    runOk({"bake", file("cross.png"), "--face-size", "16", "-q", "-o", file("copied.json")});
    EXPECT_EQ(readText(file("copied.json")), readText(file("cross.json")));
    ShCoefficients c = readProbeFile(file("cross.json"));
    ASSERT_EQ(c.rgb.size(), 9u);
    double grey = srgbDecoded(128.0 / 255.0);
    double expectedL00 = kY00 * (4.0 * std::numbers::pi / 6.0) * (1.0 + 5.0 * grey);
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(c.rgb[0][k], expectedL00, 2e-6 * expectedL00) << k;
        EXPECT_LT(c.rgb[1][k], -0.05 * expectedL00) << k; // l=1 m=-1: the bright +Y face
        EXPECT_NEAR(c.rgb[2][k], 0.0, 2e-6 * expectedL00) << k;
        EXPECT_NEAR(c.rgb[3][k], 0.0, 2e-6 * expectedL00) << k;
    }
}

// `--layout equirect` on a 4:3 image is refused (exit 2) with a message naming the file, its size
// and the 2:1 an equirect needs; no file is written.
TEST_F(CliFailures, EquirectLayoutOnA4To3ImageIsRefused) {
    writeImage(file("cross.exr"), filledImage(32, 24, [](int, int) { return glm::vec3(1.0f); }));
    expectFailure({{"bake", file("cross.exr"), "--layout", "equirect", "-q", "-o", "OUT"},
                   2,
                   {file("cross.exr"), "32x24", "2:1"}});
}

// ---- 7. Batches --------------------------------------------------------------------------------

// Inputs for batches: three different smooth environments, a.exr and b.exr (32x16 equirects,
// projected directly: 512 texels, 8192 bytes each) and c.hdr (64x32: 2048 texels, 32768 bytes).
class CliBatch : public Cli {
  protected:
    std::string a() const { return file("a.exr"); }
    std::string b() const { return file("b.exr"); }
    std::string c() const { return file("c.hdr"); }
    void writeInputs() const {
        Image smooth = smoothEquirect(32, 16);
        writeImage(a(), smooth);
        writeImage(b(),
                   filledImage(32, 16, [&](int i, int j) { return 0.5f * glm::vec3(smooth.at(31 - i, j)); }));
        writeImage(c(), filledImage(64, 32, [](int i, int j) {
                       glm::dvec3 d = equirectDirection(i, j, 64, 32);
                       return glm::vec3(float(1.5 + d.y), float(1.0 + 0.5 * d.x * d.z), float(2.0 - d.z));
                   }));
    }
    static std::vector<std::string> with(std::vector<std::string> args,
                                         const std::vector<std::string>& more) {
        args.insert(args.end(), more.begin(), more.end());
        return args;
    }
};

// The summary line of a batch, e.g. "shprobe bake: 3 probes baked, 0 failed; 2304 texels in 1 GPU
// submission; 0.41 s, 7.3 probes/s".
bool hasBatchSummary(const std::string& out, const std::string& counts) {
    static const std::regex tail(R"(; [0-9.]+ s, [0-9.]+ probes/s$)");
    for (const std::string& line : linesOf(out))
        if (startsWith(line, "shprobe bake: " + counts) && std::regex_search(line, tail)) return true;
    return false;
}

// The same three inputs and options (order 4, irradiance, on the GPU) baked one by one with -o, as
// one batch (a single GPU submission) and as a batch forced into chunks (--batch-bytes 17000: a and b in one
// submission, c in another; c given through --list, between a comment and a blank line, the list
// starting with UTF-8's byte-order mark as some editors save it) give the
// same files, byte for byte and number for number. No progress bar on stderr, which is not a
// terminal here (runOk: stderr empty); the summary counts probes, texels and submissions.
TEST_F(CliBatch, BatchEqualsSingleBakesProbeForProbe) {
    writeInputs();
    const std::vector<std::string> shared = {"--order", "4", "--irradiance", "--backend", "gpu", "-q"};
    for (const char* name : {"a", "b", "c"}) {
        std::string input = name == std::string("c") ? c() : file(std::string(name) + ".exr");
        runOk(with({"bake", input, "-o", file(std::string("single_") + name + ".json")}, shared));
    }
    RunResult whole = runOk(with({"bake", a(), b(), c(), "--out-dir", file("whole")}, shared));
    EXPECT_TRUE(hasBatchSummary(whole.out, "3 probes baked, 0 failed; 3072 texels in 1 GPU submission"))
        << whole.out;
    EXPECT_CONTAINS(whole.out, "shprobe bake: 3 inputs -> " + file("whole"));

    writeText(file("list.txt"), "\xEF\xBB\xBF# the third input\n\n  " + c() + "  \n");
    RunResult chunked = runOk(with({"bake", a(), b(), "--list", file("list.txt"), "--out-dir",
                                    file("chunked"), "--batch-bytes", "17000"},
                                   shared));
    EXPECT_TRUE(hasBatchSummary(chunked.out, "3 probes baked, 0 failed; 3072 texels in 2 GPU submissions"))
        << chunked.out;

    for (const char* name : {"a", "b", "c"}) {
        SCOPED_TRACE(name);
        std::string single = readText(file(std::string("single_") + name + ".json"));
        ASSERT_FALSE(single.empty());
        for (const char* batch : {"whole", "chunked"}) {
            fs::path path = folder() / batch / (std::string(name) + ".json");
            EXPECT_EQ(readText(path), single) << batch;
            ShCoefficients batched = readProbeFile(path.string()),
                           alone = readProbeFile(file(std::string("single_") + name + ".json"));
            ASSERT_EQ(batched.rgb.size(), 16u);
            EXPECT_EQ(batched.quantity, Quantity::Irradiance);
            for (size_t i = 0; i < alone.rgb.size(); ++i)
                for (int k = 0; k < 3; ++k)
                    EXPECT_EQ(batched.rgb[i][k], alone.rgb[i][k]) << batch << " coefficient " << i;
        }
    }
    // The inputs differ, so equal files are not a copy of one probe.
    EXPECT_NE(readProbeFile(file("single_a.json")).rgb[3].r, readProbeFile(file("single_b.json")).rgb[3].r);
    EXPECT_EQ(entriesOf(folder() / "whole"), (std::vector<std::string>{"a.json", "b.json", "c.json"}));
}

// A GPU batch of an equirect (projected directly) and a horizontal cross (a cube map) bakes both
// kinds in one chunk, each kind with its own pipelines in a submission of its own (2 GPU
// submissions): the same files, byte for byte, as baking each alone.
TEST_F(CliBatch, MixedKindsBatchEqualsSingleBakes) {
    writeInputs();
    writeImage(file("cross.exr"), filledImage(32, 24, [](int i, int j) {
                   return glm::vec3(1.0f + 0.03f * float(i), 0.5f + 0.02f * float(j), 0.25f);
               }));
    const std::vector<std::string> shared = {"--order", "3", "--backend", "gpu", "-q"};
    runOk(with({"bake", a(), "-o", file("single_a.json")}, shared));
    runOk(with({"bake", file("cross.exr"), "-o", file("single_cross.json")}, shared));
    RunResult batch = runOk(with({"bake", a(), file("cross.exr"), "--out-dir", file("mixed")}, shared));
    EXPECT_TRUE(hasBatchSummary(batch.out, "2 probes baked, 0 failed; 896 texels in 2 GPU submissions"))
        << batch.out;
    EXPECT_EQ(readText(folder() / "mixed" / "a.json"), readText(file("single_a.json")));
    EXPECT_EQ(readText(folder() / "mixed" / "cross.json"), readText(file("single_cross.json")));
    EXPECT_NE(readProbeFile(file("single_a.json")).rgb[0].r,
              readProbeFile(file("single_cross.json")).rgb[0].r);
}

// --backend cpu bakes a batch probe by probe: the same files as -o.
TEST_F(CliBatch, CpuBatchEqualsCpuBakes) {
    writeInputs();
    runOk({"bake", a(), "--backend", "cpu", "--order", "5", "-q", "-o", file("single_a.json")});
    RunResult batch =
        runOk({"bake", a(), c(), "--backend", "cpu", "--order", "5", "-q", "--out-dir", file("cpu")});
    EXPECT_TRUE(hasBatchSummary(batch.out, "2 probes baked, 0 failed; 2560 texels; ")) << batch.out;
    EXPECT_EQ(readText(folder() / "cpu" / "a.json"), readText(file("single_a.json")));
    EXPECT_EQ(readProbeFile((folder() / "cpu" / "c.json").string()).rgb.size(), 25u);
}

// A batch holding a text file named .exr (positional) and a missing file (from --list) bakes and
// writes the other two, reports each bad input on exactly one "shprobe: error:" line naming it,
// ends with one more error line giving the count, exits 2 (bad input) and writes nothing for the
// bad ones (no temporary file either).
TEST_F(CliBatch, BadInputsAreReportedAndTheOthersWritten) {
    writeInputs();
    writeText(file("bad.exr"), "these are not the pixels you are looking for\n");
    writeText(file("list.txt"), file("nowhere.exr") + "\n" + b() + "\n");
    RunResult result =
        run({"bake", a(), file("bad.exr"), "--list", file("list.txt"), "--out-dir", file("out")});
    EXPECT_EQ(result.exitCode, 2) << describe(result);
    std::vector<std::string> lines = linesOf(result.err);
    ASSERT_EQ(lines.size(), 3u) << result.err;
    for (const std::string& line : lines)
        EXPECT_TRUE(startsWith(line, "shprobe: error: ")) << line;
    for (const std::string& bad : {file("bad.exr"), file("nowhere.exr")})
        EXPECT_EQ(std::count_if(lines.begin(), lines.end(),
                                [&](const std::string& line) { return line.find(bad) != std::string::npos; }),
                  1)
            << bad << " in:\n"
            << result.err;
    EXPECT_CONTAINS(lines[0], "not an image");
    EXPECT_CONTAINS(lines[1], "no such file");
    EXPECT_CONTAINS(lines[2], "2 of 4 inputs failed");
    EXPECT_TRUE(hasBatchSummary(result.out, "2 probes baked, 2 failed;")) << result.out;
    // Inputs load on a thread ahead of the bake (bake_batch.cpp); the lines still come in input order.
    const size_t aLine =
        result.out.find("a.exr (equirect 32x16) -> " + (folder() / "out" / "a.json").string());
    const size_t bLine = result.out.find(" -> " + (folder() / "out" / "b.json").string());
    EXPECT_NE(aLine, std::string::npos) << result.out;
    EXPECT_NE(bLine, std::string::npos) << result.out;
    EXPECT_LT(aLine, bLine) << result.out;
    EXPECT_EQ(entriesOf(folder() / "out"), (std::vector<std::string>{"a.json", "b.json"}));
    EXPECT_EQ(readProbeFile((folder() / "out" / "b.json").string()).rgb.size(), 9u);

    // As a terminal shows both streams: each input's line, written or failed, in input order.
    RunResult both =
        run({"bake", a(), file("bad.exr"), "--list", file("list.txt"), "--out-dir", file("both")},
            {.errorsToOutput = true});
    std::vector<size_t> at;
    for (const std::string& mention :
         {std::string("a.json"), file("bad.exr") + ":", file("nowhere.exr") + ":", std::string("b.json")})
        at.push_back(both.out.find(mention));
    EXPECT_NE(at.back(), std::string::npos) << both.out;
    EXPECT_TRUE(std::is_sorted(at.begin(), at.end())) << both.out;
}

// The output folder is checked before any GPU work: a folder whose parent is missing is exit 3
// naming it, even with a missing input and without any Vulkan driver (which would be exit 2 or 4
// had the inputs been loaded or a device opened), at once, and nothing is created. So is a file
// where the folder should be, and a read-only folder, left as it was (as user nobody where this
// process is root, whom permission bits do not stop). A missing folder whose parent exists is created,
// and removed again where the batch wrote nothing into it.
TEST_F(CliBatch, OutputFolderIsCheckedBeforeTheBake) {
    writeInputs();
    EnvironmentChanges noDriver{{"VK_ICD_FILENAMES", file("no_such_icd.json")},
                                {"VK_DRIVER_FILES", std::nullopt}};
    auto expectOutputError = [&](const std::string& outDir, const std::string& mention) {
        RunResult result = run({"bake", a(), file("nowhere.exr"), "--out-dir", outDir},
                               {.environment = noDriver, .asOtherUser = true});
        EXPECT_EQ(result.exitCode, 3) << describe(result);
        EXPECT_EQ(linesOf(result.err).size(), 1u) << result.err;
        EXPECT_TRUE(startsWith(result.err, "shprobe: error: ")) << result.err;
        EXPECT_CONTAINS(result.err, mention);
        EXPECT_EQ(result.out, "");
        EXPECT_LT(result.seconds, 5.0) << "the output folder must be checked before the bake";
    };
    expectOutputError(file("missing/probes"), file("missing") + " does not exist");
    EXPECT_FALSE(fs::exists(file("missing")));
    writeText(file("plain"), "a file, not a folder\n");
    expectOutputError(file("plain"), "not a folder");
    EXPECT_EQ(readText(file("plain")), "a file, not a folder\n");

    fs::path readonly = folder() / "readonly";
    fs::create_directories(readonly);
    fs::permissions(readonly, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                                  fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
    expectOutputError(readonly.string(), "not writable");
    EXPECT_EQ(entriesOf(readonly), std::vector<std::string>{});

    RunResult created = runOk({"bake", a(), "--backend", "cpu", "-q", "--out-dir", file("new")});
    EXPECT_EQ(entriesOf(folder() / "new"), std::vector<std::string>{"a.json"});

    // A batch that writes nothing leaves no folder it made; a folder that was there stays.
    fs::create_directories(folder() / "kept");
    for (const char* name : {"none", "kept"}) {
        RunResult none = run({"bake", file("nowhere.exr"), file("bad.exr"), "-q", "--out-dir", file(name)});
        EXPECT_EQ(none.exitCode, 2) << describe(none);
        EXPECT_CONTAINS(none.err, "nothing was written");
    }
    EXPECT_FALSE(fs::exists(folder() / "none"));
    EXPECT_TRUE(fs::is_directory(folder() / "kept"));
}

// Two inputs that would write one file are refused up front (exit 2, one line naming both and the
// file), before the output folder is created; several inputs or --list without --out-dir are
// refused, and -o with --out-dir is a usage error.
TEST_F(CliBatch, AmbiguousOutputsAreRefused) {
    writeInputs();
    fs::create_directories(folder() / "other");
    writeImage(file("other/a.hdr"), smoothEquirect(32, 16));
    RunResult twice = run({"bake", a(), b(), file("other/a.hdr"), "--out-dir", file("out")});
    EXPECT_EQ(twice.exitCode, 2) << describe(twice);
    EXPECT_EQ(linesOf(twice.err).size(), 1u) << twice.err;
    EXPECT_CONTAINS(twice.err, a());
    EXPECT_CONTAINS(twice.err, file("other/a.hdr"));
    EXPECT_CONTAINS(twice.err, (folder() / "out" / "a.json").string());
    EXPECT_FALSE(fs::exists(file("out")));

    RunResult several = run({"bake", a(), b(), "-o", file("x.json")});
    EXPECT_EQ(several.exitCode, 2) << describe(several);
    EXPECT_CONTAINS(several.err, "--out-dir");
    writeText(file("list.txt"), a() + "\n");
    RunResult list = run({"bake", "--list", file("list.txt"), "-o", file("x.json")});
    EXPECT_EQ(list.exitCode, 2) << describe(list);
    EXPECT_CONTAINS(list.err, "--list needs --out-dir");
    RunResult both = run({"bake", a(), "-o", file("x.json"), "--out-dir", file("out")});
    EXPECT_EQ(both.exitCode, 2) << describe(both);
    EXPECT_CONTAINS(both.err, "--out-dir");
    EXPECT_FALSE(fs::exists(file("x.json")));
    EXPECT_FALSE(fs::exists(file("out")));
}

// With stderr on a terminal a batch draws a progress bar there ("\r[###...] 2/2 probes"); stdout
// (a file) holds the same lines as without one.
TEST_F(CliBatch, ProgressBarOnlyOnATerminal) {
    writeInputs();
    RunResult plain = runOk({"bake", a(), b(), "--out-dir", file("plain")});
    EXPECT_EQ(plain.err.find('\r'), std::string::npos);
    const TerminalRun terminal =
        runOnTerminal({"bake", a(), b(), "--out-dir", file("terminal")}, folder() / "terminal.out");
    const std::string out = readText(folder() / "terminal.out");
    EXPECT_EQ(terminal.exitCode, 0) << terminal.terminal;
    EXPECT_CONTAINS(terminal.terminal, "\r[");
    EXPECT_CONTAINS(terminal.terminal, "] 2/2 probes");
    EXPECT_EQ(terminal.terminal.find("error"), std::string::npos) << terminal.terminal;
    EXPECT_TRUE(hasBatchSummary(out, "2 probes baked, 0 failed;")) << out;
    EXPECT_EQ(linesOf(out).size(), linesOf(plain.out).size()) << out;
}

// A single bake of more than a second draws a line per stage on a terminal ("projecting, rows
// 4096/9216, 10.1 Mtexels/s, 1 s left"), at most 4 times a second, erased at the end; nothing of
// it with -q or without a terminal, and the probe is the same either way. The order-8 reference
// projection of 6 x 1536^2 texels takes 1.4-3 s here; the resampling before it ends within the
// first second, when nothing is drawn yet, so only the projection's line is required.
TEST_F(Cli, LargeSingleBakeDrawsProgressOnATerminal) {
    writeImage(file("sky.exr"), smoothEquirect(512, 256));
    const std::vector<std::string> bake = {"bake", file("sky.exr"), "--face-size", "1536", "--order",
                                           "8",    "--backend",     "reference"};
    auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = bake;
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    const TerminalRun shown = runOnTerminal(with({"-o", file("shown.json")}), folder() / "shown.out");
    ASSERT_EQ(shown.exitCode, 0) << shown.terminal;
    ASSERT_GT(shown.seconds, 1.2) << "the bake is too short to show its progress";
    EXPECT_CONTAINS(shown.terminal, "\rprojecting, rows ");
    EXPECT_CONTAINS(shown.terminal, "/9216, ");
    EXPECT_CONTAINS(shown.terminal, "texels/s");
    EXPECT_CONTAINS(shown.terminal, " s left");
    EXPECT_TRUE(shown.terminal.ends_with("\r\033[K")) << "the line is erased at the end: " << shown.terminal;
    const size_t draws = testing::drawsOf(shown.terminal, "\rprojecting, ") +
                         testing::drawsOf(shown.terminal, "\rresampling, ");
    EXPECT_LE(double(draws), 4.0 * shown.seconds + 2.0) << shown.terminal;

    const TerminalRun quiet = runOnTerminal(with({"-q", "-o", file("quiet.json")}), folder() / "quiet.out");
    EXPECT_EQ(quiet.exitCode, 0) << quiet.terminal;
    EXPECT_EQ(quiet.terminal, "");

    const RunResult plain = runOk(with({"-o", file("plain.json")}));
    EXPECT_EQ(linesOf(readText(folder() / "shown.out")).size(), linesOf(plain.out).size());
    EXPECT_EQ(readText(file("shown.json")), readText(file("plain.json")));
}

// ---- 8. Header formats ------------------------------------------------------------------------

// The four numbers of each array entry of a header: "vec4(r, g, b, w)" (GLSL) or "{r, g, b, w}"
// (C, 'f' suffixes), comments skipped.
std::vector<std::array<float, 4>> headerEntries(const std::string& header) {
    std::string code;
    for (const std::string& line : linesOf(header))
        code += line.substr(0, line.find("//")) + "\n";
    static const std::regex entry(R"((?:vec4\(|\{)\s*([^(){}]*?)\s*[)}])");
    std::vector<std::array<float, 4>> entries;
    for (auto match = std::sregex_iterator(code.begin(), code.end(), entry); match != std::sregex_iterator();
         ++match) {
        std::string numbers = (*match)[1];
        std::array<float, 4> values{};
        const char* text = numbers.c_str();
        for (float& value : values) {
            char* end = nullptr;
            value = std::strtof(text, &end);
            text = end + std::strspn(end, "fF, ");
        }
        entries.push_back(values);
    }
    return entries;
}

// --format glsl and --format cpp (single with -o, and a batch: one header per input, named after
// it) hold the coefficients folded for sh_irradiance.glsl: the fold of the exact float probe of
// --format binary, rounded to float, number for number (every GPU bake of an input gives the same
// bits). Orders above 5 and --extract-sun (the sun would be lost) are refused with these formats.
TEST_F(CliBatch, HeaderFormatsHoldTheFoldedProbe) {
    writeInputs();
    runOk({"bake", a(), "--order", "5", "--backend", "gpu", "-q", "--format", "binary", "-o", file("a.bin")});
    runOk({"bake", a(), "--order", "5", "--backend", "gpu", "-q", "--format", "cpp", "-o", file("a.h")});
    runOk({"bake", a(), c(), "--order", "5", "--backend", "gpu", "-q", "--format", "glsl", "--out-dir",
           file("glsl")});
    std::vector<ShCoefficients> binary = readBinaryProbes(file("a.bin"));
    ASSERT_EQ(binary.size(), 1u);
    FoldedCoefficients expected = *foldCoefficients(binary[0], 5, FoldedQuantity::Radiance);
    for (const fs::path& header : {folder() / "a.h", folder() / "glsl" / "a.glsl"}) {
        SCOPED_TRACE(header.string());
        std::string text = readText(header);
        EXPECT_CONTAINS(text, "shRadiance(");
        EXPECT_CONTAINS(text, "order      5:");
        std::vector<std::array<float, 4>> entries = headerEntries(text);
        ASSERT_EQ(entries.size(), size_t(kFoldedCount)) << text;
        for (int i = 0; i < kFoldedCount; ++i)
            for (int k = 0; k < 4; ++k)
                EXPECT_EQ(entries[i][k], k < 3 ? float(expected[i][k]) : 0.0f) << "entry " << i;
    }
    EXPECT_CONTAINS(readText(folder() / "a.h"), "static const float a_sh[25][4]");
    EXPECT_CONTAINS(readText(folder() / "glsl" / "c.glsl"), "const vec4 c_sh[SH_FOLDED_COUNT]");
    EXPECT_EQ(entriesOf(folder() / "glsl"), (std::vector<std::string>{"a.glsl", "c.glsl"}));

    RunResult order6 = run({"bake", a(), "--order", "6", "--format", "glsl", "-o", file("x.glsl")});
    EXPECT_EQ(order6.exitCode, 2) << describe(order6);
    EXPECT_CONTAINS(order6.err, "--format glsl");
    RunResult sun = run({"bake", "--extract-sun", "--format", "cpp", "-o", file("x.h")});
    EXPECT_EQ(sun.exitCode, 2) << describe(sun);
    EXPECT_CONTAINS(sun.err, "--extract-sun");
    EXPECT_FALSE(fs::exists(file("x.glsl")));
    EXPECT_FALSE(fs::exists(file("x.h")));
}

// ---- 9. A broken driver list ------------------------------------------------------------------

// An ICD manifest naming a driver library that does not exist.
void writeManifestOfMissingLibrary(const fs::path& path, const fs::path& library) {
    writeText(path, R"({"file_format_version": "1.0.0", "ICD": {"library_path": ")" + library.string() +
                        R"(", "api_version": "1.3.0"}})");
}

// The loader fails on a broken driver list in different ways: a manifest that is not JSON gives
// VK_ERROR_OUT_OF_HOST_MEMORY, a missing manifest or library VK_ERROR_INCOMPATIBLE_DRIVER. Each is
// exit 4 and one line that blames the list, naming the variable and its value, and never advice
// about sizes; the CPU backend needs no driver and still bakes. The loader stays quiet on stderr
// (VK_LOADER_DEBUG unset), with the validation layer on too: its messages are not validation's.
TEST_F(CliFailures, BrokenDriverListIsNamed) {
    writeText(file("garbage.json"), "{\"not\": \"an icd\"");
    writeManifestOfMissingLibrary(file("missing_library.json"), file("no_such_driver.so"));
    const std::vector<std::vector<std::string>> gpuCommands = {
        {"bake", "--backend", "gpu", "--face-size", "8", "-o", file("gpu.json")}, {"info"}};
    auto expectDriverListError = [&](const std::vector<std::string>& args, const EnvironmentChanges& changes,
                                     const std::string& variable) {
        SCOPED_TRACE(::testing::Message() << variable << " shprobe " << joined(args));
        RunResult result = run(args, {.environment = changes});
        EXPECT_EQ(result.exitCode, 4) << describe(result);
        EXPECT_EQ(linesOf(result.err).size(), 1u) << result.err;
        EXPECT_TRUE(startsWith(result.err, "shprobe: error: ")) << result.err;
        EXPECT_CONTAINS(result.err, "Vulkan driver list could not be loaded");
        EXPECT_CONTAINS(result.err, variable);
        EXPECT_CONTAINS(result.err, "--backend cpu");
        EXPECT_EQ(result.err.find("--face-size"), std::string::npos) << result.err;
        EXPECT_EQ(result.err.find("out of host memory; try"), std::string::npos) << result.err;
        EXPECT_EQ(result.err.find(".cpp"), std::string::npos)
            << "a source file in the message: " << result.err;
    };

    for (const std::string& list :
         {file("garbage.json"), file("no_such_icd.json"), file("missing_library.json")}) {
        EnvironmentChanges brokenList{{"VK_ICD_FILENAMES", list},
                                      {"VK_DRIVER_FILES", std::nullopt},
                                      {"VK_LOADER_DEBUG", std::nullopt},
                                      {"SHPROBE_VALIDATION", std::nullopt}};
        for (const std::vector<std::string>& args : gpuCommands)
            expectDriverListError(args, brokenList, "VK_ICD_FILENAMES=" + list);
        RunResult cpu = run({"bake", "--backend", "cpu", "--face-size", "8", "-q", "-o", file("cpu.json")},
                            {.environment = brokenList});
        EXPECT_EQ(cpu.exitCode, 0) << describe(cpu);
    }
    EXPECT_FALSE(fs::exists(file("gpu.json")));

    EnvironmentChanges driverFiles{{"VK_DRIVER_FILES", file("garbage.json")},
                                   {"VK_LOADER_DEBUG", std::nullopt},
                                   {"SHPROBE_VALIDATION", "1"}};
    expectDriverListError(gpuCommands[0], driverFiles, "VK_DRIVER_FILES=" + file("garbage.json"));
    // SHPROBE_DEBUG=1 adds the failed call's place in the source, on a line of its own.
    EnvironmentChanges debug = driverFiles;
    debug["SHPROBE_DEBUG"] = "1";
    RunResult debugged = run(gpuCommands[0], {.environment = debug});
    EXPECT_EQ(debugged.exitCode, 4) << describe(debugged);
    const std::vector<std::string> debugLines = linesOf(debugged.err);
    ASSERT_EQ(debugLines.size(), 2u) << debugged.err;
    EXPECT_TRUE(std::regex_search(
        debugLines[0], std::regex(R"(^shprobe: debug: vkCreateInstance failed at src/vk/context\.cpp:\d+$)")))
        << debugged.err;
    EXPECT_TRUE(startsWith(debugLines[1], "shprobe: error: ")) << debugged.err;

    // A list the loader copes with (lavapipe and a missing manifest) bakes under validation.
    const char* lavapipe = std::getenv("VK_ICD_FILENAMES");
    ASSERT_TRUE(lavapipe) << "ctest sets VK_ICD_FILENAMES to lavapipe";
    EnvironmentChanges partlyBroken{
        {"VK_ICD_FILENAMES", std::string(lavapipe) + ":" + file("no_such_icd.json")},
        {"VK_DRIVER_FILES", std::nullopt},
        {"VK_LOADER_DEBUG", std::nullopt},
        {"SHPROBE_VALIDATION", "1"}};
    RunResult partly =
        run({"bake", "--face-size", "8", "-q", "-o", file("partly.json")}, {.environment = partlyBroken});
    EXPECT_EQ(partly.exitCode, 0) << describe(partly);
    EXPECT_EQ(partly.err, "") << describe(partly);
}

} // namespace
} // namespace shprobe
