// GPU rotation of a batch of probes (rotate.comp) by band matrices built on the CPU.
#pragma once
#include "sh/coefficients.h"
#include "sh/rotation.h"
#include "vk/context.h"
#include "vk/pipeline.h"
#include "vk/resources.h"

#include <span>
#include <vector>

namespace shprobe {

// The pipeline for one order, created once and reused.
struct Rotator {
    int order = 0;
    ComputeProgram program;
};

Rotator createRotator(const Device& device, int order);
void destroyRotator(const Device& device, Rotator& rotator);

// Rotates every probe by rotations[0] when one rotation is given, or probe p by rotations[p] when
// there are as many rotations as probes. All orders must be the rotator's. One submission.
std::vector<ShCoefficients> rotateOnGpu(const Context& context, const Rotator& rotator,
                                        std::span<const ShRotation> rotations,
                                        std::span<const ShCoefficients> probes);

// One probe turned again and again on the device (a light turned every frame): its coefficients
// uploaded once, the band matrices of each new rotation written by the CPU into a host-visible
// buffer, and the rotated coefficients (n^2 vec4) left in `rotated` for later passes to read as a
// storage buffer.
//
//   RotatedProbe light = createRotatedProbe(context, rotator, coefficients);
//   setProbeRotation(light, makeShRotation(R, order));  // not while a recorded rotation may run
//   recordProbeRotation(commands, rotator, light, VK_PIPELINE_STAGE_VERTEX_SHADER_BIT);
struct RotatedProbe {
    Buffer matrices; // MemoryUse::Upload
    Buffer probe;
    Buffer rotated;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
};

// The probe's order must be the rotator's; it starts unrotated (the identity).
RotatedProbe createRotatedProbe(const Context& context, const Rotator& rotator, const ShCoefficients& probe);
void destroyRotatedProbe(const Device& device, RotatedProbe& rotated);
void setProbeRotation(const RotatedProbe& rotated, const ShRotation& rotation);
// The dispatch, then a barrier that makes `rotated` visible to shader reads at `readers`.
void recordProbeRotation(VkCommandBuffer commands, const Rotator& rotator, const RotatedProbe& rotated,
                         VkPipelineStageFlags readers);

} // namespace shprobe
