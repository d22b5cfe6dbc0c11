// Options whose text becomes a typed value as CLI11 reads the command line, so that a malformed value
// is refused before any input is read, device created or output touched.
#pragma once
#include <CLI/CLI.hpp>

#include <string>
#include <utility>

namespace shprobe {

// Adds `name`, whose text (a Text: one string, or a std::vector of them for an option that repeats or
// takes several values) `parse` turns into `value`. parse throws Error(Input) naming the option, which
// runProgram reports as a failed run's error: the same line and exit code as when the value was
// parsed by the command itself.
template <class Text = std::string, class Value, class Parse>
CLI::Option* addParsedOption(CLI::App& command, std::string name, Value& value, Parse parse,
                             std::string help) {
    return command.add_option_function<Text>(
        std::move(name), [&value, parse](const Text& text) { value = parse(text); }, std::move(help));
}

// A file name given empty ("-o ''", "--sky ''", an input '') names no file; where a default exists
// (the built-in sky, probe.json) it is refused rather than taken as that default.
inline CLI::Validator nonEmptyName() {
    return CLI::Validator(
        [](const std::string& input) {
            return input.empty() ? std::string("'' names no file") : std::string();
        },
        "");
}

} // namespace shprobe
