// Compute programs: a shader module, its descriptor-set layout (set 0: storage buffers, combined
// image samplers and storage images), push-constant range and pipeline, specialized by workgroup width and
// SH order. Also the pieces they are made of, which graphics pipelines share (vk/graphics.h): shader
// modules, set and pipeline layouts, descriptor pools and sets.
#pragma once
#include "vk/context.h"
#include "vk/resources.h"
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
    uint32_t localSize = 64;                     // specialization constant SHPROBE_SPEC_LOCAL_SIZE
    uint32_t order = 3;                          // specialization constant SHPROBE_SPEC_ORDER
    uint32_t variant = 0;                        // specialization constant SHPROBE_SPEC_VARIANT
};

struct ComputeProgram {
    VkShaderModule module = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    std::vector<VkDescriptorType> bindings;
    uint32_t pushConstantSize = 0;
    uint32_t localSize = 0; // invocations a workgroup
};

ComputeProgram createComputeProgram(const Device& device, const ComputeProgramDesc& desc);
void destroyComputeProgram(const Device& device, ComputeProgram& program);

// What one binding points at: a range of a buffer, or an image view (in SHADER_READ_ONLY_OPTIMAL when
// sampled, GENERAL when a storage image) with, for a combined image sampler whose layout has no
// immutable sampler, its sampler.
struct BindingTarget {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceSize offset = 0;
    VkDeviceSize size = VK_WHOLE_SIZE;
    VkImageView imageView = VK_NULL_HANDLE;
    VkSampler sampler = VK_NULL_HANDLE;
};

// Allocates a descriptor set of the program from pool and points its bindings at the targets
// (one per binding of the program, in binding order).
VkDescriptorSet createDescriptorSet(const Device& device, VkDescriptorPool pool,
                                    const ComputeProgram& program, std::span<const BindingTarget> targets);

struct DescriptorPoolSize {
    uint32_t sets = 0;
    uint32_t storageBuffers = 0;
    uint32_t imageSamplers = 0;
    uint32_t storageImages = 0;
    uint32_t uniformBuffers = 0;
    bool freeSets = false; // sets may be freed one by one (vkFreeDescriptorSets)
};
VkDescriptorPool createDescriptorPool(const Device& device, const DescriptorPoolSize& size);

// ---- The pieces ------------------------------------------------------------------------------

VkShaderModule createShaderModule(const Device& device, std::span<const uint32_t> spirv);

// Binding i of a set layout: its type, the stages that read it and, for a combined image sampler,
// the sampler fixed in the layout (none: each descriptor write names one).
struct LayoutBinding {
    VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    VkShaderStageFlags stages = VK_SHADER_STAGE_COMPUTE_BIT;
    VkSampler immutableSampler = VK_NULL_HANDLE;
};
VkDescriptorSetLayout createSetLayout(const Device& device, std::span<const LayoutBinding> bindings);

// One set layout and, when pushConstantSize > 0, one push-constant range from offset 0 that
// `pushStages` read.
VkPipelineLayout createPipelineLayout(const Device& device, VkDescriptorSetLayout setLayout,
                                      VkShaderStageFlags pushStages, uint32_t pushConstantSize);

// A set of `layout` from pool, its bindings not yet written.
VkDescriptorSet allocateDescriptorSet(const Device& device, VkDescriptorPool pool,
                                      VkDescriptorSetLayout layout);
// Points bindings firstBinding, firstBinding + 1, ... of the set, of these types, at the targets.
// Not while a command buffer that uses the set may run.
void writeDescriptors(const Device& device, VkDescriptorSet set, std::span<const VkDescriptorType> types,
                      std::span<const BindingTarget> targets, uint32_t firstBinding = 0);
// One binding.
void writeDescriptor(const Device& device, VkDescriptorSet set, uint32_t binding, VkDescriptorType type,
                     const BindingTarget& target);

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

// The workgroups that cover `threads` invocations, one each: threads / localSize rounded up.
uint64_t workgroupsFor(const ComputeProgram& program, uint64_t threads);

void dispatchRaw(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
                 const void* constants, uint32_t constantsSize, GroupCount groups);

template <typename PushConstants>
void dispatch(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
              const PushConstants& constants, GroupCount groups) {
    dispatchRaw(commands, program, set, &constants, uint32_t(sizeof(PushConstants)), groups);
}

} // namespace shprobe
