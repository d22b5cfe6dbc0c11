#include "render/scene_renderer.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/render_interface.h"
#include "render/meshes.h"
#include "vk/graphics.h"
#include "vk/pipeline.h"
#include "vk/vulkan_commands.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <glm/matrix.hpp>

namespace shprobe {

namespace {

// Tessellation: fine enough that the silhouette is round at 2k pixels and the interpolated
// normals stay close to the true ones (the shader renormalizes them).
constexpr int kSphereSegments = 128;
constexpr int kSphereRings = 64;
constexpr float kTorusMajorRadius = 1.3f;
constexpr float kTorusMinorRadius = 0.22f;

void destroyGpuMesh(const Device& device, GpuMesh& mesh) {
    destroyBuffer(device, mesh.indices);
    destroyBuffer(device, mesh.vertices);
    mesh.indexCount = 0;
}

GpuMesh createGpuMesh(const Context& context, const MeshData& mesh) {
    GpuMesh gpuMesh;
    OnFailure undo([&] { destroyGpuMesh(context, gpuMesh); });
    VkDeviceSize vertexBytes = mesh.vertices.size() * sizeof(MeshVertex);
    VkDeviceSize indexBytes = mesh.indices.size() * sizeof(uint32_t);
    gpuMesh.vertices = createBuffer(context, vertexBytes,
                                    VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                    MemoryUse::Device, "mesh vertices");
    gpuMesh.indices =
        createBuffer(context, indexBytes, VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                     MemoryUse::Device, "mesh indices");
    uploadBuffer(context, gpuMesh.vertices, mesh.vertices.data(), vertexBytes);
    uploadBuffer(context, gpuMesh.indices, mesh.indices.data(), indexBytes);
    gpuMesh.indexCount = uint32_t(mesh.indices.size());
    return gpuMesh;
}

void writeEnvironmentDescriptor(const Device& device, const SceneRenderer& renderer) {
    writeDescriptor(device, renderer.set, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                    {.imageView = renderer.environment.view, .sampler = renderer.sampler});
}

VkDescriptorSet createSceneSet(const Device& device, const SceneRenderer& renderer) {
    VkDescriptorSet set = allocateDescriptorSet(device, renderer.pool, renderer.pipelines.setLayout);
    writeDescriptor(device, set, 0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
                    {renderer.uniforms.buffer, 0, sizeof(glsl::RenderUniforms)});
    return set;
}

Cubemap blackCubemap() {
    Cubemap cubemap;
    cubemap.faceSize = 1;
    cubemap.texels.assign(kFaceCount, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    return cubemap;
}

void checkSceneFits(const SceneRenderer& renderer, const Scene& scene) {
    if (renderer.probe.order < scene.order)
        throw Error(ErrorKind::Input, "the probe was folded for order " +
                                          std::to_string(renderer.probe.order) +
                                          ", the scene asks for order " + std::to_string(scene.order));
    bool needsRadiance = scene.shading == ShadingMode::Radiance || scene.background == Background::Radiance;
    if (needsRadiance && !renderer.probe.hasRadiance)
        throw Error(ErrorKind::Input, "radiance mode and the radiance background need radiance coefficients; "
                                      "the probe holds irradiance, whose band 3 is lost (A_3 = 0)");
    if (scene.background == Background::Environment && !renderer.hasEnvironment)
        throw Error(ErrorKind::Input,
                    "the environment background needs an environment image, not a probe file");
}

glsl::RenderUniforms makeUniforms(const SceneRenderer& renderer, const Scene& scene, VkExtent2D extent) {
    glsl::RenderUniforms uniforms{};
    float aspect = float(extent.width) / float(extent.height);
    uniforms.viewProjection = viewProjection(scene.camera, aspect);
    uniforms.inverseViewProjection = glm::inverse(uniforms.viewProjection);
    uniforms.camera = glm::vec4(scene.camera.position, float(scene.camera.projection == Projection::Panorama
                                                                 ? SHPROBE_PROJECTION_PANORAMA
                                                                 : SHPROBE_PROJECTION_PERSPECTIVE));
    uniforms.viewport = glm::vec4(float(extent.width), float(extent.height), 1.0f / float(extent.width),
                                  1.0f / float(extent.height));
    uniforms.backgroundColor = glm::vec4(scene.backgroundColor, 1.0f);
    std::copy(renderer.probe.radiance.begin(), renderer.probe.radiance.end(), uniforms.radiance);
    std::copy(renderer.probe.irradiance.begin(), renderer.probe.irradiance.end(), uniforms.irradiance);
    std::copy(renderer.probe.l1.begin(), renderer.probe.l1.end(), uniforms.l1);
    uniforms.sun = renderer.probe.foldedSun; // direction.w = 0: no sun, nothing added
    return uniforms;
}

void drawObjects(const Device& device, VkCommandBuffer commands, SceneRenderer& renderer,
                 const Scene& scene) {
    if (scene.camera.projection == Projection::Panorama || scene.objects.empty()) return;
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS,
                      meshPipeline(device, renderer.pipelines, scene));
    for (const SceneObject& object : scene.objects) {
        const GpuMesh& mesh = object.shape == Shape::Sphere ? renderer.sphere : renderer.torus;
        glsl::ObjectConstants constants{object.model, glm::vec4(object.albedo, 1.0f)};
        vkCmdPushConstants(commands, renderer.pipelines.layout,
                           VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(constants),
                           &constants);
        VkDeviceSize offset = 0;
        vkCmdBindVertexBuffers(commands, 0, 1, &mesh.vertices.buffer, &offset);
        vkCmdBindIndexBuffer(commands, mesh.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
        vkCmdDrawIndexed(commands, mesh.indexCount, 1, 0, 0, 0);
    }
}

} // namespace

SceneRenderer createSceneRenderer(const Context& context) {
    SceneRenderer renderer;
    OnFailure undo([&] { destroySceneRenderer(context, renderer); });
    renderer.pipelines = createScenePipelines(context);
    renderer.sphere = createGpuMesh(context, makeSphereMesh(kSphereSegments, kSphereRings));
    renderer.torus = createGpuMesh(context, makeTorusMesh(kTorusMajorRadius, kTorusMinorRadius, 96, 32));
    renderer.uniforms =
        createBuffer(context, sizeof(glsl::RenderUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                     MemoryUse::Upload, "render uniforms");
    renderer.sampler = createSampler(context, VK_FILTER_LINEAR);
    renderer.pool = createDescriptorPool(context, {.sets = 1, .imageSamplers = 1, .uniformBuffers = 1});
    renderer.set = createSceneSet(context, renderer);
    renderer.environment = createCubeTexture(context, blackCubemap());
    writeEnvironmentDescriptor(context, renderer);
    return renderer;
}

void destroySceneRenderer(const Device& device, SceneRenderer& renderer) {
    destroyImage(device, renderer.environment);
    if (renderer.pool) vkDestroyDescriptorPool(device.device, renderer.pool, nullptr);
    if (renderer.sampler) vkDestroySampler(device.device, renderer.sampler, nullptr);
    destroyBuffer(device, renderer.uniforms);
    destroyGpuMesh(device, renderer.torus);
    destroyGpuMesh(device, renderer.sphere);
    destroyScenePipelines(device, renderer.pipelines);
    renderer = SceneRenderer{};
}

void setProbe(SceneRenderer& renderer, const ProbeShading& probe) {
    renderer.probe = probe;
}

void setEnvironment(const Context& context, SceneRenderer& renderer, const Cubemap& cubemap) {
    GpuImage image = createCubeTexture(context, cubemap);
    destroyImage(context, renderer.environment);
    renderer.environment = image;
    renderer.hasEnvironment = true;
    writeEnvironmentDescriptor(context, renderer);
}

SceneTargets createSceneTargets(const Device& device, const SceneRenderer& renderer,
                                const Tonemapper& tonemapper, VkExtent2D extent) {
    SceneTargets targets;
    targets.extent = extent;
    OnFailure undo([&] { destroySceneTargets(device, tonemapper, targets); });
    const VkImageUsageFlags attachment = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
    targets.color =
        createImage(device, {kSceneColorFormat, extent,
                             attachment | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, false,
                             "scene colour target"});
    targets.direction =
        createImage(device, {kSceneDirectionFormat, extent, attachment | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                             false, "scene direction target"});
    targets.depth = createImage(device, {renderer.pipelines.depthFormat, extent,
                                         VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, false, "depth target"});
    const std::array<VkImageView, 3> views{targets.color.view, targets.direction.view, targets.depth.view};
    targets.framebuffer = createFramebuffer(device, renderer.pipelines.renderPass, views, extent);
    targets.tonemapInput = createTonemapInput(device, tonemapper, targets.color.view);
    return targets;
}

void destroySceneTargets(const Device& device, const Tonemapper& tonemapper, SceneTargets& targets) {
    freeTonemapInput(device, tonemapper, targets.tonemapInput);
    if (targets.framebuffer) vkDestroyFramebuffer(device.device, targets.framebuffer, nullptr);
    destroyImage(device, targets.depth);
    destroyImage(device, targets.direction);
    destroyImage(device, targets.color);
    targets = SceneTargets{};
}

void recordScene(const Device& device, VkCommandBuffer commands, SceneRenderer& renderer,
                 const SceneTargets& targets, const Scene& scene) {
    checkSceneFits(renderer, scene);
    glsl::RenderUniforms uniforms = makeUniforms(renderer, scene, targets.extent);
    std::memcpy(renderer.uniforms.mapped, &uniforms, sizeof(uniforms)); // coherent memory

    std::array<VkClearValue, 3> clears{};
    clears[2].depthStencil = {1.0f, 0};
    beginRenderPass(commands, renderer.pipelines.renderPass, targets.framebuffer, targets.extent, clears);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, renderer.pipelines.layout, 0, 1,
                            &renderer.set, 0, nullptr);
    drawObjects(device, commands, renderer, scene); // first: the background only fills what is left
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS,
                      backgroundPipeline(device, renderer.pipelines, scene));
    vkCmdDraw(commands, 3, 1, 0, 0);
    vkCmdEndRenderPass(commands);
}

} // namespace shprobe
