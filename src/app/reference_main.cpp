// shprobe-reference: the probe volume of a glTF scene by the ray-traced reference (Embree, double
// precision; scene/reference_tracer.h) instead of the GPU capture, in the same file format, for
// comparisons and the scene benchmark (scripts/bench-scene.sh). Built beside shprobe, not
// installed: it is the only program that links Embree.
#include "app/commands.h"
#include "app/parsed_option.h"
#include "app/program.h"
#include "app/progress_line.h"
#include "app/stopwatch.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "common/parallel.h"
#include "formats/probe_volume.h"
#include "scene/bvh.h"
#include "scene/gltf_scene.h"
#include "scene/probe_grid.h"
#include "scene/ray_caster.h"
#include "scene/reference_tracer.h"
#include "scene/transfer.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <thread>

namespace shprobe {
namespace {

struct ReferenceOptions {
    std::string scene;
    std::string output = "reference.shpv";
    glm::ivec3 grid{1};
    bool gridGiven = false;           // --grid on the command line
    std::optional<GridBounds> bounds; // none: as shprobe scene
    int order = 3;
    int bounces = 1;
    int samples = 6144;     // 6 x 32^2: as many directions as a capture at faces 32^2 has texels
    int validityFaces = 16; // the texel rays that decide which probes are inside geometry
    std::string sky;
    int transferRays = 0; // > 0: time transfer's rays instead of tracing a volume
    bool quiet = false;
};

void addOptions(CLI::App& app, ReferenceOptions& options) {
    app.add_option("scene", options.scene, "glTF scene (.gltf or .glb)")->required()->check(nonEmptyName());
    app.add_option("-o,--output", options.output, "Probe volume to write")->capture_default_str();
    addParsedOption(app, "--grid", options.grid, parseGridCounts,
                    "Probes per axis, NX,NY,NZ (required for a volume)");
    addParsedOption(app, "--bounds", options.bounds, parseGridBounds,
                    "Grid box X0,Y0,Z0,X1,Y1,Z1 (default: as shprobe scene)");
    addRangeOption(app, "--order", options.order, "SH order", 1, kMaxOrder);
    addRangeOption(app, "--bounces", options.bounces, "Diffuse bounces", 0, 64);
    addRangeOption(app, "--samples", options.samples, "Path-traced directions per probe", 16, 1 << 24);
    addRangeOption(app, "--validity-faces", options.validityFaces,
                   "Face size of the texel rays that find the probes inside geometry (as shprobe scene: more "
                   "than half of them on back faces)",
                   1, 256);
    app.add_option("--sky", options.sky, "Environment seen where no geometry is (default: the built-in sky)");
    addRangeOption(
        app, "--transfer-rate", options.transferRays,
        "Instead of a volume: time `shprobe transfer --model shadowed` at --order with this many rays "
        "a vertex against Embree's own rate for the same rays, and the GPU's hierarchy on the cores",
        1, 1 << 20);
    app.add_flag("-q,--quiet", options.quiet, "No report");
}

// The largest difference between two transfers, relative to the largest |T| (green channel), and
// how many vectors differ at all.
struct TransferDifference {
    double relative = 0.0;
    size_t vectors = 0;
};
TransferDifference compareTransfers(const VertexTransfer& a, const VertexTransfer& b) {
    const size_t count = size_t(a.order) * size_t(a.order);
    double largest = 0.0, worst = 0.0;
    TransferDifference difference;
    for (size_t v = 0; v < a.vertexCount(); ++v) {
        bool differs = false;
        for (size_t i = v * count; i < (v + 1) * count; ++i) {
            largest = std::max(largest, double(std::abs(a.coefficients[i].g)));
            worst = std::max(worst, double(std::abs(a.coefficients[i].g - b.coefficients[i].g)));
            differs = differs || a.coefficients[i] != b.coefficients[i];
        }
        difference.vectors += differs;
    }
    difference.relative = worst / std::max(largest, 1e-30);
    return difference;
}

// The least time of three runs of `work`: the run least disturbed by the rest of the machine.
template <typename Work> double bestSeconds(const Work& work) {
    double best = std::numeric_limits<double>::infinity();
    for (int run = 0; run < 3; ++run) {
        const Clock::time_point start = Clock::now();
        work();
        best = std::min(best, millisecondsSince(start) / 1000.0);
    }
    return best;
}

// Embree's own rate on the shadowed transfer's rays: the rays collected, each thread's in the order
// it cast them (a side's rays together, as the transfer casts them), then cast on all cores by the
// same caster the transfer uses (rtcOccluded1 behind one virtual call), nothing else done per ray.
double embreeRaysPerSecond(const World& world, const TransferOptions& transfer) {
    std::mutex mutex;
    std::map<std::thread::id, std::vector<Ray>> byThread;
    computeShadowedTransfer(world, transfer, [&](const glm::vec3& origin, const glm::vec3& direction) {
        const std::lock_guard lock(mutex);
        byThread[std::this_thread::get_id()].push_back({origin, direction});
        return false;
    });
    std::vector<Ray> rays;
    for (const auto& [thread, cast] : byThread)
        rays.insert(rays.end(), cast.begin(), cast.end());
    const std::unique_ptr<RayCaster> embree = makeRayCaster(world);
    constexpr int kParts = 1024;
    std::vector<uint32_t> blocked(kParts); // written once per part: no cache line shared per ray
    const double seconds = bestSeconds([&] {
        forEachItem(kParts, threadCount(rays.size(), 4096), [&](int part) {
            const size_t first = rays.size() * part / kParts, end = rays.size() * (part + 1) / kParts;
            uint32_t count = 0;
            for (size_t r = first; r < end; ++r)
                count += embree->anyHit(rays[r]);
            blocked[part] = count;
        });
    });
    return double(rays.size()) / seconds;
}

// The shadowed transfer as `shprobe transfer` casts it (Embree through its plugin, set-up included),
// as the GPU's hierarchy (scene/bvh.h) would answer it on the cores, and Embree's own rate for the
// same rays, each the best of three runs: the rates and how far the transfers differ.
void measureTransferRate(const ReferenceOptions& options, const World& world) {
    const TransferOptions transfer{
        .model = TransferModel::Shadowed, .order = options.order, .rays = options.transferRays};
    VertexTransfer ours;
    const double oursSeconds = bestSeconds([&] { ours = computeTransfer(world, transfer); });
    const Bvh bvh = buildBvh(world);
    VertexTransfer walked;
    const double walkedSeconds = bestSeconds([&] {
        walked = computeShadowedTransfer(world, transfer,
                                         [&](const glm::vec3& origin, const glm::vec3& direction) {
                                             return anyHit(bvh, {origin, direction});
                                         });
    });
    const double embreeRate = embreeRaysPerSecond(world, transfer);
    const double rays = double(ours.raysCast);
    const auto row = [&](const char* name, double seconds, const VertexTransfer& other) {
        const TransferDifference difference = compareTransfers(ours, other);
        std::printf("%-9s %.2f s, %.3g Mrays/s, %.0f vectors/s, %.2f of Embree's rate; %zu vectors differ, "
                    "by %.2g of the largest |T| at most\n",
                    name, seconds, rays / seconds / 1e6, double(ours.vertexCount()) / seconds,
                    rays / seconds / embreeRate, difference.vectors, difference.relative);
    };
    std::printf("transfer  %s, shadowed, order %d, %d rays a vertex: %.3g rays, %zu vectors\n",
                world.description.c_str(), options.order, ours.rays, rays, ours.vertexCount());
    std::printf("embree    %.3g Mrays/s: its rtcOccluded1 alone on the same rays, all cores\n",
                embreeRate / 1e6);
    row("transfer", oursSeconds, ours);
    row("hierarchy", walkedSeconds, walked);
}

ProbeVolume traceVolume(const ReferenceOptions& options, const World& world, const ProbeGrid& grid,
                        const Environment& sky) {
    const SplitSky split = splitSceneSky(sky);
    World lit = world;
    lit.suns.insert(lit.suns.end(), split.suns.begin(), split.suns.end());
    const ReferenceTracer tracer(lit, split.residual);
    std::vector<glm::dvec3> positions;
    for (uint32_t p = 0; p < grid.probeCount(); ++p)
        positions.push_back(probePosition(grid, probeCell(grid, p)));
    // In parts, between which the progress line is drawn: each probe's estimate is the same bits
    // whichever probes are traced with it. A part holds at least one probe per core.
    const PathTraceOptions trace{.order = options.order,
                                 .bounces = options.bounces,
                                 .samples = options.samples,
                                 .seenSuns = split.suns};
    const size_t part = std::max<size_t>({1, positions.size() / 64, std::thread::hardware_concurrency()});
    ProgressLine line("probes", positions.size(), options.quiet);
    std::vector<PathTracedProbe> traced;
    traced.reserve(positions.size());
    for (size_t first = 0; first < positions.size(); first += part) {
        const size_t count = std::min(part, positions.size() - first);
        for (PathTracedProbe& probe :
             pathTraceProbes(tracer, std::span(positions).subspan(first, count), trace))
            traced.push_back(std::move(probe));
        line.update(first + count);
    }
    line.disable();
    ProbeVolume volume;
    volume.grid = grid;
    volume.order = options.order;
    volume.end = grid.probeCount();
    volume.bounces = options.bounces;
    const size_t perProbe = size_t(options.order) * options.order;
    volume.radiance.assign(positions.size() * perProbe, glm::vec3(0.0f));
    volume.irradiance.assign(positions.size() * perProbe, glm::vec3(0.0f));
    volume.valid.assign(positions.size(), 0);
    const size_t texels = 6 * size_t(options.validityFaces) * options.validityFaces;
    for (size_t p = 0; p < positions.size(); ++p) {
        if (2 * traceProbeTexels(tracer, positions[p], options.validityFaces).backFaceTexels > texels)
            continue;
        volume.valid[p] = 1;
        const ShCoefficients irradiance = convolveIrradiance(traced[p].radiance);
        for (size_t i = 0; i < perProbe; ++i) {
            volume.radiance[p * perProbe + i] = glm::vec3(traced[p].radiance.rgb[i]);
            volume.irradiance[p * perProbe + i] = glm::vec3(irradiance.rgb[i]);
        }
    }
    volume.source = world.description;
    volume.sourceHash = gltfSceneHash(options.scene);
    volume.skySource = sky.description;
    volume.settings = nlohmann::json{{"reference", "path traced"},
                                     {"samples", options.samples},
                                     {"sky", skyContentHash(sky.cubemap)}}
                          .dump();
    return volume;
}

void run(const ReferenceOptions& options) {
    if (options.transferRays > 0) return measureTransferRate(options, loadGltfScene(options.scene));
    if (!options.gridGiven) throw Error(ErrorKind::Input, "--grid is required (unless --transfer-rate)");
    checkOutputPath(options.output, OutputContent::Binary);
    checkOutputsAreNotInputs({&options.output, 1}, sceneInputs(options.scene, options.sky));
    const Clock::time_point start = Clock::now();
    const World world = loadGltfScene(options.scene);
    const ProbeGrid grid =
        options.bounds ? makeProbeGrid(options.grid, *options.bounds) : probeGridInWorld(options.grid, world);
    const Environment sky = loadSceneSky(options.sky);
    const ProbeVolume volume = traceVolume(options, world, grid, sky);
    writeProbeVolume(options.output, volume);
    if (options.quiet) return;
    const size_t inside = std::count(volume.valid.begin(), volume.valid.end(), uint8_t(0));
    std::printf("reference %s: %s, %zu inside geometry, %s, %s each -> %s in %.2f s\n",
                world.description.c_str(), counted(volume.probeCount(), "probe").c_str(), inside,
                counted(options.bounces, "bounce").c_str(), counted(options.samples, "sample").c_str(),
                options.output.c_str(), millisecondsSince(start) / 1000.0);
}

} // namespace
} // namespace shprobe

int main(int argc, char** argv) {
    CLI::App app{
        "shprobe-reference: a scene's probe volume by the ray-traced reference (Embree), in the file "
        "format of `shprobe scene` (docs/scene-probes.md)"};
    shprobe::addVersionFlag(app, "shprobe-reference");
    shprobe::ReferenceOptions options;
    addOptions(app, options);
    return shprobe::runProgram(app, "shprobe-reference", argc, argv, [&] {
        options.gridGiven = app.count("--grid") > 0;
        run(options);
    });
}
