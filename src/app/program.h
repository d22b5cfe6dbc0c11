// What both programs, shprobe and shprobe-view, do around their commands: the standard streams,
// Ctrl-C, --version, parsing, and turning an error into one line and its exit code.
#pragma once
#include <CLI/CLI.hpp>

#include <functional>

namespace shprobe {

// --version: prints "PROGRAM VERSION" and exits 0.
void addVersionFlag(CLI::App& app, const char* program);

// An option whose value must lie in [low, high], with its default shown in --help.
template <typename T, typename Bound>
CLI::Option* addRangeOption(CLI::App& command, const std::string& name, T& value, const std::string& help,
                            Bound low, Bound high) {
    return command.add_option(name, value, help)->check(CLI::Range(low, high))->capture_default_str();
}

// Parses the command line into `app`, then calls `run`. Returns the exit code: 0 success, 1 out of
// memory or an internal error, 2 bad input or usage, 3 output not written, 4 no usable Vulkan device,
// display or viewer. Every error is printed as one line, "NAME: error: ...". An Error that an option's
// parser throws while the line is parsed (app/parsed_option.h) is printed and exits as one from `run`.
int runProgram(CLI::App& app, const char* name, int argc, char** argv, const std::function<void()>& run);

// Ends the process with exit code `code` once the C streams are flushed, skipping the clean-up
// after main: every output is already written, synced and renamed, and what is left (freeing
// memory, OpenEXR's thread pool joining its threads) the process gives back whole. Under
// AddressSanitizer it returns `code` instead, so that main returns and the leak check runs.
int endProgram(int code);

} // namespace shprobe
