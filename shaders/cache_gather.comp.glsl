#version 450
// One bounce of the surface cache (scene/surface_cache.h, every point of every lattice): a point's
// irradiance E_k = pi times the mean of L_{k-1} over g x g cosine-distributed rays about its
// shading normal, one jittered in each stratum of the unit square, each reading what arrives
// (ray_shading.glsl: the surfaces reflecting the cache's E_{k-1}, or the sky).
//
//   set 0: ray_capture_interface.h; SHPROBE_RAYS_CACHE: E_{k-1}; SHPROBE_RAYS_INPUT:
//          CacheGatherPoint points[]; SHPROBE_RAYS_OUTPUT: vec4 gathered[] (rgb: E_k)
//   push constants: RayCaptureConstants (work.x points from work.y; work.z: 1 where k > 1;
//          work.w: g; seed.x: the seed, seed.y: k; pass: the rays of each point this dispatch
//          casts, `gathered` holding the sums between)
//   specialization: 0 = workgroup width; dispatch (groups, 1, 1): each invocation takes points
//   x, x + width * groups, ...
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
#include "ray_shading.glsl"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
layout(std430, set = 0, binding = SHPROBE_RAYS_INPUT) readonly buffer Points {
    CacheGatherPoint points[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_OUTPUT) buffer Gathered {
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
        uint first = rc.pass.x, end = rc.pass.x + rc.pass.y;
        vec3 sum = first == 0u ? vec3(0.0) : gathered[p].rgb;
        for (uint r = first; r < end; ++r) { // in stratum (r / g, r % g)
            float u1 = (float(r / g) + uniformAt(stream + 2u * r)) / float(g);
            float u2 = (float(r % g) + uniformAt(stream + 2u * r + 1u)) / float(g);
            sum += arriving(point.origin.xyz, cosineDirection(point.normal.xyz, u1, u2), rc.work.z != 0u).radiance;
        }
        gathered[p] = vec4(end < g * g ? sum : sum * (3.14159265358979 / float(g * g)), 0.0);
    }
}
