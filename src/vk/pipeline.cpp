#include "vk/pipeline.h"

#include "common/scope_exit.h"
#include "glsl/gpu_interface.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#include <array>
#include <vector>

namespace shprobe {

namespace {

VkPipeline createPipeline(const Device& device, VkShaderModule module, VkPipelineLayout layout,
                          const ComputeProgramDesc& desc) {
    std::array<uint32_t, 3> values{desc.localSize, desc.order, desc.variant};
    std::array<VkSpecializationMapEntry, 3> entries{
        {{SHPROBE_SPEC_LOCAL_SIZE, 0, 4}, {SHPROBE_SPEC_ORDER, 4, 4}, {SHPROBE_SPEC_VARIANT, 8, 4}}};
    VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(), sizeof(values),
                                        values.data()};

    VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = layout;
    VkPipeline pipeline = VK_NULL_HANDLE;
    VK_CHECK(vkCreateComputePipelines(device.device, device.pipelineCache, 1, &info, nullptr, &pipeline));
    return pipeline;
}

} // namespace

ComputeProgram createComputeProgram(const Device& device, const ComputeProgramDesc& desc) {
    if (desc.localSize == 0 || desc.localSize > device.info.limits.maxComputeWorkGroupSize[0] ||
        desc.localSize > device.info.limits.maxComputeWorkGroupInvocations)
        throw Error(ErrorKind::Input,
                    std::string(desc.name) + ": workgroup size " + std::to_string(desc.localSize) +
                        " is not supported by " + device.info.name + " (at most " +
                        std::to_string(device.info.limits.maxComputeWorkGroupInvocations) + ")");
    ComputeProgram program;
    program.bindings.assign(desc.bindings.begin(), desc.bindings.end());
    program.pushConstantSize = desc.pushConstantSize;
    program.localSize = desc.localSize;
    OnFailure undo([&] { destroyComputeProgram(device, program); });
    std::vector<LayoutBinding> bindings;
    for (VkDescriptorType type : desc.bindings)
        bindings.push_back(
            {type, VK_SHADER_STAGE_COMPUTE_BIT,
             type == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER ? desc.immutableSampler : VK_NULL_HANDLE});
    program.module = createShaderModule(device, desc.spirv);
    program.setLayout = createSetLayout(device, bindings);
    program.layout =
        createPipelineLayout(device, program.setLayout, VK_SHADER_STAGE_COMPUTE_BIT, desc.pushConstantSize);
    program.pipeline = createPipeline(device, program.module, program.layout, desc);
    return program;
}

void destroyComputeProgram(const Device& device, ComputeProgram& program) {
    if (program.pipeline) vkDestroyPipeline(device.device, program.pipeline, nullptr);
    if (program.layout) vkDestroyPipelineLayout(device.device, program.layout, nullptr);
    if (program.setLayout) vkDestroyDescriptorSetLayout(device.device, program.setLayout, nullptr);
    if (program.module) vkDestroyShaderModule(device.device, program.module, nullptr);
    program = ComputeProgram{};
}

VkDescriptorPool createDescriptorPool(const Device& device, const DescriptorPoolSize& size) {
    std::vector<VkDescriptorPoolSize> sizes;
    if (size.storageBuffers) sizes.push_back({VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, size.storageBuffers});
    if (size.imageSamplers) sizes.push_back({VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, size.imageSamplers});
    if (size.storageImages) sizes.push_back({VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, size.storageImages});
    if (size.uniformBuffers) sizes.push_back({VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, size.uniformBuffers});
    const VkDescriptorPoolCreateInfo info{
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
        .flags = size.freeSets
                     ? VkDescriptorPoolCreateFlags(VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT)
                     : 0,
        .maxSets = size.sets,
        .poolSizeCount = uint32_t(sizes.size()),
        .pPoolSizes = sizes.data()};
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorPool(device.device, &info, nullptr, &pool));
    return pool;
}

VkDescriptorSet createDescriptorSet(const Device& device, VkDescriptorPool pool,
                                    const ComputeProgram& program, std::span<const BindingTarget> targets) {
    if (targets.size() != program.bindings.size())
        throw Error(ErrorKind::Device, "descriptor set with " + std::to_string(targets.size()) +
                                           " targets for a program with " +
                                           std::to_string(program.bindings.size()) + " bindings");
    VkDescriptorSet set = allocateDescriptorSet(device, pool, program.setLayout);
    writeDescriptors(device, set, program.bindings, targets);
    return set;
}

VkShaderModule createShaderModule(const Device& device, std::span<const uint32_t> spirv) {
    const VkShaderModuleCreateInfo info{.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                        .codeSize = spirv.size_bytes(),
                                        .pCode = spirv.data()};
    VkShaderModule module = VK_NULL_HANDLE;
    VK_CHECK(vkCreateShaderModule(device.device, &info, nullptr, &module));
    return module;
}

VkDescriptorSetLayout createSetLayout(const Device& device, std::span<const LayoutBinding> bindings) {
    std::vector<VkDescriptorSetLayoutBinding> layoutBindings(bindings.size());
    for (uint32_t i = 0; i < layoutBindings.size(); ++i) {
        const LayoutBinding& binding = bindings[i];
        layoutBindings[i] = {i, binding.type, 1, binding.stages,
                             binding.immutableSampler ? &binding.immutableSampler : nullptr};
    }
    const VkDescriptorSetLayoutCreateInfo info{.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                               .bindingCount = uint32_t(layoutBindings.size()),
                                               .pBindings = layoutBindings.data()};
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorSetLayout(device.device, &info, nullptr, &layout));
    return layout;
}

VkPipelineLayout createPipelineLayout(const Device& device, VkDescriptorSetLayout setLayout,
                                      VkShaderStageFlags pushStages, uint32_t pushConstantSize) {
    const VkPushConstantRange range{pushStages, 0, pushConstantSize};
    const VkPipelineLayoutCreateInfo info{.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                          .setLayoutCount = 1,
                                          .pSetLayouts = &setLayout,
                                          .pushConstantRangeCount = pushConstantSize ? 1u : 0u,
                                          .pPushConstantRanges = &range};
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreatePipelineLayout(device.device, &info, nullptr, &layout));
    return layout;
}

VkDescriptorSet allocateDescriptorSet(const Device& device, VkDescriptorPool pool,
                                      VkDescriptorSetLayout layout) {
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &layout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateDescriptorSets(device.device, &allocate, &set));
    return set;
}

void writeDescriptors(const Device& device, VkDescriptorSet set, std::span<const VkDescriptorType> types,
                      std::span<const BindingTarget> targets, uint32_t firstBinding) {
    std::vector<VkDescriptorBufferInfo> buffers(targets.size());
    std::vector<VkDescriptorImageInfo> images(targets.size());
    std::vector<VkWriteDescriptorSet> writes(targets.size());
    for (uint32_t i = 0; i < writes.size(); ++i) {
        buffers[i] = {targets[i].buffer, targets[i].offset, targets[i].size};
        const bool storageImage = types[i] == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
        images[i] = {targets[i].sampler, targets[i].imageView,
                     storageImage ? VK_IMAGE_LAYOUT_GENERAL : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        writes[i].dstSet = set;
        writes[i].dstBinding = firstBinding + i;
        writes[i].descriptorCount = 1;
        writes[i].descriptorType = types[i];
        if (storageImage || types[i] == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER)
            writes[i].pImageInfo = &images[i];
        else
            writes[i].pBufferInfo = &buffers[i];
    }
    vkUpdateDescriptorSets(device.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
}

void writeDescriptor(const Device& device, VkDescriptorSet set, uint32_t binding, VkDescriptorType type,
                     const BindingTarget& target) {
    writeDescriptors(device, set, {&type, 1}, {&target, 1}, binding);
}

uint64_t workgroupsFor(const ComputeProgram& program, uint64_t threads) {
    return (threads + program.localSize - 1) / program.localSize;
}

void dispatchRaw(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
                 const void* constants, uint32_t constantsSize, GroupCount groups) {
    if (constantsSize != program.pushConstantSize)
        throw Error(ErrorKind::Device, "push constants of " + std::to_string(constantsSize) +
                                           " bytes for a program that takes " +
                                           std::to_string(program.pushConstantSize));
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.pipeline);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.layout, 0, 1, &set, 0, nullptr);
    if (constantsSize)
        vkCmdPushConstants(commands, program.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, constantsSize,
                           constants);
    vkCmdDispatch(commands, groups.x, groups.y, 1);
}

} // namespace shprobe
