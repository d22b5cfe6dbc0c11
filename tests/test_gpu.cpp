// GPU projection and convolution (project.comp, project_equirect.comp, reduce.comp, convolve.comp)
// against the double-precision CPU reference, on whatever device the context picks (lavapipe in CI,
// run once per subgroup size 4, 8, 16, 32).
#include "gpu_test.h"

#include "common/error.h"
#include "gpu/host_bake.h"
#include "gpu/probe_baker.h"
#include "gpu/rotator.h"
#include "image/environment.h"
#include "sh/basis.h"
#include "sh/fast_projection.h"
#include "sh/irradiance.h"
#include "sh/projection.h"
#include "sh/rotation.h"
#include "sh/windowing.h"
#include "vk/image.h"
#include "vk/pipeline.h"
#include "vk/resources.h"
#include "vk/vulkan_commands.h"
#include <shprobe/shprobe_test_spirv.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <glm/geometric.hpp>
#include <glm/gtc/packing.hpp>
#include <random>
#include <span>

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

// Noise in [0, 1) in RGB.
void fillNoise(std::vector<glm::vec4>& texels, uint32_t seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (glm::vec4& texel : texels)
        texel = {uniform(random), uniform(random), uniform(random), 1.0f};
}

Cubemap noiseCubemap(int faceSize, uint32_t seed) {
    Cubemap cubemap = makeCubemap(faceSize);
    fillNoise(cubemap.texels, seed);
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

// The texels as the RGBA16F upload rounds them (packHalves, tested in test_fast_projection; 5e4 is
// a tie between two halves, which F16C and glm round to different ones).
std::vector<glm::vec4> halfRounded(std::span<const glm::vec4> texels) {
    std::vector<uint64_t> halves(texels.size());
    packHalves(texels, halves.data());
    std::vector<glm::vec4> rounded;
    for (uint64_t texel : halves)
        rounded.push_back(glm::unpackHalf4x16(texel));
    return rounded;
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

    // The radiance of each probe of an upload (order 3), baked in one submission of the test's own
    // that also records the upload's last copy.
    std::vector<ShCoefficients> bakeUpload(const ProbeBaker& baker, const CubemapUpload& upload) {
        Buffer output = createBuffer(context(), probeBakeOutputBytes(3, upload.probeCount),
                                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback, "coefficients");
        ProbeBakeSet set = createProbeBakeSet(
            context(), baker, {upload.image.view, upload.faceSize, upload.probeCount, output.buffer, 0});
        submitAndWait(context(), [&](VkCommandBuffer commands) {
            recordCubemapUpload(commands, upload);
            recordProbeBake(commands, baker, set);
            computeWriteBarrier(commands);
        });
        invalidateBuffer(context(), output);
        std::vector<ShCoefficients> radiance;
        for (uint32_t k = 0; k < upload.probeCount; ++k)
            radiance.push_back(readBakeOutput(output, 0, 3, upload.probeCount, k).radiance);
        destroyProbeBakeSet(context(), set);
        destroyBuffer(context(), output);
        return radiance;
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

// The check every GPU test ends with (validationMessages() unchanged) can fail: a buffer asked for
// with no usage (VUID-VkBufferCreateInfo-usage-requiredbitmask, which drivers ignore) is counted
// as a validation message. Its own context, so that the suite's stays clean.
TEST(ValidationLayer, CountsAMessage) {
    ContextOptions options;
    options.validation = true;
    Context context = createContext(options);
    const VkBufferCreateInfo info{.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO, .size = 16, .usage = 0};
    VkBuffer buffer = VK_NULL_HANDLE;
    const VkResult result = vkCreateBuffer(context.device, &info, nullptr, &buffer);
    if (result == VK_SUCCESS) vkDestroyBuffer(context.device, buffer, nullptr);
    EXPECT_GE(context.validationMessages(), 1u);
    destroyContext(context);
}

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
    cubemap.at(2, 10, 6) = glm::vec4(6e4f, 5e4f, 4e4f, 1.0f); // the sun, within the half range (5e4: a tie)
    Cubemap rounded = cubemap;
    rounded.texels = halfRounded(cubemap.texels);
    ProbeBaker baker = hostBaker({.order = 3}, TexelFormat::Rgba16F);
    GpuBake gpu = bakeCubemap(context(), baker, cubemap);
    EXPECT_LT(relativeError(gpu.radiance, projectCubemap(rounded, 3)), kGpuTolerance);
    cubemap.at(0, 0, 0) = glm::vec4(1e5f, 0.0f, 0.0f, 1.0f);
    EXPECT_THROW(bakeCubemap(context(), baker, cubemap), Error);
    destroyProbeBaker(context(), baker);
}

// Uploads through staging slots smaller than the maps (vk/staged_upload.h), in slots of 5 and of 17
// rows against faces of 7: copies start and end inside layers, hold whole layers and partial ones,
// and cross from one probe to the next, with each slot refilled while the copy before is in flight,
// and every slot but the last submitted ahead. Any row misplaced changes the noise's coefficients, so
// the bake must equal bit for bit the same maps baked by bakeCubemaps in one submission (one slot
// where the texels are staged).
TEST_F(GpuProjection, UploadThroughSmallStagingSlotsEqualsTheDefaultRoute) {
    const std::vector<Cubemap> cubemaps = {noiseCubemap(7, 21), noiseCubemap(7, 22), noiseCubemap(7, 23)};
    std::vector<const Cubemap*> batch;
    for (const Cubemap& cubemap : cubemaps)
        batch.push_back(&cubemap);
    for (TexelFormat format : {TexelFormat::Rgba32F, TexelFormat::Rgba16F}) {
        ProbeBaker baker = hostBaker({.order = 3}, format);
        uint64_t submissionsBefore = submissionCount();
        const std::vector<GpuBake> batched = bakeCubemaps(context(), baker, batch);
        EXPECT_EQ(submissionCount() - submissionsBefore, 1u);
        for (size_t k = 0; k < cubemaps.size();
             ++k) { // the default route against the reference of its values
            Cubemap uploaded = cubemaps[k];
            if (format == TexelFormat::Rgba16F) uploaded.texels = halfRounded(cubemaps[k].texels);
            EXPECT_LT(relativeError(batched[k].radiance, projectCubemap(uploaded, 3)), kGpuTolerance)
                << "probe " << k;
        }
        for (uint32_t slotRows : {5u, 17u}) {
            const char* what = format == TexelFormat::Rgba16F ? "RGBA16F" : "RGBA32F";
            submissionsBefore = submissionCount();
            CubemapUpload upload =
                createCubemapUpload(context(), batch, baker.options.cubemaps,
                                    {.staging = {.slotBytes = slotRows * 7 * texelBytes(format), .slots = 2},
                                     .fastest = UploadRoute::Staged});
            const uint64_t slots = (3 * 6 * 7 + slotRows - 1) / slotRows; // 126 rows
            EXPECT_EQ(upload.staged.submissions, slots - 1) << what << ", slots of " << slotRows;
            EXPECT_EQ(submissionCount() - submissionsBefore, slots - 1) << what << ", slots of " << slotRows;
            const std::vector<ShCoefficients> radiance = bakeUpload(baker, upload);
            for (uint32_t k = 0; k < 3; ++k)
                EXPECT_EQ(radiance[k].rgb, batched[k].radiance.rgb)
                    << what << ", slots of " << slotRows << ", probe " << k;
            destroyCubemapUpload(context(), upload);
        }
        destroyProbeBaker(context(), baker);
    }
}

// Every route an upload can take (host_bake.h, UploadRoute) puts the same texels in the image: one
// map and batches of three, faces of 8, 12 and 7, both formats; each route bakes bit for bit what the
// staging slots bake. On a CPU device such as lavapipe the packed route is taken wherever it is
// allowed, rows and layers the driver pads included (lavapipe: rows to 64 bytes, RGBA16F rows of 12 and
// 7 texels and RGBA32F rows of 7; layers of 7 rows to 8), and one RGBA32F map of faces 8 is read in
// place.
TEST_F(GpuProjection, EveryUploadRouteBakesTheSameTexels) {
    const bool hostImages = context().info.type == VK_PHYSICAL_DEVICE_TYPE_CPU;
    for (int faceSize : {8, 12, 7}) {
        const std::vector<Cubemap> cubemaps = {noiseCubemap(faceSize, 41), noiseCubemap(faceSize, 42),
                                               noiseCubemap(faceSize, 43)};
        for (size_t probes : {size_t(1), size_t(3)}) {
            std::vector<const Cubemap*> batch;
            for (size_t k = 0; k < probes; ++k)
                batch.push_back(&cubemaps[k]);
            for (TexelFormat format : {TexelFormat::Rgba32F, TexelFormat::Rgba16F}) {
                const std::string what = std::string(format == TexelFormat::Rgba16F ? "RGBA16F" : "RGBA32F") +
                                         ", faces of " + std::to_string(faceSize) + ", " +
                                         std::to_string(probes) + " probes";
                ProbeBaker baker = hostBaker({.order = 3}, format);
                std::vector<ShCoefficients> staged;
                for (UploadRoute fastest : {UploadRoute::Staged, UploadRoute::Packed, UploadRoute::InPlace}) {
                    CubemapUpload upload =
                        createCubemapUpload(context(), batch, baker.options.cubemaps, {.fastest = fastest});
                    EXPECT_GE(upload.route, fastest) << what; // no faster route than allowed
                    if (hostImages && fastest != UploadRoute::Staged) {
                        EXPECT_NE(upload.route, UploadRoute::Staged) << what;
                    }
                    if (hostImages && fastest == UploadRoute::InPlace && probes == 1 && faceSize == 8 &&
                        format == TexelFormat::Rgba32F) {
                        EXPECT_EQ(upload.route, UploadRoute::InPlace) << what;
                    }
                    const std::vector<ShCoefficients> radiance = bakeUpload(baker, upload);
                    destroyCubemapUpload(context(), upload);
                    if (staged.empty()) staged = radiance;
                    for (size_t k = 0; k < probes; ++k)
                        EXPECT_EQ(radiance[k].rgb, staged[k].rgb)
                            << what << ", route " << int(fastest) << ", probe " << k;
                }
                destroyProbeBaker(context(), baker);
            }
        }
    }
}

// Five maps of 210^2 faces (4.2 MB each in RGBA32F, 2.1 MB in RGBA16F) are packed by more than one
// thread (4 MiB a thread at least) where there are cores, each writing its own rows of the slot (on
// lavapipe: of the image's own memory); with two threads, as on two cores, a thread's rows cross from
// one map to the next (1260 rows a map). The batch must equal the single bakes bit for bit (on
// lavapipe the single RGBA32F bakes read their texels in place).
TEST_F(GpuProjection, BatchPackedOnSeveralThreadsEqualsSingleBakes) {
    std::vector<Cubemap> cubemaps;
    std::vector<const Cubemap*> batch;
    for (uint32_t seed = 31; seed < 36; ++seed)
        cubemaps.push_back(noiseCubemap(210, seed));
    for (const Cubemap& cubemap : cubemaps)
        batch.push_back(&cubemap);
    for (TexelFormat format : {TexelFormat::Rgba32F, TexelFormat::Rgba16F}) {
        ProbeBaker baker = hostBaker({.order = 3}, format);
        const std::vector<GpuBake> batched = bakeCubemaps(context(), baker, batch);
        for (size_t k = 0; k < cubemaps.size(); ++k)
            EXPECT_EQ(batched[k].radiance.rgb, bakeCubemap(context(), baker, cubemaps[k]).radiance.rgb)
                << (format == TexelFormat::Rgba16F ? "RGBA16F" : "RGBA32F") << ", probe " << k;
        destroyProbeBaker(context(), baker);
    }
}

// A texel out of the half range in the last probe: refused after earlier slots were copied, with
// the slots in flight waited for and everything freed (the validation layer reports objects left).
TEST_F(GpuProjection, UploadRefusedInALaterSlotLeavesNothingBehind) {
    std::vector<Cubemap> cubemaps = {noiseCubemap(7, 24), noiseCubemap(7, 25)};
    cubemaps[1].at(5, 6, 6) = glm::vec4(7e4f, 0.0f, 0.0f, 1.0f);
    const Cubemap* batch[] = {&cubemaps[0], &cubemaps[1]};
    const VkDeviceSize rowBytes = 7 * texelBytes(TexelFormat::Rgba16F);
    try {
        createCubemapUpload(
            context(), batch, uploadBinding(context(), TexelFormat::Rgba16F),
            {.staging = {.slotBytes = 3 * rowBytes, .slots = 2}, .fastest = UploadRoute::Staged});
        ADD_FAILURE() << "a texel of 7e4 was uploaded as a half";
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Input);
        EXPECT_NE(std::string(error.what()).find("does not fit RGBA16F"), std::string::npos) << error.what();
    }
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
        std::vector<std::span<const glm::vec4>> texels;
        for (const Cubemap& cubemap : cubemaps)
            texels.emplace_back(cubemap.texels);
        const uint32_t n = uint32_t(cubemaps[0].faceSize);
        return upload({n, n}, uint32_t(6 * cubemaps.size()), texels, commands);
    }

    // Records, in one command buffer of the test's own, what `prepare` uploads, then the bakes of the
    // two sets it creates, the first twice (the scratch buffer is reused safely), and checks that the
    // library submitted nothing of its own.
    void recordTwoSetsInOneSubmission(const ProbeBaker& baker,
                                      const std::function<void(VkCommandBuffer)>& prepare,
                                      const ProbeBakeSet& firstSet, const ProbeBakeSet& secondSet) {
        const uint64_t submissionsBefore = submissionCount();
        submitAndWait(context(), [&](VkCommandBuffer commands) {
            prepare(commands);
            recordProbeBake(commands, baker, firstSet);
            recordProbeBake(commands, baker, secondSet);
            recordProbeBake(commands, baker, firstSet);
            computeWriteBarrier(commands);
        });
        EXPECT_EQ(submissionCount() - submissionsBefore, 1u) << "only the test's own submission";
    }

    // Probe k of `probes` in the output layout at `offset` of a mapped buffer against the reference
    // radiance and its convolution.
    static void expectOutputProbe(const Buffer& output, VkDeviceSize offset, uint32_t probes, uint32_t k,
                                  const ShCoefficients& reference) {
        const auto* values =
            reinterpret_cast<const glm::vec4*>(static_cast<const char*>(output.mapped) + offset);
        const int order = reference.order;
        const size_t n2 = size_t(coefficientCount(order));
        ShCoefficients radiance = readCoefficientSet(values + k * n2, order, Quantity::Radiance);
        ShCoefficients irradiance =
            readCoefficientSet(values + (probes + k) * n2, order, Quantity::Irradiance);
        EXPECT_LT(relativeError(radiance, reference), kGpuTolerance) << "probe " << k;
        EXPECT_LT(relativeError(irradiance, convolveIrradiance(reference)), kGpuTolerance) << "probe " << k;
    }

    // `layers` layers of `extent`, filled from the probes' texels in turn (whole layers each).
    Probes upload(VkExtent2D extent, uint32_t layers, std::span<const std::span<const glm::vec4>> texels,
                  VkCommandBuffer commands) {
        VkDeviceSize bytes = 0;
        for (std::span<const glm::vec4> probe : texels)
            bytes += probe.size_bytes();
        Probes probes;
        probes.staging = createBuffer(context(), bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload,
                                      "test upload");
        auto* out = static_cast<char*>(probes.staging.mapped);
        for (std::span<const glm::vec4> probe : texels) {
            std::memcpy(out, probe.data(), probe.size_bytes());
            out += probe.size_bytes();
        }
        probes.image =
            createImage(context(), {.extent = extent,
                                    .usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                    .what = "test probes",
                                    .layers = layers});
        changeLayout(commands, probes.image,
                     {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                      VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT,
                      VK_ACCESS_TRANSFER_WRITE_BIT});
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, probes.image.layers};
        region.imageExtent = {extent.width, extent.height, 1};
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
    recordTwoSetsInOneSubmission(
        baker,
        [&](VkCommandBuffer commands) {
            firstProbes = upload(first, commands);
            secondProbes = upload(second, commands);
            firstSet = createProbeBakeSet(device, baker,
                                          {firstProbes.image.view, 24, 3, output.buffer, firstOffset});
            secondSet = createProbeBakeSet(device, baker,
                                           {secondProbes.image.view, 9, 1, output.buffer, secondOffset});
        },
        firstSet, secondSet);
    invalidateBuffer(device, output);
    for (uint32_t k = 0; k < 3; ++k)
        expectOutputProbe(output, firstOffset, 3, k, projectCubemap(first[k], order));
    expectOutputProbe(output, secondOffset, 1, 0, projectCubemap(second[0], order));

    destroyProbeBakeSet(device, secondSet);
    destroyProbeBakeSet(device, firstSet);
    for (Probes* probes : {&firstProbes, &secondProbes}) {
        destroyImage(context(), probes->image);
        destroyBuffer(context(), probes->staging);
    }
    destroyBuffer(device, output);
    destroyProbeBaker(device, baker);
}

// A lent device is checked and described as createContext checks and describes its own; a queue
// family that does no compute work is refused by its number.
TEST_F(GpuResidentBake, BorrowedDeviceIsCheckedAsTheContextsOwn) {
    const Device device = borrowDevice({context().physicalDevice, context().device, context().queueFamily});
    EXPECT_EQ(device.info.name, context().info.name);
    EXPECT_EQ(device.info.subgroupArithmetic, context().info.subgroupArithmetic);
    EXPECT_EQ(device.info.timestamps, context().info.timestamps);
    EXPECT_EQ(device.info.unsupportedReason, "");
    try {
        borrowDevice({context().physicalDevice, context().device, 1000});
        ADD_FAILURE() << "queue family 1000 was taken";
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Device);
        EXPECT_EQ(std::string(error.what()),
                  "queue family 1000 of " + context().info.name + " does not do compute work");
    }
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

// ------------------------------------------------------------------------------------------------
// Equirect maps projected directly (project_equirect.comp and its storage variants), against the
// double reference projectEquirect, which weights each pixel by the same exact row solid angle. The
// tolerance is kGpuTolerance for the same reasons as for cube maps: per position, a weight and a
// direction of a few ulps (preciseSinCosPi, equirect_geometry.h), one basis evaluation and n^2
// multiply-adds of signed sums of eight pixels; about 32 positions summed per invocation by default,
// a tree per workgroup, a compensated sum across workgroups.

Image noiseEquirect(int width, int height, uint32_t seed) {
    Image image = makeImage(width, height);
    fillNoise(image.texels, seed);
    return image;
}

// Noise with one pixel 10^5 times brighter: a sun the size of a pixel.
Image hotPixelEquirect(int width, int height, uint32_t seed) {
    Image image = noiseEquirect(width, height, seed);
    image.at(width / 3, height / 5) = glm::vec4(1e5f, 9e4f, 8e4f, 1.0f);
    return image;
}

// The first coefficients of a projection: the projection of a lower order (the same sums).
ShCoefficients truncated(const ShCoefficients& coefficients, int order) {
    ShCoefficients lower = makeCoefficients(order, coefficients.quantity);
    std::copy_n(coefficients.rgb.begin(), lower.rgb.size(), lower.rgb.begin());
    return lower;
}

class GpuEquirect : public GpuProjection {
  protected:
    static void TearDownTestSuite() {
        for (ProbeBaker& baker : bakers_)
            destroyProbeBaker(context(), baker);
        GpuTest::TearDownTestSuite();
    }

    ProbeBaker equirectBaker(ProbeBakerOptions options, TexelFormat format = TexelFormat::Rgba32F) {
        options.source = ProbeSource::Equirect;
        return hostBaker(options, format);
    }

    // The program's own equirect baker of each order (storage RGBA32F, default workgroup shape),
    // created once for the suite: on lavapipe a pipeline is compiled at its first dispatch, which
    // takes seconds at order 8.
    static const ProbeBaker& sharedBaker(int order) {
        ProbeBaker& baker = bakers_[size_t(order - 1)];
        if (!baker.project.pipeline) {
            baker = createProbeBaker(context(), {.order = order,
                                                 .cubemaps = uploadBinding(context(), TexelFormat::Rgba32F),
                                                 .source = ProbeSource::Equirect});
        }
        return baker;
    }

  private:
    static inline std::array<ProbeBaker, kMaxOrder> bakers_;
};

// Workaround(llvmpipe, Mesa 22.3), for test time: llvmpipe compiles a pipeline again for each class
// of image it meets at a dispatch: whether the width and the height are powers of two (Mesa,
// gallivm/lp_bld_sample.h: lp_static_texture_state, pot_width and pot_height) and whether the view
// has one layer or more (measured: 0.7 s per class at order 6, 2.4 s at order 8, without a shader
// cache). The tests take maps of every class, but not every class at every order: neither side a
// power of two at every order; power-of-two widths and heights at orders 1, 3, 5 and 8 (the
// blender-data maps, 1024 x 512, need that class at 3, 5 and 8 anyway); 1-pixel-high maps (H = 1 is
// a power of two) at orders 1, 3 and 5; power-of-two widths over other heights, and two maps of one
// size in one view, at orders 1 and 3. What the classes exercise (mirrors, the half turn, the
// weights) does not depend on the order.
struct SizeClass {
    std::vector<Image> images;
    std::vector<int> orders;
};

// Checks: every order 1..8 on maps of even and odd widths and heights, with and without the half
// turn (even W), an odd W / 2 (a self-mirrored column), 1-pixel-high and 1-pixel-wide maps, a single
// pixel, maps taller than wide and a hot pixel; all maps of a class and order in one batch (one
// submission, one bake set per size), and a batch equals a bake of its map alone bit for bit.
TEST_F(GpuEquirect, MatchesReferenceAtEverySizeAndOrder) {
    const SizeClass classes[] = {
        {{noiseEquirect(7, 3, 4), noiseEquirect(10, 5, 5), noiseEquirect(6, 3, 6), noiseEquirect(33, 17, 7),
          noiseEquirect(5, 9, 8), hotPixelEquirect(130, 65, 9)},
         {1, 2, 3, 4, 5, 6, 7, 8}},
        {{noiseEquirect(3, 1, 1), noiseEquirect(6, 1, 2), noiseEquirect(6, 2, 3)}, {1, 3, 5}},
        {{noiseEquirect(1, 1, 10), noiseEquirect(2, 1, 11), noiseEquirect(8, 1, 12), noiseEquirect(16, 8, 13),
          hotPixelEquirect(64, 32, 14)},
         {1, 3, 5, 8}},
        {{noiseEquirect(1, 3, 15), noiseEquirect(2, 5, 16), noiseEquirect(16, 9, 17),
          noiseEquirect(16, 9, 18)},
         {1, 3}}};
    double worst = 0.0;
    for (const SizeClass& sizes : classes) {
        std::vector<const Image*> batch;
        for (const Image& image : sizes.images)
            batch.push_back(&image);
        for (int order : sizes.orders) {
            const ProbeBaker& baker = sharedBaker(order);
            const uint64_t submissionsBefore = submissionCount();
            const std::vector<GpuBake> bakes = bakeEquirects(context(), baker, batch);
            EXPECT_EQ(submissionCount() - submissionsBefore, 1u) << "order " << order;
            ASSERT_EQ(bakes.size(), sizes.images.size());
            for (size_t k = 0; k < bakes.size(); ++k) {
                const Image& image = sizes.images[k];
                const double error = relativeError(bakes[k].radiance, projectEquirect(image, order));
                worst = std::max(worst, error);
                EXPECT_LT(error, kGpuTolerance)
                    << image.width << " x " << image.height << ", order " << order;
            }
            const GpuBake single = bakeEquirect(context(), baker, sizes.images.back());
            EXPECT_EQ(single.radiance.rgb, bakes.back().radiance.rgb) << "order " << order;
            EXPECT_EQ(single.irradiance.rgb, bakes.back().irradiance.rgb) << "order " << order;
        }
    }
    RecordProperty("worst error", std::to_string(worst));
}

// Checks (white furnace): a constant map c gives L_00 = c sqrt(4 pi), as the exact row solid angles
// sum to 4 pi, within the GPU tolerance. The even zonal harmonics about +Y keep the midpoint-rule
// error the reference has too (test_projection), so the other coefficients and the irradiance are
// held to the reference and its convolution.
TEST_F(GpuEquirect, ConstantMapGivesExactDc) {
    const float c = 0.75f;
    Image image = makeImage(64, 32);
    std::fill(image.texels.begin(), image.texels.end(), glm::vec4(c, c, c, 1.0f));
    GpuBake gpu = bakeEquirect(context(), sharedBaker(3), image);
    const double l00 = c * std::sqrt(4.0 * M_PI);
    for (int channel = 0; channel < 3; ++channel)
        EXPECT_NEAR(gpu.radiance.rgb[0][channel], l00, kGpuTolerance * l00);
    const ShCoefficients reference = projectEquirect(image, 3);
    EXPECT_LT(relativeError(gpu.radiance, reference), kGpuTolerance);
    EXPECT_LT(relativeError(gpu.irradiance, convolveIrradiance(reference)), kGpuTolerance);
}

// A single lit pixel puts all the weight on one direction, so its coefficients carry the fp32
// rounding of that direction undiluted: at l = 7 the basis changes by up to about l |y_lm| per unit
// of angle, and a direction a few ulps off moves y_7m by about 1e-6 (measured up to 2.9e-6 of
// |L_00| at the equator, where |y_7m| / y_00 reaches 2.6). Over a whole map these errors average
// out (kGpuTolerance); for one pixel the bound is twice the measurement, still far below what a
// wrong pixel, weight or sign gives (errors of order 1).
constexpr double kSinglePixelGpuTolerance = 6e-6;

// Checks (closed form): each pixel alone on small maps (an odd W / 2, an odd W, an odd H) projects
// to c Omega_j y_k(d) at order 8, with every pixel's own direction and its row's solid angle
// wherever it lies among the eight of its position. (One bake per map: views of one layer, the
// classes MatchesReferenceAtEverySizeAndOrder compiles at order 8.)
TEST_F(GpuEquirect, EveryPixelAloneIsBasisTimesSolidAngle) {
    const glm::vec4 c(1.0f, 2.0f, 3.0f, 1.0f);
    double worst = 0.0;
    const ProbeBaker& baker = sharedBaker(kMaxOrder);
    for (const auto& [width, height] : {std::pair{6, 3}, std::pair{5, 3}}) {
        for (int j = 0; j < height; ++j)
            for (int i = 0; i < width; ++i) {
                Image image = makeImage(width, height);
                image.at(i, j) = c;
                ShCoefficients expected = makeCoefficients(kMaxOrder, Quantity::Radiance);
                std::array<double, coefficientCount(kMaxOrder)> basis{};
                evalBasis(kMaxOrder, equirectDirection(i, j, width, height), basis);
                for (size_t k = 0; k < basis.size(); ++k)
                    expected.rgb[k] = glm::dvec3(c) * (basis[k] * equirectRowSolidAngle(j, width, height));
                const double error = relativeError(bakeEquirect(context(), baker, image).radiance, expected);
                worst = std::max(worst, error);
                EXPECT_LT(error, kSinglePixelGpuTolerance)
                    << width << " x " << height << ", pixel (" << i << ", " << j << ")";
            }
    }
    RecordProperty("worst error", std::to_string(worst));
}

// Checks: any workgroup width and any work per invocation give the reference's sums (one subgroup,
// more subgroups than a subgroup has lanes, partial subgroups), for an even and an odd width.
TEST_F(GpuEquirect, WorkgroupShapesDoNotChangeTheResult) {
    const Image images[] = {noiseEquirect(30, 14, 21), noiseEquirect(29, 15, 22)};
    const Image* batch[] = {&images[0], &images[1]};
    for (uint32_t width : {1u, 3u, 100u}) {
        for (uint32_t perInvocation : {1u, 256u}) {
            ProbeBaker baker =
                equirectBaker({.order = 3, .workgroupSize = width, .texelsPerInvocation = perInvocation});
            const std::vector<GpuBake> bakes = bakeEquirects(context(), baker, batch);
            destroyProbeBaker(context(), baker);
            for (size_t k = 0; k < 2; ++k)
                EXPECT_LT(relativeError(bakes[k].radiance, projectEquirect(images[k], 3)), kGpuTolerance)
                    << images[k].width << " x " << images[k].height << ", workgroup " << width
                    << ", texels per invocation " << perInvocation;
        }
    }
}

// Checks: far more texels per invocation than lavapipe's loop cap allows still give the right sums,
// as the baker caps the positions per invocation by order (maxEquirectPositionsPerInvocation):
// 768 x 384 is 192 x 192 positions, and one 8-wide workgroup would loop 4608 times per invocation,
// with 18 basis-recurrence iterations in each at order 8 (at order 1, 4608 is within the cap).
TEST_F(GpuEquirect, HugeWorkPerInvocationStaysCorrect) {
    const Image image = noiseEquirect(768, 384, 23);
    const ShCoefficients reference = projectEquirect(image, kMaxOrder);
    for (int order : {3, kMaxOrder}) {
        ProbeBaker baker =
            equirectBaker({.order = order, .workgroupSize = 8, .texelsPerInvocation = 1u << 20});
        GpuBake gpu = bakeEquirect(context(), baker, image);
        destroyProbeBaker(context(), baker);
        EXPECT_LT(relativeError(gpu.radiance, truncated(reference, order)), kGpuTolerance)
            << "order " << order;
    }
}

// Checks: RGBA16F input (project_equirect_rgba16f.comp) matches the reference of the half-rounded
// values; values beyond the half range are refused.
TEST_F(GpuEquirect, HalfFloatInputMatchesTheReferenceOfItsValues) {
    Image image = noiseEquirect(48, 24, 24);
    image.at(5, 20) = glm::vec4(6e4f, 5e4f, 4e4f, 1.0f); // a sun within the half range
    Image rounded = image;
    rounded.texels = halfRounded(image.texels);
    ProbeBaker baker = equirectBaker({.order = 3}, TexelFormat::Rgba16F);
    EXPECT_LT(relativeError(bakeEquirect(context(), baker, image).radiance, projectEquirect(rounded, 3)),
              kGpuTolerance);
    image.at(0, 0) = glm::vec4(1e5f, 0.0f, 0.0f, 1.0f);
    EXPECT_THROW(bakeEquirect(context(), baker, image), Error);
    destroyProbeBaker(context(), baker);
}

// Checks: a baker made for one source refuses the other's targets and sets, empty or inconsistent
// maps are refused, and so are sizes the device cannot hold.
TEST_F(GpuEquirect, RefusesWhatItCannotBake) {
    ProbeBaker cubeBaker = hostBaker({.order = 3});
    const ProbeBaker& baker = sharedBaker(3);
    const Image image = noiseEquirect(8, 4, 25);
    EXPECT_THROW(bakeEquirect(context(), cubeBaker, image), Error) << "a cube-map baker";
    EXPECT_THROW(bakeCubemap(context(), baker, noiseCubemap(4, 26)), Error) << "an equirect baker";
    EXPECT_THROW(bakeEquirect(context(), baker, Image{}), Error) << "no pixels";
    Image truncatedImage = image;
    truncatedImage.texels.pop_back();
    EXPECT_THROW(bakeEquirect(context(), baker, truncatedImage), Error) << "texel count";
    Buffer output =
        createBuffer(context(), 4096, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback, "out");
    GpuImage gpuImage = createImage(
        context(), {.extent = {8, 4}, .usage = VK_IMAGE_USAGE_STORAGE_BIT, .what = "equirect", .layers = 2});
    EXPECT_THROW(createEquirectBakeSet(context(), baker, {gpuImage.view, 0, 4, 2, output.buffer, 0}), Error)
        << "width 0";
    EXPECT_THROW(createEquirectBakeSet(
                     context(), baker,
                     {gpuImage.view, 8, context().info.limits.maxImageDimension2D + 1, 2, output.buffer, 0}),
                 Error)
        << "too high";
    EXPECT_THROW(createEquirectBakeSet(context(), cubeBaker, {gpuImage.view, 8, 4, 2, output.buffer, 0}),
                 Error)
        << "a cube-map baker";
    EXPECT_THROW(createProbeBakeSet(context(), baker, {gpuImage.view, 4, 1, output.buffer, 0}), Error)
        << "a cube-map target for an equirect baker";
    destroyImage(context(), gpuImage);
    destroyBuffer(context(), output);
    destroyProbeBaker(context(), cubeBaker);
}

// Checks, on each HDR of Debian's blender-data (eight 1024 x 512 equirect maps of Blender's studio
// lights, real skies with suns and dark interiors): the GPU bake and the fast CPU path at orders 3, 5
// and 8 within 1e-6 of |L_00| of the double reference, the target. One reference projection
// of each map at order 8 serves all three orders (the lower orders are its first coefficients).
// Each map is baked alone, as `shprobe bake` bakes one file (views of one layer).
TEST_F(GpuEquirect, BlenderStudioLightsWithinTarget) {
    const std::filesystem::path folder = "/usr/share/blender/datafiles/studiolights/world";
    if (!std::filesystem::is_directory(folder))
        GTEST_SKIP() << folder << " is missing (Debian package blender-data)";
    std::vector<std::filesystem::path> paths;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
        if (entry.path().extension() == ".exr") paths.push_back(entry.path());
    std::sort(paths.begin(), paths.end());
    ASSERT_EQ(paths.size(), 8u);
    std::vector<Image> images;
    std::vector<ShCoefficients> references;
    for (const auto& path : paths) {
        images.push_back(readImage(path.string()));
        references.push_back(projectEquirect(images.back(), kMaxOrder));
    }
    for (int order : {3, 5, kMaxOrder}) {
        double worstGpu = 0.0, worstFast = 0.0;
        for (size_t k = 0; k < images.size(); ++k) {
            const ShCoefficients reference = truncated(references[k], order);
            const double gpu =
                relativeError(bakeEquirect(context(), sharedBaker(order), images[k]).radiance, reference);
            const double fast = relativeError(projectEquirectFast(images[k], order), reference);
            worstGpu = std::max(worstGpu, gpu);
            worstFast = std::max(worstFast, fast);
            std::printf("%s, order %d: error / |L_00| GPU %.2e, fast CPU %.2e\n", paths[k].filename().c_str(),
                        order, gpu, fast);
            EXPECT_LT(gpu, 1e-6) << paths[k].filename() << ", GPU, order " << order;
            EXPECT_LT(fast, 1e-6) << paths[k].filename() << ", fast CPU, order " << order;
        }
        std::printf("blender-data, order %d: worst error / |L_00| GPU %.2e, fast CPU %.2e\n", order, worstGpu,
                    worstFast);
        RecordProperty("order " + std::to_string(order) + " GPU", std::to_string(worstGpu));
        RecordProperty("order " + std::to_string(order) + " fast CPU", std::to_string(worstFast));
    }
}

// The renderer's path for equirect maps (probe_baker.h): the caller's own sampled image, viewed as a
// 2D array (two layers of one size; and one layer of a plain 2D image, through a 2D-array view of
// it), the caller's command buffer and output buffer at an offset, a second bake of the first set,
// and no submission by the library. This runs project_equirect.comp, the sampled-image module.
TEST_F(GpuResidentBake, RecordsEquirectBakesIntoTheCallersCommandBuffer) {
    const int order = 3;
    Device device = borrowDevice({context().physicalDevice, context().device, context().queueFamily});
    ProbeBaker baker = createProbeBaker(device, {.order = order, .source = ProbeSource::Equirect});
    ASSERT_EQ(baker.options.cubemaps, CubemapBinding::SampledImage);
    const std::vector<Image> first = {noiseEquirect(40, 20, 31), hotPixelEquirect(40, 20, 32)};
    const Image second = noiseEquirect(17, 9, 33);
    const VkDeviceSize alignment = device.info.limits.minStorageBufferOffsetAlignment;
    const VkDeviceSize firstOffset = alignment;
    const VkDeviceSize secondOffset =
        firstOffset + (probeBakeOutputBytes(order, 2) + alignment - 1) / alignment * alignment;
    Buffer output =
        createBuffer(device, secondOffset + probeBakeOutputBytes(order, 1),
                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::Readback, "caller's coefficients");
    const std::span<const glm::vec4> firstTexels[] = {first[0].texels, first[1].texels};
    const std::span<const glm::vec4> secondTexels[] = {second.texels};
    Probes firstProbes, secondProbes;
    VkImageView secondView = VK_NULL_HANDLE;
    ProbeBakeSet firstSet, secondSet;
    recordTwoSetsInOneSubmission(
        baker,
        [&](VkCommandBuffer commands) {
            firstProbes = upload({40, 20}, 2, firstTexels, commands);
            secondProbes = upload({17, 9}, 1, secondTexels, commands);
            secondView = createImageView(device, secondProbes.image.image, VK_IMAGE_VIEW_TYPE_2D_ARRAY,
                                         secondProbes.image.format, 1);
            firstSet = createEquirectBakeSet(device, baker,
                                             {firstProbes.image.view, 40, 20, 2, output.buffer, firstOffset});
            secondSet =
                createEquirectBakeSet(device, baker, {secondView, 17, 9, 1, output.buffer, secondOffset});
        },
        firstSet, secondSet);
    invalidateBuffer(device, output);
    for (uint32_t k = 0; k < 2; ++k)
        expectOutputProbe(output, firstOffset, 2, k, projectEquirect(first[k], order));
    expectOutputProbe(output, secondOffset, 1, 0, projectEquirect(second, order));
    EXPECT_THROW(recordProbeBake(VK_NULL_HANDLE, ProbeBaker{}, firstSet), Error)
        << "a set recorded with a baker of the other source";

    destroyProbeBakeSet(device, secondSet);
    destroyProbeBakeSet(device, firstSet);
    vkDestroyImageView(device.device, secondView, nullptr);
    for (Probes* probes : {&firstProbes, &secondProbes}) {
        destroyImage(context(), probes->image);
        destroyBuffer(context(), probes->staging);
    }
    destroyBuffer(device, output);
    destroyProbeBaker(device, baker);
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
