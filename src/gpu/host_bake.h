// Baking cube maps or equirect maps held in host memory with the recorded bake of
// gpu/probe_baker.h: upload the texels into an image, record the bake, submit, read the coefficients
// back; one submission however many maps there are. The pipelines are a ProbeBaker whose binding is
// uploadBinding(device, format) and whose source is the maps' (ProbeSource::Cubemaps or Equirect);
// the texel format uploaded follows from that binding.
#pragma once
#include "gpu/probe_baker.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"
#include "vk/context.h"
#include "vk/image.h"
#include "vk/resources.h"
#include "vk/staged_upload.h"

#include <span>
#include <string>
#include <vector>

namespace shprobe {

// The fastest way the projection can read maps uploaded in this format: as a storage image
// where the device supports storage images of the format, else as a sampled image (RGBA32F).
// RGBA16F reads half the bytes; values beyond the half range, +-65504, are refused at upload.
CubemapBinding uploadBinding(const Device& device, TexelFormat format);

// How an upload's texels reach the image the bake reads, fastest first. The first two need a device
// that reads host memory where it lies (a CPU device such as lavapipe, vk/host_memory.h).
enum class UploadRoute {
    InPlace, // one map's own RGBA32F texels are the image's memory: no copy (the map must outlive the upload)
    Packed,  // packed on all cores straight into the image's own mapped memory: no staging, no device copy
    Staged,  // packed on all cores into staging slots, which the device copies into the image
             // (vk/staged_upload.h: every slot but the last copied while the next is packed)
};

struct UploadOptions {
    StagingOptions staging;
    UploadRoute fastest = UploadRoute::InPlace; // the first route tried; Staged: as on a GPU, always
};

// Cube maps of one face size in a 2D-array image, 6 layers each (probe_baker.h's layout), and the
// staging slots they are copied from when `route` is Staged.
struct CubemapUpload {
    uint32_t faceSize = 0;
    uint32_t probeCount = 0;
    CubemapBinding binding = CubemapBinding::SampledImage;
    StagedRows staged;
    GpuImage image;
    UploadRoute route = UploadRoute::Staged;
};

// Creates the image for a baker of this binding and puts the texels there (all cube maps must have
// the same face size) by the fastest route the device and the maps allow from options.fastest on,
// but for the last staging slot's copy, which recordCubemapUpload records.
CubemapUpload createCubemapUpload(const Context& context, std::span<const Cubemap* const> cubemaps,
                                  CubemapBinding binding, const UploadOptions& options = {});
// Records the last slot's copy and leaves the image as probe_baker.h asks: in
// cubemapLayout(upload.binding), visible to compute-shader reads.
void recordCubemapUpload(VkCommandBuffer commands, const CubemapUpload& upload);
// Waits for copies still in flight.
void destroyCubemapUpload(const Context& context, CubemapUpload& upload);

// Equirect maps of one size in a 2D-array image, one layer each (probe_baker.h's equirect layout),
// uploaded as cube maps are; `view` is the 2D-array view the bake reads (one layer included).
struct EquirectUpload {
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t probeCount = 0;
    CubemapBinding binding = CubemapBinding::SampledImage;
    StagedRows staged;
    GpuImage image;
    VkImageView view = VK_NULL_HANDLE;
    UploadRoute route = UploadRoute::Staged;
};

// As the cube-map upload functions, for equirect maps (all of one size).
EquirectUpload createEquirectUpload(const Context& context, std::span<const Image* const> equirects,
                                    CubemapBinding binding, const UploadOptions& options = {});
void recordEquirectUpload(VkCommandBuffer commands, const EquirectUpload& upload);
void destroyEquirectUpload(const Context& context, EquirectUpload& upload);

struct GpuBake {
    ShCoefficients radiance;
    ShCoefficients irradiance;
    double deviceMilliseconds = 0.0; // from timestamps around the bake dispatches (all probes of the
                                     // submission, uploads excluded); 0 where unsupported
    uint32_t workgroups = 0;         // projection workgroups of this probe
    // Host wall times of the whole submission (all probes): creating the images and bake sets
    // (packing the texels, and copying all staging slots but the last where they were staged),
    // submitting and waiting (the last copies, dispatches), reading the coefficients back.
    double uploadMilliseconds = 0.0;
    double submitMilliseconds = 0.0;
    double readbackMilliseconds = 0.0;
    UploadRoute route = UploadRoute::Staged; // the slowest of the submission's uploads
};

// Probe k of the `probes` probes of a bake whose output (probe_baker.h's layout) starts at `offset`
// of a mapped buffer, after invalidateBuffer.
GpuBake readBakeOutput(const Buffer& output, VkDeviceSize offset, int order, uint32_t probes, uint32_t k);

// Largest face the GPU path accepts: texel indices are 32-bit (6 N^2 < 2^32).
constexpr int kMaxGpuFaceSize = 16384;

// Bakes several cube maps (any face sizes) with one submission; results in input order. `window`
// holds one factor per band (windowing against ringing, sh/windowing.h); it scales both outputs,
// as convolve.comp applies it: radiance L_lm w_l and irradiance A_l w_l L_lm. Empty: no window.
// The coefficients are returned as the device computed them: a probe whose fp32 sums overflowed
// (finite texels near 1e38) has coefficients that are not finite, and requireFinite says so; the
// other probes are unaffected. The texels of all cube maps should fit batchTexelBytes(device):
// split larger batches into chunks.
std::vector<GpuBake> bakeCubemaps(const Context& context, const ProbeBaker& baker,
                                  std::span<const Cubemap* const> cubemaps,
                                  std::span<const double> window = {});

// One cube map; throws Error(Input) where bakeCubemaps would return coefficients that are not finite.
GpuBake bakeCubemap(const Context& context, const ProbeBaker& baker, const Cubemap& cubemap,
                    std::span<const double> window = {});

// Equirect maps (any sizes, each side at most maxImageDimension2D) projected directly, each pixel
// weighted by its row's exact solid angle (sh/projection.h's projectEquirect is the reference), with
// a baker made for them (ProbeSource::Equirect); otherwise as bakeCubemaps, one submission, results
// in input order. Throws Error(Input) for an empty map or one whose texel count disagrees with its
// size. The texels (W H of 16 bytes each, summed) should fit batchTexelBytes(device).
std::vector<GpuBake> bakeEquirects(const Context& context, const ProbeBaker& baker,
                                   std::span<const Image* const> equirects,
                                   std::span<const double> window = {});

// One equirect map; throws Error(Input) where bakeEquirects would return coefficients that are not
// finite.
GpuBake bakeEquirect(const Context& context, const ProbeBaker& baker, const Image& equirect,
                     std::span<const double> window = {});

// The most texel bytes (6 N^2 texels of 16 bytes per cube map, summed) one bakeCubemaps call should
// hold on this device.
VkDeviceSize batchTexelBytes(const Device& device);

// The convolution alone, on radiance computed elsewhere (after lights were added to it, or with a
// window found from it, as de-ringing does). Fills radiance and irradiance of the result; radiance
// beyond float comes back not finite, for the caller's requireFinite to name its input.
GpuBake convolveOnGpu(const Context& context, const ProbeBaker& baker, const ShCoefficients& radiance,
                      std::span<const double> window = {});

// Throws Error(Input) "<what>: GPU bake: coefficient i is not finite (...)" when one of the bake's
// coefficients is not finite: finite inputs whose fp32 sums overflowed, or a device that computed
// garbage; either way no such probe may be handed on. `what` names the input.
void requireFinite(const GpuBake& bake, const std::string& what);
bool isFinite(const GpuBake& bake);

} // namespace shprobe
