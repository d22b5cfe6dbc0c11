#include "shprobe/gpu/probe_baker.h"

#include "shprobe/glsl/gpu_interface.h"
#include "shprobe/glsl/texel_geometry.h"
#include "shprobe/sh/basis.h"
#include "shprobe/sh/cubemap.h"
#include "shprobe/sh/error.h"
#include "shprobe/sh/irradiance.h"
#include "shprobe/shprobe_spirv.h"
#include "shprobe/vk/check.h"
#include "shprobe/vk/image.h"

#include <algorithm>
#include <string>
#include <vector>

namespace shprobe {

namespace {

constexpr VkDeviceSize kCoefficientBytes = 16; // rgb + padding, std430 vec4

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

VkDeviceSize coefficientSetBytes(int order) {
    return VkDeviceSize(coefficientCount(order)) * kCoefficientBytes;
}

// A projection position is a texel and its three mirror images on each of the six faces
// (quadrantSize, texel_geometry.h).
constexpr uint32_t kTexelsPerPosition = 4 * kFaceCount;

// llvmpipe (lavapipe) ends any loop after 65535 iterations, counting the iterations of nested loops
// against the outermost one, and past the limit the sums are silently wrong. Each face pair's loop
// runs fewer than 1 + 6 (1 + n^2 + n^2 / 2) iterations per position at order n (one basis
// evaluation: a few times fewer), whatever the compiler unrolls. Half the limit leaves a margin;
// other devices lose nothing by the cap.
uint32_t maxPositionsPerInvocation(int order) {
    uint32_t n = uint32_t(order);
    return 32768u / (1u + 6u * (1u + n * n + n * n / 2u));
}

// Projection workgroups per probe for N x N faces: as many as the requested work per invocation
// gives, fewer when one dispatch row (maxComputeWorkGroupCount[0]) or the partial slots of all
// probes in one storage-buffer binding need it, and never so few that an invocation passes
// lavapipe's loop cap; a target that cannot meet all of them is refused.
uint32_t groupsPerProbe(const Context& context, const ProbeBakerOptions& options, uint32_t faceSize,
                        uint32_t probes) {
    const VkPhysicalDeviceLimits& limits = context.info.limits;
    const VkDeviceSize quadrant = gpu::quadrantSize(faceSize);
    const VkDeviceSize positions = quadrant * quadrant;
    const VkDeviceSize maxSlots = limits.maxStorageBufferRange / coefficientSetBytes(options.order);
    const VkDeviceSize maxGroups =
        std::min<VkDeviceSize>(limits.maxComputeWorkGroupCount[0], maxSlots / probes);
    const VkDeviceSize perGroup = (positions + maxGroups - 1) / std::max<VkDeviceSize>(maxGroups, 1);
    const VkDeviceSize least = (perGroup + options.workgroupSize - 1) / options.workgroupSize;
    const uint32_t most = maxPositionsPerInvocation(options.order);
    if (maxGroups == 0 || least > most)
        throw Error(ErrorKind::Input, "GPU bake: " + std::to_string(probes) + " probe(s) of face size " +
                                          std::to_string(faceSize) + " at order " +
                                          std::to_string(options.order) +
                                          " are more than one bake can hold on " + context.info.name +
                                          "; bake fewer probes at a time");
    const uint32_t requested = (options.texelsPerInvocation + kTexelsPerPosition - 1) / kTexelsPerPosition;
    const VkDeviceSize perInvocation =
        std::clamp<VkDeviceSize>(requested, std::max<VkDeviceSize>(least, 1), most);
    const VkDeviceSize perWorkgroup = perInvocation * options.workgroupSize;
    return uint32_t((positions + perWorkgroup - 1) / perWorkgroup);
}

// Per-band scales for convolve.comp: the window alone (radiance) or A_l times the window
// (irradiance, E_lm = A_l L_lm). An empty window is no window.
gpu::ConvolveParams convolveParams(int order, std::span<const double> window, Quantity quantity,
                                   uint32_t outputOffset) {
    gpu::ConvolveParams params{};
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

void checkTarget(const Context& context, const ProbeBakeTarget& target) {
    if (!target.cubemaps || !target.output)
        throw Error(ErrorKind::Input, "GPU bake: the target needs a cube-map view and an output buffer");
    if (target.faceSize < 1 || target.faceSize > context.info.limits.maxImageDimension2D)
        throw Error(ErrorKind::Input, "GPU bake: face size " + std::to_string(target.faceSize) +
                                          " is outside 1.." +
                                          std::to_string(context.info.limits.maxImageDimension2D));
    if (target.probeCount < 1 || target.probeCount > context.info.limits.maxComputeWorkGroupCount[1])
        throw Error(ErrorKind::Input, "GPU bake: " + std::to_string(target.probeCount) +
                                          " probes in one bake; 1.." +
                                          std::to_string(context.info.limits.maxComputeWorkGroupCount[1]) +
                                          " on " + context.info.name);
    if (target.outputOffset % context.info.limits.minStorageBufferOffsetAlignment != 0)
        throw Error(ErrorKind::Input,
                    "GPU bake: output offset " + std::to_string(target.outputOffset) +
                        " is not a multiple of minStorageBufferOffsetAlignment (" +
                        std::to_string(context.info.limits.minStorageBufferOffsetAlignment) + ")");
}

struct ProjectModule {
    const char* name;
    std::span<const uint32_t> spirv;
};

ProjectModule projectModule(CubemapBinding binding) {
    switch (binding) {
    case CubemapBinding::StorageRgba32F:
        return {"project_rgba32f.comp", spirv::project_rgba32f_comp};
    case CubemapBinding::StorageRgba16F:
        return {"project_rgba16f.comp", spirv::project_rgba16f_comp};
    case CubemapBinding::SampledImage:
        break;
    }
    return {"project.comp", spirv::project_comp};
}

} // namespace

VkImageLayout cubemapLayout(CubemapBinding binding) {
    return binding == CubemapBinding::SampledImage ? VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL
                                                   : VK_IMAGE_LAYOUT_GENERAL;
}

Context borrowDevice(const ExternalDevice& device) {
    Context context;
    context.physicalDevice = device.physicalDevice;
    context.device = device.device;
    context.queueFamily = device.queueFamily;

    VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &subgroup};
    vkGetPhysicalDeviceProperties2(device.physicalDevice, &properties);
    vkGetPhysicalDeviceMemoryProperties(device.physicalDevice, &context.memory);
    context.info.name = properties.properties.deviceName;
    context.info.type = properties.properties.deviceType;
    context.info.apiVersion = properties.properties.apiVersion;
    context.info.limits = properties.properties.limits;
    context.info.subgroupSize = subgroup.subgroupSize;
    const VkSubgroupFeatureFlags needed = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
    context.info.subgroupArithmetic = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) &&
                                      (subgroup.supportedOperations & needed) == needed;
    if (!context.info.subgroupArithmetic)
        throw Error(ErrorKind::Device,
                    context.info.name +
                        " cannot bake probes: project.comp needs basic and arithmetic subgroup "
                        "operations in compute shaders");

    uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(device.physicalDevice, &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(device.physicalDevice, &familyCount, families.data());
    if (device.queueFamily >= familyCount ||
        !(families[device.queueFamily].queueFlags & VK_QUEUE_COMPUTE_BIT))
        throw Error(ErrorKind::Device, "queue family " + std::to_string(device.queueFamily) + " of " +
                                           context.info.name + " does not do compute work");
    return context;
}

ProbeBaker createProbeBaker(const Context& context, const ProbeBakerOptions& options) {
    if (options.order < 1 || options.order > kMaxOrder)
        throw Error(ErrorKind::Input,
                    "order " + std::to_string(options.order) + " is outside 1.." + std::to_string(kMaxOrder));
    if (options.texelsPerInvocation < 1)
        throw Error(ErrorKind::Input, "texels per invocation must be at least 1");
    // project.comp's reduction keeps vec3 subgroup totals (16 bytes in shared memory each) for
    // whole workgroups, as many coefficients at a time as SHPROBE_REDUCTION_ENTRIES allows.
    const VkDeviceSize width = options.workgroupSize;
    const VkDeviceSize reductionEntries = (SHPROBE_REDUCTION_ENTRIES + width - 1) / width * width;
    if (reductionEntries * 16 + 16 > context.info.limits.maxComputeSharedMemorySize)
        throw Error(ErrorKind::Input, "workgroup size " + std::to_string(options.workgroupSize) +
                                          " needs more shared memory than " + context.info.name + " has");
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
    try {
        if (sampled) baker.sampler = createSampler(context, VK_FILTER_NEAREST);
        const ProjectModule module = projectModule(options.cubemaps);
        baker.project = createComputeProgram(
            context, {.name = module.name,
                      .spirv = module.spirv,
                      .bindings = sampled ? std::span(kSampledBindings) : std::span(kStorageBindings),
                      .immutableSampler = baker.sampler,
                      .pushConstantSize = sizeof(gpu::ProjectParams),
                      .localSize = options.workgroupSize,
                      .order = order,
                      .cache = options.pipelineCache});
        // The reduction and convolution handle one value per coefficient: a small workgroup is enough.
        baker.reduce = createComputeProgram(context, {.name = "reduce.comp",
                                                      .spirv = spirv::reduce_comp,
                                                      .bindings = kBufferBindings,
                                                      .pushConstantSize = sizeof(gpu::ReduceParams),
                                                      .localSize = 64,
                                                      .order = order,
                                                      .cache = options.pipelineCache});
        baker.convolve = createComputeProgram(context, {.name = "convolve.comp",
                                                        .spirv = spirv::convolve_comp,
                                                        .bindings = kBufferBindings,
                                                        .pushConstantSize = sizeof(gpu::ConvolveParams),
                                                        .localSize = 64,
                                                        .order = order,
                                                        .cache = options.pipelineCache});
    } catch (...) {
        destroyProbeBaker(context, baker);
        throw;
    }
    return baker;
}

void destroyProbeBaker(const Context& context, ProbeBaker& baker) {
    destroyComputeProgram(context, baker.convolve);
    destroyComputeProgram(context, baker.reduce);
    destroyComputeProgram(context, baker.project);
    if (baker.sampler) vkDestroySampler(context.device, baker.sampler, nullptr);
    baker = ProbeBaker{};
}

VkDeviceSize probeBakeOutputBytes(int order, uint32_t probeCount) {
    return 2 * VkDeviceSize(probeCount) * coefficientSetBytes(order);
}

ProbeBakeSet createProbeBakeSet(const Context& context, const ProbeBaker& baker,
                                const ProbeBakeTarget& target) {
    checkTarget(context, target);
    const int order = baker.options.order;
    const VkDeviceSize setBytes = coefficientSetBytes(order);
    ProbeBakeSet set;
    set.target = target;
    set.groupsPerProbe = groupsPerProbe(context, baker.options, target.faceSize, target.probeCount);
    const VkDeviceSize partialBytes = VkDeviceSize(target.probeCount) * set.groupsPerProbe * setBytes;
    const VkDeviceSize radianceBytes = VkDeviceSize(target.probeCount) * setBytes;
    set.radianceOffset = alignUp(partialBytes, context.info.limits.minStorageBufferOffsetAlignment);
    try {
        set.scratch =
            createBuffer(context, set.radianceOffset + radianceBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                         MemoryUse::Device, "bake scratch (partial sums)");
        const bool sampled = baker.options.cubemaps == CubemapBinding::SampledImage;
        set.pool = createDescriptorPool(context, {.sets = 3,
                                                  .storageBuffers = 5,
                                                  .imageSamplers = sampled ? 1u : 0u,
                                                  .storageImages = sampled ? 0u : 1u});
        const BindingTarget project[] = {{.imageView = target.cubemaps},
                                         {set.scratch.buffer, 0, partialBytes}};
        const BindingTarget reduce[] = {{set.scratch.buffer, 0, partialBytes},
                                        {set.scratch.buffer, set.radianceOffset, radianceBytes}};
        const BindingTarget convolve[] = {
            {set.scratch.buffer, set.radianceOffset, radianceBytes},
            {target.output, target.outputOffset, probeBakeOutputBytes(order, target.probeCount)}};
        set.project = createDescriptorSet(context, set.pool, baker.project, project);
        set.reduce = createDescriptorSet(context, set.pool, baker.reduce, reduce);
        set.convolve = createDescriptorSet(context, set.pool, baker.convolve, convolve);
    } catch (...) {
        destroyProbeBakeSet(context, set);
        throw;
    }
    return set;
}

void destroyProbeBakeSet(const Context& context, ProbeBakeSet& set) {
    if (set.pool) vkDestroyDescriptorPool(context.device, set.pool, nullptr);
    destroyBuffer(context, set.scratch);
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
    const uint32_t probes = set.target.probeCount;
    scratchReuseBarrier(commands);
    dispatch(commands, baker.project, set.project, gpu::ProjectParams{set.target.faceSize},
             {set.groupsPerProbe, probes});
    computeWriteBarrier(commands);
    dispatch(commands, baker.reduce, set.reduce, gpu::ReduceParams{set.groupsPerProbe},
             {uint32_t(coefficientCount(baker.options.order)), probes});
    computeWriteBarrier(commands);
    recordConvolutions(commands, baker, set.convolve, probes, window);
}

} // namespace shprobe
