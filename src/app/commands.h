// The subcommands of the shprobe program. Each adds its options to the parser and runs from a
// plain options struct; library errors (shprobe::Error) reach main, which prints them.
#pragma once
#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

namespace shprobe {

struct BakeOptions {
    std::string input;            // file, folder or {face} pattern; empty: the built-in sky
    std::string output = "probe.json";
    int order = 3;
    std::string layout = "auto";
    int faceSize = 0;             // 0: from the input (256 for the built-in sky)
    std::string backend = "gpu";  // gpu | cpu
    bool irradiance = false;      // write E_lm instead of L_lm
    bool sanitize = false;        // replace NaN/Inf texels with 0 instead of refusing
    std::string device;
    bool validation = false;
    uint32_t workgroupSize = 64;
    uint32_t texelsPerInvocation = 256;
    bool quiet = false;           // no coefficient table
};

struct InfoOptions {
    bool validation = false;
};

void addBakeCommand(CLI::App& app, BakeOptions& options);
void runBake(const BakeOptions& options);

void addInfoCommand(CLI::App& app, InfoOptions& options);
void runInfo(const InfoOptions& options);

} // namespace shprobe
