// Embree's ray casting (scene/ray_caster.h): compiled into the plugin libshprobe_embree.so, which the
// program loads when it first casts rays on the CPU, and into the ray-traced reference
// (scene/reference_tracer.h), which links Embree itself. Embree's robust mode keeps shared edges
// watertight; its default build quality gives the same hierarchy run to run.
#pragma once
#include "scene/ray_caster.h"

#include <cstdint>
#include <memory>
#include <span>

namespace shprobe {

// A caster for the World's triangles `triangles` (indices into it): hits name the World's index.
// The World must have passed checkBvhWorld (scene/bvh.h). Throws Error(Input) for a triangle past
// the World's, Error(Device) where Embree cannot run or was built culling back faces.
std::unique_ptr<RayCaster> makeEmbreeRayCaster(const World& world, std::span<const uint32_t> triangles);

// The plugin's entry point, makeEmbreeRayCaster.
struct EmbreePlugin {
    std::unique_ptr<RayCaster> (*makeRayCaster)(const World& world, std::span<const uint32_t> triangles);
};

// The name of the function the plugin exports: const EmbreePlugin* shprobe_embree_plugin_v1().
#define SHPROBE_EMBREE_PLUGIN_ENTRY "shprobe_embree_plugin_v1"

} // namespace shprobe
