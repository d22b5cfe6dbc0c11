// GPU projection and convolution (project.comp, reduce.comp, convolve.comp) against the
// double-precision CPU reference, on whatever device the context picks (lavapipe in CI, run once
// per subgroup size 4, 8, 16, 32).
#include "gpu_test.h"

#include "shprobe/gpu/host_bake.h"
#include "shprobe/gpu/probe_baker.h"
#include "shprobe/gpu/rotator.h"
#include "shprobe/image/environment.h"
#include "shprobe/sh/basis.h"
#include "shprobe/sh/error.h"
#include "shprobe/sh/irradiance.h"
#include "shprobe/sh/projection.h"
#include "shprobe/sh/rotation.h"
#include "shprobe/sh/windowing.h"
#include "shprobe/shprobe_test_spirv.h"
#include "shprobe/vk/image.h"
#include "shprobe/vk/pipeline.h"
#include "shprobe/vk/resources.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/gtc/packing.hpp>
#include <random>

namespace shprobe::testing {
namespace {

// fp32 accuracy of the GPU path relative to |L_00| (the largest channel): each texel's weight,
// direction and basis carry a few ulps (~3e-7 relative, see test_geometry), each invocation sums
// about 33 terms in sequence per coefficient by default (11 positions on three face pairs, each term
// a signed sum of eight texels; a few hundred where the work per invocation is raised: error <= one
// ulp per term worst case, far less typically), the workgroup reduction is a tree and the
// cross-workgroup sum is compensated. Higher bands are scaled by max|y_lm| / y_00 <= 5 at order 8.
// 2e-6 |L_00| leaves a few times the errors measured (about 3e-7) and is 50 times tighter than a
// wrong weight or basis entry would give.
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

// One coefficient set as the bakes write it: n^2 vec4, rgb used.
ShCoefficients readCoefficientSet(const glm::vec4* values, int order, Quantity quantity) {
    ShCoefficients set = makeCoefficients(order, quantity);
    for (size_t i = 0; i < set.rgb.size(); ++i)
        set.rgb[i] = glm::dvec3(glm::vec3(values[i]));
    return set;
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
    // The pipelines for host cube maps uploaded in `format`, as the program creates them.
    ProbeBaker hostBaker(ProbeBakerOptions options, TexelFormat format = TexelFormat::Rgba32F) {
        options.cubemaps = uploadBinding(context(), format);
        return createProbeBaker(context(), options);
    }

    GpuBake bake(const Cubemap& cubemap, const ProbeBakerOptions& options) {
        ProbeBaker baker = hostBaker(options);
        GpuBake result = bakeCubemap(context(), baker, cubemap);
        destroyProbeBaker(context(), baker);
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
        expectMatchesReference(noiseCubemap(2, 11), order, "2x2 faces");
        expectMatchesReference(noiseCubemap(3, 12), order, "3x3 faces");
        // The middle column of an odd face is its own mirror image: read twice at half weight.
        expectMatchesReference(singleTexelCubemap(7, 1, 3, 5), order, "single lit texel, middle column");
        expectMatchesReference(noiseCubemap(7, 4), order, "7x7 faces");
    }
}

// 6 x 2048^2 RGBA32F is 400 MiB, more than lavapipe's 128 MiB storage-buffer range (the image has
// no such limit), and at 25 M texels accumulation errors are at their largest. Held to 1e-6 of
// |L_00| (measured 3.6e-8): the sums per invocation are short and the cross-workgroup sum is
// compensated, so size does not erode the accuracy.
TEST_F(GpuProjection, MatchesReferenceAtLargeFaces) {
    Cubemap cubemap = noiseCubemap(2048, 5);
    GpuBake gpu = bake(cubemap, {.order = 3});
    double error = relativeError(gpu.radiance, projectCubemap(cubemap, 3));
    EXPECT_LT(error, 1e-6);
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
        // E(n) = pi c for every normal (Ramamoorthi & Hanrahan: the clamped cosine integrates to pi).
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
        ProbeBaker baker = hostBaker({.order = order});
        GpuBake windowed = bakeCubemap(context(), baker, cubemap, window);
        GpuBake convolved = convolveOnGpu(context(), baker, gpu.radiance, window);
        destroyProbeBaker(context(), baker);

        ShCoefficients expected = applyWindow(projectCubemap(cubemap, order), window);
        EXPECT_LT(relativeError(windowed.radiance, expected), kGpuTolerance) << "order " << order;
        EXPECT_LT(relativeError(windowed.irradiance, convolveIrradiance(expected)), kGpuTolerance)
            << "order " << order;
        EXPECT_LT(relativeError(convolved.radiance, expected), kGpuTolerance) << "order " << order;
        EXPECT_LT(relativeError(convolved.irradiance, convolveIrradiance(expected)), kGpuTolerance)
            << "order " << order;
        EXPECT_GT(relativeError(windowed.radiance, gpu.radiance), 1e-2) << "the window changed nothing";
    }
}

// lavapipe stops loops after 65535 iterations, nested ones included, and the sums are then silently
// wrong: asking for far more texels per invocation than that allows must still give the right sums
// (the baker caps the work per invocation by order).
TEST_F(GpuProjection, HugeWorkPerInvocationStaysCorrect) {
    // 192^2 positions (each a texel and its mirror images): one 8-wide workgroup would loop 4608 times
    // per face pair, with 18 basis-recurrence iterations in each at order 8.
    Cubemap cubemap = noiseCubemap(384, 8);
    for (int order : {1, 3, 8}) {
        GpuBake gpu = bake(cubemap, {.order = order, .workgroupSize = 8, .texelsPerInvocation = 1u << 20});
        EXPECT_LT(relativeError(gpu.radiance, projectCubemap(cubemap, order)), kGpuTolerance)
            << "order " << order;
    }
}

// One position (a texel and its mirror images, 1024^2 positions) per invocation at 2048^2 in 16-wide
// workgroups asks for 65536 workgroups: one more than a dispatch row allows
// (maxComputeWorkGroupCount[0] = 65535 on lavapipe), so the baker doubles the work per invocation,
// and 32768 partial slots remain. A reduction looping over that many slots in one
// invocation loses some of them without a word under lavapipe's 65535-iteration loop cap (measured:
// L_00 3% low at 3072^2, docs/gpu-path.md); reduce.comp strides over the slots with a whole workgroup per
// coefficient.
TEST_F(GpuProjection, ManyPartialSlotsAreAllSummed) {
    Cubemap cubemap = noiseCubemap(2048, 9);
    GpuBake gpu = bake(cubemap, {.order = 3, .workgroupSize = 16, .texelsPerInvocation = 1});
    EXPECT_GE(gpu.workgroups, 32768u);
    EXPECT_LE(gpu.workgroups, context().info.limits.maxComputeWorkGroupCount[0]);
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
    EXPECT_THROW(hostBaker({.order = 0}), Error);
    EXPECT_THROW(hostBaker({.order = 9}), Error);
    ProbeBaker baker = hostBaker({.order = 3});
    Cubemap empty;
    EXPECT_THROW(bakeCubemap(context(), baker, empty), Error);
    destroyProbeBaker(context(), baker);
}

// A batch bakes each probe exactly as a bake of it alone would (same dispatch shapes, the same fixed
// summation order), so the coefficients must be bit-identical, in input order, whatever the face
// sizes; and all of it is one queue submission.
TEST_F(GpuProjection, BatchEqualsSingleBakesInOneSubmission) {
    const std::vector<Cubemap> cubemaps = {noiseCubemap(16, 11), noiseCubemap(33, 12), hotSunCubemap(16),
                                           noiseCubemap(1, 13), noiseCubemap(33, 14)};
    std::vector<const Cubemap*> batch;
    for (const Cubemap& cubemap : cubemaps)
        batch.push_back(&cubemap);
    ProbeBaker baker = hostBaker({.order = 5});
    const uint64_t submissionsBefore = submissionCount();
    std::vector<GpuBake> batched = bakeCubemaps(context(), baker, batch);
    EXPECT_EQ(submissionCount() - submissionsBefore, 1u) << "a batch of 5 probes, 3 face sizes";
    ASSERT_EQ(batched.size(), cubemaps.size());
    for (size_t k = 0; k < cubemaps.size(); ++k) {
        GpuBake single = bakeCubemap(context(), baker, cubemaps[k]);
        EXPECT_EQ(batched[k].radiance.rgb, single.radiance.rgb) << "probe " << k;
        EXPECT_EQ(batched[k].irradiance.rgb, single.irradiance.rgb) << "probe " << k;
        EXPECT_LT(relativeError(batched[k].radiance, projectCubemap(cubemaps[k], 5)), kGpuTolerance)
            << "probe " << k;
    }
    destroyProbeBaker(context(), baker);
}

// RGBA16F input: the GPU reads halves, so the reference is the projection of the half-rounded
// texels, and the fp32 tolerance applies unchanged. Values beyond the half range are refused.
TEST_F(GpuProjection, HalfFloatInputMatchesTheReferenceOfItsValues) {
    Cubemap cubemap = hotSunCubemap(32);
    cubemap.at(2, 10, 6) = glm::vec4(6e4f, 5e4f, 4e4f, 1.0f); // the sun, within the half range
    Cubemap rounded = cubemap;
    for (glm::vec4& texel : rounded.texels)
        texel = glm::unpackHalf4x16(glm::packHalf4x16(texel));
    ProbeBaker baker = hostBaker({.order = 3}, TexelFormat::Rgba16F);
    GpuBake gpu = bakeCubemap(context(), baker, cubemap);
    EXPECT_LT(relativeError(gpu.radiance, projectCubemap(rounded, 3)), kGpuTolerance);
    cubemap.at(0, 0, 0) = glm::vec4(1e5f, 0.0f, 0.0f, 1.0f);
    EXPECT_THROW(bakeCubemap(context(), baker, cubemap), Error);
    destroyProbeBaker(context(), baker);
}

// The renderer's path (probe_baker.h): a baker on a borrowed device, the caller's own image, command
// buffer and output buffer (at a non-zero offset), two targets and a second bake of the first
// target recorded in one command buffer, and no submission by the library.
class GpuResidentBake : public GpuTest {
  protected:
    struct Probes {
        GpuImage image;
        Buffer staging;
    };

    // 6 * count layers filled from the cube maps, transitioned as probe_baker.h asks.
    Probes upload(std::span<const Cubemap> cubemaps, VkCommandBuffer commands) {
        const uint32_t n = uint32_t(cubemaps[0].faceSize);
        const VkDeviceSize bytes = cubemaps[0].texels.size() * sizeof(glm::vec4);
        Probes probes;
        probes.staging = createBuffer(context(), bytes * cubemaps.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                      MemoryUse::Upload, "test upload");
        for (size_t k = 0; k < cubemaps.size(); ++k)
            std::memcpy(static_cast<char*>(probes.staging.mapped) + k * bytes, cubemaps[k].texels.data(),
                        bytes);
        probes.image =
            createImage(context(), {.extent = {n, n},
                                    .usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                    .what = "test probes",
                                    .layers = uint32_t(6 * cubemaps.size())});
        changeLayout(commands, probes.image,
                     {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                      VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_TRANSFER_WRITE_BIT});
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, probes.image.layers};
        region.imageExtent = {n, n, 1};
        vkCmdCopyBufferToImage(commands, probes.staging.buffer, probes.image.image,
                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
        changeLayout(commands, probes.image,
                     {VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT});
        return probes;
    }
};

TEST_F(GpuResidentBake, RecordsIntoTheCallersCommandBufferAndBuffer) {
    const int order = 3;
    Device device = borrowDevice({context().physicalDevice, context().device, context().queueFamily});
    ProbeBaker baker = createProbeBaker(device, {.order = order});
    const std::vector<Cubemap> first = {noiseCubemap(24, 21), noiseCubemap(24, 22), hotSunCubemap(24)};
    const std::vector<Cubemap> second = {noiseCubemap(9, 23)};
    const VkDeviceSize alignment = device.info.limits.minStorageBufferOffsetAlignment;
    const VkDeviceSize firstOffset = alignment; // not at the start of the buffer
    const VkDeviceSize secondOffset =
        firstOffset + (probeBakeOutputBytes(order, 3) + alignment - 1) / alignment * alignment;
    Buffer output =
        createBuffer(device, secondOffset + probeBakeOutputBytes(order, 1),
                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback, "caller's coefficients");
    Probes firstProbes, secondProbes;
    ProbeBakeSet firstSet, secondSet;
    const uint64_t submissionsBefore = submissionCount();
    submitAndWait(context(), [&](VkCommandBuffer commands) {
        firstProbes = upload(first, commands);
        secondProbes = upload(second, commands);
        firstSet =
            createProbeBakeSet(device, baker, {firstProbes.image.view, 24, 3, output.buffer, firstOffset});
        secondSet =
            createProbeBakeSet(device, baker, {secondProbes.image.view, 9, 1, output.buffer, secondOffset});
        recordProbeBake(commands, baker, firstSet);
        recordProbeBake(commands, baker, secondSet);
        recordProbeBake(commands, baker, firstSet); // again: the scratch buffer is reused safely
        computeWriteBarrier(commands);
    });
    EXPECT_EQ(submissionCount() - submissionsBefore, 1u) << "only the test's own submission";
    invalidateBuffer(device, output);

    auto expectProbe = [&](VkDeviceSize offset, uint32_t probes, uint32_t k, const Cubemap& cubemap) {
        const auto* values =
            reinterpret_cast<const glm::vec4*>(static_cast<const char*>(output.mapped) + offset);
        ShCoefficients reference = projectCubemap(cubemap, order);
        const size_t n2 = size_t(coefficientCount(order));
        ShCoefficients radiance = readCoefficientSet(values + k * n2, order, Quantity::Radiance);
        ShCoefficients irradiance =
            readCoefficientSet(values + (probes + k) * n2, order, Quantity::Irradiance);
        EXPECT_LT(relativeError(radiance, reference), kGpuTolerance) << "probe " << k;
        EXPECT_LT(relativeError(irradiance, convolveIrradiance(reference)), kGpuTolerance) << "probe " << k;
    };
    for (uint32_t k = 0; k < 3; ++k)
        expectProbe(firstOffset, 3, k, first[k]);
    expectProbe(secondOffset, 1, 0, second[0]);

    destroyProbeBakeSet(device, secondSet);
    destroyProbeBakeSet(device, firstSet);
    for (Probes* probes : {&firstProbes, &secondProbes}) {
        destroyImage(context(), probes->image);
        destroyBuffer(context(), probes->staging);
    }
    destroyBuffer(device, output);
    destroyProbeBaker(device, baker);
}

// The CLI's own bakes (GpuProjection above) read a storage image; this runs project.comp, the
// sampled-image module, through the same workgroup shapes: its streams of positions must cover
// every texel once whatever the width.
TEST_F(GpuResidentBake, SampledModuleMatchesTheReferenceForAnyWorkgroupShape) {
    const int order = 4;
    Device device = borrowDevice({context().physicalDevice, context().device, context().queueFamily});
    const std::vector<Cubemap> cubemaps = {noiseCubemap(24, 31)};
    const ShCoefficients reference = projectCubemap(cubemaps[0], order);
    Buffer output = createBuffer(device, probeBakeOutputBytes(order, 1), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 MemoryUse::Readback, "caller's coefficients");
    for (uint32_t width : {1u, 3u, 8u, 100u}) {
        for (uint32_t perInvocation : {1u, 256u}) {
            ProbeBaker baker = createProbeBaker(
                device, {.order = order, .workgroupSize = width, .texelsPerInvocation = perInvocation});
            ASSERT_EQ(baker.options.cubemaps, CubemapBinding::SampledImage);
            Probes probes;
            ProbeBakeSet set;
            submitAndWait(context(), [&](VkCommandBuffer commands) {
                probes = upload(cubemaps, commands);
                set = createProbeBakeSet(device, baker, {probes.image.view, 24, 1, output.buffer, 0});
                recordProbeBake(commands, baker, set);
                computeWriteBarrier(commands);
            });
            invalidateBuffer(device, output);
            ShCoefficients radiance =
                readCoefficientSet(static_cast<const glm::vec4*>(output.mapped), order, Quantity::Radiance);
            EXPECT_LT(relativeError(radiance, reference), kGpuTolerance)
                << "workgroup " << width << ", texels per invocation " << perInvocation;
            destroyProbeBakeSet(device, set);
            destroyImage(context(), probes.image);
            destroyBuffer(context(), probes.staging);
            destroyProbeBaker(device, baker);
        }
    }
    destroyBuffer(device, output);
}

TEST_F(GpuResidentBake, RefusesTargetsItCannotBake) {
    ProbeBaker baker = createProbeBaker(context(), {.order = 3});
    Buffer output =
        createBuffer(context(), 4096, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback, "out");
    GpuImage image = createImage(
        context(), {.extent = {4, 4}, .usage = VK_IMAGE_USAGE_SAMPLED_BIT, .what = "probe", .layers = 6});
    EXPECT_THROW(createProbeBakeSet(context(), baker, {image.view, 4, 1, output.buffer, 1}), Error)
        << "misaligned";
    EXPECT_THROW(createProbeBakeSet(context(), baker, {image.view, 0, 1, output.buffer, 0}), Error)
        << "face size 0";
    EXPECT_THROW(createProbeBakeSet(context(), baker, {VK_NULL_HANDLE, 4, 1, output.buffer, 0}), Error)
        << "no view";
    destroyImage(context(), image);
    destroyBuffer(context(), output);
    destroyProbeBaker(context(), baker);
}

// The texel solid angle as the GPU evaluates it (texel_geometry.h compiled to SPIR-V, with the
// device's own atan and sqrt) against the double four-atan2 formula of docs/conventions.md: within
// 1e-5 relative for every texel of faces 1..64 and of sizes up to 4096.
class GpuSolidAngles : public GpuTest {
  protected:
    double worstRelativeError(const ComputeProgram& program, int faceSize) {
        VkDeviceSize bytes = VkDeviceSize(faceSize) * faceSize * sizeof(float);
        Buffer output = createBuffer(context(), bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                     MemoryUse::Readback, "solid angles");
        VkDescriptorPool pool = createDescriptorPool(context(), {.sets = 1, .storageBuffers = 1});
        BindingTarget target{output.buffer, 0, bytes};
        VkDescriptorSet set = createDescriptorSet(context(), pool, program, std::span(&target, 1));
        uint32_t groups = std::min<uint32_t>((uint32_t(faceSize) * faceSize + 63) / 64, 4096);
        submitAndWait(context(), [&](VkCommandBuffer commands) {
            dispatch(commands, program, set, uint32_t(faceSize), {groups});
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
    static constexpr VkDescriptorType kBindings[] = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    ComputeProgram program = createComputeProgram(context(), {.name = "solid_angles.comp",
                                                              .spirv = spirv::solid_angles_comp,
                                                              .bindings = kBindings,
                                                              .pushConstantSize = sizeof(uint32_t),
                                                              .localSize = 64,
                                                              .order = 1});
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
        for (glm::dvec3& c : probe.rgb)
            c = {uniform(random), uniform(random), uniform(random)};
        probes.push_back(probe);
    }
    return probes;
}

double largestDifference(const ShCoefficients& a, const ShCoefficients& b) {
    double worst = 0.0;
    for (size_t i = 0; i < a.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(a.rgb[i][c] - b.rgb[i][c]));
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
        EXPECT_LT(largestDifference(gpu[p], rotate(rotations[p], probes[p])), kGpuRotationTolerance)
            << "probe " << p;
}

} // namespace
} // namespace shprobe::testing
