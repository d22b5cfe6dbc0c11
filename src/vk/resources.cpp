#include "vk/resources.h"

#include "common/scope_exit.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#include <algorithm>
#include <atomic>
#include <cstring>

namespace shprobe {

namespace {

std::atomic<uint64_t> gSubmissions{0};

struct MemoryPreference {
    VkMemoryPropertyFlags required;
    VkMemoryPropertyFlags preferred;
};

MemoryPreference memoryPreference(MemoryUse use) {
    switch (use) {
    case MemoryUse::Device:
        return {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT};
    case MemoryUse::Upload:
        return {VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, 0};
    case MemoryUse::Readback:
        return {VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_CACHED_BIT};
    }
    return {0, 0};
}

VkDeviceSize largestDeviceLocalHeap(const VkPhysicalDeviceMemoryProperties& memory) {
    VkDeviceSize largest = 0;
    for (uint32_t h = 0; h < memory.memoryHeapCount; ++h)
        if (memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
            largest = std::max(largest, memory.memoryHeaps[h].size);
    return largest;
}

// The memory type allowed by typeBits with all required flags: one with the preferred flags too if
// there is one, else any. Device-local types count only in the largest device-local heap while one
// there qualifies: on discrete GPUs without resizable BAR the host-visible device-local heap is a
// 256 MiB window, too small for large inputs. UINT32_MAX if none.
uint32_t findMemoryType(const VkPhysicalDeviceMemoryProperties& memory, uint32_t typeBits,
                        MemoryPreference want) {
    const VkDeviceSize largestHeap = largestDeviceLocalHeap(memory);
    auto allowed = [&](uint32_t i) {
        return (typeBits & (1u << i)) &&
               (memory.memoryTypes[i].propertyFlags & want.required) == want.required;
    };
    auto inLargeHeap = [&](uint32_t i) {
        return !(want.required & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) ||
               memory.memoryHeaps[memory.memoryTypes[i].heapIndex].size == largestHeap;
    };
    auto preferred = [&](uint32_t i) {
        return (memory.memoryTypes[i].propertyFlags & want.preferred) == want.preferred;
    };
    for (auto acceptable :
         {std::function<bool(uint32_t)>([&](uint32_t i) { return inLargeHeap(i) && preferred(i); }),
          std::function<bool(uint32_t)>(inLargeHeap), std::function<bool(uint32_t)>(preferred)})
        for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
            if (allowed(i) && acceptable(i)) return i;
    for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
        if (allowed(i)) return i;
    return UINT32_MAX;
}

std::string sizeText(VkDeviceSize size) {
    return std::to_string((size + (1 << 20) - 1) >> 20) + " MiB";
}

VkDeviceMemory allocateMemory(const Device& device, VkMemoryRequirements requirements, uint32_t type,
                              const char* what) {
    checkAllocationSize(device, requirements.size, type, what);
    VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    info.allocationSize = requirements.size;
    info.memoryTypeIndex = type;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkResult result = vkAllocateMemory(device.device, &info, nullptr, &memory);
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY)
        throw Error(ErrorKind::Device, std::string("allocating ") + sizeText(requirements.size) + " for " +
                                           what + ": out of memory on " + device.info.name + sizeAdvice());
    VK_CHECK(result);
    return memory;
}

} // namespace

void checkAllocationSize(const Device& device, VkDeviceSize size, uint32_t memoryType, const char* what) {
    VkPhysicalDeviceMaintenance3Properties maintenance3{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &maintenance3};
    vkGetPhysicalDeviceProperties2(device.physicalDevice, &properties);
    const VkDeviceSize heap = device.memory.memoryHeaps[device.memory.memoryTypes[memoryType].heapIndex].size;
    const VkDeviceSize limit = std::min(heap, maintenance3.maxMemoryAllocationSize);
    if (size > limit)
        throw Error(ErrorKind::Device, std::string("allocating ") + sizeText(size) + " for " + what +
                                           ": more than one allocation may hold on " + device.info.name +
                                           " (" + sizeText(limit) + ")" + sizeAdvice());
}

Buffer createBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use,
                    const char* what) {
    Buffer buffer;
    buffer.size = size;
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    OnFailure undo([&] { destroyBuffer(device, buffer); });
    VK_CHECK(vkCreateBuffer(device.device, &info, nullptr, &buffer.buffer));

    VkMemoryRequirements requirements;
    vkGetBufferMemoryRequirements(device.device, buffer.buffer, &requirements);
    uint32_t type = findMemoryType(device.memory, requirements.memoryTypeBits, memoryPreference(use));
    if (type == UINT32_MAX)
        throw Error(ErrorKind::Device, std::string("no suitable memory type for ") + what);
    buffer.memory = allocateMemory(device, requirements, type, what);
    VK_CHECK(vkBindBufferMemory(device.device, buffer.buffer, buffer.memory, 0));

    VkMemoryPropertyFlags flags = device.memory.memoryTypes[type].propertyFlags;
    buffer.coherent = flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    if (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
        VK_CHECK(vkMapMemory(device.device, buffer.memory, 0, VK_WHOLE_SIZE, 0, &buffer.mapped));
    return buffer;
}

void destroyBuffer(const Device& device, Buffer& buffer) {
    if (buffer.buffer) vkDestroyBuffer(device.device, buffer.buffer, nullptr);
    if (buffer.memory) vkFreeMemory(device.device, buffer.memory, nullptr); // unmaps implicitly
    buffer = Buffer{};
}

void writeBuffer(const Context& context, Buffer& buffer, VkDeviceSize size,
                 const std::function<void(void*)>& fill) {
    if (buffer.mapped) {
        fill(buffer.mapped);
        if (!buffer.coherent) {
            VkMappedMemoryRange range{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE};
            range.memory = buffer.memory;
            range.size = VK_WHOLE_SIZE;
            VK_CHECK(vkFlushMappedMemoryRanges(context.device, 1, &range));
        }
        return;
    }
    Buffer staging =
        createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload, "staging");
    ScopeExit releaseStaging([&] { destroyBuffer(context, staging); });
    fill(staging.mapped);
    submitAndWait(context, [&](VkCommandBuffer commands) {
        VkBufferCopy region{0, 0, size};
        vkCmdCopyBuffer(commands, staging.buffer, buffer.buffer, 1, &region);
        computeWriteBarrier(commands); // later submissions' shaders read what the copy wrote
    });
}

void uploadBuffer(const Context& context, Buffer& buffer, const void* data, VkDeviceSize size) {
    writeBuffer(context, buffer, size,
                [&](void* destination) { std::memcpy(destination, data, size_t(size)); });
}

void invalidateBuffer(const Device& device, const Buffer& buffer) {
    if (buffer.coherent) return;
    VkMappedMemoryRange range{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE};
    range.memory = buffer.memory;
    range.size = VK_WHOLE_SIZE;
    VK_CHECK(vkInvalidateMappedMemoryRanges(device.device, 1, &range));
}

uint64_t submissionCount() {
    return gSubmissions;
}

void submitAndWait(const Context& context, const std::function<void(VkCommandBuffer)>& record) {
    VkCommandBuffer commands = allocateCommandBuffer(context);
    ScopeExit freeCommands([&] { vkFreeCommandBuffers(context.device, context.commandPool, 1, &commands); });
    beginCommands(commands);
    record(commands);
    VK_CHECK(vkEndCommandBuffer(commands));

    VkFence fence = createFence(context);
    ScopeExit destroyFence([&] { vkDestroyFence(context.device, fence, nullptr); });
    submitCommands(context, commands, fence);
    VK_CHECK(vkWaitForFences(context.device, 1, &fence, VK_TRUE, UINT64_MAX));
}

VkCommandBuffer allocateCommandBuffer(const Context& context) {
    VkCommandBufferAllocateInfo allocate{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    allocate.commandPool = context.commandPool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateCommandBuffers(context.device, &allocate, &commands));
    return commands;
}

void beginCommands(VkCommandBuffer commands) {
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(commands, &begin));
}

VkFence createFence(const Device& device, bool signalled) {
    VkFenceCreateInfo info{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    info.flags = signalled ? VK_FENCE_CREATE_SIGNALED_BIT : 0;
    VkFence fence = VK_NULL_HANDLE;
    VK_CHECK(vkCreateFence(device.device, &info, nullptr, &fence));
    return fence;
}

VkSemaphore createSemaphore(const Device& device) {
    VkSemaphoreCreateInfo info{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    VkSemaphore semaphore = VK_NULL_HANDLE;
    VK_CHECK(vkCreateSemaphore(device.device, &info, nullptr, &semaphore));
    return semaphore;
}

void submitCommands(const Context& context, VkCommandBuffer commands, VkFence fence, const QueueSync& sync) {
    VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    if (sync.wait) {
        submit.waitSemaphoreCount = 1;
        submit.pWaitSemaphores = &sync.wait;
        submit.pWaitDstStageMask = &sync.waitStage;
    }
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &commands;
    if (sync.signal) {
        submit.signalSemaphoreCount = 1;
        submit.pSignalSemaphores = &sync.signal;
    }
    VK_CHECK(vkQueueSubmit(context.queue, 1, &submit, fence));
    ++gSubmissions;
}

VkQueryPool createTimestampPool(const Device& device) {
    if (!device.info.timestamps) return VK_NULL_HANDLE;
    VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = 2;
    VkQueryPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateQueryPool(device.device, &info, nullptr, &pool));
    return pool;
}

double timestampMilliseconds(const Device& device, VkQueryPool pool) {
    if (!pool) return 0.0;
    uint64_t ticks[2] = {};
    VK_CHECK(vkGetQueryPoolResults(device.device, pool, 0, 2, sizeof(ticks), ticks, sizeof(uint64_t),
                                   VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    // Only timestampValidBits bits count; masking the difference also handles a wrap-around.
    uint32_t bits = device.info.timestampValidBits;
    uint64_t mask = bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
    return double((ticks[1] - ticks[0]) & mask) * device.info.timestampPeriod * 1e-6;
}

void computeWriteBarrier(VkCommandBuffer commands) {
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                            VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT |
                            VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                             VK_PIPELINE_STAGE_HOST_BIT,
                         0, 1, &barrier, 0, nullptr, 0, nullptr);
}

} // namespace shprobe
