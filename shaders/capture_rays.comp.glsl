#version 450
// A probe's cube map by rays (ray_shading.glsl): each texel holds what arrives along the ray from the
// probe through its centre (the directions of sh/cubemap.h, as the raster capture and the cpu's
// one ray per texel see them), alpha SHPROBE_CAPTURE_BACK_FACE where that ray met the back of a
// one-sided material, as capture.frag writes it for recordProbeBake and count_back_faces.comp.
//
//   set 0: ray_capture_interface.h; SHPROBE_RAYS_INPUT: vec4 probes[] (xyz: position);
//          SHPROBE_RAYS_OUTPUT: rgba32f image2DArray, 6 layers per probe, in GENERAL;
//          SHPROBE_RAYS_DISTANCES: float distances[], each texel's hit distance, negative for a back
//          face of a one-sided material (visibility maps, relocation)
//   push constants: RayCaptureConstants (work.x: probes; work.z: 1 to reflect the cached bounce)
//   specialization: 0 = workgroup width; dispatch (texel groups, probes, 1): each invocation takes
//   texels x, x + width * groups, ... of probe y.
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
#include "ray_shading.glsl"
#include "texel_geometry.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(std430, set = 0, binding = SHPROBE_RAYS_INPUT) readonly buffer Probes {
    vec4 probes[];
};
layout(set = 0, binding = SHPROBE_RAYS_OUTPUT, rgba32f) uniform writeonly image2DArray cubemaps;
layout(std430, set = 0, binding = SHPROBE_RAYS_DISTANCES) writeonly buffer Distances {
    float distances[];
};

void main() {
    uint probe = gl_GlobalInvocationID.y;
    if (probe >= rc.work.x) return;
    uint n = rc.sizes.x;
    uint faceTexels = n * n;
    for (uint texel = gl_GlobalInvocationID.x; texel < 6u * faceTexels; texel += gl_NumWorkGroups.x * gl_WorkGroupSize.x) {
        uint face = texel / faceTexels;
        uint i = texel % faceTexels % n;
        uint j = texel % faceTexels / n;
        vec3 direction = normalize(unnormalizedFaceDirection(face, texelCenterCoord(i, n), texelCenterCoord(j, n)));
        RayArrival arrival = arriving(probes[probe].xyz, direction, rc.work.z != 0u);
        imageStore(cubemaps, ivec3(i, j, 6u * probe + face),
                   vec4(arrival.radiance, arrival.backFace ? SHPROBE_CAPTURE_BACK_FACE : 0.0));
        distances[6u * faceTexels * probe + texel] = arrival.backFace ? -arrival.distance : arrival.distance;
    }
}
