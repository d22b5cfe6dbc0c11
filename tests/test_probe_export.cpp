// Export formats (src/io/probe_export.h): the packed binary file round-trips and refuses malformed
// files naming the problem; the irradiance maps hold E(n) / pi at their pixels' directions, and a
// cross map loaded and projected back gives the probe's irradiance again.
#include "io/probe_export.h"

#include "image/environment.h"
#include "sh/error.h"
#include "sh/irradiance.h"
#include "sh/projection.h"
#include "test_support.h"

#include <filesystem>
#include <gtest/gtest.h>
#include <numbers>
#include <random>

namespace shprobe {
namespace {

namespace fs = std::filesystem;
using testing::expectInputError;

ShCoefficients randomProbe(int order, Quantity quantity, uint32_t seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    ShCoefficients probe = makeCoefficients(order, quantity);
    for (glm::dvec3& c : probe.rgb) c = {uniform(random), uniform(random), uniform(random)};
    probe.rgb[0] = {3.0, 2.5, 2.0}; // a positive mean, as real probes have
    return probe;
}

class ExportFiles : public ::testing::Test {
protected:
    ExportFiles() : folder_(fs::temp_directory_path() / ("shprobe_test_export_" + std::to_string(getpid()))) {
        fs::create_directories(folder_);
    }
    ~ExportFiles() override {
        std::error_code ignored;
        fs::remove_all(folder_, ignored);
    }
    std::string file(const std::string& name) const { return (folder_ / name).string(); }

private:
    fs::path folder_;
};

// Values are stored as float32: reading back gives each coefficient rounded to float, exactly.
TEST_F(ExportFiles, BinaryRoundTripsEveryOrderAndQuantity) {
    for (int order = 1; order <= 8; ++order)
        for (Quantity quantity : {Quantity::Radiance, Quantity::Irradiance}) {
            std::vector<ShCoefficients> probes = {randomProbe(order, quantity, 1), randomProbe(order, quantity, 2)};
            writeBinaryProbes(file("probes.bin"), probes);
            std::vector<ShCoefficients> read = readBinaryProbes(file("probes.bin"));
            ASSERT_EQ(read.size(), 2u);
            for (size_t p = 0; p < 2; ++p) {
                EXPECT_EQ(read[p].order, order);
                EXPECT_EQ(read[p].quantity, quantity);
                for (size_t i = 0; i < read[p].rgb.size(); ++i)
                    for (int c = 0; c < 3; ++c)
                        EXPECT_EQ(read[p].rgb[i][c], double(float(probes[p].rgb[i][c]))) << "order " << order;
            }
        }
}

TEST(BinaryProbes, HeaderIsTheDocumentedLayout) {
    ShCoefficients probe = randomProbe(3, Quantity::Irradiance, 3);
    std::string bytes = probesToBinary(std::span(&probe, 1));
    ASSERT_EQ(bytes.size(), kBinaryProbeHeaderBytes + 9u * 3u * 4u);
    EXPECT_EQ(bytes.substr(0, 4), "SHPB");
    auto word = [&](size_t offset) { return uint32_t(uint8_t(bytes[offset])) | uint32_t(uint8_t(bytes[offset + 1])) << 8; };
    EXPECT_EQ(word(4), 1u);  // version
    EXPECT_EQ(word(8), 3u);  // order
    EXPECT_EQ(word(12), 1u); // irradiance
    EXPECT_EQ(word(16), 1u); // count
    EXPECT_EQ(word(20), 32u);
}

TEST(BinaryProbes, MalformedFilesAreRefused) {
    ShCoefficients probe = randomProbe(3, Quantity::Radiance, 4);
    std::string valid = probesToBinary(std::span(&probe, 1));
    expectInputError([&] { parseBinaryProbes(valid.substr(0, 20), "short.bin"); }, "truncated header");
    expectInputError([&] { parseBinaryProbes(valid.substr(0, valid.size() - 4), "cut.bin"); }, "truncated data");
    std::string magic = valid;
    magic[0] = 'X';
    expectInputError([&] { parseBinaryProbes(magic, "magic.bin"); }, "magic");
    std::string order = valid;
    order[8] = 9;
    expectInputError([&] { parseBinaryProbes(order, "order.bin"); }, "order 9");
    std::string nan = valid;
    for (int i = 0; i < 4; ++i) nan[kBinaryProbeHeaderBytes + 4 + i] = char(0xff);
    expectInputError([&] { parseBinaryProbes(nan, "nan.bin"); }, "NaN");
    std::vector<ShCoefficients> mixed = {randomProbe(3, Quantity::Radiance, 5), randomProbe(5, Quantity::Radiance, 6)};
    expectInputError([&] { probesToBinary(mixed); }, "mixed orders");
}

// Each pixel is E(n) / pi at its direction (CONVENTIONS' equirect mapping), computed in double and
// stored as float: agreement to float rounding of the largest value.
TEST_F(ExportFiles, IrradianceEquirectHoldsEOverPi) {
    ShCoefficients radiance = randomProbe(3, Quantity::Radiance, 7);
    writeIrradianceEquirect(file("irradiance.exr"), radiance, 64);
    Image image = readImage(file("irradiance.exr"));
    ASSERT_EQ(image.width, 64);
    ASSERT_EQ(image.height, 32);
    ShCoefficients irradiance = convolveIrradiance(radiance);
    for (int j = 0; j < 32; ++j)
        for (int i = 0; i < 64; ++i) {
            glm::dvec3 expected = evaluate(irradiance, equirectDirection(i, j, 64, 32)) / std::numbers::pi;
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(image.at(i, j)[c], expected[c], 1e-6 * 3.0) << i << "," << j;
        }
}

// The cross map, loaded as an environment and projected, gives back pi times... the irradiance
// coefficients: E(n)/pi is band-limited to the probe's order, so only the cube map's quadrature
// error remains (measured 2e-5 of E_00 at face 64 for order 3; bound 2e-4). Face placement or
// orientation errors would move coefficients by O(1).
TEST_F(ExportFiles, IrradianceCrossProjectsBackToTheProbe) {
    ShCoefficients radiance = randomProbe(3, Quantity::Radiance, 8);
    writeIrradianceCross(file("irradiance_cross.exr"), radiance, 64);
    Environment environment = loadEnvironment(file("irradiance_cross.exr"), {});
    EXPECT_EQ(environment.layout, Layout::HorizontalCross);
    ShCoefficients projected = projectCubemap(environment.cubemap, 3);
    ShCoefficients expected = convolveIrradiance(radiance);
    for (size_t i = 0; i < expected.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(projected.rgb[i][c] * std::numbers::pi, expected.rgb[i][c], 2e-4 * expected.rgb[0][c])
                << "coefficient " << i;
}

} // namespace
} // namespace shprobe
