// `shprobe bench --decode` and `--write-layouts`: the in-process halves of the whole-job benchmark
// (scripts/bench-job.sh, docs/benchmark.md). Neither creates a Vulkan context.
#pragma once
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace shprobe {

struct BenchJobOptions {
    // Decode alone: each file read with readImage (the library's reader, whatever it is) --repeat
    // times; the best wall time per file is reported as one line of JSON.
    std::vector<std::string> decode;
    // EQUIRECT DIR: DIR/cross.exr (a horizontal cross) and DIR/faces/{px,nx,py,ny,pz,nz}.exr of
    // the equirect's cube map at its own face size (width / 4), the inputs of the other layouts.
    std::vector<std::string> writeLayouts;
};

void addBenchJobOptions(CLI::App& command, BenchJobOptions& options);
// Whether any option of the job's in-process halves was given (then `bench` runs only them).
bool benchJobRequested(const BenchJobOptions& options);
// repeat: runs per file (the best counts); json: also write the report there (empty: stdout only).
void runBenchJob(const BenchJobOptions& options, int repeat, const std::string& json);

} // namespace shprobe
