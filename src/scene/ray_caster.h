// The rays the CPU bakes cast (scene/ray_bake.h, scene/transfer.h): Embree's traversal of its own
// wide hierarchy, loaded as a plugin (libshprobe_embree.so, scene/embree_rays.h) by the runs that
// cast rays on the CPU, so that no other run loads Embree and TBB. The GPU backends walk
// scene/bvh.h's hierarchy instead; both answer the questions of scene/bvh.h with the same
// conventions (barycentrics, front faces), and docs/scene-probes.md, "Ray casting", says how often
// and why their hits differ.
#pragma once
#include "scene/bvh.h"
#include "scene/scene.h"

#include <memory>
#include <optional>

namespace shprobe {

// A thread should cast at least this many rays, so that starting it stays a small part of its run.
constexpr size_t kRaysPerThread = 4096;

// Rays against a World's triangles, cast from any number of threads at once.
class RayCaster {
  public:
    virtual ~RayCaster() = default;
    // The first triangle along the ray with t in [tMin, tMax], front or back, if any; triangle is
    // the World's index. Triangles of zero area are never hit.
    virtual std::optional<RayHit> closestHit(const Ray& ray) const = 0;
    // Whether any triangle, front or back, is hit with t in [tMin, tMax] (a shadow ray).
    virtual bool anyHit(const Ray& ray) const = 0;
};

// scene/bvh.h's traversals of a hierarchy behind the same interface, for code shared with the GPU
// backends (which hold that hierarchy anyway). The hierarchy must outlive the caster.
class BvhRayCaster final : public RayCaster {
  public:
    explicit BvhRayCaster(const Bvh& bvh) : bvh_(bvh) {}
    explicit BvhRayCaster(Bvh&&) = delete; // it would outlive a temporary
    std::optional<RayHit> closestHit(const Ray& ray) const override { return shprobe::closestHit(bvh_, ray); }
    bool anyHit(const Ray& ray) const override { return shprobe::anyHit(bvh_, ray); }

  private:
    const Bvh& bvh_;
};

// Embree's caster for every triangle of the world, built now (on all cores). Throws Error(Input) for
// a World whose indices are not triangles of its positions, Error(Device) where the plugin or Embree
// cannot be loaded or run ("casting rays on the CPU needs Embree, and its plugin ...").
std::unique_ptr<RayCaster> makeRayCaster(const World& world);

} // namespace shprobe
