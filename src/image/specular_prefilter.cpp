#include "image/specular_prefilter.h"

#include "common/error.h"
#include "common/parallel.h"
#include "image/environment.h"
#include "image/texel_mean.h"
#include "sh/irradiance.h"
#include "sh/projection.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;
// Output texels worth a thread: each sums a thousand or more source texels.
constexpr size_t kTexelsPerThread = 64;

// ---- The pyramid the sums read ----------------------------------------------------------------

// Level k + 1 of level k: each texel the solid-angle-weighted mean of its 2 x 2 children, which tile
// it exactly, so that every level is the area average of level 0.
Cubemap halve(const Cubemap& level) {
    const int size = level.faceSize / 2;
    Cubemap half = makeCubemap(size);
    std::vector<double> omega(size_t(level.faceSize) * size_t(level.faceSize));
    for (int j = 0; j < level.faceSize; ++j)
        for (int i = 0; i < level.faceSize; ++i)
            omega[size_t(j) * size_t(level.faceSize) + size_t(i)] = texelSolidAngle(i, j, level.faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < size; ++j)
            for (int i = 0; i < size; ++i) {
                glm::dvec3 sum(0.0);
                double weights = 0.0;
                for (int y = 2 * j; y < 2 * j + 2; ++y)
                    for (int x = 2 * i; x < 2 * i + 2; ++x) {
                        const double w = omega[size_t(y) * size_t(level.faceSize) + size_t(x)];
                        sum += w * glm::dvec3(level.at(face, x, y));
                        weights += w;
                    }
                half.at(face, i, j) = glm::vec4(glm::vec3(sum / weights), 1.0f);
            }
    return half;
}

std::vector<Cubemap> pyramidOf(const Cubemap& base) {
    std::vector<Cubemap> levels{base};
    while (levels.back().faceSize > 1)
        levels.push_back(halve(levels.back()));
    return levels;
}

double ggx(double cosH, double alpha) {
    const double a2 = alpha * alpha, t = cosH * cosH * (a2 - 1.0) + 1.0;
    return a2 / (kPi * t * t);
}

// A texel of a pyramid level as the sums read it: its unit centre, its solid angle, and its
// radiance times its solid angle.
struct Texel {
    glm::vec3 direction;
    float omega;
    glm::vec3 weighted;
};

struct Level {
    int size;
    std::vector<Texel> texels; // face after face, rows top to bottom
    double cosNear;            // a texel whose centre is closer than this to R is refined
};

// Each level's texels, and how near to R one must lie to be replaced by its four children: within
// kNearTexels half-diagonals (sqrt(2) / size radians at most), so that a texel summed whole is seen
// from R under at most 1 / kNearTexels of its distance, where the kernel is smooth across it.
constexpr double kNearTexels = 8.0;

std::vector<Level> levelsOf(const std::vector<Cubemap>& pyramid) {
    std::vector<Level> levels;
    for (const Cubemap& cubemap : pyramid) {
        const int n = cubemap.faceSize;
        Level level{n, {}, std::cos(std::min(kNearTexels * std::sqrt(2.0) / n, kPi))};
        level.texels.reserve(cubemap.texels.size());
        for (int face = 0; face < kFaceCount; ++face)
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    const double omega = texelSolidAngle(i, j, n);
                    level.texels.push_back({glm::vec3(texelDirection(face, i, j, n)), float(omega),
                                            glm::vec3(omega * glm::dvec3(cubemap.at(face, i, j)))});
                }
        levels.push_back(std::move(level));
    }
    return levels;
}

// The sums of one output direction R: sum L k Omega and sum k Omega over a partition of the sphere
// into texels of the pyramid, fine near R and coarse far from it.
struct Sums {
    glm::dvec3 r;
    double a2m1; // alpha^2 - 1
    glm::dvec3 weighted{0.0};
    double weights = 0.0;
};

// The kernel up to its constant alpha^2 / pi, which cancels in the ratio: with n = v = R,
// cos^2 theta_h = (1 + c) / 2 for c = R.l (Karis 2013, eq. 3, GGX D; the split-sum prefilter).
double kernel(double c, double a2m1) {
    const double t = 0.5 * (1.0 + c) * a2m1 + 1.0;
    return c / (t * t);
}

// Texel (face, i, j) of level `at` (levels run from the finest, 0, to 1 x 1 faces), summed whole or,
// when it lies near R and a finer level is allowed (`finest`), through its four children.
void accumulate(const std::vector<Level>& levels, int at, int finest, int face, int i, int j, Sums& sums) {
    const Level& level = levels[size_t(at)];
    const Texel& texel =
        level.texels[(size_t(face) * size_t(level.size) + size_t(j)) * size_t(level.size) + size_t(i)];
    const double c = glm::dot(sums.r, glm::dvec3(texel.direction));
    if (at > finest && c > level.cosNear) {
        for (int y = 2 * j; y < 2 * j + 2; ++y)
            for (int x = 2 * i; x < 2 * i + 2; ++x)
                accumulate(levels, at - 1, finest, face, x, y, sums);
        return;
    }
    if (c <= 0.0) return;
    const double k = kernel(c, sums.a2m1);
    sums.weighted += k * glm::dvec3(texel.weighted);
    sums.weights += k * double(texel.omega);
}

// The finest level a mip's sums read: texels of 2 / size <= alpha / kTexelsPerAlpha radians, where
// the lobe's half width in l is about 1.3 alpha: several texels across it, enough for the midpoint
// rule on a kernel this smooth. Never finer than level 0.
constexpr double kTexelsPerAlpha = 4.0;

int finestLevel(const std::vector<Level>& levels, double alpha) {
    int at = int(levels.size()) - 1;
    while (at > 0 && levels[size_t(at)].size * alpha < 2.0 * kTexelsPerAlpha)
        --at;
    return at;
}

// The level whose texels the sums start from: faces of 8 texels (or the coarsest there is).
int startLevel(const std::vector<Level>& levels) {
    int at = int(levels.size()) - 1;
    while (at > 0 && levels[size_t(at)].size < 8)
        --at;
    return at;
}

Cubemap prefilterMip(const std::vector<Level>& levels, int size, double alpha) {
    const int finest = finestLevel(levels, alpha), start = std::max(startLevel(levels), finest);
    const int startSize = levels[size_t(start)].size;
    Cubemap mip = makeCubemap(size);
    forEachItem(kFaceCount * size, threadCount(mip.texels.size(), kTexelsPerThread), [&](int row) {
        const int face = row / size, j = row % size;
        for (int i = 0; i < size; ++i) {
            Sums sums{texelDirection(face, i, j, size), alpha * alpha - 1.0};
            for (int f = 0; f < kFaceCount; ++f)
                for (int y = 0; y < startSize; ++y)
                    for (int x = 0; x < startSize; ++x)
                        accumulate(levels, start, finest, f, x, y, sums);
            mip.at(face, i, j) = glm::vec4(glm::vec3(sums.weighted / sums.weights), 1.0f);
        }
    });
    return mip;
}

} // namespace

bool isSpecularSize(int size) {
    return size >= kMinSpecularSize && size <= kMaxSpecularSize && std::has_single_bit(unsigned(size));
}

int specularMipCount(int size) {
    return std::bit_width(unsigned(size / kSmallestSpecularMip));
}

double specularMipRoughness(int mip, int mipCount) {
    return double(mip) / double(mipCount - 1);
}

double specularKernel(double cosine, double alpha) {
    if (cosine <= 0.0) return 0.0;
    return ggx(std::sqrt(0.5 * (1.0 + cosine)), alpha) * cosine;
}

std::vector<Cubemap> prefilterSpecular(const Cubemap& environment, int size) {
    if (!isSpecularSize(size))
        throw Error(ErrorKind::Input, "a specular cube map's size must be a power of two from " +
                                          std::to_string(kMinSpecularSize) + " to " +
                                          std::to_string(kMaxSpecularSize) + ", not " + std::to_string(size));
    const int count = specularMipCount(size);
    const std::vector<Cubemap> pyramid = pyramidOf(resizeCubemap(environment, size));
    const std::vector<Level> levels = levelsOf(pyramid);
    std::vector<Cubemap> mips{pyramid[0]};
    for (int i = 1; i < count; ++i) {
        const double roughness = specularMipRoughness(i, count);
        mips.push_back(prefilterMip(levels, size >> i, roughness * roughness));
    }
    return mips;
}

Cubemap radianceCubemap(const ShCoefficients& radiance, int faceSize) {
    Cubemap cubemap = evaluateCubemap(radiance, faceSize);
    for (glm::vec4& texel : cubemap.texels)
        texel = glm::max(texel, glm::vec4(0.0f));
    return cubemap;
}

void addUniformRadiance(Cubemap& cubemap, const glm::dvec3& radiance) {
    for (glm::vec4& texel : cubemap.texels)
        texel += glm::vec4(glm::vec3(radiance), 0.0f);
}

void drawSphericalLight(Cubemap& cubemap, const SphericalLight& light) {
    const int n = cubemap.faceSize;
    const glm::dvec3 direction = glm::normalize(light.direction);
    const double cosRadius = std::cos(light.angularRadius);
    // A texel spans at most 2 / n radians (at a face's centre), so one whose centre lies farther
    // than the radius plus its half-diagonal from the light's direction cannot touch the cap.
    const double cosReach = std::cos(std::min(light.angularRadius + std::sqrt(2.0) / n, kPi));
    const int grid = int(std::clamp(std::ceil(2.0 / n * 8.0 / light.angularRadius), 1.0, 256.0));
    const auto inCap = [&](const glm::dvec3& d) {
        return glm::dot(d, direction) >= cosRadius ? glm::dvec3(1.0) : glm::dvec3(0.0);
    };
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                if (glm::dot(texelDirection(face, i, j, n), direction) < cosReach) continue;
                const double coverage = texelMean(face, i, j, n, grid, inCap).x;
                cubemap.at(face, i, j) += glm::vec4(glm::vec3(coverage * light.radiance), 0.0f);
            }
}

} // namespace shprobe
