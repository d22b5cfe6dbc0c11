// Bounces by paths (scene/ray_bake.cpp, BounceLight::Paths): a probe ray's hit continues in one
// cosine-distributed direction a bounce, the suns by shadow rays at every hit, and the emissive
// triangles by a point sampled on them (next-event estimation), weighted against the cosine rays'
// chance of meeting them by the power heuristic (Veach and Guibas, "Optimally Combining Sampling
// Techniques for Monte Carlo Rendering", 1995). The first bounce of the view's ray k leaves by point
// k of the probe's shifted R2 sequence, deeper bounces and the emitters' points by the ray's own
// stream. Declares capture_rays' emitter bindings (ray_capture_interface.h).
#ifndef SHPROBE_RAY_PATHS_GLSL
#define SHPROBE_RAY_PATHS_GLSL
#include "random_words.h"
#include "ray_shading.glsl"

layout(std430, set = 0, binding = SHPROBE_RAYS_EMITTERS) readonly buffer Emitters {
    EmitterTriangle emitters[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_EMITTER_DENSITIES) readonly buffer EmitterDensities {
    float emitterDensities[];
};

#define INV_PI 0.318309886183791

// The random numbers of one probe ray's path.
struct PathRandom {
    uvec2 firstBounce; // the R2 point, times 2^32
    uvec2 state;       // the ray's stream (random_words.h)
};

// View ray k of a probe: point k of its R2 sequence (the step and shift in 32-bit fixed point, so
// that wrapping sums are the sequence's fractional parts), and a stream of its own, the probe's
// continued by k as a texel's view stream is.
PathRandom probeRayRandom(uvec4 probePaths, uint k) {
    return PathRandom(probePaths.zw + k * rc.paths.zw, mix64Words(add64(probePaths.xy, uvec2(k, 0u))));
}

// A 32-bit fixed-point number's top 24 bits: in [0, 1) as a float.
vec2 unitOfFixed(uvec2 fixedPoint) {
    return vec2(fixedPoint >> 8u) * (1.0 / 16777216.0);
}

// emitters.h powerHeuristic, as a ratio that no density's square overflows.
float powerHeuristic(float chosen, float other) {
    if (!(chosen > 0.0)) return 0.0;
    float ratio = other / chosen;
    return 1.0 / (1.0 + ratio * ratio);
}

// The emitter whose running sum first passes u0 (EmitterSampler::sample's upper_bound), the last
// one where rounding leaves none.
uint pickedEmitter(float u0) {
    uint low = 0u, high = rc.paths.y - 1u;
    while (low < high) {
        uint middle = (low + high) / 2u;
        if (emitters[middle].cumulative > u0) high = middle;
        else low = middle + 1u;
    }
    return emitters[low].triangle;
}

// The emitters' irradiance at `at` from one point sampled on them (scene/ray_bake.cpp
// emitterIrradiance): L_e max(0, n.w) / p(w) where a shadow ray reaches the point, p its density per
// solid angle, weighted by the power heuristic against the cosine rays' density.
vec3 emitterIrradiance(RaySurface at, inout uvec2 random) {
    if (rc.paths.y == 0u) return vec3(0.0);
    float u0 = nextRandom(random);
    float u1 = nextRandom(random);
    float u2 = nextRandom(random);
    uint triangle = pickedEmitter(u0);
    float root = sqrt(u1);
    vec2 barycentric = vec2(root * (1.0 - u2), root * u2);
    vec3 p0 = vertices[indices[3u * triangle]].positionU.xyz;
    vec3 p1 = vertices[indices[3u * triangle + 1u]].positionU.xyz;
    vec3 p2 = vertices[indices[3u * triangle + 2u]].positionU.xyz;
    vec3 point = (1.0 - barycentric.x - barycentric.y) * p0 + barycentric.x * p1 + barycentric.y * p2;
    vec3 toLight = point - at.leaving;
    float distance = length(toLight);
    if (!(distance > 0.0)) return vec3(0.0);
    vec3 direction = toLight / distance;
    float cosine = dot(at.shading, direction);
    if (!(cosine > 0.0)) return vec3(0.0);
    RaySurface light = describeSurface(triangle, barycentric, direction);
    float lightCosine = abs(dot(light.normal, direction));
    if (oneSidedBack(light) || !(lightCosine > 0.0)) return vec3(0.0);
    if (bvhAnyHit(rc.sizes.w, at.leaving, direction, 0.0, distance - 2.0 * rc.scale.x)) return vec3(0.0);
    float density = emitterDensities[triangle] * distance * distance / lightCosine;
    float weight = powerHeuristic(density, cosine * INV_PI);
    return surfaceEmission(light.material, light.uv) * (cosine / density * weight);
}

// The share of an emitter's light a path's bounce keeps where it meets it at `distance`: the power
// heuristic against the emitters' own sampling (emitterIrradiance), which finds the same light too.
float emissionShare(uint triangle, RaySurface met, vec3 direction, float distance, float cosineDensity) {
    float area = emitterDensities[triangle];
    float cosine = abs(dot(met.normal, direction));
    if (!(area > 0.0) || !(cosine > 0.0)) return 1.0;
    return powerHeuristic(cosineDensity, area * distance * distance / cosine);
}

// What arrives at `origin` along a probe's ray, the light its hit leaves followed as a path of
// rc.paths.x bounces: at each hit emission (its share) and the suns reflected, then, while bounces
// are left and the surface reflects, the emitters' point and the next cosine direction, whose
// density cancels the cosine (the throughput gains the albedo alone).
RayArrival pathArriving(vec3 origin, vec3 direction, PathRandom random) {
    BvhHit hit;
    if (!bvhClosestHitFrontFirst(rc.sizes.w, origin, direction, 0.0, RAY_FAR, hit))
        return RayArrival(skyTexel(direction, rc.sizes.y), false, RAY_FAR);
    RaySurface surface = describeSurface(hit.triangle, vec2(hit.u, hit.v), direction);
    if (oneSidedBack(surface)) return RayArrival(vec3(0.0), true, hit.t);
    float distance = hit.t;
    vec3 radiance = vec3(0.0);
    vec3 throughput = vec3(1.0);
    float share = 1.0;
    for (uint bounce = rc.paths.x;; --bounce) {
        vec3 reflectance = surfaceAlbedo(surface.material, surface.uv) * INV_PI;
        radiance += throughput * (share * surfaceEmission(surface.material, surface.uv) +
                                  reflectance * sunIrradiance(surface.leaving, surface.shading));
        if (bounce == 0u || reflectance == vec3(0.0)) break;
        radiance += throughput * reflectance * emitterIrradiance(surface, random.state);
        vec2 u = bounce == rc.paths.x ? unitOfFixed(random.firstBounce)
                                      : vec2(nextRandom(random.state), nextRandom(random.state));
        vec3 next = cosineDirection(surface.shading, u.x, u.y);
        float density = max(dot(surface.shading, next), 0.0) * INV_PI;
        throughput *= reflectance * 3.14159265358979;
        if (!bvhClosestHitFrontFirst(rc.sizes.w, surface.leaving, next, 0.0, RAY_FAR, hit)) {
            radiance += throughput * skyTexel(next, rc.sizes.y);
            break;
        }
        RaySurface met = describeSurface(hit.triangle, vec2(hit.u, hit.v), next);
        if (oneSidedBack(met)) break;
        share = emissionShare(hit.triangle, met, next, hit.t, density);
        surface = met;
    }
    return RayArrival(radiance, false, distance);
}

#endif
