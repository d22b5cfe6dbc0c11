#version 450
// A probe's cube map by rays (ray_shading.glsl): each texel holds the mean of what arrives along its
// s x s rays from the probe (scene/view_rays.h: through its centre where s is 1, the directions of
// sh/cubemap.h as the raster capture sees them; else one jittered in each stratum, the cpu's rays),
// alpha SHPROBE_CAPTURE_BACK_FACE where most of them met the back of a one-sided material, as
// capture.frag writes it for recordProbeBake and count_back_faces.comp. Bounces come from the cache,
// or from each ray's hit continued as a path (ray_paths.glsl), the paths numbered as the cpu numbers
// them (sobol_words.h firstTexelPath): face by face along a Morton curve over the texels, each
// texel's s^2 rays in a row, so that neighbouring rays' bounces are stratified together.
//
//   set 0: ray_capture_interface.h; SHPROBE_RAYS_INPUT: RayProbe probes[];
//          SHPROBE_RAYS_OUTPUT: rgba32f image2DArray, 6 layers per probe, in GENERAL;
//          SHPROBE_RAYS_DISTANCES: float distances[], each ray's hit distance, negative for a back
//          face of a one-sided material (visibility maps, relocation); SHPROBE_RAYS_PICKS and
//          SHPROBE_RAYS_PICK_DENSITIES: the paths' emitters and sky texels; SHPROBE_RAYS_STRATUM_SKY:
//          the shadow rays to the sky each stratum adds and SHPROBE_RAYS_CASTING_TEXELS: the texels
//          whose strata add any (the variant's SHPROBE_RAYS_STRATUM_SKY_RAYS);
//          SHPROBE_RAYS_SUNLIT_CELLS and SHPROBE_RAYS_SUNLIT_PLANES: the paths' suns' rays into the world
//   push constants: RayCaptureConstants (work.x: probes; work.z: 1 to reflect the cached bounce;
//          work.w: s; seed.zw: the view's stream base; paths: the bounces by paths and their tables;
//          pass: the rays of each texel this dispatch casts, the output holding the sums between;
//          with SHPROBE_RAYS_STRATUM_SKY_RAYS, sky passes (pass.w > 0) go before the view's)
//   specialization: 0 = workgroup width, 2 = the variant's bits (SHPROBE_RAYS_BY_PATHS for bounces by
//   paths, SHPROBE_RAYS_STRATUM_SKY_RAYS where strata cast rays to the sky); dispatch (texel groups,
//   probes, 1): each invocation takes
//   texels x, x + width * groups, ... of probe y (a sky pass: entries of SHPROBE_RAYS_CASTING_TEXELS).
#extension GL_GOOGLE_include_directive : require
#include "gpu_interface.h"
#include "random_words.h"
#include "ray_paths.glsl"
#include "sobol_words.h"
#include "texel_geometry.h"

layout(local_size_x_id = SHPROBE_SPEC_LOCAL_SIZE) in;
// Bounces by paths, or from the cache (or none): a pipeline of each, so that the other's code is not
// compiled in (lavapipe ran the bounce-0 capture at half speed with both behind a branch).
layout(constant_id = SHPROBE_SPEC_VARIANT) const uint kVariant = 0u;
const bool kByPaths = (kVariant & SHPROBE_RAYS_BY_PATHS) != 0u;
const bool kStratumSky = (kVariant & SHPROBE_RAYS_STRATUM_SKY_RAYS) != 0u;
layout(std430, set = 0, binding = SHPROBE_RAYS_INPUT) readonly buffer Probes {
    RayProbe probes[];
};
layout(set = 0, binding = SHPROBE_RAYS_OUTPUT, rgba32f) uniform image2DArray cubemaps;
layout(std430, set = 0, binding = SHPROBE_RAYS_DISTANCES) writeonly buffer Distances {
    float distances[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_STRATUM_SKY) readonly buffer StratumSky {
    uint stratumSkyRays[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_CASTING_TEXELS) readonly buffer CastingTexels {
    uint castingTexels[];
};

// What shadow rays [rc.pass.z, rc.pass.z + rc.pass.w) of stratum `stratum` of texel (i, j) of `face`
// add to its sky (scene/ray_bake.cpp skyThroughStratum: the mean of what the view's ray and the
// `count` shadow rays see), a sum that sky passes build a few rays at a time. The rays are uniform in
// the stratum on its face, at the points of the stratum's own Owen-scrambled Sobol' set, named by
// mix64(mix64(probe seed + SHPROBE_STRATUM_SKY_USE) + path).
vec3 skyThroughStratum(RayProbe at, uint face, uint i, uint j, uvec2 stratum, uint count, uint path) {
    uint n = rc.sizes.x, s = rc.work.w;
    uvec2 set = mix64Words(add64(mix64Words(add64(at.paths.xy, uvec2(SHPROBE_STRATUM_SKY_USE, 0u))), uvec2(path, 0u)));
    vec3 sky = vec3(0.0);
    for (uint e = rc.pass.z; e < min(count, rc.pass.z + rc.pass.w); ++e) {
        vec2 u = vec2(owenScrambledSobolWords(e, set, false) >> 8u) * (1.0 / 16777216.0);
        vec3 direction = normalize(unnormalizedFaceDirection(face, stratumCoord(i, stratum.x, s, u.x, n),
                                                             stratumCoord(j, stratum.y, s, u.y, n)));
        if (!bvhAnyHit(rc.sizes.w, at.position.xyz, direction, 0.0, RAY_FAR)) sky += skyTexel(direction, rc.sizes.y);
    }
    return sky / float(count + 1u);
}

// What a sky pass adds to texel (i, j) of `face`: the shares of its strata [rc.pass.y,
// rc.pass.y + SHPROBE_SKY_STRATA_PER_PASS) (skyThroughStratum), their paths numbered as the view's rays.
vec3 texelSkyPass(RayProbe at, uint face, uint i, uint j) {
    uint n = rc.sizes.x, s = rc.work.w;
    uint firstPath = firstTexelPath(face, i, j, n, s * s);
    vec3 sum = vec3(0.0);
    for (uint r = rc.pass.y; r < min(s * s, rc.pass.y + SHPROBE_SKY_STRATA_PER_PASS); ++r) {
        uint count = stratumSkyRays[stratumIndex(face, i, j, r % s, r / s, n, s)];
        if (count > rc.pass.z)
            sum += skyThroughStratum(at, face, i, j, uvec2(r % s, r / s), count, firstPath + r);
    }
    return sum;
}

// A sky pass over the first rc.pass.x texels of castingTexels, each invocation taking entries x,
// x + width * groups, ... for probe `probe`; the first (strata and rays from 0) starts their sums.
void skyPass(uint probe, RayProbe at) {
    uint faceTexels = rc.sizes.x * rc.sizes.x;
    for (uint k = gl_GlobalInvocationID.x; k < rc.pass.x; k += gl_NumWorkGroups.x * gl_WorkGroupSize.x) {
        uint texel = castingTexels[k], face = texel / faceTexels;
        uint i = texel % faceTexels % rc.sizes.x, j = texel % faceTexels / rc.sizes.x;
        ivec3 at3 = ivec3(i, j, 6u * probe + face);
        vec4 soFar = rc.pass.y == 0u && rc.pass.z == 0u ? vec4(0.0) : imageLoad(cubemaps, at3);
        imageStore(cubemaps, at3, soFar + vec4(texelSkyPass(at, face, i, j), 0.0));
    }
}

// Whether the sky passes left sums in texel (i, j) of `face`: where any of its strata casts shadow rays.
bool castsToTheSky(uint face, uint i, uint j) {
    uint s = rc.work.w;
    for (uint r = 0u; r < s * s; ++r)
        if (stratumSkyRays[stratumIndex(face, i, j, r % s, r / s, rc.sizes.x, s)] > 0u) return true;
    return false;
}

void main() {
    uint probe = gl_GlobalInvocationID.y;
    if (probe >= rc.work.x) return;
    uint n = rc.sizes.x;
    uint s = rc.work.w;
    uint faceTexels = n * n;
    RayProbe at = probes[probe];
    if (kStratumSky && rc.pass.w > 0u) {
        skyPass(probe, at);
        return;
    }
    for (uint texel = gl_GlobalInvocationID.x; texel < 6u * faceTexels; texel += gl_NumWorkGroups.x * gl_WorkGroupSize.x) {
        uint face = texel / faceTexels;
        uint i = texel % faceTexels % n;
        uint j = texel % faceTexels / n;
        ivec3 at3 = ivec3(i, j, 6u * probe + face);
        // The pass's rays r of the texel's s^2, in stratum (r % s, r / s), two draws each before them.
        uint first = rc.pass.x, end = rc.pass.x + rc.pass.y;
        uvec2 stream = skipRandomStates(mix64Words(add64(rc.seed.zw, uvec2(texel, 0u))), 2u * first);
        uint viewRay = texel * s * s + first; // the ray's index in the probe's view (scene/view_rays.h's order)
        uint firstRay = 6u * faceTexels * s * s * probe;
        uint path = firstTexelPath(face, i, j, n, s * s) + first;
        // rgb: the sum; a: back faces.
        bool carried = first > 0u || kStratumSky && castsToTheSky(face, i, j);
        vec4 soFar = carried ? imageLoad(cubemaps, at3) : vec4(0.0);
        vec3 sum = soFar.rgb;
        uint backFaces = uint(soFar.a);
        for (uint r = first; r < end; ++r) {
            uint sa = r % s, sb = r / s;
            float ja = s == 1u ? 0.5 : nextRandom(stream);
            float jb = s == 1u ? 0.5 : nextRandom(stream);
            vec3 direction = normalize(unnormalizedFaceDirection(face, stratumCoord(i, sa, s, ja, n),
                                                                 stratumCoord(j, sb, s, jb, n)));
            PathNumbers numbers = PathNumbers(at.paths.xy, path++);
            RayArrival arrival = kByPaths ? pathArriving(at.position.xyz, direction, numbers)
                                          : arriving(at.position.xyz, direction, rc.work.z != 0u);
            // An escaped ray is one of its stratum's count + 1 looks at the sky; the sky passes cast the rest.
            if (kStratumSky && arrival.distance == RAY_FAR)
                arrival.radiance /= float(stratumSkyRays[stratumIndex(face, i, j, sa, sb, n, s)] + 1u);
            sum += arrival.radiance;
            backFaces += arrival.backFace ? 1u : 0u;
            distances[firstRay + viewRay++] = arrival.backFace ? -arrival.distance : arrival.distance;
        }
        if (end < s * s) {
            imageStore(cubemaps, at3, vec4(sum, float(backFaces)));
            continue;
        }
        bool mostlyBack = 2u * backFaces > s * s;
        imageStore(cubemaps, at3, vec4(sum / float(s * s), mostlyBack ? SHPROBE_CAPTURE_BACK_FACE : 0.0));
    }
}
