// Per-vertex transfer (scene/transfer.h) with its rays cast on a Vulkan device: the direct pass
// (transfer_direct.comp, any-hit shadow rays) and each bounce (transfer_bounce.comp, closest hits
// and the previous bounce's transfer interpolated at them) walk the CPU's hierarchy
// (glsl/bvh_traversal.glsl) from the sides scene/transfer.cpp lays out, with the same stratified
// cosine rays. The passes' sums come back to the CPU, which adds the bounces and multiplies by
// the albedo as computeTransfer does. Unshadowed transfer casts no rays and stays on the CPU.
#pragma once
#include "scene/transfer.h"
#include "vk/context.h"

namespace shprobe {

// The sides are dispatched in chunks of at most this many rays, each its own submission, so that no
// submission runs long enough to trip a display driver's timeout (about 2 s on desktop systems).
constexpr uint64_t kTransferRaysPerSubmission = uint64_t(1) << 22;

// Throws as computeTransfer does, and Error(Device) for a scene whose buffers exceed what the
// device can bind (maxStorageBufferRange) or a chunk past maxComputeWorkGroupCount.
VertexTransfer computeTransferOnGpu(const Context& context, const World& world,
                                    const TransferOptions& options, const TransferProgress& progress = {});

} // namespace shprobe
