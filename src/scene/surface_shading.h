// What the light transport of scene.h reads at a surface, for any ray caster: the hit point, its
// normals, its materials (textures sampled as glTF says), the sky where rays escape, the suns. The
// ray casters (scene/bvh.h in the program, Embree in scene/reference_tracer.h) find the triangle
// and its barycentrics; SceneShading describes the point.
#pragma once
#include "scene/scene.h"
#include "sh/cubemap.h"

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

namespace shprobe {

// A point on a surface, with what the transport of scene.h reads of it.
struct SurfaceHit {
    glm::dvec3 position{0.0};      // on the triangle, from the barycentrics
    glm::dvec3 normal{0.0};        // geometric (from the winding), unit, turned to the ray's side
    glm::dvec3 shadingNormal{0.0}; // interpolated vertex normal, unit, turned with `normal`
    glm::dvec3 rayOrigin{0.0};     // position moved off the surface along `normal`: leaving rays start here
    double offset = 0.0;           // how far: SceneShading::offset(triangle)
    glm::dvec3 albedo{0.0};        // material factor times texture at TEXCOORD_0
    glm::dvec3 emission{0.0};      // likewise
    uint32_t triangle = 0;         // the World's triangle
    glm::dvec2 barycentric{0.0};   // (u, v): the point is (1 - u - v) p0 + u p1 + v p2
    bool frontSide = false;        // the side the winding faces (scene.h)
    bool backFace = false;         // the back of a one-sided material: it leaves nothing
};

// The sizes both backends bake alike: a scene scaled by any factor that keeps it inside these bakes
// to the same volume (its probes scaled too), as every distance the bakes use is a fraction of the
// scene's size or of its largest coordinate. The ray test (scene/bvh.h) multiplies three coordinate
// differences in float, which stay normal floats, far from underflow and overflow, from 1e-30 to
// 1e30; the capture's depth and normals need less.
constexpr double kMinSceneSize = 1e-10;         // the bounding box's diagonal, at least
constexpr double kMaxSceneCoordinate = 1e10;    // |x|, |y|, |z| of any vertex, at most
constexpr double kMaxSurfaceOffsetShare = 0.01; // the largest SceneShading::offset() over the diagonal

// Rays leaving a surface start this far off it along its geometric normal, in units of its
// triangle's largest coordinate: 256 float ulps of it, well above the few ulps by which a
// single-precision test of a ray from that triangle against it errs (its operands are the
// triangle's corners and a point on it), so a leaving ray never meets it again. Of the triangle's
// coordinates, not the scene's: a room by the origin beside a ground reaching 1e5 would otherwise
// start its rays 3 units off its walls, through them. (Waechter and Binder, "A Fast and Robust
// Method for Avoiding Self-Intersection", Ray Tracing Gems, scale by the point's own; a point near
// the origin on a triangle reaching 1e5 still meets that triangle's rounding, so the triangle's.)
constexpr double kSurfaceOffsetScale = 256.0 * std::numeric_limits<float>::epsilon();

// Throws Error(Input) "DESCRIPTION: ..." (world.description, else "scene") naming the scale for a
// World with triangles whose vertices all lie at one point, that is smaller than kMinSceneSize,
// whose coordinates reach past kMaxSceneCoordinate, or whose float spacing is too coarse for its
// size: where rays leaving a surface start (256 float steps of its largest coordinate off it) more
// than kMaxSurfaceOffsetShare of the scene away, a scene far from the origin for its size. Both
// backends call it, and probeGridInWorld before it places a grid.
void checkSceneScale(const World& world);

// A World checked and copied with what shading needs (suns normalized), and the sky. Immutable:
// describe and skyRadiance may run on many threads at once.
class SceneShading {
  public:
    // Throws Error(Input) for a World whose arrays disagree (scene.h), for non-finite vertices or a
    // sun without a direction, for a scale checkSceneScale refuses, or for a sky whose texel count
    // is not that of a cube map.
    SceneShading(World world, const Cubemap& sky);

    // The point of `triangle` at barycentrics (u, v), seen by a ray along `direction`.
    SurfaceHit describe(uint32_t triangle, const glm::dvec2& barycentric, const glm::dvec3& direction) const;
    // The same point seen from its front side (frontSide) or its back.
    SurfaceHit surfacePoint(uint32_t triangle, const glm::dvec2& barycentric, bool frontSide) const;
    // The sky's texel the direction falls in: nearest texel, no filtering, as the GPU capture's
    // background reads it with a NEAREST sampler.
    glm::dvec3 skyRadiance(const glm::dvec3& direction) const;

    const World& world() const { return world_; }
    const Cubemap& sky() const { return sky_; }
    std::span<const SceneSun> suns() const { return world_.suns; }
    // The triangles of non-zero area: the others cover no solid angle and have no normal.
    std::span<const uint32_t> solidTriangles() const { return solidTriangles_; }
    // How far leaving rays start off `triangle` (SurfaceHit::rayOrigin): kSurfaceOffsetScale times
    // the largest |x|, |y|, |z| of its corners.
    double offset(uint32_t triangle) const;

  private:
    World world_;
    std::vector<uint32_t> solidTriangles_;
    Cubemap sky_;
};

// What a front face reflects of the suns (scene.h): albedo / pi times sum_suns E_sun max(0, n.l)
// V(x, l), n the shading normal; one shadow ray per sun above the surface, occluded(origin,
// direction) saying whether anything blocks it, counted in rays. Sun k's light counts weight(k)
// times (a path's share of it, where another estimate finds it too).
template <typename Occluded, typename Weight>
glm::dvec3 reflectedSunLight(std::span<const SceneSun> suns, const SurfaceHit& hit, uint64_t& rays,
                             const Occluded& occluded, const Weight& weight) {
    glm::dvec3 sunLight(0.0);
    for (size_t k = 0; k < suns.size(); ++k) {
        const glm::dvec3 toSun(suns[k].direction);
        const double cosine = glm::dot(hit.shadingNormal, toSun);
        if (cosine <= 0.0) continue;
        ++rays;
        if (!occluded(hit.rayOrigin, toSun))
            sunLight += glm::dvec3(suns[k].irradiance) * (cosine * weight(k));
    }
    return hit.albedo * std::numbers::inv_pi * sunLight;
}

template <typename Occluded>
glm::dvec3 reflectedSunLight(std::span<const SceneSun> suns, const SurfaceHit& hit, uint64_t& rays,
                             const Occluded& occluded) {
    return reflectedSunLight(suns, hit, rays, occluded, [](size_t) { return 1.0; });
}

// What a front face leaves towards the ray with no bounced light (scene.h): its emission and the
// suns' light it reflects.
template <typename Occluded>
glm::dvec3 leavingWithoutBounce(std::span<const SceneSun> suns, const SurfaceHit& hit, uint64_t& rays,
                                const Occluded& occluded) {
    return hit.emission + reflectedSunLight(suns, hit, rays, occluded);
}

} // namespace shprobe
