// gltf's specularImages (image/specular_prefilter.h, formats/engine_export.h): the GGX prefilter
// against its definition, the chain's sizes and roughness mapping, the RGBD PNGs the writer embeds,
// and the program's refusals of sizes the chain cannot have.
#include "common/error.h"
#include "formats/engine_export.h"
#include "formats/probe_file.h"
#include "image/codec.h"
#include "image/environment.h"
#include "image/image_write.h"
#include "image/specular_prefilter.h"
#include "render/run_program.h"
#include "sh/lights.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <numbers>

namespace shprobe {
namespace {
namespace fs = std::filesystem;

constexpr double kPi = std::numbers::pi;

// ---- A non-trivial environment ---------------------------------------------------------------

// A smooth lobe max(0, w.d)^8 over a dim base, plus a uniform cap of 20 degrees: the lobe tests
// the kernel's shape, the cap's edge its width.
const glm::dvec3 kLobeAxis = glm::normalize(glm::dvec3(0.3, 0.8, -0.5));
const SphericalLight kCap{glm::normalize(glm::dvec3(-0.6, 0.1, 0.7)), 20.0 * kPi / 180.0, {3.0, 2.0, 1.0}};

glm::dvec3 smoothRadiance(const glm::dvec3& d) {
    return glm::dvec3(0.05, 0.1, 0.2) +
           glm::dvec3(4.0, 3.0, 2.0) * std::pow(std::max(0.0, glm::dot(kLobeAxis, d)), 8.0);
}

glm::dvec3 radiance(const glm::dvec3& d) {
    return smoothRadiance(d) +
           (glm::dot(d, kCap.direction) >= std::cos(kCap.angularRadius) ? kCap.radiance : glm::dvec3(0.0));
}

// The environment as a cube map: the smooth part at texel centres, the cap by coverage.
Cubemap testEnvironment(int faceSize) {
    Cubemap cubemap = makeCubemap(faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < faceSize; ++j)
            for (int i = 0; i < faceSize; ++i)
                cubemap.at(face, i, j) =
                    glm::vec4(glm::vec3(smoothRadiance(texelDirection(face, i, j, faceSize))), 1.0f);
    drawSphericalLight(cubemap, kCap);
    return cubemap;
}

// P(R) = integral L D max(0, R.l) / integral D max(0, R.l), in double, by the midpoint rule on a cube
// grid of kQuadratureSize faces with exact texel solid angles. Its texels (0.15 degrees at a face's
// centre) are 1/50 of the narrowest lobe's half width (GGX alpha 1/9: about 8 degrees in l).
constexpr int kQuadratureSize = 384;

struct Quadrature {
    std::vector<glm::dvec3> directions, values;
    std::vector<double> omegas;
};

const Quadrature& quadrature() {
    static const Quadrature grid = [] {
        Quadrature q;
        for (int face = 0; face < kFaceCount; ++face)
            for (int j = 0; j < kQuadratureSize; ++j)
                for (int i = 0; i < kQuadratureSize; ++i) {
                    const glm::dvec3 d = texelDirection(face, i, j, kQuadratureSize);
                    q.directions.push_back(d);
                    q.values.push_back(radiance(d));
                    q.omegas.push_back(texelSolidAngle(i, j, kQuadratureSize));
                }
        return q;
    }();
    return grid;
}

glm::dvec3 bruteForce(const glm::dvec3& r, double alpha) {
    const Quadrature& q = quadrature();
    glm::dvec3 sum(0.0);
    double weights = 0.0;
    for (size_t k = 0; k < q.directions.size(); ++k) {
        const double w = specularKernel(glm::dot(r, q.directions[k]), alpha) * q.omegas[k];
        sum += w * q.values[k];
        weights += w;
    }
    return sum / weights;
}

// ---- The chain ---------------------------------------------------------------------------------

// Sizes: log2(size / 16) + 1 mips, roughness i / (N - 1); only powers of two from 32 to 512.
TEST(SpecularChain, SizesAndRoughness) {
    EXPECT_EQ(specularMipCount(32), 2);
    EXPECT_EQ(specularMipCount(128), 4);
    EXPECT_EQ(specularMipCount(512), 6);
    EXPECT_DOUBLE_EQ(specularMipRoughness(0, 4), 0.0);
    EXPECT_DOUBLE_EQ(specularMipRoughness(2, 4), 2.0 / 3.0);
    EXPECT_DOUBLE_EQ(specularMipRoughness(3, 4), 1.0);
    for (int size : {32, 64, 128, 256, 512})
        EXPECT_TRUE(isSpecularSize(size)) << size;
    for (int size : {0, 1, 16, 48, 100, 1024})
        EXPECT_FALSE(isSpecularSize(size)) << size;
    EXPECT_THROW(prefilterSpecular(makeCubemap(8), 48), Error);
    const std::vector<Cubemap> chain = prefilterSpecular(testEnvironment(32), 64);
    ASSERT_EQ(chain.size(), 3u);
    for (size_t i = 0; i < chain.size(); ++i)
        EXPECT_EQ(chain[i].faceSize, 64 >> i);
}

// A constant environment gives that constant at every texel of every mip: the kernel is normalized
// (sum of weighted samples over sum of weights) and every pyramid level and bilinear tap is a
// convex combination. Left is float rounding: the pyramid and the mips are float, a few roundings
// of 2^-24 each, so 1e-6 relative.
TEST(SpecularChain, AConstantEnvironmentStaysConstant) {
    const glm::dvec3 constant(0.7, 1.3, 2.1);
    Cubemap environment = makeCubemap(64);
    addUniformRadiance(environment, constant);
    for (const Cubemap& mip : prefilterSpecular(environment, 128))
        for (const glm::vec4& texel : mip.texels)
            for (int c = 0; c < 3; ++c)
                ASSERT_NEAR(texel[c], constant[c], 1e-6 * constant[c]) << "mip of size " << mip.faceSize;
}

// Mip 0 is roughness 0, the environment itself: resizeCubemap's area average, each texel of a
// halving the mean of its 2 x 2 children.
TEST(SpecularChain, RoughnessZeroIsTheAreaAverage) {
    const Cubemap environment = testEnvironment(256);
    const std::vector<Cubemap> chain = prefilterSpecular(environment, 128);
    const Cubemap expected = resizeCubemap(environment, 128);
    ASSERT_EQ(chain[0].texels.size(), expected.texels.size());
    for (size_t k = 0; k < expected.texels.size(); ++k)
        ASSERT_EQ(chain[0].texels[k], expected.texels[k]) << "texel " << k;
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < 128; j += 9)
            for (int i = 0; i < 128; i += 7) {
                glm::vec4 mean =
                    0.25f *
                    (environment.at(face, 2 * i, 2 * j) + environment.at(face, 2 * i + 1, 2 * j) +
                     environment.at(face, 2 * i, 2 * j + 1) + environment.at(face, 2 * i + 1, 2 * j + 1));
                for (int c = 0; c < 3; ++c)
                    ASSERT_NEAR(chain[0].at(face, i, j)[c], mean[c], 1e-6 * (1.0 + mean[c]));
            }
}

// Mips 1..N-1 against a double quadrature of the definition, at texels chosen where the
// environment changes most: at the lobe's axis, on the cap's centre and edge, between them, and
// where only the kernels' tails reach. The prefilter's own sums are the midpoint rule over pyramid
// texels: near R at least 4 texels per alpha (the kernel's peak resolved), farther off texels seen
// under at most 1/8 of their distance, where the rule's relative error on the kernel is of order
// (1/8)^2 = 1.6% of the far texels' share of the weight. Measured: 0.47% worst (in the dim region
// below, lit by the tails alone), 0.3% and below elsewhere; 1.5% leaves room for that bound.
constexpr double kQuadratureTolerance = 0.015;
TEST(SpecularChain, MipsMatchTheQuadratureOfTheDefinition) {
    const std::vector<Cubemap> chain = prefilterSpecular(testEnvironment(128), 128);
    const glm::dvec3 edge = glm::normalize(glm::dvec3(-0.6, 0.1, 0.7) + glm::dvec3(0.0, 0.36, 0.0));
    const glm::dvec3 between = glm::normalize(kLobeAxis + kCap.direction);
    const glm::dvec3 targets[] = {kLobeAxis, kCap.direction,       edge,
                                  between,   glm::dvec3(0, -1, 0), glm::normalize(glm::dvec3(1, 0.2, 0.1))};
    double worst = 0.0;
    for (size_t mip = 1; mip < chain.size(); ++mip) {
        const Cubemap& m = chain[mip];
        const double roughness = specularMipRoughness(int(mip), int(chain.size()));
        for (const glm::dvec3& target : targets) {
            const FacePoint p = directionToFace(target);
            const int i = std::clamp(int((p.a + 1.0) * 0.5 * m.faceSize), 0, m.faceSize - 1);
            const int j = std::clamp(int((p.b + 1.0) * 0.5 * m.faceSize), 0, m.faceSize - 1);
            const glm::dvec3 expected =
                bruteForce(texelDirection(p.face, i, j, m.faceSize), roughness * roughness);
            const glm::dvec3 got(m.at(p.face, i, j));
            for (int c = 0; c < 3; ++c) {
                const double error = std::abs(got[c] - expected[c]) / expected[c];
                worst = std::max(worst, error);
                EXPECT_LT(error, kQuadratureTolerance)
                    << "mip " << mip << " channel " << c << ": " << got[c] << " vs " << expected[c];
            }
        }
    }
    std::printf("  worst relative difference from the quadrature: %.3g\n", worst);
}

// ---- The PNGs the writer embeds ------------------------------------------------------------------

std::string base64Decode(const std::string& text) {
    std::string bytes;
    uint32_t bits = 0;
    int count = 0;
    for (char c : text) {
        const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        const char* at = std::strchr(digits, c);
        if (c == '=' || !at) break;
        bits = bits << 6 | uint32_t(at - digits);
        if ((count += 6) >= 8) bytes += char(bits >> (count -= 8) & 0xff);
    }
    return bytes;
}

// A PNG's RGBA bytes, as stb_image decodes them.
std::vector<uint8_t> pngBytes(const std::string& png, const fs::path& folder, int& size) {
    const fs::path file = folder / "face.png";
    std::ofstream(file, std::ios::binary) << png;
    std::unique_ptr<ImageDecoder> decoder = openStbDecoder(file.string(), ImageFormat::Png);
    size = decoder->header().width;
    std::vector<float> values(size_t(4) * size_t(size) * size_t(decoder->header().height));
    decoder->readChannels(0, 4, values.data());
    std::vector<uint8_t> bytes;
    for (float v : values)
        bytes.push_back(uint8_t(std::lround(v * 255.0f)));
    return bytes;
}

// The writer's PNGs, RGBD-decoded as Babylon's fromRGBD does (rgb = (rgb'^2.2) / D), give back the
// chain's texels, face images flipped about their vertical axes, mip after mip, within RGBD's 8-bit
// precision: a stored byte v is within 1/2 of 255 (x D)^(1/2.2), so the decoded x is within
// 2.2 ((v + 1/2) / 255)^1.2 (1/2 / 255) / D of the value (the derivative's largest over that half
// step; D itself is stored exactly, as k / 255). The asset is JSON, its source a file name that is
// not UTF-8 included.
TEST(SpecularChain, RgbdPngsDecodeToTheChain) {
    const fs::path folder = fs::temp_directory_path() / ("shprobe_specular_" + std::to_string(getpid()));
    fs::create_directories(folder);
    Cubemap environment = testEnvironment(32);
    for (glm::vec4& texel : environment.texels)
        texel *= 10.0f; // values from 0.5 to about 70: both sides of RGBD's D = 1
    ExportOptions options;
    options.mapSize = 32;
    options.specular = {&environment, "a test environment"};
    options.metadata.source = "caf\xe9\t.exr"; // a file name's bytes: not UTF-8, a tab in it
    ShCoefficients probe = makeCoefficients(3, Quantity::Radiance);
    addAmbient(probe, glm::dvec3(1.0));
    findExportFormat("gltf")->write((folder / "light.gltf").string(), probe, options);
    // JSON must be UTF-8 (the validator and nlohmann refused the file): the byte is U+FFFD.
    const nlohmann::json asset = nlohmann::json::parse(std::ifstream(folder / "light.gltf"));
    EXPECT_EQ(asset["asset"]["extras"]["source"], "caf\xef\xbf\xbd\t.exr");
    const nlohmann::json& light = asset["extensions"]["EXT_lights_image_based"]["lights"][0];
    const std::vector<Cubemap> chain = prefilterSpecular(environment, 32);
    ASSERT_EQ(light["specularImageSize"], 32);
    ASSERT_EQ(light["specularImages"].size(), chain.size());
    double worst = 0.0;
    for (size_t mip = 0; mip < chain.size(); ++mip) {
        for (int face = 0; face < kFaceCount; ++face) {
            const int index = light["specularImages"][mip][size_t(face)];
            const std::string uri = asset["images"][size_t(index)]["uri"];
            int n = 0;
            const std::vector<uint8_t> rgbd =
                pngBytes(base64Decode(uri.substr(uri.find(',') + 1)), folder, n);
            ASSERT_EQ(n, chain[mip].faceSize);
            for (int j = 0; j < n; ++j)
                for (int x = 0; x < n; ++x) {
                    const uint8_t* texel = &rgbd[(size_t(j) * size_t(n) + size_t(x)) * 4];
                    const double d = texel[3] / 255.0;
                    const glm::vec4 expected = chain[mip].at(face, n - 1 - x, j);
                    for (int c = 0; c < 3; ++c) {
                        const double decoded = std::pow(texel[c] / 255.0, 2.2) / d;
                        const double step = 2.2 * std::pow((texel[c] + 0.5) / 255.0, 1.2) * (0.5 / 255.0) / d;
                        worst = std::max(worst, std::abs(decoded - expected[c]) / step);
                        ASSERT_LE(std::abs(decoded - expected[c]), step)
                            << "mip " << mip << " face " << face << " (" << x << ", " << j << ") channel "
                            << c;
                    }
                }
        }
    }
    std::printf("  worst RGBD difference: %.3g of its rounding bound\n", worst);
    EXPECT_NE(asset["asset"]["extras"]["specularImages"].get<std::string>().find("a test environment"),
              std::string::npos);
    fs::remove_all(folder);
}

// ---- The program ---------------------------------------------------------------------------------

class SpecularProgram : public ::testing::Test {
  protected:
    void SetUp() override {
        folder_ = fs::temp_directory_path() / ("shprobe_specular_program_" + std::to_string(getpid()));
        fs::remove_all(folder_);
        fs::create_directories(folder_);
    }
    void TearDown() override { fs::remove_all(folder_); }
    std::string path(const std::string& name) const { return (folder_ / name).string(); }
    testing::RunResult run(const std::vector<std::string>& args) {
        return testing::runProgram(args, folder_ / "logs");
    }
    fs::path folder_;
};

// A size the chain cannot have (not a power of two, below 32, above 512) is refused in one line
// naming --map-size, exit 2, before any work: nothing is written. --directional, a delta no image
// holds, is refused the same way, naming --sphere.
TEST_F(SpecularProgram, BadSizesAndDeltaLightsAreRefused) {
    ShCoefficients probe = makeCoefficients(3, Quantity::Radiance);
    addAmbient(probe, glm::dvec3(0.5));
    std::ofstream(path("p.json")) << "{\"format\": \"shprobe.sh\", \"version\": 1, \"convention\": "
                                     "\"real-orthonormal-condon-shortley\", \"order\": 1, \"quantity\": "
                                     "\"radiance\", \"coefficients\": [[1, 1, 1]]}";
    for (const std::string size : {"48", "16", "1024", "1"}) {
        for (const std::vector<std::string>& command :
             {std::vector<std::string>{"bake", "--face-size", "8", "-q", "--format", "gltf", "--map-size",
                                       size, "-o", path("out.gltf")},
              std::vector<std::string>{"convert", path("p.json"), "--map-size", size, "-o",
                                       path("out.gltf")}}) {
            const testing::RunResult result = run(command);
            EXPECT_EQ(result.exitCode, 2) << command[0] << " --map-size " << size << ": " << result.err;
            EXPECT_NE(result.err.find(
                          "--map-size: gltf's specularImageSize must be a power of two from 32 to 512, not " +
                          size),
                      std::string::npos)
                << result.err;
            EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
            EXPECT_FALSE(fs::exists(path("out.gltf"))) << command[0] << " --map-size " << size;
        }
    }
    const testing::RunResult result =
        run({"bake", "--face-size", "8", "-q", "--directional", "0,1,0", "1,1,1", "-o", path("out.gltf")});
    EXPECT_EQ(result.exitCode, 2) << result.err;
    EXPECT_NE(result.err.find("--sphere"), std::string::npos) << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_FALSE(fs::exists(path("out.gltf")));
}

// bake draws its --ambient and --sphere lights into the source: a bake of a black sky with only an
// ambient light gives that ambient at every texel of every mip (within RGBD's steps), and the extras
// name the source; convert names the probe's coefficients.
TEST_F(SpecularProgram, SourcesAreNamed) {
    writeImage(path("black.exr"), makeImage(64, 32));
    testing::RunResult result = run({"bake", path("black.exr"), "-q", "--ambient", "0.25,0.5,1", "--format",
                                     "gltf", "--map-size", "32", "-o", path("bake.gltf")});
    ASSERT_EQ(result.exitCode, 0) << result.err;
    nlohmann::json asset = nlohmann::json::parse(std::ifstream(path("bake.gltf")));
    const std::string bakeExtras = asset["asset"]["extras"]["specularImages"];
    EXPECT_NE(bakeExtras.find("the environment's radiance"), std::string::npos) << bakeExtras;
    EXPECT_NE(bakeExtras.find("--ambient"), std::string::npos) << bakeExtras;
    EXPECT_NE(bakeExtras.find("2 mips"), std::string::npos) << bakeExtras;
    for (const nlohmann::json& image : asset["images"]) {
        const std::string uri = image["uri"];
        int n = 0;
        const std::vector<uint8_t> rgbd = pngBytes(base64Decode(uri.substr(uri.find(',') + 1)), folder_, n);
        for (size_t k = 0; k < rgbd.size(); k += 4) {
            const double d = rgbd[k + 3] / 255.0;
            for (int c = 0; c < 3; ++c)
                ASSERT_NEAR(std::pow(rgbd[k + size_t(c)] / 255.0, 2.2) / d, glm::dvec3(0.25, 0.5, 1)[c],
                            0.01);
        }
    }
    writeProbeFile(path("p.json"),
                   [] {
                       ShCoefficients probe = makeCoefficients(3, Quantity::Radiance);
                       addAmbient(probe, glm::dvec3(0.5));
                       return probe;
                   }(),
                   {});
    result = run({"convert", path("p.json"), "-o", path("convert.gltf")});
    ASSERT_EQ(result.exitCode, 0) << result.err;
    asset = nlohmann::json::parse(std::ifstream(path("convert.gltf")));
    const std::string convertExtras = asset["asset"]["extras"]["specularImages"];
    EXPECT_NE(convertExtras.find("order-3 coefficients"), std::string::npos) << convertExtras;
    EXPECT_NE(convertExtras.find("4 mips"), std::string::npos) << convertExtras;
}

} // namespace
} // namespace shprobe
