#include "gpu/rotator.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/gpu_interface.h"
#include "sh/basis.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_spirv.h>

#include <cstring>
#include <glm/vec4.hpp>

namespace shprobe {

namespace {

// Floats taken by one rotation's band matrices: sum over l < order of (2l+1)^2.
size_t matrixFloats(int order) {
    return size_t(order) * (4 * size_t(order) * order - 1) / 3;
}

void checkInputs(const Rotator& rotator, std::span<const ShRotation> rotations,
                 std::span<const ShCoefficients> probes) {
    if (rotations.size() != 1 && rotations.size() != probes.size())
        throw Error(ErrorKind::Input, "GPU rotation: " + std::to_string(rotations.size()) +
                                          " rotations for " + std::to_string(probes.size()) +
                                          " probes (give 1 or one per probe)");
    for (const ShRotation& rotation : rotations)
        if (rotation.order != rotator.order)
            throw Error(ErrorKind::Input, "GPU rotation: a rotation of order " +
                                              std::to_string(rotation.order) + " for a rotator of order " +
                                              std::to_string(rotator.order));
    for (const ShCoefficients& probe : probes)
        if (probe.order != rotator.order || probe.rgb.size() != size_t(coefficientCount(probe.order)))
            throw Error(ErrorKind::Input, "GPU rotation: a probe of order " + std::to_string(probe.order) +
                                              " for a rotator of order " + std::to_string(rotator.order));
}

std::vector<float> packMatrices(std::span<const ShRotation> rotations) {
    std::vector<float> packed;
    for (const ShRotation& rotation : rotations)
        for (const std::vector<double>& band : rotation.bands)
            packed.insert(packed.end(), band.begin(), band.end());
    return packed;
}

std::vector<glm::vec4> packProbes(std::span<const ShCoefficients> probes) {
    std::vector<glm::vec4> packed;
    for (const ShCoefficients& probe : probes)
        for (const glm::dvec3& c : probe.rgb)
            packed.emplace_back(glm::vec3(c), 0.0f);
    return packed;
}

} // namespace

Rotator createRotator(const Device& device, int order) {
    requireOrder(order);
    Rotator rotator;
    rotator.order = order;
    static constexpr VkDescriptorType kBindings[] = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                                     VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                                     VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    rotator.program = createComputeProgram(device, {.name = "rotate.comp",
                                                    .spirv = spirv::rotate_comp,
                                                    .bindings = kBindings,
                                                    .pushConstantSize = sizeof(glsl::RotateParams),
                                                    .order = uint32_t(order)});
    return rotator;
}

void destroyRotator(const Device& device, Rotator& rotator) {
    destroyComputeProgram(device, rotator.program);
}

std::vector<ShCoefficients> rotateOnGpu(const Context& context, const Rotator& rotator,
                                        std::span<const ShRotation> rotations,
                                        std::span<const ShCoefficients> probes) {
    checkInputs(rotator, rotations, probes);
    if (probes.empty()) return {};
    const std::vector<float> matrices = packMatrices(rotations);
    const std::vector<glm::vec4> input = packProbes(probes);
    const VkDeviceSize matrixBytes = matrices.size() * sizeof(float);
    const VkDeviceSize probeBytes = input.size() * sizeof(glm::vec4);
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;

    Buffer matrixBuffer = createBuffer(context, matrixBytes, usage, MemoryUse::Device, "rotation matrices");
    ScopeExit releaseMatrices([&] { destroyBuffer(context, matrixBuffer); });
    Buffer probeBuffer = createBuffer(context, probeBytes, usage, MemoryUse::Device, "probes to rotate");
    ScopeExit releaseProbes([&] { destroyBuffer(context, probeBuffer); });
    Buffer rotatedBuffer = createBuffer(context, probeBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                        MemoryUse::Readback, "rotated probes");
    ScopeExit releaseRotated([&] { destroyBuffer(context, rotatedBuffer); });
    uploadBuffer(context, matrixBuffer, matrices.data(), matrixBytes);
    uploadBuffer(context, probeBuffer, input.data(), probeBytes);
    VkDescriptorPool pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 3});
    ScopeExit releasePool([&] { vkDestroyDescriptorPool(context.device, pool, nullptr); });
    BindingTarget targets[] = {{matrixBuffer.buffer, 0, matrixBytes},
                               {probeBuffer.buffer, 0, probeBytes},
                               {rotatedBuffer.buffer, 0, probeBytes}};
    VkDescriptorSet set = createDescriptorSet(context, pool, rotator.program, targets);

    uint32_t stride = rotations.size() == 1 ? 0u : uint32_t(matrixFloats(rotator.order));
    glsl::RotateParams params{uint32_t(probes.size()), stride};
    const uint64_t groups = workgroupsFor(rotator.program, input.size());
    if (groups > context.info.limits.maxComputeWorkGroupCount[0])
        throw Error(ErrorKind::Input, "GPU rotation: " + std::to_string(probes.size()) +
                                          " probes are more than one dispatch can rotate on " +
                                          context.info.name + "; rotate them in smaller batches");
    submitAndWait(context, [&](VkCommandBuffer commands) {
        dispatch(commands, rotator.program, set, params, {uint32_t(groups)});
        computeWriteBarrier(commands);
    });
    invalidateBuffer(context, rotatedBuffer);
    std::vector<ShCoefficients> rotated;
    auto* values = static_cast<const glm::vec4*>(rotatedBuffer.mapped);
    for (const ShCoefficients& probe : probes) {
        ShCoefficients result = makeCoefficients(probe.order, probe.quantity);
        for (glm::dvec3& c : result.rgb)
            c = glm::dvec3(glm::vec3(*values++));
        rotated.push_back(std::move(result));
    }
    return rotated;
}

RotatedProbe createRotatedProbe(const Context& context, const Rotator& rotator, const ShCoefficients& probe) {
    const ShRotation identity = makeShRotation(glm::dmat3(1.0), rotator.order);
    checkInputs(rotator, {&identity, 1}, {&probe, 1});
    RotatedProbe rotated;
    OnFailure undo([&] { destroyRotatedProbe(context, rotated); });
    const std::vector<glm::vec4> input = packProbes({&probe, 1});
    const VkDeviceSize matrixBytes = matrixFloats(rotator.order) * sizeof(float);
    const VkDeviceSize probeBytes = input.size() * sizeof(glm::vec4);
    rotated.matrices = createBuffer(context, matrixBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                    MemoryUse::Upload, "rotation matrices");
    rotated.probe = createBuffer(context, probeBytes,
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                 MemoryUse::Device, "probe to rotate");
    uploadBuffer(context, rotated.probe, input.data(), probeBytes);
    rotated.rotated = createBuffer(context, probeBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device,
                                   "rotated probe");
    rotated.pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 3});
    const BindingTarget targets[] = {{rotated.matrices.buffer, 0, matrixBytes},
                                     {rotated.probe.buffer, 0, probeBytes},
                                     {rotated.rotated.buffer, 0, probeBytes}};
    rotated.set = createDescriptorSet(context, rotated.pool, rotator.program, targets);
    setProbeRotation(rotated, identity);
    return rotated;
}

void destroyRotatedProbe(const Device& device, RotatedProbe& rotated) {
    if (rotated.pool) vkDestroyDescriptorPool(device.device, rotated.pool, nullptr);
    destroyBuffer(device, rotated.rotated);
    destroyBuffer(device, rotated.probe);
    destroyBuffer(device, rotated.matrices);
    rotated = RotatedProbe{};
}

void setProbeRotation(const RotatedProbe& rotated, const ShRotation& rotation) {
    const std::vector<float> matrices = packMatrices({&rotation, 1});
    if (matrices.size() * sizeof(float) != rotated.matrices.size)
        throw Error(ErrorKind::Input, "GPU rotation: a rotation of order " + std::to_string(rotation.order) +
                                          " for a probe of another order");
    std::memcpy(rotated.matrices.mapped, matrices.data(), rotated.matrices.size);
}

void recordProbeRotation(VkCommandBuffer commands, const Rotator& rotator, const RotatedProbe& rotated,
                         VkPipelineStageFlags readers) {
    const uint32_t coefficients = uint32_t(coefficientCount(rotator.order));
    dispatch(commands, rotator.program, rotated.set, glsl::RotateParams{1u, 0u},
             {uint32_t(workgroupsFor(rotator.program, coefficients))});
    const VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT,
                                  VK_ACCESS_SHADER_READ_BIT};
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, readers, 0, 1, &barrier, 0, nullptr,
                         0, nullptr);
}

} // namespace shprobe
