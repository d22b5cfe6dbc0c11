// The built-in default environment: a procedural sky (gradient, ground, sun disc), +Y up.
#include "image/environment.h"
#include "image/texel_mean.h"

#include "common/parallel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>

namespace shprobe {
namespace {

// Near the sun a texel is the mean of a grid of samples spaced at most an eighth of the sun's
// radius apart, so the disc's coverage of the texel, and with it the sun's power (which dominates
// the low-order SH), stays right when the disc is smaller than a texel. A point sample at the
// texel center would drop the sun or inflate it to a whole texel. Capped for tiny suns.
constexpr double kSunSamplesPerRadius = 8.0;
constexpr int kMaxSunSamplesPerSide = 1024;

// Samples per side for texels near the sun. A texel spans at most 2 / faceSize radians (at the
// face center, where one unit of face coordinate is one radian).
int sunSamplesPerSide(int faceSize, const SkyParameters& sky) {
    if (sky.sunAngularRadius <= 0.0) return 1;
    double samples = std::ceil(2.0 / faceSize * kSunSamplesPerRadius / sky.sunAngularRadius);
    return int(std::min(samples, double(kMaxSunSamplesPerSide)));
}

// The sun as every texel of a sky meets it: its unit direction, the cosine of its radius, and
// the cosine of the angle within which a texel may touch it: the sun's radius plus the texel's
// half-diagonal (at most sqrt(2) / faceSize radians). Worked out once, they were a third of the
// time of making the default sky.
struct Sun {
    glm::dvec3 direction;
    double cosRadius;
    double cosReach;
};
Sun sunOf(const SkyParameters& sky, int faceSize) {
    double reach = std::min(sky.sunAngularRadius + std::sqrt(2.0) / faceSize, M_PI);
    return {glm::normalize(sky.sunDirection), std::cos(sky.sunAngularRadius), std::cos(reach)};
}

// The radiance toward a unit direction whose cosine to the sun is cosToSun and whose y is up.
glm::dvec3 radianceAt(const SkyParameters& sky, const Sun& sun, double cosToSun, double up) {
    if (cosToSun >= sun.cosRadius) return sky.sunRadiance;
    if (up < 0.0) return sky.ground;
    // The square root keeps the horizon's colour in a thin band and the zenith's over most of the sky.
    return glm::mix(sky.horizon, sky.zenith, std::sqrt(up));
}

// The radiance toward a unit direction d.
glm::dvec3 radianceToward(const SkyParameters& sky, const Sun& sun, const glm::dvec3& d) {
    return radianceAt(sky, sun, glm::dot(d, sun.direction), d.y);
}

// Texels worth a thread: a few hundred microseconds of work.
constexpr size_t kTexelsPerThread = 4096;

// Row j of a face of the sky. Along a row the face table is start + a * along, with no rounding
// (each component is 0, +-1, +-a or +-b): texelDirection's directions (bit for bit where the
// compiler fuses no multiply-adds, as for x86-64's baseline; the signs of zeros aside), without its
// lookup per texel. The directions of a block of texels come first, in a loop of their own that
// vectorizes (their square roots and divisions were most of the time of making the default sky),
// then their radiance.
void makeSkyRow(Cubemap& cubemap, const SkyParameters& sky, const Sun& sun, int sunSamples, int face, int j) {
    const int faceSize = cubemap.faceSize;
    const double b = texelCenterCoord(j, faceSize);
    const glm::dvec3 start = unnormalizedFaceDirection(face, 0.0, b);
    const glm::dvec3 along = unnormalizedFaceDirection(face, 1.0, b) - start;
    constexpr int kBlock = 64;
    std::array<double, kBlock> cosToSun;
    std::array<double, kBlock> up;
    for (int first = 0; first < faceSize; first += kBlock) {
        const int count = std::min(kBlock, faceSize - first);
        for (int k = 0; k < count; ++k) {
            const glm::dvec3 center = glm::normalize(start + texelCenterCoord(first + k, faceSize) * along);
            cosToSun[size_t(k)] = glm::dot(center, sun.direction);
            up[size_t(k)] = center.y;
        }
        for (int k = 0; k < count; ++k) {
            const int i = first + k;
            const bool mayTouchSun = sunSamples > 1 && cosToSun[size_t(k)] > sun.cosReach;
            const glm::dvec3 radiance =
                mayTouchSun ? texelMean(face, i, j, faceSize, sunSamples,
                                        [&](const glm::dvec3& d) { return radianceToward(sky, sun, d); })
                            : radianceAt(sky, sun, cosToSun[size_t(k)], up[size_t(k)]);
            cubemap.at(face, i, j) = glm::vec4(glm::vec3(radiance), 1.0f);
        }
    }
}

} // namespace

glm::dvec3 skyRadiance(const SkyParameters& sky, const glm::dvec3& direction) {
    return radianceToward(sky, sunOf(sky, 1), glm::normalize(direction));
}

Cubemap makeDefaultSky(int faceSize, const SkyParameters& sky) {
    Cubemap cubemap = makeCubemap(faceSize); // throws for a face size below 1
    const int sunSamples = sunSamplesPerSide(faceSize, sky);
    const Sun sun = sunOf(sky, faceSize);
    // Item r is row r % faceSize of face r / faceSize.
    forEachItem(kFaceCount * faceSize, threadCount(cubemap.texels.size(), kTexelsPerThread),
                [&](int row) { makeSkyRow(cubemap, sky, sun, sunSamples, row / faceSize, row % faceSize); });
    return cubemap;
}

} // namespace shprobe
