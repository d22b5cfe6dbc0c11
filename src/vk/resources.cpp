#include "shprobe/vk/resources.h"

#include "shprobe/vk/check.h"

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

VkDeviceMemory allocateMemory(const Context& context, VkMemoryRequirements requirements, uint32_t type,
                              const char* what) {
    checkAllocationSize(context, requirements.size, type, what);
    VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    info.allocationSize = requirements.size;
    info.memoryTypeIndex = type;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkResult result = vkAllocateMemory(context.device, &info, nullptr, &memory);
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY)
        throw Error(ErrorKind::Device, std::string("allocating ") + sizeText(requirements.size) + " for " +
                                           what + ": out of memory on " + context.info.name +
                                           "; try a smaller --face-size");
    VK_CHECK(result);
    return memory;
}

} // namespace

void checkAllocationSize(const Context& context, VkDeviceSize size, uint32_t memoryType, const char* what) {
    VkPhysicalDeviceMaintenance3Properties maintenance3{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &maintenance3};
    vkGetPhysicalDeviceProperties2(context.physicalDevice, &properties);
    const VkDeviceSize heap =
        context.memory.memoryHeaps[context.memory.memoryTypes[memoryType].heapIndex].size;
    const VkDeviceSize limit = std::min(heap, maintenance3.maxMemoryAllocationSize);
    if (size > limit)
        throw Error(ErrorKind::Device, std::string("allocating ") + sizeText(size) + " for " + what +
                                           ": more than one allocation may hold on " + context.info.name +
                                           " (" + sizeText(limit) +
                                           "); try a smaller --face-size or fewer probes at a time");
}

Buffer createBuffer(const Context& context, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use,
                    const char* what) {
    Buffer buffer;
    buffer.size = size;
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VK_CHECK(vkCreateBuffer(context.device, &info, nullptr, &buffer.buffer));

    try {
        VkMemoryRequirements requirements;
        vkGetBufferMemoryRequirements(context.device, buffer.buffer, &requirements);
        uint32_t type = findMemoryType(context.memory, requirements.memoryTypeBits, memoryPreference(use));
        if (type == UINT32_MAX)
            throw Error(ErrorKind::Device, std::string("no suitable memory type for ") + what);
        buffer.memory = allocateMemory(context, requirements, type, what);
        VK_CHECK(vkBindBufferMemory(context.device, buffer.buffer, buffer.memory, 0));

        VkMemoryPropertyFlags flags = context.memory.memoryTypes[type].propertyFlags;
        buffer.coherent = flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        if (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
            VK_CHECK(vkMapMemory(context.device, buffer.memory, 0, VK_WHOLE_SIZE, 0, &buffer.mapped));
    } catch (...) {
        destroyBuffer(context, buffer);
        throw;
    }
    return buffer;
}

void destroyBuffer(const Context& context, Buffer& buffer) {
    if (buffer.buffer) vkDestroyBuffer(context.device, buffer.buffer, nullptr);
    if (buffer.memory) vkFreeMemory(context.device, buffer.memory, nullptr); // unmaps implicitly
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
    try {
        fill(staging.mapped);
        submitAndWait(context, [&](VkCommandBuffer commands) {
            VkBufferCopy region{0, 0, size};
            vkCmdCopyBuffer(commands, staging.buffer, buffer.buffer, 1, &region);
            computeWriteBarrier(commands); // later submissions' shaders read what the copy wrote
        });
    } catch (...) {
        destroyBuffer(context, staging);
        throw;
    }
    destroyBuffer(context, staging);
}

void uploadBuffer(const Context& context, Buffer& buffer, const void* data, VkDeviceSize size) {
    writeBuffer(context, buffer, size,
                [&](void* destination) { std::memcpy(destination, data, size_t(size)); });
}

void invalidateBuffer(const Context& context, const Buffer& buffer) {
    if (buffer.coherent) return;
    VkMappedMemoryRange range{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE};
    range.memory = buffer.memory;
    range.size = VK_WHOLE_SIZE;
    VK_CHECK(vkInvalidateMappedMemoryRanges(context.device, 1, &range));
}

uint64_t submissionCount() {
    return gSubmissions;
}

void submitAndWait(const Context& context, const std::function<void(VkCommandBuffer)>& record) {
    VkCommandBufferAllocateInfo allocate{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    allocate.commandPool = context.commandPool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateCommandBuffers(context.device, &allocate, &commands));
    VkFence fence = VK_NULL_HANDLE;
    try {
        VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        VK_CHECK(vkBeginCommandBuffer(commands, &begin));
        record(commands);
        VK_CHECK(vkEndCommandBuffer(commands));

        VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        VK_CHECK(vkCreateFence(context.device, &fenceInfo, nullptr, &fence));
        VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &commands;
        VK_CHECK(vkQueueSubmit(context.queue, 1, &submit, fence));
        ++gSubmissions;
        VK_CHECK(vkWaitForFences(context.device, 1, &fence, VK_TRUE, UINT64_MAX));
    } catch (...) {
        if (fence) vkDestroyFence(context.device, fence, nullptr);
        vkFreeCommandBuffers(context.device, context.commandPool, 1, &commands);
        throw;
    }
    vkDestroyFence(context.device, fence, nullptr);
    vkFreeCommandBuffers(context.device, context.commandPool, 1, &commands);
}

VkQueryPool createTimestampPool(const Context& context) {
    if (!context.info.timestamps) return VK_NULL_HANDLE;
    VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = 2;
    VkQueryPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateQueryPool(context.device, &info, nullptr, &pool));
    return pool;
}

double timestampMilliseconds(const Context& context, VkQueryPool pool) {
    if (!pool) return 0.0;
    uint64_t ticks[2] = {};
    VK_CHECK(vkGetQueryPoolResults(context.device, pool, 0, 2, sizeof(ticks), ticks, sizeof(uint64_t),
                                   VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    // Only timestampValidBits bits count; masking the difference also handles a wrap-around.
    uint32_t bits = context.info.timestampValidBits;
    uint64_t mask = bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
    return double((ticks[1] - ticks[0]) & mask) * context.info.timestampPeriod * 1e-6;
}

void computeWriteBarrier(VkCommandBuffer commands) {
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                             VK_PIPELINE_STAGE_HOST_BIT,
                         0, 1, &barrier, 0, nullptr, 0, nullptr);
}

} // namespace shprobe
