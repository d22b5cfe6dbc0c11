// What both programs, shprobe and shprobe-view, do around their commands: the standard streams,
// Ctrl-C, --version, parsing, and turning an error into one line and its exit code.
#pragma once
#include <CLI/CLI.hpp>

#include <functional>

namespace shprobe {

// --version: prints "PROGRAM VERSION" and exits 0.
void addVersionFlag(CLI::App& app, const char* program);

// Parses the command line into `app`, then calls `run`. Returns the exit code: 0 success, 1 out of
// memory or an internal error, 2 bad input or usage, 3 output not written, 4 no usable Vulkan device,
// display or viewer. Every error is printed as one line, "NAME: error: ...".
int runProgram(CLI::App& app, const char* name, int argc, char** argv, const std::function<void()>& run);

} // namespace shprobe
