// `shprobe relight VOLUME --sky ENV [--yaw D --pitch D] -o NEW`: a probe volume baked with
// `shprobe scene --transfer` lit by another sky, or its sky turned, from its transfer alone
// (scene/volume_bake.h relightVolume): no scene, no rays.
#include "app/commands.h"
#include "app/parsed_option.h"

#include "app/bench.h"
#include "app/stopwatch.h"
#include "common/counted.h"
#include "common/error.h"
#include "common/output_file.h"
#include "formats/probe_volume.h"
#include "image/environment.h"
#include "scene/volume_bake.h"
#include "sh/projection.h"
#include "sh/rotation.h"

#include <cstdio>
#include <nlohmann/json.hpp>

namespace shprobe {

namespace {

struct RelightSky {
    std::string name;
    std::string contentHash; // skyContentHash: the sky before it turns
    ShCoefficients radiance;
};

// The sky's radiance coefficients at the volume's order, turned by yaw and pitch.
RelightSky relightSky(const RelightOptions& options, int order) {
    RelightSky sky;
    if (!options.probe.empty()) {
        ShCoefficients radiance = probeFileRadiance(options.probe, order);
        sky = {options.probe, skyContentHash(radiance), std::move(radiance)};
    } else {
        const Environment environment =
            loadSceneSky(options.sky, {.sanitize = options.sanitize, .maxPixels = options.maxPixels});
        sky = {environment.description, skyContentHash(environment.cubemap),
               projectCubemap(environment.cubemap, order)};
    }
    if (options.yaw != 0.0 || options.pitch != 0.0)
        sky.radiance = rotate(makeShRotation(lightRotation(options.yaw, options.pitch), order), sky.radiance);
    return sky;
}

// The volume's settings with the sky it is now lit by.
std::string relitSettings(const ProbeVolume& volume, const RelightSky& sky, const RelightOptions& options) {
    nlohmann::json settings = nlohmann::json::parse(volume.settings);
    settings["sky"] = sky.contentHash;
    settings.erase("sky_turn");
    if (options.yaw != 0.0 || options.pitch != 0.0) settings["sky_turn"] = {options.yaw, options.pitch};
    return settings.dump();
}

// Relighting against its bound, both best of 5 in this run: a pass reading the transfer's bytes on
// all cores (relighting reads each once and writes a ninth as much).
void printRelightTimings(FILE* report, ProbeVolume& volume, const ShCoefficients& sky) {
    const double relight = bestMilliseconds(5, [&] { relightVolume(volume, sky); });
    const std::span<const std::byte> bytes = std::as_bytes(std::span(volume.transfer));
    const double read = memoryReadMilliseconds(bytes, 5);
    // Three significant digits below 10 ms (a small volume relights in microseconds), else tenths.
    const auto ms = [](double value) {
        char text[32];
        std::snprintf(text, sizeof(text), value < 10.0 ? "%.3g" : "%.1f", value);
        return std::string(text);
    };
    std::fprintf(report,
                 "time     relight %s ms (best of 5); reading its transfer's %.1f MB on all cores %s ms: "
                 "%.2f of that bound\n",
                 ms(relight).c_str(), double(bytes.size()) / 1e6, ms(read).c_str(), read / relight);
}

} // namespace

void addRelightOptions(CLI::App& command, RelightOptions& options) {
    command.add_option("volume", options.volume, "Probe volume baked with `shprobe scene --transfer`")
        ->required()
        ->check(nonEmptyName());
    command.add_option("-o,--output", options.output, "Probe volume to write")
        ->required()
        ->check(nonEmptyName());
    CLI::Option* sky = command
                           .add_option("--sky", options.sky,
                                       "The new sky: any input `bake` takes (default: the built-in sky)")
                           ->check(nonEmptyName());
    CLI::Option* probe =
        command
            .add_option("--probe", options.probe,
                        "The new sky as a radiance probe file (JSON, or binary of one probe)")
            ->check(nonEmptyName())
            ->excludes(sky);
    addSkyReadingOptions(command, options.sanitize, options.maxPixels);
    for (const char* name : {"--sanitize", "--max-pixels"}) // they read an image, not a probe
        command.get_option(name)->excludes(probe);
    command.add_option("--yaw", options.yaw, "The sky's turn about +Y, degrees")
        ->check(numberFrom(-360.0, 360.0));
    command.add_option("--pitch", options.pitch, "The sky's turn about +X, degrees")
        ->check(numberFrom(-360.0, 360.0));
    command.add_flag("--timings", options.timings,
                     "Time relighting (best of 5) against reading the transfer's bytes once");
    command.add_flag("-q,--quiet", options.quiet, "No report");
}

void runRelight(const RelightOptions& options) {
    checkOutputPath(options.output, OutputContent::Binary);
    std::vector<std::string> inputs = filesReadBy(options.sky.empty() ? options.probe : options.sky);
    inputs.push_back(options.volume);
    checkOutputsAreNotInputs({&options.output, 1}, inputs);
    ProbeVolume volume = readProbeVolume(options.volume);
    if (volume.transfer.empty())
        throw Error(ErrorKind::Input, options.volume + ": holds no transfer; bake it with `shprobe scene "
                                                       "--transfer` to relight it");
    const RelightSky sky = relightSky(options, volume.order);
    const Clock::time_point start = Clock::now();
    relightVolume(volume, sky.radiance);
    const double milliseconds = millisecondsSince(start);
    volume.settings = relitSettings(volume, sky, options);
    volume.skySource = sky.name;
    requireFiniteLight(volume, "the sky " + sky.name + ", or the transfer in " + options.volume + ",");
    writeProbeVolume(options.output, volume);
    if (options.quiet) return;
    FILE* report = reportStream(options.output);
    std::fprintf(report, "relit    %s of %s by %s", counted(volume.probeCount(), "probe").c_str(),
                 options.volume.c_str(), sky.name.c_str());
    if (options.yaw != 0.0 || options.pitch != 0.0)
        std::fprintf(report, ", turned yaw %g, pitch %g deg", options.yaw, options.pitch);
    std::fprintf(report, " (order %d; emission and the scene's suns as baked) in %.2f ms\n", volume.order,
                 milliseconds);
    std::fprintf(report, "wrote    %s\n", options.output.c_str());
    if (options.timings) printRelightTimings(report, volume, sky.radiance);
}

} // namespace shprobe
