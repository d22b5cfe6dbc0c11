// `shprobe bench`: projection speed against the memory-read bound (bench.cpp).
#pragma once
#include "app/bench_job.h"

#include <CLI/CLI.hpp>
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
    BenchJobOptions job; // --decode, --write-layouts: the whole-job benchmark's in-process parts
};

void addBenchCommand(CLI::App& app, BenchOptions& options);
void runBench(const BenchOptions& options);

} // namespace shprobe
