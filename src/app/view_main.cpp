// shprobe-view: the interactive viewer (view.cpp). It is a program of its own, the only one that links
// GLFW, so that shprobe bakes where no display library is installed; `shprobe view ARGS` runs it with
// ARGS.
#include "app/commands.h"
#include "app/program.h"

#include <filesystem>

int main(int argc, char** argv) {
    // Run by `shprobe view`, it keeps shprobe's argv[0], and its usage and errors read as that
    // command's ("shprobe: error: ...", as every other command prints).
    const bool viaShprobe = argc > 0 && std::filesystem::path(argv[0]).filename() == "shprobe";
    const char* name = viaShprobe ? "shprobe" : "shprobe-view";
    CLI::App app{std::string(shprobe::kViewSummary) +
                     " (conventions: docs/conventions.md; without a display, `shprobe render` draws the "
                     "same scene to an image file)",
                 viaShprobe ? "shprobe view" : "shprobe-view"};
    shprobe::addVersionFlag(app, "shprobe-view");
    shprobe::ViewOptions options;
    shprobe::addViewOptions(app, options);
    return shprobe::runProgram(app, name, argc, argv, [&] { shprobe::runView(options); });
}
