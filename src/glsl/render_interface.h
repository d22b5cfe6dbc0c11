// Constants, uniform blocks and push-constant blocks of the render modules (scene.vert,
// scene.frag, background.vert/.frag, tonemap.frag), shared by C++ and GLSL. The uniform block is
// std140 and the push constants std430; every struct is made of vec4/mat4 only, so both layouts
// equal the C++ one, which static_asserts pin.
#ifndef SHPROBE_RENDER_INTERFACE_H
#define SHPROBE_RENDER_INTERFACE_H
#include "shared.h"

// Folded coefficients the shaders hold: order 5 (bands 0..4), the highest order they evaluate.
#define SHPROBE_RENDER_MAX_ORDER 5
#define SHPROBE_FOLDED_COUNT 25

// Specialization constant ids of the render modules (id 1, SH order, as in gpu_interface.h).
#define SHPROBE_SPEC_RENDER_ORDER 1      // 3 or 5 (4 works too)
#define SHPROBE_SPEC_SHADING 2           // SHPROBE_SHADING_*
#define SHPROBE_SPEC_BACKGROUND 3        // SHPROBE_BACKGROUND_*
#define SHPROBE_SPEC_ENCODE_SRGB 4       // tonemap.frag: 1 = encode sRGB in the shader (UNORM target)
#define SHPROBE_SPEC_TRANSFER_CHANNELS 5 // relight.vert: 3 (RGB transfer) or 1 (grey)

// The transfer attributes (vec4, docs/transfer.md) relight.vert and relight_wide.vert declare, after
// the position: 15 fits Vulkan's guaranteed 16 vertex attributes, 31 a device with 32. A pipeline
// gives the ones a file does not have from a zero buffer (stride 0); the shader never reads them.
#define SHPROBE_RELIGHT_ATTRIBUTES 15
#define SHPROBE_RELIGHT_WIDE_ATTRIBUTES 31

// What a surface of normal n shows (scene.frag) and what the shading background shows.
#define SHPROBE_SHADING_RADIANCE 0     // the SH reconstruction of the radiance, L(n); no albedo
#define SHPROBE_SHADING_IRRADIANCE 1   // albedo * E(n) / pi from the order-3 or order-5 expansion
#define SHPROBE_SHADING_L1_NONLINEAR 2 // albedo * Geomerics' non-linear L1 model of E(n) / pi

// What pixels without a surface show (background.frag), along the view direction d.
#define SHPROBE_BACKGROUND_COLOR 0       // FrameUniforms.backgroundColor
#define SHPROBE_BACKGROUND_ENVIRONMENT 1 // the environment cube map
#define SHPROBE_BACKGROUND_RADIANCE 2    // the SH reconstruction of the radiance, L(d)
#define SHPROBE_BACKGROUND_SHADING 3     // what a surface of normal d would show (SHPROBE_SPEC_SHADING)

// Camera projections (FrameUniforms.camera.w).
#define SHPROBE_PROJECTION_PERSPECTIVE 0
#define SHPROBE_PROJECTION_PANORAMA 1 // every direction, equirect layout of docs/conventions.md

// The direction target's w: what the pixel's colour was evaluated from.
#define SHPROBE_DIRECTION_NONE 0.0     // background colour or environment texture
#define SHPROBE_DIRECTION_SHADING 1.0  // the shading function at normal xyz (surfaces, shading background)
#define SHPROBE_DIRECTION_RADIANCE 2.0 // the radiance reconstruction at direction xyz

SHPROBE_BEGIN

// A sun beside the probe (a probe file's "sun", from `bake --extract-sun`), added analytically by
// sun_light.h: a uniform cap of angular radius r.
struct RenderSun {
    vec4 direction; // xyz: unit, towards the sun; w: 1 when there is a sun, 0 when not (nothing is added)
    vec4 radiance;  // rgb: the radiance over its disc
    vec4 shape;     // sin r, cos r, sin^2 r, 4 sin^2(r/2) (the squared chord from the centre to the edge)
};

// Set 0, binding 0 (vertex and fragment stages). Written by the CPU before each frame.
struct RenderUniforms {
    mat4 viewProjection;        // world -> clip (Vulkan: y down, depth 0..1)
    mat4 inverseViewProjection; // clip -> world, for the background's view rays
    vec4 camera;                // xyz: camera position; w: SHPROBE_PROJECTION_*
    vec4 viewport;              // width, height, 1 / width, 1 / height (pixels)
    vec4 backgroundColor;       // rgb
    // Folded SH coefficients (rgb), see src/render/probe_shading.h: c_i = s_l k_i f_i, with k_i
    // the constant of the basis polynomial y_i = k_i p_i and s_l a per-band scale.
    vec4 radiance[SHPROBE_FOLDED_COUNT];   // s_l = 1: the radiance reconstruction L(d)
    vec4 irradiance[SHPROBE_FOLDED_COUNT]; // s_l = A_l / pi: E(n) / pi
    // Non-linear L1 model (Geomerics): [0].rgb = R0, [1..3].rgb = x, y, z of R1 per channel.
    vec4 l1[4];
    RenderSun sun;
};

// Push constants of scene.vert/scene.frag: one per drawn object.
struct ObjectConstants {
    mat4 model;  // object -> world; rotation, uniform scale and translation (normals use mat3(model))
    vec4 albedo; // rgb: Lambertian albedo
};

// Push constants of relight.vert / relight_wide.vert.
struct RelightConstants {
    mat4 clipFromWorld; // world -> clip (Vulkan: y down, depth 0..1)
};

// Push constants of tonemap.frag.
struct TonemapConstants {
    vec4 exposure; // x: linear scale applied before the curve
};

SHPROBE_END

#ifdef __cplusplus
#include <cstddef>
static_assert(sizeof(shprobe::glsl::RenderSun) == 48);
static_assert(sizeof(shprobe::glsl::RenderUniforms) ==
              64 * 2 + 16 * 3 + 16 * (2 * SHPROBE_FOLDED_COUNT + 4) + 48);
static_assert(offsetof(shprobe::glsl::RenderUniforms, sun) ==
              64 * 2 + 16 * 3 + 16 * (2 * SHPROBE_FOLDED_COUNT + 4));
static_assert(sizeof(shprobe::glsl::ObjectConstants) == 80);
static_assert(sizeof(shprobe::glsl::TonemapConstants) == 16);
static_assert(sizeof(shprobe::glsl::RelightConstants) == 64);
#endif

#endif
