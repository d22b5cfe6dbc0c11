#include "shprobe/vk/pipeline.h"

#include "shprobe/vk/check.h"

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

VkDescriptorSetLayout createSetLayout(const Context& context, std::span<const VkDescriptorType> types,
                                      const VkSampler* immutableSampler) {
    std::vector<VkDescriptorSetLayoutBinding> bindings(types.size());
    for (uint32_t i = 0; i < bindings.size(); ++i) {
        bool image = types[i] == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        bindings[i] = {i, types[i], 1, VK_SHADER_STAGE_COMPUTE_BIT, image ? immutableSampler : nullptr};
    }
    VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    info.bindingCount = uint32_t(bindings.size());
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
    VK_CHECK(vkCreateComputePipelines(context.device, desc.cache, 1, &info, nullptr, &pipeline));
    return pipeline;
}

} // namespace

ComputeProgram createComputeProgram(const Context& context, const ComputeProgramDesc& desc) {
    if (desc.localSize == 0 || desc.localSize > context.info.limits.maxComputeWorkGroupSize[0] ||
        desc.localSize > context.info.limits.maxComputeWorkGroupInvocations)
        throw Error(ErrorKind::Input,
                    std::string(desc.name) + ": workgroup size " + std::to_string(desc.localSize) +
                        " is not supported by " + context.info.name + " (at most " +
                        std::to_string(context.info.limits.maxComputeWorkGroupInvocations) + ")");
    ComputeProgram program;
    program.bindings.assign(desc.bindings.begin(), desc.bindings.end());
    program.pushConstantSize = desc.pushConstantSize;
    try {
        program.module = createShaderModule(context, desc.spirv);
        program.setLayout = createSetLayout(context, desc.bindings, &desc.immutableSampler);
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

VkDescriptorPool createDescriptorPool(const Context& context, const DescriptorPoolSize& size) {
    std::vector<VkDescriptorPoolSize> sizes;
    if (size.storageBuffers) sizes.push_back({VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, size.storageBuffers});
    if (size.imageSamplers) sizes.push_back({VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, size.imageSamplers});
    if (size.storageImages) sizes.push_back({VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, size.storageImages});
    VkDescriptorPoolCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    info.maxSets = size.sets;
    info.poolSizeCount = uint32_t(sizes.size());
    info.pPoolSizes = sizes.data();
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorPool(context.device, &info, nullptr, &pool));
    return pool;
}

VkDescriptorSet createDescriptorSet(const Context& context, VkDescriptorPool pool,
                                    const ComputeProgram& program, std::span<const BindingTarget> targets) {
    if (targets.size() != program.bindings.size())
        throw Error(ErrorKind::Device, "descriptor set with " + std::to_string(targets.size()) +
                                           " targets for a program with " +
                                           std::to_string(program.bindings.size()) + " bindings");
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &program.setLayout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateDescriptorSets(context.device, &allocate, &set));

    std::vector<VkDescriptorBufferInfo> buffers(targets.size());
    std::vector<VkDescriptorImageInfo> images(targets.size());
    std::vector<VkWriteDescriptorSet> writes(targets.size());
    for (uint32_t i = 0; i < writes.size(); ++i) {
        buffers[i] = {targets[i].buffer, targets[i].offset, targets[i].size};
        const bool storageImage = program.bindings[i] == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
        images[i] = {VK_NULL_HANDLE, targets[i].imageView,
                     storageImage ? VK_IMAGE_LAYOUT_GENERAL : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        writes[i].dstSet = set;
        writes[i].dstBinding = i;
        writes[i].descriptorCount = 1;
        writes[i].descriptorType = program.bindings[i];
        if (storageImage || program.bindings[i] == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER)
            writes[i].pImageInfo = &images[i];
        else
            writes[i].pBufferInfo = &buffers[i];
    }
    vkUpdateDescriptorSets(context.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
    return set;
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
