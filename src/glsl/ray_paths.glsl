// Bounces by paths (scene/ray_bake.cpp, BounceLight::Paths): a probe ray's hit continues in one
// cosine-distributed direction a bounce, the suns by shadow rays at every hit, the emissive
// triangles by a point sampled on them and the sky by a direction sampled towards its bright texels
// (next-event estimation), each weighted against the cosine rays' chance of meeting the same light
// by the power heuristic (Veach and Guibas, "Optimally Combining Sampling Techniques for Monte Carlo
// Rendering", 1995). Every number of a path is the cpu's: point k of the probe's Owen-scrambled
// Sobol' sets for its view ray k (ProbePaths), to a float's 24 bits. Declares capture_rays'
// next-event bindings (ray_capture_interface.h).
#ifndef SHPROBE_RAY_PATHS_GLSL
#define SHPROBE_RAY_PATHS_GLSL
#include "ray_shading.glsl"
#include "sobol_words.h"
#include "texel_geometry.h"

layout(std430, set = 0, binding = SHPROBE_RAYS_PICKS) readonly buffer Picks {
    PickedIndex picks[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_PICK_DENSITIES) readonly buffer PickDensities {
    float pickDensities[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_SUNLIT_CELLS) readonly buffer SunlitCells {
    float sunlitCells[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_SUNLIT_PLANES) readonly buffer SunlitPlanes {
    SunlitPlane sunlitPlanes[];
};

#define INV_PI 0.318309886183791

// The numbers of one probe ray's path (scene/ray_bake.cpp ProbePaths): point `ray` of the
// Owen-scrambled Sobol' sets named by mix64(seed + use), four uses a bounce level: the direction
// (shuffled below the first level), the emitter's and the sky texel's picks, the point on the
// emitter, the point in the texel.
struct PathNumbers {
    uvec2 seed; // the probe's (view_rays.h probePathSeed), words (low, high)
    uint ray;
};

#define SETS_PER_BOUNCE 4u

// Set `use`'s point, its top 24 bits in [0, 1) as floats.
vec2 pathSet(PathNumbers numbers, uint use, bool shuffled) {
    uvec2 set = mix64Words(add64(numbers.seed, uvec2(use, 0u)));
    uvec2 point = owenScrambledSobolWords(numbers.ray, set, shuffled);
    return vec2(point >> 8u) * (1.0 / 16777216.0);
}

// The unit square's point for the direction at bounce `level` (0: the first), unshuffled there so
// that neighbouring rays' first bounces keep their stratification.
vec2 bounceNumbers(PathNumbers numbers, uint level) {
    return pathSet(numbers, SETS_PER_BOUNCE * level, level > 0u);
}

// Three numbers for the point on the emitters (EmitterSampler::sample).
vec3 emitterNumbers(PathNumbers numbers, uint level) {
    return vec3(pathSet(numbers, SETS_PER_BOUNCE * level + 1u, true).x,
                pathSet(numbers, SETS_PER_BOUNCE * level + 2u, true));
}

// Three numbers for the direction towards the sky (SkySampler::sample).
vec3 skyNumbers(PathNumbers numbers, uint level) {
    return vec3(pathSet(numbers, SETS_PER_BOUNCE * level + 1u, true).y,
                pathSet(numbers, SETS_PER_BOUNCE * level + 3u, true));
}

// Three numbers for the sun's ray into the world (SunlitSampler::sample).
vec3 sunlitNumbers(PathNumbers numbers, uint level) {
    return vec3(pathSet(numbers, SHPROBE_SUNLIT_USE + 2u * level, true).x,
                pathSet(numbers, SHPROBE_SUNLIT_USE + 2u * level + 1u, true));
}

// emitters.h powerHeuristic, as a ratio that no density's square overflows.
float powerHeuristic(float chosen, float other) {
    if (!(chosen > 0.0)) return 0.0;
    float ratio = other / chosen;
    return 1.0 / (1.0 + ratio * ratio);
}

// The index of picks[first, first + count) whose running sum first passes u
// (DiscreteDistribution::pick's upper_bound), the last one where rounding leaves none.
uint pickedIndex(uint first, uint count, float u) {
    uint low = first, high = first + count - 1u;
    while (low < high) {
        uint middle = (low + high) / 2u;
        if (picks[middle].cumulative > u) high = middle;
        else low = middle + 1u;
    }
    return picks[low].index;
}

// A triangle's point at barycentrics (u, v).
vec3 trianglePoint(uint triangle, vec2 barycentric) {
    vec3 p0 = vertices[indices[3u * triangle]].positionU.xyz;
    vec3 p1 = vertices[indices[3u * triangle + 1u]].positionU.xyz;
    vec3 p2 = vertices[indices[3u * triangle + 2u]].positionU.xyz;
    return (1.0 - barycentric.x - barycentric.y) * p0 + barycentric.x * p1 + barycentric.y * p2;
}

// EmitterSampler::areaDensity, after the sky texels' probabilities.
float emitterAreaDensity(uint triangle) {
    return pickDensities[6u * rc.sizes.y * rc.sizes.y + triangle];
}

// The emitters' irradiance at `at` from one point sampled on them (scene/ray_bake.cpp
// emitterIrradiance): L_e max(0, n.w) / p(w) where a shadow ray reaches the point, p its density per
// solid angle, weighted by the power heuristic against the cosine rays' density.
vec3 emitterIrradiance(RaySurface at, PathNumbers numbers, uint level) {
    if (rc.paths.y == 0u) return vec3(0.0);
    vec3 u = emitterNumbers(numbers, level);
    uint triangle = pickedIndex(0u, rc.paths.y, u.x);
    float root = sqrt(u.y);
    vec2 barycentric = vec2(root * (1.0 - u.z), root * u.z);
    vec3 toLight = trianglePoint(triangle, barycentric) - at.leaving;
    float distance = length(toLight);
    if (!(distance > 0.0)) return vec3(0.0);
    vec3 direction = toLight / distance;
    float cosine = dot(at.shading, direction);
    if (!(cosine > 0.0)) return vec3(0.0);
    RaySurface light = describeSurface(triangle, barycentric, direction);
    float lightCosine = abs(dot(light.normal, direction));
    if (oneSidedBack(light) || !(lightCosine > 0.0)) return vec3(0.0);
    if (bvhAnyHit(rc.sizes.w, at.leaving, direction, 0.0, distance - 2.0 * max(at.offset, light.offset)))
        return vec3(0.0);
    float density = emitterAreaDensity(triangle) * distance * distance / lightCosine;
    float weight = powerHeuristic(density, cosine * INV_PI);
    return surfaceEmission(light.material, light.uv) * (cosine / density * weight);
}

// SkySampler's density per solid angle at face point ab of a sky texel: its probability over the
// texel's area on the face, (2 / n)^2, times the face's area per solid angle, (1 + a^2 + b^2)^(3/2).
float skyPointDensity(uint texel, vec2 ab) {
    float n = float(rc.sizes.y);
    float r2 = 1.0 + dot(ab, ab);
    return pickDensities[texel] * (0.25 * n * n) * r2 * sqrt(r2);
}

// SkySampler::density: 0 towards a black texel, or where the sky is black.
float skyDensity(vec3 direction) {
    if (rc.paths.z == 0u) return 0.0;
    vec2 ab;
    uint texel = skyTexelIndex(direction, rc.sizes.y, ab);
    return skyPointDensity(texel, ab);
}

// The sky's irradiance at `at` from one direction sampled towards its bright texels (scene/ray_bake.cpp
// skyIrradiance): a texel picked, a uniform point in it on its face; L max(0, n.w) / p(w) where a
// shadow ray escapes, weighted by the power heuristic against the cosine rays' density.
vec3 skyIrradiance(RaySurface at, PathNumbers numbers, uint level) {
    if (rc.paths.z == 0u) return vec3(0.0);
    vec3 u = skyNumbers(numbers, level);
    uint texel = pickedIndex(rc.paths.y, rc.paths.z, u.x);
    uint n = rc.sizes.y;
    vec2 ab = 2.0 * (vec2(texel % n, texel / n % n) + u.yz) / float(n) - 1.0;
    vec3 direction = normalize(unnormalizedFaceDirection(texel / (n * n), ab.x, ab.y));
    float cosine = dot(at.shading, direction);
    if (!(cosine > 0.0)) return vec3(0.0);
    if (bvhAnyHit(rc.sizes.w, at.leaving, direction, 0.0, RAY_FAR)) return vec3(0.0);
    float density = skyPointDensity(texel, ab);
    return skyTexel(direction, n) * (cosine / density * powerHeuristic(density, cosine * INV_PI));
}

// SunlitSampler::areaDensity: the density per unit area with which sun `sun`'s rays first meet the
// surface of unit geometric normal `normal` at `position`, were it the first they meet there.
float sunlitAreaDensity(uint sun, vec3 position, vec3 normal) {
    if (rc.paths.w == 0u) return 0.0;
    SunlitPlane plane = sunlitPlanes[sun];
    float area = plane.corner.w * plane.corner.w;
    vec3 offset = position - plane.corner.xyz;
    float i = floor(dot(offset, plane.across.xyz) / area), j = floor(dot(offset, plane.down.xyz) / area);
    float cells = float(SHPROBE_SUNLIT_CELLS);
    if (!(i >= 0.0 && i < cells && j >= 0.0 && j < cells)) return 0.0;
    uint index = (sun * SHPROBE_SUNLIT_CELLS + uint(j)) * SHPROBE_SUNLIT_CELLS + uint(i);
    return sunlitCells[index] / area * abs(dot(normal, plane.toSun.xyz));
}

// The light the suns' lit points reflect to `at` (scene/ray_bake.cpp sunlitIrradiance): from a sun's
// ray into the world, a cell of its plane picked and a uniform point in it, the first surface it
// meets, where `at` sees it, reflects albedo / pi E max(0, n.l) (its shadow ray to the sun), times
// max(0, n.w) / p(w), weighted by the power heuristic against the cosine rays' density.
vec3 sunlitIrradiance(RaySurface at, PathNumbers numbers, uint level) {
    if (rc.paths.w == 0u) return vec3(0.0);
    vec3 u = sunlitNumbers(numbers, level);
    uint cells = SHPROBE_SUNLIT_CELLS;
    uint index = pickedIndex(rc.paths.y + rc.paths.z, rc.paths.w, u.x);
    uint sun = index / (cells * cells);
    SunlitPlane plane = sunlitPlanes[sun];
    vec3 origin = plane.corner.xyz + (float(index % cells) + u.y) * plane.across.xyz +
                  (float(index % (cells * cells) / cells) + u.z) * plane.down.xyz;
    BvhHit hit;
    if (!bvhClosestHit(rc.sizes.w, origin, -plane.toSun.xyz, 0.0, RAY_FAR, hit)) return vec3(0.0);
    vec2 barycentric = vec2(hit.u, hit.v);
    vec3 toLit = trianglePoint(hit.triangle, barycentric) - at.leaving;
    float distance = length(toLit);
    if (!(distance > 0.0)) return vec3(0.0);
    vec3 direction = toLit / distance;
    float cosine = dot(at.shading, direction);
    if (!(cosine > 0.0)) return vec3(0.0);
    RaySurface lit = describeSurface(hit.triangle, barycentric, direction);
    CaptureSun light = suns[sun];
    float sunCosine = dot(lit.shading, light.direction.xyz);
    float litCosine = abs(dot(lit.normal, direction));
    if (oneSidedBack(lit) || !(sunCosine > 0.0) || !(litCosine > 0.0)) return vec3(0.0);
    if (bvhAnyHit(rc.sizes.w, at.leaving, direction, 0.0, distance - 2.0 * max(at.offset, lit.offset)))
        return vec3(0.0);
    if (bvhAnyHit(rc.sizes.w, lit.leaving, light.direction.xyz, 0.0, RAY_FAR)) return vec3(0.0);
    float area = plane.corner.w * plane.corner.w;
    float density = sunlitCells[index] / area * abs(dot(lit.normal, plane.toSun.xyz)) * distance * distance /
                    litCosine;
    if (!(density > 0.0)) return vec3(0.0);
    vec3 reflected = surfaceAlbedo(lit.material, lit.uv) * INV_PI * light.irradiance.rgb * sunCosine;
    return reflected * (cosine / density * powerHeuristic(density, cosine * INV_PI));
}

// The power heuristic's weight of a path's bounce that met `met` at `distance` along `direction`,
// drawn with `cosineDensity`, against a technique that draws points there with `areaDensity` per
// unit area (scene/ray_bake.cpp bounceShare); 1 where it draws none.
float bounceShare(float areaDensity, RaySurface met, vec3 direction, float distance, float cosineDensity) {
    float cosine = abs(dot(met.normal, direction));
    if (!(areaDensity > 0.0) || !(cosine > 0.0)) return 1.0;
    return powerHeuristic(cosineDensity, areaDensity * distance * distance / cosine);
}

// The suns' irradiance at a surface a path's bounce met at `position`, `distance` along `direction`
// drawn with density `cosineDensity` (scene/ray_bake.cpp sunShare): each sun's weighted by the power
// heuristic against the sunlit points' sampling, which finds the same light too.
vec3 sharedSunIrradiance(RaySurface met, vec3 position, vec3 direction, float distance, float cosineDensity) {
    vec3 e = vec3(0.0);
    for (uint s = 0u; s < rc.sizes.z; ++s) {
        CaptureSun sun = suns[s];
        float cosine = dot(met.shading, sun.direction.xyz);
        if (cosine <= 0.0) continue;
        if (bvhAnyHit(rc.sizes.w, met.leaving, sun.direction.xyz, 0.0, RAY_FAR)) continue;
        float share = bounceShare(sunlitAreaDensity(s, position, met.normal), met, direction, distance,
                                  cosineDensity);
        e += sun.irradiance.rgb * (cosine * share);
    }
    return e;
}

// The share of an emitter's light a path's bounce keeps where it meets it at `distance`: the power
// heuristic against the emitters' own sampling (emitterIrradiance), which finds the same light too.
float emissionShare(uint triangle, RaySurface met, vec3 direction, float distance, float cosineDensity) {
    return bounceShare(emitterAreaDensity(triangle), met, direction, distance, cosineDensity);
}

// What arrives at `origin` along a probe's ray, the light its hit leaves followed as a path of
// rc.paths.x bounces: at each hit emission (its share) and the suns reflected, then, while bounces
// are left and the surface reflects, the emitters' point, the sky's direction and the next cosine
// direction, whose density cancels the cosine (the throughput gains the albedo alone); the sky it
// escapes to is weighted against the sky's sampling, as the emitters it meets are.
RayArrival pathArriving(vec3 origin, vec3 direction, PathNumbers numbers) {
    BvhHit hit;
    if (!bvhClosestHitFrontFirst(rc.sizes.w, origin, direction, 0.0, RAY_FAR, hit))
        return RayArrival(skyTexel(direction, rc.sizes.y), false, RAY_FAR);
    RaySurface surface = describeSurface(hit.triangle, vec2(hit.u, hit.v), direction);
    if (oneSidedBack(surface)) return RayArrival(vec3(0.0), true, hit.t);
    float distance = hit.t;
    vec3 radiance = vec3(0.0);
    vec3 throughput = vec3(1.0);
    float share = 1.0;
    vec3 position = vec3(0.0), arrivedAlong = direction; // where the last bounce met the surface, and how
    float bounceDensity = 0.0;                            // 0: the probe's own ray, which counts all
    for (uint level = 0u;; ++level) {
        vec3 reflectance = surfaceAlbedo(surface.material, surface.uv) * INV_PI;
        vec3 sunLight = level == 0u ? sunIrradiance(surface.leaving, surface.shading)
                                    : sharedSunIrradiance(surface, position, arrivedAlong, hit.t, bounceDensity);
        radiance += throughput * (share * surfaceEmission(surface.material, surface.uv) + reflectance * sunLight);
        if (level == rc.paths.x || reflectance == vec3(0.0)) break;
        radiance += throughput * reflectance *
                    (emitterIrradiance(surface, numbers, level) + skyIrradiance(surface, numbers, level) +
                     sunlitIrradiance(surface, numbers, level));
        vec2 u = bounceNumbers(numbers, level);
        vec3 next = cosineDirection(surface.shading, u.x, u.y);
        float density = max(dot(surface.shading, next), 0.0) * INV_PI;
        throughput *= reflectance * 3.14159265358979;
        if (!bvhClosestHitFrontFirst(rc.sizes.w, surface.leaving, next, 0.0, RAY_FAR, hit)) {
            radiance += throughput * powerHeuristic(density, skyDensity(next)) * skyTexel(next, rc.sizes.y);
            break;
        }
        RaySurface met = describeSurface(hit.triangle, vec2(hit.u, hit.v), next);
        if (oneSidedBack(met)) break;
        share = emissionShare(hit.triangle, met, next, hit.t, density);
        surface = met;
        position = trianglePoint(hit.triangle, vec2(hit.u, hit.v));
        arrivedAlong = next;
        bounceDensity = density;
    }
    return RayArrival(radiance, false, distance);
}

#endif
