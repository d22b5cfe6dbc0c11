#include "app/program.h"

#include "app/heap.h"

#include "common/error.h"
#include "common/output_file.h"
#include "sh/cubemap.h"
#include <shprobe/version.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <unistd.h>

namespace shprobe {

namespace {

int exitCode(ErrorKind kind) {
    switch (kind) {
    case ErrorKind::Input:
        return 2;
    case ErrorKind::Output:
        return 3;
    case ErrorKind::Device:
        return 4;
    case ErrorKind::Memory:
        return 1;
    }
    return 1;
}

// An error is one line; a library's message may hold several.
std::string oneLine(std::string text) {
    while (!text.empty() && text.back() == '\n')
        text.pop_back();
    for (char& c : text)
        if (c == '\n') c = ' ';
    return text;
}

// The option of the parsed command line given more often than it takes a value, if any.
const CLI::Option* repeatedOption(const CLI::App& app) {
    for (const CLI::Option* option : app.get_options())
        if (option->get_multi_option_policy() == CLI::MultiOptionPolicy::Throw &&
            option->get_items_expected_max() <= 1 && option->count() > 1)
            return option;
    for (const CLI::App* command : app.get_subcommands())
        if (const CLI::Option* option = repeatedOption(*command)) return option;
    return nullptr;
}

// CLI11's message, but for an option given twice, of which it says "--order: At Most 1 required but
// received 2": that is said as the other option errors are.
std::string parseErrorText(const CLI::App& app, const CLI::ParseError& e) {
    const CLI::Option* repeated =
        dynamic_cast<const CLI::ArgumentMismatch*>(&e) ? repeatedOption(app) : nullptr;
    if (!repeated) return oneLine(e.what());
    return repeated->get_name() + ": given " + std::to_string(repeated->count()) + " times; give it once";
}

void printError(const char* name, const Error& e) {
    std::fprintf(stderr, "%s: error: %s\n", name, oneLine(e.what()).c_str());
}

// Descriptors 0-2 that the parent closed stand open on /dev/null (common/output_file.h). A reader
// that goes away makes a write fail with EPIPE ("cannot write -: broken pipe", exit 3) instead of
// ending the program by SIGPIPE without a word.
void prepareStandardStreams() {
    openClosedStandardDescriptors();
    std::signal(SIGPIPE, SIG_IGN);
}

} // namespace

void addVersionFlag(CLI::App& app, const char* program) {
    app.add_flag_callback(
        "--version",
        [program] {
            std::printf("%s %s\n", program, SHPROBE_VERSION_STRING);
            throw CLI::Success();
        },
        "Print the version and exit");
}

int runProgram(CLI::App& app, const char* name, int argc, char** argv, const std::function<void()>& run) {
    prepareStandardStreams();
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e); // --help, --version
        std::fprintf(stderr, "%s: error: %s (see --help)\n", name, parseErrorText(app, e).c_str());
        return 2;
    } catch (const Error& e) { // a value that its option's parser refused (app/parsed_option.h)
        printError(name, e);
        return exitCode(e.kind());
    }

    // Only once a command runs: parsing writes no file, and the handler's thread is a fair part
    // of what `shprobe --help` takes (docs/benchmark.md).
    removeTemporaryFilesOnInterrupt(); // Ctrl-C: exit at once, no partial files
    prepareHeap();
    adviseTexelHugePages(true); // cube maps and images past the heap's advice (96 MiB at faces 1024)
    try {
        run();
    } catch (const Error& e) {
        printError(name, e);
        return exitCode(e.kind());
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "%s: error: out of memory\n", name);
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: internal error: %s\n", name, oneLine(e.what()).c_str());
        return 1;
    }
    return 0;
}

// AddressSanitizer's leak check runs at exit; GCC and Clang each say in their own way that it is on.
#if defined(__SANITIZE_ADDRESS__)
#define SHPROBE_LEAK_CHECK_AT_EXIT 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SHPROBE_LEAK_CHECK_AT_EXIT 1
#endif
#endif

int endProgram(int code) {
#if !defined(SHPROBE_LEAK_CHECK_AT_EXIT)
    std::fflush(nullptr);
    _exit(code);
#endif
    return code;
}

} // namespace shprobe
