// A probe volume relit on the device (relight_volume.comp) under a sky that changes every frame, as
// Far Cry 3 relit its probe volumes for the time of day: the volume's static radiance, transfer and
// validity uploaded once (the file's sections as they are), the sky's coefficients written by the CPU
// into a host-visible buffer, and the irradiance a sampler reads (probe_volume.glsl's
// probeVolumeCoefficient layout: rgb E_i, w validity) left in `irradiance`.
//
//   VolumeRelighter relighter = createVolumeRelighter(device, volume.order);
//   RelitVolume relit = createRelitVolume(context, relighter, volume);
//   setRelitVolumeSky(relit, sky);   // not while a recorded relight may run
//   recordVolumeRelight(commands, relighter, relit, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT);
#pragma once
#include "formats/probe_volume.h"
#include "sh/coefficients.h"
#include "vk/context.h"
#include "vk/pipeline.h"
#include "vk/resources.h"

#include <glm/vec4.hpp>

#include <vector>

namespace shprobe {

// The pipeline for one order, created once and reused.
struct VolumeRelighter {
    int order = 0;
    ComputeProgram program;
};

VolumeRelighter createVolumeRelighter(const Device& device, int order);
void destroyVolumeRelighter(const Device& device, VolumeRelighter& relighter);

struct RelitVolume {
    uint32_t probes = 0;
    Buffer transfer;
    Buffer staticRadiance;
    Buffer validity;
    Buffer sky; // MemoryUse::Upload
    Buffer irradiance;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
};

// Throws Error(Input) for a volume without transfer, of another order than the relighter's, or whose
// transfer is larger than one storage buffer binding of the device holds.
RelitVolume createRelitVolume(const Context& context, const VolumeRelighter& relighter,
                              const ProbeVolume& volume);
void destroyRelitVolume(const Device& device, RelitVolume& relit);
// The sky's radiance coefficients, of the relighter's order.
void setRelitVolumeSky(const RelitVolume& relit, const ShCoefficients& sky);
// The dispatch, then a barrier that makes `irradiance` visible to shader reads at `readers`.
void recordVolumeRelight(VkCommandBuffer commands, const VolumeRelighter& relighter, const RelitVolume& relit,
                         VkPipelineStageFlags readers);

// One relight, read back: probe p's coefficient i (rgb E_i, w validity) at p * order^2 + i.
std::vector<glm::vec4> relightVolumeOnGpu(const Context& context, const VolumeRelighter& relighter,
                                          const ProbeVolume& volume, const ShCoefficients& sky);

} // namespace shprobe
