// GPU rotation of a batch of probes (rotate.comp) by band matrices built on the CPU.
#pragma once
#include "sh/coefficients.h"
#include "sh/rotation.h"
#include "vk/context.h"
#include "vk/pipeline.h"

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

} // namespace shprobe
