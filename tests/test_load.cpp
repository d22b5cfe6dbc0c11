// Load: a batch of 1,000 small probes and one 6 x 4096^2 bake, each through the program on
// lavapipe, with the program's peak resident memory measured (wait4's ru_maxrss) against the data's
// size plus the overhead stated here. Label "load": part of every ctest run.
#include "render/run_program.h"

#include <OpenImageIO/imageio.h>

#include <fstream>
#include <regex>

namespace shprobe::testing {
namespace {

constexpr long kMiB = 1024;

// A tiny equirect HDR (16 x 8: 4 x 4 faces), different for each index.
void writeSmallEnvironment(const std::string& path, int index) {
    std::vector<float> pixels(16 * 8 * 3);
    for (size_t p = 0; p < pixels.size(); ++p)
        pixels[p] = float((p * 7 + size_t(index) * 13) % 97) / 97.0f;
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out) << path;
    ASSERT_TRUE(out->open(path, OIIO::ImageSpec(16, 8, 3, OIIO::TypeDesc::FLOAT)));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
    out->close();
}

// The program's own footprint (Vulkan loader, lavapipe and LLVM, the validation layer): a single
// small bake.
long baselineKiB(const TemporaryFolder& folder) {
    writeSmallEnvironment(folder / "one.hdr", 0);
    RunResult run =
        runProgram({"bake", folder / "one.hdr", "-o", folder / "one.json"}, folder.path() / "logs");
    EXPECT_EQ(run.exitCode, 0) << describe(run);
    return run.peakKiB;
}

// 1,000 probes in one run: all baked, in few submissions, and memory does not grow with the probe
// count. The inputs are 1,000 x 6 x 4^2 texels (1.5 MiB as RGBA32F); the bound allows the baseline
// plus 64 MiB, far below what keeping every probe's image, decoded file or GPU resources would
// take, and well above the allocator's slack.
TEST(Load, ThousandSmallProbesInOneBatch) {
    TemporaryFolder folder("shprobe_load_batch");
    const long baseline = baselineKiB(folder);
    std::ofstream list(folder / "list.txt");
    for (int i = 0; i < 1000; ++i) {
        std::string path = folder / ("probe" + std::to_string(i) + ".hdr");
        writeSmallEnvironment(path, i);
        list << path << "\n";
    }
    list.close();
    RunResult run = runProgram({"bake", "--list", folder / "list.txt", "--out-dir", folder / "out"},
                               folder.path() / "logs");
    ASSERT_EQ(run.exitCode, 0) << describe(run);
    int written = 0;
    for (const auto& entry : std::filesystem::directory_iterator(folder.path() / "out"))
        written += entry.path().extension() == ".json";
    EXPECT_EQ(written, 1000);
    EXPECT_NE(run.out.find("1000 probes baked, 0 failed"), std::string::npos) << run.out;
    EXPECT_LE(run.peakKiB, baseline + 64 * kMiB) << "baseline " << baseline << " KiB";
    RecordProperty("peak KiB, 1000 probes", std::to_string(run.peakKiB));
    RecordProperty("peak KiB, one probe", std::to_string(baseline));
}

// One 6 x 4096^2 cube map (1.5 GiB of RGBA32F texels). Stated overhead: the texels are held three
// times at the peak (the cube map in host memory, the upload's staging buffer, and the device image,
// which on a CPU device is host memory too), plus the baseline and 256 MiB for the sky's generation
// and the allocator. A fourth copy would exceed it.
TEST(Load, OneCubeMapOf4096SquaredFaces) {
    TemporaryFolder folder("shprobe_load_4096");
    const long baseline = baselineKiB(folder);
    RunResult run =
        runProgram({"bake", "--face-size", "4096", "-o", folder / "sky.json"}, folder.path() / "logs");
    ASSERT_EQ(run.exitCode, 0) << describe(run);
    const long dataKiB = 6L * 4096 * 4096 * 16 / 1024;
    EXPECT_LE(run.peakKiB, baseline + 3 * dataKiB + 256 * kMiB)
        << "data " << dataKiB << " KiB, baseline " << baseline << " KiB";
    RecordProperty("peak KiB, 6 x 4096^2", std::to_string(run.peakKiB));
    RecordProperty("data KiB", std::to_string(dataKiB));
}

} // namespace
} // namespace shprobe::testing
