// Load: a batch of 1,000 small probes, one 6 x 4096^2 bake, and files cut short that claim
// 16384 x 8192 pixels, each through the program on lavapipe, with the program's peak resident
// memory measured (wait4's ru_maxrss) against the data's size plus the overhead stated here. Label
// "load": part of every ctest run.
#include "png_chunks.h"
#include "render/run_program.h"

#include <OpenImageIO/imageio.h>

#include <cstdint>
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

// The program's own footprint on a backend (on gpu: the Vulkan loader, lavapipe and LLVM, the
// validation layer): a single small bake.
long baselineKiB(const TemporaryFolder& folder, const std::string& backend) {
    writeSmallEnvironment(folder / "one.hdr", 0);
    RunResult run = runProgram({"bake", folder / "one.hdr", "--backend", backend, "-o", folder / "one.json"},
                               folder.path() / "logs");
    EXPECT_EQ(run.exitCode, 0) << describe(run);
    return run.peakKiB;
}

// Each backend by name: auto takes the CPU on a machine without a GPU device file, which would
// leave the Vulkan path unmeasured.
const char* const kBackends[] = {"cpu", "gpu"};

// 1,000 probes in one run: all baked (on the GPU in one submission, as the batch's default chunk
// holds them all), and memory does not grow with the probe count. The inputs are 1,000 x 6 x 4^2
// texels (1.5 MiB as RGBA32F); the bound allows the backend's baseline plus 64 MiB, far below what
// keeping every probe's image, decoded file or GPU resources would take, and well above the
// allocator's slack.
TEST(Load, ThousandSmallProbesInOneBatch) {
    TemporaryFolder folder("shprobe_load_batch");
    std::ofstream list(folder / "list.txt");
    for (int i = 0; i < 1000; ++i) {
        std::string path = folder / ("probe" + std::to_string(i) + ".hdr");
        writeSmallEnvironment(path, i);
        list << path << "\n";
    }
    list.close();
    for (const std::string backend : kBackends) {
        SCOPED_TRACE(backend);
        const long baseline = baselineKiB(folder, backend);
        const std::string out = folder / ("out_" + backend);
        RunResult run =
            runProgram({"bake", "--list", folder / "list.txt", "--backend", backend, "--out-dir", out},
                       folder.path() / "logs");
        ASSERT_EQ(run.exitCode, 0) << describe(run);
        int written = 0;
        for (const auto& entry : std::filesystem::directory_iterator(out))
            written += entry.path().extension() == ".json";
        EXPECT_EQ(written, 1000);
        EXPECT_NE(run.out.find("1000 probes baked, 0 failed"), std::string::npos) << run.out;
        if (backend == "gpu") {
            EXPECT_NE(run.out.find("texels in 1 GPU submission"), std::string::npos) << run.out;
        }
        EXPECT_LE(run.peakKiB, baseline + 64 * kMiB) << "baseline " << baseline << " KiB";
        RecordProperty("peak KiB, 1000 probes, " + backend, std::to_string(run.peakKiB));
        RecordProperty("peak KiB, one probe, " + backend, std::to_string(baseline));
    }
}

// One 6 x 4096^2 cube map (1.5 GiB of RGBA32F texels), held once at the peak on either backend: the
// CPU projects the generated faces where they lie, and the GPU path writes them straight into the
// upload's mapped memory (on a CPU device the device image's memory too). The bound is the
// backend's baseline, the texels once and 256 MiB for the sky's generation and the allocator; a
// second copy of the texels would exceed it.
TEST(Load, OneCubeMapOf4096SquaredFaces) {
    TemporaryFolder folder("shprobe_load_4096");
    const long dataKiB = 6L * 4096 * 4096 * 16 / 1024;
    for (const std::string backend : kBackends) {
        SCOPED_TRACE(backend);
        const long baseline = baselineKiB(folder, backend);
        RunResult run =
            runProgram({"bake", "--face-size", "4096", "--backend", backend, "-o", folder / "sky.json"},
                       folder.path() / "logs");
        ASSERT_EQ(run.exitCode, 0) << describe(run);
        EXPECT_NE(run.out.find("backend  " + backend + ": "), std::string::npos) << run.out;
        EXPECT_LE(run.peakKiB, baseline + dataKiB + 256 * kMiB)
            << "data " << dataKiB << " KiB, baseline " << baseline << " KiB";
        RecordProperty("peak KiB, 6 x 4096^2, " + backend, std::to_string(run.peakKiB));
    }
    RecordProperty("data KiB", std::to_string(dataKiB));
}

// The files claiming 16384 x 8192 pixels (2 GiB as RGBA32F texels), each cut short.

// A Radiance HDR: its header and the first scanline's 4-byte start, nothing more.
void writeCutHdr(const std::string& path) {
    std::ofstream(path, std::ios::binary) << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8192 +X 16384\n"
                                          << std::string("\x02\x02\x40\x00", 4);
}

// A Radiance HDR whose first scanline says it is 64 pixels long, not the header's 16384, then ends
// (stb_image refuses such a line, but only after allocating the image).
void writeHdrOfWrongLineLength(const std::string& path) {
    std::ofstream(path, std::ios::binary) << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8192 +X 16384\n"
                                          << std::string("\x02\x02\x00\x40\x80\x01", 6);
}

// A PNG of RGB8 pixels whose one IDAT chunk, CRC and all, holds the start of a deflate stream.
void writeCutPng(const std::string& path) {
    const std::string header =
        bigEndian32(16384) + bigEndian32(8192) + std::string("\x08\x02\x00\x00\x00", 5);
    std::ofstream(path, std::ios::binary)
        << kPngSignature + pngChunk("IHDR", header) +
               pngChunk("IDAT", std::string("\x78\x9c\xed\xc1\x01\x0d\x00\x00\x00", 9));
}

// An EXR of one half-float channel, run-length encoded (one scanline a chunk, 8192 of them), of
// even grey, written scanline by scanline from one row (4 MiB); then cut to its first MiB, past its
// offset table (64 KiB).
void writeCutExr(const std::string& path) {
    const std::string whole = path + ".whole.exr";
    {
        auto out = OIIO::ImageOutput::create(whole);
        ASSERT_TRUE(out) << whole;
        OIIO::ImageSpec spec(16384, 8192, 1, OIIO::TypeDesc::HALF);
        spec.attribute("compression", "rle");
        ASSERT_TRUE(out->open(whole, spec)) << out->geterror();
        const std::vector<float> row(16384, 0.5f);
        for (int y = 0; y < 8192; ++y)
            ASSERT_TRUE(out->write_scanline(y, 0, OIIO::TypeDesc::FLOAT, row.data())) << out->geterror();
        ASSERT_TRUE(out->close());
    }
    std::ifstream in(whole, std::ios::binary);
    std::string start(1024 * 1024, '\0');
    in.read(start.data(), std::streamsize(start.size()));
    std::ofstream(path, std::ios::binary) << start;
}

// A file of a few bytes (or KiB) claiming 16384 x 8192 pixels, cut short or with a corrupt first
// scanline, is refused (exit 2, one line naming
// it) before its 2 GiB of texels are allocated: the peak stays within 64 MiB of the baseline (the
// allocator's slack and a file read whole), where filling the texels would add 2 GiB.
TEST(Load, CutFilesClaimingHugeImagesAreRefusedFirst) {
    TemporaryFolder folder("shprobe_load_cut");
    const long baseline = baselineKiB(folder, "cpu");
    writeCutHdr(folder / "cut.hdr");
    writeCutPng(folder / "cut.png");
    writeCutExr(folder / "cut.exr");
    writeHdrOfWrongLineLength(folder / "long.hdr");
    for (const char* name : {"cut.hdr", "cut.png", "cut.exr", "long.hdr"}) {
        SCOPED_TRACE(name);
        RunResult run =
            runProgram({"bake", folder / name, "-o", folder / "cut.json"}, folder.path() / "logs");
        EXPECT_EQ(run.exitCode, 2) << describe(run);
        EXPECT_NE(run.err.find("the file may be truncated or corrupt"), std::string::npos) << run.err;
        EXPECT_LE(run.peakKiB, baseline + 64 * kMiB) << "baseline " << baseline << " KiB";
    }
}

} // namespace
} // namespace shprobe::testing
