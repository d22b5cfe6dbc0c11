#include "gpu/host_bake.h"

#include "common/error.h"
#include "common/parallel.h"
#include "common/scope_exit.h"
#include "common/stopwatch.h"
#include "glsl/gpu_interface.h"
#include "sh/basis.h"
#include "sh/fast_projection.h"
#include "vk/check.h"
#include "vk/host_memory.h"
#include "vk/image.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace shprobe {

namespace {

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

VkFormat imageFormat(TexelFormat format) {
    return format == TexelFormat::Rgba16F ? VK_FORMAT_R16G16B16A16_SFLOAT : VK_FORMAT_R32G32B32A32_SFLOAT;
}

void checkCubemap(const Cubemap& cubemap) {
    if (cubemap.faceSize < 1 || cubemap.faceSize > kMaxGpuFaceSize)
        throw Error(ErrorKind::Input, "GPU bake: face size " + std::to_string(cubemap.faceSize) +
                                          " is outside 1.." + std::to_string(kMaxGpuFaceSize));
    if (cubemap.texels.size() != size_t(kFaceCount) * cubemap.faceSize * cubemap.faceSize)
        throw Error(ErrorKind::Input, "GPU bake: the cube map holds " +
                                          std::to_string(cubemap.texels.size()) + " texels, not 6 x " +
                                          std::to_string(cubemap.faceSize) + "^2");
}

void checkEquirect(const Device& device, const Image& equirect) {
    const int64_t largest = device.info.limits.maxImageDimension2D;
    if (equirect.width < 1 || equirect.height < 1 || equirect.width > largest || equirect.height > largest)
        throw Error(ErrorKind::Input, "GPU bake: equirect size " + std::to_string(equirect.width) + "x" +
                                          std::to_string(equirect.height) + " is outside 1.." +
                                          std::to_string(largest) + " on " + device.info.name);
    if (equirect.texels.size() != size_t(equirect.width) * size_t(equirect.height))
        throw Error(ErrorKind::Input, "GPU bake: the equirect map holds " +
                                          std::to_string(equirect.texels.size()) + " texels, not " +
                                          std::to_string(equirect.width) + " x " +
                                          std::to_string(equirect.height));
}

bool exceedsHalfRange(const glm::vec4& texel) {
    return glm::any(glm::greaterThan(glm::abs(glm::vec3(texel)), glm::vec3(kHalfMax)));
}

// Writes the texels in the image's format; false where one does not fit RGBA16F (requireHalfRange
// says which).
bool packTexels(std::span<const glm::vec4> texels, TexelFormat format, void* destination) {
    if (format == TexelFormat::Rgba32F) {
        std::memcpy(destination, texels.data(), texels.size_bytes());
        return true;
    }
    packHalves(texels, static_cast<uint64_t*>(destination));
    return std::none_of(texels.begin(), texels.end(), exceedsHalfRange);
}

// RGBA16F refuses values a half cannot hold rather than clamping them silently.
void requireHalfRange(std::span<const glm::vec4> texels) {
    for (const glm::vec4& texel : texels)
        if (exceedsHalfRange(texel))
            throw Error(ErrorKind::Input, "GPU bake: a texel of " +
                                              std::to_string(std::max({texel.r, texel.g, texel.b})) +
                                              " does not fit RGBA16F (at most 65504); use RGBA32F");
}

// Calls visit(texels) for the rows [first, first + count) of the probes' layers, numbered through
// the probes (each holds whole rows of `width` texels): one span per probe the rows meet.
template <class Visit>
void forEachRowSpan(std::span<const std::span<const glm::vec4>> probeTexels, uint32_t width, uint64_t first,
                    uint64_t count, const Visit& visit) {
    for (std::span<const glm::vec4> texels : probeTexels) {
        const uint64_t rows = texels.size() / width;
        if (first >= rows) {
            first -= rows;
            continue;
        }
        const uint64_t taken = std::min(count, rows - first);
        visit(texels.subspan(first * width, taken * width));
        count -= taken;
        if (count == 0) return;
        first = 0;
    }
}

// A bytes-per-thread share worth a thread's start (tens of microseconds) when packing texels.
constexpr size_t kPackBytesPerThread = size_t(4) << 20;

// Fills rows of `height`-row layers from the probes' texels in `format`, on all cores, where `layout`
// places them (staging slots: tightly packed; an image's own memory: its layout).
FillRows packRows(std::span<const std::span<const glm::vec4>> probeTexels, uint32_t width, uint32_t height,
                  TexelFormat format, LinearRows layout) {
    const auto offsetOf = [=](uint64_t row) {
        return row / height * layout.layerPitch + row % height * layout.rowPitch;
    };
    return [=](uint64_t first, uint32_t rows, void* destination) {
        const size_t rowBytes = size_t(width) * texelBytes(format);
        const unsigned threads = threadCount(rows * rowBytes, kPackBytesPerThread);
        const VkDeviceSize firstOffset = offsetOf(first); // where `destination` lies
        const uint32_t perThread = (rows + threads - 1) / threads;
        std::atomic<bool> fits = true;
        forEachItem(int(threads), threads, [&](int piece) {
            const uint32_t begin = std::min(rows, uint32_t(piece) * perThread);
            const uint32_t end = std::min(rows, begin + perThread);
            uint64_t row = first + begin;
            forEachRowSpan(probeTexels, width, row, end - begin, [&](std::span<const glm::vec4> texels) {
                for (size_t texel = 0; texel < texels.size(); texel += width, ++row) {
                    char* out = static_cast<char*>(destination) + (offsetOf(row) - firstOffset);
                    if (!packTexels(texels.subspan(texel, width), format, out)) fits = false;
                }
            });
        });
        if (!fits) forEachRowSpan(probeTexels, width, first, rows, requireHalfRange);
    };
}

// Probe k's coefficients of one quantity in a bake output that starts at `offset`.
ShCoefficients readCoefficients(const Buffer& output, VkDeviceSize offset, int order, uint32_t probes,
                                uint32_t k, Quantity quantity) {
    ShCoefficients coefficients = makeCoefficients(order, quantity);
    offset += probeOutputOffset(order, probes, k, quantity);
    auto* values = reinterpret_cast<const glm::vec4*>(static_cast<const char*>(output.mapped) + offset);
    for (size_t i = 0; i < coefficients.rgb.size(); ++i)
        coefficients.rgb[i] = glm::dvec3(glm::vec3(values[i]));
    return coefficients;
}

std::optional<size_t> firstNonFinite(const ShCoefficients& coefficients) {
    for (size_t i = 0; i < coefficients.rgb.size(); ++i)
        if (glm::any(glm::isnan(coefficients.rgb[i])) || glm::any(glm::isinf(coefficients.rgb[i]))) return i;
    return std::nullopt;
}

TexelFormat uploadFormat(CubemapBinding binding) {
    return binding == CubemapBinding::StorageRgba16F ? TexelFormat::Rgba16F : TexelFormat::Rgba32F;
}

// The image of an upload, `layers` layers of `extent` for `binding`, holding the texels of each
// probe (probeTexels, whole layers each), by the fastest route from options.fastest on that the
// device and the texels allow; returns the route taken. What it made is in `staged` and `image`
// when it throws.
UploadRoute createLayers(const Context& context, VkExtent2D extent, uint32_t layers, CubemapBinding binding,
                         std::span<const std::span<const glm::vec4>> probeTexels, const char* what,
                         const UploadOptions& options, StagedRows& staged, GpuImage& image) {
    const TexelFormat format = uploadFormat(binding);
    const VkImageUsageFlags readUsage =
        binding == CubemapBinding::SampledImage ? VK_IMAGE_USAGE_SAMPLED_BIT : VK_IMAGE_USAGE_STORAGE_BIT;
    const VkDeviceSize rowBytes = VkDeviceSize(extent.width) * texelBytes(format);
    if (options.fastest == UploadRoute::InPlace && probeTexels.size() == 1 &&
        format == TexelFormat::Rgba32F) {
        const std::span<const glm::vec4> texels = probeTexels.front();
        if (std::optional<GpuImage> inPlace =
                importHostImage(context, texels.data(), texels.size_bytes(), imageFormat(format), extent,
                                layers, readUsage)) {
            image = *inPlace;
            return UploadRoute::InPlace;
        }
    }
    if (options.fastest != UploadRoute::Staged) {
        if (std::optional<MappedImage> mapped =
                createMappedImage(context, imageFormat(format), extent, layers, readUsage, what)) {
            image = mapped->image; // the caller's undo destroys it should the packing throw
            packRows(probeTexels, extent.width, extent.height, format,
                     mapped->rows)(0, extent.height * layers, mapped->texels);
            return UploadRoute::Packed;
        }
    }
    image = createImage(context, {.format = imageFormat(format),
                                  .extent = extent,
                                  .usage = readUsage | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                  .what = what,
                                  .layers = layers});
    const LinearRows tight{.rowPitch = rowBytes, .layerPitch = rowBytes * extent.height};
    staged =
        stageImageRows(context, image, rowBytes,
                       packRows(probeTexels, extent.width, extent.height, format, tight), options.staging);
    return UploadRoute::Staged;
}

// Records the last staging slot's copy (none for an image in host memory) and leaves the image as
// probe_baker.h asks: in cubemapLayout(binding), visible to compute-shader reads; what the host
// wrote there before the submission is visible to the device without a barrier of its own (the
// memory is coherent), the transition keeps it.
void recordLayers(VkCommandBuffer commands, const StagedRows& staged, const GpuImage& image,
                  CubemapBinding binding, UploadRoute route) {
    if (route == UploadRoute::Staged)
        return recordStagedRows(commands, staged, image, cubemapLayout(binding),
                                VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
    // An imported image starts UNDEFINED (a CPU device keeps its texels, vk/host_memory.h), a mapped one
    // PREINITIALIZED.
    const VkImageLayout from =
        route == UploadRoute::InPlace ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_PREINITIALIZED;
    changeLayout(commands, image,
                 {from, cubemapLayout(binding), VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_WRITE_BIT,
                  VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT});
}

// A source kind's host side, for bakeBatch: cube maps (6 layers each) or equirect maps (1).
struct CubemapSource {
    using Texels = Cubemap;
    using Upload = CubemapUpload;
    static constexpr uint32_t kLayers = kFaceCount;
    static void check(const Device&, const Cubemap& cubemap) { checkCubemap(cubemap); }
    static VkExtent2D size(const Cubemap& cubemap) {
        return {uint32_t(cubemap.faceSize), uint32_t(cubemap.faceSize)};
    }
    static Upload upload(const Context& context, std::span<const Cubemap* const> members,
                         CubemapBinding binding) {
        return createCubemapUpload(context, members, binding);
    }
    static void record(VkCommandBuffer commands, const Upload& upload) {
        recordCubemapUpload(commands, upload);
    }
    static void destroy(const Context& context, Upload& upload) { destroyCubemapUpload(context, upload); }
    static ProbeBakeSet bakeSet(const Device& device, const ProbeBaker& baker, const Upload& upload,
                                VkBuffer output, VkDeviceSize offset) {
        return createProbeBakeSet(device, baker,
                                  {upload.image.view, upload.faceSize, upload.probeCount, output, offset});
    }
};

struct EquirectSource {
    using Texels = Image;
    using Upload = EquirectUpload;
    static constexpr uint32_t kLayers = 1;
    static void check(const Device& device, const Image& equirect) { checkEquirect(device, equirect); }
    static VkExtent2D size(const Image& equirect) {
        return {uint32_t(equirect.width), uint32_t(equirect.height)};
    }
    static Upload upload(const Context& context, std::span<const Image* const> members,
                         CubemapBinding binding) {
        return createEquirectUpload(context, members, binding);
    }
    static void record(VkCommandBuffer commands, const Upload& upload) {
        recordEquirectUpload(commands, upload);
    }
    static void destroy(const Context& context, Upload& upload) { destroyEquirectUpload(context, upload); }
    static ProbeBakeSet bakeSet(const Device& device, const ProbeBaker& baker, const Upload& upload,
                                VkBuffer output, VkDeviceSize offset) {
        return createEquirectBakeSet(
            device, baker, {upload.view, upload.width, upload.height, upload.probeCount, output, offset});
    }
};

// Maps of one size, baked from one image (Source::kLayers layers per map) with one bake set.
template <class Source> struct BakeGroup {
    std::vector<size_t> members; // indices into the batch
    VkExtent2D size{};
    VkDeviceSize outputOffset = 0;
    typename Source::Upload upload;
    ProbeBakeSet set;
};

// Groups by size, in order of first appearance, at most maxImageArrayLayers / kLayers maps each.
template <class Source>
std::vector<BakeGroup<Source>> groupBySize(const Device& device,
                                           std::span<const typename Source::Texels* const> sources) {
    const size_t maxProbes = std::max<size_t>(1, device.info.limits.maxImageArrayLayers / Source::kLayers);
    std::vector<BakeGroup<Source>> groups;
    for (size_t i = 0; i < sources.size(); ++i) {
        const VkExtent2D size = Source::size(*sources[i]);
        auto open = std::find_if(groups.begin(), groups.end(), [&](const BakeGroup<Source>& group) {
            return group.size.width == size.width && group.size.height == size.height &&
                   group.members.size() < maxProbes;
        });
        if (open == groups.end()) open = groups.insert(groups.end(), BakeGroup<Source>{{}, size});
        open->members.push_back(i);
    }
    return groups;
}

// bakeCubemaps and bakeEquirects: one upload and bake set per size, one submission.
template <class Source>
std::vector<GpuBake> bakeBatch(const Context& context, const ProbeBaker& baker,
                               std::span<const typename Source::Texels* const> sources,
                               std::span<const double> window) {
    const int order = baker.options.order;
    for (const typename Source::Texels* source : sources)
        Source::check(context, *source);
    if (sources.empty()) return {};

    std::vector<BakeGroup<Source>> groups = groupBySize<Source>(context, sources);
    ScopeExit releaseGroups([&] {
        for (BakeGroup<Source>& group : groups) {
            destroyProbeBakeSet(context, group.set);
            Source::destroy(context, group.upload);
        }
    });
    VkDeviceSize outputBytes = 0;
    for (BakeGroup<Source>& group : groups) {
        group.outputOffset = outputBytes;
        outputBytes = alignUp(outputBytes + probeBakeOutputBytes(order, uint32_t(group.members.size())),
                              context.info.limits.minStorageBufferOffsetAlignment);
    }
    auto start = Clock::now();
    Buffer output = createBuffer(context, outputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 MemoryUse::Readback, "coefficients");
    ScopeExit releaseOutput([&] { destroyBuffer(context, output); });
    UploadRoute route = UploadRoute::InPlace;
    for (BakeGroup<Source>& group : groups) {
        std::vector<const typename Source::Texels*> members;
        for (size_t index : group.members)
            members.push_back(sources[index]);
        group.upload = Source::upload(context, members, baker.options.cubemaps);
        group.set = Source::bakeSet(context, baker, group.upload, output.buffer, group.outputOffset);
        route = std::max(route, group.upload.route);
    }
    VkQueryPool timestamps = createTimestampPool(context);
    ScopeExit releaseTimestamps([&] {
        if (timestamps) vkDestroyQueryPool(context.device, timestamps, nullptr);
    });

    const double uploadMs = millisecondsSince(start);
    start = Clock::now();
    submitAndWait(context, [&](VkCommandBuffer commands) {
        for (const BakeGroup<Source>& group : groups)
            Source::record(commands, group.upload);
        if (timestamps) {
            vkCmdResetQueryPool(commands, timestamps, 0, 2);
            vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, timestamps, 0);
        }
        for (const BakeGroup<Source>& group : groups)
            recordProbeBake(commands, baker, group.set, window);
        if (timestamps) vkCmdWriteTimestamp(commands, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps, 1);
        computeWriteBarrier(commands); // the coefficients, to the host
    });

    const double submitMs = millisecondsSince(start);
    start = Clock::now();
    invalidateBuffer(context, output);
    const double deviceMs = timestampMilliseconds(context, timestamps);
    std::vector<GpuBake> bakes(sources.size());
    for (const BakeGroup<Source>& group : groups)
        for (size_t k = 0; k < group.members.size(); ++k) {
            GpuBake& bake = bakes[group.members[k]];
            bake = readBakeOutput(output, group.outputOffset, order, uint32_t(group.members.size()),
                                  uint32_t(k));
            bake.deviceMilliseconds = deviceMs;
            bake.workgroups = group.set.groupsPerProbe;
        }
    const double readbackMs = millisecondsSince(start);
    for (GpuBake& bake : bakes) {
        bake.uploadMilliseconds = uploadMs;
        bake.submitMilliseconds = submitMs;
        bake.readbackMilliseconds = readbackMs;
        bake.route = route;
    }
    return bakes;
}

} // namespace

GpuBake readBakeOutput(const Buffer& output, VkDeviceSize offset, int order, uint32_t probes, uint32_t k) {
    return {readCoefficients(output, offset, order, probes, k, Quantity::Radiance),
            readCoefficients(output, offset, order, probes, k, Quantity::Irradiance)};
}

CubemapBinding uploadBinding(const Device& device, TexelFormat format) {
    // Vulkan requires storage-image support with optimal tiling for both formats; checked anyway.
    VkFormatProperties properties{};
    vkGetPhysicalDeviceFormatProperties(device.physicalDevice, imageFormat(format), &properties);
    if (!(properties.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT))
        return CubemapBinding::SampledImage;
    return format == TexelFormat::Rgba16F ? CubemapBinding::StorageRgba16F : CubemapBinding::StorageRgba32F;
}

CubemapUpload createCubemapUpload(const Context& context, std::span<const Cubemap* const> cubemaps,
                                  CubemapBinding binding, const UploadOptions& options) {
    if (cubemaps.empty()) throw Error(ErrorKind::Input, "GPU bake: an upload of no cube maps");
    CubemapUpload upload;
    upload.binding = binding;
    upload.faceSize = uint32_t(cubemaps.front()->faceSize);
    upload.probeCount = uint32_t(cubemaps.size());
    std::vector<std::span<const glm::vec4>> texels;
    for (const Cubemap* cubemap : cubemaps) {
        checkCubemap(*cubemap);
        if (uint32_t(cubemap->faceSize) != upload.faceSize)
            throw Error(ErrorKind::Input, "GPU bake: cube maps of one upload must share their face size");
        texels.emplace_back(cubemap->texels);
    }
    OnFailure undo([&] { destroyCubemapUpload(context, upload); });
    upload.route = createLayers(context, {upload.faceSize, upload.faceSize}, kFaceCount * upload.probeCount,
                                binding, texels, "cube maps to bake", options, upload.staged, upload.image);
    return upload;
}

void recordCubemapUpload(VkCommandBuffer commands, const CubemapUpload& upload) {
    recordLayers(commands, upload.staged, upload.image, upload.binding, upload.route);
}

void destroyCubemapUpload(const Context& context, CubemapUpload& upload) {
    destroyStagedRows(context, upload.staged);
    destroyImage(context, upload.image);
    upload = CubemapUpload{};
}

EquirectUpload createEquirectUpload(const Context& context, std::span<const Image* const> equirects,
                                    CubemapBinding binding, const UploadOptions& options) {
    EquirectUpload upload;
    upload.binding = binding;
    upload.width = uint32_t(equirects.front()->width);
    upload.height = uint32_t(equirects.front()->height);
    upload.probeCount = uint32_t(equirects.size());
    std::vector<std::span<const glm::vec4>> texels;
    for (const Image* equirect : equirects) {
        checkEquirect(context, *equirect);
        if (uint32_t(equirect->width) != upload.width || uint32_t(equirect->height) != upload.height)
            throw Error(ErrorKind::Input, "GPU bake: equirect maps of one upload must share their size");
        texels.emplace_back(equirect->texels);
    }
    OnFailure undo([&] { destroyEquirectUpload(context, upload); });
    upload.route = createLayers(context, {upload.width, upload.height}, upload.probeCount, binding, texels,
                                "equirect maps to bake", options, upload.staged, upload.image);
    upload.view = createImageView(context, upload.image.image, VK_IMAGE_VIEW_TYPE_2D_ARRAY,
                                  upload.image.format, upload.probeCount);
    return upload;
}

void recordEquirectUpload(VkCommandBuffer commands, const EquirectUpload& upload) {
    recordLayers(commands, upload.staged, upload.image, upload.binding, upload.route);
}

void destroyEquirectUpload(const Context& context, EquirectUpload& upload) {
    if (upload.view) vkDestroyImageView(context.device, upload.view, nullptr);
    destroyStagedRows(context, upload.staged);
    destroyImage(context, upload.image);
    upload = EquirectUpload{};
}

VkDeviceSize batchTexelBytes(const Device& device) {
    VkDeviceSize largestHeap = 0;
    for (uint32_t h = 0; h < device.memory.memoryHeapCount; ++h)
        if (device.memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
            largestHeap = std::max(largestHeap, device.memory.memoryHeaps[h].size);
    // A quarter of the heap leaves room for the staging copy and whatever else the device holds.
    return std::min<VkDeviceSize>(VkDeviceSize(1) << 30, largestHeap / 4);
}

std::vector<GpuBake> bakeCubemaps(const Context& context, const ProbeBaker& baker,
                                  std::span<const Cubemap* const> cubemaps, std::span<const double> window) {
    return bakeBatch<CubemapSource>(context, baker, cubemaps, window);
}

GpuBake bakeCubemap(const Context& context, const ProbeBaker& baker, const Cubemap& cubemap,
                    std::span<const double> window) {
    const Cubemap* one[] = {&cubemap};
    GpuBake bake = bakeCubemaps(context, baker, one, window).front();
    requireFinite(bake, "the cube map");
    return bake;
}

std::vector<GpuBake> bakeEquirects(const Context& context, const ProbeBaker& baker,
                                   std::span<const Image* const> equirects, std::span<const double> window) {
    return bakeBatch<EquirectSource>(context, baker, equirects, window);
}

GpuBake bakeEquirect(const Context& context, const ProbeBaker& baker, const Image& equirect,
                     std::span<const double> window) {
    const Image* one[] = {&equirect};
    GpuBake bake = bakeEquirects(context, baker, one, window).front();
    requireFinite(bake, "the equirect map");
    return bake;
}

GpuBake convolveOnGpu(const Context& context, const ProbeBaker& baker, const ShCoefficients& radiance,
                      std::span<const double> window) {
    const int order = baker.options.order;
    if (radiance.order != order || radiance.quantity != Quantity::Radiance)
        throw Error(ErrorKind::Input,
                    "GPU convolution: expected order-" + std::to_string(order) + " radiance");
    std::vector<glm::vec4> raw;
    for (const glm::dvec3& c : radiance.rgb)
        raw.emplace_back(glm::vec3(c), 0.0f);
    const VkDeviceSize setBytes = coefficientSetBytes(order);
    const VkDeviceSize outputBytes = probeBakeOutputBytes(order, 1);

    Buffer input =
        createBuffer(context, setBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                     MemoryUse::Device, "radiance to convolve");
    ScopeExit releaseInput([&] { destroyBuffer(context, input); });
    Buffer output = createBuffer(context, outputBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 MemoryUse::Readback, "coefficients");
    ScopeExit releaseOutput([&] { destroyBuffer(context, output); });
    uploadBuffer(context, input, raw.data(), setBytes);
    VkDescriptorPool pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 2});
    ScopeExit releasePool([&] { vkDestroyDescriptorPool(context.device, pool, nullptr); });
    const BindingTarget targets[] = {{input.buffer, 0, setBytes}, {output.buffer, 0, outputBytes}};
    VkDescriptorSet set = createDescriptorSet(context, pool, baker.convolve, targets);
    submitAndWait(context, [&](VkCommandBuffer commands) {
        recordConvolutions(commands, baker, set, 1, window);
        computeWriteBarrier(commands);
    });
    invalidateBuffer(context, output);
    return readBakeOutput(output, 0, order, 1, 0);
}

bool isFinite(const GpuBake& bake) {
    return !firstNonFinite(bake.radiance) && !firstNonFinite(bake.irradiance);
}

void requireFinite(const GpuBake& bake, const std::string& what) {
    const std::optional<size_t> radiance = firstNonFinite(bake.radiance);
    const std::optional<size_t> irradiance = firstNonFinite(bake.irradiance);
    if (!radiance && !irradiance) return;
    const size_t index = radiance ? *radiance : *irradiance;
    throw Error(ErrorKind::Input, what + ": GPU bake: coefficient " + std::to_string(index) +
                                      " is not finite (input values too large for fp32 sums?)");
}

} // namespace shprobe
