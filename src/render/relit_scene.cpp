#include "render/relit_scene.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "glsl/render_interface.h"
#include "gpu/host_bake.h"
#include "gpu/probe_baker.h"
#include "render/render_input.h"
#include "vk/graphics.h"
#include "vk/pipeline.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_render_spirv.h>

#include <algorithm>
#include <array>
#include <glm/geometric.hpp>
#include <string>
#include <vector>

namespace shprobe {

namespace {

constexpr VkFormat kColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

int shaderCapacity(int attributes) {
    return attributes <= SHPROBE_RELIGHT_ATTRIBUTES ? SHPROBE_RELIGHT_ATTRIBUTES
                                                    : SHPROBE_RELIGHT_WIDE_ATTRIBUTES;
}

void checkAttributes(const Device& device, const TransferMesh& mesh) {
    if (mesh.attributes <= maxTransferAttributes(device)) return;
    const uint32_t limit = device.info.limits.maxVertexInputAttributes;
    throw Error(ErrorKind::Input,
                "order " + std::to_string(mesh.order) + (mesh.channels == 3 ? " RGB" : " grey") +
                    " transfer needs " + std::to_string(mesh.attributes) +
                    " vertex attributes beside the position; " + device.info.name + " allows " +
                    std::to_string(std::min<uint32_t>(limit - 1, SHPROBE_RELIGHT_WIDE_ATTRIBUTES)) +
                    " (maxVertexInputAttributes " + std::to_string(limit) + ")");
}

Buffer createVertexData(const Context& context, const void* data, VkDeviceSize bytes,
                        VkBufferUsageFlags usage, const char* what) {
    Buffer buffer = createBuffer(context, std::max<VkDeviceSize>(bytes, 16),
                                 usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Device, what);
    if (bytes > 0) uploadBuffer(context, buffer, data, bytes);
    return buffer;
}

void createMeshBuffers(const Context& context, const TransferMesh& mesh, RelitScene& relit) {
    const World& world = mesh.world;
    relit.positions =
        createVertexData(context, world.positions.data(), world.positions.size() * sizeof(glm::vec3),
                         VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "relit positions");
    relit.transfer = createVertexData(context, mesh.transfer.data(), mesh.transfer.size() * sizeof(float),
                                      VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "relit transfer");
    const std::array<float, 4> zeros{};
    relit.zeros = createVertexData(context, zeros.data(), sizeof(zeros), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                   "relit zero attributes");
    relit.indices = createVertexData(context, world.indices.data(), world.indices.size() * sizeof(uint32_t),
                                     VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "relit indices");
    relit.indexCount = uint32_t(world.indices.size());
}

VkRenderPass createRelitRenderPass(const Device& device) {
    const std::array<VkAttachmentDescription, 2> attachments{
        attachmentDescription(kColorFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_STORE,
                              VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL),
        attachmentDescription(kDepthFormat, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_DONT_CARE,
                              VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)};
    const VkAttachmentReference color{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference depth{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    // The previous frame's tonemap (fragment) and copies read the colour before it is drawn again.
    const std::array<VkSubpassDependency, 2> dependencies =
        attachmentDependencies(VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                               VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT);
    return createRenderPass(device, {attachments, {&color, 1}, &depth, dependencies});
}

// Position at location 0 (binding 0), the file's attributes at 1.. (binding 1), the rest of the
// shader's capacity from the zero buffer (binding 2, stride 0).
VkPipeline createRelitPipeline(const Device& device, const RelitScene& relit) {
    const int capacity = shaderCapacity(relit.attributes);
    const std::array<VkVertexInputBindingDescription, 3> bindings{
        {{0, sizeof(glm::vec3), VK_VERTEX_INPUT_RATE_VERTEX},
         {1, uint32_t(relit.attributes) * 16u, VK_VERTEX_INPUT_RATE_VERTEX},
         {2, 0, VK_VERTEX_INPUT_RATE_VERTEX}}};
    std::vector<VkVertexInputAttributeDescription> attributes{{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0}};
    for (int k = 0; k < capacity; ++k)
        attributes.push_back({uint32_t(k + 1), k < relit.attributes ? 1u : 2u, VK_FORMAT_R32G32B32A32_SFLOAT,
                              k < relit.attributes ? uint32_t(k) * 16u : 0u});
    const std::array<uint32_t, 2> constants{uint32_t(relit.order), uint32_t(relit.channels)};
    const std::array<VkSpecializationMapEntry, 2> entries{
        {{SHPROBE_SPEC_RENDER_ORDER, 0, 4}, {SHPROBE_SPEC_TRANSFER_CHANNELS, 4, 4}}};
    const VkSpecializationInfo specialization{2, entries.data(), sizeof(constants), constants.data()};
    GraphicsPipelineDesc desc;
    desc.vertex = relit.vertex;
    desc.fragment = relit.fragment;
    desc.vertexSpecialization = &specialization;
    desc.vertexBindings = bindings;
    desc.vertexAttributes = attributes;
    desc.depthTest = true;
    desc.depthWrite = true;
    desc.depthCompare = VK_COMPARE_OP_GREATER; // reversed depth (cameraProjection)
    desc.layout = relit.layout;
    desc.renderPass = relit.renderPass;
    return createGraphicsPipeline(device, desc);
}

void createPipeline(const Context& context, RelitScene& relit) {
    const LayoutBinding light{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_SHADER_STAGE_VERTEX_BIT};
    relit.setLayout = createSetLayout(context, {&light, 1});
    relit.layout = createPipelineLayout(context, relit.setLayout, VK_SHADER_STAGE_VERTEX_BIT,
                                        sizeof(glsl::RelightConstants));
    relit.pool = createDescriptorPool(context, {.sets = 1, .storageBuffers = 1});
    relit.set = allocateDescriptorSet(context, relit.pool, relit.setLayout);
    writeDescriptor(context, relit.set, 0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                    {relit.light.rotated.buffer, 0, relit.light.rotated.size});
    relit.vertex = createShaderModule(context, shaderCapacity(relit.attributes) == SHPROBE_RELIGHT_ATTRIBUTES
                                                   ? spirv::relight_vert
                                                   : spirv::relight_wide_vert);
    relit.fragment = createShaderModule(context, spirv::relight_frag);
    relit.renderPass = createRelitRenderPass(context);
    relit.pipeline = createRelitPipeline(context, relit);
}

} // namespace

ShCoefficients relitLightCoefficients(const Context& context, const RelitLight& light, int order) {
    if (light.probe) return *light.probe;
    ProbeBaker baker =
        createProbeBaker(context, {.order = order, .cubemaps = uploadBinding(context, TexelFormat::Rgba32F)});
    ScopeExit releaseBaker([&] { destroyProbeBaker(context, baker); });
    double milliseconds = 0.0;
    return bakeRadiance(context, baker, light.sky, milliseconds);
}

int maxTransferAttributes(const Device& device) {
    const int beside = int(device.info.limits.maxVertexInputAttributes) - 1;
    if (beside >= SHPROBE_RELIGHT_WIDE_ATTRIBUTES) return SHPROBE_RELIGHT_WIDE_ATTRIBUTES;
    return beside >= SHPROBE_RELIGHT_ATTRIBUTES ? SHPROBE_RELIGHT_ATTRIBUTES : 0;
}

RelitScene createRelitScene(const Context& context, const TransferMesh& mesh, const ShCoefficients& light) {
    checkAttributes(context, mesh);
    if (light.order != mesh.order || light.quantity != Quantity::Radiance)
        throw Error(ErrorKind::Input, "relighting order-" + std::to_string(mesh.order) +
                                          " transfer needs radiance coefficients of that order");
    RelitScene relit;
    OnFailure undo([&] { destroyRelitScene(context, relit); });
    relit.order = mesh.order;
    relit.channels = mesh.channels;
    relit.attributes = mesh.attributes;
    const double size = glm::length(glm::dvec3(mesh.world.boundsMax - mesh.world.boundsMin));
    relit.nearPlane = float(std::max(size, 1e-10) * 1e-6);
    createMeshBuffers(context, mesh, relit);
    relit.rotator = createRotator(context, mesh.order);
    relit.light = createRotatedProbe(context, relit.rotator, light);
    createPipeline(context, relit);
    return relit;
}

void destroyRelitScene(const Device& device, RelitScene& relit) {
    if (relit.pipeline) vkDestroyPipeline(device.device, relit.pipeline, nullptr);
    if (relit.renderPass) vkDestroyRenderPass(device.device, relit.renderPass, nullptr);
    for (VkShaderModule module : {relit.vertex, relit.fragment})
        if (module) vkDestroyShaderModule(device.device, module, nullptr);
    if (relit.pool) vkDestroyDescriptorPool(device.device, relit.pool, nullptr);
    if (relit.layout) vkDestroyPipelineLayout(device.device, relit.layout, nullptr);
    if (relit.setLayout) vkDestroyDescriptorSetLayout(device.device, relit.setLayout, nullptr);
    destroyRotatedProbe(device, relit.light);
    if (relit.rotator.order > 0) destroyRotator(device, relit.rotator);
    for (Buffer* buffer : {&relit.indices, &relit.zeros, &relit.transfer, &relit.positions})
        destroyBuffer(device, *buffer);
    relit = RelitScene{};
}

void setLightRotation(const RelitScene& relit, const glm::dmat3& R) {
    setProbeRotation(relit.light, makeShRotation(R, relit.order));
}

RelitTarget createRelitTarget(const Context& context, const RelitScene& relit, VkExtent2D extent,
                              VkImageUsageFlags colorUsage) {
    return createColorDepthTarget(context, {.renderPass = relit.renderPass,
                                            .extent = extent,
                                            .colorFormat = kColorFormat,
                                            .depthFormat = kDepthFormat,
                                            .colorUsage = colorUsage,
                                            .what = "relit view",
                                            .depthWhat = "relit view depth"});
}

void recordRelitView(VkCommandBuffer commands, const RelitScene& relit, const RelitTarget& target,
                     const glm::mat4& clipFromWorld) {
    recordProbeRotation(commands, relit.rotator, relit.light, VK_PIPELINE_STAGE_VERTEX_SHADER_BIT);
    const VkClearValue clears[2] = {{}, {.depthStencil = {0.0f, 0}}};
    beginRenderPass(commands, relit.renderPass, target.framebuffer, target.extent, clears);
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, relit.pipeline);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_GRAPHICS, relit.layout, 0, 1, &relit.set, 0,
                            nullptr);
    const glsl::RelightConstants constants{clipFromWorld};
    vkCmdPushConstants(commands, relit.layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(constants), &constants);
    const std::array<VkBuffer, 3> buffers{relit.positions.buffer, relit.transfer.buffer, relit.zeros.buffer};
    const std::array<VkDeviceSize, 3> offsets{};
    vkCmdBindVertexBuffers(commands, 0, 3, buffers.data(), offsets.data());
    vkCmdBindIndexBuffer(commands, relit.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
    vkCmdDrawIndexed(commands, relit.indexCount, 1, 0, 0, 0);
    vkCmdEndRenderPass(commands);
}

} // namespace shprobe
