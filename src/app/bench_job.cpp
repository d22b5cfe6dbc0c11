// The in-process halves of the whole-job benchmark (bench_job.h): decode alone, and the cross and
// face files made from an equirect with the library's own loader and writer.
#include "app/bench_job.h"
#include "app/stopwatch.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/output_file.h"
#include "image/environment.h"
#include "image/image_write.h"
#include "sh/cubemap.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

namespace shprobe {

namespace {

constexpr std::array<const char*, kFaceCount> kFaceFileNames{"px", "nx", "py", "ny", "pz", "nz"};

// Rows [ . +Y . . ] [ -X +Z +X -Z ] [ . -Y . . ] (docs/conventions.md), column and row per Face.
constexpr std::array<std::array<int, 2>, kFaceCount> kHorizontalCrossSlots{
    {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}}};

Image faceImage(const Cubemap& cubemap, int face) {
    const int n = cubemap.faceSize;
    Image image = makeImage(n, n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            image.at(i, j) = cubemap.at(face, i, j);
    return image;
}

Image horizontalCross(const Cubemap& cubemap) {
    const int n = cubemap.faceSize;
    Image cross = makeImage(4 * n, 3 * n);
    std::fill(cross.texels.begin(), cross.texels.end(), glm::vec4(0.0f)); // the empty slots are black
    for (int face = 0; face < kFaceCount; ++face) {
        const auto [column, row] = kHorizontalCrossSlots[size_t(face)];
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                cross.at(column * n + i, row * n + j) = cubemap.at(face, i, j);
    }
    return cross;
}

void writeLayouts(const std::string& equirect, const std::string& folder) {
    const std::filesystem::path dir(folder);
    std::vector<std::string> outputs{(dir / "cross.exr").string()};
    for (const char* face : kFaceFileNames)
        outputs.push_back((dir / "faces" / (std::string(face) + ".exr")).string());
    checkOutputsAreNotInputs(outputs, {&equirect, 1});
    LoadOptions load;
    load.layout = Layout::Equirect;
    const Environment environment = loadEnvironment(equirect, load);
    std::error_code error;
    std::filesystem::create_directories(dir / "faces", error);
    if (error)
        throw Error(ErrorKind::Output,
                    "cannot create " + (dir / "faces").string() + ": " + systemReason(error.value()));
    writeImage(outputs[0], horizontalCross(environment.cubemap));
    std::printf("%s: %s as a horizontal cross, %d x %d\n", outputs[0].c_str(),
                environment.description.c_str(), 4 * environment.cubemap.faceSize,
                3 * environment.cubemap.faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        writeImage(outputs[size_t(face) + 1], faceImage(environment.cubemap, face));
    std::printf("%s/faces/{px,nx,py,ny,pz,nz}.exr: its six faces, %d x %d each\n", folder.c_str(),
                environment.cubemap.faceSize, environment.cubemap.faceSize);
}

nlohmann::ordered_json decodeReport(const std::vector<std::string>& files, int repeat) {
    nlohmann::ordered_json report;
    report["reader"] = "readImage (shprobe/image/environment.h)";
    report["repeat"] = repeat;
    report["threads"] = std::thread::hardware_concurrency();
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    double total = 0.0;
    for (const std::string& path : files) {
        double best = INFINITY;
        double first = 0.0;
        int width = 0;
        int height = 0;
        size_t bytes = 0;
        for (int r = 0; r < repeat; ++r) {
            Image image; // freed after the timing, as a bake frees it after the projection
            const Clock::time_point start = Clock::now();
            image = readImage(path);
            const double seconds = millisecondsSince(start) * 1e-3;
            if (r == 0) first = seconds;
            best = std::min(best, seconds);
            width = image.width;
            height = image.height;
            bytes = image.texels.size() * sizeof(image.texels[0]); // as readImage holds it
        }
        total += best;
        nlohmann::ordered_json row;
        row["path"] = path;
        row["width"] = width;
        row["height"] = height;
        row["decoded_bytes"] = bytes;
        row["best_seconds"] = best;
        row["first_seconds"] = first; // the process's first read of it, one-time setup included
        rows.push_back(row);
    }
    report["files"] = rows;
    report["total_best_seconds"] = total;
    return report;
}

} // namespace

void addBenchJobOptions(CLI::App& command, BenchJobOptions& options) {
    command.add_option("--decode", options.decode,
                       "Decode alone: read each FILE with the library's reader --repeat times and print "
                       "the best wall time per file as one line of JSON (no Vulkan; the kernels are "
                       "not run)");
    command
        .add_option("--write-layouts", options.writeLayouts,
                    "EQUIRECT DIR: write DIR/cross.exr (horizontal cross) and DIR/faces/*.exr (six face "
                    "files) of the equirect's cube map, for scripts/bench-job.sh (no Vulkan)")
        ->expected(2);
}

bool benchJobRequested(const BenchJobOptions& options) {
    return !options.decode.empty() || !options.writeLayouts.empty();
}

void runBenchJob(const BenchJobOptions& options, int repeat, const std::string& json) {
    if (!json.empty()) checkOutputPath(json);
    if (!options.writeLayouts.empty()) writeLayouts(options.writeLayouts[0], options.writeLayouts[1]);
    if (options.decode.empty()) return;
    const std::string text = decodeReport(options.decode, repeat).dump();
    std::printf("%s\n", text.c_str());
    if (!json.empty()) writeOutputFile(json, text + "\n");
}

} // namespace shprobe
