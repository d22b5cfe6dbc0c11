// Analytic lights added to a probe's radiance coefficients, and the extraction of a sun from a
// cube map (so that it can be added back analytically, or handled apart from the probe).
//
// All lights are circularly symmetric about a direction d, so their coefficients follow from their
// zonal harmonics z_l (the coefficients of the light centred on +z) by the zonal-to-direction rule
// L_lm = sqrt(4 pi / (2l+1)) z_l y_lm(d) (Sloan, seed 000, "zonal harmonics"; Lisle & Huang, seed 002,
// Proposition 3.2). Directions point from the probe towards the light and need not be unit length.
// Angles are in radians.
#pragma once
#include "coefficients.h"
#include "cubemap.h"

#include <glm/vec3.hpp>
#include <numbers>
#include <span>
#include <vector>

namespace shprobe {

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
    // Sloan (seed 000, "Normalization"): L_lm = (pi / s_n) I y_lm(d), so that at the probe's own
    // order a white Lambertian surface facing the light reflects radiance E(d) / pi = I, i.e. its
    // irradiance is E(d) = pi I ("irradiance I" in the 1/pi-normalized units of seeds 000 and 004).
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

// Zonal harmonics of a cap of angular radius r and unit radiance, l = 0..order-1 (Sloan, seed 000,
// appendix A3): z_l = 2 pi K_l integral_{cos r}^1 P_l(t) dt, in the closed form
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

// --- Circular light window (Lisle & Huang, seed 002, section 3.2) ------------------------------

// f_l(z) = 1/(1-z) integral_z^1 P_l(t) dt, l = 0..order-1, by the recurrence (11) of seed 002:
// f_0 = 1, f_1 = (1+z)/2, f_{l+1} = ((2l+1) z f_l - (l-1) f_{l-1}) / (l+2). z = cos(aperture) in
// [-1, 1]; at z = 1 (an aperture too small for cos to tell it from 0) every f_l is 1, the limit.
// Any order >= 1.
std::vector<double> circularWindowFactors(double cosAperture, int order);

// A cap of aperture zeta emitting a total power P (seed 002 uses P = 4 pi): radiance
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

struct SunExtractionOptions {
    // A texel can belong to the sun when its luminance (Rec. 709) exceeds both
    // relativeThreshold * (median texel luminance of the map) and absoluteThreshold.
    double relativeThreshold = 20.0;
    double absoluteThreshold = 0.0;
    // The region is the set of such texels connected (across faces) to the brightest texel and
    // within this angle of it (radians), which bounds it when the threshold is too low.
    double maxAngularRadius = 0.35; // about 20 degrees
    SunFill fill = SunFill::SurroundingSky;
};

struct SunExtraction {
    bool found = false;            // false: the brightest texel is below the threshold; map untouched
    glm::dvec3 direction{0.0};     // unit; centroid of the region weighted by removed luminance x solid angle
    glm::dvec3 power{0.0};         // sum over the region of (L - fill) Omega: the removed power per channel
    double regionSolidAngle = 0.0; // of the region's texels
    // The sun's own solid angle: (luminance power) / (core luminance), the core being the
    // solid-angle-weighted mean of the region's interior texels (all four neighbours in the region),
    // or the brightest texel when there is no interior. Partly covered edge texels thus count for
    // their coverage; for a hard-edged uniform disc this equals regionSolidAngle.
    double solidAngle = 0.0;
    double angularRadius = 0.0;   // radians: capAngularRadius(solidAngle)
    int texelCount = 0;           // texels in the region
    glm::dvec3 fillRadiance{0.0}; // what the region's texels were replaced with
};

// Finds the brightest compact region (see SunExtractionOptions), removes it from the cube map
// (replacing its texels by options.fill) and describes it. The cube map with the sun removed plus
// sunAsSphericalLight(result) approximates the original probe.
SunExtraction extractSun(Cubemap& cubemap, const SunExtractionOptions& options = {});

// The extracted sun as a uniform cap of its solid angle (angularRadius) and the same power.
SphericalLight sunAsSphericalLight(const SunExtraction& sun);

} // namespace shprobe
