// Texel positions (i, j) of a grid C positions wide (N x N for faces) visited with a fixed stride
// through the flat index j C + i, shared by the modules that stride over images (gridSize below is
// C). The row and column follow the index without a division per step (a vector integer division is
// a loop of scalar ones on CPUs).
#ifndef SHPROBE_POSITION_WALK_GLSL
#define SHPROBE_POSITION_WALK_GLSL
#include "dispatch_plan.h"

struct PositionWalk {
    uint i, j;                    // the current position
    uint strideRows, strideColumns; // the stride as whole rows plus columns
};

PositionWalk startWalk(uint first, uint stride, uint gridSize) {
    uint j = first / gridSize;
    uint rows = stride / gridSize;
    return PositionWalk(first - j * gridSize, j, rows, stride - rows * gridSize);
}

void stepWalk(inout PositionWalk walk, uint gridSize) {
    walk.i += walk.strideColumns;
    walk.j += walk.strideRows;
    if (walk.i >= gridSize) {
        walk.i -= gridSize;
        ++walk.j;
    }
}

// The positions one invocation of a 1D dispatch takes out of a grid of positions (project.comp's is
// a quarter of the face, quadrantSize in texel_geometry.h, N x N: START_STREAM(N);
// project_equirect.comp's is C x R, equirect_geometry.h: START_STREAM_OF(C * R)): `lanes` neighbouring
// invocations (a stream) take neighbouring positions side by side and walk forward together
// through one contiguous range, [first, end) in steps of `lanes`. That is what GPU memory coalescing
// wants, and what CPU prefetchers want under llvmpipe, which runs one subgroup's whole loop before
// the next subgroup's (three times faster than a grid-wide stride). The width is a power of two
// that divides the workgroup and is the same in every invocation of the dispatch (gl_SubgroupSize
// is, in these SPIR-V 1.3 modules without varying subgroup sizes), so the streams cover every
// position once whatever the hardware's subgroups really are. Each invocation walks at most
// positionsPerInvocation positions (dispatch_plan.h), the number the dispatch plan bounds.
// The includer enables GL_KHR_shader_subgroup_basic.
// Workaround(llvmpipe, Mesa 22.3): START_STREAM is a macro declaring `first`, `end` and `lanes`
// where it is used: computed in a function, returned in a struct or through out parameters, they
// come out wrong on llvmpipe (test_gpu caught it at order 8 with many positions per invocation).
// Elsewhere a function returning a struct would do; test_gpu at order 8 tells whether a driver
// needs the macro.
#define START_STREAM(gridSize) START_STREAM_OF((gridSize) * (gridSize))
#define START_STREAM_OF(positionCount)                                                           \
    uint lanes = min(gl_SubgroupSize, gl_WorkGroupSize.x & (~gl_WorkGroupSize.x + 1u));          \
    uint streamPositions = (positionCount);                                                      \
    uint perInvocation = positionsPerInvocation(streamPositions, gl_NumWorkGroups.x, gl_WorkGroupSize.x); \
    uint stream = gl_GlobalInvocationID.x / lanes;                                               \
    uint first = stream * lanes * perInvocation + gl_GlobalInvocationID.x % lanes;               \
    uint end = min((stream + 1u) * lanes * perInvocation, streamPositions);

#endif
