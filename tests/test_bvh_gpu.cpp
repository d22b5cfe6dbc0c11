// The GPU traversal of the scene hierarchy (glsl/bvh_traversal.glsl, compiled into the test module
// trace_rays.comp) against the CPU one (scene/bvh.h) on real scenes, hit for hit: the same
// arithmetic in the same order on the same arrays, so the same triangle and the same bits of t, u
// and v. Lavapipe in CI, with the validation layer on (gpu_test.h).
#include "gpu_test.h"

#include "scene/bvh.h"
#include "scene/gltf_scene.h"
#include "scene_fixtures.h"
#include "vk/pipeline.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_test_spirv.h>

#include <glm/geometric.hpp>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <unistd.h>
#include <vector>

namespace shprobe {
namespace {

using namespace shprobe::testing;

// The layouts of trace_rays.comp's buffers.
struct TraceRay {
    glm::vec4 origin;    // w: tMin
    glm::vec4 direction; // w: tMax
};
struct TraceResult {
    glm::uvec4 hit;   // World triangle (0xffffffff: none), t, u, v bits
    glm::uvec4 flags; // front face, any hit
};
static_assert(sizeof(TraceRay) == 32 && sizeof(TraceResult) == 32);

// Rays from random points of the scene's bounds: half in random directions, half aimed at a random
// vertex (through edges and vertices shared by several triangles, where ties and rounding are most
// likely to tell two traversals apart); a third of them limited to a random tMax.
std::vector<Ray> sceneRays(const World& world, size_t count, uint64_t seed) {
    std::mt19937_64 random(seed);
    std::normal_distribution<float> normal;
    auto uniform = [&](float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(random); };
    auto direction = [&] {
        for (;;) {
            const glm::vec3 d(normal(random), normal(random), normal(random));
            const float length = glm::length(d);
            if (length > 1e-3f) return d / length;
        }
    };
    std::vector<Ray> rays(count);
    const float diagonal = glm::length(world.boundsMax - world.boundsMin);
    for (size_t k = 0; k < count; ++k) {
        Ray& ray = rays[k];
        ray.origin = {uniform(world.boundsMin.x, world.boundsMax.x),
                      uniform(world.boundsMin.y, world.boundsMax.y),
                      uniform(world.boundsMin.z, world.boundsMax.z)};
        const size_t vertex = std::uniform_int_distribution<size_t>(0, world.positions.size() - 1)(random);
        ray.direction = k % 2 ? direction() : world.positions[vertex] - ray.origin;
        if (ray.direction == glm::vec3(0.0f)) ray.direction = direction();
        if (k % 3 == 0) ray.tMax = uniform(0.0f, 0.5f * diagonal) / glm::length(ray.direction);
    }
    return rays;
}

template <typename T> Buffer uploaded(const Context& context, const std::vector<T>& data, const char* what) {
    const VkDeviceSize bytes = std::max<VkDeviceSize>(sizeof(T) * data.size(), 16);
    Buffer buffer =
        createBuffer(context, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                     MemoryUse::Upload, what);
    if (!data.empty()) uploadBuffer(context, buffer, data.data(), sizeof(T) * data.size());
    return buffer;
}

class BvhGpu : public GpuTest {
  protected:
    // Both traversals of every ray on the GPU.
    std::vector<TraceResult> trace(const Bvh& bvh, const std::vector<Ray>& rays) {
        static constexpr VkDescriptorType kBindings[] = {
            VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
        struct Push {
            uint32_t rayCount;
            uint32_t nodeCount;
        };
        ComputeProgram program = createComputeProgram(context(), {.name = "trace_rays.comp",
                                                                  .spirv = spirv::trace_rays_comp,
                                                                  .bindings = kBindings,
                                                                  .pushConstantSize = sizeof(Push),
                                                                  .localSize = 64,
                                                                  .order = 1});
        std::vector<TraceRay> input(rays.size());
        for (size_t i = 0; i < rays.size(); ++i)
            input[i] = {glm::vec4(rays[i].origin, rays[i].tMin), glm::vec4(rays[i].direction, rays[i].tMax)};
        Buffer nodes = uploaded(context(), bvh.nodes, "BVH nodes");
        Buffer triangles = uploaded(context(), bvh.triangles, "BVH triangles");
        Buffer ids = uploaded(context(), bvh.triangleIds, "BVH triangle ids");
        Buffer rayBuffer = uploaded(context(), input, "rays");
        const VkDeviceSize resultBytes = sizeof(TraceResult) * rays.size();
        Buffer results = createBuffer(context(), resultBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                      MemoryUse::Readback, "hits");
        VkDescriptorPool pool = createDescriptorPool(context(), {.sets = 1, .storageBuffers = 5});
        const BindingTarget targets[] = {
            {nodes.buffer}, {triangles.buffer}, {ids.buffer}, {rayBuffer.buffer}, {results.buffer}};
        VkDescriptorSet set = createDescriptorSet(context(), pool, program, targets);
        const Push push{uint32_t(rays.size()), uint32_t(bvh.nodes.size())};
        const uint32_t groups = std::min<uint32_t>((uint32_t(rays.size()) + 63) / 64, 4096);
        submitAndWait(context(), [&](VkCommandBuffer commands) {
            dispatch(commands, program, set, push, {groups});
            computeWriteBarrier(commands);
        });
        invalidateBuffer(context(), results);
        std::vector<TraceResult> out(rays.size());
        std::memcpy(out.data(), results.mapped, resultBytes);
        vkDestroyDescriptorPool(context().device, pool, nullptr);
        for (Buffer* buffer : {&nodes, &triangles, &ids, &rayBuffer, &results})
            destroyBuffer(context(), *buffer);
        destroyComputeProgram(context(), program);
        return out;
    }
};

// On 2CylinderEngine (121k triangles) and the Cornell box, 100,000 rays each: the GPU's closest hit
// is the CPU's (scene/bvh.h closestHit) to the bit (triangle, t, u, v, face), and its any-hit
// answer is anyHit's, for every ray. No tolerance: the shader does the C++'s float operations in
// the same order, unfused (`precise`), and lavapipe rounds each one as the CPU does.
TEST_F(BvhGpu, HitsEqualTheCpuTraversalsBitForBit) {
    for (const World* world : {&engineWorld(SHPROBE_GLTF_MODELS_DIR), &openCornellBoxWithBlocks()}) {
        const Bvh bvh = buildBvh(*world);
        const std::vector<Ray> rays = sceneRays(*world, 100'000, 11);
        const auto start = std::chrono::steady_clock::now();
        const std::vector<TraceResult> gpu = trace(bvh, rays);
        const double gpuSeconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        size_t hits = 0, differ = 0, triangleDiffer = 0, anyDiffer = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            const auto expected = closestHit(bvh, rays[i]);
            const TraceResult& got = gpu[i];
            hits += expected.has_value();
            anyDiffer += (got.flags.y != 0) != anyHit(bvh, rays[i]);
            const glm::uvec4 want =
                expected ? glm::uvec4(expected->triangle, std::bit_cast<uint32_t>(expected->hit.t),
                                      std::bit_cast<uint32_t>(expected->hit.u),
                                      std::bit_cast<uint32_t>(expected->hit.v))
                         : glm::uvec4(0xffffffffu, 0u, 0u, 0u);
            const uint32_t wantFront = expected && expected->hit.frontFace ? 1u : 0u;
            triangleDiffer += want.x != got.hit.x;
            differ += want != got.hit || wantFront != got.flags.x;
        }
        std::printf(
            "%s: %zu rays, %zu hits; differ from the CPU: %zu (triangle %zu), any-hit %zu; GPU %.2f s\n",
            world->description.c_str(), rays.size(), hits, differ, triangleDiffer, anyDiffer, gpuSeconds);
        EXPECT_GT(hits, rays.size() / 4);
        EXPECT_EQ(differ, 0u);
        EXPECT_EQ(triangleDiffer, 0u);
        EXPECT_EQ(anyDiffer, 0u);
    }
}

// Edge functions that round to 0 in float but not exactly (the C++ recomputes them in double, the
// shader from the products' exact errors): the ray along +z from the origin and the sheared edge from
// c = (1, 1 + e) to b = (1 + e, 1 + 2e), e = 2^-23, whose exact edge function is -e^2. With the
// third corner at 4c the other two are 0 and 4e^2 (the latter rounding to 0 too): the signs are
// mixed, a miss, where taking the rounded 0s would hit. With it at -4c they are 0 and -4e^2: a hit.
TEST_F(BvhGpu, EdgeFunctionsThatRoundToZeroKeepTheirExactSign) {
    const float e = std::ldexp(1.0f, -23);
    const glm::vec3 b(1.0f + e, 1.0f + 2 * e, 1.0f), c(1.0f, 1.0f + e, 1.0f);
    const std::vector<Ray> rays{{.origin = glm::vec3(0.0f), .direction = glm::vec3(0.0f, 0.0f, 1.0f)}};
    for (float side : {4.0f, -4.0f}) {
        World world;
        world.positions = {glm::vec3(side * c.x, side * c.y, 1.0f), b, c};
        world.indices = {0, 1, 2};
        const Bvh bvh = buildBvh(world);
        const auto expected = closestHit(bvh, rays[0]);
        EXPECT_EQ(expected.has_value(), side < 0.0f);
        const TraceResult got = trace(bvh, rays)[0];
        if (expected)
            EXPECT_EQ(got.hit, glm::uvec4(0u, std::bit_cast<uint32_t>(expected->hit.t),
                                          std::bit_cast<uint32_t>(expected->hit.u),
                                          std::bit_cast<uint32_t>(expected->hit.v)));
        else
            EXPECT_EQ(got.hit.x, 0xffffffffu);
        EXPECT_EQ(got.flags.y, expected ? 1u : 0u);
    }
}

// A World without triangles has no node: every ray misses, closest and any.
TEST_F(BvhGpu, AnEmptyHierarchyIsNeverHit) {
    const Bvh bvh = buildBvh(World{});
    ASSERT_TRUE(bvh.nodes.empty());
    const std::vector<Ray> rays{
        {.origin = glm::vec3(0.0f), .direction = glm::vec3(0.0f, 0.0f, 1.0f)},
        {.origin = glm::vec3(1.0f), .direction = glm::vec3(-1.0f, 0.5f, 0.0f), .tMax = 2.0f}};
    for (const TraceResult& result : trace(bvh, rays)) {
        EXPECT_EQ(result.hit, glm::uvec4(0xffffffffu, 0u, 0u, 0u));
        EXPECT_EQ(result.flags, glm::uvec4(0u));
    }
}

} // namespace
} // namespace shprobe
