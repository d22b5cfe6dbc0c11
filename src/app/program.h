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
// display or viewer. Every error is printed as one line, "NAME: error: ...". An Error that an option's
// parser throws while the line is parsed (app/parsed_option.h) is printed and exits as one from `run`.
int runProgram(CLI::App& app, const char* name, int argc, char** argv, const std::function<void()>& run);

// Ends the process with exit code `code` once the C streams are flushed, without the static
// destructors and exit handlers after main: a command has closed what it wrote (outputs are
// written, synced and renamed before it returns), and what is left is freeing memory the process
// gives back whole and the libraries' own clean-up, OpenEXR's global thread pool joining its
// threads: interleaved, `shprobe --help` 1.91 -> 1.61 ms (300 rounds), a bake of courtyard.exr
// 16.8 -> 15.9 ms (400), the eight blender-data HDRs with --out-dir 73.6 -> 67.1 ms (60). Under
// AddressSanitizer it returns `code` instead, for main to return, so that its leak check at exit
// runs.
int endProgram(int code);

} // namespace shprobe
