// Image loading: layouts (equirect, crosses, six faces), sRGB and channels by name, non-finite
// texels, error messages (file system, bounded headers), cube-map resizing, the default sky and
// the EXR writer. Test images are written to a temporary folder by each test; no binary file is
// checked in.
#include "common/error.h"
#include "common/input_file.h"
#include "image/channels.h"
#include "image/environment.h"
#include "image/image_write.h"
#include "library_leaks.h"
#include "sh/fast_projection.h"
#include "test_images.h"
#include "test_support.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <functional>
#include <glm/geometric.hpp>
#include <grp.h>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <sys/resource.h>
#include <sys/wait.h>
#include <tuple>
#include <unistd.h>

namespace shprobe {
namespace {
using testing::filledImage;
using testing::LibraryLeaksIgnored;
namespace fs = std::filesystem;

// A folder of its own for each test, removed with its contents afterwards.
class EnvironmentFiles : public ::testing::Test {
  protected:
    EnvironmentFiles() {
        const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
        folder_ = fs::temp_directory_path() /
                  ("shprobe_test_environment_" + std::to_string(getpid()) + "_" + test->name());
        fs::remove_all(folder_);
        fs::create_directories(folder_);
    }
    ~EnvironmentFiles() override {
        std::error_code ignored;
        fs::remove_all(folder_, ignored);
    }
    std::string file(const std::string& name) const { return (folder_ / name).string(); }
    std::string folder() const { return folder_.string(); }

  private:
    fs::path folder_;
};

// Writes raw channel data through OpenImageIO, for the channel counts and integer formats that
// writeImage (RGB float) does not produce. Alpha is written as given, not premultiplied. A colour
// space, if given, is recorded in the file (PNG: gAMA 1 for "linear").
template <typename T>
void writeChannels(const std::string& path, int width, int height, int channels, OIIO::TypeDesc type,
                   const std::vector<T>& data, const char* colorSpace = nullptr) {
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(output) << OIIO::geterror();
    OIIO::ImageSpec spec(width, height, channels, type);
    spec.attribute("oiio:UnassociatedAlpha", 1);
    if (colorSpace) spec.attribute("oiio:ColorSpace", colorSpace);
    ASSERT_TRUE(output->open(path, spec)) << output->geterror();
    ASSERT_TRUE(output->write_image(type, data.data())) << output->geterror();
    ASSERT_TRUE(output->close()) << output->geterror();
}

void writeText(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

// The message of the Error(Input) that f must throw.
std::string inputErrorOf(const std::function<void()>& f) {
    return testing::errorOf(ErrorKind::Input, f);
}

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "message: " << (text)

double angleBetween(const glm::dvec3& a, const glm::dvec3& b) {
    return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0));
}

// The exact sRGB EOTF, written here independently of the code under test.
double srgbDecoded(double c) {
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// ---- Layout names and detection ---------------------------------------------------------------

TEST(Layouts, DetectedFromTheAspectRatio) {
    EXPECT_EQ(detectLayout(200, 100), Layout::Equirect);
    EXPECT_EQ(detectLayout(400, 300), Layout::HorizontalCross);
    EXPECT_EQ(detectLayout(300, 400), Layout::VerticalCross);
    std::string message = inputErrorOf([] { detectLayout(500, 400); });
    EXPECT_CONTAINS(message, "500x400");
    EXPECT_CONTAINS(message, "2:1");
}

TEST(Layouts, NamesParseAndPrintBack) {
    for (Layout layout :
         {Layout::Auto, Layout::Equirect, Layout::HorizontalCross, Layout::VerticalCross, Layout::Faces})
        EXPECT_EQ(parseLayout(layoutName(layout)), layout) << layoutName(layout);
    EXPECT_STREQ(layoutName(Layout::HorizontalCross), "hcross");
    EXPECT_STREQ(layoutName(Layout::VerticalCross), "vcross");
    EXPECT_CONTAINS(inputErrorOf([] { parseLayout("sphere"); }), "sphere");
}

// ---- Crosses ----------------------------------------------------------------------------------

// Cross positions in face-size units, from docs/conventions.md, in Face order.
struct Slot {
    int column;
    int row;
};
constexpr Slot kHorizontalSlots[kFaceCount] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}};
constexpr Slot kVerticalSlots[kFaceCount] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {1, 3}};

// A cross whose every texel holds its own cross coordinates (x, y, 1), so each cube texel says
// where it was read from. Every region varies, so a flip or rotation of any face shows.
Image coordinateCross(int columns, int rows, int faceSize) {
    return filledImage(columns * faceSize, rows * faceSize, [](int x, int y) { return glm::vec3(x, y, 1); });
}

// Neighbouring texels of the cross that land on the cube must be neighbours on the sphere: that is
// "each face appears as its own face image would", checked without any table of positions. Two
// adjacent texel centers are at most one texel width apart, which is at most 2 / N radians.
void expectCrossNeighboursAdjacent(const Cubemap& cubemap, int crossWidth, int crossHeight) {
    int n = cubemap.faceSize;
    std::vector<glm::dvec3> direction(size_t(crossWidth) * crossHeight, glm::dvec3(0.0));
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                glm::vec4 source = cubemap.at(face, i, j);
                direction[size_t(source.y) * crossWidth + size_t(source.x)] = texelDirection(face, i, j, n);
            }
    const double maxNeighbourAngle = 2.0 / n;
    int pairs = 0;
    for (int y = 0; y < crossHeight; ++y)
        for (int x = 0; x < crossWidth; ++x) {
            glm::dvec3 here = direction[size_t(y) * crossWidth + x];
            if (here == glm::dvec3(0.0)) continue;
            for (auto [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
                if (x + dx >= crossWidth || y + dy >= crossHeight) continue;
                glm::dvec3 next = direction[size_t(y + dy) * crossWidth + x + dx];
                if (next == glm::dvec3(0.0)) continue;
                ++pairs;
                EXPECT_LE(angleBetween(here, next), maxNeighbourAngle)
                    << "cross texels (" << x << ", " << y << ") and (" << x + dx << ", " << y + dy << ")";
            }
        }
    EXPECT_GT(pairs, 0);
}

TEST_F(EnvironmentFiles, HorizontalCrossLoadsEachFaceUpright) {
    const int n = 8;
    writeImage(file("cross.exr"), coordinateCross(4, 3, n));
    Environment environment = loadEnvironment(file("cross.exr"), {});
    EXPECT_EQ(environment.layout, Layout::HorizontalCross);
    ASSERT_EQ(environment.cubemap.faceSize, n);
    // Face texel (i, j) is the region's texel (i, j): check the top-left and bottom-right corners.
    for (int face = 0; face < kFaceCount; ++face) {
        Slot slot = kHorizontalSlots[face];
        EXPECT_EQ(environment.cubemap.at(face, 0, 0), glm::vec4(slot.column * n, slot.row * n, 1, 1)) << face;
        EXPECT_EQ(environment.cubemap.at(face, n - 1, n - 1),
                  glm::vec4(slot.column * n + n - 1, slot.row * n + n - 1, 1, 1))
            << face;
    }
    expectCrossNeighboursAdjacent(environment.cubemap, 4 * n, 3 * n);
}

TEST_F(EnvironmentFiles, VerticalCrossTurnsNegativeZ) {
    const int n = 8;
    writeImage(file("cross.exr"), coordinateCross(3, 4, n));
    Environment environment = loadEnvironment(file("cross.exr"), {});
    EXPECT_EQ(environment.layout, Layout::VerticalCross);
    ASSERT_EQ(environment.cubemap.faceSize, n);
    for (int face = 0; face < kFaceCount; ++face) {
        Slot slot = kVerticalSlots[face];
        // -Z is stored rotated 180 degrees: its face texel (0, 0) is the region's bottom-right one.
        bool rotated = face == int(Face::NegativeZ);
        glm::vec4 topLeft(slot.column * n, slot.row * n, 1, 1);
        glm::vec4 bottomRight(slot.column * n + n - 1, slot.row * n + n - 1, 1, 1);
        EXPECT_EQ(environment.cubemap.at(face, 0, 0), rotated ? bottomRight : topLeft) << face;
        EXPECT_EQ(environment.cubemap.at(face, n - 1, n - 1), rotated ? topLeft : bottomRight) << face;
    }
    expectCrossNeighboursAdjacent(environment.cubemap, 3 * n, 4 * n);
}

TEST_F(EnvironmentFiles, CrossResizedOnRequest) {
    writeImage(file("cross.exr"), filledImage(32, 24, [](int, int) { return glm::vec3(0.5f, 1.5f, 2.5f); }));
    Environment environment = loadEnvironment(file("cross.exr"), {.faceSize = 5});
    ASSERT_EQ(environment.cubemap.faceSize, 5);
    EXPECT_EQ(environment.cubemap.at(3, 4, 2), glm::vec4(0.5f, 1.5f, 2.5f, 1.0f));
}

// A cross kept as decoded (LoadOptions::keepCross) is projected where its faces lie in it
// (crossFaceRows; a vertical cross's -Z, stored turned, from a copy turned back): the same float
// sums, in the same order, as the projection of the cube map the cross is copied into, so the
// coefficients are equal to the last bit, for both crosses, an odd and an even face size and the
// orders 1, 3 and 8. Every texel differs from its mirror images in the face, so that a face read
// from the wrong place, turned or flipped shows. copyCrossToCubemap gives that cube map too.
TEST_F(EnvironmentFiles, KeptCrossIsProjectedWhereItsFacesLie) {
    for (auto [columns, rows, layout] :
         {std::tuple{4, 3, Layout::HorizontalCross}, std::tuple{3, 4, Layout::VerticalCross}}) {
        for (int n : {7, 8}) {
            SCOPED_TRACE(::testing::Message() << layoutName(layout) << ", faces " << n);
            writeImage(file("cross.exr"), filledImage(columns * n, rows * n, [](int x, int y) {
                           return glm::vec3(1.0f + 0.01f * x, 2.0f + 0.03f * y + 0.001f * x * y,
                                            0.5f + float(x % 5) * 0.2f);
                       }));
            const Environment copied = loadEnvironment(file("cross.exr"), {});
            Environment kept = loadEnvironment(file("cross.exr"), {.keepCross = true});
            ASSERT_TRUE(kept.keptCross());
            EXPECT_EQ(kept.layout, layout);
            EXPECT_EQ(kept.faceSize(), n);
            EXPECT_EQ(kept.texelCount(), copied.cubemap.texels.size());
            EXPECT_TRUE(kept.cubemap.texels.empty());
            EXPECT_EQ(kept.description, copied.description);
            for (int order : {1, 3, 8}) {
                std::vector<glm::vec4> turned;
                const ShCoefficients inPlace = projectFacesFast(
                    crossFaceRows(kept.cross, kept.layout, turned), TexelFormat::Rgba32F, n, order);
                const ShCoefficients fromCopy = projectCubemapFast(copied.cubemap, order);
                for (size_t k = 0; k < fromCopy.rgb.size(); ++k)
                    EXPECT_EQ(inPlace.rgb[k], fromCopy.rgb[k]) << "order " << order << ", coefficient " << k;
            }
            copyCrossToCubemap(kept);
            EXPECT_FALSE(kept.keptCross());
            EXPECT_EQ(kept.cubemap.texels, copied.cubemap.texels);
        }
    }
    // A face size asked for makes a cube map; a cross's shape is checked as when it is copied.
    EXPECT_FALSE(loadEnvironment(file("cross.exr"), {.faceSize = 5, .keepCross = true}).keptCross());
    writeImage(file("sky.exr"), filledImage(64, 32, [](int, int) { return glm::vec3(1.0f); }));
    EXPECT_CONTAINS(inputErrorOf([&] {
                        loadEnvironment(file("sky.exr"),
                                        {.layout = Layout::HorizontalCross, .keepCross = true});
                    }),
                    "64x32, but a hcross image must be 4:3");
}

// ---- Six face files ---------------------------------------------------------------------------

const char* const kFaceNames[kFaceCount] = {"px", "nx", "py", "ny", "pz", "nz"};

// Face f's texel (i, j) holds (f, i, j).
Image faceImage(int face, int faceSize) {
    return filledImage(faceSize, faceSize, [face](int i, int j) { return glm::vec3(face, i, j); });
}

void expectFacesInOrder(const Cubemap& cubemap, int faceSize) {
    ASSERT_EQ(cubemap.faceSize, faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < faceSize; ++j)
            for (int i = 0; i < faceSize; ++i)
                ASSERT_EQ(cubemap.at(face, i, j), glm::vec4(face, i, j, 1)) << face << " " << i << " " << j;
}

TEST_F(EnvironmentFiles, SixFacesFromAFolder) {
    fs::create_directory(file("faces"));
    for (int face = 0; face < kFaceCount; ++face)
        writeImage(file("faces/" + std::string(kFaceNames[face]) + ".exr"), faceImage(face, 4));
    writeText(file("faces/readme.txt"), "not a face");
    EXPECT_TRUE(isFacesSource(file("faces")));
    Environment environment = loadEnvironment(file("faces"), {});
    EXPECT_EQ(environment.layout, Layout::Faces);
    expectFacesInOrder(environment.cubemap, 4);
}

TEST_F(EnvironmentFiles, SixFacesFromAPattern) {
    for (int face = 0; face < kFaceCount; ++face)
        writeImage(file("sky_" + std::string(kFaceNames[face]) + ".exr"), faceImage(face, 4));
    std::string pattern = file("sky_{face}.exr");
    EXPECT_TRUE(isFacesSource(pattern));
    EXPECT_FALSE(isFacesSource(file("sky_px.exr")));
    Environment environment = loadEnvironment(pattern, {});
    EXPECT_EQ(environment.layout, Layout::Faces);
    expectFacesInOrder(environment.cubemap, 4);
}

TEST_F(EnvironmentFiles, FacesMustExistBeSquareAndMatch) {
    for (int face = 0; face < kFaceCount - 1; ++face)
        writeImage(file("sky_" + std::string(kFaceNames[face]) + ".exr"), faceImage(face, 4));
    EXPECT_CONTAINS(inputErrorOf([&] { loadEnvironment(file("sky_{face}.exr"), {}); }), "sky_nz.exr");

    writeImage(file("sky_nz.exr"), faceImage(5, 8));
    std::string message = inputErrorOf([&] { loadEnvironment(file("sky_{face}.exr"), {}); });
    EXPECT_CONTAINS(message, "sky_nz.exr is 8x8");
    EXPECT_CONTAINS(message, "sky_px.exr is 4x4");

    writeImage(file("sky_nz.exr"), filledImage(4, 3, [](int, int) { return glm::vec3(1); }));
    message = inputErrorOf([&] { loadEnvironment(file("sky_{face}.exr"), {}); });
    EXPECT_CONTAINS(message, "sky_nz.exr");
    EXPECT_CONTAINS(message, "square");
}

// Faces large enough to decode side by side (on all cores) land each in its own face; the NaN
// texels of two faces are counted together; and of two faces that fail, the error is the first
// one's in face order (+X, -X, +Y, -Y, +Z, -Z), as when they are decoded one after another.
TEST_F(EnvironmentFiles, LargeFacesDecodeSideBySide) {
    const int n = 128;
    const auto writeFaces = [&](const std::map<int, int>& nanTexels) {
        for (int face = 0; face < kFaceCount; ++face) {
            Image image = faceImage(face, n);
            const auto nans = nanTexels.find(face);
            for (int t = 0; nans != nanTexels.end() && t < nans->second; ++t)
                image.texels[size_t(t) * 97].g = std::numeric_limits<float>::quiet_NaN();
            writeImage(file("sky_" + std::string(kFaceNames[face]) + ".exr"), image);
        }
    };
    writeFaces({});
    expectFacesInOrder(loadEnvironment(file("sky_{face}.exr"), {}).cubemap, n);

    writeFaces({{2, 3}, {5, 2}}); // +Y, -Z
    EXPECT_EQ(loadEnvironment(file("sky_{face}.exr"), {.nonFinite = NonFinitePolicy::Replace}).replacedTexels,
              5u);
    std::string message = inputErrorOf([&] { loadEnvironment(file("sky_{face}.exr"), {}); });
    EXPECT_CONTAINS(message, "sky_py.exr: 3 texels are NaN or infinite");

    writeFaces({});
    for (const char* name : {"sky_nx.exr", "sky_nz.exr"})
        fs::resize_file(file(name), fs::file_size(file(name)) * 2 / 3);
    message = inputErrorOf([&] { loadEnvironment(file("sky_{face}.exr"), {}); });
    EXPECT_CONTAINS(message, "sky_nx.exr");
    EXPECT_EQ(message.find("sky_nz.exr"), std::string::npos) << message;
}

// ---- Equirect ---------------------------------------------------------------------------------

// A smooth function of direction, linear in (x, y, z), so that every face and every latitude
// sees a different value.
float smoothRadiance(const glm::dvec3& d) {
    return float(1.0 + d.x + 2.0 * d.y + 3.0 * d.z);
}

Image smoothEquirect(int width, int height) {
    return filledImage(width, height, [&](int i, int j) {
        return glm::vec3(smoothRadiance(equirectDirection(i, j, width, height)));
    });
}

// Mean of smoothRadiance over texel (i, j) by solid angle: a 16 x 16 grid of sub-texels, each
// weighed by its own solid angle.
double smoothTexelMean(int face, int i, int j, int faceSize) {
    const int grid = 16;
    double sum = 0.0, solidAngle = 0.0;
    for (int sj = grid * j; sj < grid * (j + 1); ++sj)
        for (int si = grid * i; si < grid * (i + 1); ++si) {
            const double weight = texelSolidAngle(si, sj, grid * faceSize);
            sum += weight * smoothRadiance(texelDirection(face, si, sj, grid * faceSize));
            solidAngle += weight;
        }
    return sum / solidAngle;
}

// The map's pixels hold f at their centres, and a texel is their mean over its footprint, each
// pixel weighed by the solid angle it shares with the texel. f is linear in the direction, so a
// pixel wholly inside agrees with f's mean over it to second order in its size, and one cut by the
// texel's edges errs by at most |grad f| times half its diagonal: 3.74 x 0.0174 = 0.065 at W = 256,
// which bounds the texel's mean too. f's mean over a texel is f at its centre to second order.
// Measured: 0.019 at face 64, where a texel is about a pixel and most pixels are cut, and 1.7e-3 at
// face 8. A face turned or mirrored errs by order 1; EachPixelsPowerGoesToTheTexelsItCovers checks
// the footprints themselves.
constexpr double kEquirectInterpolationError = 0.07;

TEST_F(EnvironmentFiles, EquirectMatchesTheFunctionAtTexelCenters) {
    writeImage(file("sky.exr"), smoothEquirect(256, 128));
    Environment environment = loadEnvironment(file("sky.exr"), {});
    EXPECT_EQ(environment.layout, Layout::Equirect);
    ASSERT_EQ(environment.cubemap.faceSize, 64); // width / 4
    EXPECT_CONTAINS(environment.description, "equirect 256x128");
    double maxError = 0.0;
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < 64; ++j)
            for (int i = 0; i < 64; ++i) {
                double expected = smoothRadiance(texelDirection(face, i, j, 64));
                maxError = std::max(maxError, std::abs(environment.cubemap.at(face, i, j).g - expected));
            }
    RecordProperty("max_error", std::to_string(maxError));
    std::printf("equirect 256x128 -> cube 64: max error %.3g\n", maxError);
    EXPECT_LT(maxError, kEquirectInterpolationError);
}

// With small faces each texel averages the many pixels under it: compare with f's mean over it.
TEST(Equirect, SmallFacesAverageTheirTexels) {
    const int faceSize = 8; // 256 / (4 * 8) = 8 supersamples per side
    Cubemap cubemap = equirectToCubemap(smoothEquirect(256, 128), faceSize);
    double maxError = 0.0;
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < faceSize; ++j)
            for (int i = 0; i < faceSize; ++i)
                maxError = std::max(
                    maxError, std::abs(cubemap.at(face, i, j).r - smoothTexelMean(face, i, j, faceSize)));
    std::printf("equirect 256x128 -> cube 8: max error against the texel mean %.3g\n", maxError);
    EXPECT_LT(maxError, kEquirectInterpolationError);
}

// A texel's integral and its area are summed alike around its edges: only rounding.
TEST(Equirect, ConstantStaysConstant) {
    Cubemap cubemap =
        equirectToCubemap(filledImage(64, 32, [](int, int) { return glm::vec3(0.7f, 1.1f, 3.0f); }), 7);
    for (const glm::vec4& texel : cubemap.texels) {
        EXPECT_NEAR(texel.r, 0.7f, 1e-6f);
        EXPECT_NEAR(texel.b, 3.0f, 1e-6f);
    }
}

// averageCubemap keeps each block's integral: for every texel of the 8^2 map, its value times its
// solid angle equals the sum of value times solid angle of the 4 x 4 texels of the 32^2 map it
// covers (double sums of float texels: 1e-6 relative). A map of random texels, so that a texel
// taken from the wrong block or weighed by face area instead (up to a quarter apart within a block
// near a corner) fails.
TEST(Cubemap, AveragingKeepsEachBlocksIntegral) {
    std::mt19937 random(7);
    std::uniform_real_distribution<float> value(0.0f, 1.0f);
    Cubemap fine = makeCubemap(32);
    for (glm::vec4& texel : fine.texels)
        texel = glm::vec4(value(random), value(random), value(random), 1.0f);
    const Cubemap coarse = averageCubemap(fine, 8);
    ASSERT_EQ(coarse.faceSize, 8);
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < 8; ++j) {
            for (int i = 0; i < 8; ++i) {
                glm::dvec3 block(0.0);
                for (int y = 4 * j; y < 4 * j + 4; ++y)
                    for (int x = 4 * i; x < 4 * i + 4; ++x)
                        block += texelSolidAngle(x, y, 32) * glm::dvec3(fine.at(face, x, y));
                const glm::dvec3 kept = texelSolidAngle(i, j, 8) * glm::dvec3(coarse.at(face, i, j));
                EXPECT_NEAR(kept.r, block.r, 1e-6 * block.r) << face << " " << i << " " << j;
                EXPECT_NEAR(kept.b, block.b, 1e-6 * block.b) << face << " " << i << " " << j;
            }
        }
    }
    EXPECT_EQ(averageCubemap(fine, 32).texels, fine.texels); // not smaller: the map itself
}

// Where the sizes do not divide, a texel of the map that straddles the edges of the smaller map's
// texels is split between them by solid angle. One bright texel at a time on a 12^2 map averaged
// to 5^2: its power (value times solid angle) is kept to float rounding (3e-7), and each texel of
// the 5^2 map gets the share of it that lies inside, against a count of the 128 x 128 sub-texels
// whose centres lie there (their edge strips misplace at most 1/256 of the texel per edge, hence
// 1%). Giving the whole texel to the one that holds its centre (the rule before) fails.
TEST(Cubemap, AveragingSplitsAStraddlingTexelBySolidAngle) {
    constexpr int kFine = 12, kCoarse = 5, kSub = 128;
    for (int face : {0, 4}) {
        for (int j = 0; j < kFine; ++j) {
            for (int i = 0; i < kFine; ++i) {
                Cubemap fine = makeCubemap(kFine);
                fine.texels[(size_t(face) * kFine + size_t(j)) * kFine + size_t(i)] = glm::vec4(1.0f);
                const Cubemap coarse = averageCubemap(fine, kCoarse);
                std::vector<double> expected(size_t(kCoarse) * kCoarse, 0.0);
                for (int y = j * kSub; y < (j + 1) * kSub; ++y)
                    for (int x = i * kSub; x < (i + 1) * kSub; ++x)
                        expected[size_t((2 * y + 1) * kCoarse / (2 * kFine * kSub)) * kCoarse +
                                 size_t((2 * x + 1) * kCoarse / (2 * kFine * kSub))] +=
                            texelSolidAngle(x, y, kFine * kSub);
                const double power = texelSolidAngle(i, j, kFine);
                double kept = 0.0;
                for (int y = 0; y < kCoarse; ++y) {
                    for (int x = 0; x < kCoarse; ++x) {
                        const double share = texelSolidAngle(x, y, kCoarse) * coarse.at(face, x, y).r;
                        EXPECT_NEAR(share, expected[size_t(y) * kCoarse + size_t(x)], 0.01 * power)
                            << face << " " << i << " " << j << " -> " << x << " " << y;
                        kept += share;
                    }
                }
                EXPECT_NEAR(kept, power, 3e-7 * power) << face << " " << i << " " << j;
            }
        }
    }
    Cubemap constant = makeCubemap(kFine);
    for (glm::vec4& texel : constant.texels)
        texel = glm::vec4(0.7f, 1.0f, 3.0f, 1.0f);
    for (const glm::vec4& texel : averageCubemap(constant, kCoarse).texels)
        EXPECT_NEAR(texel.b, 3.0f, 3e-6f);
}

// Where each pixel's power goes, counted by brute force: each pixel cut into sub x sub pieces of
// equal solid angle (equal steps in longitude and in z = cos(theta)), each giving its solid angle to
// the texel that holds its centre. shares[p][t] is pixel p's solid angle inside texel t.
std::vector<std::vector<double>> pixelSharesOfTexels(int width, int height, int faceSize, int sub) {
    const size_t texels = size_t(kFaceCount) * size_t(faceSize) * size_t(faceSize);
    std::vector<std::vector<double>> shares(size_t(width) * size_t(height), std::vector<double>(texels, 0.0));
    for (int row = 0; row < height; ++row) {
        const double zTop = std::cos(std::numbers::pi * row / height);
        const double zBottom = std::cos(std::numbers::pi * (row + 1) / height);
        const double piece = equirectRowSolidAngle(row, width, height) / (double(sub) * sub);
        for (int column = 0; column < width; ++column) {
            std::vector<double>& share = shares[size_t(row) * size_t(width) + size_t(column)];
            for (int sj = 0; sj < sub; ++sj) {
                const double z = zTop + (zBottom - zTop) * (sj + 0.5) / sub;
                const double r = std::sqrt(1.0 - z * z);
                for (int si = 0; si < sub; ++si) {
                    const double phi =
                        2.0 * std::numbers::pi * (column + (si + 0.5) / sub) / width - std::numbers::pi;
                    const FacePoint p = directionToFace({r * std::sin(phi), z, -r * std::cos(phi)});
                    const int i = std::min(int((p.a + 1.0) * 0.5 * faceSize), faceSize - 1);
                    const int j = std::min(int((p.b + 1.0) * 0.5 * faceSize), faceSize - 1);
                    share[(size_t(p.face) * faceSize + size_t(j)) * faceSize + size_t(i)] += piece;
                }
            }
        }
    }
    return shares;
}

// Each pixel of a 32 x 16 map lit alone: the cube map keeps its power (value times solid angle
// over all texels) to 1e-6 (float texels), and gives each texel the share of the pixel that lies
// in it, against the brute-force count above: 128 x 128 pieces a pixel misplace at most the pieces
// that a texel edge cuts, a strip of 1/128 of the pixel along each edge crossing it, so 2% of the
// pixel's power covers the worst pixel, one cut by two edges. Face size 5 puts a texel around each
// pole, 6 puts four texel corners there; every pixel, so the seam, the poles, every row and
// column, and every face's orientation are each checked. Giving a texel its centre's pixel alone
// (point sampling) misplaces up to the whole pixel.
TEST(Equirect, EachPixelsPowerGoesToTheTexelsItCovers) {
    constexpr int kWidth = 32, kHeight = 16, kSub = 128;
    for (int faceSize : {5, 6}) {
        const auto shares = pixelSharesOfTexels(kWidth, kHeight, faceSize, kSub);
        double worstPower = 0.0, worstShare = 0.0;
        for (int row = 0; row < kHeight; ++row) {
            for (int column = 0; column < kWidth; ++column) {
                Image image = testing::constantImage(kWidth, kHeight, glm::vec3(0.0f));
                image.at(column, row) = glm::vec4(1.0f);
                const Cubemap cubemap = equirectToCubemap(image, faceSize);
                const double power = equirectRowSolidAngle(row, kWidth, kHeight);
                const std::vector<double>& expected = shares[size_t(row) * kWidth + size_t(column)];
                double kept = 0.0;
                for (int face = 0; face < kFaceCount; ++face)
                    for (int j = 0; j < faceSize; ++j)
                        for (int i = 0; i < faceSize; ++i) {
                            const double share = texelSolidAngle(i, j, faceSize) * cubemap.at(face, i, j).r;
                            const size_t t = (size_t(face) * faceSize + size_t(j)) * faceSize + size_t(i);
                            worstShare = std::max(worstShare, std::abs(share - expected[t]) / power);
                            ASSERT_NEAR(share, expected[t], 0.02 * power)
                                << "pixel " << column << " " << row << ", face " << face << " texel " << i
                                << " " << j << ", face size " << faceSize;
                            kept += share;
                        }
                worstPower = std::max(worstPower, std::abs(kept - power) / power);
                ASSERT_NEAR(kept, power, 1e-6 * power) << "pixel " << column << " " << row;
            }
        }
        std::printf("face size %d: power kept to %.2g, shares to %.2g of a pixel's\n", faceSize, worstPower,
                    worstShare);
    }
}

// Larger and smaller than the pixels, a random map's power is kept: the sum over the cube map of
// value times solid angle against the sum over the pixels (float texels: 1e-6).
TEST(Equirect, PowerIsKeptAtAnyFaceSize) {
    std::mt19937 random(3);
    std::uniform_real_distribution<float> value(0.0f, 1.0f);
    const Image image = filledImage(64, 32, [&](int, int) { return glm::vec3(value(random)); });
    double power = 0.0;
    for (int row = 0; row < 32; ++row)
        for (int column = 0; column < 64; ++column)
            power += equirectRowSolidAngle(row, 64, 32) * image.at(column, row).r;
    for (int faceSize : {1, 2, 3, 7, 16, 33, 100}) {
        const Cubemap cubemap = equirectToCubemap(image, faceSize);
        double kept = 0.0;
        for (int face = 0; face < kFaceCount; ++face)
            for (int j = 0; j < faceSize; ++j)
                for (int i = 0; i < faceSize; ++i)
                    kept += texelSolidAngle(i, j, faceSize) * cubemap.at(face, i, j).r;
        EXPECT_NEAR(kept, power, 1e-6 * power) << "face size " << faceSize;
    }
}

TEST_F(EnvironmentFiles, LayoutOverrideMustFitTheImage) {
    writeImage(file("sky.exr"), smoothEquirect(64, 32));
    std::string message =
        inputErrorOf([&] { loadEnvironment(file("sky.exr"), {.layout = Layout::HorizontalCross}); });
    EXPECT_CONTAINS(message, "sky.exr");
    EXPECT_CONTAINS(message, "64x32");
    // An equirect must be 2:1: a 4:3 image read as one would be silently stretched.
    writeImage(file("cross.exr"), coordinateCross(4, 3, 2));
    message = inputErrorOf([&] { loadEnvironment(file("cross.exr"), {.layout = Layout::Equirect}); });
    EXPECT_CONTAINS(message, "cross.exr");
    EXPECT_CONTAINS(message, "2:1");
}

// ---- sRGB decoding and channels ---------------------------------------------------------------

// readImage computes the EOTF in double and rounds once to float: agreement to float precision.
constexpr float kFloatRounding = 1e-7f;

TEST_F(EnvironmentFiles, EightBitImagesAreDecodedFromSrgb) {
    std::vector<uint8_t> rgb = {128, 128, 128, 0, 10, 255};
    writeChannels(file("srgb.png"), 2, 1, 3, OIIO::TypeDesc::UINT8, rgb);
    Image image = readImage(file("srgb.png"));
    EXPECT_NEAR(image.at(0, 0).r, 0.2158605f, kFloatRounding);
    EXPECT_NEAR(image.at(0, 0).b, 0.2158605f, kFloatRounding);
    EXPECT_EQ(image.at(1, 0).r, 0.0f);
    EXPECT_NEAR(image.at(1, 0).g, srgbDecoded(10.0 / 255.0), kFloatRounding); // linear segment
    EXPECT_EQ(image.at(1, 0).b, 1.0f);
}

TEST_F(EnvironmentFiles, IntegerImagesMarkedLinearAreNotDecoded) {
    writeChannels(file("linear.png"), 1, 1, 3, OIIO::TypeDesc::UINT8, std::vector<uint8_t>{128, 128, 128},
                  "linear");
    EXPECT_NEAR(readImage(file("linear.png")).at(0, 0).r, 128.0f / 255.0f, kFloatRounding);
}

TEST_F(EnvironmentFiles, SixteenBitImagesAreDecodedFromSrgb) {
    std::vector<uint16_t> rgb = {32768, 1000, 65535};
    writeChannels(file("srgb16.png"), 1, 1, 3, OIIO::TypeDesc::UINT16, rgb);
    Image image = readImage(file("srgb16.png"));
    EXPECT_NEAR(image.at(0, 0).r, srgbDecoded(32768.0 / 65535.0), kFloatRounding);
    EXPECT_NEAR(image.at(0, 0).g, srgbDecoded(1000.0 / 65535.0), kFloatRounding);
    EXPECT_EQ(image.at(0, 0).b, 1.0f);
}

TEST_F(EnvironmentFiles, FloatImagesAreLinear) {
    std::vector<float> rgb = {0.5f, 2.0f, -0.25f};
    writeChannels(file("linear.exr"), 1, 1, 3, OIIO::TypeDesc::FLOAT, rgb);
    EXPECT_EQ(glm::vec3(readImage(file("linear.exr")).at(0, 0)), glm::vec3(0.5f, 2.0f, -0.25f));
}

// Radiance .hdr stores RGBE: an 8-bit mantissa per channel with a shared exponent, so values come
// back linear (no sRGB decode) within half a mantissa step, 1/256 of the largest channel.
TEST_F(EnvironmentFiles, RadianceHdrImagesAreLinear) {
    std::vector<float> rgb = {0.5f, 2.0f, 40.0f, 1000.0f, 3.0f, 0.25f};
    writeChannels(file("sky.hdr"), 2, 1, 3, OIIO::TypeDesc::FLOAT, rgb);
    Image image = readImage(file("sky.hdr"));
    for (int x = 0; x < 2; ++x) {
        float largest = std::max({rgb[3 * x], rgb[3 * x + 1], rgb[3 * x + 2]});
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(image.at(x, 0)[c], rgb[3 * x + c], largest / 256.0f)
                << "pixel " << x << " channel " << c;
    }
}

// JPEG is 8-bit sRGB like PNG. A flat image survives JPEG's DCT quantization up to a code value
// or so of rounding (the DC term alone): the decode of 128 +- 1.5 bounds the result.
TEST_F(EnvironmentFiles, JpegImagesAreDecodedFromSrgb) {
    std::vector<uint8_t> rgb(16 * 16 * 3, 128);
    writeChannels(file("flat.jpg"), 16, 16, 3, OIIO::TypeDesc::UINT8, rgb);
    Image image = readImage(file("flat.jpg"));
    for (const glm::vec4& texel : image.texels) {
        EXPECT_GT(texel.g, srgbDecoded(126.5 / 255.0));
        EXPECT_LT(texel.g, srgbDecoded(129.5 / 255.0));
    }
}

TEST_F(EnvironmentFiles, OneChannelIsGrey) {
    writeChannels(file("grey.exr"), 2, 1, 1, OIIO::TypeDesc::FLOAT, std::vector<float>{0.25f, 3.0f});
    Image image = readImage(file("grey.exr"));
    EXPECT_EQ(glm::vec3(image.at(0, 0)), glm::vec3(0.25f));
    EXPECT_EQ(glm::vec3(image.at(1, 0)), glm::vec3(3.0f));
}

TEST_F(EnvironmentFiles, TwoChannelsAreGreyAndIgnoredAlpha) {
    // Alpha 0 must not blacken the grey value (no premultiplication).
    writeChannels(file("grey_alpha.png"), 1, 1, 2, OIIO::TypeDesc::UINT8, std::vector<uint8_t>{128, 0});
    EXPECT_NEAR(readImage(file("grey_alpha.png")).at(0, 0).r, 0.2158605f, kFloatRounding);
    EXPECT_NEAR(readImage(file("grey_alpha.png")).at(0, 0).b, 0.2158605f, kFloatRounding);
}

TEST_F(EnvironmentFiles, FourChannelsAreRgbAndIgnoredAlpha) {
    writeChannels(file("rgba.png"), 1, 1, 4, OIIO::TypeDesc::UINT8, std::vector<uint8_t>{255, 128, 0, 0});
    Image image = readImage(file("rgba.png"));
    EXPECT_EQ(image.at(0, 0).r, 1.0f);
    EXPECT_NEAR(image.at(0, 0).g, 0.2158605f, kFloatRounding);
    EXPECT_EQ(image.at(0, 0).b, 0.0f);

    writeChannels(file("rgba.exr"), 1, 1, 4, OIIO::TypeDesc::FLOAT,
                  std::vector<float>{1.5f, 2.5f, 3.5f, 0.0f});
    EXPECT_EQ(glm::vec3(readImage(file("rgba.exr")).at(0, 0)), glm::vec3(1.5f, 2.5f, 3.5f));
}

// ---- Channels by name -------------------------------------------------------------------------

// Float channels under the given names, pixel after pixel; OpenImageIO's EXR writer keeps the
// names (and stores them sorted, the order it reads them back in). Chromaticities, if given, are
// written as the EXR attribute (red, green, blue, white xy).
void writeNamedChannels(const std::string& path, int width, int height, const std::vector<std::string>& names,
                        const std::vector<float>& data,
                        const std::array<float, 8>* chromaticities = nullptr) {
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(output) << OIIO::geterror();
    OIIO::ImageSpec spec(width, height, int(names.size()), OIIO::TypeDesc::FLOAT);
    spec.channelnames = names;
    spec.alpha_channel = -1;
    if (chromaticities)
        spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), chromaticities->data());
    ASSERT_TRUE(output->open(path, spec)) << output->geterror();
    ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, data.data())) << output->geterror();
    ASSERT_TRUE(output->close()) << output->geterror();
}

TEST(ChannelPlans, ChosenByName) {
    struct Case {
        std::vector<std::string> names;
        ChannelMeaning meaning;
        std::array<int, 3> channels;
    };
    const std::vector<Case> cases = {
        {{"R", "G", "B"}, ChannelMeaning::Rgb, {0, 1, 2}},
        {{"A", "B", "G", "R"}, ChannelMeaning::Rgb, {3, 2, 1}},
        {{"R", "G", "B", "Y"}, ChannelMeaning::Rgb, {0, 1, 2}},
        {{"Y"}, ChannelMeaning::Grey, {0, 0, 0}},
        {{"A", "Y"}, ChannelMeaning::Grey, {1, 1, 1}},
        {{"Y", "BY", "RY"}, ChannelMeaning::LuminanceChroma, {0, 2, 1}},
        // The unprefixed layer first, then layers in the order of their first channel.
        {{"diffuse.R", "diffuse.G", "diffuse.B", "R", "G", "B"}, ChannelMeaning::Rgb, {3, 4, 5}},
        {{"A", "a.R", "a.G", "b.R", "b.G", "b.B"}, ChannelMeaning::Rgb, {3, 4, 5}},
        {{"Z", "light.sun.B", "light.sun.G", "light.sun.R"}, ChannelMeaning::Rgb, {3, 2, 1}},
        {{"depth.Z", "mask.Y"}, ChannelMeaning::Grey, {1, 1, 1}},
        // OpenImageIO's names for any two-channel image whose format names none: grey and alpha.
        {{"R", "G"}, ChannelMeaning::Grey, {0, 0, 0}},
    };
    for (const Case& c : cases) {
        ChannelPlan plan = planChannels(c.names, "test");
        std::string names = ::testing::PrintToString(c.names);
        EXPECT_EQ(plan.meaning, c.meaning) << names;
        for (int i = 0; i < plan.count(); ++i)
            EXPECT_EQ(plan.channels[size_t(i)], c.channels[size_t(i)]) << names;
    }
}

TEST(ChannelPlans, NamesWithoutColourAreRefused) {
    EXPECT_EQ(inputErrorOf([] {
                  planChannels({"Z", "A"}, "sky.exr");
              }),
              "sky.exr: no R,G,B, Y or Y,RY,BY channels (found: Z, A)");
    EXPECT_EQ(inputErrorOf([] { planChannels({}, "sky.exr"); }),
              "sky.exr: no R,G,B, Y or Y,RY,BY channels (found: none)");
    // Case matters, as in OpenEXR; a layer needs all three; R and G beside another are not OpenImageIO's
    // default names.
    EXPECT_CONTAINS(inputErrorOf([] { planChannels({"r", "g", "b"}, "x"); }), "(found: r, g, b)");
    EXPECT_CONTAINS(inputErrorOf([] {
                        planChannels({"diffuse.R", "diffuse.G"}, "x");
                    }),
                    "(found: diffuse.R, diffuse.G)");
    EXPECT_CONTAINS(inputErrorOf([] { planChannels({"R", "G", "Z"}, "x"); }), "(found: R, G, Z)");
    EXPECT_EQ(inputErrorOf([] {
                  planChannels({"Y", "RY"}, "sky.exr");
              }),
              "sky.exr: chroma channel RY without its pair (RY and BY come together; found: Y, RY)");
    // A long list is cut, and control bytes do not break the one line.
    std::vector<std::string> many(40, "Z");
    many[0] = "bad\nname";
    std::string message = inputErrorOf([&] { planChannels(many, "x"); });
    EXPECT_CONTAINS(message, "bad?name, Z");
    EXPECT_CONTAINS(message, "and 24 more)");
}

// OpenEXR's luminance weights are the Y row of the primaries' RGB-to-XYZ matrix. BT.709 with D65
// gives the published (0.2126, 0.7152, 0.0722), rounded there to 4 digits; ACES AP1 gives the
// 10-digit Y row of the AP1-to-XYZ matrix of SMPTE ST 2065-1 / Academy S-2014-004, to float.
TEST(LuminanceChroma, WeightsFollowTheChromaticities) {
    glm::vec3 bt709 = luminanceWeights(Chromaticities{}, "test");
    EXPECT_NEAR(bt709.r, 0.2126f, 5e-5f);
    EXPECT_NEAR(bt709.g, 0.7152f, 5e-5f);
    EXPECT_NEAR(bt709.b, 0.0722f, 5e-5f);
    const Chromaticities ap1{{0.713, 0.293}, {0.165, 0.830}, {0.128, 0.044}, {0.32168, 0.33767}};
    glm::vec3 aces = luminanceWeights(ap1, "test");
    EXPECT_NEAR(aces.r, 0.2722287168f, 1e-6f);
    EXPECT_NEAR(aces.g, 0.6740817658f, 1e-6f);
    EXPECT_NEAR(aces.b, 0.0536895174f, 1e-6f);
    const Chromaticities degenerate{{0.3, 0.3}, {0.3, 0.3}, {0.3, 0.3}, {0.3127, 0.3290}};
    EXPECT_CONTAINS(inputErrorOf([&] { luminanceWeights(degenerate, "sky.exr"); }),
                    "sky.exr: the chromaticities");
}

// RGB to OpenEXR's luminance/chroma as RgbaOutputFile stores it: Y = w . rgb, RY = (R - Y) / Y,
// BY = (B - Y) / Y.
glm::vec3 toLuminanceChroma(const glm::vec3& rgb, const glm::vec3& w) {
    float y = glm::dot(rgb, w);
    return {y, (rgb.r - y) / y, (rgb.b - y) / y};
}

// Positive, of several sizes and saturations (Y must not be 0).
glm::vec3 colourfulTexel(int x, int y) {
    return {0.05f + 0.7f * float(x), 0.02f + 1.3f * float(y), 3.0f / float(1 + x + y)};
}

// Forward and back, each step rounds to float once, values up to the largest component; G is
// (Y - R w.r - B w.b) / w.g, about ten roundings divided by w.g (0.72 for BT.709, 0.67 for AP1):
// within 1e-6 of the largest component (measured: 2.2e-7 over 64 x 64 such texels).
constexpr float kLuminanceChromaRounding = 1e-6f;

void expectRgbBack(const Image& image, int width, int height) {
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            glm::vec3 expected = colourfulTexel(x, y);
            float largest = std::max({expected.r, expected.g, expected.b});
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(image.at(x, y)[c], expected[c], kLuminanceChromaRounding * largest)
                    << "texel " << x << " " << y << " channel " << c;
        }
}

TEST_F(EnvironmentFiles, LuminanceChromaIsConvertedToRgb) {
    const int w = 8, h = 4;
    const glm::vec3 weights = luminanceWeights(Chromaticities{}, "test"); // no chromaticities: BT.709
    std::vector<float> yca;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            glm::vec3 stored = toLuminanceChroma(colourfulTexel(x, y), weights);
            yca.insert(yca.end(), {stored[0], stored[1], stored[2]});
        }
    writeNamedChannels(file("yca.exr"), w, h, {"Y", "RY", "BY"}, yca);
    expectRgbBack(readImage(file("yca.exr")), w, h);
}

// The file's chromaticities give the weights. The extra channels sort between BY and RY, so the
// planned channels lie apart and are read one by one.
TEST_F(EnvironmentFiles, LuminanceChromaUsesTheFilesChromaticities) {
    const int w = 8, h = 4;
    const std::array<float, 8> ap1xy{0.713f, 0.293f, 0.165f, 0.830f, 0.128f, 0.044f, 0.32168f, 0.33767f};
    const Chromaticities ap1{
        {ap1xy[0], ap1xy[1]}, {ap1xy[2], ap1xy[3]}, {ap1xy[4], ap1xy[5]}, {ap1xy[6], ap1xy[7]}};
    const glm::vec3 weights = luminanceWeights(ap1, "test");
    std::vector<float> data;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            glm::vec3 stored = toLuminanceChroma(colourfulTexel(x, y), weights);
            data.insert(data.end(), {stored[0], stored[1], stored[2], 7.0f, 8.0f, 9.0f, 10.0f});
        }
    writeNamedChannels(file("aces.exr"), w, h, {"Y", "RY", "BY", "C", "D", "E", "F"}, data, &ap1xy);
    expectRgbBack(readImage(file("aces.exr")), w, h);
}

TEST(LuminanceChroma, ZeroChromaIsExactlyGrey) {
    const glm::vec3 weights = luminanceWeights(Chromaticities{}, "test");
    for (float y : {0.3f, 1.0f, 7e4f})
        EXPECT_EQ(luminanceChromaToRgb(y, 0.0f, 0.0f, weights), glm::vec3(y)) << y;
}

TEST_F(EnvironmentFiles, LayerPrefixedRgbIsRead) {
    writeNamedChannels(file("layer.exr"), 1, 1, {"diffuse.R", "diffuse.G", "diffuse.B", "A", "Z"},
                       {1.0f, 2.0f, 3.0f, 4.0f, 5.0f});
    EXPECT_EQ(glm::vec3(readImage(file("layer.exr")).at(0, 0)), glm::vec3(1.0f, 2.0f, 3.0f));
    writeNamedChannels(file("both.exr"), 1, 1, {"diffuse.R", "diffuse.G", "diffuse.B", "R", "G", "B"},
                       {7.0f, 8.0f, 9.0f, 1.0f, 2.0f, 3.0f});
    EXPECT_EQ(glm::vec3(readImage(file("both.exr")).at(0, 0)), glm::vec3(1.0f, 2.0f, 3.0f));
}

TEST_F(EnvironmentFiles, LuminanceWithAlphaIsGrey) {
    writeNamedChannels(file("ya.exr"), 1, 1, {"Y", "A"}, {0.75f, 0.0f});
    EXPECT_EQ(glm::vec3(readImage(file("ya.exr")).at(0, 0)), glm::vec3(0.75f));
}

TEST_F(EnvironmentFiles, ChannelsWithoutColourAreRefusedNamingThem) {
    writeNamedChannels(file("depth.exr"), 1, 1, {"Z"}, {1.0f});
    EXPECT_EQ(inputErrorOf([&] { readImage(file("depth.exr")); }),
              file("depth.exr") + ": no R,G,B, Y or Y,RY,BY channels (found: Z)");
    writeNamedChannels(file("motion.exr"), 1, 1, {"R", "G", "Z"}, {1.0f, 2.0f, 3.0f});
    EXPECT_EQ(inputErrorOf([&] { readImage(file("motion.exr")); }),
              file("motion.exr") + ": no R,G,B, Y or Y,RY,BY channels (found: R, G, Z)");
}

// ---- Non-finite texels ------------------------------------------------------------------------

Image equirectWithNonFiniteTexels() {
    Image image = filledImage(16, 8, [](int, int) { return glm::vec3(1.0f); });
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    image.at(1, 1).r = nan;
    image.at(2, 3).g = nan;
    image.at(5, 5) = glm::vec4(nan, nan, nan, 1.0f);
    image.at(7, 0).b = inf;
    image.at(9, 7).r = -inf;
    return image;
}

TEST_F(EnvironmentFiles, NonFiniteTexelsAreRefusedWithTheirCount) {
    writeImage(file("nan.exr"), equirectWithNonFiniteTexels());
    std::string message = inputErrorOf([&] { loadEnvironment(file("nan.exr"), {}); });
    EXPECT_CONTAINS(message, "nan.exr");
    EXPECT_CONTAINS(message, "5 texels are NaN or infinite");
    EXPECT_CONTAINS(message, "--sanitize");
}

TEST_F(EnvironmentFiles, NonFiniteTexelsAreReplacedOnRequest) {
    writeImage(file("nan.exr"), equirectWithNonFiniteTexels());
    Environment environment = loadEnvironment(file("nan.exr"), {.nonFinite = NonFinitePolicy::Replace});
    EXPECT_EQ(environment.replacedTexels, 5u);
    for (const glm::vec4& texel : environment.cubemap.texels) {
        // Replaced before resampling: no NaN spreads, and the zeros only darken, never brighten.
        EXPECT_TRUE(std::isfinite(texel.r) && std::isfinite(texel.g) && std::isfinite(texel.b));
        EXPECT_LE(texel.r, 1.0f + kFloatRounding);
        EXPECT_GE(texel.r, 0.0f);
    }
}

TEST(NonFinitePolicy, ReplacesWithZeroAndKeepsNegatives) {
    std::vector<glm::vec4> texels = {{-2.0f, 1.0f, 0.5f, 1.0f}, {std::nanf(""), 1.0f, 1.0f, 1.0f}};
    EXPECT_EQ(applyNonFinitePolicy(texels, NonFinitePolicy::Replace, "test"), 1u);
    EXPECT_EQ(texels[0], glm::vec4(-2.0f, 1.0f, 0.5f, 1.0f));
    EXPECT_EQ(glm::vec3(texels[1]), glm::vec3(0.0f));
    // Alpha is not colour: a NaN alpha is not counted.
    std::vector<glm::vec4> alphaOnly = {{1.0f, 1.0f, 1.0f, std::nanf("")}};
    EXPECT_EQ(applyNonFinitePolicy(alphaOnly, NonFinitePolicy::Refuse, "test"), 0u);
}

// ---- Unreadable files -------------------------------------------------------------------------

TEST_F(EnvironmentFiles, MissingFile) {
    std::string message = inputErrorOf([&] { loadEnvironment(file("absent.exr"), {}); });
    EXPECT_CONTAINS(message, "absent.exr");
    EXPECT_CONTAINS(message, "no such file");
}

TEST_F(EnvironmentFiles, EmptyFile) {
    writeText(file("empty.exr"), "");
    std::string message = inputErrorOf([&] { readImage(file("empty.exr")); });
    EXPECT_CONTAINS(message, "empty.exr");
    EXPECT_CONTAINS(message, "empty");
}

TEST_F(EnvironmentFiles, TextFileNamedExr) {
    writeText(file("notes.exr"), "These are not pixels.\n");
    std::string message = inputErrorOf([&] { readImage(file("notes.exr")); });
    EXPECT_CONTAINS(message, "notes.exr");
    EXPECT_CONTAINS(message, "not an image");
}

// Cut in half, the file loses part of its header; cut short by a few bytes, only pixels are lost.
TEST_F(EnvironmentFiles, TruncatedFile) {
    writeImage(file("half.exr"), smoothEquirect(64, 32));
    fs::resize_file(file("half.exr"), fs::file_size(file("half.exr")) / 2);
    EXPECT_CONTAINS(inputErrorOf([&] { readImage(file("half.exr")); }), "half.exr");

    writeImage(file("short.exr"), smoothEquirect(64, 32));
    fs::resize_file(file("short.exr"), fs::file_size(file("short.exr")) - 10);
    std::string message = inputErrorOf([&] { readImage(file("short.exr")); });
    EXPECT_CONTAINS(message, "short.exr");
    EXPECT_CONTAINS(message, "truncated");
}

TEST_F(EnvironmentFiles, AspectRatioMatchingNoLayout) {
    writeImage(file("odd.exr"), filledImage(50, 40, [](int, int) { return glm::vec3(1); }));
    std::string message = inputErrorOf([&] { loadEnvironment(file("odd.exr"), {}); });
    EXPECT_CONTAINS(message, "odd.exr");
    EXPECT_CONTAINS(message, "50x40");
    EXPECT_CONTAINS(message, "4:3");
}

// A header may claim a size whose allocation alone would exhaust memory: refused before reading,
// naming the limit and how to raise it. 65536 x 32768 passes the side limit (65536) and is refused
// by the pixel limit (16384 x 8192 by default); 100000 is longer than any side may be.
TEST_F(EnvironmentFiles, OversizeHeaderIsRefusedBeforeReading) {
    writeText(file("huge.ppm"), "P6\n100000 100000\n255\n\x01\x02\x03");
    std::string message = inputErrorOf([&] { readImage(file("huge.ppm")); });
    EXPECT_CONTAINS(message, "huge.ppm");
    EXPECT_CONTAINS(message, "100000x100000");
    EXPECT_CONTAINS(message, "limit of 65536 pixels per side");

    writeText(file("huge.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 32768 +X 65536\n");
    message = inputErrorOf([&] { readImage(file("huge.hdr")); });
    EXPECT_CONTAINS(message, "huge.hdr: the image is 65536x32768 (2147483648 pixels), more than the limit of "
                             "134217728 pixels (16384x8192); raise it with --max-pixels");
    // Raised, the limit lets the header through: the missing pixels are what fails then. Not run
    // here, as it would allocate 32 GiB; a small image shows the limit moving instead.
}

// The limit is LoadOptions::maxPixels (--max-pixels): a 64 x 32 image passes at 2048 pixels and is
// refused at 2047, for single images and for each of six faces.
TEST_F(EnvironmentFiles, PixelLimitIsAnOption) {
    writeImage(file("small.exr"), smoothEquirect(64, 32));
    EXPECT_EQ(loadEnvironment(file("small.exr"), {.maxPixels = 2048}).cubemap.faceSize, 16);
    std::string message = inputErrorOf([&] { loadEnvironment(file("small.exr"), {.maxPixels = 2047}); });
    EXPECT_CONTAINS(message,
                    "small.exr: the image is 64x32 (2048 pixels), more than the limit of 2047 pixels");

    for (const char* name : {"px", "nx", "py", "ny", "pz", "nz"})
        writeImage(folder() + "/" + name + ".exr", filledImage(8, 8, [](int, int) { return glm::vec3(1); }));
    EXPECT_EQ(loadEnvironment(folder(), {.maxPixels = 64}).cubemap.faceSize, 8);
    EXPECT_CONTAINS(inputErrorOf([&] { loadEnvironment(folder(), {.maxPixels = 63}); }),
                    "limit of 63 pixels");
    EXPECT_CONTAINS(inputErrorOf([&] { loadEnvironment(file("small.exr"), {.maxPixels = 0}); }),
                    "--max-pixels");
}

// libpng prints "libpng error: ..." to stderr itself; OpenImageIO reports the same text, which the
// Error carries. Nothing reaches stderr. (AddressSanitizer builds let library output through: see
// image_read.cpp.)
TEST_F(EnvironmentFiles, TruncatedPngSaysSoInTheErrorOnly) {
    std::vector<uint8_t> noise(64 * 32 * 3);
    uint32_t state = 7;
    for (uint8_t& byte : noise)
        byte = uint8_t((state = state * 1664525u + 1013904223u) >> 24);
    writeChannels(file("full.png"), 64, 32, 3, OIIO::TypeDesc::UINT8, noise);
    fs::copy_file(file("full.png"), file("cut.png"));
    fs::resize_file(file("cut.png"), fs::file_size(file("full.png")) / 2);
    ::testing::internal::CaptureStderr();
    std::string message = inputErrorOf([&] {
        [[maybe_unused]] LibraryLeaksIgnored leaks;
        readImage(file("cut.png"));
    });
    std::string printed = ::testing::internal::GetCapturedStderr();
    EXPECT_CONTAINS(message, "cut.png: cannot read the pixels; the file may be truncated");
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
#if defined(SHPROBE_TEST_ASAN)
    (void)printed;
#else
    EXPECT_EQ(printed, "");
#endif
}

// Values are kept as stored: negative and huge finite texels are not changed on reading (the
// non-finite policy deals with NaN and infinities only).
TEST_F(EnvironmentFiles, NegativeAndHugeTexelsAreKept) {
    Image image = filledImage(
        2, 1, [](int x, int) { return x == 0 ? glm::vec3(-1.5f, -0.0f, -3e5f) : glm::vec3(1e30f); });
    writeImage(file("extreme.exr"), image);
    Image back = readImage(file("extreme.exr"));
    EXPECT_EQ(glm::vec3(back.at(0, 0)), glm::vec3(-1.5f, -0.0f, -3e5f));
    EXPECT_EQ(glm::vec3(back.at(1, 0)), glm::vec3(1e30f));
    std::vector<glm::vec4> texels = back.texels;
    EXPECT_EQ(applyNonFinitePolicy(texels, NonFinitePolicy::Replace, "extreme.exr"), 0u);
    EXPECT_EQ(texels, back.texels);
}

// Pipes and devices are not read (they could block, or never end).
TEST_F(EnvironmentFiles, OnlyRegularFilesAreRead) {
    EXPECT_CONTAINS(inputErrorOf([&] { readImage("/dev/null"); }), "/dev/null: not a regular file");
    EXPECT_CONTAINS(inputErrorOf([&] { readImage(folder()); }), "is a folder");
}

// A loop of links, as the input, as a face file (of a pattern and of a folder) and as the faces
// folder: each is one line "PATH: REASON" in the system's words.
TEST_F(EnvironmentFiles, LoopsOfLinksAreSaidAsSuch) {
    const std::string loop = systemReason(ELOOP); // "too many levels of symbolic links"
    fs::create_symlink(file("loop.exr"), file("loop.exr"));
    EXPECT_EQ(inputErrorOf([&] { loadEnvironment(file("loop.exr"), {}); }), file("loop.exr") + ": " + loop);
    EXPECT_EQ(inputErrorOf([&] { readImage(file("loop.exr")); }), file("loop.exr") + ": " + loop);

    for (int face = 1; face < kFaceCount; ++face)
        writeImage(file("sky_" + std::string(kFaceNames[face]) + ".exr"), faceImage(face, 4));
    fs::create_symlink(file("sky_px.exr"), file("sky_px.exr"));
    EXPECT_EQ(inputErrorOf([&] { loadEnvironment(file("sky_{face}.exr"), {}); }),
              file("sky_px.exr") + ": " + loop);

    fs::create_directory(file("faces"));
    for (int face = 1; face < kFaceCount; ++face)
        writeImage(file("faces/" + std::string(kFaceNames[face]) + ".exr"), faceImage(face, 4));
    fs::create_symlink(file("faces/px.exr"), file("faces/px.exr"));
    EXPECT_EQ(inputErrorOf([&] { loadEnvironment(file("faces"), {}); }), file("faces/px.exr") + ": " + loop);

    fs::create_symlink(file("folder_loop"), file("folder_loop"));
    EXPECT_EQ(inputErrorOf([&] { loadEnvironment(file("folder_loop"), {.layout = Layout::Faces}); }),
              file("folder_loop") + ": " + loop);
}

TEST_F(EnvironmentFiles, NamesLongerThanTheSystemAllowsAreSaidAsSuch) {
    const std::string tooLong = file(std::string(300, 'n') + ".exr");
    EXPECT_EQ(inputErrorOf([&] { loadEnvironment(tooLong, {}); }),
              tooLong + ": " + systemReason(ENAMETOOLONG));
    const std::string pattern = file(std::string(300, 'n') + "_{face}.exr");
    EXPECT_CONTAINS(inputErrorOf([&] { loadEnvironment(pattern, {}); }), systemReason(ENAMETOOLONG));
}

// Runs `body` in a child process as user and group nobody (65534) and returns the message of the
// Error(Input) it threw ("" if none); nullopt when the child could not switch users. The child
// only asks the file system (every case fails before an image library runs), so forking a process
// that may hold library threads is safe.
std::optional<std::string> inputErrorAsNobody(const std::function<void()>& body) {
    int pipeFds[2];
    if (pipe(pipeFds) != 0) return std::nullopt;
    pid_t child = fork();
    if (child == 0) {
        close(pipeFds[0]);
        std::string message = "\x01";
        if (setgroups(0, nullptr) == 0 && setgid(65534) == 0 && setuid(65534) == 0) {
            message.clear();
            try {
                body();
            } catch (const Error& error) {
                message = error.what();
            }
        }
        ssize_t written = write(pipeFds[1], message.data(), message.size());
        _exit(written == ssize_t(message.size()) ? 0 : 1);
    }
    close(pipeFds[1]);
    std::string message;
    char buffer[512];
    for (ssize_t got; (got = read(pipeFds[0], buffer, sizeof buffer)) > 0;)
        message.append(buffer, size_t(got));
    close(pipeFds[0]);
    int status = 0;
    waitpid(child, &status, 0);
    if (message == "\x01") return std::nullopt;
    return message;
}

// What an unprivileged user may not read is said as "permission denied": a file of mode 000, a
// file in a folder they may not search, and a faces folder they may list but not search.
TEST_F(EnvironmentFiles, UnreadableFilesSayPermissionDenied) {
    if (geteuid() != 0) GTEST_SKIP() << "needs root, to read as user nobody in a child process";
    const std::string denied = systemReason(EACCES); // "permission denied"
    writeImage(file("locked.exr"), smoothEquirect(16, 8));
    fs::permissions(file("locked.exr"), fs::perms::none);
    fs::create_directory(file("private"));
    writeImage(file("private/sky.exr"), smoothEquirect(16, 8));
    fs::permissions(file("private"), fs::perms::owner_all);
    fs::create_directory(file("faces"));
    for (int face = 0; face < kFaceCount; ++face)
        writeImage(file("faces/" + std::string(kFaceNames[face]) + ".exr"), faceImage(face, 4));
    fs::permissions(file("faces"), fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);

    const std::vector<std::pair<std::string, std::string>> cases = {
        {file("locked.exr"), file("locked.exr")},
        {file("private/sky.exr"), file("private/sky.exr")},
        {file("faces"), file("faces/px.exr")},
    };
    for (const auto& [input, named] : cases) {
        std::optional<std::string> message =
            inputErrorAsNobody([path = input] { loadEnvironment(path, {}); });
        if (!message) GTEST_SKIP() << "this system does not let root switch to user nobody";
        EXPECT_EQ(*message, named + ": " + denied) << input;
    }
    // Root reads them all (the files are sound).
    EXPECT_EQ(readImage(file("locked.exr")).width, 16);
}

// ---- Headers read within bounds ---------------------------------------------------------------
// Hand-made OpenEXR headers ("OpenEXR File Layout", openexr.com): magic, version 2 and flags, then
// attributes `name\0 type\0 int32 size, value` until an empty name.

std::string littleEndian32(uint32_t value) {
    return {char(value & 0xff), char(value >> 8 & 0xff), char(value >> 16 & 0xff), char(value >> 24)};
}

std::string exrAttribute(const std::string& name, const std::string& type, const std::string& value) {
    return name + '\0' + type + '\0' + littleEndian32(uint32_t(value.size())) + value;
}

// Channels of 32-bit float, sampled as given.
struct ExrChannel {
    std::string name;
    int xSampling = 1;
    int ySampling = 1;
};
std::string exrChannelList(const std::vector<ExrChannel>& channels) {
    std::string list;
    for (const ExrChannel& c : channels)
        list += c.name + '\0' + littleEndian32(2) + std::string(4, '\0') +
                littleEndian32(uint32_t(c.xSampling)) + littleEndian32(uint32_t(c.ySampling));
    return list + '\0';
}

// The attributes every scan-line image has, for a width x height image of the given channels.
std::string exrRequiredAttributes(int width, int height, const std::vector<ExrChannel>& channels) {
    std::string window = littleEndian32(0) + littleEndian32(0) + littleEndian32(uint32_t(width - 1)) +
                         littleEndian32(uint32_t(height - 1));
    std::string one = littleEndian32(0x3f800000); // 1.0f
    return exrAttribute("channels", "chlist", exrChannelList(channels)) +
           exrAttribute("compression", "compression", std::string(1, '\0')) +
           exrAttribute("dataWindow", "box2i", window) + exrAttribute("displayWindow", "box2i", window) +
           exrAttribute("lineOrder", "lineOrder", std::string(1, '\0')) +
           exrAttribute("pixelAspectRatio", "float", one) +
           exrAttribute("screenWindowCenter", "v2f", std::string(8, '\0')) +
           exrAttribute("screenWindowWidth", "float", one);
}

std::string exrStart(uint32_t flags = 0) {
    return std::string("\x76\x2f\x31\x01", 4) + littleEndian32(2 | flags);
}

const std::vector<ExrChannel> kRgb = {{"B"}, {"G"}, {"R"}};

// The peak resident memory of this process so far, in bytes.
size_t peakMemory() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return size_t(usage.ru_maxrss) * 1024;
}

// A 600-byte EXR whose "comments" claims 2^31 - 1 bytes made OpenEXR allocate them (2.2 GB) and
// read for seconds before it failed. Refused from the header, in far less than a second and
// without the allocation (the process's peak memory does not grow by anything like it).
TEST_F(EnvironmentFiles, ExrAttributeClaimingMoreThanTheFileIsRefusedAtOnce) {
    std::string bytes = exrStart() + exrRequiredAttributes(8, 4, kRgb) + "comments" + '\0' + "string" + '\0' +
                        littleEndian32(0x7fffffff) + std::string(200, 'x');
    bytes.resize(600, '\0');
    writeText(file("tiny.exr"), bytes);
    const size_t memoryBefore = peakMemory();
    const auto start = std::chrono::steady_clock::now();
    std::string message = inputErrorOf([&] { loadEnvironment(file("tiny.exr"), {.maxPixels = 2048}); });
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 1.0);
    EXPECT_LT(peakMemory() - memoryBefore, size_t(64) << 20);
    const size_t left = 600 - (bytes.find(std::string(200, 'x')));
    EXPECT_EQ(message, file("tiny.exr") +
                           ": the OpenEXR header attribute \"comments\" (string) claims "
                           "2147483647 bytes, more than the " +
                           std::to_string(left) + " left in the file");
}

TEST_F(EnvironmentFiles, ExrHeadersBeyondTheLimitsAreRefused) {
    const std::string header = exrStart() + exrRequiredAttributes(8, 4, kRgb);
    auto refusal = [&](const std::string& name, const std::string& bytes) {
        writeText(file(name), bytes + std::string(64, '\0'));
        return inputErrorOf([&] { readImage(file(name)); });
    };
    EXPECT_CONTAINS(
        refusal("negative.exr", header + "note" + '\0' + "string" + '\0' + littleEndian32(0xfffffff0u)),
        "attribute \"note\" (string) claims a negative size (-16 bytes)");
    // OpenEXR reads a box2i as 16 bytes whatever the size says: any other size would make it read
    // the rest of the header from elsewhere than the scan.
    EXPECT_CONTAINS(refusal("box.exr", header + exrAttribute("crop", "box2i", std::string(20, '\0'))),
                    "attribute \"crop\" (box2i) claims 20 bytes; a box2i value has 16");
    EXPECT_CONTAINS(refusal("name.exr", header + exrAttribute(std::string(300, 'n'), "string", "x")),
                    "holds an attribute name longer than 255 bytes");
    std::string many = header;
    for (int i = 0; i < kMaxExrAttributesPerHeader; ++i)
        many += exrAttribute("a" + std::to_string(i), "int", "1234");
    EXPECT_CONTAINS(refusal("many.exr", many), "the OpenEXR header has more than 1000 attributes");

    std::string parts = exrStart(0x1000);
    for (int i = 0; i <= kMaxExrParts; ++i)
        parts += exrAttribute("name", "string", "p" + std::to_string(i)) + '\0';
    EXPECT_CONTAINS(refusal("parts.exr", parts + '\0'), "the OpenEXR header has more than 1000 parts");
}

// OpenEXR's luminance/chroma files keep RY and BY at half resolution; OpenImageIO reads no
// subsampled channel. Said naming the channel.
TEST_F(EnvironmentFiles, SubsampledChannelsAreRefusedNamingThem) {
    std::string bytes = exrStart() + exrRequiredAttributes(4, 4, {{"BY", 2, 2}, {"RY", 2, 2}, {"Y"}}) + '\0';
    writeText(file("yca.exr"), bytes + std::string(256, '\0'));
    EXPECT_EQ(inputErrorOf([&] { readImage(file("yca.exr")); }),
              file("yca.exr") +
                  ": channel BY is subsampled (2 x 2), and shprobe reads only full-resolution EXR "
                  "channels; store the image at full resolution");
}

// Files OpenImageIO writes, one part or two, pass the scan, which stops at the header's end.
TEST_F(EnvironmentFiles, ExrHeadersOfSoundFilesPass) {
    writeImage(file("sky.exr"), smoothEquirect(16, 8));
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(file("parts.exr"));
    ASSERT_TRUE(output);
    // The parts of one file share a display window: both are 16 x 8.
    std::array<OIIO::ImageSpec, 2> specs{OIIO::ImageSpec(16, 8, 3, OIIO::TypeDesc::FLOAT),
                                         OIIO::ImageSpec(16, 8, 1, OIIO::TypeDesc::FLOAT)};
    specs[0].attribute("oiio:subimagename", "colour");
    specs[1].attribute("oiio:subimagename", "depth");
    specs[1].channelnames = {"Z"};
    std::vector<float> rgb(16 * 8 * 3, 0.5f), depth(16 * 8, 9.0f);
    ASSERT_TRUE(output->open(file("parts.exr"), 2, specs.data())) << output->geterror();
    ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, rgb.data())) << output->geterror();
    ASSERT_TRUE(output->open(file("parts.exr"), specs[1], OIIO::ImageOutput::AppendSubimage))
        << output->geterror();
    ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, depth.data())) << output->geterror();
    ASSERT_TRUE(output->close());
    for (const char* name : {"sky.exr", "parts.exr"}) {
        int fd = open(file(name).c_str(), O_RDONLY | O_CLOEXEC);
        ASSERT_GE(fd, 0);
        uint64_t headerBytes = checkImageHeader(fd, file(name));
        close(fd);
        EXPECT_GT(headerBytes, 8u) << name;
        EXPECT_LT(headerBytes, fs::file_size(file(name))) << name;
    }
    EXPECT_EQ(readImage(file("parts.exr")).at(3, 2), glm::vec4(0.5f, 0.5f, 0.5f, 1.0f));
}

// libpng allocates a chunk's length before reading it: a text chunk claiming 2^31 - 1 bytes in a
// 52-byte PNG cost 2.2 GB. Refused from the chunk's length.
TEST_F(EnvironmentFiles, PngChunkClaimingMoreThanTheFileIsRefused) {
    std::string ihdr = std::string("\0\0\0\x0d"
                                   "IHDR",
                                   8) +
                       std::string("\0\0\0\x04\0\0\0\x02\x08\x02\0\0\0", 13) +
                       std::string(4, '\0'); // CRC unchecked before the refusal
    std::string text = std::string("\x7f\xff\xff\xff"
                                   "tEXt",
                                   8) +
                       "Comment" + '\0' + "abc";
    writeText(file("text.png"), std::string("\x89PNG\r\n\x1a\n", 8) + ihdr + text);
    EXPECT_EQ(inputErrorOf([&] { readImage(file("text.png")); }),
              file("text.png") +
                  ": the PNG chunk \"tEXt\" claims 2147483647 bytes, more than the 7 left in the file");
}

// ---- Resizing ---------------------------------------------------------------------------------

Cubemap randomCubemap(int faceSize) {
    std::mt19937 random(7);
    std::uniform_real_distribution<float> value(0.0f, 4.0f);
    Cubemap cubemap = makeCubemap(faceSize);
    for (glm::vec4& texel : cubemap.texels)
        texel = glm::vec4(value(random), value(random), value(random), 1.0f);
    return cubemap;
}

glm::dvec3 faceMean(const Cubemap& cubemap, int face) {
    glm::dvec3 sum(0.0);
    for (int j = 0; j < cubemap.faceSize; ++j)
        for (int i = 0; i < cubemap.faceSize; ++i)
            sum += glm::dvec3(glm::vec3(cubemap.at(face, i, j)));
    return sum / double(cubemap.faceSize * cubemap.faceSize);
}

// Weights sum to 1 in double; one float rounding per texel.
constexpr double kResizeRounding = 1e-6;

TEST(Resize, KeepsAConstant) {
    Cubemap constant = makeCubemap(12);
    for (glm::vec4& texel : constant.texels)
        texel = glm::vec4(0.3f, 2.0f, 5.0f, 1.0f);
    for (int size : {1, 5, 7, 12, 13, 31}) {
        Cubemap resized = resizeCubemap(constant, size);
        ASSERT_EQ(resized.faceSize, size);
        for (const glm::vec4& texel : resized.texels) {
            ASSERT_NEAR(texel.r, 0.3, kResizeRounding) << size;
            ASSERT_NEAR(texel.b, 5.0, kResizeRounding) << size;
        }
    }
}

// Area averaging covers every source texel with total weight (to / from)^2, so each face's mean
// is kept, also for ratios that are not integers.
TEST(Resize, ShrinkingKeepsTheMean) {
    Cubemap source = randomCubemap(12);
    for (int size : {1, 4, 5, 7, 11}) {
        Cubemap resized = resizeCubemap(source, size);
        for (int face = 0; face < kFaceCount; ++face) {
            glm::dvec3 before = faceMean(source, face);
            glm::dvec3 after = faceMean(resized, face);
            EXPECT_NEAR(after.r, before.r, kResizeRounding * 4) << size;
            EXPECT_NEAR(after.g, before.g, kResizeRounding * 4) << size;
        }
    }
}

TEST(Resize, HalvingAveragesTwoByTwoBlocks) {
    Cubemap source = randomCubemap(8);
    Cubemap half = resizeCubemap(source, 4);
    glm::vec4 block =
        (source.at(2, 2, 4) + source.at(2, 3, 4) + source.at(2, 2, 5) + source.at(2, 3, 5)) / 4.0f;
    EXPECT_NEAR(half.at(2, 1, 2).r, block.r, kResizeRounding * 4);
    EXPECT_NEAR(half.at(2, 1, 2).g, block.g, kResizeRounding * 4);
}

// Halving weighs each texel of a 2 x 2 block by exactly 1/2 per axis, and the sums of floats in
// double are exact, so each texel is the block's mean rounded once to float: equal, not near.
// 512 -> 256 is enough work to run on several threads; every texel of every face is checked.
TEST(Resize, HalvingLargeFacesGivesEveryBlockMeanExactly) {
    const int size = 256;
    Cubemap source = randomCubemap(2 * size);
    Cubemap half = resizeCubemap(source, size);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < size; ++j)
            for (int i = 0; i < size; ++i) {
                glm::dvec4 sum = glm::dvec4(source.at(face, 2 * i, 2 * j)) +
                                 glm::dvec4(source.at(face, 2 * i + 1, 2 * j)) +
                                 glm::dvec4(source.at(face, 2 * i, 2 * j + 1)) +
                                 glm::dvec4(source.at(face, 2 * i + 1, 2 * j + 1));
                ASSERT_EQ(half.at(face, i, j), glm::vec4(sum / 4.0)) << face << " " << i << " " << j;
            }
}

// ---- Default sky ------------------------------------------------------------------------------

double luminance(const glm::vec4& texel) {
    return 0.2126 * texel.r + 0.7152 * texel.g + 0.0722 * texel.b;
}

TEST(DefaultSky, SunIsBrightAndGroundIsDark) {
    const int n = 64;
    SkyParameters sky;
    Cubemap cubemap = makeDefaultSky(n, sky);
    glm::dvec3 sun = glm::normalize(sky.sunDirection);
    double groundSum = 0.0, skySum = 0.0;
    int groundCount = 0, skyCount = 0;
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                glm::dvec3 d = texelDirection(face, i, j, n);
                double value = luminance(cubemap.at(face, i, j));
                double fromSun = angleBetween(d, sun);
                if (fromSun < sky.sunAngularRadius) {
                    EXPECT_GT(value, 1000.0) << "inside the sun disc";
                } else if (fromSun > sky.sunAngularRadius + 3.0 / n) { // clear of texels the disc touches
                    EXPECT_LT(value, 2.0);
                    (d.y < 0.0 ? groundSum : skySum) += value;
                    ++(d.y < 0.0 ? groundCount : skyCount);
                }
            }
    EXPECT_LT(groundSum / groundCount, 0.5 * skySum / skyCount);
}

// Clear of the sun a texel holds the sky at its center, whatever the face size: 1 and 7 texels are
// fewer than the rows' blocks of 64 directions, 100 ends in a part of one. makeDefaultSky finds
// the directions row by row and skyRadiance normalizes texelDirection's again, which may move it
// by an ulp of a double: the float texels agree to a few float ulps.
TEST(DefaultSky, TexelsClearOfTheSunHoldTheSkyAtTheirCenters) {
    SkyParameters sky;
    glm::dvec3 sun = glm::normalize(sky.sunDirection);
    for (int n : {1, 7, 64, 100}) {
        Cubemap cubemap = makeDefaultSky(n, sky);
        int compared = 0;
        for (int face = 0; face < kFaceCount; ++face)
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    glm::dvec3 d = texelDirection(face, i, j, n);
                    if (angleBetween(d, sun) < sky.sunAngularRadius + 1.5 / n) continue; // past sqrt(2) / n
                    glm::dvec3 expected = skyRadiance(sky, d);
                    glm::vec4 texel = cubemap.at(face, i, j);
                    for (int c = 0; c < 3; ++c)
                        ASSERT_NEAR(texel[c], expected[c], 1e-6 * expected[c])
                            << n << " " << face << " " << i << " " << j;
                    ASSERT_EQ(texel.a, 1.0f);
                    ++compared;
                }
        EXPECT_GE(compared, kFaceCount * n * n / 2) << n;
    }
}

// The sun's power is sunRadiance times its cone's solid angle 2 pi (1 - cos r), whatever the face
// size, even when the disc is smaller than a texel. The coverage grid (8 samples per sun radius,
// about 200 inside the disc) miscounts the disc's edge by a few tenths of a percent (0.2% measured).
constexpr double kSunPowerError = 0.01;

TEST(DefaultSky, SunPowerIsKeptAtEveryFaceSize) {
    SkyParameters sky;
    SkyParameters sunless = sky;
    sunless.sunRadiance = glm::dvec3(0.0);
    double expected = sky.sunRadiance.r * 2.0 * std::numbers::pi * (1.0 - std::cos(sky.sunAngularRadius));
    for (int n : {1, 4, 16, 64, 256}) {
        Cubemap with = makeDefaultSky(n, sky);
        Cubemap without = makeDefaultSky(n, sunless);
        double power = 0.0;
        for (int face = 0; face < kFaceCount; ++face)
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i)
                    power += texelSolidAngle(i, j, n) * (with.at(face, i, j).r - without.at(face, i, j).r);
        std::printf("sky face size %d: sun power %.5f, expected %.5f (relative error %.2g)\n", n, power,
                    expected, power / expected - 1.0);
        EXPECT_NEAR(power / expected, 1.0, kSunPowerError) << n;
    }
}

// ---- Writing ----------------------------------------------------------------------------------

TEST_F(EnvironmentFiles, ExrRoundTripsExactly) {
    std::mt19937 random(3);
    std::normal_distribution<float> value(0.0f, 1000.0f);
    Image image =
        filledImage(13, 7, [&](int, int) { return glm::vec3(value(random), value(random), value(random)); });
    writeImage(file("out.exr"), image);
    Image back = readImage(file("out.exr"));
    ASSERT_EQ(back.width, 13);
    ASSERT_EQ(back.height, 7);
    for (size_t t = 0; t < image.texels.size(); ++t)
        ASSERT_EQ(glm::vec3(back.texels[t]), glm::vec3(image.texels[t])) << t;
    // Nothing else is left in the folder: the temporary file was renamed.
    EXPECT_EQ(std::distance(fs::directory_iterator(folder()), fs::directory_iterator()), 1);
}

// 8-bit files hold sRGB: writeImage encodes what readImage decodes. 0.2158605 encodes to 128
// exactly, 0 and 1 to 0 and 255, so these come back to float precision.
TEST_F(EnvironmentFiles, EightBitFilesRoundTripThroughSrgb) {
    Image image = filledImage(1, 1, [](int, int) { return glm::vec3(0.0f, 0.2158605f, 1.0f); });
    writeImage(file("out.png"), image);
    Image back = readImage(file("out.png"));
    EXPECT_EQ(back.at(0, 0).r, 0.0f);
    EXPECT_NEAR(back.at(0, 0).g, 0.2158605f, kFloatRounding);
    EXPECT_EQ(back.at(0, 0).b, 1.0f);
}

TEST_F(EnvironmentFiles, WritingIntoAMissingFolderFails) {
    try {
        writeImage(file("absent/out.exr"), smoothEquirect(4, 2));
        ADD_FAILURE() << "no Error was thrown";
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Output);
        EXPECT_CONTAINS(std::string(error.what()), "absent");
    }
}

} // namespace
} // namespace shprobe
