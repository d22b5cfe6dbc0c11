#include "gpu/scene_capture.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/capture_interface.h"
#include "glsl/gpu_interface.h"
#include "glsl/texel_geometry.h"
#include "gpu/host_bake.h"
#include "scene/surface_shading.h"
#include "vk/check.h"
#include "vk/graphics.h"
#include "vk/pipeline.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_scene_spirv.h>
#include <shprobe/shprobe_spirv.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <glm/geometric.hpp>
#include <string>

namespace shprobe {

namespace {

constexpr VkFormat kShadowFormat = VK_FORMAT_D32_SFLOAT; // depth of captures, views and shadow maps
constexpr VkBufferUsageFlags kStorageUpload =
    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
constexpr uint32_t kCountWidth = 64; // count_back_faces.comp's workgroup width

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
    return (value + alignment - 1) / alignment * alignment;
}

// Throws Error(Input) when `bytes` exceed what one storage-buffer binding may span on the device:
// the shaders bind each buffer whole.
void checkStorageRange(const Device& device, VkDeviceSize bytes, const char* what) {
    const VkDeviceSize limit = device.info.limits.maxStorageBufferRange;
    if (bytes <= limit) return;
    throw Error(ErrorKind::Input, std::string("scene capture: the ") + what + " take " +
                                      std::to_string(bytes >> 20) + " MiB, more than the " +
                                      std::to_string(limit >> 20) +
                                      " MiB a storage buffer of the device may hold");
}

void checkWorld(const World& world) {
    if (world.indices.size() % 3 != 0 || world.triangleMaterials.size() != world.triangleCount())
        throw Error(ErrorKind::Input, "scene capture: the triangle lists of " + world.description +
                                          " do not match their materials");
    for (uint32_t index : world.indices)
        if (index >= world.positions.size())
            throw Error(ErrorKind::Input,
                        "scene capture: an index of " + world.description + " is beyond its vertices");
    for (uint32_t material : world.triangleMaterials)
        if (material >= world.materials.size())
            throw Error(ErrorKind::Input, "scene capture: a triangle of " + world.description +
                                              " names a material it does not have");
    if (world.normals.size() != world.positions.size() ||
        (!world.uvs.empty() && world.uvs.size() != world.positions.size()))
        throw Error(ErrorKind::Input, "scene capture: the vertices of " + world.description +
                                          " lack normals or texture coordinates");
    for (const SceneTexture& texture : world.textures)
        if (texture.width < 1 || texture.height < 1 ||
            texture.texels.size() != size_t(texture.width) * texture.height)
            throw Error(ErrorKind::Input,
                        "scene capture: a texture of " + world.description + " is empty or cut short");
    for (const SceneMaterial& m : world.materials)
        for (int texture : {m.albedoTexture, m.emissionTexture})
            if (texture < -1 || texture >= int(world.textures.size()))
                throw Error(ErrorKind::Input, "scene capture: a material of " + world.description +
                                                  " names a texture it does not have");
}

std::vector<glsl::CaptureVertex> packVertices(const World& world) {
    std::vector<glsl::CaptureVertex> vertices(world.positions.size());
    for (size_t i = 0; i < vertices.size(); ++i) {
        const glm::vec2 uv = i < world.uvs.size() ? world.uvs[i] : glm::vec2(0.0f);
        vertices[i] = {glm::vec4(world.positions[i], uv.x), glm::vec4(world.normals[i], uv.y)};
    }
    return vertices;
}

std::vector<glsl::CaptureMaterial> packMaterials(const World& world) {
    std::vector<glsl::CaptureMaterial> materials;
    for (const SceneMaterial& m : world.materials)
        materials.push_back({glm::vec4(m.albedo, float(m.albedoTexture)),
                             glm::vec4(m.emission, float(m.emissionTexture)),
                             glm::vec4(m.doubleSided ? 1.0f : 0.0f, 0.0f, 0.0f, 0.0f)});
    return materials;
}

struct PackedTextures {
    std::vector<glsl::CaptureTexture> extents;
    std::vector<glm::vec4> texels;
};

PackedTextures packTextures(const World& world) {
    PackedTextures packed;
    for (const SceneTexture& texture : world.textures) {
        packed.extents.push_back({glm::uvec4(uint32_t(packed.texels.size()), uint32_t(texture.width),
                                             uint32_t(texture.height), 0u)});
        packed.texels.insert(packed.texels.end(), texture.texels.begin(), texture.texels.end());
    }
    return packed;
}

// Probes and their bounce volume header, with no previous bounce: counts.w = 0; then the
// visibility maps, two texels to a vec4, and the capture offsets, one to a vec4.
std::vector<glm::vec4> packBounce(const BounceSource& bounce) {
    constexpr size_t kHeader = sizeof(glsl::CaptureVolumeHeader) / sizeof(glm::vec4);
    const size_t probes = size_t(bounce.counts.x) * bounce.counts.y * bounce.counts.z;
    const size_t perProbe = size_t(bounce.order) * bounce.order;
    const size_t texels = probes * size_t(bounce.visibilitySize) * size_t(bounce.visibilitySize);
    const size_t offsetsAt = probes * perProbe + (texels + 1) / 2; // after the header
    std::vector<glm::vec4> packed(kHeader + offsetsAt + bounce.offsets.size(), glm::vec4(0.0f));
    if (probes == 0) return packed;
    if (bounce.irradiance.size() != probes * perProbe || bounce.valid.size() != probes ||
        bounce.visibility.size() != texels || (!bounce.offsets.empty() && bounce.offsets.size() != probes))
        throw Error(ErrorKind::Input, "scene capture: the previous bounce's volume holds " +
                                          std::to_string(bounce.irradiance.size()) + " coefficients, " +
                                          std::to_string(bounce.visibility.size()) +
                                          " visibility texels and " + std::to_string(bounce.offsets.size()) +
                                          " capture offsets for " + std::to_string(probes) +
                                          " probes of order " + std::to_string(bounce.order));
    const glsl::CaptureVolumeHeader header{
        glm::vec4(glm::vec3(bounce.boundsMin), 0.0f), glm::vec4(glm::vec3(bounce.boundsMax), 0.0f),
        glm::uvec4(glm::uvec3(bounce.counts), 1u),
        glm::uvec4(uint32_t(bounce.visibilitySize), uint32_t(probes * perProbe),
                   bounce.offsets.empty() ? 0u : uint32_t(offsetsAt), 0u)};
    std::memcpy(packed.data(), &header, sizeof(header));
    for (size_t p = 0; p < probes; ++p)
        for (size_t i = 0; i < perProbe; ++i)
            packed[kHeader + p * perProbe + i] =
                glm::vec4(glm::vec3(bounce.irradiance[p * perProbe + i]), bounce.valid[p] ? 1.0f : 0.0f);
    std::memcpy(&packed[kHeader + probes * perProbe], bounce.visibility.data(), texels * sizeof(glm::vec2));
    for (size_t p = 0; p < bounce.offsets.size(); ++p)
        packed[kHeader + offsetsAt + p] = glm::vec4(bounce.offsets[p], 0.0f);
    return packed;
}

// The orthographic view of the world's box from a sun: map coordinates from the two axes across
// the sun's direction (square texels over the larger extent), depth along it, larger nearer the
// sun, the box's ends 1% inside (0, 1) so that no surface ties with the cleared depth 0.
glsl::CaptureSun sunView(const SceneSun& sun, const World& world, uint32_t mapSize) {
    const glm::vec3 l = sun.direction / glm::length(sun.direction); // the bits SceneShading gives it
    const glm::vec3 helper = std::abs(l.y) < 0.9f ? glm::vec3(0.0f, 1.0f, 0.0f) : glm::vec3(1.0f, 0.0f, 0.0f);
    const glm::vec3 u = glm::normalize(glm::cross(helper, l));
    const glm::vec3 v = glm::cross(l, u);
    const std::array<glm::vec3, 3> axes{u, v, l};
    glm::vec3 low(INFINITY), high(-INFINITY);
    for (int corner = 0; corner < 8; ++corner) {
        const glm::vec3 p((corner & 1) ? world.boundsMax.x : world.boundsMin.x,
                          (corner & 2) ? world.boundsMax.y : world.boundsMin.y,
                          (corner & 4) ? world.boundsMax.z : world.boundsMin.z);
        for (int a = 0; a < 3; ++a) {
            low[a] = std::min(low[a], glm::dot(axes[a], p));
            high[a] = std::max(high[a], glm::dot(axes[a], p));
        }
    }
    // A floor for a flat box, relative to the scene (checkSceneScale keeps it above kMinSceneSize).
    const float worldSize = std::max(glm::length(world.boundsMax - world.boundsMin), float(kMinSceneSize));
    const float extent = std::max({high.x - low.x, high.y - low.y, 1e-6f * worldSize}) * 1.01f;
    const float depthRange = std::max(high.z - low.z, 1e-6f * worldSize) * 1.02f;
    const glm::vec3 centre = 0.5f * (low + high);
    const std::array<float, 3> scale{1.0f / extent, 1.0f / extent, 1.0f / depthRange};
    const std::array<float, 3> origin{0.5f, 0.5f, 0.5f};
    glm::mat4 m(0.0f); // world -> (map x, map y, depth) in [0, 1], m[column][row]
    for (int r = 0; r < 3; ++r) {
        for (int column = 0; column < 3; ++column)
            m[column][r] = axes[r][column] * scale[r];
        m[3][r] = origin[r] - centre[r] * scale[r];
    }
    m[3][3] = 1.0f;
    return {m, glm::vec4(l, 0.0f), glm::vec4(sun.irradiance, 0.0f),
            glm::vec4(extent / float(mapSize), 1.0f / depthRange, 0.0f, 0.0f),
            glm::uvec4(0u, mapSize, 0u, 0u)};
}

std::vector<glsl::CaptureSun> packSuns(const World& world, uint32_t mapSize) {
    std::vector<glsl::CaptureSun> suns;
    for (const SceneSun& sun : world.suns) {
        suns.push_back(sunView(sun, world, mapSize));
        suns.back().map.x = uint32_t(suns.size() - 1) * mapSize * mapSize;
    }
    return suns;
}

// The shadow maps' clip space: the map coordinates from [0, 1] to [-1, 1] (row 0 at y = -1, as
// framebuffer rows are), depth as it is.
glm::mat4 shadowClip(const glsl::CaptureSun& sun) {
    glm::mat4 toClip(1.0f);
    toClip[0][0] = toClip[1][1] = 2.0f;
    toClip[3][0] = toClip[3][1] = -1.0f;
    return toClip * sun.worldToShadow;
}

// One colour attachment (the capture layer, left in GENERAL for the bake's storage reads; not
// cleared, as the sky covers every texel) and depth, cleared.
VkRenderPass createCaptureRenderPass(const Device& device, VkFormat depthFormat) {
    const std::array<VkAttachmentDescription, 2> attachments{
        attachmentDescription(kCaptureFormat, VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_STORE,
                              VK_IMAGE_LAYOUT_GENERAL),
        attachmentDescription(depthFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_DONT_CARE,
                              VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)};
    const VkAttachmentReference color{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference depth{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    // The previous batch's bake and count read the layers before they are drawn again; the layer
    // reaches the bake (compute), copies and a view's tonemap pass (fragment).
    const std::array<VkSubpassDependency, 2> dependencies =
        attachmentDependencies(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                               VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT |
                                   VK_PIPELINE_STAGE_TRANSFER_BIT);
    return createRenderPass(device, {attachments, {&color, 1}, &depth, dependencies});
}

uint32_t sunCount(const SceneCapture& capture) {
    return uint32_t(capture.suns.size());
}

// The sky over the whole face first (no depth), then the surfaces, nearest first: reversed depth
// (near plane at 1, infinitely far at 0) keeps float depth precise from the near plane out.
VkPipeline createCapturePipeline(const Device& device, const SceneCapture& capture, bool surfaces) {
    const uint32_t order = uint32_t(capture.options.order);
    const VkSpecializationInfo specialization = orderSpecialization(order);
    GraphicsPipelineDesc desc;
    desc.vertex = surfaces ? capture.surfaceVertex : capture.skyVertex;
    desc.fragment = surfaces ? capture.surfaceFragment : capture.skyFragment;
    desc.fragmentSpecialization = &specialization;
    desc.depthTest = true; // the subpass has depth; the sky neither tests nor writes it
    desc.depthWrite = surfaces;
    desc.depthCompare = surfaces ? VK_COMPARE_OP_GREATER : VK_COMPARE_OP_ALWAYS;
    desc.layout = capture.layout;
    desc.renderPass = capture.renderPass;
    return createGraphicsPipeline(device, desc);
}

void createCaptureBuffers(const Context& context, SceneCapture& capture, const World& world,
                          const Cubemap& sky) {
    const PackedTextures textures = packTextures(world);
    capture.buffers.resize(SHPROBE_CAPTURE_BINDINGS);
    capture.buffers[SHPROBE_CAPTURE_VERTICES] = createStorage(context, packVertices(world), "scene vertices");
    capture.buffers[SHPROBE_CAPTURE_INDICES] = createStorage(context, world.indices, "scene indices");
    capture.buffers[SHPROBE_CAPTURE_TRIANGLES] =
        createStorage(context, world.triangleMaterials, "scene triangle materials");
    capture.buffers[SHPROBE_CAPTURE_MATERIALS] =
        createStorage(context, packMaterials(world), "scene materials");
    capture.buffers[SHPROBE_CAPTURE_TEXTURES] = createStorage(context, textures.extents, "scene textures");
    capture.buffers[SHPROBE_CAPTURE_TEXELS] = createStorage(context, textures.texels, "scene texels");
    capture.buffers[SHPROBE_CAPTURE_SKY] = createStorage(context, sky.texels, "sky texels");
    capture.buffers[SHPROBE_CAPTURE_VOLUME] = createStorage(context, packBounce({}), "previous bounce");
    capture.suns = packSuns(world, uint32_t(capture.options.shadowMapSize));
    const std::vector<glsl::CaptureSun>& suns = capture.suns;
    capture.buffers[SHPROBE_CAPTURE_SUNS] = createStorage(context, suns, "suns");
    const VkDeviceSize shadowBytes = VkDeviceSize(suns.size()) * capture.options.shadowMapSize *
                                     capture.options.shadowMapSize * sizeof(float);
    checkStorageRange(context, shadowBytes, "shadow maps");
    capture.buffers[SHPROBE_CAPTURE_SHADOWS] = createBuffer(context, std::max<VkDeviceSize>(shadowBytes, 16),
                                                            kStorageUpload, MemoryUse::Device, "shadow maps");
}

void writeCaptureDescriptors(const Device& device, const SceneCapture& capture) {
    std::array<VkDescriptorType, SHPROBE_CAPTURE_BINDINGS> types;
    std::array<BindingTarget, SHPROBE_CAPTURE_BINDINGS> targets;
    for (size_t b = 0; b < types.size(); ++b) {
        types[b] = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        targets[b] = {.buffer = capture.buffers[b].buffer};
    }
    writeDescriptors(device, capture.set, types, targets);
}

// World -> clip for one face: clip (x, y, w) are the face-local (a, b) and the depth along the
// face's axis of the direction from the probe (texel_geometry.h's face table, inverted).
glm::mat4 faceProjection(uint32_t face, const glm::dvec3& probe, float nearPlane) {
    const glm::vec3 a = glsl::orientToFace(face, glm::vec3(1.0f, 0.0f, 0.0f));
    const glm::vec3 b = glsl::orientToFace(face, glm::vec3(0.0f, 1.0f, 0.0f));
    const glm::vec3 axis = glsl::orientToFace(face, glm::vec3(0.0f, 0.0f, 1.0f));
    return clipFromRows({a, b, axis}, probe, nearPlane);
}

GpuImage createDepthImage(const Device& device, const SceneCapture& capture) {
    GpuImageDesc desc;
    desc.format = capture.depthFormat;
    desc.extent = {uint32_t(capture.options.faceSize), uint32_t(capture.options.faceSize)};
    desc.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
    desc.what = "capture depth";
    return createImage(device, desc);
}

// count_back_faces.comp with its set, reading the target's image and writing `counts`.
struct BackFaceCount {
    ComputeProgram program;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
};

BackFaceCount createBackFaceCount(const Device& device, const CaptureTarget& target,
                                  const BindingTarget& counts) {
    BackFaceCount count;
    OnFailure undo([&] {
        if (count.pool) vkDestroyDescriptorPool(device.device, count.pool, nullptr);
        destroyComputeProgram(device, count.program);
    });
    const std::array<VkDescriptorType, 2> bindings{VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                                   VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    count.program = createComputeProgram(device, {.name = "count_back_faces",
                                                  .spirv = spirv::count_back_faces_comp,
                                                  .bindings = bindings,
                                                  .pushConstantSize = sizeof(uint32_t),
                                                  .localSize = kCountWidth});
    count.pool = createDescriptorPool(device, {.sets = 1, .storageBuffers = 1, .storageImages = 1});
    const std::array<BindingTarget, 2> targets{BindingTarget{.imageView = target.cubemaps.view}, counts};
    count.set = createDescriptorSet(device, count.pool, count.program, targets);
    return count;
}

void destroyBackFaceCount(const Device& device, BackFaceCount& count) {
    if (count.pool) vkDestroyDescriptorPool(device.device, count.pool, nullptr);
    destroyComputeProgram(device, count.program);
    count = BackFaceCount{};
}

// Depth only, kept for the copy into the shadow-map buffer.
VkRenderPass createShadowRenderPass(const Device& device) {
    const VkAttachmentDescription depth =
        attachmentDescription(kShadowFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_STORE,
                              VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    const VkAttachmentReference reference{0, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    const VkSubpassDependency toCopy{0,
                                     VK_SUBPASS_EXTERNAL,
                                     VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT,
                                     VK_PIPELINE_STAGE_TRANSFER_BIT,
                                     VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                                     VK_ACCESS_TRANSFER_READ_BIT,
                                     0};
    return createRenderPass(device, {{&depth, 1}, {}, &reference, {&toCopy, 1}});
}

// Each sun's depth map, drawn with the capture's vertex stage and copied into the shadow-map
// buffer, which the capture's fragments then read: one submission, its objects released after.
void drawShadowMaps(const Context& context, const SceneCapture& capture) {
    VkFormatProperties properties;
    vkGetPhysicalDeviceFormatProperties(context.physicalDevice, kShadowFormat, &properties);
    const VkFormatFeatureFlags needed =
        VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_FORMAT_FEATURE_TRANSFER_SRC_BIT;
    if ((properties.optimalTilingFeatures & needed) != needed)
        throw Error(ErrorKind::Device,
                    "scene capture: the device cannot draw shadow maps of VK_FORMAT_D32_SFLOAT");
    const uint32_t size = uint32_t(capture.options.shadowMapSize);
    VkRenderPass renderPass = createShadowRenderPass(context);
    ScopeExit releasePass([&] { vkDestroyRenderPass(context.device, renderPass, nullptr); });
    GraphicsPipelineDesc desc;
    desc.vertex = capture.surfaceVertex;
    desc.depthTest = true;
    desc.depthWrite = true;
    desc.depthCompare = VK_COMPARE_OP_GREATER;
    desc.colorAttachments = 0;
    desc.layout = capture.layout;
    desc.renderPass = renderPass;
    VkPipeline pipeline = createGraphicsPipeline(context, desc);
    ScopeExit releasePipeline([&] { vkDestroyPipeline(context.device, pipeline, nullptr); });
    GpuImage maps = createImage(
        context, {.format = kShadowFormat,
                  .extent = {size, size},
                  .usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                  .what = "shadow maps",
                  .layers = sunCount(capture)});
    std::vector<VkImageView> views;
    std::vector<VkFramebuffer> framebuffers;
    ScopeExit releaseMaps([&] {
        for (VkFramebuffer framebuffer : framebuffers)
            vkDestroyFramebuffer(context.device, framebuffer, nullptr);
        for (VkImageView view : views)
            vkDestroyImageView(context.device, view, nullptr);
        destroyImage(context, maps);
    });
    for (uint32_t s = 0; s < sunCount(capture); ++s) {
        views.push_back(createImageView(context, maps.image, VK_IMAGE_VIEW_TYPE_2D, kShadowFormat, 1, s));
        framebuffers.push_back(createFramebuffer(context, renderPass, {&views.back(), 1}, {size, size}));
    }
    submitAndWait(context, [&](VkCommandBuffer commands) {
        vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, capture.layout, 0, 1, &capture.set,
                                0, nullptr);
        const VkClearValue clear{.depthStencil = {0.0f, 0}};
        for (uint32_t s = 0; s < sunCount(capture); ++s) {
            const glsl::CaptureConstants constants{shadowClip(capture.suns[s]), glm::vec4(0.0f),
                                                   glm::uvec4(0u)};
            beginRenderPass(commands, renderPass, framebuffers[s], {size, size}, {&clear, 1});
            vkCmdPushConstants(commands, capture.layout,
                               VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                               sizeof(constants), &constants);
            vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
            if (capture.triangleCount > 0) vkCmdDraw(commands, 3 * capture.triangleCount, 1, 0, 0);
            vkCmdEndRenderPass(commands);
        }
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, sunCount(capture)};
        region.imageExtent = {size, size, 1};
        vkCmdCopyImageToBuffer(commands, maps.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                               capture.buffers[SHPROBE_CAPTURE_SHADOWS].buffer, 1, &region);
        VkMemoryBarrier toFragments{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
        toFragments.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        toFragments.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
        vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
                             0, 1, &toFragments, 0, nullptr, 0, nullptr);
    });
}

} // namespace

Buffer createStorage(const Context& context, const void* data, size_t bytes, const char* what) {
    checkStorageRange(context, bytes, what);
    const VkDeviceSize size = std::max<VkDeviceSize>(bytes, 16);
    Buffer buffer = createBuffer(context, size, kStorageUpload, MemoryUse::Device, what);
    OnFailure undo([&] { destroyBuffer(context, buffer); });
    if (bytes > 0) uploadBuffer(context, buffer, data, bytes);
    return buffer;
}

// The target's layers into GENERAL, what they held dropped, before the capture writes them: as
// attachments (recordSceneCapture) or storage (the capture by rays).
void layersToGeneral(VkCommandBuffer commands, const CaptureTarget& target) {
    changeLayout(commands, target.cubemaps,
                 {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0,
                  VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                  VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT});
}

uint32_t capturesPerBatch(const Device& device, const SceneCapture& capture, uint32_t probesPerBatch) {
    const uint64_t probeBytes =
        6 * uint64_t(capture.options.faceSize) * uint64_t(capture.options.faceSize) * 16;
    const uint64_t byMemory = std::max<uint64_t>(1, (uint64_t(256) << 20) / probeBytes);
    const uint64_t byLayers = std::max<uint64_t>(1, device.info.limits.maxImageArrayLayers / 6);
    return uint32_t(std::max<uint64_t>(1, std::min({uint64_t(probesPerBatch), byMemory, byLayers})));
}

namespace {
constexpr VkSpecializationMapEntry kOrderEntry{SHPROBE_SPEC_ORDER, 0, sizeof(uint32_t)};
} // namespace

VkSpecializationInfo orderSpecialization(const uint32_t& order) {
    return {1, &kOrderEntry, sizeof(order), &order};
}

// World -> clip with clip x, y and w the dot products of (position - origin) with the three rows
// and z = near: depth = near / w, reversed (1 at the near plane, 0 infinitely far).
glm::mat4 clipFromRows(const std::array<glm::vec3, 3>& rows, const glm::dvec3& origin, float nearPlane) {
    const std::array<int, 3> rowOf{0, 1, 3};
    const glm::vec3 o(origin);
    glm::mat4 m(0.0f); // column-major: m[column][row]
    for (int r = 0; r < 3; ++r) {
        for (int column = 0; column < 3; ++column)
            m[column][rowOf[r]] = rows[r][column];
        m[3][rowOf[r]] = -glm::dot(rows[r], o);
    }
    m[3][2] = nearPlane;
    return m;
}

// The sky, then the surfaces, into the render pass begun, with the push constants set.
void recordSkyAndSurfaces(VkCommandBuffer commands, const SceneCapture& capture) {
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, capture.sky);
    vkCmdDraw(commands, 3, 1, 0, 0);
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, capture.surfaces);
    if (capture.triangleCount > 0) vkCmdDraw(commands, 3 * capture.triangleCount, 1, 0, 0);
}

SceneCapture createSceneCapture(const Context& context, const World& world, const Cubemap& sky,
                                const SceneCaptureOptions& options) {
    if (options.faceSize < 1 || options.faceSize > kMaxGpuFaceSize)
        throw Error(ErrorKind::Input, "scene capture: face size " + std::to_string(options.faceSize) +
                                          " is outside 1.." + std::to_string(kMaxGpuFaceSize));
    if (options.order < 1 || options.order > SHPROBE_MAX_ORDER)
        throw Error(ErrorKind::Input, "scene capture: order " + std::to_string(options.order) +
                                          " is outside 1.." + std::to_string(SHPROBE_MAX_ORDER));
    if (sky.faceSize < 1) throw Error(ErrorKind::Input, "scene capture: the sky has no texels");
    if (options.shadowMapSize < 1 || options.shadowMapSize > 16384)
        throw Error(ErrorKind::Input, "scene capture: shadow map size " +
                                          std::to_string(options.shadowMapSize) + " is outside 1..16384");
    checkWorld(world);
    checkSceneScale(world);

    SceneCapture capture;
    OnFailure undo([&] { destroySceneCapture(context, capture); });
    capture.options = options;
    capture.triangleCount = uint32_t(world.triangleCount());
    capture.skyFaceSize = uint32_t(sky.faceSize);
    // A millionth of the world's size, whatever its scale (an absolute floor would cut away a small
    // scene whole): closer than any probe sits to a wall it should see. Reversed float depth holds
    // near / w at any scale checkSceneScale accepts.
    const float size = glm::length(world.boundsMax - world.boundsMin);
    capture.nearPlane = std::max(size, float(kMinSceneSize)) * 1e-6f;
    // 32-bit float depth: with the near plane at a millionth of the world, 16-bit depth would round
    // everything past a tenth of it to the cleared far value and lose it.
    VkFormatProperties depthProperties;
    vkGetPhysicalDeviceFormatProperties(context.physicalDevice, kShadowFormat, &depthProperties);
    if (!(depthProperties.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT))
        throw Error(ErrorKind::Device,
                    "scene capture: the device has no VK_FORMAT_D32_SFLOAT depth attachments");
    capture.depthFormat = kShadowFormat;
    capture.renderPass = createCaptureRenderPass(context, capture.depthFormat);
    std::array<LayoutBinding, SHPROBE_CAPTURE_BINDINGS> bindings;
    bindings.fill(
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT});
    capture.setLayout = createSetLayout(context, bindings);
    capture.layout = createPipelineLayout(context, capture.setLayout,
                                          VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                                          sizeof(glsl::CaptureConstants));
    capture.surfaceVertex = createShaderModule(context, spirv::capture_vert);
    capture.surfaceFragment = createShaderModule(context, spirv::capture_frag);
    capture.skyVertex = createShaderModule(context, spirv::fullscreen_vert);
    capture.skyFragment = createShaderModule(context, spirv::capture_sky_frag);
    capture.surfaces = createCapturePipeline(context, capture, true);
    capture.sky = createCapturePipeline(context, capture, false);
    createCaptureBuffers(context, capture, world, sky);
    capture.pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = SHPROBE_CAPTURE_BINDINGS});
    capture.set = allocateDescriptorSet(context, capture.pool, capture.setLayout);
    writeCaptureDescriptors(context, capture);
    if (!capture.suns.empty()) drawShadowMaps(context, capture);
    return capture;
}

void destroySceneCapture(const Device& device, SceneCapture& capture) {
    if (capture.pool) vkDestroyDescriptorPool(device.device, capture.pool, nullptr);
    for (Buffer& buffer : capture.buffers)
        destroyBuffer(device, buffer);
    for (VkPipeline pipeline : {capture.surfaces, capture.sky})
        if (pipeline) vkDestroyPipeline(device.device, pipeline, nullptr);
    for (VkShaderModule module :
         {capture.surfaceVertex, capture.surfaceFragment, capture.skyVertex, capture.skyFragment})
        if (module) vkDestroyShaderModule(device.device, module, nullptr);
    if (capture.layout) vkDestroyPipelineLayout(device.device, capture.layout, nullptr);
    if (capture.setLayout) vkDestroyDescriptorSetLayout(device.device, capture.setLayout, nullptr);
    if (capture.renderPass) vkDestroyRenderPass(device.device, capture.renderPass, nullptr);
    capture = SceneCapture{};
}

void setBounceSource(const Context& context, SceneCapture& capture, const BounceSource& bounce) {
    if (bounce.counts != glm::ivec3(0) && bounce.order != capture.options.order)
        throw Error(ErrorKind::Input, "scene capture: the previous bounce is of order " +
                                          std::to_string(bounce.order) + ", the capture of order " +
                                          std::to_string(capture.options.order));
    Buffer next = createStorage(context, packBounce(bounce), "previous bounce");
    destroyBuffer(context, capture.buffers[SHPROBE_CAPTURE_VOLUME]);
    capture.buffers[SHPROBE_CAPTURE_VOLUME] = next;
    writeDescriptor(context, capture.set, SHPROBE_CAPTURE_VOLUME, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                    {.buffer = next.buffer});
    capture.bounceGrid = {bounce.boundsMin, bounce.boundsMax, bounce.counts};
}

CaptureTarget createCaptureTarget(const Device& device, const SceneCapture& capture, uint32_t probeCount) {
    CaptureTarget target;
    OnFailure undo([&] { destroyCaptureTarget(device, target); });
    target.probeCount = probeCount;
    const VkExtent2D extent{uint32_t(capture.options.faceSize), uint32_t(capture.options.faceSize)};
    GpuImageDesc desc;
    desc.format = kCaptureFormat;
    desc.extent = extent;
    desc.usage =
        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    desc.layers = 6 * probeCount;
    desc.what = "probe captures";
    target.cubemaps = createImage(device, desc);
    target.depth = createDepthImage(device, capture);
    for (uint32_t layer = 0; layer < desc.layers; ++layer) {
        target.layerViews.push_back(
            createImageView(device, target.cubemaps.image, VK_IMAGE_VIEW_TYPE_2D, kCaptureFormat, 1, layer));
        const std::array<VkImageView, 2> views{target.layerViews.back(), target.depth.view};
        target.framebuffers.push_back(createFramebuffer(device, capture.renderPass, views, extent));
    }
    return target;
}

void destroyCaptureTarget(const Device& device, CaptureTarget& target) {
    for (VkFramebuffer framebuffer : target.framebuffers)
        vkDestroyFramebuffer(device.device, framebuffer, nullptr);
    for (VkImageView view : target.layerViews)
        vkDestroyImageView(device.device, view, nullptr);
    destroyImage(device, target.depth);
    destroyImage(device, target.cubemaps);
    target = CaptureTarget{};
}

void recordSceneCapture(VkCommandBuffer commands, const SceneCapture& capture, const CaptureTarget& target,
                        std::span<const glm::dvec3> positions) {
    if (positions.size() > target.probeCount)
        throw Error(ErrorKind::Input, "scene capture: " + std::to_string(positions.size()) +
                                          " probes for a target of " + std::to_string(target.probeCount));
    const uint32_t n = uint32_t(capture.options.faceSize);
    const VkClearValue clears[2] = {{}, {.depthStencil = {0.0f, 0}}}; // depth 0: infinitely far
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, capture.layout, 0, 1, &capture.set, 0,
                            nullptr);
    for (size_t p = 0; p < positions.size(); ++p)
        for (uint32_t face = 0; face < 6; ++face) {
            const glsl::CaptureConstants constants{
                faceProjection(face, positions[p], capture.nearPlane),
                glm::vec4(glm::vec3(positions[p]), 1.0f),
                glm::uvec4(face, n, capture.skyFaceSize, sunCount(capture)),
                glm::vec4(0.0f, 0.0f, 1.0f, 0.0f)};
            beginRenderPass(commands, capture.renderPass, target.framebuffers[6 * p + face], {n, n}, clears);
            vkCmdPushConstants(commands, capture.layout,
                               VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                               sizeof(constants), &constants);
            recordSkyAndSurfaces(commands, capture);
            vkCmdEndRenderPass(commands);
        }
}

std::vector<SceneProbe> bakeCapturedProbes(const Context& context, const SceneCapture& capture,
                                           const CaptureTarget& target, std::span<const glm::dvec3> positions,
                                           const SceneBakeOptions& options, const RecordCapture& record,
                                           const FinishBatch& finish) {
    const uint32_t batch = target.probeCount;
    ProbeBaker baker =
        createProbeBaker(context, {.order = options.order, .cubemaps = CubemapBinding::StorageRgba32F});
    ScopeExit releaseBaker([&] { destroyProbeBaker(context, baker); });
    const VkDeviceSize coefficientBytes = alignUp(probeBakeOutputBytes(options.order, batch),
                                                  context.info.limits.minStorageBufferOffsetAlignment);
    Buffer output = createBuffer(context, coefficientBytes + batch * sizeof(uint32_t),
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback, "scene probes");
    ScopeExit releaseOutput([&] { destroyBuffer(context, output); });
    ProbeBakeSet set = createProbeBakeSet(
        context, baker, {target.cubemaps.view, uint32_t(capture.options.faceSize), batch, output.buffer, 0});
    ScopeExit releaseSet([&] { destroyProbeBakeSet(context, set); });
    BackFaceCount count =
        createBackFaceCount(context, target, {.buffer = output.buffer, .offset = coefficientBytes});
    ScopeExit releaseCount([&] { destroyBackFaceCount(context, count); });

    std::vector<SceneProbe> probes;
    for (size_t first = 0; first < positions.size(); first += batch) {
        const std::span<const glm::dvec3> members =
            positions.subspan(first, std::min<size_t>(batch, positions.size() - first));
        submitAndWait(context, [&](VkCommandBuffer commands) {
            // The layers no capture of a partial batch draws are baked too (see capturesPerBatch):
            // in GENERAL from the start, whatever they hold.
            if (first == 0) layersToGeneral(commands, target);
            record(commands, members);
            recordProbeBake(commands, baker, set);
            const uint32_t faceSize = uint32_t(capture.options.faceSize);
            dispatch(commands, count.program, count.set, faceSize, {uint32_t(members.size()), 1});
            computeWriteBarrier(commands);
        });
        invalidateBuffer(context, output);
        const auto* counts =
            reinterpret_cast<const uint32_t*>(static_cast<const char*>(output.mapped) + coefficientBytes);
        for (size_t k = 0; k < members.size(); ++k) {
            GpuBake bake = readBakeOutput(output, 0, options.order, batch, uint32_t(k));
            probes.push_back(
                {std::move(bake.radiance), std::move(bake.irradiance), counts[k], {}, glm::vec3(0.0f)});
        }
        if (finish) finish(first, std::span(probes).subspan(first));
    }
    return probes;
}

std::vector<SceneProbe> bakeSceneProbes(const Context& context, const SceneCapture& capture,
                                        std::span<const glm::dvec3> positions,
                                        const SceneBakeOptions& options) {
    CaptureTarget target =
        createCaptureTarget(context, capture, capturesPerBatch(context, capture, options.probesPerBatch));
    ScopeExit releaseTarget([&] { destroyCaptureTarget(context, target); });
    return bakeCapturedProbes(context, capture, target, positions, options,
                              [&](VkCommandBuffer commands, std::span<const glm::dvec3> members) {
                                  recordSceneCapture(commands, capture, target, members);
                              });
}

Cubemap readCapturedCubemap(const Context& context, const CaptureTarget& target, const glm::dvec3& position,
                            const RecordCapture& record) {
    Cubemap cubemap = makeCubemap(int(target.cubemaps.extent.width));
    const VkDeviceSize bytes = cubemap.texels.size() * sizeof(glm::vec4);
    Buffer readback = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Readback,
                                   "captured cube map");
    ScopeExit releaseReadback([&] { destroyBuffer(context, readback); });
    submitAndWait(context, [&](VkCommandBuffer commands) {
        layersToGeneral(commands, target);
        record(commands, {&position, 1}); // visible to transfers
        // GENERAL would do, but the validation layer reports a copy from it (a performance warning).
        changeLayout(commands, target.cubemaps,
                     {VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                      VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                      VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_TRANSFER_READ_BIT});
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 6};
        region.imageExtent = {target.cubemaps.extent.width, target.cubemaps.extent.height, 1};
        vkCmdCopyImageToBuffer(commands, target.cubemaps.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                               readback.buffer, 1, &region);
        computeWriteBarrier(commands);
    });
    invalidateBuffer(context, readback);
    std::memcpy(cubemap.texels.data(), readback.mapped, bytes);
    return cubemap;
}

Cubemap captureProbeCubemap(const Context& context, const SceneCapture& capture, const glm::dvec3& position) {
    CaptureTarget target = createCaptureTarget(context, capture, 1);
    ScopeExit releaseTarget([&] { destroyCaptureTarget(context, target); });
    return readCapturedCubemap(context, target, position,
                               [&](VkCommandBuffer commands, std::span<const glm::dvec3> members) {
                                   recordSceneCapture(commands, capture, target, members);
                               });
}

} // namespace shprobe
