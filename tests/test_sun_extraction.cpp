// Sun extraction on real HDRs: what `bake --extract-sun` does, in process, on each equirect of
// Blender's studio lights (Debian's blender-data; each test is skipped where it is not installed).
// The environment is loaded as bake loads it (face size width / 4), its sun extracted, the sun
// written into a probe file beside the residual's coefficients and read back as `render`, `view`
// and `rotate` read it. Checked: the sun is found exactly in the maps that have a visible one (see
// kWorlds), it is physically valid (radiance finite and >= 0 per channel, radius in (0, 90]
// degrees, above the horizon, where the image's own brightest pixel is), every reader accepts it,
// and the residual map holds no value below what the original held or below 0 where it was not.
#include "formats/probe_file.h"
#include "image/environment.h"
#include "sh/lights.h"
#include "sh/projection.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <unistd.h>

namespace shprobe {
namespace {
namespace fs = std::filesystem;

constexpr double kDegree = std::numbers::pi / 180.0;
const fs::path kWorldFolder = "/usr/share/blender/datafiles/studiolights/world";

// Which maps have a sun, by looking at them: city, sunrise and sunset show the sun's disc. The
// others have none (courtyard and forest: bright sky through an arcade or leaves) or show lamps
// (interior's ceiling spots, night's lights on the horizon, studio's round lamps), which the
// dominance criterion must leave in the probe: each shares the light with others like it.
struct World {
    const char* name;
    bool hasSun;
};
const World kWorlds[] = {{"city", true},   {"courtyard", false}, {"forest", false}, {"interior", false},
                         {"night", false}, {"studio", false},    {"sunrise", true}, {"sunset", true}};

// The probe file holds 9 significant digits; the sun's numbers are written in full, so this is a
// bound, not the error.
constexpr double kFileDigits = 5e-9;
// The sun's direction against the equirect's brightest pixel: the pixel is 0.35 degree wide and
// the direction is the centroid of the cube map's resampled disc. Measured 0.11 to 0.24 degree.
constexpr double kDirectionError = 0.5 * kDegree;

// A folder of its own for each test, removed with its contents afterwards.
class BlenderWorld : public ::testing::TestWithParam<World> {
  protected:
    BlenderWorld() {
        const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
        folder_ = fs::temp_directory_path() / ("shprobe_test_sun_extraction_" + std::to_string(getpid()) +
                                               "_" + GetParam().name + "_" + test->name());
        fs::remove_all(folder_);
        fs::create_directories(folder_);
    }
    ~BlenderWorld() override {
        std::error_code ignored;
        fs::remove_all(folder_, ignored);
    }
    std::string file(const std::string& name) const { return (folder_ / name).string(); }

  private:
    fs::path folder_;
};

double luminance(const glm::vec4& t) {
    return 0.2126 * t.r + 0.7152 * t.g + 0.0722 * t.b; // Rec. 709, as the extraction
}

// Direction of the equirect image's brightest pixel, read without the cube map.
glm::dvec3 brightestPixelDirection(const std::string& path) {
    const Image image = readImage(path);
    size_t best = 0;
    for (size_t k = 1; k < image.texels.size(); ++k)
        if (luminance(image.texels[k]) > luminance(image.texels[best])) best = k;
    return equirectDirection(int(best % size_t(image.width)), int(best / size_t(image.width)), image.width,
                             image.height);
}

double angleBetween(const glm::dvec3& a, const glm::dvec3& b) {
    return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0));
}

void printMeasurements(const char* name, const SunExtraction& sun) {
    const glm::dvec3 radiance = sun.solidAngle > 0.0 ? sun.power / sun.solidAngle : glm::dvec3(0.0);
    std::printf("  %-9s %-12s extent %6.2f deg, radius %5.2f deg, dominance %.3f, power fraction %.4f, "
                "peak ratio %8.0f, direction (%.3f, %.3f, %.3f), radiance (%.4g, %.4g, %.4g)\n",
                name, sun.found ? "sun" : "no sun found", sun.extent / kDegree, sun.angularRadius / kDegree,
                sun.dominance, sun.powerFraction, sun.peakRatio, sun.direction.x, sun.direction.y,
                sun.direction.z, radiance.r, radiance.g, radiance.b);
}

// Removing the sun only lowers texels, and never below 0 where they were not negative: the residual
// keeps min(L, fill) per channel with fill >= 0.
void expectNothingNewBelow(const Cubemap& before, const Cubemap& after) {
    ASSERT_EQ(before.texels.size(), after.texels.size());
    size_t raised = 0, madeNegative = 0;
    for (size_t k = 0; k < before.texels.size(); ++k) {
        for (int channel = 0; channel < 3; ++channel) {
            const float was = before.texels[k][channel], is = after.texels[k][channel];
            raised += is > was;
            madeNegative += is < std::min(was, 0.0f);
        }
    }
    EXPECT_EQ(raised, 0u) << "texel channels raised by the extraction";
    EXPECT_EQ(madeNegative, 0u) << "texel channels pushed below min(original, 0)";
}

// The sun as takeOutSun (bake) writes it: radiance = power / solid angle, over a cap of that radius.
ProbeSun probeSun(const SunExtraction& sun) {
    const SphericalLight light = sunAsSphericalLight(sun);
    return ProbeSun{light.direction, light.radiance, light.angularRadius};
}

void expectPhysicallyValid(const ProbeSun& sun) {
    for (int channel = 0; channel < 3; ++channel) {
        EXPECT_TRUE(std::isfinite(sun.radiance[channel])) << "channel " << channel;
        EXPECT_GE(sun.radiance[channel], 0.0) << "channel " << channel;
    }
    EXPECT_GT(sun.angularRadius, 0.0);
    EXPECT_LE(sun.angularRadius, 90.0 * kDegree);
    EXPECT_GT(sun.direction.y, 0.0) << "a sun is above the horizon (+Y is up)";
}

void expectSameSun(const ProbeSun& read, const ProbeSun& written) {
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(read.direction[c], written.direction[c], kFileDigits) << "direction " << c;
        EXPECT_NEAR(read.radiance[c], written.radiance[c], kFileDigits * written.radiance[c])
            << "radiance " << c;
    }
    EXPECT_NEAR(read.angularRadius, written.angularRadius, kFileDigits * written.angularRadius);
}

TEST_P(BlenderWorld, ExtractedSunIsValidAndEveryReaderAcceptsIt) {
    const World world = GetParam();
    const fs::path path = kWorldFolder / (std::string(world.name) + ".exr");
    if (!fs::exists(path)) GTEST_SKIP() << path << " is missing (Debian package blender-data)";
    Environment environment = loadEnvironment(path.string(), LoadOptions{});
    const Cubemap original = environment.cubemap;
    const SunExtraction sun = extractSun(environment.cubemap);
    printMeasurements(world.name, sun);
    EXPECT_EQ(sun.found, world.hasSun) << world.name;
    expectNothingNewBelow(original, environment.cubemap);
    if (!sun.found) {
        EXPECT_EQ(environment.cubemap.texels, original.texels) << "no sun: the map is left untouched";
        return;
    }
    const ProbeSun written = probeSun(sun);
    expectPhysicallyValid(written);
    EXPECT_LT(angleBetween(written.direction, brightestPixelDirection(path.string())), kDirectionError);

    ProbeMetadata metadata;
    metadata.source = path.string();
    metadata.sun = written;
    writeProbeFile(file("probe.json"), projectCubemap(environment.cubemap, 3), metadata);
    Probe probe;
    ASSERT_NO_THROW(probe = readProbe(file("probe.json")));
    ASSERT_TRUE(probe.sun.has_value());
    expectSameSun(*probe.sun, written);
}

INSTANTIATE_TEST_SUITE_P(StudioLights, BlenderWorld, ::testing::ValuesIn(kWorlds),
                         [](const ::testing::TestParamInfo<World>& world) {
                             return std::string(world.param.name);
                         });

} // namespace
} // namespace shprobe
