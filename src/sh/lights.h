// Analytic lights added to a probe's radiance coefficients, and the extraction of a sun from a
// cube map (so that it can be added back analytically, or handled apart from the probe).
//
// All lights are circularly symmetric about a direction d, so their coefficients follow from their
// zonal harmonics z_l (the coefficients of the light centred on +z) by the zonal-to-direction rule
// L_lm = sqrt(4 pi / (2l+1)) z_l y_lm(d) (Sloan, "Stupid Spherical Harmonics (SH) Tricks", zonal
// harmonics; Lisle & Huang, "Algorithms for Spherical Harmonic Lighting", Proposition 3.2). Directions point
// from the probe towards the light and need not be unit length. Angles are in radians.
#pragma once
#include "sh/coefficients.h"
#include "sh/cubemap.h"

#include <glm/vec3.hpp>
#include <numbers>
#include <span>
#include <vector>

namespace shprobe {

// `d` of unit length, whatever its length: (1e300, 1e300, 0) too, whose length overflows double.
// Throws Error(Input) for a vector that is zero or not finite.
glm::dvec3 unitDirection(const glm::dvec3& d);

// --- Zonal building blocks ---------------------------------------------------------------------

// Adds sqrt(4 pi / (2l+1)) zonal[l] y_lm(d) scale to every coefficient, l = 0..order-1.
// zonal must hold at least radiance.order values.
void addZonal(ShCoefficients& radiance, const glm::dvec3& direction, std::span<const double> zonal,
              const glm::dvec3& scale);

// Solid angle of a cap of angular radius r: 2 pi (1 - cos r), computed as 4 pi sin^2(r/2).
double capSolidAngle(double angularRadius);
// Angular radius of the cap of a given solid angle (inverse of capSolidAngle), 0..pi.
double capAngularRadius(double solidAngle);

// --- Directional light (a delta) ---------------------------------------------------------------

// s_n = sum_{l<n} A_l (2l+1) / (4 pi): the order-n irradiance, at the normal facing it, of a delta
// light of unit power (by the addition theorem, E(d) = sum_l A_l (2l+1)/(4 pi) P_l(1)). The exact
// (untruncated) value is 1; s_1 = 1/4, s_2 = 3/4, s_3 = s_4 = 17/16, s_5 = s_6 = 31/32,
// s_7 = s_8 = 261/256. Any order >= 1.
double deltaLightPeak(int order);

enum class DirectionalNormalization {
    // Sloan ("Stupid SH Tricks", "Normalization"): L_lm = (pi / s_n) I y_lm(d), so that at the probe's own
    // order a white Lambertian surface facing the light reflects radiance E(d) / pi = I, i.e. its
    // irradiance is E(d) = pi I ("irradiance I" in the 1/pi-normalized units of Sloan and of Geomerics'
    // notes).
    // At order 3 the scale is 16 pi / 17, at order 5 32 pi / 31.
    Sloan,
    // A delta of power I: L_lm = I y_lm(d). The exact irradiance at the facing normal is I; the
    // order-n probe gives s_n I there (17/16 I at order 3, Sloan's "17 against 1").
    Power,
};

struct DirectionalLight {
    glm::dvec3 direction{0.0, 0.0, 1.0};
    glm::dvec3 intensity{1.0};
    DirectionalNormalization normalization = DirectionalNormalization::Sloan;
};
void addDirectionalLight(ShCoefficients& radiance, const DirectionalLight& light);

// --- Spherical light (a uniform cap) -----------------------------------------------------------

// Zonal harmonics of a cap of angular radius r and unit radiance, l = 0..order-1 (Sloan, "Stupid SH
// Tricks", appendix A3): z_l = 2 pi K_l integral_{cos r}^1 P_l(t) dt, in the closed form
// z_0 = 2 pi K_0 (1 - cos r), z_l = 2 pi K_l sin^2(r) P_l'(cos r) / (l (l+1)) for l >= 1 (e.g.
// z_1 = sqrt(3 pi)/2 sin^2 r, z_2 = sqrt(5 pi)/2 cos r sin^2 r), free of cancellation for small r.
// Any order >= 1 (the add* functions are limited to kMaxOrder by the basis).
std::vector<double> sphericalLightZonal(double angularRadius, int order);

struct SphericalLight {
    glm::dvec3 direction{0.0, 0.0, 1.0};
    double angularRadius = 0.0; // radians, in (0, pi]
    glm::dvec3 radiance{1.0};   // uniform over the cap; power = radiance * capSolidAngle(angularRadius)
};
void addSphericalLight(ShCoefficients& radiance, const SphericalLight& light);

// --- Circular light window (Lisle & Huang, "Algorithms for SH Lighting", section 3.2) ---------

// f_l(z) = 1/(1-z) integral_z^1 P_l(t) dt, l = 0..order-1, by Lisle & Huang's recurrence (11):
// f_0 = 1, f_1 = (1+z)/2, f_{l+1} = ((2l+1) z f_l - (l-1) f_{l-1}) / (l+2). z = cos(aperture) in
// [-1, 1]; at z = 1 (an aperture too small for cos to tell it from 0) every f_l is 1, the limit.
// Any order >= 1.
std::vector<double> circularWindowFactors(double cosAperture, int order);

// A cap of aperture zeta emitting a total power P (Lisle & Huang use P = 4 pi): radiance
// P / (2 pi (1 - cos zeta)) inside, and L_lm = P f_l(cos zeta) y_lm(d). The same light as a
// SphericalLight of that radiance, computed by the other paper's route.
struct CircularWindow {
    glm::dvec3 direction{0.0, 0.0, 1.0};
    double aperture = 0.0; // radians, in (0, pi]
    glm::dvec3 power{4.0 * std::numbers::pi};
};
void addCircularWindow(ShCoefficients& radiance, const CircularWindow& window);

// --- Ambient -----------------------------------------------------------------------------------

// A uniform radiance c from every direction: L_00 += sqrt(4 pi) c, nothing else.
void addAmbient(ShCoefficients& radiance, const glm::dvec3& ambientRadiance);

// --- Sun extraction ----------------------------------------------------------------------------

enum class SunFill {
    SurroundingSky, // region texels get the mean of the one-texel ring around the region
    Zero,           // region texels get 0; the whole texel radiance counts as sun
};

// The defaults were chosen by measuring the eight HDRs of Blender's studio lights (city,
// courtyard, forest, interior, night, studio, sunrise, sunset: 1024 x 512 equirects, loaded at face
// size 256). Their visible suns (city, sunrise, sunset) and their other lights (ceiling spots,
// lamps, bright sky through an arcade or leaves) differ most in dominance: a sun's region held
// 99.9% or more of the power above the threshold, another light at most 55%, as lights like it
// share the rest. The figures below are from those maps.
struct SunExtractionOptions {
    // A texel can belong to the sun when its luminance (Rec. 709) exceeds relativeThreshold *
    // (median texel luminance of the map), absoluteThreshold and peakFraction * (the brightest
    // texel's luminance).
    double relativeThreshold = 20.0;
    double absoluteThreshold = 0.0;
    // The sun's disc is where the luminance is within three decades of the peak; the glow around it
    // (the aureole) is left to the probe, where it is smooth enough to project well. 20 x median
    // alone takes the glow into the sun on city and sunrise (radii of 7.8 and 12.6 degrees), 1/1000
    // of the peak leaves 0.8 and 0.9. A partly covered edge texel dimmer than this stays in the sky,
    // so the fill (the ring's mean) is biased by at most this fraction of the sun's radiance.
    double peakFraction = 1e-3;
    // The region is the set of such texels connected (across faces) to the brightest texel and
    // within this angle of it (radians), which bounds it when the threshold is too low.
    double maxAngularRadius = 0.35; // about 20 degrees
    SunFill fill = SunFill::SurroundingSky;

    // --- When the region is a sun: all four must hold, otherwise the map is left untouched ---
    // Compact: every region texel centre lies within this angle (radians) of the sun's direction.
    // Measured: the suns 0.8 to 1.5 degrees (a 0.27-degree sun blurred by the maps' 0.35-degree
    // pixels), studio's brightest lamp 8.1, courtyard's sky 18.6. 5 degrees also keeps suns drawn as
    // large as 3. At most pi/2, so that a sun's angular radius is in (0, 90] degrees as probe files
    // require.
    double maxSunAngularRadius = 5.0 * std::numbers::pi / 180.0;
    // Dominant: the region holds at least this fraction of the luminance power (L Omega) of all the
    // texels above the threshold: nothing else in the map comes near it. Measured: the suns 0.999 to
    // 1; interior's brightest ceiling spot 0.55 (a second one as bright holds most of the rest),
    // night's brightest horizon light 0.32, studio's brightest lamp 0.27, forest 0.11, courtyard 0.07.
    double minDominance = 0.8;
    // Substantial: the removed luminance power is at least this fraction of the whole map's; a light
    // too weak to matter is not worth taking out. Measured: sunset's sun, low and dimmed, 0.023;
    // city's 0.24, sunrise's 0.58.
    double minPowerFraction = 0.01;
    // Far brighter than the sky: the brightest texel is at least this many times the median
    // luminance. The real sun is some 1e5 times the sky; the maps' suns give 3.9e3 (sunset) to 2.4e5
    // (sunrise). An 8-bit image (texels at most its white) passes only if its median is below
    // 1/1000 of white; courtyard, with no sun in view, gives 658.
    double minPeakRatio = 1000.0;
};

struct SunExtraction {
    // false: the brightest region failed the criteria (or no texel is above the threshold) and the
    // map is untouched; the fields below then describe the region that failed.
    bool found = false;
    glm::dvec3 direction{0.0};     // unit; centroid of the region weighted by removed luminance x solid angle
    glm::dvec3 power{0.0};         // sum over the region of (L - residual) Omega: the removed power, >= 0
    double regionSolidAngle = 0.0; // of the region's texels
    // The sun's own solid angle: (luminance power) / (core luminance), the core being the
    // solid-angle-weighted mean of the removed luminance over the region's interior texels (all
    // four neighbours in the region), or the brightest texel's when there is no interior. Partly
    // covered edge texels thus count for their coverage; for a hard-edged uniform disc this equals
    // regionSolidAngle.
    double solidAngle = 0.0;
    double angularRadius = 0.0;   // radians: capAngularRadius(solidAngle)
    int texelCount = 0;           // texels in the region
    glm::dvec3 fillRadiance{0.0}; // the sky level the region's texels were brought down to (>= 0)

    // What the criteria of SunExtractionOptions measured (all but peakRatio stay 0 when no texel is
    // above the threshold).
    double peakRatio = 0.0; // brightest texel luminance / median luminance (infinite if the median is <= 0)
    double dominance = 0.0; // region's share of the luminance power of all texels above the threshold
    double powerFraction = 0.0; // removed luminance power / luminance power of the whole map
    double extent = 0.0;        // radians: the largest angle from direction to a region texel centre
};

// Finds the brightest compact region (see SunExtractionOptions) and, if it passes the criteria,
// removes it from the cube map and describes it. Removing brings every region texel down to the
// fill per channel, and never raises one: the texel keeps min(L, fill) (fill >= 0), the sun gets
// the rest, L - min(L, fill) >= 0. Neither part is negative where L is not, a negative texel is left
// as it is, and residual + sun = L exactly. The cube map with the sun removed plus
// sunAsSphericalLight(result) approximates the original probe.
SunExtraction extractSun(Cubemap& cubemap, const SunExtractionOptions& options = {});

// The extracted sun as a uniform cap of its solid angle (angularRadius) and the same power.
SphericalLight sunAsSphericalLight(const SunExtraction& sun);

} // namespace shprobe
