// What the render shaders need from a probe, computed once on the CPU: the SH coefficients with
// the basis constants and the per-band convolution folded in (sh_irradiance.glsl evaluates only
// polynomials), the renormalized L1 terms of the non-linear model, and the sun a probe file may
// carry beside its coefficients (bake --extract-sun), which the shaders add analytically
// (src/glsl/sun_light.h). Also the double-precision references of the three shading modes
// and of the sun, which the tests compare the shaders with.
#pragma once
#include "glsl/render_interface.h"
#include "sh/coefficients.h"
#include "sh/folding.h"
#include "sh/lights.h"

#include <array>
#include <optional>
#include <string>

namespace shprobe {

enum class ShadingMode {
    Radiance,    // L(n): the SH reconstruction of the environment (no convolution, no albedo)
    Irradiance,  // albedo E(n) / pi, E from the order-3 or order-5 expansion
    L1NonLinear, // albedo times the non-linear L1 model of E(n) / pi (Geomerics' L1 notes)
};

// "radiance", "irradiance", "l1-nonlinear"; parse throws Error(Input) for anything else.
const char* shadingModeName(ShadingMode mode);
ShadingMode parseShadingMode(const std::string& name);

// Orders the render shaders evaluate: 3 to 5 (bands 0..2 always; see sh_irradiance.glsl).
constexpr int kMinRenderOrder = 3;
constexpr int kMaxRenderOrder = SHPROBE_RENDER_MAX_ORDER;

// basisPolynomialScale, basisPolynomial, truncateOrder and the fold itself: sh/folding.h.

// Folded coefficients for the shaders (rgb; layout of glsl::RenderUniforms), from foldCoefficients.
struct ProbeShading {
    int order = 0;            // bands 0..order-1 are set; the others are 0
    bool hasRadiance = false; // false for irradiance probes whose bands with A_l = 0 are needed
    std::array<glm::vec4, SHPROBE_FOLDED_COUNT> radiance{};   // s_l = 1
    std::array<glm::vec4, SHPROBE_FOLDED_COUNT> irradiance{}; // s_l = A_l / pi
    std::array<glm::vec4, 4> l1{};                            // R0, R1.x, R1.y, R1.z per channel
    std::optional<SphericalLight> sun;                        // not in the coefficients; added analytically
    glsl::RenderSun foldedSun{};                              // direction.w = 0 without a sun
};

// Folds the first `order` bands (1..kMaxRenderOrder) of a radiance or irradiance probe. Radiance
// of an irradiance probe is E_lm / A_l, unknown where A_l = 0 (l = 3): hasRadiance is then false.
// Throws Error(Input) naming `name` when the probe has fewer bands than `order`, or when the sun
// is not a light (radius outside (0, 90] degrees, negative or non-finite radiance, no direction).
ProbeShading foldProbe(const ShCoefficients& probe, int order, const std::string& name,
                       const std::optional<SphericalLight>& sun = std::nullopt);

// Throws Error(Input) "NAME: its light is past the float range the shaders take (...)" where the
// shaders' float sums of these coefficients (each times a basis polynomial or a transfer entry)
// could pass float's range; foldProbe checks its own result so.
void requireFloatLight(const ShCoefficients& light, const std::string& name);

// The sun's uniforms: unit direction, radiance, and sin r, cos r, sin^2 r, 4 sin^2(r/2) from the
// double radius (sin^2(r/2) rather than 1 - cos r, which cancels for small r).
glsl::RenderSun foldSun(const SphericalLight& sun);

// Renormalized L0 and L1 of radiance (Geomerics' L1 notes), per channel:
// R0 = (1/4pi) int L, R1 = (1/4pi) int L w.
struct RenormalizedL1 {
    glm::dvec3 r0;
    glm::dvec3 r1[3]; // x, y, z components, each rgb
};
RenormalizedL1 renormalizedL1(const ShCoefficients& radiance);

// Double references of the shading modes at unit normal n, for a radiance probe of at least
// `order` bands (albedo 1; the shaders multiply irradiance modes by the albedo).
glm::dvec3 l1NonLinearOverPi(const ShCoefficients& radiance, const glm::dvec3& n);
glm::dvec3 shadeReference(const ShCoefficients& radiance, ShadingMode mode, int order, const glm::dvec3& n);

// E / L: the irradiance per unit radiance of a uniform cap of angular radius r (0 < r <= pi/2)
// at a normal whose cosine with the cap's centre is cosTheta, i.e. the projected solid angle of the
// part of the cap above the horizon: pi sin^2(r) cosTheta when all of it is above, 0 when all is
// below, and Snyder's closed form in between (see sun_light.h), evaluated as written in double.
double sphericalCapIrradiance(double cosTheta, double angularRadius);

// What the sun adds at unit normal n (albedo 1): E_sun(n) / pi in the irradiance modes, and in
// radiance mode the disc, its radiance within its angular radius of its direction (0 outside).
glm::dvec3 sunShadeReference(const SphericalLight& sun, ShadingMode mode, const glm::dvec3& n);

// Linear exposure that maps the probe's mean radiance (its L0 term, Rec. 709 luminance; plus the
// sun's power spread over the sphere, when it has one) to a mid grey; 1 for a probe without light.
float autoExposure(const ShCoefficients& probe, const std::optional<SphericalLight>& sun = std::nullopt);

} // namespace shprobe
