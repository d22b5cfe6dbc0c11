// GPU bake from host memory: uploads cube maps into an image, records the bake of
// gpu/probe_baker.h (project.comp, reduce.comp, convolve.comp) and reads the coefficients back,
// all in one submission however many cube maps there are.
#pragma once
#include "shprobe/gpu/probe_baker.h"
#include "shprobe/sh/coefficients.h"
#include "shprobe/sh/cubemap.h"
#include "shprobe/vk/context.h"
#include "shprobe/vk/image.h"
#include "shprobe/vk/resources.h"

#include <span>
#include <string>
#include <vector>

namespace shprobe {

struct ProjectorOptions {
    int order = 3;                      // 1..kMaxOrder
    uint32_t workgroupSize = 64;        // invocations per workgroup
    uint32_t texelsPerInvocation = 256; // sets the workgroup count: more texels, fewer reductions;
                                        // capped by order for lavapipe's loop limit (probe_baker.cpp)
    // How the texels are stored on the GPU: RGBA32F as loaded, or RGBA16F (half the bytes to read;
    // values beyond the half range, +-65504, are refused).
    TexelFormat texelFormat = TexelFormat::Rgba32F;
    VkPipelineCache pipelineCache = VK_NULL_HANDLE; // optional
};

// The fastest way the projection can read cube maps uploaded in this format: as a storage image
// where the device supports storage images of the format, else as a sampled image.
CubemapBinding uploadBinding(const Context& context, TexelFormat format);

// Cube maps of one face size in a 2D-array image, 6 layers each (probe_baker.h's layout), bound as
// uploadBinding says, with the staging buffer they are copied from.
struct CubemapUpload {
    uint32_t faceSize = 0;
    uint32_t probeCount = 0;
    CubemapBinding binding = CubemapBinding::SampledImage;
    Buffer staging;
    GpuImage image;
};

// Creates the image and fills the staging buffer (all cube maps must have the same face size).
CubemapUpload createCubemapUpload(const Context& context, std::span<const Cubemap* const> cubemaps,
                                  TexelFormat format);
// Records the copy and leaves the image as probe_baker.h asks: in cubemapLayout(upload.binding),
// visible to compute-shader reads.
void recordCubemapUpload(VkCommandBuffer commands, const CubemapUpload& upload);
void destroyCubemapUpload(const Context& context, CubemapUpload& upload);

// Pipelines for one order, created once and reused for any number of bakes.
struct Projector {
    ProjectorOptions options;
    ProbeBaker baker;
};

Projector createProjector(const Context& context, const ProjectorOptions& options);
void destroyProjector(const Context& context, Projector& projector);

struct GpuBake {
    ShCoefficients radiance;
    ShCoefficients irradiance;
    double deviceMilliseconds = 0.0; // from timestamps around the bake dispatches (all probes of the
                                     // submission, uploads excluded); 0 where unsupported
    uint32_t workgroups = 0;         // projection workgroups of this probe
    std::string failure;             // why the coefficients cannot be used (not finite); empty if fine
};

// Largest face the GPU path accepts: texel indices are 32-bit (6 N^2 < 2^32).
constexpr int kMaxGpuFaceSize = 16384;

// Projects the cube map and convolves the result, in one submission. `window` holds one factor per
// band (windowing against ringing, see sh/windowing.h); it scales both outputs, as convolve.comp
// applies it: radiance L_lm w_l and irradiance A_l w_l L_lm. Empty: no window.
GpuBake bakeCubemap(const Context& context, const Projector& projector, const Cubemap& cubemap,
                    std::span<const double> window = {});

// Bakes several cube maps (any face sizes) with one submission; results in input order. The window,
// if any, applies to all of them. A probe whose coefficients are not finite (fp32 sums overflowed)
// comes back with `failure` set; the others are unaffected. (bakeCubemap throws instead.) The texels of all
// cube maps must fit batchTexelBytes(context): split larger batches into chunks.
std::vector<GpuBake> bakeCubemaps(const Context& context, const Projector& projector,
                                  std::span<const Cubemap* const> cubemaps,
                                  std::span<const double> window = {});

// The most texel bytes (6 N^2 texels of 16 bytes per cube map, summed) one bakeCubemaps call accepts
// on this device.
VkDeviceSize batchTexelBytes(const Context& context);

// The convolution alone, on radiance computed elsewhere (after lights were added to it, or with a
// window found from it, as de-ringing does). Fills radiance and irradiance of the result.
GpuBake convolveOnGpu(const Context& context, const Projector& projector, const ShCoefficients& radiance,
                      std::span<const double> window = {});

} // namespace shprobe
