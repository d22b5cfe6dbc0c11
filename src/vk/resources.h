// Buffers, command buffers and their submission. Plain handles; createBuffer / destroyBuffer.
#pragma once
#include "vk/context.h"
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
void checkAllocationSize(const Device& device, VkDeviceSize size, uint32_t memoryType, const char* what);

// `what` names the buffer in error messages ("input texels").
Buffer createBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use,
                    const char* what);
void destroyBuffer(const Device& device, Buffer& buffer);

// Fills the first `size` bytes of the buffer with `fill(destination)`: in place when the buffer is
// mapped, through a staging buffer otherwise (the buffer then needs VK_BUFFER_USAGE_TRANSFER_DST_BIT).
void writeBuffer(const Context& context, Buffer& buffer, VkDeviceSize size,
                 const std::function<void(void*)>& fill);
// writeBuffer with a plain copy of data.
void uploadBuffer(const Context& context, Buffer& buffer, const void* data, VkDeviceSize size);
// Makes device writes to a mapped buffer visible to the host (no-op for coherent memory).
void invalidateBuffer(const Device& device, const Buffer& buffer);

// Records commands with `record`, submits them on the context's queue and waits for them.
void submitAndWait(const Context& context, const std::function<void(VkCommandBuffer)>& record);

// The pieces of a submission, for work that outlives one call (a viewer's frames):
// A primary command buffer from the context's pool (free it there with vkFreeCommandBuffers).
VkCommandBuffer allocateCommandBuffer(const Context& context);
// Begins recording commands that are submitted once.
void beginCommands(VkCommandBuffer commands);
// `signalled`: the first wait on the fence returns at once.
VkFence createFence(const Device& device, bool signalled = false);
VkSemaphore createSemaphore(const Device& device);

// What a submission waits for before `waitStage` and signals when done (presentation).
struct QueueSync {
    VkSemaphore wait = VK_NULL_HANDLE;
    VkPipelineStageFlags waitStage = 0;
    VkSemaphore signal = VK_NULL_HANDLE;
};
// Submits recorded commands on the context's queue; `fence` (optional) is signalled when they
// completed.
void submitCommands(const Context& context, VkCommandBuffer commands, VkFence fence,
                    const QueueSync& sync = {});
// Queue submissions made by submitAndWait and submitCommands in this process so far (tests count them).
uint64_t submissionCount();

// A pool of two timestamp queries, or VK_NULL_HANDLE when the queue cannot write timestamps.
VkQueryPool createTimestampPool(const Device& device);
// Milliseconds between the pool's two timestamps (waits for them); 0 for VK_NULL_HANDLE.
double timestampMilliseconds(const Device& device, VkQueryPool pool);

// A barrier making compute-shader (and transfer) writes visible to later compute reads and writes,
// transfers and host reads (a later pass may add to what an earlier one wrote).
void computeWriteBarrier(VkCommandBuffer commands);

} // namespace shprobe
