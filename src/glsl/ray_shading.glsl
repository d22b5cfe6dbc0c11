// The transport of scene/scene.h by rays on the scene's hierarchy, as the cpu backend follows it
// (scene/ray_bake.cpp arriving, scene/surface_shading.cpp describe): what arrives along a ray is
// the sky where it meets nothing, nothing from the back of a one-sided material, else what the
// front face leaves: emission + albedo / pi (suns by shadow rays + the cached bounce at the hit).
// Declares set 0 of ray_capture_interface.h up to SHPROBE_RAYS_CACHE and the push constants `rc`;
// the includer declares its own input and output.
#ifndef SHPROBE_RAY_SHADING_GLSL
#define SHPROBE_RAY_SHADING_GLSL
#include "bvh_interface.h"
#include "capture_world.glsl"
#include "ray_capture_interface.h"

layout(std430, set = 0, binding = SHPROBE_RAYS_BVH_NODES) readonly buffer BvhNodes {
    BvhNode bvhNodes[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_BVH_TRIANGLES) readonly buffer BvhTriangles {
    BvhTriangle bvhTriangles[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_BVH_IDS) readonly buffer BvhTriangleIds {
    uint bvhTriangleIds[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_LATTICES) readonly buffer Lattices {
    CacheLattice lattices[];
};
layout(std430, set = 0, binding = SHPROBE_RAYS_CACHE) readonly buffer Cache {
    vec4 cache[];
};
layout(push_constant, std430) uniform Push {
    RayCaptureConstants rc;
};

#include "bvh_traversal.glsl"

#define RAY_FAR uintBitsToFloat(0x7f800000u) // +infinity: rays without a limit

// Index of lattice point (i, j), i + j <= m, row by row (scene/surface_cache.cpp latticeIndex).
uint latticeIndex(int m, int i, int j) {
    return uint(j * (m + 1) - j * (j - 1) / 2 + i);
}

// The cached irradiance on `side` of `triangle` at barycentrics (u, v): linear over the lattice
// cell holding the point (scene/surface_cache.cpp blendAt, without refinement).
vec3 cachedIrradiance(uint triangle, uint side, vec2 barycentric) {
    uvec4 lattice = lattices[triangle].points;
    int m = int(lattice.y);
    uint first = lattice.x + side * uint((m + 1) * (m + 2) / 2);
    float x = clamp(barycentric.x, 0.0, 1.0) * float(m);
    float y = clamp(barycentric.y, 0.0, 1.0) * float(m);
    int i0 = min(int(x), m - 1);
    int j0 = min(int(y), m - 1);
    while (i0 + j0 > m - 1) { // u + v a rounding over 1
        if (i0 > 0) --i0;
        else --j0;
    }
    float fx = x - float(i0);
    float fy = y - float(j0);
    if (fx + fy <= 1.0 || i0 + j0 + 2 > m)
        return (1.0 - fx - fy) * cache[first + latticeIndex(m, i0, j0)].rgb +
               fx * cache[first + latticeIndex(m, i0 + 1, j0)].rgb +
               fy * cache[first + latticeIndex(m, i0, j0 + 1)].rgb;
    return (fx + fy - 1.0) * cache[first + latticeIndex(m, i0 + 1, j0 + 1)].rgb +
           (1.0 - fx) * cache[first + latticeIndex(m, i0, j0 + 1)].rgb +
           (1.0 - fy) * cache[first + latticeIndex(m, i0 + 1, j0)].rgb;
}

// The suns' irradiance at a point whose leaving rays start at `origin`, of shading normal n: a
// shadow ray to each sun above the surface (scene/surface_shading.h leavingWithoutBounce).
vec3 sunIrradiance(vec3 origin, vec3 n) {
    vec3 e = vec3(0.0);
    for (uint s = 0u; s < rc.sizes.z; ++s) {
        CaptureSun sun = suns[s];
        float cosine = dot(n, sun.direction.xyz);
        if (cosine <= 0.0) continue;
        if (!bvhAnyHit(rc.sizes.w, origin, sun.direction.xyz, 0.0, RAY_FAR)) e += sun.irradiance.rgb * cosine;
    }
    return e;
}

// What arrives along a ray, whether it met the back of a one-sided material, and how far it went
// (t along the unit direction; infinity where it met nothing).
struct RayArrival {
    vec3 radiance;
    bool backFace;
    float distance;
};

// A triangle's point at barycentrics (u, v), seen along `direction` (scene/surface_shading.cpp
// describe): its material, geometric and shading normals on the side seen, texture coordinate, and
// where the rays that leave it start.
struct RaySurface {
    CaptureMaterial material;
    vec3 normal;
    vec3 shading;
    vec2 uv;
    vec3 leaving;
    float offset; // how far `leaving` is off the surface and back along the ray
    bool front;
};

// How far leaving rays start off a triangle: kSurfaceOffsetScale (rc.scale.x) times the largest
// |x|, |y|, |z| of its corners (scene/surface_shading.h SceneShading::offset).
float surfaceOffset(vec3 p0, vec3 p1, vec3 p2) {
    vec3 largest = max(max(abs(p0), abs(p1)), abs(p2));
    return rc.scale.x * max(max(largest.x, largest.y), largest.z);
}

// Whether the ray met the back of a one-sided material, which leaves nothing.
bool oneSidedBack(RaySurface surface) {
    return !surface.front && surface.material.sides.x < 0.5;
}

RaySurface describeSurface(uint triangle, vec2 barycentric, vec3 direction) {
    uint corner0 = indices[3u * triangle], corner1 = indices[3u * triangle + 1u],
         corner2 = indices[3u * triangle + 2u];
    CaptureVertex v0 = vertices[corner0], v1 = vertices[corner1], v2 = vertices[corner2];
    vec3 normal = normalize(cross(v1.positionU.xyz - v0.positionU.xyz, v2.positionU.xyz - v0.positionU.xyz));
    bool front = dot(normal, direction) < 0.0;
    float side = front ? 1.0 : -1.0;
    CaptureMaterial material = materials[triangleMaterials[triangle]];
    vec3 weights = vec3(1.0 - barycentric.x - barycentric.y, barycentric);
    vec3 position = weights.x * v0.positionU.xyz + weights.y * v1.positionU.xyz + weights.z * v2.positionU.xyz;
    vec3 interpolated = weights.x * v0.normalV.xyz + weights.y * v1.normalV.xyz + weights.z * v2.normalV.xyz;
    vec2 uv = weights.x * vec2(v0.positionU.w, v0.normalV.w) + weights.y * vec2(v1.positionU.w, v1.normalV.w) +
              weights.z * vec2(v2.positionU.w, v2.normalV.w);
    // Leaving rays start from the point moved off the surface and back along the ray: a ray through a
    // texel centre may meet a room's corner exactly, on both walls' planes, and a point moved off one
    // of them alone lies on the other, where rounding (the scene's scale) decides whether its shadow
    // ray leaves the room.
    vec3 shading = side * (length(interpolated) > 0.0 ? normalize(interpolated) : normal);
    float offset = surfaceOffset(v0.positionU.xyz, v1.positionU.xyz, v2.positionU.xyz);
    return RaySurface(material, side * normal, shading, uv, position + offset * (side * normal - direction),
                      offset, front);
}

// The radiance arriving at `origin` from unit `direction`, the surfaces reflecting the cached
// bounce when `cached` (the cache holds it), none otherwise.
RayArrival arriving(vec3 origin, vec3 direction, bool cached) {
    BvhHit hit;
    if (!bvhClosestHitFrontFirst(rc.sizes.w, origin, direction, 0.0, RAY_FAR, hit))
        return RayArrival(skyTexel(direction, rc.sizes.y), false, RAY_FAR);
    RaySurface surface = describeSurface(hit.triangle, vec2(hit.u, hit.v), direction);
    if (oneSidedBack(surface)) return RayArrival(vec3(0.0), true, hit.t);
    vec3 irradiance = sunIrradiance(surface.leaving, surface.shading);
    if (cached) irradiance += cachedIrradiance(hit.triangle, surface.front ? 0u : 1u, vec2(hit.u, hit.v));
    return RayArrival(surfaceLeaving(surface.material, surface.uv, irradiance), false, hit.t);
}

// A cosine-distributed direction about unit n (scene/sampling.h cosineDirection): the frame of
// Duff et al., "Building an Orthonormal Basis, Revisited" (2017), and Malley's method.
vec3 cosineDirection(vec3 n, float u1, float u2) {
    float sign = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    vec3 bitangent = vec3(b, sign + n.y * n.y * a, -n.y);
    float r = sqrt(u1);
    float phi = 6.28318530717959 * u2;
    return normalize(r * cos(phi) * t + r * sin(phi) * bitangent + sqrt(max(0.0, 1.0 - u1)) * n);
}

#endif
