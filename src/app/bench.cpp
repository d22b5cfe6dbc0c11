// `shprobe bench`: how fast each projection path runs, measured in one run on the same generated
// inputs against the machine's own bound: a plain multithreaded pass that reads the same texel
// bytes once. The inputs are held as RGBA32F and as RGBA16F (the same values, which halves
// represent exactly), and each path is compared with the bound of the bytes it reads. Every figure
// is the best of --repeat runs; ratios, not absolute times, are what compare across machines.
#include "app/bench.h"
#include "app/bench_device.h"
#include "app/parsed_option.h"
#include "app/program.h"
#include "app/stopwatch.h"
#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/scope_exit.h"
#include "glsl/dispatch_plan.h"
#include "gpu/host_bake.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/fast_projection.h"
#include "sh/projection.h"
#include "vk/context.h"

#include <glm/gtc/packing.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <span>
#include <thread>

namespace shprobe {

namespace {

struct Measurement {
    int faceSize;
    const char* format; // of the texels the path reads
    int order;          // 0 for the memory-read bound
    std::string path;
    double milliseconds;
    double texelsPerSecond;
    double bytesPerSecond; // the texel bytes the path reads, per second
    double fractionOfBound;
    const char* bound;       // what fractionOfBound is against (Bench::kBoundNames)
    double errorToReference; // max |c - reference| / |L_00|; negative when not measured
};

// The same noise as RGBA32F and as RGBA16F: values in [0, 1) rounded to half precision, so that both
// formats hold them exactly and one reference serves both.
struct BenchInput {
    Cubemap rgba32f;
    std::vector<uint64_t> rgba16f; // one texel (four halves) per word
};

BenchInput noiseInput(int faceSize) {
    BenchInput input{makeCubemap(faceSize), {}};
    input.rgba16f.resize(input.rgba32f.texels.size());
    std::mt19937 random{uint32_t(faceSize)};
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (size_t t = 0; t < input.rgba16f.size(); ++t) {
        input.rgba16f[t] = glm::packHalf4x16({uniform(random), uniform(random), uniform(random), 1.0f});
        input.rgba32f.texels[t] = glm::unpackHalf4x16(input.rgba16f[t]);
    }
    return input;
}

std::span<const std::byte> bytesOf(const BenchInput& input, TexelFormat format) {
    return format == TexelFormat::Rgba32F ? std::as_bytes(std::span(input.rgba32f.texels))
                                          : std::as_bytes(std::span(input.rgba16f));
}

const char* formatName(TexelFormat format) {
    return format == TexelFormat::Rgba32F ? "RGBA32F" : "RGBA16F";
}

} // namespace

double bestMilliseconds(int repeat, const std::function<void()>& f) {
    double best = INFINITY;
    for (int r = 0; r < repeat; ++r) {
        Clock::time_point start = Clock::now();
        f();
        best = std::min(best, millisecondsSince(start));
    }
    return best;
}

namespace {

// Sum of the 64-bit words of bytes, in eight independent sums (one cache line per step, which the
// compiler turns into vector additions) so that the loads, not the additions, set the pace.
uint64_t sumWords(std::span<const std::byte> bytes) {
    std::array<uint64_t, 8> sums{};
    const size_t words = bytes.size() / sizeof(uint64_t);
    const auto add = [&](size_t word, size_t sum) {
        uint64_t loaded;
        std::memcpy(&loaded, bytes.data() + word * sizeof(uint64_t), sizeof(loaded));
        sums[sum] += loaded;
    };
    size_t word = 0;
    for (; word + sums.size() <= words; word += sums.size()) {
        for (size_t s = 0; s < sums.size(); ++s)
            add(word + s, s);
    }
    for (; word < words; ++word)
        add(word, 0);
    uint64_t total = 0;
    for (uint64_t sum : sums)
        total += sum;
    return total;
}

} // namespace

// The threads take 1 MiB parts in turn, as the fast CPU path takes its blocks, so that a core lent
// to another process slows both alike.
double memoryReadMilliseconds(std::span<const std::byte> bytes, int repeat) {
    constexpr size_t kPartBytes = size_t(1) << 20;
    const size_t partsPerPass = (bytes.size() + kPartBytes - 1) / kPartBytes;
    const size_t passes = std::max<size_t>(1, (size_t(256) << 20) / bytes.size());
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<uint64_t> sums(threads);
    double ms = bestMilliseconds(repeat, [&] {
        std::atomic<size_t> nextPart{0};
        std::vector<std::thread> workers;
        for (unsigned t = 0; t < threads; ++t)
            workers.emplace_back([&, t] {
                for (size_t part = nextPart++; part < passes * partsPerPass; part = nextPart++) {
                    const size_t offset = part % partsPerPass * kPartBytes;
                    const size_t size = std::min(kPartBytes, bytes.size() - offset);
                    sums[t] += sumWords(bytes.subspan(offset, size));
                }
            });
        for (std::thread& worker : workers)
            worker.join();
    });
    volatile uint64_t keep = sums[0]; // the sums must be computed
    (void)keep;
    return ms / double(passes);
}

namespace {

double errorToReference(const ShCoefficients& coefficients, const ShCoefficients& reference) {
    double worst = 0.0;
    for (size_t i = 0; i < reference.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(coefficients.rgb[i][c] - reference.rgb[i][c]));
    const glm::dvec3& dc = reference.rgb[0];
    return worst / std::max({std::abs(dc.r), std::abs(dc.g), std::abs(dc.b)});
}

// A memcpy of the bytes into memory already written once (no page faults), best of `repeat`: what
// putting the texels where a CPU device reads them would cost.
double memcpyMilliseconds(std::span<const std::byte> bytes, int repeat) {
    std::vector<std::byte> destination(bytes.size());
    return bestMilliseconds(repeat, [&] { std::memcpy(destination.data(), bytes.data(), bytes.size()); });
}

// The float arithmetic project.comp does for one probe, per face pair and position: the signed sums
// (24 vec3 additions, 72) and, per coefficient, the accumulation (a multiply by the weight and three
// multiply-adds) and the basis (about three: each recurrence step is a multiply, a multiply-add and
// a multiply; the closed forms of bands 0-4 take no more), 72 + 7 n^2 in all. The walk, the
// direction and the solid angle (a few dozen a position, at any order) are not counted, so the
// bound it gives is optimistic.
double projectionMultiplyAdds(int faceSize, int order) {
    constexpr double kFacePairs = 3.0;
    return double(glsl::projectionPositions(uint32_t(faceSize))) * kFacePairs * (72.0 + 7.0 * order * order);
}

// What a row's fraction is against, each measured in the same run on the same bytes.
enum class Bound {
    CpuRead,              // memoryReadMilliseconds: the CPU rows
    DeviceRead,           // the faster of read_buffer.comp and a buffer copy: the device rows
    DeviceArithmetic,     // the projection's multiply-adds at the device's rate (multiply_adds.comp)
    Transfer,             // a host-to-device copy from pinned memory: the uploads
    TransferAndProjection // the transfer, then the projection on the device: a whole GPU bake
};

// The names of Bound in the report's `against` column and JSON `bound`.
constexpr const char* kBoundNames[] = {"cpu read", "gpu read", "gpu arith", "transfer", "xfer+proj"};

class Bench {
  public:
    Bench(const BenchOptions& options, Context& context, double multiplyAddsPerSecond)
        : options_(options), context_(context), multiplyAddsPerSecond_(multiplyAddsPerSecond),
          report_(reportStream(options.json)) {}

    void runFaceSize(int faceSize) {
        const BenchInput input = noiseInput(faceSize);
        texels_ = double(input.rgba32f.texels.size());
        for (TexelFormat format : kFormats) {
            const std::span<const std::byte> bytes = bytesOf(input, format);
            Bounds& bounds = bounds_[size_t(format)];
            bounds.cpuReadMs = memoryReadMilliseconds(bytes, options_.repeat);
            add(faceSize, format, 0, "cpu memory read (bound)", bounds.cpuReadMs, -1.0, Bound::CpuRead);
            add(faceSize, format, 0, "cpu memcpy", memcpyMilliseconds(bytes, options_.repeat), -1.0,
                Bound::CpuRead);
            bounds.device = measureDeviceBounds(context_, bytes, options_.repeat);
            if (bounds.device.readMilliseconds <= 0.0) continue; // no timestamps
            add(faceSize, format, 0, "gpu buffer read (device)", bounds.device.readMilliseconds, -1.0,
                Bound::DeviceRead);
            add(faceSize, format, 0, "gpu buffer copy (device)", bounds.device.copyMilliseconds, -1.0,
                Bound::DeviceRead);
            add(faceSize, format, 0, "host-to-device copy, pinned (transfer bound)",
                bounds.device.transferMilliseconds, -1.0, Bound::Transfer);
        }
        // read_texels reads the texels as the projection does: its access pattern's own bound, from
        // the image and from a buffer.
        for (TexelFormat format : kFormats) {
            const TexelReads reads =
                deviceTexelReads(context_, input.rgba32f, bytesOf(input, format), format, options_.repeat);
            if (reads.imageMilliseconds > 0.0)
                add(faceSize, format, 0, "gpu texel reads only (device)", reads.imageMilliseconds, -1.0,
                    Bound::DeviceRead);
            if (reads.bufferMilliseconds > 0.0)
                add(faceSize, format, 0, "gpu texel reads only, buffer (device)", reads.bufferMilliseconds,
                    -1.0, Bound::DeviceRead);
        }
        for (int order : options_.orders)
            runOrder(input, order);
    }

    const std::vector<Measurement>& measurements() const { return measurements_; }

  private:
    static constexpr std::array<TexelFormat, 2> kFormats{TexelFormat::Rgba32F, TexelFormat::Rgba16F};

    // One format's bounds, and the projection's device time of the order being measured.
    struct Bounds {
        double cpuReadMs = 0.0;
        DeviceBounds device;
        double projectionMs = 0.0;
    };

    double boundMilliseconds(TexelFormat format, Bound bound) const {
        const Bounds& bounds = bounds_[size_t(format)];
        switch (bound) {
        case Bound::CpuRead:
            return bounds.cpuReadMs;
        case Bound::DeviceRead: // a copy reads every byte too, and on some devices sooner
            return std::min(bounds.device.readMilliseconds, bounds.device.copyMilliseconds);
        case Bound::DeviceArithmetic:
            return arithmeticMs_;
        case Bound::Transfer:
            return bounds.device.transferMilliseconds;
        case Bound::TransferAndProjection:
            return bounds.device.transferMilliseconds + bounds.projectionMs;
        }
        return 0.0;
    }

    void runOrder(const BenchInput& input, int order) {
        const Cubemap& cubemap = input.rgba32f;
        ShCoefficients reference;
        bool haveReference = cubemap.faceSize <= options_.referenceMaxFaceSize;
        if (haveReference) {
            double ms = bestMilliseconds(1, [&] { reference = projectCubemap(cubemap, order); });
            add(cubemap.faceSize, TexelFormat::Rgba32F, order, "cpu reference (double)", ms, 0.0,
                Bound::CpuRead);
        }
        arithmeticMs_ = 0.0;
        if (multiplyAddsPerSecond_ > 0.0) {
            arithmeticMs_ = projectionMultiplyAdds(cubemap.faceSize, order) / multiplyAddsPerSecond_ * 1e3;
            add(cubemap.faceSize, TexelFormat::Rgba32F, order, "gpu multiply-adds at peak (arithmetic bound)",
                arithmeticMs_, -1.0, Bound::DeviceArithmetic);
        }
        for (TexelFormat format : kFormats)
            runGpu(cubemap, format, order, haveReference ? &reference : nullptr);
        for (TexelFormat format : kFormats)
            runCpuFast(input, format, order, haveReference ? &reference : nullptr);
    }

    void runGpu(const Cubemap& cubemap, TexelFormat format, int order, const ShCoefficients* reference) {
        ProbeBaker baker =
            createProbeBaker(context_, {.order = order, .cubemaps = uploadBinding(context_, format)});
        ScopeExit destroyBaker([&] { destroyProbeBaker(context_, baker); });
        GpuBake bake = bakeCubemap(context_, baker, cubemap); // untimed: llvmpipe compiles at first use
        double deviceMs = INFINITY;
        double wallMs = bestMilliseconds(options_.repeat, [&] {
            bake = bakeCubemap(context_, baker, cubemap);
            deviceMs = std::min(deviceMs, bake.deviceMilliseconds);
        });
        const double error = reference ? errorToReference(bake.radiance, *reference) : -1.0;
        bounds_[size_t(format)].projectionMs = bake.deviceMilliseconds > 0.0 ? deviceMs : 0.0;
        // Against the slower of its two bounds (a roofline): reading the texels or doing the arithmetic.
        const Bound bound =
            boundMilliseconds(format, Bound::DeviceArithmetic) > boundMilliseconds(format, Bound::DeviceRead)
                ? Bound::DeviceArithmetic
                : Bound::DeviceRead;
        if (bake.deviceMilliseconds > 0.0)
            add(cubemap.faceSize, format, order, "gpu projection (device)", deviceMs, error, bound);
        add(cubemap.faceSize, format, order, "gpu bake (wall: upload, dispatch, readback)", wallMs, error,
            Bound::TransferAndProjection);
    }

    // The fast CPU path on all cores, reading the texels in `format`.
    void runCpuFast(const BenchInput& input, TexelFormat format, int order, const ShCoefficients* reference) {
        const void* texels = bytesOf(input, format).data();
        const int faceSize = input.rgba32f.faceSize;
        const FastProjectionOptions fast{.threads = std::max(1u, std::thread::hardware_concurrency())};
        ShCoefficients result;
        const auto project = [&] { result = projectFacesFast(texels, format, faceSize, order, fast); };
        const double ms = bestMilliseconds(options_.repeat, project);
        const std::string path = "cpu fast (float, " + std::to_string(fast.threads) + " threads)";
        add(faceSize, format, order, path, ms, reference ? errorToReference(result, *reference) : -1.0,
            Bound::CpuRead);
    }

    void add(int faceSize, TexelFormat format, int order, const std::string& path, double ms, double error,
             Bound bound) {
        const double rate = texels_ / (ms * 1e-3);
        const double bytes = rate * double(texelBytes(format));
        const double boundMs = boundMilliseconds(format, bound);
        measurements_.push_back({faceSize, formatName(format), order, path, ms, rate, bytes, boundMs / ms,
                                 kBoundNames[size_t(bound)], error});
        const Measurement& m = measurements_.back();
        std::fprintf(report_, "%6d  %-7s  %5s  %-46s %10.2f %10.1f %7.2f %8.1f%% %-10s", m.faceSize, m.format,
                     order ? std::to_string(order).c_str() : "-", m.path.c_str(), m.milliseconds,
                     m.texelsPerSecond * 1e-6, m.bytesPerSecond * 1e-9, m.fractionOfBound * 100.0, m.bound);
        if (m.errorToReference >= 0.0) std::fprintf(report_, "  %.1e", m.errorToReference);
        std::fprintf(report_, "\n");
        std::fflush(report_);
    }

    const BenchOptions& options_;
    Context& context_;
    double multiplyAddsPerSecond_; // 0 without timestamps
    FILE* report_;                 // the table: stderr where the JSON goes to standard output
    double arithmeticMs_ = 0.0;    // the order being measured: projectionMultiplyAdds at that rate
    double texels_ = 0.0;
    std::array<Bounds, kFormats.size()> bounds_{}; // indexed by TexelFormat
    std::vector<Measurement> measurements_;
};

using PipelineCreations = std::vector<std::pair<int, PipelineCreation>>;

// The pipelines of each order created with an empty cache, then from the first one's data read back
// from a file: what a second run of the program saves, if the driver caches anything.
PipelineCreations measurePipelines(const Device& device, const std::vector<int>& orders, FILE* report) {
    std::fprintf(report, "\npipeline creation (project, reduce, convolve)\n%5s %12s %14s %12s\n", "order",
                 "first ms", "from cache ms", "cache bytes");
    PipelineCreations creations;
    for (int order : orders) {
        PipelineCreation creation = measurePipelineCreation(device, order);
        std::fprintf(report, "%5d %12.2f %14.2f %12zu\n", order, creation.firstMilliseconds,
                     creation.cachedMilliseconds, creation.cacheBytes);
        creations.emplace_back(order, creation);
    }
    return creations;
}

nlohmann::ordered_json reportJson(const Device& device, double multiplyAddsPerSecond,
                                  const std::vector<Measurement>& measurements,
                                  const PipelineCreations& pipelineCreations) {
    nlohmann::ordered_json report;
    report["device"] = device.info.name;
    report["driver"] = device.info.driver;
    report["device_type"] = deviceTypeName(device.info.type);
    report["subgroup_size"] = device.info.subgroupSize;
    report["threads"] = std::thread::hardware_concurrency();
    report["multiply_adds_per_second"] = multiplyAddsPerSecond;
    report["input"] = "noise in [0, 1), half-representable, 6 faces; RGBA32F and RGBA16F";
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (const Measurement& m : measurements) {
        nlohmann::ordered_json row;
        row["face_size"] = m.faceSize;
        row["format"] = m.format;
        row["order"] = m.order;
        row["path"] = m.path;
        row["milliseconds"] = m.milliseconds;
        row["texels_per_second"] = m.texelsPerSecond;
        row["bytes_per_second"] = m.bytesPerSecond;
        row["fraction_of_bound"] = m.fractionOfBound;
        row["bound"] = m.bound;
        if (m.errorToReference >= 0.0) row["max_error_relative_to_L00"] = m.errorToReference;
        rows.push_back(row);
    }
    report["measurements"] = rows;
    nlohmann::ordered_json pipelines = nlohmann::ordered_json::array();
    for (const auto& [order, creation] : pipelineCreations)
        pipelines.push_back({{"order", order},
                             {"first_milliseconds", creation.firstMilliseconds},
                             {"cached_milliseconds", creation.cachedMilliseconds},
                             {"cache_bytes", creation.cacheBytes}});
    report["pipeline_creation"] = pipelines;
    return report;
}

// Sizes no cube map can have, or that bake would refuse, are refused before the device starts.
std::vector<int> checkedFaceSizes(const std::vector<int>& faceSizes) {
    for (int faceSize : faceSizes) {
        requireFaceSize(faceSize);
        if (faceSize > kMaxGpuFaceSize)
            throw Error(ErrorKind::Input, "--sizes: " + std::to_string(faceSize) + " is more than the " +
                                              std::to_string(kMaxGpuFaceSize) +
                                              " a bake takes as --face-size");
    }
    return faceSizes;
}

} // namespace

void addBenchOptions(CLI::App& command, BenchOptions& options) {
    addParsedOption<std::vector<int>>(command, "--sizes", options.faceSizes, checkedFaceSizes, "Face sizes")
        ->default_str("[" + CLI::detail::join(options.faceSizes) + "]");
    addRangeOption(command, "--orders", options.orders, "SH orders", 1, kMaxOrder);
    addRangeOption(command, "--repeat", options.repeat, "Runs per measurement (the best counts)", 1, 100);
    command
        .add_option("--reference-max-size", options.referenceMaxFaceSize,
                    "Largest face size for the (slow) double reference")
        ->capture_default_str();
    command.add_option("--json", options.json, "Also write the measurements to this JSON file")
        ->check(nonEmptyName());
    command.add_option("--device", options.device, "Vulkan device index or name part");
}

void runBench(const BenchOptions& options) {
    if (!options.json.empty()) checkOutputPath(options.json);
    ContextOptions contextOptions;
    contextOptions.device = options.device;
    Context context = createContext(contextOptions);
    ScopeExit destroy([&] { destroyContext(context); });
    FILE* report = reportStream(options.json); // the table: stderr where the JSON goes to standard output
    std::fprintf(report, "device: %s (%s), %s, subgroup size %u; CPU threads: %u\n",
                 context.info.name.c_str(), deviceTypeName(context.info.type), context.info.driver.c_str(),
                 context.info.subgroupSize, std::thread::hardware_concurrency());
    if (context.info.type == VK_PHYSICAL_DEVICE_TYPE_CPU)
        std::fprintf(report,
                     "the device is a CPU: its bounds (gpu buffer read, copy, transfer) are passes over CPU "
                     "memory\n");
    const double multiplyAdds = multiplyAddsPerSecond(context, options.repeat);
    if (multiplyAdds > 0.0)
        std::fprintf(report, "device float multiply-adds: %.1f G/s (the arithmetic bound's rate)\n",
                     multiplyAdds * 1e-9);
    std::fprintf(report, "%6s  %-7s  %5s  %-46s %10s %10s %7s %9s %-10s %s\n", "face", "format", "order",
                 "path", "ms", "Mtexel/s", "GB/s", "of bound", "against", "error/|L00|");
    Bench bench(options, context, multiplyAdds);
    for (int faceSize : options.faceSizes)
        bench.runFaceSize(faceSize);
    const PipelineCreations pipelineCreations = measurePipelines(context, options.orders, report);
    // With the validation layer (SHPROBE_VALIDATION=1), a message fails the run as it fails a bake.
    if (uint32_t messages = context.validationMessages(); messages > 0)
        throw Error(ErrorKind::Device, counted(messages, "Vulkan validation message") + " (above)");
    if (!options.json.empty())
        writeOutputFile(options.json,
                        reportJson(context, multiplyAdds, bench.measurements(), pipelineCreations).dump(2) +
                            "\n");
}

} // namespace shprobe
