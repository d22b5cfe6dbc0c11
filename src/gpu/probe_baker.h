// GPU-resident probe baking for renderers: the cube maps are already on the GPU, the commands go
// into the caller's command buffer, the coefficients into the caller's buffer. No submission, no
// wait and no host access happen here; the caller decides when the work runs and what follows it.
//
//   Device device = borrowDevice({physicalDevice, vkDevice, queueFamily});  // once
//   ProbeBaker baker = createProbeBaker(device, {.order = 3});
//   ProbeBakeSet set = createProbeBakeSet(device, baker, {cubemapsView, 256, probeCount, buffer, 0});
//   recordProbeBake(commandBuffer, baker, set);                              // per bake
//   ... submit; once it completed: destroyProbeBakeSet, or record it again (same view, new texels).
//
// Equirect maps are baked directly, without a cube map, by a baker made for them:
//
//   ProbeBaker baker = createProbeBaker(device, {.order = 3, .source = ProbeSource::Equirect});
//   ProbeBakeSet set = createEquirectBakeSet(device, baker, {view, 2048, 1024, probeCount, buffer, 0});
//   recordProbeBake(commandBuffer, baker, set);                              // per bake
//
// What the caller provides:
// - The cube maps: a VkImageView of type VK_IMAGE_VIEW_TYPE_2D_ARRAY over 6 * probeCount layers:
//   probe p's face f is layer 6p + f of the view, faces in Vulkan's order +X, -X, +Y, -Y, +Z, -Z with
//   the orientation of shaders/INTERFACE.md (the orientation vkCmdCopyBufferToImage and cube-map
//   rendering give). One mip level is read: the view's base. Alpha is ignored. As the baker's
//   CubemapBinding says: an image with VK_IMAGE_USAGE_SAMPLED_BIT in any format the device can
//   sample, or one with VK_IMAGE_USAGE_STORAGE_BIT in exactly RGBA32F or RGBA16F.
// - Or the equirect maps (ProbeSource::Equirect): a VkImageView of type VK_IMAGE_VIEW_TYPE_2D_ARRAY
//   over probeCount layers of W x H texels, probe p at layer p, rows top to bottom as
//   docs/conventions.md says ("Equirectangular maps": row 0 is +Y, the center looks along -Z). A view
//   of one layer of a plain 2D image is such a view. Same formats, mip level and alpha as cube maps.
// - Before recordProbeBake: the image in cubemapLayout(binding) (SHADER_READ_ONLY_OPTIMAL or
//   GENERAL), and a barrier that makes its writes available to VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT /
//   VK_ACCESS_SHADER_READ_BIT.
// - The output: a buffer with VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, probeBakeOutputBytes(order,
//   probeCount) bytes from an offset that is a multiple of minStorageBufferOffsetAlignment. Layout
//   (std430, vec4 per coefficient, rgb in xyz, w = 0), with n^2 coefficients per probe, flat index
//   i = l(l+1) + m:
//     radiance   L_i of probe p at offset + (p * n^2 + i) * 16
//     irradiance E_i of probe p at offset + ((probeCount + p) * n^2 + i) * 16
// - After recordProbeBake: a barrier from VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT /
//   VK_ACCESS_SHADER_WRITE_BIT to whatever reads the output (uniform reads, transfer, host).
// - The bakes of one ProbeBakeSet share its scratch buffer: recordProbeBake orders itself after the
//   earlier compute work of the queue it runs on, so they may follow each other in one command
//   buffer or on one queue, but must not run concurrently on different queues. Different sets
//   are independent.
#pragma once
#include "glsl/dispatch_plan.h"
#include "sh/coefficients.h"
#include "vk/context.h"
#include "vk/pipeline.h"
#include "vk/resources.h"

#include <cstdint>
#include <span>

namespace shprobe {

// The renderer's own device, borrowed: shprobe creates its baker's objects on it and nothing else.
struct ExternalDevice {
    VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    uint32_t queueFamily = 0; // a family with VK_QUEUE_COMPUTE_BIT, where the bakes will run
    VkPipelineCache pipelineCache = VK_NULL_HANDLE; // optional: the bakers' pipelines go through it
};

// The borrowed handles as the Device the bakers are created on (vk/context.h): no instance, queue
// or command pool comes with it, since nothing here submits. Nothing is created, so nothing is to
// be destroyed. Throws Error(Device) when the queue family does no compute work, or naming what the
// device lacks for baking as createContext does (missingRequirement, vk/context.h).
Device borrowDevice(const ExternalDevice& external);

// How the projection reads the cube maps (or equirect maps): project.comp (project_equirect.comp)
// samples an image of any format; project_rgba32f.comp and project_rgba16f.comp (project_equirect_
// rgba32f.comp, project_equirect_rgba16f.comp) read a storage image of that format. The values and
// the results are the same; which is faster depends on the driver (`shprobe bench` measures).
enum class CubemapBinding { SampledImage, StorageRgba32F, StorageRgba16F };

// What a baker projects: cube maps (project.comp) or equirect maps (project_equirect.comp, which
// weights each pixel by its exact solid angle, as the double reference projectEquirect does).
enum class ProbeSource { Cubemaps, Equirect };

// The layout the cube maps must be in when the bake runs.
VkImageLayout cubemapLayout(CubemapBinding binding);

struct ProbeBakerOptions {
    int order = 3; // 1..kMaxOrder
    CubemapBinding cubemaps = CubemapBinding::SampledImage;
    uint32_t workgroupSize = glsl::kDefaultWorkgroupWidth;            // invocations per projection workgroup
    uint32_t texelsPerInvocation = glsl::kDefaultTexelsPerInvocation; // work per invocation (capped by order)
    ProbeSource source = ProbeSource::Cubemaps; // the projection pipeline built; `cubemaps` is its binding
};

// Created once and reused for any number of bakes: the pipelines of project (of options.source),
// reduce and convolve, their set layouts and, for a sampled image, the sampler.
struct ProbeBaker {
    ProbeBakerOptions options;
    VkSampler sampler = VK_NULL_HANDLE; // SampledImage only
    ComputeProgram project;
    ComputeProgram reduce;
    ComputeProgram convolve;
};

ProbeBaker createProbeBaker(const Device& device, const ProbeBakerOptions& options);
void destroyProbeBaker(const Device& device, ProbeBaker& baker);

// One cube-map bake's input and output.
struct ProbeBakeTarget {
    VkImageView cubemaps = VK_NULL_HANDLE; // 2D array of 6 * probeCount layers (see above)
    uint32_t faceSize = 0;                 // N: the layers are N x N
    uint32_t probeCount = 1;
    VkBuffer output = VK_NULL_HANDLE;
    VkDeviceSize outputOffset = 0; // a multiple of minStorageBufferOffsetAlignment
};

// The output layout above: bytes of one probe's n^2 coefficients, where probe p's radiance or
// irradiance starts (from ProbeBakeTarget::outputOffset), and the bytes of the whole output.
VkDeviceSize coefficientSetBytes(int order);
VkDeviceSize probeOutputOffset(int order, uint32_t probeCount, uint32_t probe, Quantity quantity);
VkDeviceSize probeBakeOutputBytes(int order, uint32_t probeCount);

// One equirect bake's input and output (the output as for cube maps).
struct EquirectBakeTarget {
    VkImageView equirects = VK_NULL_HANDLE; // 2D array of probeCount layers (see above)
    uint32_t width = 0;                     // W x H: the layers' size
    uint32_t height = 0;
    uint32_t probeCount = 1;
    VkBuffer output = VK_NULL_HANDLE;
    VkDeviceSize outputOffset = 0; // a multiple of minStorageBufferOffsetAlignment
};

// What the bakes of one target need, created once and reusable for any number of bakes of it:
// the scratch buffer (partial sums, raw radiance) and the descriptor sets (a pool of their own).
struct ProbeBakeSet {
    ProbeSource source = ProbeSource::Cubemaps;
    ProbeBakeTarget target;      // ProbeSource::Cubemaps
    EquirectBakeTarget equirect; // ProbeSource::Equirect
    uint32_t groupsPerProbe = 0; // projection workgroups per probe
    Buffer scratch;
    VkDeviceSize radianceOffset = 0; // bytes: where the raw radiance starts in the scratch buffer
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet project = VK_NULL_HANDLE;
    VkDescriptorSet reduce = VK_NULL_HANDLE;
    VkDescriptorSet convolve = VK_NULL_HANDLE;
};

// Throws Error(Input) when the target exceeds what the device can bake in one dispatch, or when the
// baker was made for the other source.
ProbeBakeSet createProbeBakeSet(const Device& device, const ProbeBaker& baker, const ProbeBakeTarget& target);
ProbeBakeSet createEquirectBakeSet(const Device& device, const ProbeBaker& baker,
                                   const EquirectBakeTarget& target);
// After the last command buffer that used it completed.
void destroyProbeBakeSet(const Device& device, ProbeBakeSet& set);

// Records project, reduce and both convolutions of every probe of the set (cube maps or equirect
// maps, as the set was created): 4 dispatches whatever the probe count. `window` holds one factor
// per band (de-ringing, sh/windowing.h) applied to both outputs; empty: none. Throws Error(Input)
// for a set of the other source than the baker's.
void recordProbeBake(VkCommandBuffer commands, const ProbeBaker& baker, const ProbeBakeSet& set,
                     std::span<const double> window = {});

// The convolutions alone, for radiance computed elsewhere: a set of baker.convolve reading the raw
// radiance of `probes` probes (binding 0) and writing the output layout above (binding 1).
void recordConvolutions(VkCommandBuffer commands, const ProbeBaker& baker, VkDescriptorSet convolveSet,
                        uint32_t probes, std::span<const double> window);

} // namespace shprobe
