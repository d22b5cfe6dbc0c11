// `shprobe bench`: how fast each projection path runs, measured in one run on the same generated
// inputs against the machine's own bound: a plain multithreaded pass that reads the same texel
// bytes once. Every figure is the best of --repeat runs; ratios, not absolute times, are what
// compare across machines.
#include "app/bench.h"
#include "gpu/projector.h"
#include "io/atomic_file.h"
#include "sh/basis.h"
#include "sh/projection.h"
#include "vk/context.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

namespace shprobe {

namespace {

using Clock = std::chrono::steady_clock;

struct Measurement {
    int faceSize;
    int order;      // 0 for the memory-read bound
    std::string path;
    double milliseconds;
    double texelsPerSecond;
    double fractionOfBound;
    double errorToReference; // max |c - reference| / |L_00|; negative when not measured
};

Cubemap noiseCubemap(int faceSize) {
    Cubemap cubemap = makeCubemap(faceSize);
    std::mt19937 random{uint32_t(faceSize)};
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (glm::vec4& texel : cubemap.texels) texel = {uniform(random), uniform(random), uniform(random), 1.0f};
    return cubemap;
}

// Best wall time of `repeat` runs of f, in milliseconds.
double bestMilliseconds(int repeat, const std::function<void()>& f) {
    double best = INFINITY;
    for (int r = 0; r < repeat; ++r) {
        Clock::time_point start = Clock::now();
        f();
        best = std::min(best, std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
    return best;
}

// Reads every texel on all cores (four independent sums per thread so the loads, not the additions,
// set the pace), repeating the pass until at least 256 MiB were read so that starting the threads
// does not count; returns the time of one pass. Nothing that reads the data can beat this here.
double memoryReadMilliseconds(const Cubemap& cubemap, int repeat) {
    const size_t count = cubemap.texels.size();
    const size_t passes = std::max<size_t>(1, (size_t(256) << 20) / (count * sizeof(glm::vec4)));
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<float> sums(threads);
    double ms = bestMilliseconds(repeat, [&] {
        std::vector<std::thread> workers;
        for (unsigned t = 0; t < threads; ++t)
            workers.emplace_back([&, t] {
                const glm::vec4* texels = cubemap.texels.data();
                glm::vec4 sum(0.0f);
                for (size_t pass = 0; pass < passes; ++pass)
                    for (size_t i = count * t / threads; i < count * (t + 1) / threads; ++i) sum += texels[i];
                sums[t] = sum.x + sum.y + sum.z + sum.w;
            });
        for (std::thread& worker : workers) worker.join();
    });
    volatile float keep = sums[0]; // the sums must be computed
    (void)keep;
    return ms / double(passes);
}

double errorToReference(const ShCoefficients& coefficients, const ShCoefficients& reference) {
    double worst = 0.0;
    for (size_t i = 0; i < reference.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(coefficients.rgb[i][c] - reference.rgb[i][c]));
    const glm::dvec3& dc = reference.rgb[0];
    return worst / std::max({std::abs(dc.r), std::abs(dc.g), std::abs(dc.b)});
}

class Bench {
public:
    Bench(const BenchOptions& options, Context& context) : options_(options), context_(context) {}

    void runFaceSize(int faceSize) {
        Cubemap cubemap = noiseCubemap(faceSize);
        texels_ = double(cubemap.texels.size());
        boundMs_ = memoryReadMilliseconds(cubemap, options_.repeat);
        add(faceSize, 0, "memory read (bound)", boundMs_, -1.0);
        for (int order : options_.orders) runOrder(cubemap, order);
    }

    const std::vector<Measurement>& measurements() const { return measurements_; }

private:
    void runOrder(const Cubemap& cubemap, int order) {
        ShCoefficients reference;
        bool haveReference = cubemap.faceSize <= options_.referenceMaxFaceSize;
        if (haveReference) {
            double ms = bestMilliseconds(1, [&] { reference = projectCubemap(cubemap, order); });
            add(cubemap.faceSize, order, "cpu reference (double)", ms, 0.0);
        }
        Projector projector = createProjector(context_, {.order = order});
        GpuBake bake;
        double deviceMs = INFINITY;
        double wallMs = bestMilliseconds(options_.repeat, [&] {
            bake = bakeCubemap(context_, projector, cubemap);
            deviceMs = std::min(deviceMs, bake.deviceMilliseconds);
        });
        destroyProjector(context_, projector);
        double error = haveReference ? errorToReference(bake.radiance, reference) : -1.0;
        if (bake.deviceMilliseconds > 0.0) add(cubemap.faceSize, order, "gpu projection (device)", deviceMs, error);
        add(cubemap.faceSize, order, "gpu bake (wall: upload, dispatch, readback)", wallMs, error);
    }

    void add(int faceSize, int order, const std::string& path, double ms, double error) {
        double rate = texels_ / (ms * 1e-3);
        measurements_.push_back({faceSize, order, path, ms, rate, boundMs_ / ms, error});
        const Measurement& m = measurements_.back();
        std::printf("%6d  %5s  %-44s %10.2f %10.1f %8.1f%%", m.faceSize, order ? std::to_string(order).c_str() : "-",
                    m.path.c_str(), m.milliseconds, m.texelsPerSecond * 1e-6, m.fractionOfBound * 100.0);
        if (m.errorToReference >= 0.0) std::printf("  %.1e", m.errorToReference);
        std::printf("\n");
        std::fflush(stdout);
    }

    const BenchOptions& options_;
    Context& context_;
    double texels_ = 0.0;
    double boundMs_ = 0.0;
    std::vector<Measurement> measurements_;
};

nlohmann::ordered_json reportJson(const Context& context, const std::vector<Measurement>& measurements) {
    nlohmann::ordered_json report;
    report["device"] = context.info.name;
    report["driver"] = context.info.driver;
    report["device_type"] = deviceTypeName(context.info.type);
    report["subgroup_size"] = context.info.subgroupSize;
    report["threads"] = std::thread::hardware_concurrency();
    report["input"] = "RGBA32F noise, 6 faces";
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (const Measurement& m : measurements) {
        nlohmann::ordered_json row;
        row["face_size"] = m.faceSize;
        row["order"] = m.order;
        row["path"] = m.path;
        row["milliseconds"] = m.milliseconds;
        row["texels_per_second"] = m.texelsPerSecond;
        row["fraction_of_memory_read_bound"] = m.fractionOfBound;
        if (m.errorToReference >= 0.0) row["max_error_relative_to_L00"] = m.errorToReference;
        rows.push_back(row);
    }
    report["measurements"] = rows;
    return report;
}

} // namespace

void addBenchCommand(CLI::App& app, BenchOptions& options) {
    CLI::App* command = app.add_subcommand(
        "bench", "Measure every projection path against the machine's memory-read bound, in one run");
    command->add_option("--sizes", options.faceSizes, "Face sizes")->capture_default_str();
    command->add_option("--orders", options.orders, "SH orders")->check(CLI::Range(1, kMaxOrder))->capture_default_str();
    command->add_option("--repeat", options.repeat, "Runs per measurement (the best counts)")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    command->add_option("--reference-max-size", options.referenceMaxFaceSize,
                        "Largest face size for the (slow) double reference")
        ->capture_default_str();
    command->add_option("--json", options.json, "Also write the measurements to this JSON file");
    command->add_option("--device", options.device, "Vulkan device index or name part");
}

void runBench(const BenchOptions& options) {
    if (!options.json.empty()) checkOutputPath(options.json);
    ContextOptions contextOptions;
    contextOptions.device = options.device;
    Context context = createContext(contextOptions);
    std::printf("device: %s (%s), %s, subgroup size %u; CPU threads: %u\n", context.info.name.c_str(),
                deviceTypeName(context.info.type), context.info.driver.c_str(), context.info.subgroupSize,
                std::thread::hardware_concurrency());
    std::printf("%6s  %5s  %-44s %10s %10s %9s  %s\n", "face", "order", "path", "ms", "Mtexel/s", "of bound",
                "error/|L00|");
    std::vector<Measurement> measurements;
    try {
        Bench bench(options, context);
        for (int faceSize : options.faceSizes) bench.runFaceSize(faceSize);
        measurements = bench.measurements();
    } catch (...) {
        destroyContext(context);
        throw;
    }
    if (!options.json.empty()) writeFileAtomic(options.json, reportJson(context, measurements).dump(2) + "\n");
    destroyContext(context);
}

} // namespace shprobe
