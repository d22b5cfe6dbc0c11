// Analytic lights (see lights.h for the formulas and their sources) and sun extraction.
#include "sh/lights.h"

#include "common/error.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <string>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;

void requireRadiance(const ShCoefficients& radiance) {
    if (radiance.quantity != Quantity::Radiance) {
        throw Error(ErrorKind::Input, "lights are added to radiance coefficients, got irradiance");
    }
    requireCoefficients(radiance);
}

// Zonal harmonics need no basis evaluation: any number of bands.
void requireBandCount(int order) {
    if (order < 1) throw Error(ErrorKind::Input, "SH order must be at least 1, got " + std::to_string(order));
}

void requireAngle(double angle, const char* what) {
    if (!(angle > 0.0 && angle <= kPi)) {
        throw Error(ErrorKind::Input,
                    std::string(what) + " must be in (0, pi] radians, got " + std::to_string(angle));
    }
}

// P_l(x) and P_l'(x) for l = 0..count-1: Bonnet's recurrence and P'_{l+1} = P'_{l-1} + (2l+1) P_l,
// which only adds terms of one sign near x = 1 and so keeps full precision for small caps.
struct LegendreValues {
    std::vector<double> value;
    std::vector<double> derivative;
};

LegendreValues legendreWithDerivatives(double x, int count) {
    LegendreValues p{std::vector<double>(size_t(count) + 1), std::vector<double>(size_t(count) + 1)};
    p.value[0] = 1.0, p.derivative[0] = 0.0;
    p.value[1] = x, p.derivative[1] = 1.0;
    for (int l = 1; l < count; ++l) {
        p.value[size_t(l + 1)] =
            ((2.0 * l + 1.0) * x * p.value[size_t(l)] - l * p.value[size_t(l - 1)]) / (l + 1.0);
        p.derivative[size_t(l + 1)] = p.derivative[size_t(l - 1)] + (2.0 * l + 1.0) * p.value[size_t(l)];
    }
    return p;
}

} // namespace

// Scaled by its largest component first, so that its length is neither infinite nor zero.
glm::dvec3 unitDirection(const glm::dvec3& d) {
    const double largest = std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
    if (!std::isfinite(largest) || largest == 0.0)
        throw Error(ErrorKind::Input, "light direction must be finite and non-zero");
    const glm::dvec3 scaled = d / largest;
    return scaled / glm::length(scaled);
}

void addZonal(ShCoefficients& radiance, const glm::dvec3& direction, std::span<const double> zonal,
              const glm::dvec3& scale) {
    requireRadiance(radiance);
    if (zonal.size() < size_t(radiance.order)) {
        throw Error(ErrorKind::Input, "zonal harmonics hold " + std::to_string(zonal.size()) +
                                          " bands, order " + std::to_string(radiance.order) + " needs " +
                                          std::to_string(radiance.order));
    }
    std::array<double, coefficientCount(kMaxOrder)> y{};
    evalBasis(radiance.order, unitDirection(direction), y);
    for (int l = 0; l < radiance.order; ++l) {
        const double bandScale = std::sqrt(4.0 * kPi / (2.0 * l + 1.0)) * zonal[size_t(l)];
        for (int m = -l; m <= l; ++m)
            radiance.rgb[size_t(shIndex(l, m))] += scale * (bandScale * y[size_t(shIndex(l, m))]);
    }
}

double capSolidAngle(double angularRadius) {
    const double s = std::sin(0.5 * angularRadius);
    return 4.0 * kPi * s * s;
}

double capAngularRadius(double solidAngle) {
    const double s = std::sqrt(std::clamp(solidAngle / (4.0 * kPi), 0.0, 1.0));
    return 2.0 * std::asin(s);
}

double deltaLightPeak(int order) {
    requireBandCount(order);
    double sum = 0.0;
    for (int l = 0; l < order; ++l)
        sum += irradianceBandFactor(l) * (2.0 * l + 1.0) / (4.0 * kPi);
    return sum;
}

// A delta of power I has L_lm = I y_lm(d) (projection of a Dirac); Sloan's normalization divides by
// the order's own peak irradiance s_n and multiplies by pi (see lights.h).
void addDirectionalLight(ShCoefficients& radiance, const DirectionalLight& light) {
    requireRadiance(radiance);
    const double scale =
        light.normalization == DirectionalNormalization::Sloan ? kPi / deltaLightPeak(radiance.order) : 1.0;
    std::array<double, coefficientCount(kMaxOrder)> y{};
    evalBasis(radiance.order, unitDirection(light.direction), y);
    for (size_t i = 0; i < radiance.rgb.size(); ++i)
        radiance.rgb[i] += light.intensity * (scale * y[i]);
}

// z_l = 2 pi K_l integral_{cos r}^1 P_l(t) dt. Legendre's equation ((1-t^2) P_l')' = -l(l+1) P_l gives
// integral_c^1 P_l = (1 - c^2) P_l'(c) / (l(l+1)) for l >= 1, and 1 - c = 2 sin^2(r/2) for l = 0.
std::vector<double> sphericalLightZonal(double angularRadius, int order) {
    requireBandCount(order);
    requireAngle(angularRadius, "spherical light angular radius");
    const double c = std::cos(angularRadius);
    const double sinSquared = std::sin(angularRadius) * std::sin(angularRadius);
    const LegendreValues p = legendreWithDerivatives(c, order);
    std::vector<double> zonal(static_cast<size_t>(order));
    zonal[0] = shNormalization(0, 0) * capSolidAngle(angularRadius); // 2 pi K_0 (1 - c)
    for (int l = 1; l < order; ++l) {
        const double integral = sinSquared * p.derivative[size_t(l)] / (l * (l + 1.0));
        zonal[size_t(l)] = 2.0 * kPi * shNormalization(l, 0) * integral;
    }
    return zonal;
}

void addSphericalLight(ShCoefficients& radiance, const SphericalLight& light) {
    requireRadiance(radiance);
    addZonal(radiance, light.direction, sphericalLightZonal(light.angularRadius, radiance.order),
             light.radiance);
}

std::vector<double> circularWindowFactors(double cosAperture, int order) {
    requireBandCount(order);
    if (!(cosAperture >= -1.0 && cosAperture <= 1.0)) {
        throw Error(ErrorKind::Input,
                    "circular window needs cos(aperture) in [-1, 1], got " + std::to_string(cosAperture));
    }
    const double z = cosAperture;
    std::vector<double> f(size_t(std::max(order, 2)));
    f[0] = 1.0;
    f[1] = 0.5 * (1.0 + z);
    for (int l = 1; l + 1 < order; ++l)
        f[size_t(l + 1)] = ((2.0 * l + 1.0) * z * f[size_t(l)] - (l - 1.0) * f[size_t(l - 1)]) / (l + 2.0);
    f.resize(size_t(order));
    return f;
}

// L_lm = P f_l(cos zeta) y_lm(d) = sqrt(4 pi / (2l+1)) z_l y_lm(d) with z_l = sqrt((2l+1)/(4 pi)) f_l.
void addCircularWindow(ShCoefficients& radiance, const CircularWindow& window) {
    requireRadiance(radiance);
    requireAngle(window.aperture, "circular window aperture");
    std::vector<double> zonal = circularWindowFactors(std::cos(window.aperture), radiance.order);
    for (size_t l = 0; l < zonal.size(); ++l)
        zonal[l] *= std::sqrt((2.0 * double(l) + 1.0) / (4.0 * kPi));
    addZonal(radiance, window.direction, zonal, window.power);
}

void addAmbient(ShCoefficients& radiance, const glm::dvec3& ambientRadiance) {
    requireRadiance(radiance);
    radiance.rgb[0] += std::sqrt(4.0 * kPi) * ambientRadiance;
}

// --- Sun extraction ----------------------------------------------------------------------------

namespace {

double luminance(const glm::dvec3& rgb) {
    return 0.2126 * rgb.r + 0.7152 * rgb.g + 0.0722 * rgb.b; // Rec. 709
}

glm::dvec3 texelRgb(const Cubemap& cubemap, size_t index) {
    const glm::vec4& t = cubemap.texels[index];
    return glm::dvec3(t.r, t.g, t.b);
}

struct TexelCoord {
    int face;
    int i;
    int j;
};

TexelCoord texelCoord(size_t index, int n) {
    const size_t perFace = size_t(n) * size_t(n);
    return {int(index / perFace), int(index % perFace % size_t(n)), int(index % perFace / size_t(n))};
}

size_t texelIndex(const TexelCoord& t, int n) {
    return (size_t(t.face) * size_t(n) + size_t(t.j)) * size_t(n) + size_t(t.i);
}

glm::dvec3 directionOf(size_t index, int n) {
    const TexelCoord t = texelCoord(index, n);
    return texelDirection(t.face, t.i, t.j, n);
}

double solidAngleOf(size_t index, int n) {
    const TexelCoord t = texelCoord(index, n);
    return texelSolidAngle(t.i, t.j, n);
}

// The texel next to t one step along (di, dj); off the face's edge, the texel of the neighbouring
// face that holds the continued direction.
size_t neighbourTexel(const TexelCoord& t, int di, int dj, int n) {
    const int i = t.i + di, j = t.j + dj;
    if (i >= 0 && i < n && j >= 0 && j < n) return texelIndex({t.face, i, j}, n);
    const double a = 2.0 * (i + 0.5) / n - 1.0, b = 2.0 * (j + 0.5) / n - 1.0;
    const FacePoint p = directionToFace(faceDirection(t.face, a, b));
    auto toTexel = [n](double coordinate) {
        return std::clamp(int(std::floor((coordinate + 1.0) * 0.5 * n)), 0, n - 1);
    };
    return texelIndex({p.face, toTexel(p.a), toTexel(p.b)}, n);
}

// What the threshold and the criteria need from the whole map.
struct MapLuminance {
    double median = 0.0;
    size_t brightest = 0; // the seed of the region
    double peak = 0.0;    // the brightest texel's luminance
    double power = 0.0;   // sum of max(luminance, 0) Omega over the map
};

MapLuminance measureMap(const Cubemap& cubemap) {
    const int n = cubemap.faceSize;
    MapLuminance map;
    std::vector<double> values(cubemap.texels.size());
    for (size_t k = 0; k < values.size(); ++k) {
        values[k] = luminance(texelRgb(cubemap, k));
        map.power += std::max(values[k], 0.0) * solidAngleOf(k, n);
        if (k == 0 || values[k] > map.peak) map.brightest = k, map.peak = values[k];
    }
    const auto middle = values.begin() + std::ptrdiff_t(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    map.median = *middle;
    return map;
}

double luminanceThreshold(const MapLuminance& map, const SunExtractionOptions& options) {
    return std::max(
        {options.relativeThreshold * map.median, options.absoluteThreshold, options.peakFraction * map.peak});
}

struct SunRegion {
    std::vector<size_t> texels;   // above the threshold, connected to the seed, within the angle
    std::vector<size_t> ring;     // below the threshold and adjacent to the region
    std::vector<size_t> interior; // region texels whose four neighbours are all in the region
};

template <typename Predicate> bool allNeighbours(size_t index, int n, Predicate predicate) {
    const TexelCoord t = texelCoord(index, n);
    return predicate(neighbourTexel(t, 1, 0, n)) && predicate(neighbourTexel(t, -1, 0, n)) &&
           predicate(neighbourTexel(t, 0, 1, n)) && predicate(neighbourTexel(t, 0, -1, n));
}

// Breadth-first flood fill from the brightest texel over 4-neighbours, across faces.
SunRegion growRegion(const Cubemap& cubemap, size_t seed, double threshold, double maxAngle) {
    enum : std::uint8_t { Unseen, Region, Ring, Excluded };
    const int n = cubemap.faceSize;
    const glm::dvec3 axis = directionOf(seed, n);
    const double minCosine = std::cos(maxAngle);
    std::vector<std::uint8_t> state(cubemap.texels.size(), Unseen);
    SunRegion region;
    std::deque<size_t> queue{seed};
    state[seed] = Region;
    while (!queue.empty()) {
        const size_t current = queue.front();
        queue.pop_front();
        region.texels.push_back(current);
        const TexelCoord t = texelCoord(current, n);
        const int steps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (const auto& step : steps) {
            const size_t next = neighbourTexel(t, step[0], step[1], n);
            if (state[next] != Unseen) continue;
            if (luminance(texelRgb(cubemap, next)) <= threshold) {
                state[next] = Ring;
                region.ring.push_back(next);
            } else if (glm::dot(directionOf(next, n), axis) < minCosine) {
                state[next] = Excluded;
            } else {
                state[next] = Region;
                queue.push_back(next);
            }
        }
    }
    for (size_t k : region.texels) {
        if (allNeighbours(k, n, [&](size_t neighbour) { return state[neighbour] == Region; }))
            region.interior.push_back(k);
    }
    return region;
}

// The sky level under the sun: the ring's mean, clamped to >= 0 per channel so that the residual
// min(L, fill) is never negative where L is not (resampled HDRs hold small negative lobes).
glm::dvec3 fillLevel(const Cubemap& cubemap, const SunRegion& region, SunFill fill) {
    if (fill == SunFill::Zero || region.ring.empty()) return glm::dvec3(0.0);
    glm::dvec3 sum(0.0);
    for (size_t k : region.ring)
        sum += texelRgb(cubemap, k);
    return glm::max(sum / double(region.ring.size()), glm::dvec3(0.0));
}

// What a region texel keeps, per channel min(L, fill): the fill never exceeds the texel, so
// removing the sun cannot raise a channel (a sunset's sun is dimmer in blue than the sky around it)
// nor push one below 0. In float, as stored, so that the removed part below is exact.
glm::vec3 residualRadiance(const glm::vec4& texel, const glm::dvec3& fill) {
    return glm::min(glm::vec3(texel), glm::vec3(fill));
}

// L - min(L, fill) = max(L - fill, 0) per channel: the sun's share of the texel, never negative.
glm::dvec3 removedRadiance(const glm::vec4& texel, const glm::dvec3& fill) {
    return glm::dvec3(glm::vec3(texel)) - glm::dvec3(residualRadiance(texel, fill));
}

// Removed luminance of the sun's fully covered part: the solid-angle-weighted mean over the
// region's interior, or the brightest texel's when the region is too small to have an interior.
double coreLuminance(const Cubemap& cubemap, const SunRegion& region, const glm::dvec3& fill) {
    const int n = cubemap.faceSize;
    double weighted = 0.0, solidAngle = 0.0;
    for (size_t k : region.interior) {
        const double omega = solidAngleOf(k, n);
        weighted += luminance(removedRadiance(cubemap.texels[k], fill)) * omega;
        solidAngle += omega;
    }
    if (solidAngle > 0.0) return weighted / solidAngle;
    double brightest = 0.0;
    for (size_t k : region.texels)
        brightest = std::max(brightest, luminance(removedRadiance(cubemap.texels[k], fill)));
    return brightest;
}

double largestAngleFrom(const glm::dvec3& direction, const std::vector<size_t>& texels, int n) {
    double minCosine = 1.0;
    for (size_t k : texels)
        minCosine = std::min(minCosine, glm::dot(direction, directionOf(k, n)));
    return std::acos(std::clamp(minCosine, -1.0, 1.0));
}

// Describes the sun the region would give, without touching the map.
SunExtraction measureSun(const Cubemap& cubemap, const SunRegion& region, const glm::dvec3& fill,
                         const MapLuminance& map) {
    const int n = cubemap.faceSize;
    SunExtraction sun;
    sun.texelCount = int(region.texels.size());
    sun.fillRadiance = fill;
    glm::dvec3 weightedDirection(0.0);
    for (size_t k : region.texels) {
        const double omega = solidAngleOf(k, n);
        const glm::dvec3 removed = removedRadiance(cubemap.texels[k], fill);
        sun.power += removed * omega;
        sun.regionSolidAngle += omega;
        weightedDirection += luminance(removed) * omega * directionOf(k, n);
    }
    // Partly covered edge texels count for the fraction of the core luminance they hold.
    const double luminancePower = luminance(sun.power), core = coreLuminance(cubemap, region, fill);
    sun.solidAngle =
        core > 0.0 ? std::min(luminancePower / core, sun.regionSolidAngle) : sun.regionSolidAngle;
    // The seed (brightest texel) stands in when nothing would be removed (a fill as bright as the sun).
    sun.direction = glm::length(weightedDirection) > 0.0 ? glm::normalize(weightedDirection)
                                                         : directionOf(region.texels[0], n);
    sun.angularRadius = capAngularRadius(sun.solidAngle);
    sun.extent = largestAngleFrom(sun.direction, region.texels, n);
    sun.powerFraction = map.power > 0.0 ? luminancePower / map.power : 0.0;
    return sun;
}

// The region's share of the luminance power of all texels above the threshold.
double regionDominance(const Cubemap& cubemap, const SunRegion& region, double threshold) {
    const int n = cubemap.faceSize;
    double inRegion = 0.0, aboveThreshold = 0.0;
    for (size_t k : region.texels)
        inRegion += luminance(texelRgb(cubemap, k)) * solidAngleOf(k, n);
    for (size_t k = 0; k < cubemap.texels.size(); ++k) {
        const double value = luminance(texelRgb(cubemap, k));
        if (value > threshold) aboveThreshold += value * solidAngleOf(k, n);
    }
    return aboveThreshold > 0.0 ? inRegion / aboveThreshold : 0.0;
}

bool isSun(const SunExtraction& sun, const SunExtractionOptions& options) {
    const bool compact = sun.extent <= options.maxSunAngularRadius;
    const bool dominant = sun.dominance >= options.minDominance;
    const bool substantial = luminance(sun.power) > 0.0 && sun.powerFraction >= options.minPowerFraction;
    const bool bright = sun.peakRatio >= options.minPeakRatio;
    // What probe files accept (a disc of radius in (0, 90] degrees), whatever the options.
    const bool valid = sun.solidAngle > 0.0 && sun.angularRadius > 0.0 && sun.angularRadius <= 0.5 * kPi;
    return compact && dominant && substantial && bright && valid;
}

void removeRegion(Cubemap& cubemap, const SunRegion& region, const glm::dvec3& fill) {
    for (size_t k : region.texels)
        cubemap.texels[k] = glm::vec4(residualRadiance(cubemap.texels[k], fill), cubemap.texels[k].a);
}

void requireSunOptions(const SunExtractionOptions& options) {
    const bool thresholds = options.relativeThreshold >= 0.0 && options.absoluteThreshold >= 0.0 &&
                            options.peakFraction >= 0.0 && options.peakFraction <= 1.0;
    const bool angles = options.maxAngularRadius > 0.0 && options.maxSunAngularRadius > 0.0 &&
                        options.maxSunAngularRadius <= 0.5 * kPi;
    const bool criteria = options.minDominance >= 0.0 && options.minDominance <= 1.0 &&
                          options.minPowerFraction >= 0.0 && options.minPeakRatio >= 0.0;
    if (!(thresholds && angles && criteria)) {
        throw Error(ErrorKind::Input, "sun extraction needs non-negative thresholds and criteria, a peak "
                                      "fraction and a dominance in [0, 1], a positive maximum radius and a "
                                      "maximum sun radius in (0, pi/2]");
    }
}

} // namespace

SunExtraction extractSun(Cubemap& cubemap, const SunExtractionOptions& options) {
    const int n = cubemap.faceSize;
    if (n <= 0 || cubemap.texels.size() != size_t(kFaceCount) * size_t(n) * size_t(n)) {
        throw Error(ErrorKind::Input, "cube map holds " + std::to_string(cubemap.texels.size()) +
                                          " texels for face size " + std::to_string(n));
    }
    requireSunOptions(options);
    const MapLuminance map = measureMap(cubemap);
    const double peakRatio =
        map.median > 0.0 ? map.peak / map.median : std::numeric_limits<double>::infinity();
    const double threshold = luminanceThreshold(map, options);
    if (!(map.peak > threshold)) return SunExtraction{.peakRatio = peakRatio};
    const SunRegion region = growRegion(cubemap, map.brightest, threshold, options.maxAngularRadius);
    const glm::dvec3 fill = fillLevel(cubemap, region, options.fill);
    SunExtraction sun = measureSun(cubemap, region, fill, map);
    sun.peakRatio = peakRatio;
    sun.dominance = regionDominance(cubemap, region, threshold);
    sun.found = isSun(sun, options);
    if (sun.found) removeRegion(cubemap, region, fill);
    return sun;
}

SphericalLight sunAsSphericalLight(const SunExtraction& sun) {
    if (!sun.found || !(sun.solidAngle > 0.0)) {
        throw Error(ErrorKind::Input, "no extracted sun to turn into a spherical light");
    }
    return SphericalLight{sun.direction, sun.angularRadius, sun.power / sun.solidAngle};
}

} // namespace shprobe
