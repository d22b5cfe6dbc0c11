// What the transfer modules (shaders/transfer_direct.comp.glsl, transfer_bounce.comp.glsl) read,
// shared by C++ (gpu/transfer_rays.h, scene/transfer.h) and GLSL: the vertex sides the rays leave
// from, laid out as scene/transfer.cpp casts from them, and the scene's triangles and materials as
// a bounce reads them at a hit. Every struct is made of 16-byte vectors, so the std430 layouts equal
// the C++ ones, which static_asserts pin.
#ifndef SHPROBE_TRANSFER_INTERFACE_H
#define SHPROBE_TRANSFER_INTERFACE_H
#include "shared.h"

// TransferSide::ids.w bits.
#define SHPROBE_SIDE_BACK 1u   // the back side of a double-sided vertex: its normal is turned
#define SHPROBE_SIDE_UNUSED 2u // a vertex no triangle uses: it casts nothing and its transfer is 0

SHPROBE_BEGIN

// One vertex side: its g x g rays start at `origin` about `normal`, their jitter drawn from the
// splitmix64 stream whose state before the first draw is ids.xy (scene/sampling.h RandomStream).
struct TransferSide {
    vec4 origin; // xyz: moved off the surface as scene/transfer.h says; w: 0
    vec4 normal; // xyz: unit, turned for a back side; w: 0
    uvec4 ids;   // x, y: the random state's low and high 32 bits; z: the vertex; w: SHPROBE_SIDE_ bits
};

// A World triangle as a bounce reads it: its corners' vertices and its material.
struct TransferTriangle {
    uvec4 corners; // xyz: World vertex indices; w: material index
};

// A material's albedo: factor times its texture (none: -1) sampled bilinearly at TEXCOORD_0.
struct TransferMaterial {
    vec4 albedo;   // rgb: baseColorFactor; a: 0
    ivec4 texture; // x: texture index or -1; y: 1 double-sided; z, w: 0
};

// A texture's texels in the shared texel array: rows top to bottom, width * height from `first`.
struct TransferTexture {
    uvec4 extent; // x: first texel; y: width; z: height; w: 0
};

// transfer_direct.comp and transfer_bounce.comp: sides firstSide .. firstSide + sideCount - 1, each
// casting its rays firstRay .. firstRay + rayCount - 1 of g^2 (ray k in stratum (k / g, k % g)). A
// pass after a side's first carries on the sums the pass before left in the output; the last scales
// them.
struct TransferParams {
    uint firstSide;
    uint sideCount;
    uint nodeCount; // of the hierarchy (0: no triangles)
    uint strata;    // g: each side casts g x g rays
    uint firstRay;
    uint rayCount;
    uint unused[2];
};

SHPROBE_END

#ifdef __cplusplus
static_assert(sizeof(shprobe::glsl::TransferSide) == 48);
static_assert(sizeof(shprobe::glsl::TransferTriangle) == 16);
static_assert(sizeof(shprobe::glsl::TransferMaterial) == 32);
static_assert(sizeof(shprobe::glsl::TransferTexture) == 16);
static_assert(sizeof(shprobe::glsl::TransferParams) == 32);
#endif

#endif
