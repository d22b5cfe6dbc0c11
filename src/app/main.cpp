// shprobe: bakes HDR environments into spherical-harmonics light probes on the GPU.
#include "app/bench.h"
#include "app/bench_job.h"
#include "app/commands.h"
#include "app/program.h"
#include "common/error.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <functional>
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
void addBench(CLI::App& command, shprobe::BenchOptions& bench, shprobe::BenchJobOptions& job) {
    shprobe::addBenchOptions(command, bench);
    shprobe::addBenchJobOptions(command, job);
    command.footer("shprobe-bench, installed beside shprobe, runs the same measurements without "
                   "--decode and --write-layouts, and needs only the Vulkan loader (docs/benchmark.md)");
}

void runBench(const shprobe::BenchOptions& bench, const shprobe::BenchJobOptions& job) {
    if (shprobe::benchJobRequested(job)) return shprobe::runBenchJob(job, bench.repeat, bench.json);
    shprobe::runBench(bench);
}

// One subcommand: its name and summary (the top-level --help lists them all), the options it adds
// to its parser and what it runs once parsed.
struct Command {
    const char* name;
    std::string summary;
    std::function<void(CLI::App& command)> addOptions;
    std::function<void(const CLI::App& command)> run;
};

// The command a command line names: its first argument that is not an option (the program's own
// options, --help and --version, take no value).
std::string_view commandNamed(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (argv[i][0] != '-') return argv[i];
    return {};
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
    shprobe::RelightOptions relight;
    shprobe::TransferCommandOptions transfer;
    shprobe::BenchOptions bench;
    shprobe::BenchJobOptions benchJob;
    const Command commands[] = {
        {"bake", "Project environments onto SH and write the coefficients",
         [&](CLI::App& c) { shprobe::addBakeOptions(c, bake); },
         [&](const CLI::App&) { shprobe::runBake(bake); }},
        {"convert",
         "Write a probe file in another format: the engine exports of docs/exports.md and bake's formats",
         [&](CLI::App& c) { shprobe::addConvertOptions(c, convert); },
         [&](const CLI::App&) { shprobe::runConvert(convert); }},
        {"info", "List Vulkan devices and the features shprobe uses",
         [&](CLI::App& c) { shprobe::addInfoOptions(c, info); },
         [&](const CLI::App&) { shprobe::runInfo(info); }},
        {"render", "Render a sphere lit by a probe to an image (no window)",
         [&](CLI::App& c) { shprobe::addRenderOptions(c, render); },
         [&](const CLI::App&) { shprobe::runRender(render); }},
        // Everything after `view` is the viewer's, --help included, and goes to it untouched.
        {"view",
         std::string(shprobe::kViewSummary) +
             " (runs shprobe-view, installed beside shprobe: see `shprobe view --help`; exit 4 where it "
             "is not, as in a build with SHPROBE_BUILD_VIEWER=OFF)",
         [](CLI::App&) {}, [&](const CLI::App&) { runViewer(argv); }},
        {"rotate", "Rotate a probe: a light from d then comes from R d",
         [&](CLI::App& c) { shprobe::addRotateOptions(c, rotate); },
         [&](const CLI::App&) { shprobe::runRotate(rotate); }},
        {"light", "Write the probe of analytic lights",
         [&](CLI::App& c) { shprobe::addLightOptions(c, light); },
         [&](const CLI::App&) { shprobe::runLight(light); }},
        {"scene",
         "Bake a grid of light probes inside a glTF scene, by rays on the CPU or on a Vulkan device, into a "
         "probe volume (docs/scene-probes.md)",
         [&](CLI::App& c) { shprobe::addSceneOptions(c, scene); },
         [&](const CLI::App& c) {
             scene.bouncesGiven = c.count("--bounces") > 0;
             shprobe::runScene(scene);
         }},
        {"transfer",
         "Bake per-vertex radiance transfer of a glTF scene (any sky relights it) into the scene's "
         "vertex attributes, by rays on the CPU or a Vulkan device (docs/transfer.md)",
         [&](CLI::App& c) { shprobe::addTransferOptions(c, transfer); },
         [&](const CLI::App& c) {
             transfer.bouncesGiven = c.count("--bounces") > 0;
             transfer.raysGiven = c.count("--rays") > 0;
             shprobe::runTransfer(transfer);
         }},
        {"merge", "Join the bricks of one `shprobe scene` bake into its whole volume",
         [&](CLI::App& c) { shprobe::addMergeOptions(c, merge); },
         [&](const CLI::App&) { shprobe::runMerge(merge); }},
        {"relight",
         "Light a probe volume baked with `shprobe scene --transfer` by another sky, or its sky turned, "
         "without a capture",
         [&](CLI::App& c) { shprobe::addRelightOptions(c, relight); },
         [&](const CLI::App&) { shprobe::runRelight(relight); }},
        {"bench", shprobe::kBenchSummary, [&](CLI::App& c) { addBench(c, bench, benchJob); },
         [&](const CLI::App&) { runBench(bench, benchJob); }},
    };
    // Only the command the line names gets its options: constructing every command's options was
    // much of what `shprobe --help` ran (docs/benchmark.md).
    const std::string_view named = commandNamed(argc, argv);
    std::string names;
    bool known = named.empty();
    for (const Command& command : commands) {
        CLI::App* parser = app.add_subcommand(command.name, command.summary);
        if (named == command.name) command.addOptions(*parser);
        known = known || named == command.name;
        names += names.empty() ? command.name : std::string(", ") + command.name;
    }
    app.preparse_callback([&](std::size_t) {
        if (!known)
            throw CLI::ValidationError("there is no command \"" + std::string(named) +
                                       "\"; the commands are " + names);
    });

    // `shprobe view ARGS`: only `shprobe view` itself is parsed here.
    const bool view = argc > 1 && std::string_view(argv[1]) == "view";
    return shprobe::endProgram(shprobe::runProgram(app, "shprobe", view ? 2 : argc, argv, [&] {
        for (const Command& command : commands)
            if (app.got_subcommand(command.name)) command.run(*app.get_subcommand(command.name));
    }));
}
