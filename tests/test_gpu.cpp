// GPU projection and convolution (project.comp, reduce.comp, convolve.comp) against the
// double-precision CPU reference, on whatever device the context picks (lavapipe in CI, run once
// per subgroup size 4, 8, 16, 32).
#include "gpu_test.h"

#include "gpu/projector.h"
#include "gpu/rotator.h"
#include "image/environment.h"
#include "sh/basis.h"
#include "sh/error.h"
#include "sh/irradiance.h"
#include "sh/projection.h"
#include "sh/rotation.h"
#include "sh/windowing.h"
#include "shprobe/shprobe_test_spirv.h"
#include "vk/pipeline.h"
#include "vk/resources.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <glm/geometric.hpp>
#include <random>

namespace shprobe::testing {
namespace {

// fp32 accuracy of the GPU path relative to |L_00| (the largest channel): each texel's weight,
// direction and basis carry a few ulps (~3e-7 relative, see test_geometry), each invocation sums at
// most texelsPerInvocation = 256 terms in sequence (error <= 256 ulps worst case, ~16 ulps typical),
// the workgroup reduction is a tree and the cross-workgroup sum is compensated. Higher bands are
// scaled by max|y_lm| / y_00 <= 5 at order 8. 2e-6 |L_00| leaves a few times the errors measured
// (about 3e-7) and is 50 times tighter than a wrong weight or basis entry would give.
constexpr double kGpuTolerance = 2e-6;

Cubemap noiseCubemap(int faceSize, uint32_t seed) {
    Cubemap cubemap = makeCubemap(faceSize);
    std::mt19937 random(seed);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (glm::vec4& texel : cubemap.texels)
        texel = {uniform(random), uniform(random), uniform(random), 1.0f};
    return cubemap;
}

// The built-in sky with one texel 10^5 times brighter than the sky: a sun the size of a texel.
Cubemap hotSunCubemap(int faceSize) {
    Cubemap cubemap = makeDefaultSky(faceSize);
    cubemap.at(2, faceSize / 3, faceSize / 5) = glm::vec4(1e5f, 9e4f, 8e4f, 1.0f);
    return cubemap;
}

Cubemap singleTexelCubemap(int faceSize, int face, int i, int j) {
    Cubemap cubemap = makeCubemap(faceSize);
    cubemap.at(face, i, j) = glm::vec4(1.0f, 2.0f, 3.0f, 1.0f);
    return cubemap;
}

double largestDc(const ShCoefficients& coefficients) {
    const glm::dvec3& dc = coefficients.rgb[0];
    return std::max({std::abs(dc.r), std::abs(dc.g), std::abs(dc.b)});
}

// Largest |gpu - reference| over all coefficients and channels, relative to |L_00|.
double relativeError(const ShCoefficients& gpu, const ShCoefficients& reference) {
    double worst = 0.0;
    for (size_t i = 0; i < reference.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(gpu.rgb[i][c] - reference.rgb[i][c]));
    return worst / largestDc(reference);
}

class GpuProjection : public GpuTest {
  protected:
    GpuBake bake(const Cubemap& cubemap, const ProjectorOptions& options) {
        Projector projector = createProjector(context(), options);
        GpuBake result = bakeCubemap(context(), projector, cubemap);
        destroyProjector(context(), projector);
        return result;
    }

    void expectMatchesReference(const Cubemap& cubemap, int order, const char* what) {
        GpuBake gpu = bake(cubemap, {.order = order});
        ShCoefficients reference = projectCubemap(cubemap, order);
        double error = relativeError(gpu.radiance, reference);
        EXPECT_LT(error, kGpuTolerance) << what << ", face " << cubemap.faceSize << ", order " << order;
        RecordProperty(std::string(what) + " order " + std::to_string(order), std::to_string(error));
    }
};

TEST_F(GpuProjection, MatchesReferenceOnGeneratedCubemaps) {
    for (int order : {1, 3, 5, 8}) {
        expectMatchesReference(noiseCubemap(16, 1), order, "noise");
        expectMatchesReference(noiseCubemap(33, 2), order, "noise, odd size");
        expectMatchesReference(hotSunCubemap(64), order, "sky with a hot sun texel");
        expectMatchesReference(singleTexelCubemap(8, 4, 2, 5), order, "single lit texel");
        expectMatchesReference(noiseCubemap(1, 3), order, "1x1 faces");
        expectMatchesReference(noiseCubemap(7, 4), order, "7x7 faces");
    }
}

// 6 x 2048^2 RGBA32F is 400 MiB: more than lavapipe's 128 MiB storage-buffer range, so the input is
// projected in several dispatches, and at 25 M texels accumulation errors are at their largest.
TEST_F(GpuProjection, MatchesReferenceAtLargeFaces) {
    Cubemap cubemap = noiseCubemap(2048, 5);
    GpuBake gpu = bake(cubemap, {.order = 3});
    if (context().info.limits.maxStorageBufferRange < cubemap.texels.size() * sizeof(glm::vec4)) {
        EXPECT_GT(gpu.dispatches, 1u) << "the 400 MiB input is larger than one binding may be";
    }
    double error = relativeError(gpu.radiance, projectCubemap(cubemap, 3));
    EXPECT_LT(error, kGpuTolerance);
    RecordProperty("error 2048 order 3", std::to_string(error));
}

// White furnace (filament cmgen's test): a constant environment c gives L_00 = c sqrt(4 pi) and,
// through order 3, zeros: the cube's octahedral symmetry cancels bands 1 to 3 exactly even for
// texel-center sampling. (Band 4 holds a cube-invariant combination, y_40 with y_44, so there the
// sampled sum is small but not zero, on the CPU as on the GPU.)
TEST_F(GpuProjection, ConstantEnvironmentGivesOnlyDcAndPiIrradiance) {
    const float c = 0.75f;
    Cubemap cubemap = makeCubemap(32);
    std::fill(cubemap.texels.begin(), cubemap.texels.end(), glm::vec4(c, c, c, 1.0f));
    GpuBake gpu = bake(cubemap, {.order = 3});
    const double l00 = c * std::sqrt(4.0 * M_PI);
    glm::dvec3 irradiance = evaluate(gpu.irradiance, glm::normalize(glm::dvec3(0.2, -0.7, 0.4)));
    for (int channel = 0; channel < 3; ++channel) {
        EXPECT_NEAR(gpu.radiance.rgb[0][channel], l00, kGpuTolerance * l00);
        for (size_t i = 1; i < gpu.radiance.rgb.size(); ++i)
            EXPECT_NEAR(gpu.radiance.rgb[i][channel], 0.0, kGpuTolerance * l00) << "coefficient " << i;
        // E(n) = pi c for every normal (seed 001: the clamped cosine integrates to pi).
        EXPECT_NEAR(irradiance[channel], M_PI * c, kGpuTolerance * M_PI * c);
    }
}

TEST_F(GpuProjection, IrradianceIsTheConvolutionOfTheRadiance) {
    for (int order : {3, 5, 8}) {
        GpuBake gpu = bake(hotSunCubemap(32), {.order = order});
        ShCoefficients expected = convolveIrradiance(gpu.radiance);
        // One float multiply by A_l rounded to float: 2 ulps.
        for (size_t i = 0; i < expected.rgb.size(); ++i)
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(gpu.irradiance.rgb[i][c], expected.rgb[i][c], 2.5e-7 * largestDc(expected))
                    << "order " << order << " coefficient " << i;
    }
}

TEST_F(GpuProjection, SameInputGivesBitIdenticalCoefficients) {
    Cubemap cubemap = noiseCubemap(64, 6);
    GpuBake first = bake(cubemap, {.order = 5});
    GpuBake second = bake(cubemap, {.order = 5});
    ASSERT_EQ(first.radiance.rgb.size(), second.radiance.rgb.size());
    EXPECT_EQ(std::memcmp(first.radiance.rgb.data(), second.radiance.rgb.data(),
                          first.radiance.rgb.size() * sizeof(glm::dvec3)),
              0);
}

// Any workgroup width and any amount of work per invocation gives the same sums: this exercises
// reductions with one subgroup, with more subgroups than a subgroup has lanes, and partial
// subgroups (widths that are not multiples of the subgroup size).
TEST_F(GpuProjection, WorkgroupShapesDoNotChangeTheResult) {
    Cubemap cubemap = noiseCubemap(24, 7);
    ShCoefficients reference = projectCubemap(cubemap, 4);
    for (uint32_t width : {1u, 3u, 8u, 32u, 64u, 100u, 256u, 1024u}) {
        for (uint32_t perInvocation : {1u, 5u, 256u}) {
            GpuBake gpu =
                bake(cubemap, {.order = 4, .workgroupSize = width, .texelsPerInvocation = perInvocation});
            EXPECT_LT(relativeError(gpu.radiance, reference), kGpuTolerance)
                << "workgroup " << width << ", texels per invocation " << perInvocation;
        }
    }
}

// A window scales band l of both outputs by w_l inside convolve.comp: the windowed radiance and
// irradiance equal the CPU's applyWindow / convolveIrradiance of the reference (same tolerance).
TEST_F(GpuProjection, WindowIsAppliedByTheConvolutionShader) {
    Cubemap cubemap = hotSunCubemap(32);
    for (int order : {3, 5}) {
        std::vector<double> window = windowFactors(WindowKind::Hanning, 3.5, order);
        GpuBake gpu = bake(cubemap, {.order = order});
        Projector projector = createProjector(context(), {.order = order});
        GpuBake windowed = bakeCubemap(context(), projector, cubemap, window);
        GpuBake convolved = convolveOnGpu(context(), projector, gpu.radiance, window);
        destroyProjector(context(), projector);

        ShCoefficients expected = applyWindow(projectCubemap(cubemap, order), window);
        EXPECT_LT(relativeError(windowed.radiance, expected), kGpuTolerance) << "order " << order;
        EXPECT_LT(relativeError(windowed.irradiance, convolveIrradiance(expected)), kGpuTolerance) << "order " << order;
        EXPECT_LT(relativeError(convolved.radiance, expected), kGpuTolerance) << "order " << order;
        EXPECT_LT(relativeError(convolved.irradiance, convolveIrradiance(expected)), kGpuTolerance) << "order " << order;
        EXPECT_GT(relativeError(windowed.radiance, gpu.radiance), 1e-2) << "the window changed nothing";
    }
}

// lavapipe stops loops after 65535 iterations, nested ones included, and the sums are then silently
// wrong: asking for far more texels per invocation than that allows must still give the right sums
// (the projector caps the work per invocation by order).
TEST_F(GpuProjection, HugeWorkPerInvocationStaysCorrect) {
    Cubemap cubemap = noiseCubemap(96, 8); // 55296 texels: one 8-wide workgroup would loop 6912 times
    for (int order : {1, 3, 8}) {
        GpuBake gpu = bake(cubemap, {.order = order, .workgroupSize = 8, .texelsPerInvocation = 1u << 20});
        EXPECT_LT(relativeError(gpu.radiance, projectCubemap(cubemap, order)), kGpuTolerance) << "order " << order;
    }
}

// One texel position per invocation at 2048^2 makes 65536 workgroups, hence 65536 partial slots:
// more than lavapipe lets one loop run, so a reduction that loops over all slots in one invocation
// loses some of them without a word (it did: L_00 came out 3% low at 3072^2). reduce.comp strides
// over the slots with a whole workgroup per coefficient.
TEST_F(GpuProjection, ManyPartialSlotsAreAllSummed) {
    Cubemap cubemap = noiseCubemap(2048, 9);
    GpuBake gpu = bake(cubemap, {.order = 3, .texelsPerInvocation = 1});
    EXPECT_GE(gpu.workgroups, 65536u);
    EXPECT_LT(relativeError(gpu.radiance, projectCubemap(cubemap, 3)), kGpuTolerance);
}

// ctest runs this file once per lavapipe vector width; each run must report the subgroup size it is
// named for (LP_NATIVE_VECTOR_WIDTH / 32), or the four runs would test the same thing. (At 1024 on a
// 256-bit CPU lavapipe reports 32 while running subgroups of 16; project.comp does not rely on the
// reported size, see the comment there.)
TEST_F(GpuProjection, RunsAtTheRequestedSubgroupSize) {
    const char* width = std::getenv("LP_NATIVE_VECTOR_WIDTH");
    if (!width) GTEST_SKIP() << "LP_NATIVE_VECTOR_WIDTH is not set (ctest sets it for each run)";
    EXPECT_EQ(context().info.subgroupSize, uint32_t(std::atoi(width) / 32));
}

TEST_F(GpuProjection, RejectsBadOrdersAndFaces) {
    EXPECT_THROW(createProjector(context(), {.order = 0}), Error);
    EXPECT_THROW(createProjector(context(), {.order = 9}), Error);
    Projector projector = createProjector(context(), {.order = 3});
    Cubemap empty;
    EXPECT_THROW(bakeCubemap(context(), projector, empty), Error);
    destroyProjector(context(), projector);
}

// The texel solid angle as the GPU evaluates it (texel_geometry.h compiled to SPIR-V, with the
// device's own atan and sqrt) against the double four-atan2 formula of CONVENTIONS.md: within
// 1e-5 relative for every texel of faces 1..64 and of sizes up to 4096.
class GpuSolidAngles : public GpuTest {
  protected:
    double worstRelativeError(const ComputeProgram& program, int faceSize) {
        VkDeviceSize bytes = VkDeviceSize(faceSize) * faceSize * sizeof(float);
        Buffer output = createBuffer(context(), bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                     MemoryUse::Readback, "solid angles");
        VkDescriptorPool pool = createDescriptorPool(context(), 1, 1);
        BufferRange range{&output, 0, bytes};
        VkDescriptorSet set = createDescriptorSet(context(), pool, program, std::span(&range, 1));
        uint32_t groups = std::min<uint32_t>((uint32_t(faceSize) * faceSize + 63) / 64, 4096);
        submitAndWait(context(), [&](VkCommandBuffer commands) {
            dispatch(commands, program, set, uint32_t(faceSize), groups);
            computeWriteBarrier(commands);
        });
        invalidateBuffer(context(), output);
        const float* gpu = static_cast<const float*>(output.mapped);
        double worst = 0.0;
        for (int j = 0; j < faceSize; ++j)
            for (int i = 0; i < faceSize; ++i) {
                double exact = texelSolidAngle(i, j, faceSize);
                worst = std::max(worst, std::abs(gpu[size_t(j) * faceSize + i] - exact) / exact);
            }
        vkDestroyDescriptorPool(context().device, pool, nullptr);
        destroyBuffer(context(), output);
        return worst;
    }
};

TEST_F(GpuSolidAngles, EveryTexelMatchesTheDoubleFormula) {
    ComputeProgram program = createComputeProgram(
        context(), {"solid_angles.comp", spirv::solid_angles_comp, 1, sizeof(uint32_t), 64, 1});
    std::vector<int> sizes;
    for (int n = 1; n <= 64; ++n)
        sizes.push_back(n);
    for (int n : {127, 255, 256, 511, 1000, 1024, 2047, 2048, 4096})
        sizes.push_back(n);
    double worstOverall = 0.0;
    for (int n : sizes) {
        double worst = worstRelativeError(program, n);
        EXPECT_LT(worst, 1e-5) << "face size " << n;
        worstOverall = std::max(worstOverall, worst);
    }
    RecordProperty("worst relative error", std::to_string(worstOverall));
    destroyComputeProgram(context(), program);
}

// rotate.comp against the double-precision CPU rotation (src/sh/rotation.h) on random probes. Each
// output sums at most 2l+1 = 15 products of fp32-rounded matrix entries (|D_mn| <= 1) and
// coefficients, with about three roundings each: 15 * 3 * 6e-8 < 3e-6 of the largest coefficient.
constexpr double kGpuRotationTolerance = 3e-6;

std::vector<ShCoefficients> randomProbes(int order, int count, uint32_t seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    std::vector<ShCoefficients> probes;
    for (int p = 0; p < count; ++p) {
        ShCoefficients probe = makeCoefficients(order, Quantity::Radiance);
        for (glm::dvec3& c : probe.rgb) c = {uniform(random), uniform(random), uniform(random)};
        probes.push_back(probe);
    }
    return probes;
}

double largestDifference(const ShCoefficients& a, const ShCoefficients& b) {
    double worst = 0.0;
    for (size_t i = 0; i < a.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(a.rgb[i][c] - b.rgb[i][c]));
    return worst;
}

class GpuRotation : public GpuTest {};

TEST_F(GpuRotation, OneRotationForABatchMatchesTheCpu) {
    for (int order : {1, 3, 5, 8}) {
        ShRotation rotation = makeShRotation(rotationFromEulerZYZ(30.0, 70.0, -115.0), order);
        std::vector<ShCoefficients> probes = randomProbes(order, 37, uint32_t(order));
        Rotator rotator = createRotator(context(), order);
        std::vector<ShCoefficients> gpu = rotateOnGpu(context(), rotator, std::span(&rotation, 1), probes);
        destroyRotator(context(), rotator);
        ASSERT_EQ(gpu.size(), probes.size());
        for (size_t p = 0; p < probes.size(); ++p)
            EXPECT_LT(largestDifference(gpu[p], rotate(rotation, probes[p])), kGpuRotationTolerance)
                << "order " << order << " probe " << p;
    }
}

TEST_F(GpuRotation, EachProbeWithItsOwnRotationMatchesTheCpu) {
    const int order = 5;
    std::vector<ShCoefficients> probes = randomProbes(order, 12, 99);
    std::vector<ShRotation> rotations;
    for (int p = 0; p < 12; ++p)
        rotations.push_back(makeShRotation(rotationFromEulerZYZ(13.0 * p, 29.0 * p, -7.0 * p), order));
    Rotator rotator = createRotator(context(), order);
    std::vector<ShCoefficients> gpu = rotateOnGpu(context(), rotator, rotations, probes);
    EXPECT_THROW(rotateOnGpu(context(), rotator, std::span(rotations).first(2), probes), Error);
    destroyRotator(context(), rotator);
    for (size_t p = 0; p < probes.size(); ++p)
        EXPECT_LT(largestDifference(gpu[p], rotate(rotations[p], probes[p])), kGpuRotationTolerance) << "probe " << p;
}

} // namespace
} // namespace shprobe::testing
