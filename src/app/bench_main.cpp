// shprobe-bench: `shprobe bench`'s measurements (bench.h) as a program of its own, which links no
// image library and needs only the Vulkan loader, so that it can be copied alone to a GPU machine
// (docs/benchmark.md). `shprobe bench --decode` and `--write-layouts`, the whole-job benchmark's
// parts, read and write image files: given here, they are refused in one line that names them.
#include "app/bench.h"
#include "app/program.h"
#include "common/error.h"

#include <array>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    CLI::App app{std::string("shprobe-bench: ") + shprobe::kBenchSummary +
                 " (generated inputs; needs only the Vulkan loader)"};
    shprobe::addVersionFlag(app, "shprobe-bench");
    shprobe::BenchOptions bench;
    shprobe::addBenchOptions(app, bench);
    // Hidden from --help (group ""): parsed only to be refused in a clearer line than "not expected".
    const std::array<std::string, 2> imageOptions{"--decode", "--write-layouts"};
    std::vector<std::string> imageArguments;
    for (const std::string& name : imageOptions)
        app.add_option(name, imageArguments)->group("");
    app.footer("`shprobe bench` takes the same options, and also --decode and --write-layouts, which read "
               "and write image files (shprobe-bench links no image codec).");

    return shprobe::runProgram(app, "shprobe-bench", argc, argv, [&] {
        for (const std::string& name : imageOptions)
            if (app.count(name) > 0)
                throw shprobe::Error(shprobe::ErrorKind::Input,
                                     name + " needs the image codecs, which shprobe-bench "
                                            "does not link: run it with `shprobe bench`");
        shprobe::runBench(bench);
    });
}
