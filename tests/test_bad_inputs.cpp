// What the program does with hostile inputs, one test per row of the table of docs/reliability.md:
// truncated and oversized images, odd faces and channel counts, extreme texel values, options out
// of range, bad probe files, outputs that cannot be written, and Ctrl-C. Each failure must exit
// with the table's code and print exactly one line, "shprobe: error: ...", naming the input and the
// problem (no library chatter), leave no file behind (not even a temporary one) and leave an
// existing output byte for byte as it was. Also the device side: the requirements a device must
// meet, Vulkan errors as messages, and an allocation no device can make.
//
// ctest runs this with VK_ICD_FILENAMES = lavapipe and SHPROBE_VALIDATION=1, which the children
// inherit: a validation message fails their run. Test files are written by each test into its own
// temporary folder; no binary file is checked in.
#include "child_program.h"
#include "common/error.h"
#include "formats/probe_export.h"
#include "formats/probe_file.h"
#include "image/environment.h"
#include "image/image_write.h"
#include "png_chunks.h"
#include "sh/basis.h"
#include "test_images.h"
#include "test_support.h"
#include "vk/check.h"
#include "vk/context.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <functional>
#include <grp.h>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace shprobe {
namespace {
using testing::bigEndian32;
using testing::constantImage;
using testing::filledImage;
using testing::kPngSignature;
using testing::pngChunk;
using BadInputs = ProgramTest;

// ---- Test files -------------------------------------------------------------------------------

// Raw channels through OpenImageIO, for channel counts and formats writeImage (RGB) does not make.
template <typename T>
void writeChannels(const fs::path& path, int width, int height, int channels, OIIO::TypeDesc type,
                   const std::vector<T>& data) {
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(output) << OIIO::geterror();
    OIIO::ImageSpec spec(width, height, channels, type);
    spec.attribute("oiio:UnassociatedAlpha", 1);
    ASSERT_TRUE(output->open(path.string(), spec)) << output->geterror();
    ASSERT_TRUE(output->write_image(type, data.data())) << output->geterror();
    ASSERT_TRUE(output->close()) << output->geterror();
}

// An 8-bit PNG of noise: deflate cannot shrink it, so a cut always falls inside the pixel data.
void writeNoisePng(const fs::path& path, int width, int height) {
    std::vector<uint8_t> rgb(size_t(width) * height * 3);
    uint32_t state = 12345;
    for (uint8_t& byte : rgb)
        byte = uint8_t((state = state * 1664525u + 1013904223u) >> 24);
    writeChannels(path, width, height, 3, OIIO::TypeDesc::UINT8, rgb);
}

void cutFile(const fs::path& from, const fs::path& to, uintmax_t bytes) {
    fs::copy_file(from, to, fs::copy_options::overwrite_existing);
    fs::resize_file(to, bytes);
}

// A Radiance HDR header claiming width x height, and no pixels.
void writeHdrHeader(const fs::path& path, int width, int height) {
    writeText(path, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(height) + " +X " +
                        std::to_string(width) + "\n");
}

// A valid PNG signature and IHDR (8-bit RGB) claiming width x height, then the start of an empty
// zlib stream as the only IDAT and IEND: far too few pixels.
void writePngHeader(const fs::path& path, uint32_t width, uint32_t height) {
    std::string header = bigEndian32(width) + bigEndian32(height) + std::string("\x08\x02\x00\x00\x00", 5);
    writeText(path, kPngSignature + pngChunk("IHDR", header) + pngChunk("IDAT", std::string("\x78\x9c", 2)) +
                        pngChunk("IEND", ""));
}

constexpr double kY00 = 0.28209479177387814; // 1 / (2 sqrt(pi))

// ---- The command line ---------------------------------------------------------------------------

// The program builds only the parser of the command a line names (main.cpp): the top-level help
// still lists every command, each command's help lists its own options, and an option of another
// command is refused as unknown, wherever the command stands after the program's own flags.
TEST_F(BadInputs, EachCommandTakesItsOwnOptionsAndOnlyThose) {
    const std::pair<const char*, const char*> commands[] = {
        {"bake", "--face-size"},  {"convert", "--map-size"}, {"info", "--validation"},
        {"render", "--exposure"}, {"rotate", "--euler"},     {"light", "--directional"},
        {"scene", "--bounces"},   {"merge", "bricks"},       {"bench", "--sizes"},
    };
    const std::string help = runOk({"--help"}).out;
    for (const auto& [name, option] : commands) {
        EXPECT_NE(help.find("\n  " + std::string(name) + " "), std::string::npos) << name << " in\n" << help;
        const std::string own = runOk({name, "--help"}).out;
        EXPECT_NE(own.find(option), std::string::npos) << name << " --help:\n" << own;
    }
    EXPECT_NE(help.find("\n  view "), std::string::npos) << help;
    EXPECT_NE(runOk({"--help", "bake"}).out.find("--face-size"), std::string::npos)
        << "a command named after the program's --help gets its options, and the help is its own";
    expectFailure({{"rotate", "--grid", "1,1,1", "-o", "OUT"}, 2, {"--grid"}});
    expectFailure({{"bake", "--euler", "0,0,0", "-o", "OUT"}, 2, {"--euler"}});
    expectFailure({{"nonsense", "-o", "OUT"},
                   2,
                   {"there is no command \"nonsense\"; the commands are bake, convert,"}});
}

// ---- Truncated and oversized images -----------------------------------------------------------

// An EXR cut short loses pixels (the reader says so) or, cut to a few hundred bytes, its header
// (not an image). `bake` and `render` (which bakes an environment first) both refuse it.
TEST_F(BadInputs, TruncatedExr) {
    writeImage(file("full.exr"), filledImage(64, 32, [](int x, int y) { return glm::vec3(x, y, 1.0f); }));
    cutFile(file("full.exr"), file("short.exr"), fs::file_size(file("full.exr")) - 40);
    cutFile(file("full.exr"), file("head.exr"), 200);
    expectFailure({{"bake", file("short.exr"), "-o", "OUT"}, 2, {file("short.exr"), "truncated"}});
    expectFailure({{"bake", file("head.exr"), "-o", "OUT"}, 2, {file("head.exr"), "not an image"}});
    expectFailure(
        {{"render", file("short.exr"), "-o", "OUT"}, 2, {file("short.exr"), "truncated"}, "out.png"});
}

// EXR files and OpenImageIO's formats are read and written by plugins loaded on first use
// (image/exr_plugin.h, image/oiio_plugin.h). One that cannot be loaded fails the run like any bad
// input, naming the file, the library it needs and why (the dynamic loader's reason, or where it
// looked): reading (exit 2) and writing
// (exit 3, before any output is made), with nothing written.
TEST_F(BadInputs, CodecPluginsThatCannotBeLoadedAreNamed) {
    writeImage(file("sky.exr"), constantImage(16, 8, glm::vec3(1.0f)));
    writeImage(file("sky.hdr"), constantImage(16, 8, glm::vec3(1.0f)));
    writeChannels(file("sky.tif"), 16, 8, 3, OIIO::TypeDesc::FLOAT, std::vector<float>(16 * 8 * 3, 1.0f));
    const std::string missing = file("no-such-plugin.so");
    const EnvironmentChanges noExr{{"SHPROBE_EXR_PLUGIN", missing}};
    expectFailure({{"bake", file("sky.exr"), "-o", "OUT"},
                   2,
                   {file("sky.exr") + ": this format needs OpenEXR, and its plugin libshprobe_exr.so",
                    "(SHPROBE_EXR_PLUGIN: loading " + missing + " failed: " + missing +
                        ": cannot open shared object file: No such file or directory)"},
                   "out.json",
                   noExr});
    expectFailure({{"bake", file("sky.hdr"), "--format", "irradiance-equirect", "-o", "OUT"},
                   3,
                   {"cannot write", "out.exr: this format needs OpenEXR", missing},
                   "out.exr",
                   noExr});
    expectFailure(
        {{"bake", file("sky.tif"), "-o", "OUT"},
         2,
         {file("sky.tif") + ": this format needs OpenImageIO, and its plugin libshprobe_oiio.so", missing},
         "out.json",
         {{"SHPROBE_OIIO_PLUGIN", missing}}});
    // The same runs without the variables read and write these files.
    runOk({"bake", file("sky.exr"), "-o", file("sky.json")});
    runOk({"bake", file("sky.tif"), "-o", file("tif.json")});
    runOk({"bake", file("sky.hdr"), "--format", "irradiance-equirect", "-o", file("irradiance.exr")});
}

// libpng prints "libpng error: ..." itself before OpenImageIO reports the same: the program's
// stderr holds only its own line, which carries the library's text.
TEST_F(BadInputs, TruncatedPng) {
    writeNoisePng(file("full.png"), 64, 32);
    cutFile(file("full.png"), file("cut.png"), fs::file_size(file("full.png")) * 6 / 10);
    expectFailure({{"bake", file("cut.png"), "-o", "OUT"}, 2, {file("cut.png"), "truncated", "end of file"}});
}

// A file of zeros (a sparse 1 GiB one here) is no image, whatever its name: refused from its first
// 512 bytes, where OpenImageIO's DICOM reader, offered what no other reader takes, read it to its
// end 4 bytes at a time (26 s for 200 MB).
TEST_F(BadInputs, FilesOfZerosAreRefusedAtOnce) {
    for (const char* name : {"zeros.hdr", "zeros.tif"}) {
        std::ofstream(file(name)).close();
        fs::resize_file(file(name), uintmax_t(1) << 30);
        expectFailure(
            {{"bake", file(name), "-o", "OUT"}, 2, {file(name), "its first 512 bytes are all zero"}});
    }
}

// A header claiming 65536 x 32768 (2^31 pixels, 32 GiB as RGBA32F) is refused from the header
// with the limit and the option that raises it: the run is quick and allocates nothing of that size.
TEST_F(BadInputs, OversizeHeaderIsRefusedBeforeAnyAllocation) {
    writeHdrHeader(file("huge.hdr"), 65536, 32768);
    writePngHeader(file("huge.png"), 65536, 32768);
    writeHdrHeader(file("long.hdr"), 100000, 1);
    for (const char* name : {"huge.hdr", "huge.png"}) {
        expectFailure(
            {{"bake", file(name), "-o", "OUT"},
             2,
             {file(name), "65536x32768", "limit of 134217728 pixels (16384x8192)", "--max-pixels"}});
        RunResult quick = run({"bake", file(name), "-o", file("quick.json")});
        EXPECT_LT(quick.seconds, 5.0) << "refused from the header, before reading";
    }
    expectFailure({{"bake", file("long.hdr"), "-o", "OUT"}, 2, {file("long.hdr"), "100000x1", "65536"}});
    expectFailure(
        {{"render", file("huge.hdr"), "-o", "OUT"}, 2, {file("huge.hdr"), "--max-pixels"}, "out.png"});
}

// --max-pixels sets the limit: a 64 x 32 image (2048 pixels) passes at 2048 and is refused at 2047.
TEST_F(BadInputs, MaxPixelsSetsTheLimit) {
    writeImage(file("small.exr"), constantImage(64, 32, glm::vec3(1.0f)));
    runOk(
        {"bake", file("small.exr"), "--backend", "cpu", "--max-pixels", "2048", "-q", "-o", file("ok.json")});
    expectFailure({{"bake", file("small.exr"), "--backend", "cpu", "--max-pixels", "2047", "-o", "OUT"},
                   2,
                   {file("small.exr"), "64x32 (2048 pixels)", "limit of 2047 pixels"}});
    expectFailure({{"bake", file("small.exr"), "--max-pixels", "0", "-o", "OUT"}, 2, {"--max-pixels"}});
}

// ---- Faces and channels -----------------------------------------------------------------------

void writeFaces(const fs::path& folder, int width, int height, const std::function<float(int)>& value) {
    fs::create_directories(folder);
    const char* names[kFaceCount] = {"px", "nx", "py", "ny", "pz", "nz"};
    for (int face = 0; face < kFaceCount; ++face)
        writeImage((folder / (std::string(names[face]) + ".exr")).string(),
                   constantImage(width, height, glm::vec3(value(face))));
}

TEST_F(BadInputs, NonSquareFaces) {
    writeFaces(folder() / "faces", 16, 12, [](int) { return 1.0f; });
    expectFailure({{"bake", file("faces"), "-o", "OUT"}, 2, {"px.exr", "16x12", "square"}});
}

// Six 1 x 1 faces are a valid cube map: each texel is a whole face, 4 pi / 6 sr, so
// L00 = Y00 (4 pi / 6) (sum of the six values) exactly. The GPU and the fast CPU path give it to
// fp32 precision, the double reference to the file's 9 digits.
TEST_F(BadInputs, OneTexelFacesAreBaked) {
    writeFaces(folder() / "faces", 1, 1, [](int face) { return float(face + 1); });
    runOk({"bake", file("faces"), "-q", "-o", file("gpu.json")});
    runOk({"bake", file("faces"), "-q", "--backend", "cpu", "-o", file("fast.json")});
    runOk({"bake", file("faces"), "-q", "--backend", "reference", "-o", file("cpu.json")});
    const double expected = kY00 * (4.0 * std::numbers::pi / 6.0) * 21.0;
    EXPECT_NEAR(readProbeFile(file("gpu.json")).rgb[0].r, expected, 1e-6 * expected);
    EXPECT_NEAR(readProbeFile(file("fast.json")).rgb[0].r, expected, 1e-6 * expected);
    EXPECT_NEAR(readProbeFile(file("cpu.json")).rgb[0].r, expected, 5e-9 * expected); // 9 digits in the file
}

// 1 channel is grey for R, G and B; 2 channels grey and alpha; 4 channels RGB and alpha. Alpha is
// ignored (here 0: it neither blackens nor weights anything). A constant c gives L00 = c Y00 4 pi.
TEST_F(BadInputs, OneTwoAndFourChannelsHaveTheirStatedMeaning) {
    const int w = 16, h = 8;
    writeChannels(file("grey.exr"), w, h, 1, OIIO::TypeDesc::FLOAT, std::vector<float>(w * h, 0.5f));
    std::vector<float> greyAlpha, rgba;
    for (int t = 0; t < w * h; ++t) {
        greyAlpha.insert(greyAlpha.end(), {0.5f, 0.0f});
        rgba.insert(rgba.end(), {0.25f, 0.5f, 0.75f, 0.0f});
    }
    writeChannels(file("grey_alpha.exr"), w, h, 2, OIIO::TypeDesc::FLOAT, greyAlpha);
    writeChannels(file("rgba.exr"), w, h, 4, OIIO::TypeDesc::FLOAT, rgba);
    const double full = kY00 * 4.0 * std::numbers::pi;
    const std::map<std::string, glm::dvec3> expected = {
        {"grey.exr", glm::dvec3(0.5)}, {"grey_alpha.exr", glm::dvec3(0.5)}, {"rgba.exr", {0.25, 0.5, 0.75}}};
    for (const auto& [name, value] : expected) {
        runOk({"bake", file(name), "--backend", "cpu", "-q", "-o", file(name + ".json")});
        ShCoefficients probe = readProbeFile(file(name + ".json"));
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(probe.rgb[0][c], value[c] * full, 1e-6 * full) << name << " " << c;
    }
}

// ---- Texel values -----------------------------------------------------------------------------

// NaN and +Inf texels are refused with their count, unless --sanitize replaces them with 0.
TEST_F(BadInputs, NanAndInfinityNeedSanitize) {
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    writeImage(file("nan.exr"),
               filledImage(16, 8, [&](int x, int y) { return glm::vec3(x == 3 && y == 2 ? nan : 1.0f); }));
    writeImage(file("inf.exr"),
               filledImage(16, 8, [&](int x, int) { return glm::vec3(x < 2 ? inf : 1.0f); }));
    expectFailure({{"bake", file("nan.exr"), "-o", "OUT"},
                   2,
                   {file("nan.exr"), "1 texel is NaN or infinite", "--sanitize to replace it with 0"}});
    expectFailure({{"bake", file("inf.exr"), "-o", "OUT"},
                   2,
                   {file("inf.exr"), "16 texels are NaN or infinite", "--sanitize to replace them with 0"}});
    RunResult sanitized = runOk({"bake", file("inf.exr"), "--sanitize", "-q", "-o", file("sanitized.json")});
    EXPECT_CONTAINS(sanitized.out, "replaced 16 NaN/Inf texels with 0");
    RunResult one = runOk({"bake", file("nan.exr"), "--sanitize", "-o", file("one.json")});
    EXPECT_CONTAINS(one.out, "replaced 1 NaN/Inf texel with 0");
    EXPECT_TRUE(std::isfinite(readProbeFile(file("sanitized.json")).rgb[0].r));
}

// Negative texels are baked as they are (the projection is linear): a constant (-1, -2, -3) gives
// L00 = Y00 4 pi (-1, -2, -3), on the GPU as on the CPU.
TEST_F(BadInputs, NegativeTexelsAreBakedAsGiven) {
    writeImage(file("negative.exr"), constantImage(32, 16, glm::vec3(-1.0f, -2.0f, -3.0f)));
    runOk({"bake", file("negative.exr"), "-q", "-o", file("negative.json")});
    const double full = kY00 * 4.0 * std::numbers::pi;
    ShCoefficients probe = readProbeFile(file("negative.json"));
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(probe.rgb[0][c], -(c + 1) * full, 2e-6 * (c + 1) * full) << c;
}

// 1e30 is a finite float and bakes (L00 = 1e30 Y00 4 pi, within fp32 of it).
TEST_F(BadInputs, HugeFiniteTexelsAreBaked) {
    writeImage(file("huge.exr"), constantImage(32, 16, glm::vec3(1e30f)));
    runOk({"bake", file("huge.exr"), "-q", "-o", file("huge.json")});
    const double expected = 1e30 * kY00 * 4.0 * std::numbers::pi;
    EXPECT_NEAR(readProbeFile(file("huge.json")).rgb[0].r, expected, 2e-6 * expected);
}

// 3e38 is finite too, but the fp32 sums of the GPU and of the fast CPU path overflow: refused
// (exit 2) with one line naming the input, and nothing is written; at the default backend too.
// The double reference sums it, but its L00 (3e38 sqrt(4 pi) = 1.06e39) is past the floats every
// file holds, and so is the irradiance pi L00 = 5.6e38 of 5e37, written with --irradiance: refused
// alike, where the JSON took 1.06e39, which render and convert then refused. 5e37's radiance (L00
// 1.8e38) fits, and is written.
TEST_F(BadInputs, TexelsOverflowingFp32SumsAreRefused) {
    writeImage(file("overflow.exr"), constantImage(32, 16, glm::vec3(3e38f)));
    for (const char* backend : {"auto", "gpu", "cpu"})
        expectFailure({{"bake", file("overflow.exr"), "--backend", backend, "-o", "OUT"},
                       2,
                       {file("overflow.exr"), "not finite", "fp32 sums"}});
    writeImage(file("bright.exr"), constantImage(32, 16, glm::vec3(5e37f)));
    for (const auto& [format, output] : {std::pair{"json", "out.json"}, std::pair{"binary", "out.bin"}}) {
        expectFailure(
            {{"bake", file("overflow.exr"), "--backend", "reference", "--format", format, "-o", "OUT"},
             2,
             {file("overflow.exr"), "past the float range"},
             output});
        expectFailure({{"bake", file("bright.exr"), "--backend", "reference", "--irradiance", "--format",
                        format, "-o", "OUT"},
                       2,
                       {file("bright.exr"), "past the float range"},
                       output});
    }
    runOk({"bake", file("bright.exr"), "--backend", "reference", "-q", "-o", file("bright.json")});
}

// Lights past float added to a finite projection: refused on every backend, naming the lights (the
// image is not at fault). An --ambient of 5e37 has L00 = 5e37 sqrt(4 pi) = 1.8e38, which fits, but
// its irradiance pi L00 = 5.6e38 does not; 1e37's (1.1e38) does. An image of 5e37 whose irradiance
// is past float already (the double reference bakes it) is refused too once lights add to it.
TEST_F(BadInputs, LightsPastFloatAreRefused) {
    writeImage(file("plain.exr"), constantImage(32, 16, glm::vec3(1.0f)));
    for (const char* backend : {"gpu", "cpu", "reference"})
        for (const char* ambient : {"1e39,1,1", "5e37,1,1"})
            expectFailure(
                {{"bake", file("plain.exr"), "--ambient", ambient, "--backend", backend, "-o", "OUT"},
                 2,
                 {"error: " + file("plain.exr"), "--ambient", "past float", "make them weaker"}});
    runOk({"bake", file("plain.exr"), "--ambient", "1e37,1,1", "-q", "-o", file("bright.json")});
    writeImage(file("bright.exr"), constantImage(32, 16, glm::vec3(5e37f)));
    expectFailure(
        {{"bake", file("bright.exr"), "--ambient", "1e39,1,1", "--backend", "reference", "-o", "OUT"},
         2,
         {"error: " + file("bright.exr"), "radiance reaches", "past float"}});
    expectFailure(
        {{"light", "--ambient", "1e39,1,1", "-o", "OUT"}, 2, {"light: ", "--ambient", "past float"}});
}

// ---- Options out of range ---------------------------------------------------------------------

TEST_F(BadInputs, OrderAndFaceSizeOutOfRange) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    expectFailure({{"bake", "--order", "0", "-o", "OUT"}, 2, {"--order", "0"}});
    expectFailure({{"bake", "--order", "9", "-o", "OUT"}, 2, {"--order", "9"}});
    expectFailure({{"bake", "--face-size", "0", "-o", "OUT"}, 2, {"--face-size", "0"}});
    expectFailure({{"light", "--order", "9", "--ambient", "1,1,1", "-o", "OUT"}, 2, {"--order", "9"}});
    expectFailure(
        {{"render", file("probe.json"), "--face-size", "0", "-o", "OUT"}, 2, {"--face-size"}, "out.png"});
    expectFailure(
        {{"render", file("probe.json"), "--order", "4", "-o", "OUT"}, 2, {"--order", "4"}, "out.png"});
}

// ---- Probe files ------------------------------------------------------------------------------

// Every command that reads probe files refuses each bad one, naming the file and what is wrong:
// malformed and truncated JSON (with where the parser stopped), an empty file, a folder, a missing
// file, a file of another format (by its first bytes), and files of the wrong schema. `view` reads
// them before opening a window.
TEST_F(BadInputs, BadProbeFilesAreRefusedByEveryCommand) {
    const std::string valid = probeToJson(testing::distinctProbe(3), {});
    auto edited = [&](const std::string& from, const std::string& to) {
        std::string text = valid;
        size_t at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from << " not in\n" << valid;
        return at == std::string::npos ? text : text.replace(at, from.size(), to);
    };
    enum class Kind { File, Folder, Missing };
    struct BadProbe {
        std::string name;
        std::string text;
        std::vector<std::string> problem;
        Kind kind = Kind::File;
    };
    const std::vector<BadProbe> probes = {
        {"malformed.json", "{\"format\": \"shprobe.sh\",, }", {"not valid JSON", "line 1, column 25"}},
        {"truncated.json", valid.substr(0, valid.size() / 2), {"not valid JSON", "parse error at line"}},
        {"empty.json", "", {"the file is empty"}},
        {"garbage.json", std::string("\x01\x7f\0\0garbage", 11), {"not valid JSON"}},
        {"image.json", std::string("\x89PNG\r\n\x1a\n\0\0", 10), {"a PNG image, not a probe file"}},
        {"array.json", "[1, 2, 3]", {"JSON object"}},
        {"no_format.json", edited("\"format\": \"shprobe.sh\",", ""), {"missing field \"format\""}},
        {"version.json", edited("\"version\": 1", "\"version\": 2"), {"field \"version\" must be 1"}},
        {"order.json", edited("\"order\": 3", "\"order\": 9"), {"field \"order\""}},
        {"rows.json", edited("\"order\": 3", "\"order\": 4"), {"16 rows for order 4, not 9"}},
        {"row.json", edited("[1, 0.5, -0]", "[\"one\", 0.5, 0]"), {"coefficients[0]"}},
        {"overflow.json", edited("[1, 0.5, -0]", "[1e999, 0.5, 0]"), {"not valid JSON", "overflow"}},
        {"folder.json", "", {"is a folder"}, Kind::Folder},
        {"missing.json", "", {"no such file"}, Kind::Missing},
    };
    for (const BadProbe& probe : probes) {
        const std::string path = file(probe.name);
        if (probe.kind == Kind::Folder) fs::create_directories(path);
        if (probe.kind == Kind::File) writeText(path, probe.text);
        std::vector<std::string> mentions = probe.problem;
        mentions.push_back(path);
        SCOPED_TRACE(probe.name);
        expectFailure({{"rotate", path, "--euler", "0,90,0", "-o", "OUT"}, 2, mentions});
        // The three commands share the reader; each program start costs about 0.3 s (the libraries
        // OpenImageIO loads), so render and view get one file of each kind.
        if (probe.name != "malformed.json" && probe.name != "truncated.json" &&
            probe.name != "version.json" && probe.name != "folder.json")
            continue;
        expectFailure({{"render", path, "-o", "OUT"}, 2, mentions, "out.png"});
        expectFailure({{"view", path, "--frames", "1", "--screenshot", "OUT"}, 2, mentions, "shot.png"});
    }
}

// ---- Outputs that cannot be written -----------------------------------------------------------

// Every command that writes, with an output of each kind it writes.
std::vector<Failure> everyWriter(const std::string& probe) {
    return {
        {{"bake", "--face-size", "4", "-o", "OUT"}, 3, {}, "probe.json"},
        {{"bake", "--face-size", "4", "--format", "binary", "-o", "OUT"}, 3, {}, "probe.bin"},
        {{"bake", "--face-size", "4", "--format", "irradiance-equirect", "-o", "OUT"}, 3, {}, "map.exr"},
        {{"rotate", probe, "--euler", "0,90,0", "-o", "OUT"}, 3, {}, "rotated.json"},
        {{"light", "--ambient", "1,1,1", "-o", "OUT"}, 3, {}, "light.json"},
        {{"render", probe, "--size", "8", "-o", "OUT"}, 3, {}, "render.png"},
        {{"render", probe, "--size", "8", "-o", "OUT"}, 3, {}, "render.exr"},
        {{"view", probe, "--frames", "1", "--screenshot", "OUT"}, 3, {}, "shot.png"},
        {{"bench", "--sizes", "4", "--json", "OUT"}, 3, {}, "bench.json"},
    };
}

// Exit 3 before any work, the message names the missing folder; the folder is not created.
TEST_F(BadInputs, OutputIntoAMissingFolder) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    const fs::path missing = folder() / "no_such_folder";
    for (Failure failure : everyWriter(file("probe.json"))) {
        failure.mentions = {missing.string(), "does not exist"};
        SCOPED_TRACE(failure.args[0] + " -> " + failure.output);
        RunResult result = run(withOutput(failure.args, (missing / failure.output).string()));
        expectMessage(failure, result);
        EXPECT_LT(result.seconds, 5.0) << "the output must be checked before any work";
        EXPECT_FALSE(fs::exists(missing));
    }
}

// An output ending in / (or . or ..) names a folder, even one that is not there: exit 3 before any
// work, saying why in words, where it said "it is a folder" of a name that was none; nothing made.
TEST_F(BadInputs, AnOutputEndingInASlashIsRefused) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    for (Failure failure : everyWriter(file("probe.json"))) {
        failure.mentions = {"names a folder, not a file"};
        SCOPED_TRACE(failure.args[0] + " -> " + failure.output);
        const std::string output = file("new_" + failure.output);
        RunResult result = run(withOutput(failure.args, output + "/"));
        expectMessage(failure, result);
        EXPECT_LT(result.seconds, 5.0) << "the output must be checked before any work";
        EXPECT_FALSE(fs::exists(output));
    }
}

// "-o ''" names no file: every command refuses it in the same words (exit 2, one line; bake and
// convert have a default name they must not take instead, the others said "cannot write ''" with
// exit 3), and nothing appears in the working folder. So does an empty input
// or file option where a default exists (a script's empty variable): bake '' and render '' baked
// the built-in sky, --out-dir '' wrote into the working folder, --sky '' and --probe '' lit by the
// built-in sky, bench --json '' wrote nothing; scene '', transfer '', merge '' and relight '' said
// ": no such file".
TEST_F(BadInputs, AnEmptyOutputNameIsRefused) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    const fs::path working = folder() / "working";
    fs::create_directories(working);
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"bake", "-o", ""}, "--output"},
        {{"convert", file("probe.json"), "-o", ""}, "--output"},
        {{"rotate", file("probe.json"), "--euler", "0,0,0", "-o", ""}, "--output"},
        {{"light", "--ambient", "1,1,1", "-o", ""}, "--output"},
        {{"render", file("probe.json"), "-o", ""}, "--output"},
        {{"scene", file("s.glb"), "--grid", "1,1,1", "-o", ""}, "--output"},
        {{"transfer", file("s.glb"), "-o", ""}, "--output"},
        {{"merge", file("v.shpv"), "-o", ""}, "--output"},
        {{"relight", file("v.shpv"), "-o", ""}, "--output"},
        {{"bake", ""}, "input"},
        {{"render", "", "-o", file("r.png")}, "input"},
        {{"bake", "--out-dir", ""}, "--out-dir"},
        {{"bake", "--list", "", "--out-dir", file("probes")}, "--list"},
        {{"scene", file("s.glb"), "--sky", "", "-o", file("v.shpv")}, "--sky"},
        {{"relight", file("v.shpv"), "--probe", "", "-o", file("w.shpv")}, "--probe"},
        {{"bench", "--json", ""}, "--json"},
        {{"scene", "", "--grid", "1,1,1", "-o", file("v.shpv")}, "scene"},
        {{"transfer", "", "-o", file("t.glb")}, "scene"},
        {{"merge", "", "-o", file("v.shpv")}, "bricks"},
        {{"relight", "", "-o", file("w.shpv")}, "volume"},
    };
    for (const auto& [args, option] : cases) {
        SCOPED_TRACE(args[0] + " " + option);
        const RunResult result = run(args, {.workingFolder = working.string()});
        expectMessage({args, 2, {option + ": '' names no file"}}, result);
        EXPECT_TRUE(fs::is_empty(working));
    }
    for (const char* name : {"r.png", "probes", "v.shpv", "w.shpv", "t.glb"})
        EXPECT_FALSE(fs::exists(file(name))) << name;
}

// A binary file given as --list (an image, say) is refused at its first NUL byte, naming the line,
// before any input is read: its bytes were taken for paths, and the outputs' names cut at the NUL.
TEST_F(BadInputs, ListOfABinaryFileIsRefused) {
    writeText(file("list.txt"),
              "# skies\n" + file("a.exr") + "\n" + std::string("\x89PNG\0\x01\xff", 7) + "\n");
    const RunResult result = run({"bake", "--list", file("list.txt"), "--out-dir", file("probes")});
    expectMessage({{}, 2, {"--list " + file("list.txt") + ": line 3 holds a NUL byte"}}, result);
    EXPECT_FALSE(fs::exists(file("probes")));
}

// A binary probe file of several probes (a batch's) is not one probe: the readers say so instead
// of taking the first alone, also where the batch is larger than any JSON probe file (1 MiB).
TEST_F(BadInputs, ProbeReadersTakeABinaryFileOfOneProbe) {
    const ShCoefficients probe = testing::distinctProbe(3);
    for (const size_t count : {size_t(2), size_t(20000)}) {
        const std::vector<ShCoefficients> batch(count, probe);
        writeBinaryProbes(file("batch.bin"), batch);
        const std::string holds = "holds " + std::to_string(count) + " probes; give a file of one probe";
        for (const std::vector<std::string>& args :
             {std::vector<std::string>{"convert", file("batch.bin"), "-o", "OUT"},
              {"rotate", file("batch.bin"), "--euler", "0,0,0", "-o", "OUT"}})
            expectFailure({args, 2, {file("batch.bin"), holds}, "out.json"});
    }
    ASSERT_GT(fs::file_size(file("batch.bin")), uintmax_t(1) << 20);
}

// A binary probe is known by its magic, not its name: from standard input, under another extension,
// and as render's and rotate's input it reads back as the float32 values it holds.
TEST_F(BadInputs, BinaryProbesAreReadByContent) {
    const ShCoefficients probe = testing::distinctProbe(3);
    writeBinaryProbes(file("probe.bin"), std::span(&probe, 1));
    fs::copy_file(file("probe.bin"), file("probe.dat"));
    const auto expectSameProbe = [&](const std::string& path) {
        const ShCoefficients back = readProbeFile(path);
        ASSERT_EQ(back.rgb.size(), probe.rgb.size());
        for (size_t i = 0; i < probe.rgb.size(); ++i)
            for (int c = 0; c < 3; ++c)
                EXPECT_EQ(back.rgb[i][c], double(float(probe.rgb[i][c]))) << path << " coefficient " << i;
    };
    const RunResult piped =
        run({"convert", "-", "-o", file("piped.json")}, {.standardInput = file("probe.bin")});
    EXPECT_EQ(piped.exitCode, 0) << piped.err;
    expectSameProbe(file("piped.json"));
    runOk({"convert", file("probe.dat"), "-o", file("renamed.json")});
    expectSameProbe(file("renamed.json"));
    runOk({"rotate", file("probe.bin"), "--euler", "0,0,0", "-o", file("turned.json")});
    expectSameProbe(file("turned.json"));
    runOk({"render", file("probe.bin"), "--size", "8", "-o", file("sphere.exr")});
    EXPECT_TRUE(fs::exists(file("sphere.exr")));
}

// Exit 3, naming the folder; an existing file in it is untouched and nothing is added. Permission
// bits do not stop root: as root, the program runs as user nobody.
TEST_F(BadInputs, OutputIntoAReadOnlyFolder) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    const fs::path readonly = folder() / "readonly";
    fs::create_directories(readonly);
    const std::string before = "an earlier good output\n";
    std::vector<std::string> names;
    for (const Failure& failure : everyWriter(file("probe.json"))) {
        writeText(readonly / failure.output, before);
        names.push_back(failure.output);
    }
    std::sort(names.begin(), names.end());
    names.erase(std::unique(names.begin(), names.end()), names.end());
    fs::permissions(readonly, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                                  fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
    for (Failure failure : everyWriter(file("probe.json"))) {
        failure.mentions = {readonly.string(), "not writable"};
        SCOPED_TRACE(failure.args[0] + " -> " + failure.output);
        for (const std::string& name : {failure.output, "new_" + failure.output}) {
            RunResult result =
                run(withOutput(failure.args, (readonly / name).string()), {.asOtherUser = true});
            expectMessage(failure, result);
        }
    }
    EXPECT_EQ(entriesOf(readonly), names);
    for (const std::string& name : names)
        EXPECT_EQ(readText(readonly / name), before) << name;
}

// ---- Ctrl-C -----------------------------------------------------------------------------------

// A signal ends the run within a second whatever it is doing, by the signal itself (a shell shows
// 130 for SIGINT, 143 for SIGTERM), with no partial or temporary file and the earlier output intact.
void expectInterrupted(const RunResult& result, int signal, double signalledAt) {
    EXPECT_EQ(result.exitCode, 128 + signal) << describe(result);
    EXPECT_LT(result.seconds - signalledAt, 1.0) << "the run must end promptly";
}

double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// A long bake (6 x 2048^2 texels of the built-in sky projected by the double reference at order 8,
// about 5 s on these machines), interrupted by SIGINT after 0.5 s and by SIGTERM after 1.2 s. The signals are
// handled by a thread of their own, so the phase the bake is in does not matter.
TEST_F(BadInputs, InterruptedBakeLeavesNoFile) {
    for (auto [signal, after] : {std::pair{SIGINT, 500}, std::pair{SIGTERM, 1200}}) {
        SCOPED_TRACE(strsignal(signal));
        const fs::path out = folder() / "out";
        fs::remove_all(out);
        fs::create_directories(out);
        writeText(out / "probe.json", "an earlier good output\n");
        Clock::time_point start = Clock::now();
        Child bake({"bake", "--face-size", "2048", "--backend", "reference", "--order", "8", "-q", "-o",
                    (out / "probe.json").string()},
                   folder() / "logs", {});
        std::this_thread::sleep_for(std::chrono::milliseconds(after));
        ASSERT_TRUE(bake.running()) << "the bake ended before it could be interrupted";
        double signalledAt = secondsSince(start);
        bake.signal(signal);
        expectInterrupted(bake.wait(), signal, signalledAt);
        EXPECT_EQ(entriesOf(out), std::vector<std::string>{"probe.json"});
        EXPECT_EQ(readText(out / "probe.json"), "an earlier good output\n");
    }
}

// While the output is being written: a 4096 x 2048 irradiance map takes seconds to compress, and
// the signal comes as soon as its temporary file exists. The temporary file goes with the process.
TEST_F(BadInputs, InterruptWhileWritingRemovesTheTemporaryFile) {
    const fs::path out = folder() / "out";
    fs::create_directories(out);
    writeText(out / "map.exr", "an earlier good output\n");
    Clock::time_point start = Clock::now();
    Child bake({"bake", "--backend", "cpu", "--face-size", "16", "--format", "irradiance-equirect",
                "--map-size", "4096", "-q", "-o", (out / "map.exr").string()},
               folder() / "logs", {});
    while (entriesOf(out).size() < 2 && bake.running() && secondsSince(start) < 60.0)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    std::vector<std::string> during = entriesOf(out);
    ASSERT_EQ(during.size(), 2u) << "no temporary file appeared while the map was written";
    EXPECT_EQ(during[0].rfind(".map.", 0), 0u) << during[0];
    double signalledAt = secondsSince(start);
    bake.signal(SIGINT);
    expectInterrupted(bake.wait(), SIGINT, signalledAt);
    EXPECT_EQ(entriesOf(out), std::vector<std::string>{"map.exr"});
    EXPECT_EQ(readText(out / "map.exr"), "an earlier good output\n");
}

// ---- The device: requirements, Vulkan errors, memory ------------------------------------------

DeviceCapabilities capableDevice() {
    return {VK_API_VERSION_1_3, true, VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
            VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_VOTE_BIT |
                VK_SUBGROUP_FEATURE_ARITHMETIC_BIT};
}

// Each requirement missing alone is named the way Vulkan names it.
TEST(DeviceRequirements, EachMissingFeatureIsNamed) {
    EXPECT_EQ(missingRequirement(capableDevice()), "");
    DeviceCapabilities old = capableDevice();
    old.apiVersion = VK_API_VERSION_1_0;
    EXPECT_CONTAINS(missingRequirement(old), "Vulkan 1.0.0 (shprobe needs 1.1)");
    DeviceCapabilities noCompute = capableDevice();
    noCompute.computeQueue = false;
    EXPECT_CONTAINS(missingRequirement(noCompute), "no compute queue");
    DeviceCapabilities fragmentOnly = capableDevice();
    fragmentOnly.subgroupStages = VK_SHADER_STAGE_FRAGMENT_BIT;
    EXPECT_CONTAINS(missingRequirement(fragmentOnly), "VK_SHADER_STAGE_COMPUTE_BIT");
    DeviceCapabilities noArithmetic = capableDevice();
    noArithmetic.subgroupOperations = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_VOTE_BIT;
    EXPECT_CONTAINS(missingRequirement(noArithmetic), "VK_SUBGROUP_FEATURE_ARITHMETIC_BIT");
    EXPECT_CONTAINS(missingRequirement(noArithmetic), "subgroupAdd");
    DeviceCapabilities noBasic = capableDevice();
    noBasic.subgroupOperations = VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
    EXPECT_CONTAINS(missingRequirement(noBasic), "VK_SUBGROUP_FEATURE_BASIC_BIT");
}

DeviceInfo deviceNamed(const std::string& name, uint32_t index, std::string unsupportedReason) {
    DeviceInfo device;
    device.name = name;
    device.index = index;
    device.type = VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU;
    device.unsupportedReason = std::move(unsupportedReason);
    return device;
}

// The message of the Error(Device) that f must throw.
std::string deviceErrorOf(const std::function<void()>& f) {
    return testing::errorOf(ErrorKind::Device, f);
}

// A device without a required feature is passed over for one that has it; when none has it (or
// the one asked for lacks it) the run is refused, naming each device, what it lacks, and the CPU
// backend.
TEST(DeviceRequirements, DevicesLackingAFeatureAreRefusedByName) {
    DeviceCapabilities noArithmetic = capableDevice();
    noArithmetic.subgroupOperations = VK_SUBGROUP_FEATURE_BASIC_BIT;
    const std::string lacks = missingRequirement(noArithmetic);
    std::vector<DeviceInfo> devices = {deviceNamed("Old GPU", 0, lacks), deviceNamed("llvmpipe", 1, "")};
    EXPECT_EQ(pickDevice(devices, "").name, "llvmpipe");

    std::string requested = deviceErrorOf([&] { pickDevice(devices, "old"); });
    EXPECT_CONTAINS(requested, "Old GPU cannot be used: " + lacks);
    EXPECT_CONTAINS(requested, "--backend cpu");

    devices[1].unsupportedReason = "no compute queue";
    std::string none = deviceErrorOf([&] { pickDevice(devices, ""); });
    EXPECT_CONTAINS(none, "no usable Vulkan device");
    EXPECT_CONTAINS(none, "Old GPU: " + lacks);
    EXPECT_CONTAINS(none, "llvmpipe: no compute queue");
    EXPECT_CONTAINS(none, "--backend cpu");
}

// --backend auto starts no Vulkan where nothing shows a GPU (any device there would be a CPU): the
// files by which a GPU's driver reaches it, and NVIDIA's kernel module, are found by name under a
// made-up root, and only they: not a card node alone (a display), nor other devices.
using GpuFiles = ProgramTest;
TEST_F(GpuFiles, AreFoundByName) {
    EXPECT_EQ(findGpuFile(file("missing")), "");
    const fs::path root = folder() / "root";
    fs::create_directories(root / "dev" / "dri" / "by-path");
    fs::create_directories(root / "proc" / "driver");
    for (const char* other : {"dev/null", "dev/zero", "dev/tty0", "dev/fb0", "dev/nvme0", "dev/dri/card0",
                              "dev/dri/by-path/pci-0000:00:02.0-card", "proc/driver/rtc"})
        writeText(root / other, "");
    EXPECT_EQ(findGpuFile(root.string()), "") << "no GPU: a display's card node and other files";
    for (const char* gpu :
         {"dev/dri/renderD128", "dev/nvidia0", "dev/nvidiactl", "dev/nvhost-ctrl", "dev/nvmap", "dev/nvgpu",
          "dev/dxg", "dev/mali0", "dev/kgsl-3d0", "dev/galcore", "dev/pvrsrvkm", "proc/driver/nvidia"}) {
        writeText(root / gpu, "");
        EXPECT_EQ(findGpuFile(root.string()), (root / gpu).string());
        fs::remove(root / gpu);
    }
    // Without a dri folder (whose listing fails) the other places are still listed.
    const fs::path plain = folder() / "plain";
    fs::create_directories(plain / "dev");
    writeText(plain / "dev" / "nvidia0", "");
    EXPECT_EQ(findGpuFile(plain.string()), (plain / "dev" / "nvidia0").string());
}

// A lost device and a lack of memory are reported with the call, the result's name, what the
// program was doing (the nested DeviceSteps, outer to inner) and what to try; once the steps end,
// they are no longer named.
TEST(VulkanErrors, DeviceLostNamesTheResultTheCallAndTheStep) {
    auto lost = [] { VK_CHECK(VK_ERROR_DEVICE_LOST); };
    std::string message;
    {
        DeviceStep bake("baking sky.exr");
        DeviceStep project("projecting the environment");
        message = deviceErrorOf(lost);
    }
    EXPECT_CONTAINS(message, "VK_ERROR_DEVICE_LOST (-4)");
    EXPECT_CONTAINS(message, "VK_ERROR_DEVICE_LOST failed"); // the call's text
    EXPECT_CONTAINS(message, "while baking sky.exr: projecting the environment");
    EXPECT_EQ(message.find(".cpp"), std::string::npos) << "a source file in a user's message: " << message;
    EXPECT_CONTAINS(message, "device was lost");
    EXPECT_EQ(deviceErrorOf(lost).find("while"), std::string::npos);

    std::string submit = vkErrorMessage(VK_ERROR_DEVICE_LOST, "vkQueueSubmit(queue, 1, &submit, fence)");
    EXPECT_CONTAINS(submit, "vkQueueSubmit(queue, 1, &submit, fence) failed with VK_ERROR_DEVICE_LOST (-4): "
                            "the Vulkan device was lost");
}

TEST(VulkanErrors, OutOfMemoryIsSaidInWords) {
    EXPECT_CONTAINS(deviceErrorOf([] { VK_CHECK(VK_ERROR_OUT_OF_DEVICE_MEMORY); }),
                    "VK_ERROR_OUT_OF_DEVICE_MEMORY (-2)");
    EXPECT_CONTAINS(deviceErrorOf([] { VK_CHECK(VK_ERROR_OUT_OF_DEVICE_MEMORY); }), "out of device memory");
    EXPECT_CONTAINS(deviceErrorOf([] { VK_CHECK(VK_ERROR_OUT_OF_HOST_MEMORY); }), "out of host memory");
    EXPECT_STREQ(vkResultName(VK_ERROR_OUT_OF_DATE_KHR), "VK_ERROR_OUT_OF_DATE_KHR");
    EXPECT_STREQ(vkResultName(VkResult(-123456)), "VkResult");
}

// A buffer of 1 TiB, more than any heap of the device and beyond maxBufferSize: an Error naming
// the result and what was being done, not a crash, and no validation message.
TEST(DeviceMemory, AllocationLargerThanTheDeviceIsAnError) {
    ContextOptions options;
    options.validation = true;
    Context context = createContext(options);
    VkDeviceSize largestHeap = 0;
    for (uint32_t h = 0; h < context.memory.memoryHeapCount; ++h)
        largestHeap = std::max(largestHeap, context.memory.memoryHeaps[h].size);
    const VkDeviceSize size = VkDeviceSize(1) << 40;
    ASSERT_GT(size, largestHeap);
    std::string message = deviceErrorOf([&] {
        DeviceStep step("allocating 1 TiB of test texels");
        Buffer buffer =
            createBuffer(context, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device, "test texels");
        destroyBuffer(context, buffer);
    });
    EXPECT_CONTAINS(message, "OUT_OF_DEVICE_MEMORY");
    EXPECT_CONTAINS(message, "allocating 1 TiB of test texels");
    EXPECT_EQ(context.validationMessages(), 0u);
    destroyContext(context);
}

} // namespace
} // namespace shprobe
