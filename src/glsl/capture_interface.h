// Buffers and push constants of the scene capture (capture.vert, capture.frag, capture_sky.frag),
// shared by C++ and GLSL: the world's triangles, materials and textures, the sky, and the volume of
// the previous bounce, each in a storage buffer (std430; every struct is made of 16-byte vectors,
// so the layouts equal the C++ ones, which static_asserts pin). The transport the shaders follow
// is src/scene/scene.h's.
#ifndef SHPROBE_CAPTURE_INTERFACE_H
#define SHPROBE_CAPTURE_INTERFACE_H
#include "shared.h"

// Storage-buffer bindings of set 0.
#define SHPROBE_CAPTURE_VERTICES 0  // CaptureVertex[]
#define SHPROBE_CAPTURE_INDICES 1   // uint[]: three per triangle
#define SHPROBE_CAPTURE_TRIANGLES 2 // uint[]: each triangle's material
#define SHPROBE_CAPTURE_MATERIALS 3 // CaptureMaterial[]
#define SHPROBE_CAPTURE_TEXTURES 4  // CaptureTexture[]
#define SHPROBE_CAPTURE_TEXELS 5    // vec4[]: every texture's linear RGBA, rows top to bottom
#define SHPROBE_CAPTURE_SKY 6       // vec4[]: the sky cube map, 6 faces of N x N (sh/cubemap.h order)
#define SHPROBE_CAPTURE_VOLUME 7    // CaptureVolumeHeader, then vec4 coefficients
#define SHPROBE_CAPTURE_SUNS 8      // CaptureSun[]
#define SHPROBE_CAPTURE_SHADOWS 9   // float[]: each sun's shadow map, rows top to bottom
#define SHPROBE_CAPTURE_BINDINGS 10

// What the capture writes in alpha: 1 where the texel sees the back of a one-sided surface (the
// probe is inside something), 0 elsewhere. The bake ignores alpha; the validity count reads it.
#define SHPROBE_CAPTURE_BACK_FACE 1.0

SHPROBE_BEGIN

struct CaptureVertex {
    vec4 positionU; // world position, and TEXCOORD_0's u
    vec4 normalV;   // world normal (unit), and TEXCOORD_0's v
};

struct CaptureMaterial {
    vec4 albedo;   // rgb: factor; w: texture index, or -1
    vec4 emission; // rgb: factor; w: texture index, or -1
    vec4 sides;    // x: 1 when double-sided
};

struct CaptureTexture {
    uvec4 extent; // x: first texel in SHPROBE_CAPTURE_TEXELS, y: width, z: height
};

// The volume the previous bounce baked (grid of scene/probe_grid.h: probe (i, j, k) at
// boundsMin + (boundsMax - boundsMin) * (i, j, k) / (counts - 1), an axis of one probe at the
// centre), followed by order^2 vec4 per probe in flat order i + nx (j + ny k): the irradiance
// coefficients' rgb, and w = 1 for a valid probe, 0 for one inside geometry; then, where the
// volume holds visibility, each probe's size^2 texels of (mean, mean square) distance, two to a
// vec4 (xy, zw); then, where it holds capture offsets, one vec4 per probe (xyz: the offset from its
// grid position where it was captured).
struct CaptureVolumeHeader {
    vec4 boundsMin;   // xyz
    vec4 boundsMax;   // xyz
    uvec4 counts;     // xyz: probes per axis; w: 0 when there is no previous bounce
    uvec4 visibility; // x: texels a side of each probe's map, 0: none; y: the maps' first vec4;
                      // z: the capture offsets' first vec4, 0: none (all zero)
};

// A sun (scene/scene.h) and its shadow map: the depth, seen from the sun (orthographic, over the
// world's box), of the surface nearest to the sun, larger nearer to it.
struct CaptureSun {
    mat4 worldToShadow; // x, y: map coordinates in [0, 1]; z: depth in [0, 1]
    vec4 direction;     // xyz: unit, towards the sun
    vec4 irradiance;    // rgb: on a surface facing the sun
    vec4 scale;         // x: the world size of a map texel; y: depth per world unit
    uvec4 map;          // x: first depth in SHPROBE_CAPTURE_SHADOWS, y: the map's size (square)
};

// CaptureConstants.face.x of a camera's view (renderSceneView) rather than a probe's face.
#define SHPROBE_CAPTURE_CAMERA 6u

// Push constants: one face of one probe, or a camera's view.
struct CaptureConstants {
    mat4 worldToClip; // the face's projection, with reversed depth (near plane at depth 1)
    vec4 probe;       // xyz: the probe's (or camera's) position; w: the probes' sphere radius
    uvec4 face;       // x: face 0..5 (sh/cubemap.h order), y: capture face size, z: sky face size,
                      // w: sun count
    vec4 view;        // xy: a camera's view's size in pixels; z: 1 to draw back faces a little
                      // farther (captures and views, capture.vert), 0 for the shadow maps
};

SHPROBE_END

#ifdef __cplusplus
static_assert(sizeof(shprobe::glsl::CaptureVertex) == 32);
static_assert(sizeof(shprobe::glsl::CaptureMaterial) == 48);
static_assert(sizeof(shprobe::glsl::CaptureTexture) == 16);
static_assert(sizeof(shprobe::glsl::CaptureVolumeHeader) == 64);
static_assert(sizeof(shprobe::glsl::CaptureConstants) == 112); // within the 128 bytes every device has
static_assert(sizeof(shprobe::glsl::CaptureSun) == 128);
#endif

#endif
