// The GPU side of `shprobe bench` that needs more than a bake: the device's own read bound on the
// projection's access pattern, and the cost of creating the pipelines with and without a
// pipeline cache.
#pragma once
#include "gpu/host_bake.h"
#include "sh/cubemap.h"
#include "vk/context.h"

#include <cstddef>
#include <functional>
#include <span>

namespace shprobe {

// Device milliseconds (timestamps) of read_texels over the cube map: every texel read as the
// storage-image projection reads it (positions, streams, order), and only summed. Each the best of
// `repeat` runs after an untimed one; 0 without timestamps or without storage images of the format.
struct TexelReads {
    double imageMilliseconds = 0.0;  // read_texels_<format>.comp: from the image the projection reads
    double bufferMilliseconds = 0.0; // read_texels_buffer_<format>.comp: from a storage buffer of the
                                     // same texels (`bytes`, layer after layer); 0 where they exceed
                                     // maxStorageBufferRange
};
TexelReads deviceTexelReads(const Context& context, const Cubemap& cubemap, std::span<const std::byte> bytes,
                            TexelFormat format, int repeat);

// The device's own bounds for `bytes` (a multiple of 16 bytes), timed with timestamps, each the best
// of `repeat` runs after an untimed one; 0 without timestamps. On a CPU device such as lavapipe all
// three are CPU memory passes.
struct DeviceBounds {
    double readMilliseconds = 0.0;     // read_buffer.comp: a plain coalesced read of a device-local buffer
    double copyMilliseconds = 0.0;     // vkCmdCopyBuffer of it to another device-local buffer
    double transferMilliseconds = 0.0; // vkCmdCopyBuffer from a host-visible (pinned) staging buffer
};
DeviceBounds measureDeviceBounds(const Context& context, std::span<const std::byte> bytes, int repeat);

// The device's rate of float multiply-adds (multiply_adds.comp: independent fused multiply-adds, one
// float each), from timestamps over a dispatch grown until it runs 10 ms or more, the best of
// `repeat` runs; 0 without timestamps. On a CPU device such as lavapipe, the CPU's vector units.
double multiplyAddsPerSecond(const Context& context, int repeat);

struct PipelineCreation {
    double firstMilliseconds = 0.0;  // createProbeBaker with an empty pipeline cache
    double cachedMilliseconds = 0.0; // again, with a cache loaded from the first one's saved data
    size_t cacheBytes = 0;           // the saved data (a driver without a real cache saves a header)
};

// Creates and destroys the bake pipelines twice, the second time from a cache that went
// through a file (as the next run of the program would see it).
PipelineCreation measurePipelineCreation(const Device& device, int order);

} // namespace shprobe
