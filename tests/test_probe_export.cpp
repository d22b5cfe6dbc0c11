// Export formats (src/formats/probe_export.h): the packed binary file round-trips and refuses malformed
// files naming the problem; the GLSL and C/C++ headers hold exactly the folded coefficients
// (sh/folding.h), evaluate to the probe's radiance or E(n) / pi, and compile (glslangValidator, and
// the system's C and C++ compilers); the irradiance maps hold E(n) / pi at their pixels'
// directions, and a cross map loaded and projected back gives the probe's irradiance again.
#include "formats/probe_export.h"

#include "common/error.h"
#include "image/environment.h"
#include "sh/basis.h"
#include "sh/folding.h"
#include "sh/irradiance.h"
#include "sh/projection.h"
#include "test_support.h"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <numbers>
#include <random>
#include <regex>
#include <spawn.h>
#include <sstream>
#include <sys/wait.h>

extern char** environ;

namespace shprobe {
namespace {

namespace fs = std::filesystem;
using testing::expectInputError;

ShCoefficients randomProbe(int order, Quantity quantity, uint32_t seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    ShCoefficients probe = makeCoefficients(order, quantity);
    for (glm::dvec3& c : probe.rgb)
        c = {uniform(random), uniform(random), uniform(random)};
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
            std::vector<ShCoefficients> probes = {randomProbe(order, quantity, 1),
                                                  randomProbe(order, quantity, 2)};
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
    auto word = [&](size_t offset) {
        return uint32_t(uint8_t(bytes[offset])) | uint32_t(uint8_t(bytes[offset + 1])) << 8;
    };
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
    expectInputError([&] { parseBinaryProbes(valid.substr(0, valid.size() - 4), "cut.bin"); },
                     "truncated data");
    std::string magic = valid;
    magic[0] = 'X';
    expectInputError([&] { parseBinaryProbes(magic, "magic.bin"); }, "magic");
    std::string order = valid;
    order[8] = 9;
    expectInputError([&] { parseBinaryProbes(order, "order.bin"); }, "order 9");
    std::string nan = valid;
    for (int i = 0; i < 4; ++i)
        nan[kBinaryProbeHeaderBytes + 4 + i] = char(0xff);
    expectInputError([&] { parseBinaryProbes(nan, "nan.bin"); }, "NaN");
    std::vector<ShCoefficients> mixed = {randomProbe(3, Quantity::Radiance, 5),
                                         randomProbe(5, Quantity::Radiance, 6)};
    expectInputError([&] { probesToBinary(mixed); }, "mixed orders");
}

// ---- Headers ---------------------------------------------------------------------------------

// The rgba entries of a header's array, in order, read back with strtof: "vec4(r, g, b, w)" in
// GLSL, "{r, g, b, w}" in C (the 'f' suffix ends the number). Comments are skipped.
std::vector<std::array<float, 4>> headerEntries(const std::string& header, HeaderLanguage language) {
    std::string code;
    std::istringstream lines(header);
    for (std::string line; std::getline(lines, line);)
        code += line.substr(0, line.find("//")) + "\n";
    static const std::regex glsl(R"(vec4\(([^()]*)\))"), c(R"(\{([^{}]*)\})");
    std::vector<std::array<float, 4>> entries;
    const std::regex& entry = language == HeaderLanguage::Glsl ? glsl : c;
    for (auto match = std::sregex_iterator(code.begin(), code.end(), entry); match != std::sregex_iterator();
         ++match) {
        std::array<float, 4> values{};
        const char* text = &*(*match)[1].first;
        for (float& value : values) {
            char* end = nullptr;
            value = std::strtof(text, &end);
            EXPECT_NE(end, text) << "not a number at: " << std::string(text).substr(0, 20);
            text = end + std::strspn(end, "fF, \n");
        }
        entries.push_back(values);
    }
    return entries;
}

TEST(ProbeHeaders, IdentifiersAreValidInCAndGlsl) {
    EXPECT_EQ(headerIdentifier("sunset"), "sunset");
    EXPECT_EQ(headerIdentifier("Studio Light-2.v3"), "Studio_Light_2_v3");
    EXPECT_EQ(headerIdentifier("__a__b__"), "a_b");                    // no reserved double or leading '_'
    EXPECT_EQ(headerIdentifier("2k_sky"), "probe_2k_sky");             // no leading digit
    EXPECT_EQ(headerIdentifier("gl_sky"), "probe_gl_sky");             // GLSL reserves gl_
    EXPECT_EQ(headerIdentifier("caf\xc3\xa9 terrace"), "caf_terrace"); // UTF-8 bytes are not ASCII letters
    EXPECT_EQ(headerIdentifier(""), "probe");
    EXPECT_EQ(headerIdentifier("---"), "probe");
}

// Every order the shader takes, both quantities, both languages: the 25 entries read back are the
// folded coefficients rounded to float, exactly (the shortest round-trip text), with w = 0 and the
// entries past the order 0; and the header names the order and the function that evaluates it.
TEST(ProbeHeaders, HoldExactlyTheFoldedCoefficients) {
    for (int order = 1; order <= kMaxFoldedOrder; ++order)
        for (Quantity quantity : {Quantity::Radiance, Quantity::Irradiance})
            for (HeaderLanguage language : {HeaderLanguage::Glsl, HeaderLanguage::C}) {
                SCOPED_TRACE(::testing::Message()
                             << "order " << order
                             << (quantity == Quantity::Radiance ? " radiance" : " irradiance")
                             << (language == HeaderLanguage::Glsl ? " glsl" : " c"));
                ShCoefficients probe = randomProbe(order, quantity, uint32_t(10 * order));
                std::string header = probeToHeader(probe, language, "sky", "sky.exr (equirect 64x32)");
                FoldedQuantity folded = quantity == Quantity::Radiance ? FoldedQuantity::Radiance
                                                                       : FoldedQuantity::IrradianceOverPi;
                FoldedCoefficients expected = *foldCoefficients(probe, order, folded);
                std::vector<std::array<float, 4>> entries = headerEntries(header, language);
                ASSERT_EQ(entries.size(), size_t(kFoldedCount)) << header;
                for (int i = 0; i < kFoldedCount; ++i) {
                    for (int c = 0; c < 3; ++c)
                        EXPECT_EQ(entries[i][c], float(expected[i][c])) << "entry " << i;
                    EXPECT_EQ(entries[i][3], 0.0f);
                    if (i >= order * order) {
                        EXPECT_EQ(entries[i][0], 0.0f) << "entry " << i;
                    }
                }
                EXPECT_NE(header.find("order      " + std::to_string(order) + ":"), std::string::npos)
                    << header;
                EXPECT_NE(header.find(quantity == Quantity::Radiance ? "shRadiance(" : "shIrradianceOverPi("),
                          std::string::npos);
                EXPECT_NE(header.find("sky.exr (equirect 64x32)"), std::string::npos);
                EXPECT_NE(header.find(language == HeaderLanguage::Glsl ? "const vec4 sky_sh[SH_FOLDED_COUNT]"
                                                                       : "static const float sky_sh[25][4]"),
                          std::string::npos)
                    << header;
            }
    ShCoefficients order6 = randomProbe(6, Quantity::Radiance, 1);
    expectInputError([&] { probeToHeader(order6, HeaderLanguage::C, "sky", ""); }, "order 6");
}

// What the shader computes from the header's numbers, sum_i c_i p_i(n) with Sloan's p_6 = z^2 (in
// double here), is E(n) / pi for an irradiance probe and L(n) for a radiance probe, to the float
// rounding of the coefficients (1e-6 of the sum of term magnitudes). The irradiance probe is the
// convolution of a radiance probe, so its band 3 is 0 as any irradiance's is.
TEST(ProbeHeaders, EvaluateToTheProbe) {
    std::mt19937 random(5);
    std::normal_distribution<double> normal;
    for (Quantity quantity : {Quantity::Radiance, Quantity::Irradiance}) {
        ShCoefficients radiance = randomProbe(5, Quantity::Radiance, 21);
        ShCoefficients probe = quantity == Quantity::Radiance ? radiance : convolveIrradiance(radiance);
        std::vector<std::array<float, 4>> c =
            headerEntries(probeToHeader(probe, HeaderLanguage::C, "sky", ""), HeaderLanguage::C);
        ASSERT_EQ(c.size(), size_t(kFoldedCount));
        for (int sample = 0; sample < 200; ++sample) {
            glm::dvec3 n = glm::normalize(glm::dvec3(normal(random), normal(random), normal(random)));
            glm::dvec3 sum(0.0), magnitude(0.0);
            for (int i = 0; i < kFoldedCount; ++i) {
                if (quantity == Quantity::Irradiance && shBand(i) == 3) continue; // the shader skips A_3 = 0
                double p = i == 6 ? n.z * n.z : basisPolynomial(i, n);
                for (int k = 0; k < 3; ++k) {
                    sum[k] += double(c[i][k]) * p;
                    magnitude[k] += std::abs(double(c[i][k]) * p);
                }
            }
            glm::dvec3 expected =
                evaluate(probe, n) / (quantity == Quantity::Irradiance ? std::numbers::pi : 1.0);
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(sum[k], expected[k], 1e-6 * magnitude[k]) << "sample " << sample;
        }
    }
}

// Runs a program found on PATH with `args` (no shell); its stderr goes to `log`. Returns the exit code.
int runTool(const std::vector<std::string>& args, const fs::path& log) {
    std::vector<std::string> strings = args;
    std::vector<char*> argv;
    for (std::string& arg : strings)
        argv.push_back(arg.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    pid_t pid = 0;
    int spawnError = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawnError != 0) {
        ADD_FAILURE() << "cannot start " << args[0] << ": " << std::strerror(spawnError);
        return -1;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string textOf(const fs::path& path) {
    std::ifstream in(path);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

// Two probe headers in one translation unit compile, without a warning, as C99 and as C++17.
TEST_F(ExportFiles, CHeadersCompileAsCAndCpp) {
    writeProbeHeader(file("sky.h"), randomProbe(3, Quantity::Irradiance, 31), HeaderLanguage::C, "sky.exr");
    writeProbeHeader(file("2k studio.h"), randomProbe(5, Quantity::Radiance, 32), HeaderLanguage::C,
                     "studio.exr");
    std::ofstream(file("use.c"))
        << "#include \"sky.h\"\n#include \"2k studio.h\"\n"
           "float total(void) {\n"
           "    return sky_sh[0][0] + probe_2k_studio_sh[24][2] + SKY_SH_ORDER + PROBE_2K_STUDIO_SH_ORDER;\n"
           "}\n";
    for (const char* language : {"c", "c++"}) {
        std::vector<std::string> command = {std::string(language) == "c" ? "cc" : "c++",
                                            "-fsyntax-only",
                                            "-Wall",
                                            "-Wextra",
                                            "-Wpedantic",
                                            "-Werror",
                                            std::string(language) == "c" ? "-std=c99" : "-std=c++17",
                                            "-x",
                                            language,
                                            file("use.c")};
        EXPECT_EQ(runTool(command, file("compile.log")), 0) << language << ":\n"
                                                            << textOf(file("compile.log"));
    }
}

// A fragment shader that includes sh_irradiance.glsl and two probe headers (one per quantity) and
// evaluates both compiles for Vulkan with glslangValidator.
TEST_F(ExportFiles, GlslHeadersCompile) {
    writeProbeHeader(file("sky.glsl"), randomProbe(3, Quantity::Irradiance, 41), HeaderLanguage::Glsl,
                     "sky.exr");
    writeProbeHeader(file("studio.glsl"), randomProbe(5, Quantity::Radiance, 42), HeaderLanguage::Glsl,
                     "studio.exr");
    std::ofstream(file("use.frag.glsl"))
        << "#version 450\n"
           "#extension GL_GOOGLE_include_directive : require\n"
           "#include \"sh_irradiance.glsl\"\n"
           "#include \"sky.glsl\"\n"
           "#include \"studio.glsl\"\n"
           "layout(location = 0) in vec3 normal;\n"
           "layout(location = 0) out vec4 color;\n"
           "void main() {\n"
           "    vec3 n = normalize(normal);\n"
           "    color = vec4(shIrradianceOverPi(sky_sh, n, sky_sh_order) +\n"
           "                 shRadiance(studio_sh, n, studio_sh_order), 1.0);\n"
           "}\n";
    fs::path includes = fs::path(SHPROBE_TEST_DATA_DIR).parent_path().parent_path() / "src" / "glsl";
    std::vector<std::string> command = {
        "glslangValidator",       "--target-env",        "vulkan1.1", "-S",           "frag",
        "-I" + includes.string(), file("use.frag.glsl"), "-o",        file("use.spv")};
    EXPECT_EQ(runTool(command, file("glslang.log")), 0) << textOf(file("glslang.log"));
    EXPECT_TRUE(fs::exists(file("use.spv")));
}

// Each pixel is E(n) / pi at its direction (the equirect mapping of docs/conventions.md), computed in double
// and stored as float: agreement to float rounding of the largest value.
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
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(image.at(i, j)[c], expected[c], 1e-6 * 3.0) << i << "," << j;
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
