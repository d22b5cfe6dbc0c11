// The render shaders on the device (lavapipe in CI) against the double references, pixel by pixel
// at the normals the shader used (read back from the float direction target): orders 3 and 5,
// every mode, on the sphere and on full-sphere panoramas; Sloan's delta-light facts ("Stupid SH
// Tricks"); the non-linear L1 model's positivity and energy (Geomerics' L1 notes); a probe file's sun, added
// analytically (E_probe(n) + E_sun(n) per pixel); the display bytes and EXR output.
#include "render_test.h"

#include "common/error.h"
#include "glsl/render_interface.h"
#include "image/environment.h"
#include "render/image_output.h"
#include "render/probe_shading.h"
#include "render/scene.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/lights.h"
#include "sh/projection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>
#include <optional>
#include <unistd.h>

namespace shprobe::testing {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr glm::vec3 kAlbedo{0.8f, 0.6f, 0.4f};

// ---- Probes -----------------------------------------------------------------------------------

// Delta lights of power w_k along d_k: L_lm = sum_k w_k y_lm(d_k), a non-negative radiance.
ShCoefficients deltaLights(const std::vector<std::pair<glm::dvec3, glm::dvec3>>& lights) {
    ShCoefficients radiance = makeCoefficients(5, Quantity::Radiance);
    std::vector<double> y(25);
    for (const auto& [direction, power] : lights) {
        evalBasis(5, glm::normalize(direction), y);
        for (size_t i = 0; i < y.size(); ++i)
            radiance.rgb[i] += power * y[i];
    }
    return radiance;
}

ShCoefficients coloredLights() {
    return deltaLights({{{0.3, 0.8, -0.5}, {9.0, 8.0, 6.0}},
                        {{-0.7, 0.1, 0.2}, {1.0, 2.0, 4.0}},
                        {{0.1, -0.9, 0.3}, {0.5, 0.4, 0.3}},
                        {{0.2, 0.1, 1.0}, {2.0, 2.0, 2.0}}});
}

// The built-in sky (gradient, ground, a sun 20000 times brighter) projected by the CPU reference.
ShCoefficients skyProbe() {
    return projectCubemap(makeDefaultSky(32), 5);
}

// The built-in sky with its sun taken out (as `bake --extract-sun` does), and the sun.
struct SunnyProbe {
    ShCoefficients radiance;
    SphericalLight sun;
};
SunnyProbe skyWithoutSun() {
    Cubemap sky = makeDefaultSky(64);
    SunExtraction sun = extractSun(sky);
    EXPECT_TRUE(sun.found);
    return {projectCubemap(sky, 5), sunAsSphericalLight(sun)};
}

// A delta light of power pi along d: the exact E(n)/pi is max(n.d, 0), 1 at the light's pole.
ShCoefficients directionalLight(const glm::dvec3& d) {
    return deltaLights({{d, glm::dvec3(kPi)}});
}

// ---- Rendering --------------------------------------------------------------------------------

RenderedImage render(const Scene& scene, uint32_t width, uint32_t height) {
    return renderOffscreen(RenderTest::context(), RenderTest::renderer(), scene, {width, height}, 1.0f);
}

Scene sphereView(int order, ShadingMode mode, float yawDegrees = 0.0f) {
    Scene scene = sphereScene(orbitCamera(yawDegrees, 0.0f, 3.2f), order, mode, Background::Color);
    scene.objects[0].albedo = kAlbedo;
    return scene;
}

// Every direction at once: the background shows what a white surface of normal d shows.
Scene panorama(int order, ShadingMode mode, Background background = Background::Shading) {
    Scene scene;
    scene.camera.projection = Projection::Panorama;
    scene.order = order;
    scene.shading = mode;
    scene.background = background;
    return scene;
}

// ---- Comparison -------------------------------------------------------------------------------

struct Comparison {
    double worst = 0.0;       // largest |gpu - reference| / scale over pixels and channels
    int pixels = 0;           // pixels compared
    int sunPixels = 0;        // of which the sun adds to (disc, or irradiance > 0)
    int terminatorPixels = 0; // of which the horizon cuts the sun (|n.d| < sin r)
};

// The size errors are measured against, per channel at normal n: for the SH modes, the sum of
// the magnitudes of the terms the shader adds, sum_i |c_i| |p_i|(n), where |p_i| adds the
// magnitudes of the polynomial's monomials (35z^4 + 30z^2 + 3 for y_40): fp32 rounding is
// relative to those, not to the possibly cancelling sum. For the L1 model, its maximum 4 R0.
glm::dvec3 errorScale(const ProbeShading& folded, ShadingMode mode, int order, const glm::dvec3& n) {
    if (mode == ShadingMode::L1NonLinear) return 4.0 * glm::dvec3(glm::vec3(folded.l1[0]));
    const glm::dvec3 a = glm::abs(n);
    const double x2 = a.x * a.x, y2 = a.y * a.y, z2 = a.z * a.z;
    const double magnitude[25] = {1,
                                  a.y,
                                  a.z,
                                  a.x,
                                  a.x * a.y,
                                  a.y * a.z,
                                  z2,
                                  a.x * a.z,
                                  x2 + y2,
                                  a.y * (3 * x2 + y2),
                                  a.x * a.y * a.z,
                                  a.y * (5 * z2 + 1),
                                  a.z * (5 * z2 + 3),
                                  a.x * (5 * z2 + 1),
                                  a.z * (x2 + y2),
                                  a.x * (x2 + 3 * y2),
                                  a.x * a.y * (x2 + y2),
                                  a.y * a.z * (3 * x2 + y2),
                                  a.x * a.y * (7 * z2 + 1),
                                  a.y * a.z * (7 * z2 + 3),
                                  35 * z2 * z2 + 30 * z2 + 3,
                                  a.x * a.z * (7 * z2 + 3),
                                  (x2 + y2) * (7 * z2 + 1),
                                  a.x * a.z * (x2 + 3 * y2),
                                  x2 * (x2 + 3 * y2) + y2 * (3 * x2 + y2)};
    const auto& c = mode == ShadingMode::Radiance ? folded.radiance : folded.irradiance;
    glm::dvec3 scale(0.0);
    for (int i = 0; i < coefficientCount(order); ++i)
        scale += glm::abs(glm::dvec3(glm::vec3(c[size_t(i)]))) * magnitude[i];
    return scale;
}

// What the sun adds to the error scale at normal n: in the irradiance modes, its term's magnitude
// L s^2 |e| (E/pi = L s^2 e when all of the sun is up, terms of the size of the result elsewhere,
// sun_light.h) plus L s^2 for the rounding of e = n.d itself (|n||d| = 1, and dE/de <= pi L s^2); in
// radiance mode L where the disc is drawn.
glm::dvec3 sunErrorScale(const SphericalLight& sun, ShadingMode mode, const glm::dvec3& n) {
    if (mode == ShadingMode::Radiance) return sunShadeReference(sun, mode, n);
    double s = std::sin(sun.angularRadius);
    return sun.radiance * s * s * (1.0 + std::abs(glm::dot(n, sun.direction)));
}

// Whether n is so close to the edge of the sun's disc that fp32 may put it on either side:
// |n - d|^2 within 1e-7 of 4 sin^2(r/2) (the fp32 squared chord is good to ~1e-9 for small suns).
bool onDiscEdge(const SphericalLight& sun, const glm::dvec3& n) {
    double half = std::sin(0.5 * sun.angularRadius);
    glm::dvec3 chord = n - sun.direction;
    return std::abs(glm::dot(chord, chord) - 4.0 * half * half) < 1e-7;
}

// Compares every pixel whose direction target says `kind` with albedo * reference(n), the
// probe's reference plus, with a sun, sunShadeReference (the disc's edge pixels are skipped).
struct Comparison;
Comparison compare(const RenderedImage& image, const ShCoefficients& radiance, ShadingMode mode, int order,
                   float kind, const glm::dvec3& albedo,
                   const std::optional<SphericalLight>& sun = std::nullopt);

Comparison compare(const RenderedImage& image, const ShCoefficients& radiance, ShadingMode mode, int order,
                   float kind, const glm::dvec3& albedo, const std::optional<SphericalLight>& sun) {
    ProbeShading folded = foldProbe(radiance, 5, "probe");
    Comparison comparison;
    for (size_t p = 0; p < image.linear.texels.size(); ++p) {
        const glm::vec4& direction = image.directions.texels[p];
        if (direction.w != kind) continue;
        glm::dvec3 n = glm::normalize(glm::dvec3(glm::vec3(direction)));
        glm::dvec3 reference = shadeReference(radiance, mode, order, n);
        glm::dvec3 scale = errorScale(folded, mode, order, n);
        if (sun) {
            if (mode == ShadingMode::Radiance && onDiscEdge(*sun, n)) continue;
            glm::dvec3 added = sunShadeReference(*sun, mode, n);
            reference += added;
            scale += sunErrorScale(*sun, mode, n);
            if (added != glm::dvec3(0.0)) ++comparison.sunPixels;
            if (std::abs(glm::dot(n, sun->direction)) < std::sin(sun->angularRadius))
                ++comparison.terminatorPixels;
        }
        if (mode != ShadingMode::Radiance && kind == SHPROBE_DIRECTION_SHADING) reference *= albedo;
        glm::dvec3 gpu(glm::vec3(image.linear.texels[p]));
        for (int c = 0; c < 3; ++c)
            if (scale[c] > 0.0)
                comparison.worst = std::max(comparison.worst, std::abs(gpu[c] - reference[c]) / scale[c]);
        ++comparison.pixels;
    }
    return comparison;
}

// fp32 evaluation of at most 25 terms, each a polynomial of degree <= 4 in the fp32 normal, times
// an fp32 folded coefficient: each term carries <= ~10 roundings of u = 2^-24 = 6e-8 relative to
// its magnitude, the sum <= 25 more relative to the sum of magnitudes, and normalize() leaves
// |n| = 1 +- 2u, which moves a degree-4 term by 8u: worst case ~45u = 2.7e-6 of the scale above.
// Typical errors are 10-30 times smaller (measured: printed by the test).
constexpr double kShTolerance = 3e-6;
// The L1 model adds length(), a division and pow(q, p), which Vulkan lets drivers compute with
// large errors (pow as exp2(p log2 q): 3 + 2p ulp at best); relative to 4 R0 it stays within a few
// ulps of fp32 on lavapipe; 2e-5 (~300 ulps) leaves room for other drivers' pow.
constexpr double kL1Tolerance = 2e-5;

double tolerance(ShadingMode mode) {
    return mode == ShadingMode::L1NonLinear ? kL1Tolerance : kShTolerance;
}

class RenderAccuracy : public RenderTest {
  protected:
    void expectMatches(const ShCoefficients& radiance, const char* probeName,
                       const std::optional<SphericalLight>& sun = std::nullopt) {
        setProbe(renderer().scene, foldProbe(radiance, 5, probeName, sun));
        for (int order : {3, 5}) {
            for (ShadingMode mode :
                 {ShadingMode::Radiance, ShadingMode::Irradiance, ShadingMode::L1NonLinear}) {
                Comparison sphere = compare(render(sphereView(order, mode), 64, 64), radiance, mode, order,
                                            SHPROBE_DIRECTION_SHADING, glm::dvec3(kAlbedo), sun);
                Comparison everywhere = compare(render(panorama(order, mode), 64, 32), radiance, mode, order,
                                                SHPROBE_DIRECTION_SHADING, glm::dvec3(1.0), sun);
                std::printf("  %s order %d %-12s sphere %4d px worst %.2e, panorama %4d px worst %.2e (of "
                            "the scale)\n",
                            probeName, order, shadingModeName(mode), sphere.pixels, sphere.worst,
                            everywhere.pixels, everywhere.worst);
                EXPECT_GT(sphere.pixels, 64 * 64 / 2) << "the sphere covers about 60% of the image";
                if (!sun || mode != ShadingMode::Radiance) {
                    EXPECT_EQ(everywhere.pixels, 64 * 32);
                }
                EXPECT_LT(sphere.worst, tolerance(mode))
                    << probeName << " order " << order << " " << shadingModeName(mode);
                EXPECT_LT(everywhere.worst, tolerance(mode))
                    << probeName << " order " << order << " " << shadingModeName(mode);
            }
            Comparison background = compare(
                render(panorama(order, ShadingMode::Irradiance, Background::Radiance), 64, 32), radiance,
                ShadingMode::Radiance, order, SHPROBE_DIRECTION_RADIANCE, glm::dvec3(1.0), sun);
            if (!sun) {
                EXPECT_EQ(background.pixels, 64 * 32);
            }
            EXPECT_LT(background.worst, kShTolerance) << "radiance background, order " << order;
        }
    }

    // The sun on its own terms: panoramas fine enough that many pixels fall where the horizon cuts
    // the sun (|n.d| < sin r) and inside its disc, and the sphere seen from the sun's side.
    void expectSunMatches(const ShCoefficients& radiance, const SphericalLight& sun, const char* probeName,
                          uint32_t width) {
        setProbe(renderer().scene, foldProbe(radiance, 5, probeName, sun));
        glm::dvec3 d = glm::normalize(sun.direction);
        float yaw = float(glm::degrees(std::atan2(d.x, d.z))), pitch = float(glm::degrees(std::asin(d.y)));
        for (ShadingMode mode : {ShadingMode::Irradiance, ShadingMode::L1NonLinear, ShadingMode::Radiance}) {
            Scene sphere = sphereScene(orbitCamera(yaw + 60.0f, std::clamp(pitch, -80.0f, 80.0f), 3.2f), 5,
                                       mode, Background::Color);
            sphere.objects[0].albedo = kAlbedo;
            Comparison lit = compare(render(sphere, 128, 128), radiance, mode, 5, SHPROBE_DIRECTION_SHADING,
                                     glm::dvec3(kAlbedo), sun);
            Comparison everywhere = compare(render(panorama(5, mode), width, width / 2), radiance, mode, 5,
                                            SHPROBE_DIRECTION_SHADING, glm::dvec3(1.0), sun);
            std::printf("  %s + sun (r = %.3f deg) %-12s sphere %5d px (%4d lit by the sun, %3d at its "
                        "terminator) worst %.2e; panorama %5d px (%4d, %4d) worst %.2e\n",
                        probeName, glm::degrees(sun.angularRadius), shadingModeName(mode), lit.pixels,
                        lit.sunPixels, lit.terminatorPixels, lit.worst, everywhere.pixels,
                        everywhere.sunPixels, everywhere.terminatorPixels, everywhere.worst);
            EXPECT_GT(everywhere.sunPixels, 0) << probeName << " " << shadingModeName(mode);
            if (mode != ShadingMode::Radiance) {
                EXPECT_GT(lit.terminatorPixels, 0) << probeName;
                EXPECT_GT(everywhere.terminatorPixels, int(width)) << probeName;
            }
            EXPECT_LT(lit.worst, tolerance(mode)) << probeName << " " << shadingModeName(mode);
            EXPECT_LT(everywhere.worst, tolerance(mode)) << probeName << " " << shadingModeName(mode);
        }
    }
};

TEST_F(RenderAccuracy, ColoredLightsEveryOrderAndMode) {
    expectMatches(coloredLights(), "lights");
}

TEST_F(RenderAccuracy, BuiltInSkyEveryOrderAndMode) {
    expectMatches(skyProbe(), "sky");
}

// E_probe(n) + E_sun(n): the built-in sky without its sun plus the sun it had (r = 1.146 degrees),
// and the coloured lights with suns from 0.5 to 90 degrees.
TEST_F(RenderAccuracy, ProbeWithSunEveryOrderAndMode) {
    SunnyProbe sky = skyWithoutSun();
    expectMatches(sky.radiance, "sky - sun", sky.sun);
    expectSunMatches(sky.radiance, sky.sun, "sky - sun", 1024);
    const glm::dvec3 d = glm::normalize(glm::dvec3(0.5, 0.6, -0.62));
    for (double radiusDegrees : {0.5, 3.0, 25.0, 90.0}) {
        SphericalLight sun{d, radiusDegrees * kPi / 180.0, glm::dvec3(2000.0, 1800.0, 1500.0)};
        sun.radiance /= 1e3 * std::pow(std::sin(sun.angularRadius), 2); // peak E/pi about 2, 1.8, 1.5
        expectSunMatches(coloredLights(), sun, "lights", radiusDegrees < 1.0 ? 1024 : 256);
    }
}

// Without a sun nothing is added (RenderSun.direction.w = 0), and with one the pixels it cannot
// reach (the whole sun below their horizon) keep the sunless values bit for bit.
TEST_F(RenderTest, SunAddsNothingWhereItIsBelowTheHorizon) {
    SunnyProbe sky = skyWithoutSun();
    const double s = std::sin(sky.sun.angularRadius);
    for (ShadingMode mode : {ShadingMode::Irradiance, ShadingMode::L1NonLinear}) {
        setProbe(renderer().scene, foldProbe(sky.radiance, 5, "sky - sun"));
        RenderedImage plain = render(panorama(5, mode), 128, 64);
        setProbe(renderer().scene, foldProbe(sky.radiance, 5, "sky - sun", sky.sun));
        RenderedImage sunny = render(panorama(5, mode), 128, 64);
        int dark = 0, differing = 0;
        for (size_t p = 0; p < plain.linear.texels.size(); ++p) {
            glm::dvec3 n = glm::normalize(glm::dvec3(glm::vec3(plain.directions.texels[p])));
            if (glm::dot(n, sky.sun.direction) > -s - 1e-6) continue;
            ++dark;
            if (plain.linear.texels[p] != sunny.linear.texels[p]) ++differing;
        }
        EXPECT_GT(dark, 128 * 64 / 3);
        EXPECT_EQ(differing, 0) << shadingModeName(mode);
    }
}

// ---- Sloan's facts ("Stupid SH Tricks") -------------------------------------------------------

// The pixel of the rendered sphere whose normal points most nearly along d: its value and normal.
struct Sample {
    glm::dvec3 value;
    glm::dvec3 normal;
};
Sample closestTo(const RenderedImage& image, const glm::dvec3& d) {
    Sample best{glm::dvec3(0.0), glm::dvec3(0.0)};
    double bestDot = -2.0;
    for (size_t p = 0; p < image.linear.texels.size(); ++p) {
        const glm::vec4& direction = image.directions.texels[p];
        if (direction.w != SHPROBE_DIRECTION_SHADING) continue;
        glm::dvec3 n = glm::normalize(glm::dvec3(glm::vec3(direction)));
        if (glm::dot(n, d) > bestDot) {
            bestDot = glm::dot(n, d);
            best = {glm::dvec3(glm::vec3(image.linear.texels[p])) / glm::dvec3(kAlbedo), n};
        }
    }
    return best;
}

TEST_F(RenderTest, DirectionalLightOrderThreeAndFiveAsSloanSays) {
    // Light along +Z, towards the camera at yaw 0; the camera at yaw 180 sees the opposite side.
    const glm::dvec3 d(0.0, 0.0, 1.0);
    setProbe(renderer().scene, foldProbe(directionalLight(d), 5, "light"));
    double pole[6] = {}, antipode[6] = {};
    for (int order : {3, 5}) {
        Sample front = closestTo(render(sphereView(order, ShadingMode::Irradiance, 0.0f), 65, 65), d);
        Sample back = closestTo(render(sphereView(order, ShadingMode::Irradiance, 180.0f), 65, 65), -d);
        ASSERT_GT(glm::dot(front.normal, d), 0.9999) << "the centre pixel faces the light";
        ASSERT_GT(glm::dot(back.normal, -d), 0.9999);
        pole[order] = front.value.r;
        antipode[order] = back.value.r;
        std::printf("  order %d: E/pi = %.6f at the pole (n.d = %.6f), %.6f opposite; exact 1 and 0\n", order,
                    pole[order], glm::dot(front.normal, d), antipode[order]);
    }
    // The centre pixel's normal is within 1e-4 of the pole, where the slope of E/pi is < 1.5: 2e-4.
    constexpr double kPoleTolerance = 2e-4;
    EXPECT_NEAR(pole[3] - 1.0, 1.0 / 16.0, kPoleTolerance) << "order 3 overshoots the exact 1 by 1/16";
    EXPECT_NEAR(antipode[3], 1.0 / 16.0, kPoleTolerance) << "order 3: spurious 1/16 lobe opposite the light";
    EXPECT_NEAR(pole[5], 31.0 / 32.0, kPoleTolerance);
    EXPECT_NEAR(antipode[5], -1.0 / 32.0, kPoleTolerance) << "order 5: a negative lobe";
    EXPECT_NEAR(pole[5] / antipode[5], -31.0, 31.0 * 1e-2) << "a -1 lobe against a peak of 31";
    EXPECT_NEAR(pole[3] / antipode[3], 17.0, 17.0 * 1e-2) << "17 at the light, 1 opposite";
}

// ---- The non-linear L1 model (Geomerics) ------------------------------------------------------

// Mean over the sphere of a panorama's pixels, each weighted by its exact solid angle.
glm::dvec3 sphereMean(const RenderedImage& image) {
    glm::dvec3 sum(0.0);
    const int width = image.linear.width, height = image.linear.height;
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i)
            sum += glm::dvec3(glm::vec3(image.linear.at(i, j))) * equirectRowSolidAngle(j, width, height);
    return sum / (4.0 * kPi);
}

glm::dvec3 smallest(const RenderedImage& image) {
    glm::dvec3 lowest(1e30);
    for (const glm::vec4& texel : image.linear.texels)
        lowest = glm::min(lowest, glm::dvec3(glm::vec3(texel)));
    return lowest;
}

TEST_F(RenderTest, NonLinearL1IsNonNegativeAndKeepsTheL0Energy) {
    for (const ShCoefficients& radiance :
         {directionalLight(glm::dvec3(0.3, 0.9, -0.2)), coloredLights(), skyProbe()}) {
        setProbe(renderer().scene, foldProbe(radiance, 5, "probe"));
        RenderedImage nonLinear = render(panorama(3, ShadingMode::L1NonLinear), 256, 128);
        RenormalizedL1 l1 = renormalizedL1(radiance);
        glm::dvec3 mean = sphereMean(nonLinear), low = smallest(nonLinear);
        std::printf("  R0 = (%.5f %.5f %.5f): mean of the model (%.5f %.5f %.5f), min (%.2e %.2e %.2e)\n",
                    l1.r0.r, l1.r0.g, l1.r0.b, mean.r, mean.g, mean.b, low.r, low.g, low.b);
        for (int c = 0; c < 3; ++c) {
            EXPECT_GE(low[c], 0.0) << "channel " << c;
            // Midpoint quadrature of a smooth function on 256 x 128 pixels: relative error ~1e-4
            // for the sharpest model (q^3 of a delta light); 1e-3 leaves a margin.
            EXPECT_NEAR(mean[c], l1.r0[c], 1e-3 * l1.r0[c]) << "channel " << c;
        }
    }
}

// ---- Outputs ------------------------------------------------------------------------------------

double acesFilmic(double x) {
    return std::clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
double srgbEncode(double c) {
    return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}

TEST_F(RenderTest, DisplayBytesAreTheTonemappedLinearColour) {
    setProbe(renderer().scene, foldProbe(skyProbe(), 5, "sky"));
    const float exposure = 0.7f;
    RenderedImage image =
        renderOffscreen(context(), renderer(), sphereView(5, ShadingMode::Irradiance), {48, 48}, exposure);
    int worst = 0;
    for (size_t p = 0; p < image.linear.texels.size(); ++p)
        for (int c = 0; c < 3; ++c) {
            double mapped = acesFilmic(std::max(double(image.linear.texels[p][c]) * exposure, 0.0));
            int expected = int(std::lround(255.0 * srgbEncode(mapped)));
            worst = std::max(worst, std::abs(int(image.display[p * 4 + size_t(c)]) - expected));
        }
    std::printf("  display bytes vs CPU tonemap of the linear colour: worst %d / 255\n", worst);
    EXPECT_LE(worst, 1) << "the sRGB store may round either way";
}

TEST_F(RenderTest, ExrHoldsTheLinearColour) {
    setProbe(renderer().scene, foldProbe(coloredLights(), 5, "lights"));
    RenderedImage image = render(sphereView(3, ShadingMode::Irradiance), 32, 24);
    std::filesystem::path folder =
        std::filesystem::temp_directory_path() / ("shprobe_render_" + std::to_string(getpid()));
    std::filesystem::create_directories(folder);
    std::string path = (folder / "sphere.exr").string();
    writeRenderedImage(path, image);
    Image read = readImage(path);
    std::filesystem::remove_all(folder);
    ASSERT_EQ(read.width, 32);
    ASSERT_EQ(read.height, 24);
    for (size_t p = 0; p < read.texels.size(); ++p)
        EXPECT_EQ(glm::vec3(read.texels[p]), glm::vec3(image.linear.texels[p])) << "pixel " << p;
}

TEST_F(RenderTest, ScenesNeedWhatTheyShow) {
    ShCoefficients irradiance = makeCoefficients(5, Quantity::Irradiance);
    irradiance.rgb[0] = glm::dvec3(1.0);
    setProbe(renderer().scene, foldProbe(irradiance, 5, "e.json"));
    EXPECT_THROW(render(sphereView(5, ShadingMode::Radiance), 8, 8), Error)
        << "irradiance probes lack band 3";
    EXPECT_NO_THROW(render(sphereView(5, ShadingMode::Irradiance), 8, 8));
    Scene environment = sphereView(3, ShadingMode::Irradiance);
    environment.background = Background::Environment;
    if (!renderer().scene.hasEnvironment) {
        EXPECT_THROW(render(environment, 8, 8), Error);
    }
}

} // namespace
} // namespace shprobe::testing
