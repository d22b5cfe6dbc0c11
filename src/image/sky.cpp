// The built-in default environment: a procedural sky (gradient, ground, sun disc), +Y up.
#include "shprobe/image/environment.h"

#include "shprobe/sh/parallel.h"

#include <algorithm>
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

// Whether any of a texel may lie inside the sun: its center is closer to the sun's center than
// the sun's radius plus the texel's half-diagonal (at most sqrt(2) / faceSize radians), compared
// as cosines: the cosine of the angle to the sun's center, and the cosine of that limit.
struct SunReach {
    glm::dvec3 direction;
    double cosLimit;
};
SunReach sunReach(int faceSize, const SkyParameters& sky) {
    double limit = std::min(sky.sunAngularRadius + std::sqrt(2.0) / faceSize, M_PI);
    return {glm::normalize(sky.sunDirection), std::cos(limit)};
}
bool texelMayTouchSun(int face, int i, int j, int faceSize, const SunReach& sun) {
    return glm::dot(texelDirection(face, i, j, faceSize), sun.direction) > sun.cosLimit;
}

// Texels worth a thread: a few hundred microseconds of work.
constexpr size_t kTexelsPerThread = 4096;

// Mean sky radiance over an n x n grid in texel (i, j), each sample weighted by the solid angle
// per unit face area, 1 / (1 + a^2 + b^2)^(3/2), so that mean x texel solid angle is the integral.
glm::dvec3 texelMean(const SkyParameters& sky, int face, int i, int j, int faceSize, int n) {
    if (n == 1) return skyRadiance(sky, texelDirection(face, i, j, faceSize)); // one sample: no weights
    double step = 2.0 / (double(faceSize) * n);
    glm::dvec3 sum(0.0);
    double weights = 0.0;
    for (int sj = 0; sj < n; ++sj) {
        for (int si = 0; si < n; ++si) {
            double a = -1.0 + (i * n + si + 0.5) * step;
            double b = -1.0 + (j * n + sj + 0.5) * step;
            double weight = std::pow(1.0 + a * a + b * b, -1.5);
            sum += weight * skyRadiance(sky, faceDirection(face, a, b));
            weights += weight;
        }
    }
    return sum / weights;
}

} // namespace

glm::dvec3 skyRadiance(const SkyParameters& sky, const glm::dvec3& direction) {
    glm::dvec3 d = glm::normalize(direction);
    if (glm::dot(d, glm::normalize(sky.sunDirection)) >= std::cos(sky.sunAngularRadius))
        return sky.sunRadiance;
    if (d.y < 0.0) return sky.ground;
    // The square root keeps the horizon's colour in a thin band and the zenith's over most of the sky.
    return glm::mix(sky.horizon, sky.zenith, std::sqrt(d.y));
}

Cubemap makeDefaultSky(int faceSize, const SkyParameters& sky) {
    Cubemap cubemap = makeCubemap(faceSize); // throws for a face size below 1
    const int sunSamples = sunSamplesPerSide(faceSize, sky);
    const SunReach sun = sunReach(faceSize, sky);
    // Item r is row r % faceSize of face r / faceSize.
    forEachItem(kFaceCount * faceSize, threadCount(cubemap.texels.size(), kTexelsPerThread), [&](int row) {
        int face = row / faceSize;
        int j = row % faceSize;
        for (int i = 0; i < faceSize; ++i) {
            int n = texelMayTouchSun(face, i, j, faceSize, sun) ? sunSamples : 1;
            cubemap.at(face, i, j) = glm::vec4(glm::vec3(texelMean(sky, face, i, j, faceSize, n)), 1.0f);
        }
    });
    return cubemap;
}

} // namespace shprobe
