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
#include "formats/probe_volume.h"
#include "scene/gltf_scene.h"
#include "scene/probe_grid.h"
#include "scene/reference_tracer.h"
#include "sh/irradiance.h"

#include <algorithm>
#include <cstdio>
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
    std::optional<GridBounds> bounds; // none: as shprobe scene
    int order = 3;
    int bounces = 1;
    int samples = 6144;     // 6 x 32^2: as many directions as a capture at faces 32^2 has texels
    int validityFaces = 16; // the texel rays that decide which probes are inside geometry
    std::string sky;
    bool quiet = false;
};

void addOptions(CLI::App& app, ReferenceOptions& options) {
    app.add_option("scene", options.scene, "glTF scene (.gltf or .glb)")->required();
    app.add_option("-o,--output", options.output, "Probe volume to write")->capture_default_str();
    addParsedOption(app, "--grid", options.grid, parseGridCounts, "Probes per axis, NX,NY,NZ")->required();
    addParsedOption(app, "--bounds", options.bounds, parseGridBounds,
                    "Grid box X0,Y0,Z0,X1,Y1,Z1 (default: as shprobe scene)");
    addRangeOption(app, "--order", options.order, "SH order", 1, 8);
    addRangeOption(app, "--bounces", options.bounces, "Diffuse bounces", 0, 64);
    addRangeOption(app, "--samples", options.samples, "Path-traced directions per probe", 16, 1 << 24);
    addRangeOption(app, "--validity-faces", options.validityFaces,
                   "Face size of the texel rays that find the probes inside geometry (as shprobe scene: more "
                   "than half of them on back faces)",
                   1, 256);
    app.add_option("--sky", options.sky, "Environment seen where no geometry is (default: the built-in sky)");
    app.add_flag("-q,--quiet", options.quiet, "No report");
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
    volume.settings =
        nlohmann::json{{"reference", "path traced"}, {"samples", options.samples}, {"sky", sky.description}}
            .dump();
    return volume;
}

void run(const ReferenceOptions& options) {
    checkOutputPath(options.output, OutputContent::Binary);
    checkOutputsAreNotInputs({&options.output, 1}, sceneInputs(options.scene, options.sky));
    const Clock::time_point start = Clock::now();
    const World world = loadGltfScene(options.scene);
    const ProbeGrid grid =
        options.bounds ? makeProbeGrid(options.grid, *options.bounds) : probeGridInWorld(options.grid, world);
    const Environment sky = loadSceneSky(options.sky, 0);
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
    return shprobe::runProgram(app, "shprobe-reference", argc, argv, [&] { run(options); });
}
