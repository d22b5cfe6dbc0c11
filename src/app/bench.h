// `shprobe bench` and shprobe-bench: projection speed against the memory-read bound, on generated
// inputs (bench.cpp). It needs the Vulkan context and the GPU passes, and no image codec:
// shprobe-bench (bench_main.cpp) is this alone, and `shprobe bench` adds the whole-job benchmark's
// in-process parts (bench_job.h), which read and write image files.
#pragma once
#include <CLI/CLI.hpp>
#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace shprobe {

struct BenchOptions {
    std::vector<int> faceSizes{64, 256, 1024, 2048};
    std::vector<int> orders{3, 5, 8};
    int repeat = 3;
    int referenceMaxFaceSize = 2048; // the double reference takes seconds beyond this
    std::string json;
    std::string device;
};

inline constexpr char kBenchSummary[] =
    "Measure every projection path against the machine's memory-read bound, in one run";

// The benchmark's options on `command`: `shprobe bench`, or shprobe-bench's own command line.
void addBenchOptions(CLI::App& command, BenchOptions& options);
// Prints a row per path, face size, format and order, then the pipeline creation times; --json
// also writes them to a file.
void runBench(const BenchOptions& options);

// Best wall time of `repeat` runs of f, in milliseconds.
double bestMilliseconds(int repeat, const std::function<void()>& f);
// Reads `bytes` (whole 64-bit words) once on all cores, repeating the pass until at least 256 MiB
// were read so that starting the threads does not count; the best time of one pass of `repeat`.
// Nothing that reads the data can beat this here: the CPU rows' bound.
double memoryReadMilliseconds(std::span<const std::byte> bytes, int repeat);

} // namespace shprobe
