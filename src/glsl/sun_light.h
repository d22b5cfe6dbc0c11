// The sun of a probe file (`bake --extract-sun`), added analytically to what the SH probe of the
// rest gives, shared by C++ (tests run this very code in fp32) and GLSL (scene.frag, background.frag).
//
// The sun is a uniform cap: radiance L over the directions within angular radius r of its direction
// d (s = sin r, c = cos r). The irradiance it gives a surface of normal n is L times the projected
// solid angle of the part of the cap above the surface's horizon; with e = cos(theta) = n.d:
//   e >= s (the whole cap above the horizon):  E = pi L s^2 e
//   e <= -s (the whole cap below):             E = 0
//   otherwise (the horizon cuts the cap):      E = L (s^2 e acos(y) - x sin(theta) sqrt(1 - y^2) s^2
//                                                     + atan(sin(theta) sqrt(1 - y^2) / x)),
//                                              x = c / s, y = -x e / sin(theta),
// the exact irradiance of a spherical light (Snyder, "Area light sources for real-time graphics",
// Microsoft Research MSR-TR-96-11, 1996; in this form Lagarde & de Rousiers, "Moving Frostbite to
// PBR", SIGGRAPH 2014 course notes, sphere area lights). src/render/probe_shading.cpp
// evaluates it as written, in double, as the reference.
//
// As written it cancels catastrophically in fp32 for a small sun: its last two terms are each about
// s and their sum about s^3 (s^2 = 8e-5 for r = 0.5 degree, so 13 of fp32's 24 bits would be
// lost), and it needs acos and atan, which Vulkan only requires within 4096 ulps. With
// sin(theta) sqrt(1 - y^2) = w / s, w = sqrt(s^2 - e^2) = sqrt((s - e)(s + e)), the same value is
//   E = L (s^2 e atan2(w, -c e) + atan(t) - c w),  t = w / c,
// and atan(t) - c w = (atan(t) - t) + s^2 t, whose series -t^3/3 + t^5/5 - ... has no cancellation:
// every term is of order s^3, the size of the result. The arctangents are evaluated here from
// arithmetic and sqrt, to about an ulp (as texel_geometry.h does for texel weights).
#ifndef SHPROBE_SUN_LIGHT_H
#define SHPROBE_SUN_LIGHT_H
#include "precise_math.h"
#include "render_interface.h"

SHPROBE_BEGIN

// The angle of the vector (x, y) with y > 0 (or y >= 0 and x != 0), in [0, pi].
SHPROBE_FN float sunAtan2Upper(float y, float x) {
    const float kPi = 3.14159265358979f;
    if (x >= y) return preciseAtan(y / x);
    if (-x >= y) return kPi - preciseAtan(y / -x);
    float t = x / y; // |t| < 1
    return x >= 0.0f ? 0.5f * kPi - preciseAtan(t) : 0.5f * kPi + preciseAtan(-t);
}

// atan(t) - t for 0 <= t <= 0.5 by its series -t^3/3 + t^5/5 - ... to t^29 (t^2 <= 1/4: the first
// omitted term is below 4e-10 of the first).
SHPROBE_FN float sunAtanMinusIdentity(float t) {
    float t2 = t * t;
    float series = 1.0f / 29.0f;
    series = 1.0f / 27.0f - t2 * series;
    series = 1.0f / 25.0f - t2 * series;
    series = 1.0f / 23.0f - t2 * series;
    series = 1.0f / 21.0f - t2 * series;
    series = 1.0f / 19.0f - t2 * series;
    series = 1.0f / 17.0f - t2 * series;
    series = 1.0f / 15.0f - t2 * series;
    series = 1.0f / 13.0f - t2 * series;
    series = 1.0f / 11.0f - t2 * series;
    series = 1.0f / 9.0f - t2 * series;
    series = 1.0f / 7.0f - t2 * series;
    series = 1.0f / 5.0f - t2 * series;
    series = 1.0f / 3.0f - t2 * series;
    return -t * t2 * series;
}

// E / (pi L): the irradiance over pi per unit radiance of a cap of angular radius r at a normal
// whose cosine with the cap's centre is e. shape = RenderSun.shape: (s, c, s^2, _). A normal facing
// the sun gets s^2: the sun's peak E / pi is L sin^2(r).
SHPROBE_FN float sunCapIrradianceOverPi(float e, vec4 shape) {
    const float kPi = 3.14159265358979f;
    float s = shape.x, c = shape.y, s2 = shape.z;
    if (e >= s) return s2 * e;
    if (e <= -s) return 0.0f;
    float w = sqrt((s - e) * (s + e)); // > 0 here
    // atan(w / c) - c w, c = cos(r) >= 0 (r <= 90 degrees). Beyond t = w / c = 0.5 (radii above
    // 26.5 degrees) the direct difference loses at most a factor 1 / s^2 < 5 to cancellation.
    float tail = w <= 0.5f * c ? sunAtanMinusIdentity(w / c) + s2 * (w / c) : sunAtan2Upper(w, c) - c * w;
    return (s2 * e * sunAtan2Upper(w, -c * e) + tail) / kPi;
}

// What the sun adds at normal (or direction) n, by the shading mode (SHPROBE_SHADING_*):
// irradiance modes: albedo * E_sun(n) / pi; radiance mode: the sun's disc, its radiance where n is
// within the sun's angular radius of its direction (the squared chord |n - d|^2 <= 4 sin^2(r/2),
// which fp32 resolves for small radii where the cosine would not). Nothing without a sun.
SHPROBE_FN vec3 sunShading(RenderSun sun, uint shading, vec3 n, vec3 albedo) {
    if (sun.direction.w == 0.0f) return vec3(0.0f);
    vec3 d = vec3(sun.direction.x, sun.direction.y, sun.direction.z);
    vec3 radiance = vec3(sun.radiance.x, sun.radiance.y, sun.radiance.z);
    if (shading == SHPROBE_SHADING_RADIANCE) {
        vec3 chord = n - d;
        return dot(chord, chord) <= sun.shape.w ? radiance : vec3(0.0f);
    }
    return albedo * radiance * sunCapIrradianceOverPi(dot(n, d), sun.shape);
}

SHPROBE_END

#endif
