// Compute programs: a shader module, its descriptor-set layout (set 0: storage buffers, combined
// image samplers and storage images), push-constant range and pipeline, specialized by workgroup width and
// SH order.
#pragma once
#include "shprobe/vk/context.h"
#include "shprobe/vk/resources.h"
#include <cstdint>
#include <span>
#include <vector>

namespace shprobe {

struct ComputeProgramDesc {
    const char* name = "";           // for error messages
    std::span<const uint32_t> spirv; // the module's words
    std::span<const VkDescriptorType>
        bindings; // binding i of set 0: STORAGE_BUFFER, COMBINED_IMAGE_SAMPLER or STORAGE_IMAGE
    VkSampler immutableSampler = VK_NULL_HANDLE; // the sampler of every combined image sampler
    uint32_t pushConstantSize = 0;               // bytes
    uint32_t localSize = 64;                     // specialization constant 0
    uint32_t order = 3;                          // specialization constant 1
    VkPipelineCache cache = VK_NULL_HANDLE;      // optional
};

struct ComputeProgram {
    VkShaderModule module = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    std::vector<VkDescriptorType> bindings;
    uint32_t pushConstantSize = 0;
};

ComputeProgram createComputeProgram(const Context& context, const ComputeProgramDesc& desc);
void destroyComputeProgram(const Context& context, ComputeProgram& program);

// What one binding points at: a range of a buffer, or an image view (in SHADER_READ_ONLY_OPTIMAL when
// sampled, GENERAL when a storage image).
struct BindingTarget {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceSize offset = 0;
    VkDeviceSize size = VK_WHOLE_SIZE;
    VkImageView imageView = VK_NULL_HANDLE;
};

// Allocates a descriptor set of the program from pool and points its bindings at the targets
// (one per binding of the program, in binding order).
VkDescriptorSet createDescriptorSet(const Context& context, VkDescriptorPool pool,
                                    const ComputeProgram& program, std::span<const BindingTarget> targets);

struct DescriptorPoolSize {
    uint32_t sets = 0;
    uint32_t storageBuffers = 0;
    uint32_t imageSamplers = 0;
    uint32_t storageImages = 0;
};
VkDescriptorPool createDescriptorPool(const Context& context, const DescriptorPoolSize& size);

// Workgroups of a dispatch: x, and y (the probe index of the baking modules).
struct GroupCount {
    uint32_t x = 1;
    uint32_t y = 1;
};

// Binds the program and set, pushes the constants and dispatches the workgroups.
// The push-constant block must be the size the program was created with.
template <typename PushConstants>
void dispatch(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
              const PushConstants& constants, GroupCount groups);

void dispatchRaw(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
                 const void* constants, uint32_t constantsSize, GroupCount groups);

template <typename PushConstants>
void dispatch(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
              const PushConstants& constants, GroupCount groups) {
    dispatchRaw(commands, program, set, &constants, uint32_t(sizeof(PushConstants)), groups);
}

} // namespace shprobe
