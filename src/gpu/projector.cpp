#include "gpu/projector.h"

#include "gpu_interface.h"
#include "sh/basis.h"
#include "sh/error.h"
#include "sh/irradiance.h"
#include "shprobe/shprobe_spirv.h"
#include "vk/check.h"
#include "vk/resources.h"

#include <algorithm>
#include <span>
#include <cmath>
#include <vector>

namespace shprobe {

namespace {

constexpr VkDeviceSize kTexelBytes = sizeof(glm::vec4);
constexpr VkDeviceSize kCoefficientBytes = sizeof(glm::vec4); // rgb + padding, std430 vec4

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

// One projection dispatch: a band of rows of all six faces, small enough for one storage-buffer
// binding. In the uploaded buffer the bands follow each other, each holding its rows face by face.
struct Band {
    uint32_t firstRow;
    uint32_t rowCount;
    uint32_t groupCount;
    uint32_t partialOffset;
    VkDeviceSize offset; // bytes
    VkDeviceSize size;   // bytes
};

// llvmpipe (lavapipe) ends any loop after 65535 iterations, counting the iterations of nested loops
// against the outermost one, and past the limit the sums are silently wrong. One position (six
// texels) runs fewer than 1 + 6 (1 + n^2 + n^2 / 2) loop iterations at order n (the position and
// face loops, the accumulation, the recurrence of bands above 4). Half the limit leaves a margin;
// other devices lose nothing by the cap.
uint32_t maxPositionsPerInvocation(int order) {
    uint32_t n = uint32_t(order);
    return 32768u / (1u + 6u * (1u + n * n + n * n / 2u));
}

// Positions (texel positions of all six faces) each invocation handles. The request is raised
// when needed so that all partial slots fit one storage-buffer binding (half of it, leaving room for
// the rounding of each band's group count), and capped for lavapipe's loop limit; a face size that
// cannot meet both is refused.
uint32_t positionsPerInvocation(const DeviceInfo& device, const ProjectorOptions& options, uint32_t faceSize) {
    VkDeviceSize slotBytes = VkDeviceSize(coefficientCount(options.order)) * kCoefficientBytes;
    VkDeviceSize maxSlots = device.limits.maxStorageBufferRange / slotBytes / 2;
    VkDeviceSize positions = VkDeviceSize(faceSize) * faceSize;
    VkDeviceSize perGroup = (positions + maxSlots - 1) / maxSlots;
    uint32_t least = uint32_t((perGroup + options.workgroupSize - 1) / options.workgroupSize);
    uint32_t most = maxPositionsPerInvocation(options.order);
    if (least > most)
        throw Error(ErrorKind::Input, "GPU bake: face size " + std::to_string(faceSize) + " at order " +
                                          std::to_string(options.order) + " needs a workgroup wider than " +
                                          std::to_string(options.workgroupSize) + " on " + device.name);
    uint32_t requested = (options.texelsPerInvocation + kFaceCount - 1) / kFaceCount;
    return std::clamp(requested, std::max(least, 1u), most);
}

// Rows per band: as many as one binding can hold and one dispatch's workgroup count can cover, a
// multiple of 8 so that band offsets (96 N firstRow bytes) meet every storage-buffer offset
// alignment Vulkan allows (at most 256).
uint32_t rowsPerBand(const DeviceInfo& device, uint32_t faceSize, uint32_t positionsPerGroup) {
    VkDeviceSize rowBytes = VkDeviceSize(kFaceCount) * faceSize * kTexelBytes;
    VkDeviceSize byBinding = device.limits.maxStorageBufferRange / rowBytes;
    VkDeviceSize byGroups = VkDeviceSize(device.limits.maxComputeWorkGroupCount[0]) * positionsPerGroup / faceSize;
    VkDeviceSize rows = std::min(byBinding, byGroups);
    if (rows >= faceSize) return faceSize;
    return uint32_t(std::max<VkDeviceSize>(8, rows / 8 * 8));
}

std::vector<Band> planBands(const DeviceInfo& device, const ProjectorOptions& options, uint32_t faceSize) {
    uint32_t positionsPerGroup = options.workgroupSize * positionsPerInvocation(device, options, faceSize);
    uint32_t bandRows = rowsPerBand(device, faceSize, positionsPerGroup);
    std::vector<Band> bands;
    uint32_t partials = 0;
    VkDeviceSize offset = 0;
    for (uint32_t firstRow = 0; firstRow < faceSize; firstRow += bandRows) {
        uint32_t rows = std::min(bandRows, faceSize - firstRow);
        uint32_t positions = rows * faceSize;
        uint32_t groups = (positions + positionsPerGroup - 1) / positionsPerGroup;
        VkDeviceSize size = VkDeviceSize(kFaceCount) * positions * kTexelBytes;
        bands.push_back({firstRow, rows, groups, partials, offset, size});
        partials += groups;
        offset += size;
    }
    return bands;
}

// Writes the cube map band after band, each band's rows face by face (project.comp's layout).
void writeBands(const Cubemap& cubemap, const std::vector<Band>& bands, void* destination) {
    auto* out = static_cast<glm::vec4*>(destination);
    size_t n = size_t(cubemap.faceSize);
    for (const Band& band : bands)
        for (int face = 0; face < kFaceCount; ++face) {
            const glm::vec4* rows = &cubemap.at(face, 0, int(band.firstRow));
            out = std::copy(rows, rows + band.rowCount * n, out);
        }
}

// Per-band scales for convolve.comp: the window alone (windowed radiance), or A_l times the window
// (irradiance, E_lm = A_l L_lm). An empty window is no window.
gpu::ConvolveParams bandScales(int order, std::span<const double> window, Quantity quantity) {
    gpu::ConvolveParams params{};
    for (int l = 0; l < order; ++l) {
        double scale = window.empty() ? 1.0 : window[size_t(l)];
        if (quantity == Quantity::Irradiance) scale *= irradianceBandFactor(l);
        params.bandScale[l / 4][l % 4] = float(scale);
    }
    return params;
}

void checkWindow(int order, std::span<const double> window) {
    if (!window.empty() && window.size() != size_t(order))
        throw Error(ErrorKind::Input, "a window of " + std::to_string(window.size()) + " bands for order " +
                                          std::to_string(order));
}

// Throws when a coefficient is not finite: finite inputs whose sums overflow fp32 (values near
// 1e38), or a device that computed garbage; either way no such probe is handed on.
ShCoefficients readCoefficients(const Buffer& results, VkDeviceSize offset, int order, Quantity quantity) {
    ShCoefficients coefficients = makeCoefficients(order, quantity);
    auto* values = reinterpret_cast<const glm::vec4*>(static_cast<const char*>(results.mapped) + offset);
    for (size_t i = 0; i < coefficients.rgb.size(); ++i) {
        glm::vec3 value(values[i]);
        if (!std::isfinite(value.r) || !std::isfinite(value.g) || !std::isfinite(value.b))
            throw Error(ErrorKind::Input, "GPU bake: coefficient " + std::to_string(i) +
                                              " is not finite (input values too large for fp32 sums?)");
        coefficients.rgb[i] = glm::dvec3(value);
    }
    return coefficients;
}

// The host-visible results buffer: three coefficient sets, each at a storage-buffer-aligned offset.
struct ResultSlots {
    VkDeviceSize bytes;  // one coefficient set
    VkDeviceSize stride; // bytes rounded up to the offset alignment
    static constexpr int kRawRadiance = 0, kRadiance = 1, kIrradiance = 2, kCount = 3;
    VkDeviceSize offset(int slot) const { return VkDeviceSize(slot) * stride; }
};

ResultSlots resultSlots(const Context& context, int order) {
    VkDeviceSize bytes = VkDeviceSize(coefficientCount(order)) * kCoefficientBytes;
    return {bytes, alignUp(bytes, context.info.limits.minStorageBufferOffsetAlignment)};
}

// Everything one bake allocates, destroyed in one place.
struct BakeResources {
    Buffer texels;
    Buffer partials;
    Buffer results; // ResultSlots; host-visible
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkQueryPool timestamps = VK_NULL_HANDLE;
};

void destroyBakeResources(const Context& context, BakeResources& resources) {
    if (resources.timestamps) vkDestroyQueryPool(context.device, resources.timestamps, nullptr);
    if (resources.pool) vkDestroyDescriptorPool(context.device, resources.pool, nullptr);
    destroyBuffer(context, resources.results);
    destroyBuffer(context, resources.partials);
    destroyBuffer(context, resources.texels);
}

void checkCubemap(const Cubemap& cubemap) {
    if (cubemap.faceSize < 1 || cubemap.faceSize > kMaxGpuFaceSize)
        throw Error(ErrorKind::Input, "GPU bake: face size " + std::to_string(cubemap.faceSize) +
                                          " is outside 1.." + std::to_string(kMaxGpuFaceSize));
    if (cubemap.texels.size() != size_t(kFaceCount) * cubemap.faceSize * cubemap.faceSize)
        throw Error(ErrorKind::Input, "GPU bake: the cube map holds " + std::to_string(cubemap.texels.size()) +
                                          " texels, not 6 x " + std::to_string(cubemap.faceSize) + "^2");
}

VkQueryPool createTimestampPool(const Context& context) {
    if (!context.info.timestamps) return VK_NULL_HANDLE;
    VkQueryPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = 2;
    VkQueryPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateQueryPool(context.device, &info, nullptr, &pool));
    return pool;
}

double readDeviceMilliseconds(const Context& context, VkQueryPool pool) {
    if (!pool) return 0.0;
    uint64_t ticks[2] = {};
    VK_CHECK(vkGetQueryPoolResults(context.device, pool, 0, 2, sizeof(ticks), ticks, sizeof(uint64_t),
                                   VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    // Only timestampValidBits bits count; masking the difference also handles a wrap-around.
    uint32_t bits = context.info.timestampValidBits;
    uint64_t mask = bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
    return double((ticks[1] - ticks[0]) & mask) * context.info.timestampPeriod * 1e-6;
}

// Descriptor sets and dispatches of the two convolutions, both reading the raw radiance slot.
struct Convolutions {
    VkDescriptorSet radianceSet;
    VkDescriptorSet irradianceSet;
};

Convolutions createConvolutions(const Context& context, const Projector& projector, VkDescriptorPool pool,
                                const Buffer& results, const ResultSlots& slots) {
    auto setFor = [&](int slot) {
        BufferRange ranges[] = {{&results, slots.offset(ResultSlots::kRawRadiance), slots.bytes},
                                {&results, slots.offset(slot), slots.bytes}};
        return createDescriptorSet(context, pool, projector.convolve, ranges);
    };
    return {setFor(ResultSlots::kRadiance), setFor(ResultSlots::kIrradiance)};
}

void recordConvolutions(VkCommandBuffer commands, const Projector& projector, const Convolutions& convolutions,
                        std::span<const double> window) {
    int order = projector.options.order;
    dispatch(commands, projector.convolve, convolutions.radianceSet, bandScales(order, window, Quantity::Radiance), 1);
    dispatch(commands, projector.convolve, convolutions.irradianceSet,
             bandScales(order, window, Quantity::Irradiance), 1);
    computeWriteBarrier(commands);
}

void readResults(const Context& context, const Buffer& results, const ResultSlots& slots, int order, GpuBake& bake) {
    invalidateBuffer(context, results);
    bake.radiance = readCoefficients(results, slots.offset(ResultSlots::kRadiance), order, Quantity::Radiance);
    bake.irradiance = readCoefficients(results, slots.offset(ResultSlots::kIrradiance), order, Quantity::Irradiance);
}

} // namespace

Projector createProjector(const Context& context, const ProjectorOptions& options) {
    if (options.order < 1 || options.order > kMaxOrder)
        throw Error(ErrorKind::Input, "order " + std::to_string(options.order) + " is outside 1.." +
                                          std::to_string(kMaxOrder));
    if (options.texelsPerInvocation < 1)
        throw Error(ErrorKind::Input, "texels per invocation must be at least 1");
    // project.comp keeps one vec3 (16 bytes in shared memory) per invocation for its reduction.
    if (VkDeviceSize(options.workgroupSize) * 16 + 16 > context.info.limits.maxComputeSharedMemorySize)
        throw Error(ErrorKind::Input, "workgroup size " + std::to_string(options.workgroupSize) +
                                          " needs more shared memory than " + context.info.name + " has");
    Projector projector;
    projector.options = options;
    uint32_t order = uint32_t(options.order);
    try {
        projector.project = createComputeProgram(
            context, {"project.comp", spirv::project_comp, 2, sizeof(gpu::ProjectParams), options.workgroupSize, order});
        // The reduction and convolution handle one value per coefficient: a small workgroup is enough.
        projector.reduce = createComputeProgram(
            context, {"reduce.comp", spirv::reduce_comp, 2, sizeof(gpu::ReduceParams), 64, order});
        projector.convolve = createComputeProgram(
            context, {"convolve.comp", spirv::convolve_comp, 2, sizeof(gpu::ConvolveParams), 64, order});
    } catch (...) {
        destroyProjector(context, projector);
        throw;
    }
    return projector;
}

void destroyProjector(const Context& context, Projector& projector) {
    destroyComputeProgram(context, projector.convolve);
    destroyComputeProgram(context, projector.reduce);
    destroyComputeProgram(context, projector.project);
}

GpuBake bakeCubemap(const Context& context, const Projector& projector, const Cubemap& cubemap,
                    std::span<const double> window) {
    checkCubemap(cubemap);
    const int order = projector.options.order;
    checkWindow(order, window);
    const ResultSlots slots = resultSlots(context, order);
    const VkDeviceSize coefficientBytes = slots.bytes;
    const VkDeviceSize texelBytes = cubemap.texels.size() * kTexelBytes;
    const std::vector<Band> bands = planBands(context.info, projector.options, uint32_t(cubemap.faceSize));
    const uint32_t partialSlots = bands.back().partialOffset + bands.back().groupCount;

    BakeResources resources;
    GpuBake bake;
    try {
        const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
        resources.texels = createBuffer(context, texelBytes, storage | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                        MemoryUse::Device, "input texels");
        resources.partials =
            createBuffer(context, partialSlots * coefficientBytes, storage, MemoryUse::Device, "partial sums");
        resources.results = createBuffer(context, slots.offset(ResultSlots::kCount), storage, MemoryUse::Readback,
                                         "coefficients");
        resources.pool = createDescriptorPool(context, uint32_t(bands.size()) + 3, 2 * (uint32_t(bands.size()) + 3));
        resources.timestamps = createTimestampPool(context);
        writeBuffer(context, resources.texels, texelBytes,
                    [&](void* destination) { writeBands(cubemap, bands, destination); });

        std::vector<VkDescriptorSet> bandSets;
        for (const Band& band : bands) {
            BufferRange ranges[] = {{&resources.texels, band.offset, band.size},
                                    {&resources.partials, 0, VK_WHOLE_SIZE}};
            bandSets.push_back(createDescriptorSet(context, resources.pool, projector.project, ranges));
        }
        BufferRange reduceRanges[] = {{&resources.partials, 0, VK_WHOLE_SIZE},
                                      {&resources.results, slots.offset(ResultSlots::kRawRadiance), coefficientBytes}};
        VkDescriptorSet reduceSet = createDescriptorSet(context, resources.pool, projector.reduce, reduceRanges);
        Convolutions convolutions = createConvolutions(context, projector, resources.pool, resources.results, slots);

        submitAndWait(context, [&](VkCommandBuffer commands) {
            if (resources.timestamps) {
                vkCmdResetQueryPool(commands, resources.timestamps, 0, 2);
                vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, resources.timestamps, 0);
            }
            for (size_t i = 0; i < bands.size(); ++i) {
                const Band& band = bands[i];
                gpu::ProjectParams params{uint32_t(cubemap.faceSize), band.firstRow, band.rowCount, band.partialOffset};
                dispatch(commands, projector.project, bandSets[i], params, band.groupCount);
            }
            computeWriteBarrier(commands);
            dispatch(commands, projector.reduce, reduceSet, gpu::ReduceParams{partialSlots},
                     uint32_t(coefficientCount(order)));
            computeWriteBarrier(commands);
            recordConvolutions(commands, projector, convolutions, window);
            if (resources.timestamps)
                vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, resources.timestamps, 1);
        });

        readResults(context, resources.results, slots, order, bake);
        bake.deviceMilliseconds = readDeviceMilliseconds(context, resources.timestamps);
        bake.workgroups = partialSlots;
        bake.dispatches = uint32_t(bands.size());
    } catch (...) {
        destroyBakeResources(context, resources);
        throw;
    }
    destroyBakeResources(context, resources);
    return bake;
}

std::vector<GpuBake> bakeCubemaps(const Context& context, const Projector& projector,
                                  std::span<const Cubemap* const> cubemaps, std::span<const double> window) {
    std::vector<GpuBake> bakes;
    for (const Cubemap* cubemap : cubemaps) bakes.push_back(bakeCubemap(context, projector, *cubemap, window));
    return bakes;
}

VkDeviceSize batchTexelBytes(const Context& context) {
    return context.info.limits.maxStorageBufferRange;
}

GpuBake convolveOnGpu(const Context& context, const Projector& projector, const ShCoefficients& radiance,
                      std::span<const double> window) {
    const int order = projector.options.order;
    if (radiance.order != order || radiance.quantity != Quantity::Radiance)
        throw Error(ErrorKind::Input, "GPU convolution: expected order-" + std::to_string(order) + " radiance");
    checkWindow(order, window);
    const ResultSlots slots = resultSlots(context, order);
    std::vector<glm::vec4> raw;
    for (const glm::dvec3& c : radiance.rgb) raw.emplace_back(glm::vec3(c), 0.0f);

    Buffer results;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    auto release = [&] {
        if (pool) vkDestroyDescriptorPool(context.device, pool, nullptr);
        destroyBuffer(context, results);
    };
    GpuBake bake;
    try {
        results = createBuffer(context, slots.offset(ResultSlots::kCount), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               MemoryUse::Readback, "coefficients");
        uploadBuffer(context, results, raw.data(), slots.bytes); // slot 0: the raw radiance
        pool = createDescriptorPool(context, 2, 4);
        Convolutions convolutions = createConvolutions(context, projector, pool, results, slots);
        submitAndWait(context, [&](VkCommandBuffer commands) {
            recordConvolutions(commands, projector, convolutions, window);
        });
        readResults(context, results, slots, order, bake);
    } catch (...) {
        release();
        throw;
    }
    release();
    return bake;
}

} // namespace shprobe
