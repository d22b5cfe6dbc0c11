// Draws a Scene lit by a probe into scene targets: linear colour (RGBA32F, unclamped: negative
// SH lobes stay negative), the direction each pixel was shaded at (RGBA32F, see
// render_interface.h) and depth. The environment cube map and the folded probe are set once and
// reused for any number of frames; pipelines are created on first use.
#pragma once
#include "render/gpu_image.h"
#include "render/probe_shading.h"
#include "render/scene.h"
#include "render/scene_pipelines.h"
#include "render/tonemap.h"
#include "vk/resources.h"

namespace shprobe {

struct GpuMesh {
    Buffer vertices;
    Buffer indices;
    uint32_t indexCount = 0;
};

struct SceneRenderer {
    ScenePipelines pipelines;
    GpuMesh sphere;
    GpuMesh torus;
    Buffer uniforms;      // glsl::RenderUniforms, host-visible; written when a frame is recorded
    GpuImage environment; // a 1x1 black cube until setEnvironment
    bool hasEnvironment = false;
    VkSampler sampler = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
    ProbeShading probe;
};

SceneRenderer createSceneRenderer(const Context& context);
void destroySceneRenderer(const Device& device, SceneRenderer& renderer);

// Neither may be called while a frame that uses the renderer runs on the device.
void setProbe(SceneRenderer& renderer, const ProbeShading& probe);
void setEnvironment(const Context& context, SceneRenderer& renderer, const Cubemap& cubemap);

struct SceneTargets {
    VkExtent2D extent{};
    GpuImage color;     // ends in SHADER_READ_ONLY_OPTIMAL
    GpuImage direction; // ends in TRANSFER_SRC_OPTIMAL
    GpuImage depth;
    VkFramebuffer framebuffer = VK_NULL_HANDLE;
    VkDescriptorSet tonemapInput = VK_NULL_HANDLE; // color, for the tonemapper it was made with
};

SceneTargets createSceneTargets(const Device& device, const SceneRenderer& renderer,
                                const Tonemapper& tonemapper, VkExtent2D extent);
void destroySceneTargets(const Device& device, const Tonemapper& tonemapper, SceneTargets& targets);

// Writes the uniforms for this scene and records its pass. Throws Error(Input) when the scene
// needs what the renderer lacks (an environment, radiance of the probe, more bands).
void recordScene(const Device& device, VkCommandBuffer commands, SceneRenderer& renderer,
                 const SceneTargets& targets, const Scene& scene);

} // namespace shprobe
