// Buffers and one-shot command submission. Plain handles; createBuffer / destroyBuffer.
#pragma once
#include "shprobe/vk/context.h"
#include <functional>

namespace shprobe {

enum class MemoryUse {
    Device,   // device-local; host-visible too where the device has such memory (UMA, lavapipe)
    Upload,   // host-visible, coherent: written by the CPU, read by the device
    Readback, // host-visible, cached where possible: written by the device, read by the CPU
};

struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void* mapped = nullptr; // persistently mapped when the memory is host-visible
    bool coherent = false;
};

// Throws Error(Device) naming `what` when size exceeds what one allocation of the memory type may
// hold (its heap, maxMemoryAllocationSize): drivers may accept such a request and fail later.
void checkAllocationSize(const Context& context, VkDeviceSize size, uint32_t memoryType, const char* what);

// `what` names the buffer in error messages ("input texels").
Buffer createBuffer(const Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use,
                    const char* what);
void destroyBuffer(const Context& context, Buffer& buffer);

// Fills the first `size` bytes of the buffer with `fill(destination)`: in place when the buffer is
// mapped, through a staging buffer otherwise (the buffer then needs VK_BUFFER_USAGE_TRANSFER_DST_BIT).
void writeBuffer(const Context& context, Buffer& buffer, VkDeviceSize size,
                 const std::function<void(void*)>& fill);
// writeBuffer with a plain copy of data.
void uploadBuffer(const Context& context, Buffer& buffer, const void* data, VkDeviceSize size);
// Makes device writes to a mapped buffer visible to the host (no-op for coherent memory).
void invalidateBuffer(const Context& context, const Buffer& buffer);

// Records commands with `record`, submits them on the context's queue and waits for them.
void submitAndWait(const Context& context, const std::function<void(VkCommandBuffer)>& record);
// Queue submissions made by submitAndWait in this process so far (tests count them).
uint64_t submissionCount();

// A pool of two timestamp queries, or VK_NULL_HANDLE when the queue cannot write timestamps.
VkQueryPool createTimestampPool(const Context& context);
// Milliseconds between the pool's two timestamps (waits for them); 0 for VK_NULL_HANDLE.
double timestampMilliseconds(const Context& context, VkQueryPool pool);

// A barrier making compute-shader (and transfer) writes visible to later compute reads, transfers
// and host reads.
void computeWriteBarrier(VkCommandBuffer commands);

} // namespace shprobe
