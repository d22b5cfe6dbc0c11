#include "gpu/probe_baker.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/dispatch_plan.h"
#include "glsl/gpu_interface.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/irradiance.h"
#include "vk/check.h"
#include "vk/image.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_spirv.h>

#include <algorithm>
#include <optional>
#include <string>

namespace shprobe {

namespace {

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

// A projection's positions per probe, the texels each holds and the loop cap on the positions
// per invocation (glsl/dispatch_plan.h), and what the probes are, for messages.
struct ProjectionShape {
    uint32_t positions;
    uint32_t texelsPerPosition;
    uint32_t maxPositions;
    std::string probes; // "probe(s) of face size 256"
};

ProjectionShape cubemapShape(uint32_t order, uint32_t faceSize) {
    return {glsl::projectionPositions(faceSize), glsl::kTexelsPerPosition,
            glsl::maxPositionsPerInvocation(order), "probe(s) of face size " + std::to_string(faceSize)};
}

ProjectionShape equirectShape(uint32_t order, uint32_t width, uint32_t height) {
    return {glsl::equirectProjectionPositions(width, height), glsl::equirectTexelsPerPosition(width),
            glsl::maxEquirectPositionsPerInvocation(order),
            "equirect probe(s) of " + std::to_string(width) + "x" + std::to_string(height)};
}

// Projection workgroups per probe: shprobe's dispatch plan (glsl/dispatch_plan.h, shared with the
// shaders and stated in shaders/INTERFACE.md) under this device's limits. A target the plan cannot
// fit in one bake is refused.
uint32_t groupsPerProbe(const Device& device, const ProbeBakerOptions& options, const ProjectionShape& shape,
                        uint32_t probes) {
    const VkPhysicalDeviceLimits& limits = device.info.limits;
    const uint32_t maxGroups =
        glsl::maxGroupsPerProbe(limits.maxComputeWorkGroupCount[0], limits.maxStorageBufferRange,
                                uint32_t(coefficientSetBytes(options.order)), probes);
    const uint32_t perInvocation =
        glsl::planPositionsOf(shape.positions, shape.texelsPerPosition, options.texelsPerInvocation,
                              options.workgroupSize, maxGroups, shape.maxPositions);
    if (perInvocation == 0)
        throw Error(ErrorKind::Input, "GPU bake: " + std::to_string(probes) + " " + shape.probes +
                                          " at order " + std::to_string(options.order) +
                                          " are more than one bake can hold on " + device.info.name +
                                          "; bake fewer probes at a time");
    return glsl::planGroups(shape.positions, perInvocation, options.workgroupSize);
}

// Per-band scales for convolve.comp: the window alone (radiance) or A_l times the window
// (irradiance, E_lm = A_l L_lm). An empty window is no window.
glsl::ConvolveParams convolveParams(int order, std::span<const double> window, Quantity quantity,
                                    uint32_t outputOffset) {
    glsl::ConvolveParams params{};
    for (int l = 0; l < order; ++l) {
        double scale = window.empty() ? 1.0 : window[size_t(l)];
        if (quantity == Quantity::Irradiance) scale *= irradianceBandFactor(l);
        params.bandScale[l / 4][l % 4] = float(scale);
    }
    params.outputOffset = outputOffset;
    return params;
}

// Compute work recorded earlier on the queue (an earlier bake of the same set reading or writing
// the scratch buffer) finishes before this bake writes it.
void scratchReuseBarrier(VkCommandBuffer commands) {
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                         0, 1, &barrier, 0, nullptr, 0, nullptr);
}

void checkWindow(int order, std::span<const double> window) {
    if (!window.empty() && window.size() != size_t(order))
        throw Error(ErrorKind::Input, "a window of " + std::to_string(window.size()) + " bands for order " +
                                          std::to_string(order));
}

// What one bake reads and writes, whatever its source.
struct BakeBindings {
    VkImageView source;
    uint32_t probeCount;
    VkBuffer output;
    VkDeviceSize outputOffset;
};

void checkSize(const Device& device, const char* what, uint32_t size) {
    if (size < 1 || size > device.info.limits.maxImageDimension2D)
        throw Error(ErrorKind::Input, std::string("GPU bake: ") + what + " " + std::to_string(size) +
                                          " is outside 1.." +
                                          std::to_string(device.info.limits.maxImageDimension2D));
}

void checkTarget(const Device& device, const ProbeBaker& baker, ProbeSource source,
                 const BakeBindings& target) {
    const bool equirect = source == ProbeSource::Equirect;
    if (baker.options.source != source)
        throw Error(ErrorKind::Input, std::string("GPU bake: a baker made for ") +
                                          (equirect ? "cube maps" : "equirect maps") + " cannot bake " +
                                          (equirect ? "equirect maps" : "cube maps"));
    if (!target.source || !target.output)
        throw Error(ErrorKind::Input, std::string("GPU bake: the target needs ") +
                                          (equirect ? "an equirect view" : "a cube-map view") +
                                          " and an output buffer");
    if (target.probeCount < 1 || target.probeCount > device.info.limits.maxComputeWorkGroupCount[1])
        throw Error(ErrorKind::Input, "GPU bake: " + std::to_string(target.probeCount) +
                                          " probes in one bake; 1.." +
                                          std::to_string(device.info.limits.maxComputeWorkGroupCount[1]) +
                                          " on " + device.info.name);
    if (target.outputOffset % device.info.limits.minStorageBufferOffsetAlignment != 0)
        throw Error(ErrorKind::Input, "GPU bake: output offset " + std::to_string(target.outputOffset) +
                                          " is not a multiple of minStorageBufferOffsetAlignment (" +
                                          std::to_string(device.info.limits.minStorageBufferOffsetAlignment) +
                                          ")");
}

struct ProjectModule {
    const char* name;
    std::span<const uint32_t> spirv;
};

ProjectModule projectModule(ProbeSource source, CubemapBinding binding) {
    const bool equirect = source == ProbeSource::Equirect;
    switch (binding) {
    case CubemapBinding::StorageRgba32F:
        return equirect ? ProjectModule{"project_equirect_rgba32f.comp", spirv::project_equirect_rgba32f_comp}
                        : ProjectModule{"project_rgba32f.comp", spirv::project_rgba32f_comp};
    case CubemapBinding::StorageRgba16F:
        return equirect ? ProjectModule{"project_equirect_rgba16f.comp", spirv::project_equirect_rgba16f_comp}
                        : ProjectModule{"project_rgba16f.comp", spirv::project_rgba16f_comp};
    case CubemapBinding::SampledImage:
        break;
    }
    return equirect ? ProjectModule{"project_equirect.comp", spirv::project_equirect_comp}
                    : ProjectModule{"project.comp", spirv::project_comp};
}

// The scratch buffer and descriptor sets of a bake of `groups` projection workgroups per probe.
ProbeBakeSet createBakeSet(const Device& device, const ProbeBaker& baker, const BakeBindings& target,
                           uint32_t groups) {
    const int order = baker.options.order;
    const VkDeviceSize setBytes = coefficientSetBytes(order);
    ProbeBakeSet set;
    set.source = baker.options.source;
    set.groupsPerProbe = groups;
    const VkDeviceSize partialBytes = VkDeviceSize(target.probeCount) * set.groupsPerProbe * setBytes;
    const VkDeviceSize radianceBytes = VkDeviceSize(target.probeCount) * setBytes;
    set.radianceOffset = alignUp(partialBytes, device.info.limits.minStorageBufferOffsetAlignment);
    OnFailure undo([&] { destroyProbeBakeSet(device, set); });
    set.scratch = createBuffer(device, set.radianceOffset + radianceBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               MemoryUse::Device, "bake scratch (partial sums)");
    const bool sampled = baker.options.cubemaps == CubemapBinding::SampledImage;
    set.pool = createDescriptorPool(device, {.sets = 3,
                                             .storageBuffers = 5,
                                             .imageSamplers = sampled ? 1u : 0u,
                                             .storageImages = sampled ? 0u : 1u});
    const BindingTarget project[] = {{.imageView = target.source}, {set.scratch.buffer, 0, partialBytes}};
    const BindingTarget reduce[] = {{set.scratch.buffer, 0, partialBytes},
                                    {set.scratch.buffer, set.radianceOffset, radianceBytes}};
    const BindingTarget convolve[] = {
        {set.scratch.buffer, set.radianceOffset, radianceBytes},
        {target.output, target.outputOffset, probeBakeOutputBytes(order, target.probeCount)}};
    set.project = createDescriptorSet(device, set.pool, baker.project, project);
    set.reduce = createDescriptorSet(device, set.pool, baker.reduce, reduce);
    set.convolve = createDescriptorSet(device, set.pool, baker.convolve, convolve);
    return set;
}

} // namespace

VkImageLayout cubemapLayout(CubemapBinding binding) {
    return binding == CubemapBinding::SampledImage ? VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL
                                                   : VK_IMAGE_LAYOUT_GENERAL;
}

Device borrowDevice(const ExternalDevice& external) {
    Device device;
    device.physicalDevice = external.physicalDevice;
    device.device = external.device;
    device.queueFamily = external.queueFamily;
    device.pipelineCache = external.pipelineCache;
    vkGetPhysicalDeviceMemoryProperties(external.physicalDevice, &device.memory);

    // Checked as createContext checks each device, with the bakes on the caller's family; a family
    // that does no compute work is the caller's choice, not the device's lack, and is named as such.
    const bool computes = isComputeFamily(external.physicalDevice, external.queueFamily);
    device.info = describeDevice(external.physicalDevice, 0,
                                 computes ? std::optional(external.queueFamily) : std::nullopt);
    if (!computes)
        throw Error(ErrorKind::Device, "queue family " + std::to_string(external.queueFamily) + " of " +
                                           device.info.name + " does not do compute work");
    if (!device.info.unsupportedReason.empty())
        throw Error(ErrorKind::Device,
                    device.info.name + " cannot bake probes: " + device.info.unsupportedReason);
    return device;
}

ProbeBaker createProbeBaker(const Device& device, const ProbeBakerOptions& options) {
    if (options.order < 1 || options.order > kMaxOrder)
        throw Error(ErrorKind::Input,
                    "order " + std::to_string(options.order) + " is outside 1.." + std::to_string(kMaxOrder));
    if (options.texelsPerInvocation < 1)
        throw Error(ErrorKind::Input, "texels per invocation must be at least 1");
    if (options.workgroupSize < 1) throw Error(ErrorKind::Input, "the workgroup size must be at least 1");
    if (glsl::projectionSharedBytes(options.workgroupSize) > device.info.limits.maxComputeSharedMemorySize)
        throw Error(ErrorKind::Input, "workgroup size " + std::to_string(options.workgroupSize) +
                                          " needs more shared memory than " + device.info.name + " has");
    const bool sampled = options.cubemaps == CubemapBinding::SampledImage;
    static constexpr VkDescriptorType kSampledBindings[] = {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                                                            VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    static constexpr VkDescriptorType kStorageBindings[] = {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                                            VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    static constexpr VkDescriptorType kBufferBindings[] = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                                           VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    const uint32_t order = uint32_t(options.order);
    ProbeBaker baker;
    baker.options = options;
    OnFailure undo([&] { destroyProbeBaker(device, baker); });
    if (sampled) baker.sampler = createSampler(device, VK_FILTER_NEAREST);
    const ProjectModule module = projectModule(options.source, options.cubemaps);
    baker.project = createComputeProgram(
        device,
        {.name = module.name,
         .spirv = module.spirv,
         .bindings = sampled ? std::span(kSampledBindings) : std::span(kStorageBindings),
         .immutableSampler = baker.sampler,
         .pushConstantSize = options.source == ProbeSource::Equirect ? uint32_t(sizeof(glsl::EquirectParams))
                                                                     : uint32_t(sizeof(glsl::ProjectParams)),
         .localSize = options.workgroupSize,
         .order = order});
    auto bufferProgram = [&](const char* name, std::span<const uint32_t> spirv, uint32_t pushConstantSize) {
        return createComputeProgram(device, {.name = name,
                                             .spirv = spirv,
                                             .bindings = kBufferBindings,
                                             .pushConstantSize = pushConstantSize,
                                             .localSize = glsl::kCoefficientWorkgroupWidth,
                                             .order = order});
    };
    baker.reduce = bufferProgram("reduce.comp", spirv::reduce_comp, sizeof(glsl::ReduceParams));
    baker.convolve = bufferProgram("convolve.comp", spirv::convolve_comp, sizeof(glsl::ConvolveParams));
    return baker;
}

void destroyProbeBaker(const Device& device, ProbeBaker& baker) {
    destroyComputeProgram(device, baker.convolve);
    destroyComputeProgram(device, baker.reduce);
    destroyComputeProgram(device, baker.project);
    if (baker.sampler) vkDestroySampler(device.device, baker.sampler, nullptr);
    baker = ProbeBaker{};
}

VkDeviceSize coefficientSetBytes(int order) {
    return VkDeviceSize(coefficientCount(order)) * sizeof(float[4]); // a std430 vec4: rgb, padding
}

VkDeviceSize probeOutputOffset(int order, uint32_t probeCount, uint32_t probe, Quantity quantity) {
    const uint32_t slot = quantity == Quantity::Radiance ? probe : probeCount + probe;
    return slot * coefficientSetBytes(order);
}

VkDeviceSize probeBakeOutputBytes(int order, uint32_t probeCount) {
    return 2 * VkDeviceSize(probeCount) * coefficientSetBytes(order);
}

ProbeBakeSet createProbeBakeSet(const Device& device, const ProbeBaker& baker,
                                const ProbeBakeTarget& target) {
    const BakeBindings bindings{target.cubemaps, target.probeCount, target.output, target.outputOffset};
    checkTarget(device, baker, ProbeSource::Cubemaps, bindings);
    checkSize(device, "face size", target.faceSize);
    const uint32_t groups =
        groupsPerProbe(device, baker.options, cubemapShape(uint32_t(baker.options.order), target.faceSize),
                       target.probeCount);
    ProbeBakeSet set = createBakeSet(device, baker, bindings, groups);
    set.target = target;
    return set;
}

ProbeBakeSet createEquirectBakeSet(const Device& device, const ProbeBaker& baker,
                                   const EquirectBakeTarget& target) {
    const BakeBindings bindings{target.equirects, target.probeCount, target.output, target.outputOffset};
    checkTarget(device, baker, ProbeSource::Equirect, bindings);
    checkSize(device, "equirect width", target.width);
    checkSize(device, "equirect height", target.height);
    const uint32_t groups = groupsPerProbe(
        device, baker.options, equirectShape(uint32_t(baker.options.order), target.width, target.height),
        target.probeCount);
    ProbeBakeSet set = createBakeSet(device, baker, bindings, groups);
    set.equirect = target;
    return set;
}

void destroyProbeBakeSet(const Device& device, ProbeBakeSet& set) {
    if (set.pool) vkDestroyDescriptorPool(device.device, set.pool, nullptr);
    destroyBuffer(device, set.scratch);
    set = ProbeBakeSet{};
}

void recordConvolutions(VkCommandBuffer commands, const ProbeBaker& baker, VkDescriptorSet convolveSet,
                        uint32_t probes, std::span<const double> window) {
    const int order = baker.options.order;
    checkWindow(order, window);
    // Radiance (windowed) first, then irradiance after all probes' radiance: the output layout.
    const uint32_t irradianceOffset = probes * uint32_t(coefficientCount(order));
    // The two dispatches write disjoint parts of the output, so they need no barrier between them.
    dispatch(commands, baker.convolve, convolveSet, convolveParams(order, window, Quantity::Radiance, 0),
             {1, probes});
    dispatch(commands, baker.convolve, convolveSet,
             convolveParams(order, window, Quantity::Irradiance, irradianceOffset), {1, probes});
}

void recordProbeBake(VkCommandBuffer commands, const ProbeBaker& baker, const ProbeBakeSet& set,
                     std::span<const double> window) {
    checkWindow(baker.options.order, window); // before anything is recorded
    const bool equirect = set.source == ProbeSource::Equirect;
    if (set.source != baker.options.source)
        throw Error(ErrorKind::Input, std::string("GPU bake: a bake set of ") +
                                          (equirect ? "equirect maps" : "cube maps") +
                                          " recorded with a baker of the other source");
    const uint32_t probes = equirect ? set.equirect.probeCount : set.target.probeCount;
    scratchReuseBarrier(commands);
    if (equirect) {
        dispatch(commands, baker.project, set.project,
                 glsl::EquirectParams{set.equirect.width, set.equirect.height}, {set.groupsPerProbe, probes});
    } else {
        dispatch(commands, baker.project, set.project, glsl::ProjectParams{set.target.faceSize},
                 {set.groupsPerProbe, probes});
    }
    computeWriteBarrier(commands);
    dispatch(commands, baker.reduce, set.reduce, glsl::ReduceParams{set.groupsPerProbe},
             {uint32_t(coefficientCount(baker.options.order)), probes});
    computeWriteBarrier(commands);
    recordConvolutions(commands, baker, set.convolve, probes, window);
}

} // namespace shprobe
