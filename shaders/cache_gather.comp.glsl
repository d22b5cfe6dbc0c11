#version 450
// One bounce of the surface cache (scene/surface_cache.h, every point of every lattice): a point's
// irradiance E_k = pi times the mean of L_{k-1} over g x g cosine-distributed rays about its
// shading normal, one jittered in each stratum of the unit square, each reading what arrives
// (ray_shading.glsl: the surfaces reflecting the cache's E_{k-1}, or the sky).
//
//   set 0: ray_capture_interface.h; SHPROBE_RAYS_CACHE: E_{k-1}; SHPROBE_RAYS_INPUT:
//          CacheGatherPoint points[]; SHPROBE_RAYS_OUTPUT: vec4 gathered[] (rgb: E_k)
//   push constants: RayCaptureConstants (work.x points from work.y; work.z: 1 where k > 1;
//          work.w: g; seed.x: the seed, seed.y: k)
//   specialization: 0 = workgroup width; dispatch (groups, 1, 1): each invocation takes points
//   x, x + width * groups, ...
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
#include "ray_shading.glsl"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(std430, set = 0, binding = SHPROBE_RAYS_INPUT) readonly buffer Points {
    CacheGatherPoint points[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_OUTPUT) writeonly buffer Gathered {
    vec4 gathered[];
};

// Jarzynski and Olano, "Hash Functions for GPU Rendering" (JCGT 2020): the PCG hash, whose output
// bits pass the statistical tests the paper applies; the random numbers of a point's rays are named
// by (seed, bounce, point, ray), so no thread's order changes them.
uint pcgHash(uint value) {
    uint state = value * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1): 24 bits.
float uniformAt(uint key) {
    return float(pcgHash(key) >> 8u) * (1.0 / 16777216.0);
}

void main() {
    uint g = rc.work.w;
    for (uint k = gl_GlobalInvocationID.x; k < rc.work.x; k += gl_NumWorkGroups.x * gl_WorkGroupSize.x) {
        uint p = rc.work.y + k;
        CacheGatherPoint point = points[p];
        if (point.normal.xyz == vec3(0.0)) { // of a zero-area triangle, which no ray meets
            gathered[p] = vec4(0.0);
            continue;
        }
        uint stream = pcgHash(pcgHash(rc.seed.x + pcgHash(rc.seed.y)) + p);
        vec3 sum = vec3(0.0);
        for (uint a = 0u; a < g; ++a) {
            for (uint b = 0u; b < g; ++b) {
                uint ray = 2u * (a * g + b);
                float u1 = (float(a) + uniformAt(stream + ray)) / float(g);
                float u2 = (float(b) + uniformAt(stream + ray + 1u)) / float(g);
                sum += arriving(point.origin.xyz, cosineDirection(point.normal.xyz, u1, u2), rc.work.z != 0u).radiance;
            }
        }
        gathered[p] = vec4(sum * (3.14159265358979 / float(g * g)), 0.0);
    }
}
