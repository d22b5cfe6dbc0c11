// What both programs, shprobe and shprobe-view, do around their commands: the standard streams,
// Ctrl-C, --version, parsing, and turning an error into one line and its exit code.
#pragma once
#include <CLI/CLI.hpp>

#include <charconv>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace shprobe {

// --version: prints "PROGRAM VERSION" and exits 0.
void addVersionFlag(CLI::App& app, const char* program);

// A whole-number option's check at parse time, in the words of numberFrom (commands.h): "--frames:
// 1e9 is not a whole number from 1 to 1073741824", where CLI11's Range says "Value 1e9 not in range".
// Attached with transform(): the value is handed on as the decimal number checked, since CLI11 would
// read "010" as octal 8 and refuse "09".
inline CLI::Validator wholeNumberFrom(int64_t min, int64_t max) {
    const std::string allowed = "whole number from " + std::to_string(min) + " to " + std::to_string(max);
    return CLI::Validator(
        [=](std::string& input) {
            const std::string_view digits =
                input.starts_with('+') ? std::string_view(input).substr(1) : input;
            int64_t value = 0;
            const char* end = digits.data() + digits.size();
            const auto [stop, error] = std::from_chars(digits.data(), end, value);
            if (error != std::errc() || stop != end || value < min || value > max)
                return input + " is not a " + allowed;
            input = std::to_string(value);
            return std::string();
        },
        allowed);
}

// A whole-number option whose value must lie in [low, high], with its default shown in --help.
template <typename T>
CLI::Option* addRangeOption(CLI::App& command, const std::string& name, T& value, const std::string& help,
                            int64_t low, int64_t high) {
    return command.add_option(name, value, help)
        ->transform(wholeNumberFrom(low, high))
        ->capture_default_str();
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
