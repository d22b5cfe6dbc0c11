// shprobe: bakes HDR environments into spherical-harmonics light probes on the GPU.
#include "app/bench.h"
#include "app/commands.h"
#include "shprobe/io/output_file.h"
#include "shprobe/sh/error.h"
#include "shprobe/version.h"

#include <csignal>
#include <cstdio>
#include <exception>
#include <fcntl.h>
#include <string>

namespace {

// Exit codes: 0 success, 2 bad input or usage, 3 output not written, 4 Vulkan device problem.
int exitCode(shprobe::ErrorKind kind) {
    switch (kind) {
    case shprobe::ErrorKind::Input:
        return 2;
    case shprobe::ErrorKind::Output:
        return 3;
    case shprobe::ErrorKind::Device:
        return 4;
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

// Descriptors 0-2 that the parent closed are opened on /dev/null, so that no file the program
// opens takes their place (a probe file read as standard input, an output sent to standard
// output). A reader that goes away makes a write fail with EPIPE ("cannot write -: broken pipe",
// exit 3) instead of ending the program by SIGPIPE without a word.
void prepareStandardStreams() {
    for (int fd = 0; fd <= 2; ++fd)
        if (fcntl(fd, F_GETFD) < 0) open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY);
    std::signal(SIGPIPE, SIG_IGN);
}

} // namespace

int main(int argc, char** argv) {
    prepareStandardStreams();
    shprobe::removeTemporaryFilesOnInterrupt(); // Ctrl-C: exit at once, no partial files
    CLI::App app{"shprobe: bake HDR environments into spherical-harmonics light probes with Vulkan "
                 "(conventions: docs/conventions.md)"};
    app.require_subcommand(1);
    app.add_flag_callback(
        "--version",
        [] {
            std::printf("shprobe %s\n", SHPROBE_VERSION_STRING);
            throw CLI::Success();
        },
        "Print the version and exit");
    shprobe::BakeOptions bake;
    shprobe::ConvertOptions convert;
    shprobe::InfoOptions info;
    shprobe::RenderOptions render;
    shprobe::ViewOptions view;
    shprobe::RotateOptions rotate;
    shprobe::LightCommandOptions light;
    shprobe::BenchOptions bench;
    shprobe::addBakeCommand(app, bake);
    shprobe::addConvertCommand(app, convert);
    shprobe::addInfoCommand(app, info);
    shprobe::addRenderCommand(app, render);
    shprobe::addViewCommand(app, view);
    shprobe::addRotateCommand(app, rotate);
    shprobe::addLightCommand(app, light);
    shprobe::addBenchCommand(app, bench);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e); // --help
        std::fprintf(stderr, "shprobe: error: %s (see --help)\n", oneLine(e.what()).c_str());
        return 2;
    }

    try {
        if (app.got_subcommand("bake")) shprobe::runBake(bake);
        if (app.got_subcommand("convert")) shprobe::runConvert(convert);
        if (app.got_subcommand("info")) shprobe::runInfo(info);
        if (app.got_subcommand("render")) shprobe::runRender(render);
        if (app.got_subcommand("view")) shprobe::runView(view);
        if (app.got_subcommand("rotate")) shprobe::runRotate(rotate);
        if (app.got_subcommand("light")) shprobe::runLight(light);
        if (app.got_subcommand("bench")) shprobe::runBench(bench);
    } catch (const shprobe::Error& e) {
        std::fprintf(stderr, "shprobe: error: %s\n", oneLine(e.what()).c_str());
        return exitCode(e.kind());
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "shprobe: error: out of memory\n");
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "shprobe: internal error: %s\n", oneLine(e.what()).c_str());
        return 1;
    }
    return 0;
}
