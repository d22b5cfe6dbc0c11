#include "gpu/transfer_rays.h"

#include "common/error.h"
#include "common/scope_exit.h"
#include "sh/basis.h"
#include "vk/pipeline.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_scene_spirv.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <optional>

namespace shprobe {

namespace {

// What the passes read, uploaded once: the hierarchy, the sides, the triangles with their
// materials, texture coordinates and textures; and U_k, which pass k writes into transfer[k % 2]
// while a bounce reads U_{k-1} from the other, copied into `readback` after each pass. `carried`
// holds what rounding took from the sums of the pass in flight (glsl/transfer_pass.glsl).
struct TransferBuffers {
    Buffer nodes, bvhTriangles, triangleIds, sides, triangles, materials, uvs, textures, texels, backSides;
    std::array<Buffer, 2> transfer;
    Buffer carried, readback;
};

// The two modules and their sets: `direct` writes transfer[0]; bounceSets[p] writes transfer[p]
// and reads transfer[1 - p].
struct TransferPrograms {
    ComputeProgram direct, bounce;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet directSet = VK_NULL_HANDLE;
    std::array<VkDescriptorSet, 2> bounceSets{};
};

std::vector<Buffer*> allBuffers(TransferBuffers& b) {
    return {&b.nodes,       &b.bvhTriangles, &b.triangleIds, &b.sides,   &b.triangles,
            &b.materials,   &b.uvs,          &b.textures,    &b.texels,  &b.backSides,
            &b.transfer[0], &b.transfer[1],  &b.carried,     &b.readback};
}

// Throws Error(Device) where `bytes` exceed what one storage-buffer binding of the device holds.
void requireBindable(const Device& device, VkDeviceSize bytes, const char* what) {
    const VkDeviceSize limit = device.info.limits.maxStorageBufferRange;
    if (bytes <= limit) return;
    throw Error(ErrorKind::Device, "transfer: the " + std::string(what) + " take " +
                                       std::to_string(bytes >> 20) +
                                       " MiB, more than one buffer binding holds on " + device.info.name +
                                       " (" + std::to_string(limit >> 20) + " MiB); use --backend cpu");
}

// A device-local storage buffer holding `data` (16 bytes where it is empty: a binding needs a buffer).
template <typename T>
Buffer uploadStorage(const Context& context, const std::vector<T>& data, const char* what) {
    const VkDeviceSize bytes = sizeof(T) * data.size();
    requireBindable(context, bytes, what);
    Buffer buffer = createBuffer(context, std::max<VkDeviceSize>(bytes, 16),
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                 MemoryUse::Device, what);
    if (bytes > 0) uploadBuffer(context, buffer, data.data(), bytes);
    return buffer;
}

std::vector<glsl::TransferTriangle> packTriangles(const World& world) {
    std::vector<glsl::TransferTriangle> triangles(world.triangleCount());
    for (size_t t = 0; t < triangles.size(); ++t)
        triangles[t].corners = {world.indices[3 * t], world.indices[3 * t + 1], world.indices[3 * t + 2],
                                world.triangleMaterials[t]};
    return triangles;
}

std::vector<glsl::TransferMaterial> packMaterials(const World& world) {
    std::vector<glsl::TransferMaterial> materials;
    for (const SceneMaterial& material : world.materials)
        materials.push_back({glm::vec4(material.albedo, 0.0f),
                             glm::ivec4(material.albedoTexture, material.doubleSided ? 1 : 0, 0, 0)});
    return materials;
}

// Every texture's texels one after the other, and where each starts.
void packTextures(const World& world, std::vector<glsl::TransferTexture>& textures,
                  std::vector<glm::vec4>& texels) {
    for (const SceneTexture& texture : world.textures) {
        textures.push_back({glm::uvec4(uint32_t(texels.size()), texture.width, texture.height, 0)});
        texels.insert(texels.end(), texture.texels.begin(), texture.texels.end());
    }
}

void uploadScene(const Context& context, const TransferScene& scene, int order, TransferBuffers& buffers) {
    const World& world = scene.world;
    buffers.nodes = uploadStorage(context, scene.bvh.nodes, "hierarchy's nodes");
    buffers.bvhTriangles = uploadStorage(context, scene.bvh.triangles, "hierarchy's triangles");
    buffers.triangleIds = uploadStorage(context, scene.bvh.triangleIds, "hierarchy's triangle ids");
    buffers.sides = uploadStorage(context, scene.sides, "vertex sides");
    buffers.triangles = uploadStorage(context, packTriangles(world), "triangles");
    buffers.materials = uploadStorage(context, packMaterials(world), "materials");
    buffers.uvs = uploadStorage(context, world.uvs, "texture coordinates");
    std::vector<glsl::TransferTexture> textures;
    std::vector<glm::vec4> texels;
    packTextures(world, textures, texels);
    buffers.textures = uploadStorage(context, textures, "textures");
    buffers.texels = uploadStorage(context, texels, "texels");
    buffers.backSides = uploadStorage(context, scene.backSides, "back sides");
    const VkDeviceSize bytes = scene.sides.size() * size_t(coefficientCount(order)) * sizeof(glm::vec4);
    requireBindable(context, bytes, "transfer vectors");
    for (Buffer& transfer : buffers.transfer)
        transfer = createBuffer(context, bytes,
                                VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                MemoryUse::Device, "transfer vectors");
    buffers.carried = createBuffer(context, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Device,
                                   "transfer rounding carried");
    buffers.readback = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Readback,
                                    "transfer vectors read back");
}

void destroyTransferPrograms(const Device& device, TransferPrograms& programs) {
    if (programs.pool != VK_NULL_HANDLE) vkDestroyDescriptorPool(device.device, programs.pool, nullptr);
    programs.pool = VK_NULL_HANDLE;
    destroyComputeProgram(device, programs.bounce);
    destroyComputeProgram(device, programs.direct);
}

void createTransferPrograms(const Context& context, const TransferBuffers& b, int order,
                            TransferPrograms& programs) {
    static constexpr std::array<VkDescriptorType, 13> kBindings = [] {
        std::array<VkDescriptorType, 13> bindings{};
        bindings.fill(VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
        return bindings;
    }();
    const auto program = [&](const char* name, std::span<const uint32_t> spirv, size_t bindings) {
        return createComputeProgram(context, {.name = name,
                                              .spirv = spirv,
                                              .bindings = std::span(kBindings).first(bindings),
                                              .pushConstantSize = sizeof(glsl::TransferParams),
                                              .order = uint32_t(order)});
    };
    programs.direct = program("transfer_direct.comp", spirv::transfer_direct_comp, 6);
    programs.bounce = program("transfer_bounce.comp", spirv::transfer_bounce_comp, kBindings.size());
    programs.pool =
        createDescriptorPool(context, {.sets = 3, .storageBuffers = uint32_t(6 + 2 * kBindings.size())});
    const BindingTarget direct[] = {{b.nodes.buffer}, {b.bvhTriangles.buffer}, {b.triangleIds.buffer},
                                    {b.sides.buffer}, {b.transfer[0].buffer},  {b.carried.buffer}};
    programs.directSet = createDescriptorSet(context, programs.pool, programs.direct, direct);
    for (int p = 0; p < 2; ++p) {
        const BindingTarget bounce[] = {
            {b.nodes.buffer},       {b.bvhTriangles.buffer}, {b.triangleIds.buffer},     {b.sides.buffer},
            {b.transfer[p].buffer}, {b.carried.buffer},      {b.transfer[1 - p].buffer}, {b.triangles.buffer},
            {b.materials.buffer},   {b.uvs.buffer},          {b.textures.buffer},        {b.texels.buffer},
            {b.backSides.buffer}};
        programs.bounceSets[p] = createDescriptorSet(context, programs.pool, programs.bounce, bounce);
    }
}

// The device's state across the passes, made at the first.
struct GpuTransfer {
    const Context& context;
    int order = 3;
    TransferBuffers buffers;
    TransferPrograms programs;
    bool ready = false;
};

void destroyGpuTransfer(GpuTransfer& gpu) {
    destroyTransferPrograms(gpu.context, gpu.programs);
    for (Buffer* buffer : allBuffers(gpu.buffers))
        destroyBuffer(gpu.context, *buffer);
}

// Workaround(llvmpipe, Mesa 22.3): llvmpipe ends an invocation's loops after 65535 iterations in
// all (glsl/dispatch_plan.h), and a side's rays are a loop around the hierarchy's traversal, whose
// steps per ray the scene decides, so many rays left groups of sides short (docs/transfer.md). A
// side's rays are cast in passes of this many, each carrying on the sums the one before left, which
// leaves a ray over 3,000 traversal steps at order 8 (a bounce gathers 3 x 64 sums per hit). Other
// devices spend a dispatch per pass.
constexpr uint32_t kTransferRaysPerPass = 16;

// Sides per submission: kTransferRaysPerSubmission rays, within one dispatch's workgroup count.
uint32_t sidesPerChunk(const Device& device, const ComputeProgram& program, int strata) {
    const uint64_t byRays = std::max<uint64_t>(1, kTransferRaysPerSubmission / (uint64_t(strata) * strata));
    const uint64_t byGroups = uint64_t(device.info.limits.maxComputeWorkGroupCount[0]) * program.localSize;
    return uint32_t(std::min({byRays, byGroups, uint64_t(UINT32_MAX / 2)}));
}

// Pass k over every side, a chunk per submission, then U_k copied back into `current`.
uint64_t castPass(GpuTransfer& gpu, const TransferScene& scene, int k, std::span<glm::vec3> current) {
    const Context& context = gpu.context;
    if (!gpu.ready) {
        uploadScene(context, scene, gpu.order, gpu.buffers);
        createTransferPrograms(context, gpu.buffers, gpu.order, gpu.programs);
        gpu.ready = true;
    }
    const ComputeProgram& program = k == 0 ? gpu.programs.direct : gpu.programs.bounce;
    const VkDescriptorSet set = k == 0 ? gpu.programs.directSet : gpu.programs.bounceSets[k % 2];
    const uint32_t sides = uint32_t(scene.sides.size());
    const uint32_t chunk = sidesPerChunk(context, program, scene.strata);
    const uint32_t rays = uint32_t(scene.strata) * uint32_t(scene.strata);
    for (uint32_t first = 0; first < sides; first += chunk) {
        glsl::TransferParams params{.firstSide = first,
                                    .sideCount = std::min(chunk, sides - first),
                                    .nodeCount = uint32_t(scene.bvh.nodes.size()),
                                    .strata = uint32_t(scene.strata)};
        submitAndWait(context, [&](VkCommandBuffer commands) {
            for (params.firstRay = 0; params.firstRay < rays; params.firstRay += kTransferRaysPerPass) {
                params.rayCount = std::min(kTransferRaysPerPass, rays - params.firstRay);
                dispatch(commands, program, set, params,
                         {uint32_t(workgroupsFor(program, params.sideCount))});
                computeWriteBarrier(commands);
            }
        });
    }
    const Buffer& written = gpu.buffers.transfer[size_t(k % 2)];
    submitAndWait(context, [&](VkCommandBuffer commands) {
        const VkBufferCopy region{0, 0, written.size};
        vkCmdCopyBuffer(commands, written.buffer, gpu.buffers.readback.buffer, 1, &region);
        computeWriteBarrier(commands);
    });
    invalidateBuffer(context, gpu.buffers.readback);
    const auto* values = static_cast<const glm::vec4*>(gpu.buffers.readback.mapped);
    for (size_t i = 0; i < current.size(); ++i)
        current[i] = glm::vec3(values[i]);
    uint64_t used = 0;
    for (const glsl::TransferSide& side : scene.sides)
        used += (side.ids.w & SHPROBE_SIDE_UNUSED) == 0;
    return used * uint64_t(scene.strata) * uint64_t(scene.strata);
}

} // namespace

VertexTransfer computeTransferOnGpu(const Context& context, const World& world,
                                    const TransferOptions& options, const TransferProgress& progress) {
    GpuTransfer gpu{.context = context, .order = options.order};
    ScopeExit release([&] { destroyGpuTransfer(gpu); });
    return computeTransfer(
        world, options,
        [&](const TransferScene& scene, int k, std::span<const glm::vec3>, std::span<glm::vec3> current) {
            return castPass(gpu, scene, k, current);
        },
        progress);
}

} // namespace shprobe
