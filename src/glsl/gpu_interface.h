// Constants and push-constant blocks of the compute modules, shared by C++ and GLSL.
// Layouts are std430 (push constants) and are pinned by static_asserts in C++.
#ifndef SHPROBE_GPU_INTERFACE_H
#define SHPROBE_GPU_INTERFACE_H
#include "shared.h"

// Highest SH order (number of bands) the modules accept: order 8 is l <= 7, 64 coefficients.
#define SHPROBE_MAX_ORDER 8
#define SHPROBE_MAX_COEFFICIENTS (SHPROBE_MAX_ORDER * SHPROBE_MAX_ORDER)

// project.comp's shared memory for its reduction: the subgroup totals of ceil(512 / width)
// coefficients at a time, one vec3 per invocation of the workgroup (a subgroup of one is the worst case).
#define SHPROBE_REDUCTION_ENTRIES 512u

// Specialization constant ids, the same in every module that uses them.
#define SHPROBE_SPEC_LOCAL_SIZE 0 // workgroup width (x); 1D workgroups
#define SHPROBE_SPEC_ORDER 1      // SH order 1..SHPROBE_MAX_ORDER
#define SHPROBE_SPEC_VARIANT 2    // a module's own switch between code paths (0: its default)

SHPROBE_BEGIN

// Band l of flat SH index i = l(l+1) + m: the largest l with l^2 <= i. Integer only: a float sqrt
// may round a perfect square down on some devices.
SHPROBE_FN uint bandOfIndex(uint index) {
    uint l = 0u;
    while ((l + 1u) * (l + 1u) <= index)
        ++l;
    return l;
}

// project.comp: projects the N x N cube maps (N = faceSize) of the bound image, one probe per
// workgroup row; workgroup (g, p) writes its partial sums to slot p * gl_NumWorkGroups.x + g.
struct ProjectParams {
    uint faceSize;
};

// project_equirect.comp: projects the W x H equirect maps (W = width, H = height) of the bound
// image, one probe per workgroup row, into partial slots as project.comp does.
struct EquirectParams {
    uint width;
    uint height;
};

// reduce.comp: sums each probe's partialCount partial slots into its coefficient set.
struct ReduceParams {
    uint partialCount;
};

// convolve.comp: multiplies coefficient i of band l by bandScale[l] (A_l times an optional window)
// and writes it outputOffset vec4 into the output binding.
struct ConvolveParams {
    vec4 bandScale[SHPROBE_MAX_ORDER / 4];
    uint outputOffset;
};

// rotate.comp: rotates probeCount probes. Probe p uses the band matrices that start at float
// p * matrixStride of the matrix buffer (matrixStride = 0: one rotation for all probes).
struct RotateParams {
    uint probeCount;
    uint matrixStride;
};

// relight_volume.comp: relights probeCount probes of a probe volume; bandScale[l] is A_l.
struct RelightVolumeParams {
    vec4 bandScale[SHPROBE_MAX_ORDER / 4];
    uint probeCount;
};

SHPROBE_END

#ifdef __cplusplus
static_assert(sizeof(shprobe::glsl::ProjectParams) == 4);
static_assert(sizeof(shprobe::glsl::EquirectParams) == 8);
static_assert(sizeof(shprobe::glsl::ReduceParams) == 4);
static_assert(sizeof(shprobe::glsl::ConvolveParams) == 36);
static_assert(sizeof(shprobe::glsl::RotateParams) == 8);
static_assert(sizeof(shprobe::glsl::RelightVolumeParams) == 36);
#endif

#endif
