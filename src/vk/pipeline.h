// Compute programs: a shader module, its descriptor-set layout (storage buffers at bindings
// 0..n-1 of set 0), push-constant range and pipeline, specialized by workgroup width and SH order.
#pragma once
#include "vk/context.h"
#include "vk/resources.h"
#include <cstdint>
#include <span>

namespace shprobe {

struct ComputeProgramDesc {
    const char* name = "";             // for error messages
    std::span<const uint32_t> spirv;   // the module's words
    uint32_t storageBufferCount = 0;   // bindings 0..n-1 of set 0, all storage buffers
    uint32_t pushConstantSize = 0;     // bytes
    uint32_t localSize = 64;           // specialization constant 0
    uint32_t order = 3;                // specialization constant 1
};

struct ComputeProgram {
    VkShaderModule module = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    uint32_t storageBufferCount = 0;
    uint32_t pushConstantSize = 0;
};

ComputeProgram createComputeProgram(const Context& context, const ComputeProgramDesc& desc);
void destroyComputeProgram(const Context& context, ComputeProgram& program);

// A range of a buffer bound to one storage-buffer binding.
struct BufferRange {
    const Buffer* buffer;
    VkDeviceSize offset;
    VkDeviceSize size;
};

// Allocates a descriptor set of the program from pool and points its bindings at the ranges
// (one per storage buffer of the program, in binding order).
VkDescriptorSet createDescriptorSet(const Context& context, VkDescriptorPool pool, const ComputeProgram& program,
                                    std::span<const BufferRange> ranges);
VkDescriptorPool createDescriptorPool(const Context& context, uint32_t maxSets, uint32_t maxStorageBuffers);

// Binds the program and set, pushes the constants and dispatches groupCount workgroups (x only).
// The push-constant block must be the size the program was created with.
template <typename PushConstants>
void dispatch(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
              const PushConstants& constants, uint32_t groupCount);

void dispatchRaw(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
                 const void* constants, uint32_t constantsSize, uint32_t groupCount);

template <typename PushConstants>
void dispatch(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
              const PushConstants& constants, uint32_t groupCount) {
    dispatchRaw(commands, program, set, &constants, uint32_t(sizeof(PushConstants)), groupCount);
}

} // namespace shprobe
