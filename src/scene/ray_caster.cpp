// The CPU's ray caster through the Embree plugin (scene/ray_caster.h).
#include "scene/ray_caster.h"

#include "common/plugin_loader.h"
#include "scene/embree_rays.h"

#include <numeric>
#include <vector>

namespace shprobe {

std::unique_ptr<RayCaster> makeRayCaster(const World& world) {
    checkBvhWorld(world);
    constexpr PluginName kEmbree{"libshprobe_embree.so", SHPROBE_EMBREE_PLUGIN_ENTRY, "SHPROBE_EMBREE_PLUGIN",
                                 "casting rays on the CPU needs Embree"};
    const EmbreePlugin& plugin = loadPlugin<EmbreePlugin>(kEmbree, ErrorKind::Device, world.description);
    std::vector<uint32_t> triangles(world.triangleCount());
    std::iota(triangles.begin(), triangles.end(), 0u);
    return plugin.makeRayCaster(world, triangles);
}

} // namespace shprobe
