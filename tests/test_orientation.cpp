// Orientation of every input path, end to end: an environment lit only in one quadrant of one cube
// face must give an L1 (linear SH band) vector pointing into that quadrant, for a cube map built in
// memory, a horizontal cross, a vertical cross and an equirect map (projected directly and after
// conversion to a cube map). Face-order, flip and cross-placement mistakes are the most common bugs
// of such tools; each of them moves at least one quadrant's light to another quadrant or face.
//
// Independence: the face direction table, the inverse (direction -> face, a, b), the equirect
// direction formula and the cross layouts are written here again from the text of docs/conventions.md,
// not taken from the library, so a mistake made consistently in the library's geometry and in its
// loaders cannot cancel out. The library's directionToFace is checked as well, as the brief's
// decoding of the result, but the expected quadrant always comes from the table below.
//
// Also here: the equirect map projected directly agrees with the same map converted to a cube map
// and projected (docs/conventions.md, "Equirectangular maps"), on a synthetic map and, where installed,
// on a real HDR environment.
#include "image/environment.h"
#include "image/image_write.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/projection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <glm/geometric.hpp>
#include <map>
#include <numbers>
#include <ostream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace shprobe {
namespace {
namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

// ---- docs/conventions.md, written again ---------------------------------------------------------

const char* const kFaceNames[kFaceCount] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};

// "+X: ( 1, -b, -a)  -X: (-1, -b,  a)  +Y: ( a,  1,  b)  -Y: ( a, -1, -b)  +Z: ( a, -b,  1)
//  -Z: (-a, -b, -1)", normalized. a grows to the right of the face image, b downwards.
glm::dvec3 tableDirection(int face, double a, double b) {
    glm::dvec3 d;
    switch (face) {
    case 0:
        d = {1, -b, -a};
        break;
    case 1:
        d = {-1, -b, a};
        break;
    case 2:
        d = {a, 1, b};
        break;
    case 3:
        d = {a, -1, -b};
        break;
    case 4:
        d = {a, -b, 1};
        break;
    default:
        d = {-a, -b, -1};
        break;
    }
    return glm::normalize(d);
}

// The inverse of the table: the face of the major axis, then (a, b) solved from that face's row.
struct TablePoint {
    int face;
    double a;
    double b;
};
TablePoint tableFacePoint(const glm::dvec3& d) {
    double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
    if (ax >= ay && ax >= az)
        return d.x > 0 ? TablePoint{0, -d.z / ax, -d.y / ax} : TablePoint{1, d.z / ax, -d.y / ax};
    if (ay >= az) return d.y > 0 ? TablePoint{2, d.x / ay, d.z / ay} : TablePoint{3, d.x / ay, -d.z / ay};
    return d.z > 0 ? TablePoint{4, d.x / az, -d.y / az} : TablePoint{5, -d.x / az, -d.y / az};
}

// "u = (i+0.5)/W, v = (j+0.5)/H, theta = pi v, phi = 2pi u - pi,
//  direction (sin theta sin phi, cos theta, -sin theta cos phi)".
glm::dvec3 tableEquirectAt(double u, double v) {
    double theta = kPi * v;
    double phi = 2.0 * kPi * u - kPi;
    return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
}
glm::dvec3 tableEquirectDirection(int i, int j, int width, int height) {
    return tableEquirectAt((i + 0.5) / width, (j + 0.5) / height);
}

// The cross layouts, as docs/conventions.md draws them; a slot is found by the face's name.
// Horizontal (4:3): [ . +Y . . ] [ -X +Z +X -Z ] [ . -Y . . ].
// Vertical (3:4):   [ . +Y . ] [ -X +Z +X ] [ . -Y . ] [ . -Z . ], with -Z rotated 180 degrees.
const std::vector<std::string> kHorizontalCrossRows = {". +Y . .", "-X +Z +X -Z", ". -Y . ."};
const std::vector<std::string> kVerticalCrossRows = {". +Y .", "-X +Z +X", ". -Y .", ". -Z ."};

struct Slot {
    int column;
    int row;
};
Slot findSlot(const std::vector<std::string>& rows, int face) {
    for (int row = 0; row < int(rows.size()); ++row) {
        std::istringstream tokens(rows[size_t(row)]);
        std::string token;
        for (int column = 0; tokens >> token; ++column)
            if (token == kFaceNames[face]) return {column, row};
    }
    ADD_FAILURE() << "face " << kFaceNames[face] << " is not in the cross";
    return {0, 0};
}

// ---- Quadrants ----------------------------------------------------------------------------------

// Quadrant of a face image: signA -1 = left half of the columns (a < 0), +1 = right half;
// signB -1 = top half of the rows (b < 0), +1 = bottom half.
struct Quadrant {
    int face;
    int signA;
    int signB;
};
Quadrant quadrantOf(int index) { // 0..23
    return {index / 4, (index % 2) ? 1 : -1, ((index / 2) % 2) ? 1 : -1};
}
std::string describe(const Quadrant& q) {
    return std::string("face ") + kFaceNames[q.face] + ", quadrant " +
           (q.signA < 0 ? "a<0 (left)" : "a>0 (right)") + " " + (q.signB < 0 ? "b<0 (top)" : "b>0 (bottom)");
}
bool insideQuadrant(const glm::dvec3& d, const Quadrant& q) {
    TablePoint p = tableFacePoint(d);
    return p.face == q.face && p.a * q.signA > 0 && p.b * q.signB > 0;
}
// Texel (i, j) of an N x N face image lies in the quadrant (N even).
bool texelInQuadrant(int i, int j, int n, const Quadrant& q) {
    return (i < n / 2 ? -1 : 1) == q.signA && (j < n / 2 ? -1 : 1) == q.signB;
}

// Where the quadrant's light should point: the solid-angle-weighted mean direction of the
// continuous quadrant, integrated here from the table (density 1 / (1 + a^2 + b^2)^(3/2)).
glm::dvec3 quadrantCentroid(const Quadrant& q) {
    const int grid = 64;
    glm::dvec3 sum(0.0);
    for (int sj = 0; sj < grid; ++sj)
        for (int si = 0; si < grid; ++si) {
            double a = q.signA * (si + 0.5) / grid;
            double b = q.signB * (sj + 0.5) / grid;
            sum += tableDirection(q.face, a, b) / std::pow(1.0 + a * a + b * b, 1.5);
        }
    return glm::normalize(sum);
}

double degreesBetween(const glm::dvec3& u, const glm::dvec3& v) {
    return std::acos(std::clamp(glm::dot(glm::normalize(u), glm::normalize(v)), -1.0, 1.0)) * 180.0 / kPi;
}

std::string text(const glm::dvec3& v) {
    char buffer[96];
    std::snprintf(buffer, sizeof buffer, "(%.4f, %.4f, %.4f)", v.x, v.y, v.z);
    return buffer;
}

// The L1 direction of channel r: y_1,-1 = -c y, y_1,0 = c z, y_1,1 = -c x (docs/conventions.md), so the
// first moment of the radiance is proportional to (-L_1,1, -L_1,-1, L_1,0).
glm::dvec3 l1Direction(const ShCoefficients& sh) {
    return glm::normalize(glm::dvec3(-sh.rgb[size_t(shIndex(1, 1))].r, -sh.rgb[size_t(shIndex(1, -1))].r,
                                     sh.rgb[size_t(shIndex(1, 0))].r));
}

// ---- Building the lit environments ----------------------------------------------------------------

constexpr int kFaceSize = 8;        // cube and crosses: each quadrant is 4 x 4 texels
constexpr int kEquirectWidth = 256; // equirect 256 x 128, loaded as cube faces of 64
constexpr int kEquirectHeight = 128;
constexpr int kOrder = 2; // L0 and L1 are all the test reads

const glm::vec4 kLit(1.0f, 1.0f, 1.0f, 1.0f);
const glm::vec4 kDark(0.0f, 0.0f, 0.0f, 1.0f);

Cubemap quadrantCubemap(const Quadrant& q) {
    Cubemap cubemap = makeCubemap(kFaceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < kFaceSize; ++j)
            for (int i = 0; i < kFaceSize; ++i)
                cubemap.at(face, i, j) = face == q.face && texelInQuadrant(i, j, kFaceSize, q) ? kLit : kDark;
    return cubemap;
}

// A cross image with the quadrant painted where docs/conventions.md puts that face's texel (i, j).
Image quadrantCross(const Quadrant& q, const std::vector<std::string>& rows, bool negativeZRotated) {
    const int n = kFaceSize;
    int columns = 0;
    for (const std::string& row : rows) {
        std::istringstream tokens(row);
        std::string token;
        int count = 0;
        while (tokens >> token)
            ++count;
        columns = std::max(columns, count);
    }
    Image cross = makeImage(columns * n, int(rows.size()) * n);
    std::fill(cross.texels.begin(), cross.texels.end(), kDark);
    Slot slot = findSlot(rows, q.face);
    bool rotated = negativeZRotated && q.face == int(Face::NegativeZ);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            if (!texelInQuadrant(i, j, n, q)) continue;
            // Rotated 180 degrees: face texel (i, j) is stored at (n-1-i, n-1-j) of its slot.
            int x = rotated ? n - 1 - i : i;
            int y = rotated ? n - 1 - j : j;
            cross.at(slot.column * n + x, slot.row * n + y) = kLit;
        }
    return cross;
}

// An equirect map lit at the pixels whose center direction (from the formula above) falls into the
// quadrant.
Image quadrantEquirect(const Quadrant& q) {
    Image image = makeImage(kEquirectWidth, kEquirectHeight);
    for (int j = 0; j < kEquirectHeight; ++j)
        for (int i = 0; i < kEquirectWidth; ++i)
            image.at(i, j) = insideQuadrant(tableEquirectDirection(i, j, kEquirectWidth, kEquirectHeight), q)
                                 ? kLit
                                 : kDark;
    return image;
}

// ---- The check --------------------------------------------------------------------------------------

// The L1 direction of a texel-exact quadrant is a positive combination of directions inside the
// quadrant, which is a convex spherical polygon (bounded by the planes a = 0, b = 0 and the face's
// edges), so it lies strictly inside it: the face and the signs of (a, b) must match exactly.
// It must also be close to the continuous quadrant's centroid. Measured: at most 0.30 degrees for
// the cube and crosses (the quadrant's 4 x 4 texels stand for themselves by their centers, a
// midpoint rule), 0.012 degrees for the equirect map projected directly and 0.020 after conversion
// (its staircase edges, 1.4 degrees per pixel, average out along the edges). 2 degrees is far below
// the 20+ degrees from the centroid to the quadrant's edges, across which any flip or misplacement
// moves the light (it moves it 40+ degrees: mirrored to another quadrant or face).
constexpr double kCentroidToleranceDegrees = 2.0;

// Largest angle from the centroid seen per input path, printed after the quadrant tests.
std::map<std::string, double>& worstAngles() {
    static std::map<std::string, double> angles;
    return angles;
}

void expectPointsIntoQuadrant(const ShCoefficients& sh, const Quadrant& q, const std::string& path) {
    glm::dvec3 d = l1Direction(sh);
    glm::dvec3 expected = quadrantCentroid(q);
    TablePoint own = tableFacePoint(d);
    FacePoint library = directionToFace(d);
    std::string context = path + ", " + describe(q) + ": L1 direction " + text(d) + ", expected near " +
                          text(expected) + " (centroid of the quadrant, from the docs/conventions.md table)";
    // Decoded with the table written here (independent of the code under test)...
    EXPECT_EQ(own.face, q.face) << context << "; it points into face " << kFaceNames[own.face];
    EXPECT_GT(own.a * q.signA, 0.0) << context << "; its a is " << own.a;
    EXPECT_GT(own.b * q.signB, 0.0) << context << "; its b is " << own.b;
    // ...and with the library's directionToFace.
    EXPECT_EQ(library.face, q.face) << context << "; directionToFace gives face " << kFaceNames[library.face];
    EXPECT_GT(library.a * q.signA, 0.0) << context << "; directionToFace gives a = " << library.a;
    EXPECT_GT(library.b * q.signB, 0.0) << context << "; directionToFace gives b = " << library.b;
    double angle = degreesBetween(d, expected);
    EXPECT_LT(angle, kCentroidToleranceDegrees) << context << "; " << angle << " degrees off";
    ::testing::Test::RecordProperty("degrees_from_centroid", std::to_string(angle));
    double& worst = worstAngles()[path];
    worst = std::max(worst, angle);
}

// ---- Quadrant tests, one per input path and quadrant ------------------------------------------------

enum class InputPath { Cube, HorizontalCross, VerticalCross, EquirectDirect, EquirectLoaded };
const char* pathName(InputPath path);
void PrintTo(InputPath path, std::ostream* out) {
    *out << pathName(path);
}
const char* pathName(InputPath path) {
    switch (path) {
    case InputPath::Cube:
        return "cube";
    case InputPath::HorizontalCross:
        return "hcross";
    case InputPath::VerticalCross:
        return "vcross";
    case InputPath::EquirectDirect:
        return "equirect_direct";
    case InputPath::EquirectLoaded:
        return "equirect_loaded";
    }
    return "?";
}

class LitQuadrant : public ::testing::TestWithParam<std::tuple<InputPath, int>> {
  protected:
    LitQuadrant() {
        std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
        for (char& c : name)
            if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
        folder_ =
            fs::temp_directory_path() / ("shprobe_test_orientation_" + std::to_string(getpid()) + "_" + name);
        fs::remove_all(folder_);
        fs::create_directories(folder_);
    }
    static void TearDownTestSuite() {
        for (const auto& [path, angle] : worstAngles())
            std::printf("%s: L1 direction at most %.3g degrees from the quadrant's centroid\n", path.c_str(),
                        angle);
    }
    ~LitQuadrant() override {
        std::error_code ignored;
        fs::remove_all(folder_, ignored);
    }
    std::string file(const std::string& name) const { return (folder_ / name).string(); }

  private:
    fs::path folder_;
};

TEST_P(LitQuadrant, L1PointsIntoIt) {
    auto [path, index] = GetParam();
    Quadrant q = quadrantOf(index);
    std::string where = std::string(pathName(path));
    switch (path) {
    case InputPath::Cube:
        expectPointsIntoQuadrant(projectCubemap(quadrantCubemap(q), kOrder), q, where);
        break;
    case InputPath::HorizontalCross:
    case InputPath::VerticalCross: {
        bool horizontal = path == InputPath::HorizontalCross;
        writeImage(file("cross.exr"), quadrantCross(q, horizontal ? kHorizontalCrossRows : kVerticalCrossRows,
                                                    /*negativeZRotated=*/!horizontal));
        Environment environment = loadEnvironment(file("cross.exr"), {.layout = Layout::Auto});
        ASSERT_EQ(environment.layout, horizontal ? Layout::HorizontalCross : Layout::VerticalCross) << where;
        ASSERT_EQ(environment.cubemap.faceSize, kFaceSize) << where;
        expectPointsIntoQuadrant(projectCubemap(environment.cubemap, kOrder), q, where);
        break;
    }
    case InputPath::EquirectDirect:
        expectPointsIntoQuadrant(projectEquirect(quadrantEquirect(q), kOrder), q, where);
        break;
    case InputPath::EquirectLoaded: {
        writeImage(file("equirect.exr"), quadrantEquirect(q));
        Environment environment = loadEnvironment(file("equirect.exr"), {.layout = Layout::Auto});
        ASSERT_EQ(environment.layout, Layout::Equirect) << where;
        ASSERT_EQ(environment.cubemap.faceSize, kEquirectWidth / 4) << where;
        expectPointsIntoQuadrant(projectCubemap(environment.cubemap, kOrder), q, where);
        break;
    }
    }
}

// Test names such as Orientation/LitQuadrant.L1PointsIntoIt/vcross_NZ_left_top.
std::string quadrantTestName(const ::testing::TestParamInfo<LitQuadrant::ParamType>& info) {
    static const char* const faces[kFaceCount] = {"PX", "NX", "PY", "NY", "PZ", "NZ"};
    Quadrant q = quadrantOf(std::get<1>(info.param));
    return std::string(pathName(std::get<0>(info.param))) + "_" + faces[q.face] +
           (q.signA < 0 ? "_left" : "_right") + (q.signB < 0 ? "_top" : "_bottom");
}

INSTANTIATE_TEST_SUITE_P(Orientation, LitQuadrant,
                         ::testing::Combine(::testing::Values(InputPath::Cube, InputPath::HorizontalCross,
                                                              InputPath::VerticalCross,
                                                              InputPath::EquirectDirect,
                                                              InputPath::EquirectLoaded),
                                            ::testing::Range(0, 24)),
                         quadrantTestName);

// Diagnosis: when a quadrant test fails, this tells whether the library's geometry itself departs
// from the docs/conventions.md table (then every path fails alike) or a loader places a face wrongly (then
// only its path fails). The library computes in double: 1e-12 is rounding.
TEST(Orientation, LibraryGeometryFollowsTheConventionsTable) {
    for (int face = 0; face < kFaceCount; ++face)
        for (double a : {-0.9, -0.3, 0.4, 0.8})
            for (double b : {-0.7, -0.2, 0.1, 0.95}) {
                glm::dvec3 d = tableDirection(face, a, b);
                EXPECT_LT(glm::length(faceDirection(face, a, b) - d), 1e-12)
                    << "faceDirection, face " << kFaceNames[face] << " a " << a << " b " << b;
                FacePoint p = directionToFace(d);
                EXPECT_EQ(p.face, face) << "directionToFace " << text(d);
                EXPECT_NEAR(p.a, a, 1e-12) << "directionToFace " << text(d);
                EXPECT_NEAR(p.b, b, 1e-12) << "directionToFace " << text(d);
                TablePoint own = tableFacePoint(d);
                EXPECT_EQ(own.face, face);
                EXPECT_NEAR(own.a, a, 1e-12);
                EXPECT_NEAR(own.b, b, 1e-12);
            }
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 16; ++i)
            EXPECT_LT(glm::length(equirectDirection(i, j, 16, 8) - tableEquirectDirection(i, j, 16, 8)),
                      1e-12)
                << "equirectDirection (" << i << ", " << j << ")";
    // The formula as written above says what docs/conventions.md says in words: the image's center looks
    // along -Z, its right quarter along +X, its top row is +Y.
    EXPECT_LT(glm::length(tableEquirectAt(0.5, 0.5) - glm::dvec3(0, 0, -1)), 1e-15);
    EXPECT_LT(glm::length(tableEquirectAt(0.75, 0.5) - glm::dvec3(1, 0, 0)), 1e-15);
    EXPECT_LT(glm::length(tableEquirectAt(0.3, 0.0) - glm::dvec3(0, 1, 0)), 1e-15);
}

// ---- Equirect: direct projection against conversion to a cube map ----------------------------------

struct Lobe {
    glm::dvec3 axis;
    double sharpness;
    glm::dvec3 colour;
};
// Three lobes exp(k (d.c - 1)) of different widths (k = 5: about 35 degrees; k = 25: about 16
// degrees) and colours, on a dim ambient term, so that every coefficient up to l = 4 is non-zero
// and the three channels differ.
const Lobe kLobes[] = {
    {glm::normalize(glm::dvec3(0.3, 0.8, -0.5)), 5.0, {1.0, 0.6, 0.2}},
    {glm::normalize(glm::dvec3(-0.7, -0.2, 0.4)), 12.0, {0.1, 0.5, 1.2}},
    {glm::normalize(glm::dvec3(0.5, -0.6, -0.6)), 25.0, {2.0, 0.3, 0.8}},
};
const glm::dvec3 kAmbient(0.05, 0.04, 0.03);

glm::dvec3 lobeRadiance(const glm::dvec3& d) {
    glm::dvec3 sum = kAmbient;
    for (const Lobe& lobe : kLobes)
        sum += lobe.colour * std::exp(lobe.sharpness * (glm::dot(d, lobe.axis) - 1.0));
    return sum;
}

Image lobeEquirect(int width, int height) {
    Image image = makeImage(width, height);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i)
            image.at(i, j) =
                glm::vec4(glm::vec3(lobeRadiance(tableEquirectDirection(i, j, width, height))), 1.0f);
    return image;
}

// Largest |difference| over the first order^2 coefficients and the three channels, each relative to
// the |L00| of its channel.
double maxRelativeDifference(const ShCoefficients& x, const ShCoefficients& y, int order) {
    double worst = 0.0;
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < order * order; ++i)
            worst =
                std::max(worst, std::abs(x.rgb[size_t(i)][c] - y.rgb[size_t(i)][c]) / std::abs(x.rgb[0][c]));
    return worst;
}

// Both paths are second-order accurate quadratures of the same integral; the conversion keeps each
// pixel's power in the texels it covers (128-texel faces from 512 pixels: about a pixel a texel),
// and the cube's projection then evaluates the basis at texel centres, a midpoint rule over cells
// h = 2 pi / 512 = 0.0123 rad wide, which for band l errs like (h^2 / 24) l (l + 1) = 6.3e-6 l (l + 1)
// of a coefficient, twice over (the pixels' and the texels' cells): at most 7.6e-5 (l = 2) and
// 2.5e-4 (l = 4), and no coefficient here exceeds |L00|. Measured: 4.3e-5 (order 3) and 7.2e-5
// (order 5) of |L00|.
// The tolerances sit above the estimate and far below what a half-pixel mistake causes: rendering the map
// half a pixel off in u or in v moves the coefficients by 6e-3 to 8e-3 of |L00| (measured), a flipped axis by
// order 1.
constexpr double kSyntheticToleranceOrder3 = 2e-4;
constexpr double kSyntheticToleranceOrder5 = 5e-4;

TEST(EquirectProjection, DirectAgreesWithConvertedCubemap) {
    Image equirect = lobeEquirect(512, 256);
    Cubemap cubemap = equirectToCubemap(equirect, 128);
    for (auto [order, tolerance] :
         {std::pair{3, kSyntheticToleranceOrder3}, std::pair{5, kSyntheticToleranceOrder5}}) {
        ShCoefficients direct = projectEquirect(equirect, order);
        ShCoefficients converted = projectCubemap(cubemap, order);
        double difference = maxRelativeDifference(direct, converted, order);
        std::printf("lobes 512x256, order %d: direct vs cube 128, max |difference| / |L00| = %.3g\n", order,
                    difference);
        RecordProperty("order" + std::to_string(order) + "_relative_difference", std::to_string(difference));
        EXPECT_LT(difference, tolerance) << "order " << order;
    }
}

// A real HDR environment (Blender's studio light "sunset", 1024 x 512, installed on some machines):
// the same comparison, at the loader's default face size (width / 4 = 256). The sun is a feature of
// about 2 x 2 pixels (peak 6520) holding 7% of the red channel's power: the cube keeps that power
// and moves it by less than a texel (0.0078 rad at most), and over the several texels the sun
// covers the first-order part of that move cancels. Measured: 1.4e-5 (order 3) and 3.2e-5 (order
// 5) of |L00|; sampling the map at texel centres instead, as a resampling that misses part of the
// sun does, gave 3.6e-3 and 4.3e-3. The bound is that of the smooth maps above, 5e-4: a half-pixel
// shift (6e-3 to 8e-3) or a flipped axis fails it.
constexpr double kSunsetTolerance = 5e-4;

TEST(EquirectProjection, DirectAgreesWithConvertedCubemapOnARealHdr) {
    const std::string path = "/usr/share/blender/datafiles/studiolights/world/sunset.exr";
    if (!fs::exists(path)) GTEST_SKIP() << path << " is not installed on this machine";
    Image equirect = readImage(path);
    ASSERT_EQ(equirect.width, 2 * equirect.height);
    Cubemap cubemap = equirectToCubemap(equirect, equirect.width / 4);
    for (int order : {3, 5}) {
        ShCoefficients direct = projectEquirect(equirect, order);
        ShCoefficients converted = projectCubemap(cubemap, order);
        double difference = maxRelativeDifference(direct, converted, order);
        std::printf("sunset.exr %dx%d, order %d: direct vs cube %d, max |difference| / |L00| = %.3g\n",
                    equirect.width, equirect.height, order, equirect.width / 4, difference);
        RecordProperty("order" + std::to_string(order) + "_relative_difference", std::to_string(difference));
        EXPECT_LT(difference, kSunsetTolerance) << "order " << order;
    }
}

} // namespace
} // namespace shprobe
