#include "vk/pipeline.h"

#include "vk/check.h"

#include <array>
#include <vector>

namespace shprobe {

namespace {

VkShaderModule createShaderModule(const Context& context, std::span<const uint32_t> spirv) {
    VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    info.codeSize = spirv.size_bytes();
    info.pCode = spirv.data();
    VkShaderModule module = VK_NULL_HANDLE;
    VK_CHECK(vkCreateShaderModule(context.device, &info, nullptr, &module));
    return module;
}

VkDescriptorSetLayout createStorageBufferSetLayout(const Context& context, uint32_t count) {
    std::vector<VkDescriptorSetLayoutBinding> bindings(count);
    for (uint32_t i = 0; i < count; ++i)
        bindings[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    info.bindingCount = count;
    info.pBindings = bindings.data();
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorSetLayout(context.device, &info, nullptr, &layout));
    return layout;
}

VkPipelineLayout createPipelineLayout(const Context& context, VkDescriptorSetLayout setLayout,
                                      uint32_t pushConstantSize) {
    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushConstantSize};
    VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    info.setLayoutCount = 1;
    info.pSetLayouts = &setLayout;
    info.pushConstantRangeCount = pushConstantSize ? 1 : 0;
    info.pPushConstantRanges = &range;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreatePipelineLayout(context.device, &info, nullptr, &layout));
    return layout;
}

VkPipeline createPipeline(const Context& context, VkShaderModule module, VkPipelineLayout layout,
                          const ComputeProgramDesc& desc) {
    // Specialization constant ids 0 and 1: SHPROBE_SPEC_LOCAL_SIZE, SHPROBE_SPEC_ORDER.
    std::array<uint32_t, 2> values{desc.localSize, desc.order};
    std::array<VkSpecializationMapEntry, 2> entries{{{0, 0, 4}, {1, 4, 4}}};
    VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(), sizeof(values), values.data()};

    VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = layout;
    VkPipeline pipeline = VK_NULL_HANDLE;
    VK_CHECK(vkCreateComputePipelines(context.device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    return pipeline;
}

} // namespace

ComputeProgram createComputeProgram(const Context& context, const ComputeProgramDesc& desc) {
    if (desc.localSize == 0 || desc.localSize > context.info.limits.maxComputeWorkGroupSize[0] ||
        desc.localSize > context.info.limits.maxComputeWorkGroupInvocations)
        throw Error(ErrorKind::Input, std::string(desc.name) + ": workgroup size " + std::to_string(desc.localSize) +
                                          " is not supported by " + context.info.name + " (at most " +
                                          std::to_string(context.info.limits.maxComputeWorkGroupInvocations) + ")");
    ComputeProgram program;
    program.storageBufferCount = desc.storageBufferCount;
    program.pushConstantSize = desc.pushConstantSize;
    try {
        program.module = createShaderModule(context, desc.spirv);
        program.setLayout = createStorageBufferSetLayout(context, desc.storageBufferCount);
        program.layout = createPipelineLayout(context, program.setLayout, desc.pushConstantSize);
        program.pipeline = createPipeline(context, program.module, program.layout, desc);
    } catch (...) {
        destroyComputeProgram(context, program);
        throw;
    }
    return program;
}

void destroyComputeProgram(const Context& context, ComputeProgram& program) {
    if (program.pipeline) vkDestroyPipeline(context.device, program.pipeline, nullptr);
    if (program.layout) vkDestroyPipelineLayout(context.device, program.layout, nullptr);
    if (program.setLayout) vkDestroyDescriptorSetLayout(context.device, program.setLayout, nullptr);
    if (program.module) vkDestroyShaderModule(context.device, program.module, nullptr);
    program = ComputeProgram{};
}

VkDescriptorPool createDescriptorPool(const Context& context, uint32_t maxSets, uint32_t maxStorageBuffers) {
    VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, maxStorageBuffers};
    VkDescriptorPoolCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    info.maxSets = maxSets;
    info.poolSizeCount = 1;
    info.pPoolSizes = &size;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorPool(context.device, &info, nullptr, &pool));
    return pool;
}

VkDescriptorSet createDescriptorSet(const Context& context, VkDescriptorPool pool, const ComputeProgram& program,
                                    std::span<const BufferRange> ranges) {
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &program.setLayout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateDescriptorSets(context.device, &allocate, &set));

    std::vector<VkDescriptorBufferInfo> buffers;
    for (const BufferRange& range : ranges) buffers.push_back({range.buffer->buffer, range.offset, range.size});
    std::vector<VkWriteDescriptorSet> writes(buffers.size());
    for (uint32_t i = 0; i < writes.size(); ++i) {
        writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        writes[i].dstSet = set;
        writes[i].dstBinding = i;
        writes[i].descriptorCount = 1;
        writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        writes[i].pBufferInfo = &buffers[i];
    }
    vkUpdateDescriptorSets(context.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
    return set;
}

void dispatchRaw(VkCommandBuffer commands, const ComputeProgram& program, VkDescriptorSet set,
                 const void* constants, uint32_t constantsSize, uint32_t groupCount) {
    if (constantsSize != program.pushConstantSize)
        throw Error(ErrorKind::Device, "push constants of " + std::to_string(constantsSize) +
                                           " bytes for a program that takes " +
                                           std::to_string(program.pushConstantSize));
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.pipeline);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.layout, 0, 1, &set, 0, nullptr);
    if (constantsSize)
        vkCmdPushConstants(commands, program.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, constantsSize, constants);
    vkCmdDispatch(commands, groupCount, 1, 1);
}

} // namespace shprobe
