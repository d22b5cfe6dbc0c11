// The device's own read bound for `shprobe bench` (read_texels_rgba32f.comp, read_texels_rgba16f.comp):
// reads every texel exactly as the projection modules' storage variants do (same image, layers,
// positions, streams and order) and only sums them, so its speed is the most any projection
// reading the texels this way can reach on the device. Not part of the baking interface.
// With SHPROBE_BUFFER_TEXELS defined (read_texels_buffer_rgba32f.comp, ..._rgba16f.comp) the same
// texels, positions and order come from a storage buffer laid out as the layers are uploaded (layer
// after layer, rows tightly packed): whether the image or the walk holds the projection back.
//
//   set 0, binding 0: storage image2DArray cubemaps (cubemap_input.glsl), or the buffer: vec4
//                     texels[] (rgba32f) or uvec2 texels[] (rgba16f, four halves)
//   set 0, binding 1: buffer, vec4 sums[]: one per invocation (keeps the reads from being optimized away)
//   push constants: ProjectParams; dispatch (groups, probes, 1) as the projection
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_EXT_control_flow_attributes : require

#include "gpu_interface.h"
#include "position_walk.glsl"
#include "texel_geometry.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;

layout(set = 0, binding = 1, std430) writeonly buffer Sums { vec4 sums[]; };
layout(push_constant, std430) uniform Push { ProjectParams params; };

#ifdef SHPROBE_BUFFER_TEXELS
layout(set = 0, binding = 0, std430) readonly buffer Texels { SHPROBE_BUFFER_TEXELS texels[]; };
vec3 readRadiance(uint i, uint j, int layer) {
    uint index = (uint(layer) * params.faceSize + j) * params.faceSize + i;
#ifdef SHPROBE_BUFFER_HALVES
    uvec2 halves = texels[index];
    return vec3(unpackHalf2x16(halves.x), unpackHalf2x16(halves.y).x);
#else
    return texels[index].rgb;
#endif
}
#else
#include "cubemap_input.glsl"
#endif

void main() {
    uint faceSize = params.faceSize;
    uint quadrant = quadrantSize(faceSize);
    int firstLayer = int(gl_WorkGroupID.y) * 6;
    START_STREAM(quadrant)
    vec3 sum = vec3(0.0f);
    [[unroll]] for (int pair = 0; pair < 3; ++pair) {
        PositionWalk walk = startWalk(first, lanes, quadrant);
        for (uint position = first; position < end; position += lanes) {
            uint mirrorI = faceSize - 1u - walk.i, mirrorJ = faceSize - 1u - walk.j;
            [[unroll]] for (int face = 2 * pair; face < 2 * pair + 2; ++face) {
                int layer = firstLayer + face;
                sum += readRadiance(walk.i, walk.j, layer) + readRadiance(mirrorI, walk.j, layer) +
                       readRadiance(walk.i, mirrorJ, layer) + readRadiance(mirrorI, mirrorJ, layer);
            }
            stepWalk(walk, quadrant);
        }
    }
    sums[(gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationIndex] =
        vec4(sum, 0.0f);
}
