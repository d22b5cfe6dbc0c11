// The fast float projection of cube maps and equirect maps against the double reference and closed
// forms, its half-float input, its independence of the thread count, and its refusals.
#include "common/error.h"
#include "common/parallel.h"
#include "sh/basis.h"
#include "sh/fast_projection.h"
#include "sh/projection.h"

#include <glm/common.hpp>
#include <glm/gtc/packing.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

namespace shprobe {
namespace {

constexpr double kFloatEpsilon = 0x1p-24; // unit roundoff of float

// Rounding of one table entry Omega y_k in float, in units of kFloatEpsilon relative to max |y_k|:
// the recurrence through l = 7 loses up to about 50 (measured near the face centers, where the
// three-term recurrence of P_l(z) at z near 1 cancels), the normalization, the solid angle and the
// product a few more.
constexpr double kTableRounding = 64.0;

// Bound of the fast path's error relative to |L_00|, for positive radiance whose largest value is at
// most kMaxToMean times its mean. Its error per texel is at most (s + t) u |L Omega y_k|, u the float
// unit roundoff: s <= N/4 + 3 for the float sums (the parity sums, the multiply-add, and the
// recursive sum of N/4 terms per lane along a row of positions), t = kTableRounding. Summed over the
// sphere, |L y_k| Omega adds up to at most max L sqrt(4 pi) (Cauchy-Schwarz with the unit norm of
// y_k), and |L_00| = mean L sqrt(4 pi), so the error relative to |L_00| is at most
// kMaxToMean (N/4 + 3 + t) u. Measured errors are 10 to 100 times smaller (the roundings do not all
// add up); the bound still catches any error of the method (a wrong sign, texel or rotation) by
// orders of magnitude.
constexpr double kMaxToMean = 2.0; // noise uniform in [0, 1]
double floatRoundingBound(int faceSize) {
    return kMaxToMean * (faceSize / 4.0 + 3.0 + kTableRounding) * kFloatEpsilon;
}
// The accuracy target at 6 x 2048^2. The bound above allows 7e-5 there, but the rounding errors of
// different rows are independent and mostly cancel (measured: 4e-8 to 6e-8); this checks they do.
constexpr double kLargeFaceError = 1e-6;

// Noise in [0, 1) in RGB; alpha, which the projection ignores, is NaN so that any leak shows.
void fillNoise(std::vector<glm::vec4>& texels, unsigned seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (glm::vec4& texel : texels)
        texel = glm::vec4(uniform(random), uniform(random), uniform(random), nan);
}

Cubemap noiseCubemap(int faceSize, unsigned seed) {
    Cubemap cube = makeCubemap(faceSize);
    fillNoise(cube.texels, seed);
    return cube;
}

// max over coefficients and channels of |result - expected|, divided by the largest |L_00| channel.
double errorRelativeToL00(const ShCoefficients& result, const ShCoefficients& expected) {
    double worst = 0.0;
    for (size_t i = 0; i < expected.rgb.size(); ++i) {
        const glm::dvec3 deviation = glm::abs(result.rgb[i] - expected.rgb[i]);
        worst = std::max({worst, deviation.x, deviation.y, deviation.z});
    }
    const glm::dvec3 dc = glm::abs(expected.rgb[0]);
    return worst / std::max({dc.x, dc.y, dc.z});
}

void expectIdentical(const ShCoefficients& a, const ShCoefficients& b, const char* what) {
    ASSERT_EQ(a.rgb.size(), b.rgb.size()) << what;
    for (size_t i = 0; i < a.rgb.size(); ++i) {
        for (int c = 0; c < 3; ++c)
            EXPECT_EQ(a.rgb[i][c], b.rgb[i][c]) << what << ", coefficient " << i << ", channel " << c;
    }
}

// Checks: noise projects as the reference does, for every (order, face size) pair: odd and even
// sizes, one texel per face, rows with and without an unpaired middle position.
TEST(FastProjection, MatchesReference) {
    for (int faceSize : {1, 7, 64, 257}) {
        const Cubemap cube = noiseCubemap(faceSize, unsigned(faceSize));
        for (int order : {1, 3, 5, 8}) {
            const double error =
                errorRelativeToL00(projectCubemapFast(cube, order), projectCubemap(cube, order));
            std::printf("N = %3d, order %d: error / |L_00| = %.2e\n", faceSize, order, error);
            EXPECT_LT(error, floatRoundingBound(faceSize)) << "N = " << faceSize << ", order " << order;
        }
    }
}

// Expected projection of an environment lit in one texel only, of direction d and solid angle Omega:
// c Omega y_k(d).
ShCoefficients singleTexelProjection(const glm::dvec3& direction, double solidAngle, const glm::vec4& c) {
    ShCoefficients expected = makeCoefficients(kMaxOrder, Quantity::Radiance);
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    evalBasis(kMaxOrder, direction, basis);
    for (size_t k = 0; k < basis.size(); ++k)
        expected.rgb[k] = glm::dvec3(c) * (basis[k] * solidAngle);
    return expected;
}

// The same for texel (i, j) of a face.
ShCoefficients singleTexelProjection(int face, int i, int j, int faceSize, const glm::vec4& c) {
    return singleTexelProjection(texelDirection(face, i, j, faceSize), texelSolidAngle(i, j, faceSize), c);
}

// A single texel is projected with the rounding of one table entry only, kTableRounding ulps of
// max |y_k|, which is sqrt(2l + 1) = sqrt(15) times |y_00| through l = 7 (addition theorem:
// sum_m y_lm^2 = (2l + 1) / (4 pi)). Measured: 4.7e-6, against 1.5e-5.
constexpr double kSingleTexelError = kTableRounding * kFloatEpsilon * 3.873;

// Checks: each texel alone, on every face of small odd and even faces (middle rows and columns, rows
// of one and three positions), projects to c Omega y_k(d): every texel has its own direction and
// solid angle, whatever its place among its mirror images.
TEST(FastProjection, EveryTexelAlone) {
    const glm::vec4 c(1.0f, 2.0f, 0.5f, 0.0f);
    double worst = 0.0;
    for (int faceSize : {1, 2, 5, 6}) {
        Cubemap cube = makeCubemap(faceSize);
        for (int face = 0; face < kFaceCount; ++face) {
            for (int j = 0; j < faceSize; ++j) {
                for (int i = 0; i < faceSize; ++i) {
                    cube.at(face, i, j) = c;
                    const double error = errorRelativeToL00(projectCubemapFast(cube, kMaxOrder),
                                                            singleTexelProjection(face, i, j, faceSize, c));
                    cube.at(face, i, j) = glm::vec4(0.0f);
                    worst = std::max(worst, error);
                    EXPECT_LT(error, kSingleTexelError)
                        << "N = " << faceSize << ", face " << face << ", texel (" << i << ", " << j << ")";
                }
            }
        }
    }
    std::printf("single texels: worst error / |L_00| = %.2e\n", worst);
}

// Checks: one hot texel on a large odd face, against the reference projection of the whole cube map.
TEST(FastProjection, HotTexelOnLargeFace) {
    constexpr int faceSize = 257, face = int(Face::NegativeZ), i = 200, j = 17;
    Cubemap cube = makeCubemap(faceSize);
    cube.at(face, i, j) = glm::vec4(1000.0f, 1.0f, 3.0f, 0.0f);
    const double error =
        errorRelativeToL00(projectCubemapFast(cube, kMaxOrder), projectCubemap(cube, kMaxOrder));
    std::printf("hot texel on N = 257: error / |L_00| = %.2e\n", error);
    EXPECT_LT(error, kSingleTexelError);
}

// The float value of an IEEE half, from the format's definition: (-1)^s 2^(e-15) (1 + m/1024) for a
// biased exponent e in 1..30, (-1)^s 2^-14 (m/1024) for e = 0.
float halfValue(uint16_t bits) {
    const int exponent = (bits >> 10) & 0x1f;
    const int mantissa = bits & 0x3ff;
    const double magnitude =
        exponent == 0 ? std::ldexp(mantissa, -24) : std::ldexp(1024 + mantissa, exponent - 25);
    return float(bits & 0x8000 ? -magnitude : magnitude);
}

bool finiteHalf(uint16_t bits) {
    return ((bits >> 10) & 0x1f) != 0x1f;
}

// The same texels as half bits and as their float values.
struct HalfCubemap {
    std::vector<uint16_t> halves; // RGBA per texel
    Cubemap floats;
};

HalfCubemap halfCubemap(int faceSize, const std::vector<uint16_t>& rgbValues) {
    HalfCubemap cube{std::vector<uint16_t>(size_t(kFaceCount) * faceSize * faceSize * 4, 0),
                     makeCubemap(faceSize)};
    for (size_t v = 0; v < rgbValues.size(); ++v) {
        cube.halves[v / 3 * 4 + v % 3] = rgbValues[v];
        cube.floats.texels[v / 3][int(v % 3)] = halfValue(rgbValues[v]);
    }
    return cube;
}

// Checks: RGBA16F input gives exactly the result of the RGBA32F input of the same values, on random
// finite halves of every magnitude and sign (normal and subnormal), at two orders.
TEST(FastProjection, HalfInputEqualsFloatInput) {
    constexpr int faceSize = 64;
    std::mt19937 random(16);
    std::uniform_int_distribution<int> bits(0, 0xffff);
    std::vector<uint16_t> values;
    while (values.size() < size_t(kFaceCount) * faceSize * faceSize * 3) {
        const uint16_t value = uint16_t(bits(random));
        if (finiteHalf(value)) values.push_back(value);
    }
    const HalfCubemap cube = halfCubemap(faceSize, values);
    for (int order : {3, 8}) {
        expectIdentical(projectFacesFast(cube.halves.data(), TexelFormat::Rgba16F, faceSize, order),
                        projectCubemapFast(cube.floats, order), "random halves");
    }
}

// Checks: every finite half converts exactly. Projections of one-texel faces, 18 values each (three
// channels of six faces), are compared as above; the values of one projection are consecutive
// half bit patterns of one sign, within a factor 2 of each other or zero, so that no float product
// of one of them can be lost in the double sum of the others.
TEST(FastProjection, EveryFiniteHalfConvertsExactly) {
    constexpr size_t kValuesPerProjection = kFaceCount * 3;
    for (uint16_t sign : {uint16_t(0), uint16_t(0x8000)}) {
        for (uint32_t first = 0; first < 0x7c00; first += kValuesPerProjection) {
            std::vector<uint16_t> values;
            for (uint32_t m = first; m < std::min<uint32_t>(first + kValuesPerProjection, 0x7c00); ++m)
                values.push_back(uint16_t(sign | m));
            const HalfCubemap cube = halfCubemap(1, values);
            expectIdentical(projectFacesFast(cube.halves.data(), TexelFormat::Rgba16F, 1, 1),
                            projectCubemapFast(cube.floats, 1), "consecutive halves");
            if (HasFailure()) {
                ADD_FAILURE() << "first half bits 0x" << std::hex << (sign | first);
                return;
            }
        }
    }
}

// Checks: packHalves rounds every float to the nearest half, by F16C and without. For each pair of
// neighbouring finite halves a < b (a >= 0): a itself and the float just below their midpoint give a,
// just above gives b, the midpoint (exact in float: 12 significant bits) either. The second lane
// holds the negatives, the third a itself; alpha is written 0. Beyond the range: infinities.
TEST(FastProjection, PackHalvesRoundsToTheNearestHalf) {
    std::vector<glm::vec4> texels;
    std::vector<std::array<uint16_t, 2>> expected; // the halves allowed for lane 0 (lane 1: sign set)
    for (uint16_t bits = 0; bits < 0x7bff; ++bits) {
        const float a = glm::unpackHalf1x16(bits), b = glm::unpackHalf1x16(uint16_t(bits + 1));
        const float middle = (a + b) / 2;
        const uint16_t next = uint16_t(bits + 1);
        for (auto [value, low, high] :
             {std::tuple{a, bits, bits}, std::tuple{std::nextafter(middle, 0.0f), bits, bits},
              std::tuple{middle, bits, next}, std::tuple{std::nextafter(middle, b), next, next}}) {
            texels.push_back({value, -value, a, 1e9f});
            expected.push_back({low, high});
        }
    }
    texels.push_back({1e5f, -1e5f, 65504.0f, 1.0f});
    expected.push_back({0x7c00, 0x7c00});
    for (KernelLevel level : {KernelLevel::X86_64_V4, KernelLevel::Baseline}) {
        std::vector<uint64_t> halves(texels.size());
        packHalves(texels, halves.data(), level);
        for (size_t t = 0; t < texels.size(); ++t) {
            const uint16_t lane0 = uint16_t(halves[t]), lane1 = uint16_t(halves[t] >> 16);
            const bool nearest = lane0 == expected[t][0] || lane0 == expected[t][1];
            const bool lanesKept = lane1 == (lane0 | 0x8000u) &&
                                   glm::unpackHalf1x16(uint16_t(halves[t] >> 32)) == texels[t].z &&
                                   (halves[t] >> 48) == 0;
            ASSERT_TRUE(nearest && lanesKept)
                << (level == KernelLevel::Baseline ? "baseline" : "widest") << ", value " << texels[t].x
                << ": halves 0x" << std::hex << halves[t] << ", expected 0x" << expected[t][0] << " or 0x"
                << expected[t][1];
        }
    }
}

// Checks: the result is bit-identical for 1, 2 and 3 threads and for all cores.
TEST(FastProjection, IdenticalForEveryThreadCount) {
    const Cubemap cube = noiseCubemap(257, 3);
    const ShCoefficients single = projectCubemapFast(cube, 5, {.threads = 1});
    for (unsigned threads : {2u, 3u, 0u})
        expectIdentical(projectCubemapFast(cube, 5, {.threads = threads}), single, "threads");
}

// Checks: the accuracy target, 6 x 2048^2 at order 3 within 1e-6 of |L_00| of the reference.
TEST(FastProjection, LargeCubemapWithinTarget) {
    const Cubemap cube = noiseCubemap(2048, 2048);
    const double error = errorRelativeToL00(projectCubemapFast(cube, 3), projectCubemap(cube, 3));
    std::printf("N = 2048, order 3: error / |L_00| = %.2e\n", error);
    EXPECT_LT(error, kLargeFaceError);
}

// The kind of the Error that project() throws, -1 if it throws none.
template <class Project> int errorKind(Project&& project) {
    try {
        project();
    } catch (const Error& e) {
        return int(e.kind());
    }
    return -1;
}

// Checks: faces where they lie (FaceRows), here each in a wider image of its own, in reverse face
// order and with rows padded to an odd stride, give the cube map's result to the last bit; a stride
// below the face size and a missing face are refused.
TEST(FastProjection, FacesWhereTheyLieEqualTheCubemap) {
    const int n = 33;
    const Cubemap cube = noiseCubemap(n, 7);
    const size_t stride = 2 * n + 3;
    std::vector<glm::vec4> wide(kFaceCount * n * stride, glm::vec4(1e30f)); // padding: never read
    FaceRows faces;
    for (int face = 0; face < kFaceCount; ++face) {
        glm::vec4* first = wide.data() + size_t(kFaceCount - 1 - face) * n * stride + 2;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                first[size_t(j) * stride + size_t(i)] = cube.at(face, i, j);
        faces.faces[size_t(face)] = first;
        faces.rowStrides[size_t(face)] = stride;
    }
    for (int order : {1, 4, 8})
        expectIdentical(projectFacesFast(faces, TexelFormat::Rgba32F, n, order),
                        projectCubemapFast(cube, order), "faces where they lie");
    faces.rowStrides[3] = n - 1;
    EXPECT_EQ(errorKind([&] { projectFacesFast(faces, TexelFormat::Rgba32F, n, 3); }), int(ErrorKind::Input));
    faces.rowStrides[3] = stride;
    faces.faces[5] = nullptr;
    EXPECT_EQ(errorKind([&] { projectFacesFast(faces, TexelFormat::Rgba32F, n, 3); }), int(ErrorKind::Input));
}

// ------------------------------------------------------------------------------------------------
// Equirect maps (projectEquirectFast): Fourier sums along each row in float, then the rows in double
// (fast_projection.cpp, top of the file).

Image noiseEquirect(int width, int height, unsigned seed) {
    Image image = makeImage(width, height);
    fillNoise(image.texels, seed);
    return image;
}

// Bound of the equirect path's error relative to |L_00|, as floatRoundingBound for faces: per pixel
// at most (W/4 + 3 + 1) u |L Omega y_l|m|(theta, 0)| (the float sums along a row of W/4 terms per
// lane, the parity sums and the multiply-add; one rounding of the table entry cos(m phi) or
// sin(m phi), which multiplies y_l|m|(theta, 0) rather than y_lm(w)). Summed over the sphere,
// |L y_l|m|(theta, 0)| Omega is at most max L sqrt(4 pi) sqrt(2) (Cauchy-Schwarz; the square of
// y_l|m|(theta, 0) integrates to 2 for m != 0, twice that of y_lm), so relative to |L_00| =
// mean L sqrt(4 pi) the error is at most kMaxToMean sqrt(2) (W/4 + 4) u. Measured errors are 100 to
// 1000 times smaller (10 for one-pixel-wide maps); the bound still catches a wrong sign, pixel,
// weight or frame by far.
double equirectRoundingBound(int width) {
    return kMaxToMean * std::sqrt(2.0) * (width / 4.0 + 4.0) * kFloatEpsilon;
}

// Checks: noise projects as the reference does (projectEquirect, the same exact row solid angles)
// at every order, for even and odd widths and heights, 1-pixel-high and 1-pixel-wide maps, a single
// pixel, rows with and without an unpaired middle position, maps taller than wide.
TEST(FastEquirectProjection, MatchesReference) {
    const int sizes[][2] = {{1, 1}, {2, 1}, {3, 1},   {8, 1},   {1, 5},     {7, 3},    {16, 8},
                            {5, 9}, {6, 2}, {33, 17}, {64, 32}, {257, 129}, {512, 256}};
    for (const auto& [width, height] : sizes) {
        const Image image = noiseEquirect(width, height, unsigned(width * 1000 + height));
        for (int order = 1; order <= kMaxOrder; ++order) {
            const double error =
                errorRelativeToL00(projectEquirectFast(image, order), projectEquirect(image, order));
            if (order == 1 || order == 3 || order == kMaxOrder)
                std::printf("%3d x %3d, order %d: error / |L_00| = %.2e\n", width, height, order, error);
            EXPECT_LT(error, equirectRoundingBound(width)) << width << " x " << height << ", order " << order;
        }
    }
}

// Checks (white furnace): a constant map c gives L_00 = c sqrt(4 pi) to double rounding, not just
// float: c = 0.75 and the row sums of its multiples are exact in float (at most W = 512 terms of a
// dyadic value), and the row solid angles, applied in double, sum to 4 pi. The other coefficients
// equal the reference's (midpoint-rule error of the zonal even harmonics about +Y, see
// test_projection) within the float bound.
TEST(FastEquirectProjection, ConstantMapGivesExactL00) {
    const float c = 0.75f;
    for (const auto& [width, height] : {std::pair{512, 256}, std::pair{33, 17}, std::pair{1, 1}}) {
        Image image = makeImage(width, height);
        std::fill(image.texels.begin(), image.texels.end(), glm::vec4(c, c, c, 1.0f));
        const ShCoefficients fast = projectEquirectFast(image, kMaxOrder);
        const double l00 = c * std::sqrt(4.0 * std::numbers::pi);
        for (int channel = 0; channel < 3; ++channel)
            EXPECT_NEAR(fast.rgb[0][channel], l00, 1e-14 * l00) << width << " x " << height;
        EXPECT_LT(errorRelativeToL00(fast, projectEquirect(image, kMaxOrder)), equirectRoundingBound(width))
            << width << " x " << height;
    }
}

// Expected projection of an equirect map lit at pixel (i, j) only: c Omega_j y_k(d).
ShCoefficients singlePixelProjection(int i, int j, int width, int height, const glm::vec4& c) {
    return singleTexelProjection(equirectDirection(i, j, width, height),
                                 equirectRowSolidAngle(j, width, height), c);
}

// A single pixel is projected with two float roundings, of its table entry cos(m phi) or sin(m phi)
// and of the product with its radiance (its parity sums are exact, with zeros), each relative to
// |c Omega y_l|m|(theta, 0)|, which is at most sqrt(2l + 1) = sqrt(15) times |c Omega y_00| through
// l = 7 (addition theorem at phi = 0, where the sines vanish). Twice that allows for the order of the
// roundings; the rest is double. Measured: 6.3e-8.
constexpr double kSinglePixelError = 4.0 * kFloatEpsilon * 3.873;

// Checks: each pixel alone on small maps of odd and even widths and heights (middle columns and
// rows, unpaired positions, one row, one column) projects to c Omega_j y_k(d): every pixel has its
// own direction and its row's solid angle, whatever its place among its mirror images.
TEST(FastEquirectProjection, EveryPixelAlone) {
    const glm::vec4 c(1.0f, 2.0f, 0.5f, 0.0f);
    double worst = 0.0;
    for (const auto& [width, height] : {std::pair{1, 1}, std::pair{2, 1}, std::pair{5, 3}, std::pair{6, 4},
                                        std::pair{1, 3}, std::pair{9, 2}}) {
        Image image = makeImage(width, height);
        for (int j = 0; j < height; ++j) {
            for (int i = 0; i < width; ++i) {
                image.at(i, j) = c;
                const double error = errorRelativeToL00(projectEquirectFast(image, kMaxOrder),
                                                        singlePixelProjection(i, j, width, height, c));
                image.at(i, j) = glm::vec4(0.0f);
                worst = std::max(worst, error);
                EXPECT_LT(error, kSinglePixelError)
                    << width << " x " << height << ", pixel (" << i << ", " << j << ")";
            }
        }
    }
    std::printf("single pixels: worst error / |L_00| = %.2e\n", worst);
}

// Checks (closed form): one lit row of constant c is a ring about +Y at colatitude theta_j. Its
// frame sums cos(m phi_i) vanish for 0 < m < W, so only the zonal harmonics about +Y remain, and
// by the rotation of zonal harmonics (Sloan, "Stupid Spherical Harmonics (SH) Tricks", zonal
// harmonics) L_lm = c Omega_j W y_l0(theta_j) sqrt(4 pi / (2l + 1)) y_lm(+Y), y_l0(theta) the zonal
// harmonic about the frame's axis. The error is that of the float sums along the row: at most
// (W/4 + 4) u of sum_i |c Omega_j y_l|m|(theta_j, 0)| <= (W/4 + 4) u sqrt(15) |L_00| (see above).
TEST(FastEquirectProjection, SingleRowIsARingAboutY) {
    const glm::vec4 c(0.5f, 1.0f, 3.0f, 0.0f);
    for (const auto& [width, height, row] :
         {std::tuple{8, 5, 0}, std::tuple{16, 8, 5}, std::tuple{33, 17, 8}, std::tuple{64, 1, 0}}) {
        Image image = makeImage(width, height);
        for (int i = 0; i < width; ++i)
            image.at(i, row) = c;
        const double theta = std::numbers::pi * (row + 0.5) / height;
        std::array<double, coefficientCount(kMaxOrder)> zonal{}, atY{};
        evalBasis(kMaxOrder, {std::sin(theta), 0.0, std::cos(theta)}, zonal);
        evalBasis(kMaxOrder, {0.0, 1.0, 0.0}, atY);
        ShCoefficients expected = makeCoefficients(kMaxOrder, Quantity::Radiance);
        for (int l = 0; l < kMaxOrder; ++l) {
            for (int m = -l; m <= l; ++m) {
                const double scale =
                    equirectRowSolidAngle(row, width, height) * width * zonal[size_t(shIndex(l, 0))] *
                    std::sqrt(4.0 * std::numbers::pi / (2 * l + 1)) * atY[size_t(shIndex(l, m))];
                expected.rgb[size_t(shIndex(l, m))] = glm::dvec3(c) * scale;
            }
        }
        const double error = errorRelativeToL00(projectEquirectFast(image, kMaxOrder), expected);
        EXPECT_LT(error, (width / 4.0 + 4.0) * kFloatEpsilon * 3.873)
            << width << " x " << height << ", row " << row;
    }
}

// Checks: RGBA16F input gives exactly the result of the RGBA32F input of the same values (random
// finite halves of every magnitude and sign), at two orders, on an odd and an even size.
TEST(FastEquirectProjection, HalfInputEqualsFloatInput) {
    std::mt19937 random(17);
    std::uniform_int_distribution<int> bits(0, 0xffff);
    for (const auto& [width, height] : {std::pair{64, 32}, std::pair{45, 23}}) {
        std::vector<uint16_t> halves(size_t(width) * height * 4, 0);
        Image floats = makeImage(width, height);
        for (size_t v = 0; v < size_t(width) * height * 3; ++v) {
            uint16_t value = 0x7c00;
            while (!finiteHalf(value))
                value = uint16_t(bits(random));
            halves[v / 3 * 4 + v % 3] = value;
            floats.texels[v / 3][int(v % 3)] = halfValue(value);
        }
        for (int order : {3, 8}) {
            expectIdentical(projectEquirectFast(halves.data(), TexelFormat::Rgba16F, width, height, order),
                            projectEquirectFast(floats, order), "random halves");
        }
    }
}

// Checks: the result is bit-identical for 1, 2 and 3 threads and for all cores (389 rows: 49 blocks
// of 4 rows of positions).
TEST(FastEquirectProjection, IdenticalForEveryThreadCount) {
    const Image image = noiseEquirect(777, 389, 5);
    const ShCoefficients single = projectEquirectFast(image, 5, {.threads = 1});
    for (unsigned threads : {2u, 3u, 0u})
        expectIdentical(projectEquirectFast(image, 5, {.threads = threads}), single, "threads");
}

// Checks: the kernels of every instruction set this processor runs (on x86-64: x86-64-v4, v3 and
// the baseline, as many as it has), not only the widest that a bake takes, project cube maps and
// equirect maps as the reference does, within the same bounds, and halves exactly as their floats
// (the baseline converting them without F16C). An older processor runs the narrower kernels in bakes.
TEST(FastProjection, EveryKernelLevelMatchesTheReference) {
    const Cubemap cube = noiseCubemap(65, 65);
    const Image image = noiseEquirect(130, 65, 130);
    std::vector<uint16_t> halfBits(size_t(kFaceCount) * 65 * 65 * 3);
    std::mt19937 random(18);
    for (uint16_t& bits : halfBits)
        bits = uint16_t(random() % 0x7c00); // finite, positive
    const HalfCubemap halves = halfCubemap(65, halfBits);
    const std::array levels{KernelLevel::X86_64_V4, KernelLevel::X86_64_V3, KernelLevel::Baseline};
    int ran = 0;
    for (KernelLevel level : levels) {
        if (level < widestKernelLevel()) continue; // wider than the processor runs
        ++ran;
        const FastProjectionOptions options{.widest = level};
        SCOPED_TRACE("level " + std::to_string(int(level)));
        for (int order : {3, 8}) {
            EXPECT_LT(
                errorRelativeToL00(projectCubemapFast(cube, order, options), projectCubemap(cube, order)),
                floatRoundingBound(65));
            EXPECT_LT(
                errorRelativeToL00(projectEquirectFast(image, order, options), projectEquirect(image, order)),
                equirectRoundingBound(130));
            expectIdentical(projectFacesFast(halves.halves.data(), TexelFormat::Rgba16F, 65, order, options),
                            projectCubemapFast(halves.floats, order, options), "halves");
        }
    }
    std::printf("kernel levels run: %d of %zu\n", ran, levels.size());
    EXPECT_GE(ran, 1);
}

// Checks: the accuracy target at a common equirect size, 2048 x 1024 at orders 3, 5 and 8,
// within 1e-6 of |L_00| of the reference (one reference projection at order 8: lower orders are its
// first coefficients, the same sums). The bound above allows 7e-5; the rows' rounding errors are
// independent and mostly cancel (measured: 1e-8).
TEST(FastEquirectProjection, LargeMapWithinTarget) {
    const Image image = noiseEquirect(2048, 1024, 2048);
    const ShCoefficients reference = projectEquirect(image, kMaxOrder);
    for (int order : {3, 5, kMaxOrder}) {
        ShCoefficients truncated = makeCoefficients(order, Quantity::Radiance);
        std::copy_n(reference.rgb.begin(), truncated.rgb.size(), truncated.rgb.begin());
        const double error = errorRelativeToL00(projectEquirectFast(image, order), truncated);
        std::printf("2048 x 1024, order %d: error / |L_00| = %.2e\n", order, error);
        EXPECT_LT(error, kLargeFaceError) << "order " << order;
    }
}

// Checks: the same target where the roundings do not cancel. Along a row of even radiance every
// product of a Fourier sum's cos(0 phi) = 1 is the same, so each rounding of the growing float sum
// goes the same way; over the W/4 terms of a row they added up to 9.7e-6 of |L_00| at 4096 wide and
// 3.9e-5 at 16384 with one float sum a row, 6e-7 at 16384 with chunks of 16 pairs and stages of 64
// added plainly (fast_projection.cpp, accumulateCoefficients and accumulateRow). Rows of a constant
// (the worst case: all of them err alike) at widths up to 16384, few rows high since the error is
// per row. Measured: 1.4e-7 at 1000 wide, 1.5e-7 at 4096 and 16384; the bound, below the 1e-6
// target, is what tells the compensated sum from the plain one.
TEST(FastEquirectProjection, EvenRowsWithinTarget) {
    constexpr double kEvenRowError = 2.5e-7;
    for (int width : {1000, 4096, 16384}) {
        Image image = makeImage(width, 6);
        std::fill(image.texels.begin(), image.texels.end(), glm::vec4(0.1f, 0.1f, 0.1f, 1.0f));
        for (int order : {3, kMaxOrder}) {
            const double error =
                errorRelativeToL00(projectEquirectFast(image, order), projectEquirect(image, order));
            std::printf("%d x 6 of 0.1, order %d: error / |L_00| = %.2e\n", width, order, error);
            EXPECT_LT(error, kEvenRowError) << width << " wide, order " << order;
        }
    }
}

// Checks: a width or height below 1, an order outside 1..8, no texels and an image whose texel
// count disagrees with its size are input errors.
TEST(FastEquirectProjection, InvalidInputThrows) {
    const Image image = makeImage(4, 2);
    const int input = int(ErrorKind::Input);
    EXPECT_EQ(errorKind([&] { projectEquirectFast(image.texels.data(), TexelFormat::Rgba32F, 0, 2, 3); }),
              input);
    EXPECT_EQ(errorKind([&] { projectEquirectFast(image.texels.data(), TexelFormat::Rgba16F, 4, -1, 3); }),
              input);
    EXPECT_EQ(errorKind([&] { projectEquirectFast(image.texels.data(), TexelFormat::Rgba32F, 4, 2, 0); }),
              input);
    EXPECT_EQ(errorKind([&] {
                  projectEquirectFast(image.texels.data(), TexelFormat::Rgba32F, 4, 2, kMaxOrder + 1);
              }),
              input);
    EXPECT_EQ(errorKind([&] { projectEquirectFast(nullptr, TexelFormat::Rgba32F, 4, 2, 3); }), input);
    EXPECT_EQ(errorKind([&] { projectEquirectFast(Image{}, 3); }), input);
    Image truncated = image;
    truncated.texels.pop_back();
    EXPECT_EQ(errorKind([&] { projectEquirectFast(truncated, 3); }), input);
}

// Checks: a face size below 1, an order outside 1..8, no texels and a cube map whose texel count
// disagrees with its size are input errors.
TEST(FastProjection, InvalidInputThrows) {
    const Cubemap cube = makeCubemap(2);
    const int input = int(ErrorKind::Input);
    EXPECT_EQ(errorKind([&] { projectFacesFast(cube.texels.data(), TexelFormat::Rgba32F, 0, 3); }), input);
    EXPECT_EQ(errorKind([&] { projectFacesFast(cube.texels.data(), TexelFormat::Rgba16F, -2, 3); }), input);
    EXPECT_EQ(errorKind([&] { projectFacesFast(cube.texels.data(), TexelFormat::Rgba32F, 2, 0); }), input);
    EXPECT_EQ(
        errorKind([&] { projectFacesFast(cube.texels.data(), TexelFormat::Rgba32F, 2, kMaxOrder + 1); }),
        input);
    EXPECT_EQ(errorKind([&] { projectFacesFast(nullptr, TexelFormat::Rgba32F, 2, 3); }), input);
    EXPECT_EQ(errorKind([&] { projectCubemapFast(Cubemap{}, 3); }), input);
    Cubemap truncated = cube;
    truncated.texels.pop_back();
    EXPECT_EQ(errorKind([&] { projectCubemapFast(truncated, 3); }), input);
}

// The fast path's rows go over all cores by forEachItem: every item once, and an exception a task
// throws on any thread (out of memory in a worker) reaches the caller after all threads stop,
// where it used to end the process (std::terminate).
TEST(ForEachItem, EveryItemOnceAndExceptionsReachTheCaller) {
    std::vector<std::atomic<int>> visits(1000);
    forEachItem(1000, 4, [&](int item) { ++visits[size_t(item)]; });
    EXPECT_TRUE(std::all_of(visits.begin(), visits.end(), [](const std::atomic<int>& v) { return v == 1; }));
    for (int failing : {0, 1, 500, 999}) {
        std::atomic<int> done{0};
        EXPECT_THROW(forEachItem(1000, 4,
                                 [&](int item) {
                                     if (item == failing) throw std::bad_alloc();
                                     std::this_thread::sleep_for(std::chrono::microseconds(200));
                                     ++done;
                                 }),
                     std::bad_alloc)
            << failing;
        // The items not yet taken are left: a failure at the first item ends the run within the items
        // the other threads hold, where the 999 others would all sleep their turn.
        if (failing == 0) {
            EXPECT_LT(done.load(), 500);
        }
    }
}

} // namespace
} // namespace shprobe
