// Light probes inside a scene, on the GPU: each probe's cube map is drawn from the world (sky,
// emission, and the previous bounce's irradiance reflected by the surfaces; scene/scene.h), into
// the six layers per probe that recordProbeBake reads, and baked by it in the same command buffer.
//
//   SceneCapture capture = createSceneCapture(context, world, sky, {.faceSize = 32});
//   CaptureTarget target = createCaptureTarget(context, capture, 32);        // 32 probes at a time
//   recordSceneCapture(commands, capture, target, positions);                // <= 32 positions
//   recordProbeBake(commands, baker, set);  // a ProbeBakeSet of target.cubemaps.view (probe_baker.h)
//
// bakeSceneProbes does all of it for a list of positions: batches, bakes, reads back. The scene's
// views (render/scene_view.h) draw with these pipelines; `shprobe scene` captures its probes by rays
// instead (gpu/ray_capture.h), on this capture's buffers and target.
#pragma once
#include "glsl/capture_interface.h"
#include "gpu/probe_baker.h"
#include "scene/scene.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"
#include "vk/context.h"
#include "vk/image.h"
#include "vk/resources.h"

#include <array>
#include <cstdint>
#include <functional>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

namespace shprobe {

// The irradiance of the previous bounce: a regular grid of probes (scene/probe_grid.h's
// placement), order^2 coefficients each, and whether each is valid (not inside geometry).
struct BounceSource {
    glm::dvec3 boundsMin{0.0};
    glm::dvec3 boundsMax{0.0};
    glm::ivec3 counts{0};
    int order = 0;
    std::span<const glm::dvec3> irradiance; // probe p's coefficient i at p * order^2 + i
    std::span<const uint8_t> valid;         // one per probe
    int visibilitySize = 0;                 // ProbeVolume's visibility maps; 0: none
    std::span<const glm::vec2> visibility;
    std::span<const glm::vec3> offsets; // ProbeVolume's capture offsets; empty: all zero
};

// Where the probes of a bounce source are (its grid, without the coefficients).
struct BounceGrid {
    glm::dvec3 boundsMin{0.0};
    glm::dvec3 boundsMax{0.0};
    glm::ivec3 counts{0};
};

struct SceneCaptureOptions {
    int faceSize = 32;        // N: each probe's cube map is 6 x N x N
    int order = 3;            // of the previous bounce's volume (the bake's order)
    int shadowMapSize = 2048; // each sun's shadow map, over the world's box
};

// The world, the sky and the previous bounce in storage buffers, with the capture's render pass
// and pipelines. The world's triangles are drawn as they are: no culling, so that back faces are
// seen and counted.
struct SceneCapture {
    SceneCaptureOptions options;
    uint32_t triangleCount = 0;
    uint32_t skyFaceSize = 0;
    float nearPlane = 0.0f; // scaled to the world, so that no wall a probe can touch is clipped
    VkFormat depthFormat = VK_FORMAT_UNDEFINED;
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkShaderModule surfaceVertex = VK_NULL_HANDLE;
    VkShaderModule surfaceFragment = VK_NULL_HANDLE;
    VkShaderModule skyVertex = VK_NULL_HANDLE;
    VkShaderModule skyFragment = VK_NULL_HANDLE;
    VkPipeline surfaces = VK_NULL_HANDLE;
    VkPipeline sky = VK_NULL_HANDLE;
    std::vector<glsl::CaptureSun> suns; // as the shaders read them, with their shadow maps' projections
    BounceGrid bounceGrid;              // of setBounceSource's volume; counts 0: none
    std::vector<Buffer> buffers;        // one per binding of capture_interface.h
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
};

// Draws each sun's shadow map (one submission) when the world has suns. Throws Error(Input) for a
// world or sky the capture cannot hold (an index beyond the vertices, a face size of 0),
// Error(Device) when the device lacks what it needs (32-bit float depth, for the shadow maps).
SceneCapture createSceneCapture(const Context& context, const World& world, const Cubemap& sky,
                                const SceneCaptureOptions& options);
void destroySceneCapture(const Device& device, SceneCapture& capture);

// Makes the next captures reflect `bounce` off the surfaces (none: an empty BounceSource).
// Not while a command buffer using the capture may run.
void setBounceSource(const Context& context, SceneCapture& capture, const BounceSource& bounce);

// Where the captures of up to probeCount probes go: the RGBA32F 2D-array image of 6 layers per
// probe (probe_baker.h's layout, for CubemapBinding::StorageRgba32F), a framebuffer per layer and
// the depth buffer they share.
struct CaptureTarget {
    uint32_t probeCount = 0;
    GpuImage cubemaps;
    GpuImage depth;
    std::vector<VkImageView> layerViews;
    std::vector<VkFramebuffer> framebuffers;
};
CaptureTarget createCaptureTarget(const Device& device, const SceneCapture& capture, uint32_t probeCount);
void destroyCaptureTarget(const Device& device, CaptureTarget& target);

// Records the capture of each position (at most target.probeCount) into layers 6p..6p+5 and
// leaves the image in VK_IMAGE_LAYOUT_GENERAL, visible to compute-shader reads. Alpha holds
// SHPROBE_CAPTURE_BACK_FACE where a texel sees the back of a one-sided surface.
void recordSceneCapture(VkCommandBuffer commands, const SceneCapture& capture, const CaptureTarget& target,
                        std::span<const glm::dvec3> positions);

// The parts of a capture that a view of the world (render/scene_view.h) draws with: the sky, then
// the surfaces, into the capture's render pass begun with its push constants set; world -> clip with
// clip x, y and w the dot products of (position - origin) with the rows, reversed depth; the SH
// order as the shaders' specialization constant (`order` must outlive the info).
constexpr VkFormat kCaptureFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
void recordSkyAndSurfaces(VkCommandBuffer commands, const SceneCapture& capture);
glm::mat4 clipFromRows(const std::array<glm::vec3, 3>& rows, const glm::dvec3& origin, float nearPlane);
VkSpecializationInfo orderSpecialization(const uint32_t& order);

// A storage buffer (device memory) holding `bytes` of data, at least 16 bytes since a binding may
// not be empty. Throws Error(Input) where the bytes exceed what one binding may span on the device:
// the shaders bind each buffer whole.
Buffer createStorage(const Context& context, const void* data, size_t bytes, const char* what);
template <typename T>
Buffer createStorage(const Context& context, const std::vector<T>& values, const char* what) {
    return createStorage(context, values.data(), values.size() * sizeof(T), what);
}

// The probes a capture target holds for bakeSceneProbes: probesPerBatch, within the device's image
// layers (6 per probe) and 256 MiB of capture images. Every batch is baked at this size, a partial
// last one too: the bake's workgroup split depends on the probe count, and a probe's sums must not
// depend on how many probes share its batch (a brick equals the same probes of the whole bake, bit
// for bit).
uint32_t capturesPerBatch(const Device& device, const SceneCapture& capture, uint32_t probesPerBatch);

// What bakeSceneProbes gives for each probe.
struct SceneProbe {
    ShCoefficients radiance;
    ShCoefficients irradiance;
    uint32_t backFaceTexels = 0;       // of the 6 N^2 texels of its cube map
    std::vector<glm::vec2> visibility; // the capture by rays' visibility map (gpu/ray_capture.h);
                                       // empty for the raster capture
    glm::vec3 offset{0.0f};            // where the capture by rays moved it out of geometry, from
                                       // the position asked for (ProbeRelocation); zero otherwise
};

struct SceneBakeOptions {
    int order = 3;
    uint32_t probesPerBatch = 32; // captured and baked per command buffer
};

// Captures and bakes every position, probesPerBatch per command buffer (capture, bake, back-face
// count, then one wait); results in input order.
std::vector<SceneProbe> bakeSceneProbes(const Context& context, const SceneCapture& capture,
                                        std::span<const glm::dvec3> positions,
                                        const SceneBakeOptions& options);

// Records the capture of up to target.probeCount positions into the target's layers (6 per probe),
// leaving them written for compute-shader reads: recordSceneCapture, or the capture by rays
// (gpu/ray_capture.h).
using RecordCapture = std::function<void(VkCommandBuffer commands, std::span<const glm::dvec3> positions)>;

// Called after each batch is read back with its probes, those of positions first, first + 1, ...
using FinishBatch = std::function<void(size_t first, std::span<SceneProbe> probes)>;

// bakeSceneProbes with the captures `record` makes into `target`, target.probeCount per batch.
std::vector<SceneProbe> bakeCapturedProbes(const Context& context, const SceneCapture& capture,
                                           const CaptureTarget& target, std::span<const glm::dvec3> positions,
                                           const SceneBakeOptions& options, const RecordCapture& record,
                                           const FinishBatch& finish = {});

// A cube map captured for one probe, read back (for tests and pictures): radiance in rgb, alpha
// as recordSceneCapture leaves it.
Cubemap captureProbeCubemap(const Context& context, const SceneCapture& capture, const glm::dvec3& position);
// The same of a one-probe target, captured by `record`.
Cubemap readCapturedCubemap(const Context& context, const CaptureTarget& target, const glm::dvec3& position,
                            const RecordCapture& record);

} // namespace shprobe
