// Per-vertex transfer with its rays cast on the device (gpu/transfer_rays.h) against the CPU's
// (scene/transfer.h) on real scenes, the closed forms of test_transfer on the device, and the
// backend `shprobe transfer` chooses. Lavapipe, with the validation layer on (gpu_test.h).
#include "gpu_test.h"

#include "gpu/transfer_rays.h"
#include "scene/gltf_scene.h"
#include "scene/transfer.h"
#include "scene/transfer_mesh.h"
#include "scene_fixtures.h"
#include "sh/basis.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>

namespace shprobe {
namespace {

using namespace shprobe::testing;
namespace fs = std::filesystem;

// How the device's transfer departs from the CPU's: the largest difference of any coefficient
// of any vertex, over the estimate's noise scale (below), and how many vertices differ by more
// than rounding (kRounding of that scale).
struct Departure {
    double worst = 0.0; // in units of one ray's weight
    size_t vertices = 0;
    size_t differing = 0;
};

// One ray's share of a coefficient, the unit the two estimates can differ by where a ray passes
// on one device and is stopped on the other (an edge grazed, float rounding of its direction):
// the largest albedo over pi times pi / R times the largest basis value of the order,
// max |y_lm| <= sqrt((2l + 1) / (4 pi)).
double rayWeight(const World& world, int order, int rays) {
    double albedo = 0.0;
    for (const SceneMaterial& material : world.materials)
        albedo = std::max(
            {albedo, double(material.albedo.r), double(material.albedo.g), double(material.albedo.b)});
    return albedo / std::numbers::pi * std::numbers::pi / rays *
           std::sqrt((2.0 * order - 1.0) / (4.0 * std::numbers::pi));
}

// The two sums of a vertex agree to float rounding where every ray goes the same way: R terms of
// at most one ray's weight each, added in float on the device, in double on the CPU, err by at
// most R 2^-24 ray weights; kRounding takes 1e-3 ray weights as "the same" (R <= 1024 here).
constexpr double kRounding = 1e-3;

Departure compare(const VertexTransfer& gpu, const VertexTransfer& cpu, double weight) {
    Departure departure;
    const size_t count = size_t(coefficientCount(cpu.order));
    departure.vertices = cpu.vertexCount();
    for (size_t v = 0; v < departure.vertices; ++v) {
        double vertexWorst = 0.0;
        for (size_t i = 0; i < count; ++i) {
            const glm::vec3 d = glm::abs(gpu.coefficients[v * count + i] - cpu.coefficients[v * count + i]);
            vertexWorst = std::max({vertexWorst, double(d.r), double(d.g), double(d.b)});
        }
        departure.worst = std::max(departure.worst, vertexWorst / weight);
        departure.differing += vertexWorst > kRounding * weight;
    }
    return departure;
}

class TransferGpu : public GpuTest {
  protected:
    // Both backends on one configuration; the departure, printed with the timings.
    Departure compareBackends(const char* name, const World& world, const TransferOptions& options) {
        const auto start = std::chrono::steady_clock::now();
        const VertexTransfer gpu = computeTransferOnGpu(context(), world, options);
        const auto middle = std::chrono::steady_clock::now();
        const VertexTransfer cpu = computeTransfer(world, options);
        const auto end = std::chrono::steady_clock::now();
        EXPECT_EQ(gpu.rays, cpu.rays);
        EXPECT_EQ(gpu.raysCast, cpu.raysCast);
        EXPECT_EQ(gpu.coefficients.size(), cpu.coefficients.size());
        const Departure departure = compare(gpu, cpu, rayWeight(world, options.order, cpu.rays));
        std::printf("%s, %s order %d, %d rays: worst %.3g ray weights, %zu of %zu vertices beyond rounding; "
                    "gpu %.2f s, cpu %.2f s\n",
                    name, transferModelName(options.model), options.order, cpu.rays, departure.worst,
                    departure.differing, departure.vertices,
                    std::chrono::duration<double>(middle - start).count(),
                    std::chrono::duration<double>(end - middle).count());
        return departure;
    }
};

// The Cornell box with its blocks (open at the front), shadowed and interreflected (K = 1), orders 3
// and 8, and the same box with its white walls textured by a checker (the bounce samples it at the
// hit as the CPU does). The device casts the CPU's rays (the same strata, the same random numbers
// to 2^-24, directions to float rounding), so every coefficient agrees to rounding except where a
// ray grazing an edge goes another way: each such ray moves a coefficient by at most one ray
// weight (rayWeight), a bounce's ray by an albedo times the previous pass's, less. Measured: no
// vertex differs by more than rounding (kRounding) on lavapipe. Bound: 2 ray weights for any
// vertex, and at most 1% of the vertices beyond rounding, which a systematic error (a wrong sample,
// a wrong side, a wrong texel) breaks by far.
TEST_F(TransferGpu, CornellBoxMatchesTheCpu) {
    World textured = openCornellBoxWithBlocks();
    textured.textures.push_back(
        {.width = 2,
         .height = 2,
         .texels = {glm::vec4(1.0f), glm::vec4(0.2f), glm::vec4(0.5f), glm::vec4(0.8f)}});
    textured.materials[0].albedoTexture = 0;
    for (size_t v = 0; v < textured.uvs.size(); ++v)
        textured.uvs[v] =
            glm::vec2(textured.positions[v].x + textured.positions[v].y, textured.positions[v].z);
    for (const auto& [name, world] :
         {std::pair<const char*, const World*>{"Cornell box", &openCornellBoxWithBlocks()},
          {"textured Cornell box", &textured}}) {
        for (TransferModel model : {TransferModel::Shadowed, TransferModel::Interreflected}) {
            for (int order : {3, 8}) {
                const Departure d = compareBackends(
                    name, *world, {.model = model, .order = order, .rays = 256, .bounces = 1});
                EXPECT_LE(d.worst, 2.0) << name << ", " << transferModelName(model) << " order " << order;
                EXPECT_LE(double(d.differing), 0.01 * double(d.vertices));
            }
        }
    }
}

// 4,096 rays a side, cast in many passes (gpu/transfer_rays.cpp: llvmpipe ends an invocation's loops
// after 65535 iterations in all, which one pass of a side's rays ran past, leaving whole groups of
// sides with a fraction of their transfer): within 2 ray weights, as at 256 rays. Not the count
// beyond rounding: a ray weight is 16 times smaller here and the float sums of 4,096 rays round
// by up to 0.8 of one (measured), so most vertices differ by more than 1e-3 of a weight.
TEST_F(TransferGpu, ManyRaysASideMatchTheCpu) {
    for (TransferModel model : {TransferModel::Shadowed, TransferModel::Interreflected}) {
        for (int rays : {4096, 1089}) { // 1,089: 68 passes of 16 and one of 1
            const Departure d = compareBackends("Cornell box", openCornellBoxWithBlocks(),
                                                {.model = model, .order = 3, .rays = rays, .bounces = 1});
            EXPECT_LE(d.worst, 2.0) << transferModelName(model) << ", " << rays << " rays";
        }
    }
}

// 2CylinderEngine.glb (121,496 triangles; its vertices' sides face one another in narrow gaps, where
// rays graze many edges): the same bounds as the Cornell box at 9 rays, so that lavapipe casts it
// in a few seconds.
TEST_F(TransferGpu, EngineMatchesTheCpu) {
    const World& world = engineWorld(SHPROBE_GLTF_MODELS_DIR);
    for (TransferModel model : {TransferModel::Shadowed, TransferModel::Interreflected}) {
        const Departure d =
            compareBackends("2CylinderEngine", world, {.model = model, .order = 3, .rays = 9, .bounces = 1});
        EXPECT_LE(d.worst, 2.0) << transferModelName(model);
        EXPECT_LE(double(d.differing), 0.01 * double(d.vertices)) << transferModelName(model);
    }
}

// A plane with nothing above: every ray escapes, so the device's shadowed transfer is the
// unshadowed closed form up to the estimate's error, which test_transfer measures for the CPU's
// rays (rms 3.2e-4 at order 3, 1024 rays on a 12 x 12 grid; here the 4 corners of one quad, whose
// largest error stays below 5 times that rms, 1.6e-3, the bound). Inside a closed box nothing
// escapes: the shadowed and interreflected transfer are exactly 0 on the device as on the CPU.
TEST_F(TransferGpu, ClosedForms) {
    FixtureScene plane{.materials = {{glm::vec3(0.6f)}}, .nodes = {{.mesh = 0}}, .roots = {0}};
    plane.meshes.resize(1);
    plane.meshes[0].material = 0;
    addQuad(plane.meshes[0], glm::vec3(0.0f), {0.0f, 0.0f, 0.5f}, {0.5f, 0.0f, 0.0f});
    const World open = loadFixtureWorld(plane);
    const VertexTransfer exact = computeTransfer(open, {.model = TransferModel::Unshadowed, .order = 3});
    const VertexTransfer shadowed =
        computeTransferOnGpu(context(), open, {.model = TransferModel::Shadowed, .order = 3, .rays = 1024});
    ASSERT_EQ(shadowed.coefficients.size(), exact.coefficients.size());
    for (size_t k = 0; k < exact.coefficients.size(); ++k)
        EXPECT_NEAR(shadowed.coefficients[k].g, exact.coefficients[k].g, 1.6e-3) << "coefficient " << k;
    // L_00 has no noise there (every ray adds Y_00), so at 2^18 rays, 16,384 passes of float sums,
    // it shows what the passes' additions lose: 2.3e-3 of it uncompensated, float rounding (1e-6
    // allows a few dozen roundings) where each addition's error is carried.
    const VertexTransfer many = computeTransferOnGpu(
        context(), open, {.model = TransferModel::Shadowed, .order = 1, .rays = 1 << 18});
    for (uint32_t v = 0; v < open.positions.size(); ++v)
        EXPECT_NEAR(many.coefficients[v].g, exact.coefficients[9 * v].g, 1e-6 * exact.coefficients[9 * v].g)
            << "vertex " << v;

    FixtureScene closed{.materials = {{glm::vec3(0.9f)}}, .nodes = {{.mesh = 0}}, .roots = {0}};
    closed.meshes.resize(1);
    closed.meshes[0].material = 0;
    addBox(closed.meshes[0], glm::vec3(0.0f), glm::vec3(2.0f), true);
    const World box = loadFixtureWorld(closed);
    for (TransferModel model : {TransferModel::Shadowed, TransferModel::Interreflected}) {
        const VertexTransfer transfer =
            computeTransferOnGpu(context(), box, {.model = model, .order = 4, .rays = 64, .bounces = 2});
        for (const glm::vec3& c : transfer.coefficients)
            ASSERT_EQ(c, glm::vec3(0.0f)) << transferModelName(model);
    }
}

// `shprobe transfer` under auto takes the cores on lavapipe (a CPU device) and the device with
// --backend gpu, and says so; both write the same attributes (names, types, counts), their values
// as close as the two backends (above).
TEST(TransferProgram, BackendChoiceAndSameLayout) {
    const fs::path folder = fs::temp_directory_path() / "shprobe-transfer-gpu";
    fs::remove_all(folder);
    fs::create_directories(folder);
    const std::string scene = (folder / "box.glb").string();
    writeCornellBoxGltf(scene, {.innerBoxes = true});
    const auto run = [&](const std::string& args, const std::string& name) {
        const std::string out = (folder / (name + ".txt")).string();
        const std::string command = std::string(SHPROBE_EXECUTABLE) + " transfer " + scene +
                                    " --model interreflected --rays 64 " + args + " -o " +
                                    (folder / (name + ".glb")).string() + " > " + out + " 2>&1";
        EXPECT_EQ(std::system(command.c_str()), 0) << command;
        std::ifstream in(out);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    const std::string automatic = run("", "auto");
    const std::string gpu = run("--backend gpu --validation", "gpu");
    EXPECT_NE(automatic.find("backend  cpu: all cores, rays by Embree ("), std::string::npos) << automatic;
    EXPECT_NE(gpu.find("backend  gpu: llvmpipe"), std::string::npos) << gpu;
    const TransferMesh cpuMesh = loadTransferMesh((folder / "auto.glb").string());
    const TransferMesh gpuMesh = loadTransferMesh((folder / "gpu.glb").string());
    EXPECT_EQ(cpuMesh.order, gpuMesh.order);
    EXPECT_EQ(cpuMesh.channels, gpuMesh.channels);
    EXPECT_EQ(cpuMesh.attributes, gpuMesh.attributes);
    ASSERT_EQ(cpuMesh.transfer.size(), gpuMesh.transfer.size());
    const double weight = rayWeight(cpuMesh.world, 3, 64);
    for (size_t k = 0; k < cpuMesh.transfer.size(); ++k)
        ASSERT_NEAR(cpuMesh.transfer[k], gpuMesh.transfer[k], 2.0 * weight) << "float " << k;
    fs::remove_all(folder);
}

} // namespace
} // namespace shprobe
