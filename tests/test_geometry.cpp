// Texel geometry: cube-map face table, solid angles (double reference and the fp32 shader form),
// the inverse maps, and equirect directions and solid angles.
#include "common/error.h"
#include "glsl/texel_geometry.h"
#include "sh/cubemap.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace shprobe {
namespace {

constexpr double kPi = std::numbers::pi;

// Sums of up to 6 * 256^2 double solid angles of size about 4/N^2: rounding only.
constexpr double kSolidAngleSumError = 1e-11;
// docs/conventions.md gives the N = 4 check values to 12 decimals.
constexpr double kCheckValueError = 1e-11;
// docs/conventions.md: the fp32 solid angle must match the double formula within 1e-5 relative.
constexpr double kFp32SolidAngleRelativeError = 1e-5;
// fp32 direction: corners rounded to 2^-24, then normalized; a few ulps of float.
constexpr double kFp32DirectionError = 1e-6;
// Double round trips through sqrt, atan2, acos and normalize: a few ulps of values of order 1.
constexpr double kRoundTripError = 1e-12;
// For pixel coordinates the round trip error scales with the image size (up to 2048 here).
constexpr double kPixelRoundTripError = 1e-9;

// Checks: the exact solid angles of all 6 N^2 texels cover the sphere, 4 pi, at odd, even, tiny
// and large sizes.
TEST(Geometry, CubeSolidAnglesSumToFourPi) {
    for (int n : {1, 2, 3, 4, 17, 256}) {
        double sum = 0.0;
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i)
                sum += texelSolidAngle(i, j, n);
        }
        EXPECT_NEAR(kFaceCount * sum, 4.0 * kPi, kSolidAngleSumError) << "N = " << n;
    }
    EXPECT_NEAR(texelSolidAngle(0, 0, 1), 4.0 * kPi / 6.0, kCheckValueError);
}

// Checks: the N = 4 values docs/conventions.md gives for the four-atan2 formula, and the face's mirror
// symmetries (corner texels equal, and so on).
TEST(Geometry, CubeSolidAngleCheckValues) {
    EXPECT_NEAR(texelSolidAngle(0, 0, 4), 0.081455587595, kCheckValueError);
    EXPECT_NEAR(texelSolidAngle(1, 1, 4), 0.201357920790, kCheckValueError);
    for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
            EXPECT_NEAR(texelSolidAngle(i, j, 4), texelSolidAngle(3 - i, j, 4), 1e-15);
            EXPECT_NEAR(texelSolidAngle(i, j, 4), texelSolidAngle(j, i, 4), 1e-15);
        }
    }
}

// Worst relative error of shprobe::glsl::texelSolidAngleFp32 against the double formula over the
// texels (i, j) of one face with i, j multiples of stride (the six faces share their solid angles).
double worstFp32SolidAngleError(int n, int stride) {
    double worst = 0.0;
    for (int j = 0; j < n; j += stride) {
        for (int i = 0; i < n; i += stride) {
            const double reference = texelSolidAngle(i, j, n);
            const double fp32 = glsl::texelSolidAngleFp32(glsl::uint(i), glsl::uint(j), glsl::uint(n));
            worst = std::max(worst, std::abs(fp32 - reference) / reference);
        }
    }
    return worst;
}

// Checks: the fp32 solid angle of texel_geometry.h (what the shaders use) matches the double
// four-atan2 formula within 1e-5 relative for every texel, at every face size from 1 to 64 and at
// 127, 256, 511, 1024, 2048 and 4096 (docs/conventions.md demands every size up to 4096; these cover
// small, odd, power-of-two and the largest). Prints the worst error per size.
TEST(Geometry, Fp32SolidAngleMatchesDoubleAtEverySize) {
    double worstSmall = 0.0;
    for (int n = 1; n <= 64; ++n) {
        const double worst = worstFp32SolidAngleError(n, 1);
        worstSmall = std::max(worstSmall, worst);
        EXPECT_LT(worst, kFp32SolidAngleRelativeError) << "N = " << n;
    }
    std::printf("fp32 solid angle, worst relative error, N = 1..64: %.3g\n", worstSmall);
    for (int n : {127, 256, 511, 1024, 2048, 4096}) {
        const double worst = worstFp32SolidAngleError(n, 1);
        std::printf("fp32 solid angle, worst relative error, N = %d: %.3g\n", n, worst);
        EXPECT_LT(worst, kFp32SolidAngleRelativeError) << "N = " << n;
    }
}

// Checks: the double texelDirection equals the normalized fp32 unnormalizedFaceDirection of
// texel_geometry.h
// for every texel of every face, so CPU reference and shaders sample the same directions.
TEST(Geometry, TexelDirectionMatchesShaderTable) {
    for (int n : {1, 2, 3, 8, 31, 64}) {
        for (int face = 0; face < kFaceCount; ++face) {
            for (int j = 0; j < n; ++j) {
                for (int i = 0; i < n; ++i) {
                    const float a = glsl::texelCenterCoord(glsl::uint(i), glsl::uint(n));
                    const float b = glsl::texelCenterCoord(glsl::uint(j), glsl::uint(n));
                    const glm::dvec3 shader =
                        glm::normalize(glsl::unnormalizedFaceDirection(glsl::uint(face), a, b));
                    const glm::dvec3 reference = texelDirection(face, i, j, n);
                    ASSERT_LT(glm::length(shader - reference), kFp32DirectionError)
                        << "face " << face << ", texel (" << i << ", " << j << "), N = " << n;
                }
            }
        }
    }
}

// Checks: directionToFace returns the face and the face-local texel center of every texel direction.
TEST(Geometry, DirectionToFaceInvertsTexelDirection) {
    for (int n : {1, 2, 7, 64}) {
        for (int face = 0; face < kFaceCount; ++face) {
            for (int j = 0; j < n; ++j) {
                for (int i = 0; i < n; ++i) {
                    const FacePoint point = directionToFace(texelDirection(face, i, j, n));
                    ASSERT_EQ(point.face, face) << "texel (" << i << ", " << j << "), N = " << n;
                    ASSERT_NEAR(point.a, 2.0 * (i + 0.5) / n - 1.0, kRoundTripError);
                    ASSERT_NEAR(point.b, 2.0 * (j + 0.5) / n - 1.0, kRoundTripError);
                }
            }
        }
    }
}

// Checks: directionToFace does not need unit vectors and picks the face of the major axis.
TEST(Geometry, DirectionToFaceAxes) {
    EXPECT_EQ(directionToFace({5.0, 1.0, -2.0}).face, int(Face::PositiveX));
    EXPECT_EQ(directionToFace({-5.0, 1.0, -2.0}).face, int(Face::NegativeX));
    EXPECT_EQ(directionToFace({0.1, 3.0, -2.0}).face, int(Face::PositiveY));
    EXPECT_EQ(directionToFace({0.1, -3.0, -2.0}).face, int(Face::NegativeY));
    EXPECT_EQ(directionToFace({0.1, 0.2, 0.3}).face, int(Face::PositiveZ));
    EXPECT_EQ(directionToFace({0.1, 0.2, -0.3}).face, int(Face::NegativeZ));
    const FacePoint center = directionToFace({0.0, 0.0, -2.0});
    EXPECT_EQ(center.a, 0.0);
    EXPECT_EQ(center.b, 0.0);
}

// "Up" (top row, small b) and "left" (column 0, small a) of each face, read off the table of
// docs/conventions.md: e.g. +X (1, -b, -a) has y > 0 on its top row and z > 0 on its left column.
struct FaceOrientation {
    Face face;
    glm::dvec3 up;
    glm::dvec3 left;
};
const FaceOrientation kFaceOrientations[] = {
    {Face::PositiveX, {0, 1, 0}, {0, 0, 1}},   {Face::NegativeX, {0, 1, 0}, {0, 0, -1}},
    {Face::PositiveY, {0, 0, -1}, {-1, 0, 0}}, {Face::NegativeY, {0, 0, 1}, {-1, 0, 0}},
    {Face::PositiveZ, {0, 1, 0}, {-1, 0, 0}},  {Face::NegativeZ, {0, 1, 0}, {1, 0, 0}},
};

// Checks: the face diagram: every texel of the top row leans "up", every texel of the left column
// leans "left", and the face center is the face's axis.
TEST(Geometry, FaceOrientationFacts) {
    constexpr int n = 8;
    for (const FaceOrientation& o : kFaceOrientations) {
        const int face = int(o.face);
        for (int k = 0; k < n; ++k) {
            EXPECT_GT(glm::dot(texelDirection(face, k, 0, n), o.up), 0.0) << "face " << face << " top row";
            EXPECT_LT(glm::dot(texelDirection(face, k, n - 1, n), o.up), 0.0)
                << "face " << face << " bottom row";
            EXPECT_GT(glm::dot(texelDirection(face, 0, k, n), o.left), 0.0)
                << "face " << face << " left column";
        }
        const glm::dvec3 axis = faceDirection(face, 0.0, 0.0);
        EXPECT_EQ(directionToFace(axis).face, face);
        EXPECT_NEAR(glm::length(glm::cross(axis, o.up)), 1.0, kRoundTripError);
    }
}

void expectSameEdge(Face first, double a0, double b0, Face second, double a1, double b1) {
    EXPECT_LT(glm::length(faceDirection(int(first), a0, b0) - faceDirection(int(second), a1, b1)),
              kRoundTripError)
        << "face " << int(first) << " at (" << a0 << ", " << b0 << "), face " << int(second) << " at (" << a1
        << ", " << b1 << ")";
}

// Checks: faces meet as in the horizontal cross of docs/conventions.md, [ -X +Z +X -Z ] with +Y above
// and -Y below +Z: the right edge (a = 1) of each face is the left edge (a = -1) of the next, and
// the bottom (b = 1) of +Y is the top (b = -1) of +Z, whose bottom is the top of -Y.
TEST(Geometry, FacesMeetAsInTheCross) {
    for (double t = -1.0; t <= 1.0; t += 0.25) {
        expectSameEdge(Face::NegativeX, 1.0, t, Face::PositiveZ, -1.0, t);
        expectSameEdge(Face::PositiveZ, 1.0, t, Face::PositiveX, -1.0, t);
        expectSameEdge(Face::PositiveX, 1.0, t, Face::NegativeZ, -1.0, t);
        expectSameEdge(Face::NegativeZ, 1.0, t, Face::NegativeX, -1.0, t);
        expectSameEdge(Face::PositiveY, t, 1.0, Face::PositiveZ, t, -1.0);
        expectSameEdge(Face::PositiveZ, t, 1.0, Face::NegativeY, t, -1.0);
    }
}

// Checks: a face index outside 0..5 and non-positive sizes are input errors.
TEST(Geometry, InvalidArgumentsThrow) {
    EXPECT_THROW(faceDirection(6, 0.0, 0.0), Error);
    EXPECT_THROW(makeCubemap(0), Error);
    EXPECT_THROW(makeImage(4, -1), Error);
    const Cubemap cube = makeCubemap(3);
    EXPECT_EQ(cube.texels.size(), size_t(kFaceCount * 9));
    const Image image = makeImage(5, 2);
    EXPECT_EQ(image.texels.size(), size_t(10));
}

// Checks: texels no machine can allocate (more than a vector may hold; 6 x (2^31 - 1)^2 would pass
// size_t) are one Error(Memory) saying what and how much, before any allocation, not a bare
// std::bad_alloc ("out of memory" alone) nor an internal error. Sizes that reach the allocator and
// fail there say the same (allocateTexels); not tried here, since AddressSanitizer aborts on them.
TEST(Geometry, TexelsBeyondMemoryAreNamed) {
    auto messageOf = [](const auto& allocate) {
        try {
            allocate();
        } catch (const Error& e) {
            EXPECT_EQ(e.kind(), ErrorKind::Memory);
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_EQ(messageOf([] { makeImage(2147483647, 2147483647); }),
              "out of memory: an image of 2147483647 x 2147483647 texels needs 68719476672.0 GiB");
    EXPECT_EQ(messageOf([] { makeCubemap(2147483647); }),
              "out of memory: a cube map of 6 x 2147483647^2 texels needs 412316860032.0 GiB");
}

// Checks: directionToEquirect maps the direction of every pixel back to the pixel's center
// (i + 0.5, j + 0.5), for odd, even and elongated sizes.
TEST(Geometry, EquirectRoundTrip) {
    for (auto [w, h] : {std::pair{1, 1}, {7, 5}, {64, 32}, {2048, 3}}) {
        for (int j = 0; j < h; ++j) {
            for (int i = 0; i < w; ++i) {
                const PixelPoint p = directionToEquirect(equirectDirection(i, j, w, h), w, h);
                ASSERT_NEAR(p.x, i + 0.5, kPixelRoundTripError)
                    << "pixel (" << i << ", " << j << ") of " << w << "x" << h;
                ASSERT_NEAR(p.y, j + 0.5, kPixelRoundTripError)
                    << "pixel (" << i << ", " << j << ") of " << w << "x" << h;
                ASSERT_NEAR(glm::length(equirectDirection(i, j, w, h)), 1.0, kRoundTripError);
            }
        }
    }
}

// Checks: the orientation of docs/conventions.md: the image center looks along -Z, the right quarter
// along +X, the left quarter along -X, the top edge is +Y and the bottom edge -Y; +Z is on the
// seam, which maps into [0, W).
TEST(Geometry, EquirectOrientation) {
    constexpr int w = 16, h = 8;
    const auto expectPixel = [](glm::dvec3 d, double x, double y) {
        const PixelPoint p = directionToEquirect(d, w, h);
        EXPECT_NEAR(p.x, x, kRoundTripError) << d.x << ", " << d.y << ", " << d.z;
        EXPECT_NEAR(p.y, y, kRoundTripError) << d.x << ", " << d.y << ", " << d.z;
    };
    expectPixel({0, 0, -1}, 0.5 * w, 0.5 * h);
    expectPixel({1, 0, 0}, 0.75 * w, 0.5 * h);
    expectPixel({-1, 0, 0}, 0.25 * w, 0.5 * h);
    expectPixel({0, 0, 1}, 0.0, 0.5 * h);
    EXPECT_NEAR(directionToEquirect({0, 1, 0}, w, h).y, 0.0, kRoundTripError);
    EXPECT_NEAR(directionToEquirect({0, -1, 0}, w, h).y, double(h), kRoundTripError);
    const PixelPoint seam = directionToEquirect({-1e-300, 0, 1}, w, h);
    EXPECT_GE(seam.x, 0.0);
    EXPECT_LT(seam.x, double(w));
    // Forward: pixel (2, 1) of 5 x 3 is the exact center, and every pixel of row 0 is near +Y.
    EXPECT_NEAR(glm::length(equirectDirection(2, 1, 5, 3) - glm::dvec3(0, 0, -1)), 0.0, kRoundTripError);
    for (int i = 0; i < w; ++i)
        EXPECT_NEAR(equirectDirection(i, 0, w, h).y, std::cos(kPi * 0.5 / h), kRoundTripError);
}

// Checks: the exact per-row solid angles cover the sphere, and equal (2 pi / W)(cos theta0 -
// cos theta1) written out directly.
TEST(Geometry, EquirectRowSolidAngles) {
    for (auto [w, h] : {std::pair{1, 1}, {8, 4}, {3, 1000}, {512, 256}}) {
        double sum = 0.0;
        for (int j = 0; j < h; ++j) {
            const double direct = 2.0 * kPi / w * (std::cos(kPi * j / h) - std::cos(kPi * (j + 1) / h));
            EXPECT_NEAR(equirectRowSolidAngle(j, w, h), direct, 1e-15)
                << "row " << j << " of " << w << "x" << h;
            sum += w * equirectRowSolidAngle(j, w, h);
        }
        EXPECT_NEAR(sum, 4.0 * kPi, kSolidAngleSumError) << w << "x" << h;
    }
}

} // namespace
} // namespace shprobe
