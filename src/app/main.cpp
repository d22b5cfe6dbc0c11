// shprobe: bakes HDR environments into spherical-harmonics light probes on the GPU.
#include "app/bench.h"
#include "app/bench_job.h"
#include "app/commands.h"
#include "app/program.h"
#include "shprobe/sh/error.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <unistd.h>
#include <vector>

namespace {

// `shprobe view ARGS`: the viewer is a program of its own, shprobe-view, so that shprobe links no
// window system. It is taken from this program's folder (the build folder, or the installed bin/),
// never from PATH, so that a shprobe runs its own build's viewer, and it replaces this process with
// ARGS untouched and shprobe's argv[0] (it then reads as `shprobe view`). A build without GLFW has
// none: exit 4, as for a missing display or device.
void runViewer(char** argv) {
    std::error_code error;
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
    if (error)
        throw shprobe::Error(shprobe::ErrorKind::Device,
                             "cannot find the viewer: /proc/self/exe: " + error.message());
    const std::string viewer = (self.parent_path() / "shprobe-view").string();
    std::vector<char*> args{argv[0]};
    for (char** arg = argv + 2; *arg != nullptr; ++arg)
        args.push_back(*arg);
    args.push_back(nullptr);
    execv(viewer.c_str(), args.data());
    if (errno == ENOENT)
        throw shprobe::Error(shprobe::ErrorKind::Device,
                             "the viewer is not installed: there is no " + viewer +
                                 " (a build with -DSHPROBE_BUILD_VIEWER=OFF has none, nor needs GLFW); "
                                 "`shprobe render` draws the same scene to an image file");
    throw shprobe::Error(shprobe::ErrorKind::Device,
                         "cannot run the viewer " + viewer + ": " + std::strerror(errno));
}

// `shprobe bench`: the kernel benchmark (bench.h, all of shprobe-bench) and the whole-job
// benchmark's in-process parts (bench_job.h), which read and write image files.
void addBench(CLI::App& app, shprobe::BenchOptions& bench, shprobe::BenchJobOptions& job) {
    CLI::App* command = app.add_subcommand("bench", shprobe::kBenchSummary);
    shprobe::addBenchOptions(*command, bench);
    shprobe::addBenchJobOptions(*command, job);
    command->footer("shprobe-bench, installed beside shprobe, runs the same measurements without "
                    "--decode and --write-layouts, and needs only the Vulkan loader (docs/benchmark.md)");
}

void runBench(const shprobe::BenchOptions& bench, const shprobe::BenchJobOptions& job) {
    if (shprobe::benchJobRequested(job)) return shprobe::runBenchJob(job, bench.repeat, bench.json);
    shprobe::runBench(bench);
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"shprobe: bake HDR environments into spherical-harmonics light probes with Vulkan "
                 "(conventions: docs/conventions.md)"};
    app.require_subcommand(1);
    shprobe::addVersionFlag(app, "shprobe");
    shprobe::BakeOptions bake;
    shprobe::ConvertOptions convert;
    shprobe::InfoOptions info;
    shprobe::RenderOptions render;
    shprobe::RotateOptions rotate;
    shprobe::LightCommandOptions light;
    shprobe::SceneOptions scene;
    shprobe::MergeOptions merge;
    shprobe::BenchOptions bench;
    shprobe::BenchJobOptions benchJob;
    shprobe::addBakeCommand(app, bake);
    shprobe::addConvertCommand(app, convert);
    shprobe::addInfoCommand(app, info);
    shprobe::addRenderCommand(app, render);
    app.add_subcommand("view",
                       std::string(shprobe::kViewSummary) +
                           " (runs shprobe-view, installed beside shprobe: see `shprobe view "
                           "--help`; exit 4 where it is not, as in a build with SHPROBE_BUILD_VIEWER=OFF)");
    shprobe::addRotateCommand(app, rotate);
    shprobe::addLightCommand(app, light);
    shprobe::addSceneCommand(app, scene);
    shprobe::addMergeCommand(app, merge);
    addBench(app, bench, benchJob);

    // Everything after `view` is the viewer's, --help included, and goes to it untouched: only
    // `shprobe view` itself is parsed here.
    const bool view = argc > 1 && std::string_view(argv[1]) == "view";
    return shprobe::runProgram(app, "shprobe", view ? 2 : argc, argv, [&] {
        if (view) runViewer(argv);
        if (app.got_subcommand("bake")) shprobe::runBake(bake);
        if (app.got_subcommand("convert")) shprobe::runConvert(convert);
        if (app.got_subcommand("info")) shprobe::runInfo(info);
        if (app.got_subcommand("render")) shprobe::runRender(render);
        if (app.got_subcommand("rotate")) shprobe::runRotate(rotate);
        if (app.got_subcommand("light")) shprobe::runLight(light);
        if (app.got_subcommand("scene"))
            shprobe::runScene(scene, app.get_subcommand("scene")->count("--bounces") > 0);
        if (app.got_subcommand("merge")) shprobe::runMerge(merge);
        if (app.got_subcommand("bench")) runBench(bench, benchJob);
    });
}
