// `shprobe scene` and `shprobe merge` end to end, on lavapipe with the validation layer on: a
// Cornell box written by the test (scene_fixtures.h) baked whole and in bricks, the bricks merged
// to the whole bake byte for byte, bounce after bounce; a real scene (Debian's assimp-testmodels)
// baked; and every broken glTF there refused in one line, leaving no file.
#include "child_program.h"
#include "scene_fixtures.h"
#include "terminal_run.h"

#include "formats/probe_file.h"
#include "formats/probe_volume.h"
#include "image/environment.h"
#include "image/image_write.h"
#include "scene/probe_grid.h"
#include "sh/projection.h"

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <map>
#include <span>
#include <sys/stat.h>
#include <tuple>

namespace shprobe {
namespace {

using testing::runOnTerminal;
using testing::TerminalRun;

class SceneCommand : public ProgramTest {
  protected:
    // Runs `args` and `extra` writing to `output`; it must succeed.
    void runWithOutput(std::vector<std::string> args, const std::vector<std::string>& extra,
                       const std::string& output) const {
        args.insert(args.end(), extra.begin(), extra.end());
        args.insert(args.end(), {"-o", output});
        runOk(args);
    }
    std::string cornellBox() const {
        const std::string path = file("cornell.glb");
        testing::writeCornellBoxGltf(path, {.closed = true, .innerBoxes = true});
        return path;
    }
};

std::string bytesOf(const std::string& path) {
    return readText(path);
}

// A ray bake of more than a second draws a progress line on a terminal ("probes 12/216, 3.1 Mrays/s,
// 2 s left"), redrawn at most 4 times a second and erased at the end; nothing of it with -q or with
// stderr in a file, and stdout is the same either way. The bake casts 4 times the rays until it takes
// more than a second, so that it shows its progress on a fast machine and stays short on a slow one.
TEST_F(SceneCommand, ProgressLineOnlyOnATerminal) {
    const std::string scene = cornellBox();
    std::vector<std::string> bake;
    auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = bake;
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    TerminalRun shown;
    for (int rays = 4; rays <= 1024; rays *= 4) {
        bake = {"scene",
                scene,
                "--backend",
                "cpu",
                "--grid",
                "6,6,6",
                "--bounces",
                "2",
                "--rays-per-texel",
                std::to_string(rays)};
        shown = runOnTerminal(with({"-o", file("shown.shpv")}), folder() / "shown.out");
        ASSERT_EQ(shown.exitCode, 0) << shown.terminal;
        if (shown.seconds > 1.0) break;
    }
    ASSERT_GT(shown.seconds, 1.0) << "the bake is too short to show its progress";
    EXPECT_CONTAINS(shown.terminal, "\rprobes ");
    EXPECT_CONTAINS(shown.terminal, "/216, ");
    EXPECT_CONTAINS(shown.terminal, "rays/s");
    EXPECT_CONTAINS(shown.terminal, " s left");
    EXPECT_TRUE(shown.terminal.ends_with("\r\033[K")) << "the line is erased at the end: " << shown.terminal;
    EXPECT_LE(double(testing::drawsOf(shown.terminal, "\rprobes ")), 4.0 * shown.seconds + 2.0)
        << shown.terminal;

    const TerminalRun quiet = runOnTerminal(with({"-q", "-o", file("quiet.shpv")}), folder() / "quiet.out");
    EXPECT_EQ(quiet.exitCode, 0) << quiet.terminal;
    EXPECT_EQ(quiet.terminal, "");

    const RunResult plain = run(with({"-o", file("plain.shpv")}));
    EXPECT_EQ(plain.exitCode, 0) << describe(plain);
    EXPECT_EQ(plain.err, "");
    EXPECT_EQ(linesOf(readText(folder() / "shown.out")).size(), linesOf(plain.out).size());
    EXPECT_EQ(bytesOf(file("shown.shpv")), bytesOf(file("plain.shpv")));
}

// `shprobe info` says what `scene --backend auto` runs, and a scene bake under auto runs that, for
// the reason info gives.
TEST_F(SceneCommand, InfoSaysWhatAutoRuns) {
    const RunResult info = run({"info"});
    ASSERT_EQ(info.exitCode, 0) << describe(info);
    const std::string marker = "scene    --backend auto (the default): ";
    const size_t at = info.out.find(marker);
    ASSERT_NE(at, std::string::npos) << info.out;
    const std::string said =
        info.out.substr(at + marker.size(), info.out.find('\n', at) - at - marker.size());
    const RunResult bake =
        run({"scene", cornellBox(), "--grid", "2,2,2", "--bounces", "0", "-o", file("auto.shpv")});
    ASSERT_EQ(bake.exitCode, 0) << describe(bake);
    if (said.starts_with("cpu (")) {
        const std::string reason = said.substr(5, said.size() - 6);
        EXPECT_CONTAINS(bake.out, "backend  cpu: ");
        EXPECT_CONTAINS(bake.out, "(auto: " + reason + ")");
    } else {
        EXPECT_CONTAINS(bake.out, "backend  gpu: ");
    }
}

// On the gpu backend a brick bakes every bounce of its probes, the surface cache gathered whole
// (--bounce-light cache: auto takes paths for so few probes, GpuBricksByPathsMergeToTheWholeBake):
// bounce 0 in three bricks, merged, must be the whole bounce-0 bake byte for byte (each probe's
// capture and bake do not depend on which probes share its batch); so must bounce 1 in bricks after
// the merged bounce 0 (--previous), against the whole --bounces 1 bake.
// The grid is 3x3x3 inside the box, faces 16^2: small enough for lavapipe, and the bricks cut through batches
// of 4 probes. merge reports what it joined, and nothing with -q.
TEST_F(SceneCommand, BricksMergeToTheWholeBake) {
    const std::string scene = cornellBox();
    const std::vector<std::string> common{
        "scene", scene,       "--grid", "3,3,3", "--face-size",    "16",   "--probes-per-batch",
        "4",     "--backend", "gpu",    "-q",    "--bounce-light", "cache"};
    auto bake = [&](const std::vector<std::string>& extra, const std::string& output) {
        runWithOutput(common, extra, output);
    };
    bake({"--bounces", "0"}, file("whole0.shpv"));
    bake({"--bounces", "1"}, file("whole1.shpv"));
    std::vector<std::string> merge0{"merge"}, merge1{"merge"};
    for (const char* brick : {"2/3", "0/3", "1/3"}) {
        const std::string name = file(std::string("b0_") + brick[0] + ".shpv");
        bake({"--brick", brick, "--bounces", "0"}, name);
        merge0.push_back(name);
    }
    std::vector<std::string> args = merge0;
    args.insert(args.end(), {"-o", file("merged0.shpv")});
    EXPECT_CONTAINS(runOk(args).out, "merged   3 bricks into");
    EXPECT_EQ(bytesOf(file("merged0.shpv")), bytesOf(file("whole0.shpv")));
    std::vector<std::string> quiet = merge0; // -q: the same volume, no report
    quiet.insert(quiet.end(), {"-q", "-o", file("quiet0.shpv")});
    EXPECT_EQ(runOk(quiet).out, "");
    EXPECT_EQ(bytesOf(file("quiet0.shpv")), bytesOf(file("whole0.shpv")));
    for (const char* brick : {"1/3", "0/3", "2/3"}) {
        const std::string name = file(std::string("b1_") + brick[0] + ".shpv");
        bake({"--brick", brick, "--previous", file("merged0.shpv")}, name);
        merge1.push_back(name);
    }
    merge1.insert(merge1.end(), {"-o", file("merged1.shpv")});
    runOk(merge1);
    EXPECT_EQ(bytesOf(file("merged1.shpv")), bytesOf(file("whole1.shpv")));

    // The closed box's light reaches every probe, and bounce 1 adds light to bounce 0 everywhere.
    const ProbeVolume zero = readProbeVolume(file("whole0.shpv"));
    const ProbeVolume one = readProbeVolume(file("whole1.shpv"));
    ASSERT_EQ(zero.probeCount(), 27u);
    EXPECT_EQ(one.bounces, 1);
    for (uint32_t p = 0; p < zero.probeCount(); ++p) {
        if (!zero.valid[p]) continue; // inside an inner block
        EXPECT_GT(one.radiance[p * 9].g, zero.radiance[p * 9].g) << "probe " << p;
    }
}

// On the gpu backend bounces by paths (--bounce-light paths) name each probe's random numbers by its
// place in the world: bricks of a two-bounce bake merge to the whole bake byte for byte, the volume
// records the bounce light, and the report says it. For this grid (27 probes of 6 x 8^2 rays against
// the cache's thousands of points of 64 rays) auto takes paths too, the same bytes.
TEST_F(SceneCommand, GpuBricksByPathsMergeToTheWholeBake) {
    const std::string scene = cornellBox();
    const std::vector<std::string> common{
        "scene",     scene, "--grid",    "3,3,3", "--face-size",        "8",
        "--bounces", "2",   "--backend", "gpu",   "--probes-per-batch", "4"};
    std::vector<std::string> reported = common;
    reported.insert(reported.end(), {"--bounce-light", "paths", "-o", file("whole.shpv")});
    const RunResult whole = runOk(reported);
    EXPECT_CONTAINS(whole.out, "bounces by paths from the probes' hits");
    std::vector<std::string> merge{"merge"};
    for (const char* brick : {"1/2", "0/2"}) {
        const std::string name = file(std::string("b_") + brick[0] + ".shpv");
        runWithOutput(common, {"--brick", brick, "--bounce-light", "paths", "-q"}, name);
        merge.push_back(name);
    }
    merge.insert(merge.end(), {"-o", file("merged.shpv")});
    runOk(merge);
    EXPECT_EQ(bytesOf(file("merged.shpv")), bytesOf(file("whole.shpv")));
    runWithOutput(common, {"-q"}, file("auto.shpv"));
    EXPECT_EQ(bytesOf(file("auto.shpv")), bytesOf(file("whole.shpv")));
    const ProbeVolume volume = readProbeVolume(file("whole.shpv"));
    EXPECT_EQ(volume.bounces, 2);
    EXPECT_CONTAINS(volume.settings, "\"bounce_light\":\"paths\"");
    EXPECT_CONTAINS(volume.settings, "\"backend\":\"gpu\"");
}

// On the cpu backend every run bakes all bounces of its probes, the surfaces' cache gathered where
// they need it with random numbers named by the point: bricks of a two-bounce bake merge to the
// whole bake byte for byte, and a second whole run gives the same bytes.
TEST_F(SceneCommand, RayBricksMergeToTheWholeBake) {
    const std::string scene = cornellBox();
    const std::vector<std::string> common{"scene",     scene, "--grid",    "3,3,3", "--face-size", "8",
                                          "--bounces", "2",   "--backend", "cpu",   "-q"};
    auto bake = [&](const std::vector<std::string>& extra, const std::string& output) {
        runWithOutput(common, extra, output);
    };
    bake({}, file("whole.shpv"));
    bake({}, file("again.shpv"));
    EXPECT_EQ(bytesOf(file("again.shpv")), bytesOf(file("whole.shpv")));
    std::vector<std::string> merge{"merge"};
    for (const char* brick : {"1/2", "0/2"}) {
        const std::string name = file(std::string("b_") + brick[0] + ".shpv");
        bake({"--brick", brick}, name);
        merge.push_back(name);
    }
    merge.insert(merge.end(), {"-o", file("merged.shpv")});
    runOk(merge);
    EXPECT_EQ(bytesOf(file("merged.shpv")), bytesOf(file("whole.shpv")));
    const ProbeVolume volume = readProbeVolume(file("whole.shpv"));
    EXPECT_EQ(volume.bounces, 2);
    EXPECT_CONTAINS(volume.settings, "\"backend\":\"cpu\"");
}

// `scene --transfer` and `relight` (scene/volume_bake.h; the physics in test_volume_transfer): an open
// Cornell box, whose probes see the sky. Bricks with transfer merge to the whole bake byte for byte;
// relit by the sky it was baked under, a volume is its own bytes; relighting replaces the light (a
// turned volume relit by the first sky is the first volume again, byte for byte); what cannot be
// relit is refused in one line, leaving no file.
TEST_F(SceneCommand, RelightableVolumesRelightWithoutACapture) {
    const std::string scene = file("open.glb");
    testing::writeCornellBoxGltf(scene, {.innerBoxes = true});
    const std::vector<std::string> common{"scene", scene,       "--grid", "2,2,2",      "--face-size",
                                          "8",     "--bounces", "1",      "--transfer", "-q"};
    auto bake = [&](const std::vector<std::string>& extra, const std::string& output) {
        runWithOutput(common, extra, output);
    };
    bake({}, file("whole.shpv"));
    bake({"--brick", "1/2"}, file("b1.shpv"));
    bake({"--brick", "0/2"}, file("b0.shpv"));
    runOk({"merge", file("b1.shpv"), file("b0.shpv"), "-o", file("merged.shpv")});
    EXPECT_EQ(bytesOf(file("merged.shpv")), bytesOf(file("whole.shpv")));
    const ProbeVolume whole = readProbeVolume(file("whole.shpv"));
    EXPECT_EQ(whole.transfer.size(), size_t(8 * 81));
    EXPECT_CONTAINS(whole.settings, "\"transfer\":true");

    runOk({"relight", file("whole.shpv"), "-q", "-o", file("same.shpv")});
    EXPECT_EQ(bytesOf(file("same.shpv")), bytesOf(file("whole.shpv")));
    // --timings on a volume this small: times of microseconds, in significant digits (not "0.00 ms").
    const RunResult timed = runOk({"relight", file("whole.shpv"), "--timings", "-o", file("timed.shpv")});
    EXPECT_CONTAINS(timed.out, "of that bound");
    EXPECT_EQ(timed.out.find(" 0.00 ms"), std::string::npos) << timed.out;
    const RunResult report =
        runOk({"relight", file("whole.shpv"), "--yaw", "90", "--pitch", "-20", "-o", file("turned.shpv")});
    EXPECT_CONTAINS(report.out, "turned yaw 90, pitch -20");
    const ProbeVolume turned = readProbeVolume(file("turned.shpv"));
    EXPECT_NE(turned.radiance, whole.radiance);
    EXPECT_CONTAINS(turned.settings, "\"sky_turn\":[90.0,-20.0]");
    runOk({"relight", file("turned.shpv"), "-q", "-o", file("back.shpv")});
    EXPECT_EQ(bytesOf(file("back.shpv")), bytesOf(file("whole.shpv")));
    // A sky whose light the transfer carries past float: refused as the input it is, nothing written.
    ShCoefficients blinding = makeCoefficients(3, Quantity::Radiance);
    for (glm::dvec3& coefficient : blinding.rgb)
        coefficient = glm::dvec3(1e38);
    writeProbeFile(file("blinding.json"), blinding, {});
    expectFailure({{"relight", file("whole.shpv"), "--probe", file("blinding.json"), "-o", "OUT"},
                   2,
                   {"overflows float", "the sky " + file("blinding.json") + ", or the transfer in " +
                                           file("whole.shpv") + ", is far too strong"},
                   "out.shpv"});

    runOk({"scene", scene, "--grid", "1,1,1", "--face-size", "4", "--backend", "cpu", "-q", "-o",
           file("plain.shpv")});
    expectFailure(
        {{"relight", file("plain.shpv"), "-o", "OUT"}, 2, {"holds no transfer", "--transfer"}, "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "1,1,1", "--transfer", "--backend", "gpu", "-o", "OUT"},
                   2,
                   {"--transfer", "cpu"},
                   "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "1,1,1", "--transfer", "--cache-refinement", "2", "-o", "OUT"},
                   2,
                   {"--cache-refinement", "linear"},
                   "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "1,1,1", "--transfer", "--bounce-light", "paths", "-o", "OUT"},
                   2,
                   {"--bounce-light paths", "linear"},
                   "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "1,1,1", "--cache-refinement", "2", "--bounce-light", "paths",
                    "-o", "OUT"},
                   2,
                   {"--cache-refinement", "keeps no cache"},
                   "out.shpv"});
}

// --rays-per-texel is rounded up to a square, and the bake says and records the rays it cast: 3 and 4
// (2 x 2) give the same volume and the summary "4 per texel" (they differed in the recorded count and
// the sky's averaging, so their bricks would not merge).
TEST_F(SceneCommand, RaysPerTexelAreRoundedUpToASquare) {
    const std::string scene = cornellBox();
    for (const char* rays : {"3", "4"}) {
        const RunResult result =
            run({"scene", scene, "--grid", "2,2,2", "--face-size", "4", "--bounces", "0", "--backend", "cpu",
                 "--rays-per-texel", rays, "-o", file(rays + std::string(".shpv"))});
        ASSERT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_CONTAINS(result.out, "4 per texel");
    }
    EXPECT_TRUE(bytesOf(file("3.shpv")) == bytesOf(file("4.shpv")));
}

// A --cache-spacing finer than a triangle's lattice may be (kMaxCacheSubdivisions of its longest
// edge) is said in one warning line, with the triangles it caps and the spacing they keep, and the
// bake goes on. The closed box's 12 wall triangles have edges of 2 sqrt 2 = 2.83: at 0.008 they
// would need 354 subdivisions and keep 2.83 / 256 = 0.011; its inner boxes' longest, 1.34, needs
// 168. At 0.02 no lattice is capped and nothing is said.
TEST_F(SceneCommand, CacheSpacingFinerThanALatticeHoldsIsSaid) {
    const std::string scene = cornellBox();
    auto bake = [&](const std::string& spacing) {
        const RunResult result = run({"scene", scene, "--grid", "1,1,1", "--face-size", "2", "--bounces", "1",
                                      "--bounce-light", "cache", "--gather-rays", "1", "--backend", "cpu",
                                      "--cache-spacing", spacing, "-q", "-o", file(spacing + ".shpv")});
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        return result;
    };
    const RunResult capped = bake("0.008");
    EXPECT_EQ(linesOf(capped.err).size(), 1u) << capped.err;
    EXPECT_CONTAINS(capped.err, "shprobe: warning: --cache-spacing 0.008: 12 triangles would need more "
                                "than 256 subdivisions of an edge; they have 256, their points up to 0.011 "
                                "apart");
    EXPECT_NO_THROW(readProbeVolume(file("0.008.shpv")));
    EXPECT_EQ(bake("0.02").err, "");
}

// A volume written to standard output is the file's bytes alone: scene's, merge's and relight's
// summaries then go to stderr, as bake's do (they were appended to the stream, which merge then
// refused as longer than its header says).
TEST_F(SceneCommand, VolumesOnStandardOutputHoldNoSummary) {
    const std::string scene = file("open.glb");
    testing::writeCornellBoxGltf(scene, {});
    const std::vector<std::string> bake{"scene", scene,       "--grid", "2,2,2",     "--face-size",
                                        "4",     "--bounces", "0",      "--transfer"};
    auto to = [](std::vector<std::string> args, const std::string& output) {
        args.insert(args.end(), {"-o", output});
        return args;
    };
    auto brick = [&](const char* which) {
        std::vector<std::string> args = bake;
        args.insert(args.end(), {"--brick", which});
        return args;
    };
    runOk(to(bake, file("whole.shpv")));
    runOk(to(brick("0/2"), file("b0.shpv")));
    runOk(to(brick("1/2"), file("b1.shpv")));
    runOk(to({"relight", file("whole.shpv")}, file("relit.shpv")));
    const std::vector<std::tuple<std::vector<std::string>, std::string, std::string>> cases = {
        {bake, "whole.shpv", "wrote    -"},
        {{"merge", file("b0.shpv"), file("b1.shpv")}, "whole.shpv", "merged   2 bricks into -"},
        {{"relight", file("whole.shpv")}, "relit.shpv", "wrote    -"},
    };
    for (const auto& [args, same, summary] : cases) {
        SCOPED_TRACE(args[0]);
        const RunResult result = run(to(args, "-"));
        ASSERT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_TRUE(result.out == bytesOf(file(same))) << result.out.size() << " bytes on stdout";
        EXPECT_CONTAINS(result.err, summary);
    }
}

// Probe relocation on the cpu backend, in the closed Cornell box with its blocks: of a 4x3x3 grid
// (cells 0.24 along x, 0.8 along y, 0.5 along z), five probes lie inside a block 0.06 from a face and
// are moved out, each by at most 0.45 of 0.24 and valid where it was captured; two lie in the tall
// block's middle, 0.2 from any face, and stay inside (invalid, then filled). Bricks (baking the
// neighbours they fill from, relocated as the whole bake relocates them) merge to the whole bake
// byte for byte, and a second run repeats it. With --relocation-limit 0 the volume holds no capture
// offsets (neither the header's key and setting nor the section: the volume of a bake before
// relocation), and every probe that did not move is the relocating bake's, bit for bit.
TEST_F(SceneCommand, ProbesInsideGeometryAreMovedOut) {
    const std::string scene = cornellBox();
    const std::vector<std::string> common{
        "scene",       scene, "--grid",    "4,3,3", "--bounds",  "-0.58,0.2,-0.3,0.14,1.8,0.7",
        "--face-size", "8",   "--bounces", "1",     "--backend", "cpu"};
    auto bake = [&](std::vector<std::string> extra, const std::string& output) {
        std::vector<std::string> args = common;
        args.insert(args.end(), extra.begin(), extra.end());
        args.insert(args.end(), {"-o", output});
        return runOk(args);
    };
    const std::string report = bake({}, file("moved.shpv")).out;
    EXPECT_CONTAINS(report, "invalid  7 inside geometry");
    EXPECT_CONTAINS(
        report, "moved    5 out of geometry (by at most 0.45 of the smallest cell side), 2 stayed inside");
    EXPECT_CONTAINS(report, "filled   2 invalid probes");
    bake({"-q"}, file("again.shpv"));
    EXPECT_EQ(bytesOf(file("again.shpv")), bytesOf(file("moved.shpv")));
    std::vector<std::string> merge{"merge"};
    for (const char* brick : {"2/3", "0/3", "1/3"}) {
        const std::string name = file(std::string("moved_") + brick[0] + ".shpv");
        bake({"--brick", brick, "-q"}, name);
        merge.push_back(name);
    }
    merge.insert(merge.end(), {"-o", file("merged.shpv")});
    runOk(merge);
    EXPECT_EQ(bytesOf(file("merged.shpv")), bytesOf(file("moved.shpv")));

    bake({"--no-dilation", "-q"}, file("kept.shpv"));
    bake({"--no-dilation", "--relocation-limit", "0", "-q"}, file("fixed.shpv"));
    EXPECT_EQ(bytesOf(file("fixed.shpv")).find("capture_offsets"), std::string::npos);
    EXPECT_EQ(bytesOf(file("fixed.shpv")).find("relocation_limit"), std::string::npos);
    const ProbeVolume moved = readProbeVolume(file("kept.shpv"));
    const ProbeVolume fixed = readProbeVolume(file("fixed.shpv"));
    EXPECT_TRUE(fixed.offsets.empty());
    ASSERT_EQ(moved.offsets.size(), size_t(36));
    int count = 0;
    for (uint32_t p = 0; p < 36; ++p) {
        const std::span<const glm::vec3> a(&moved.radiance[p * 9], 9), b(&fixed.radiance[p * 9], 9);
        if (moved.offsets[p] == glm::vec3(0.0f)) {
            EXPECT_EQ(moved.valid[p], fixed.valid[p]) << p;
            EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin())) << p;
            continue;
        }
        ++count;
        EXPECT_LE(glm::length(moved.offsets[p]), 0.45f * 0.24f) << p;
        EXPECT_EQ(moved.valid[p], 1) << p;
        EXPECT_EQ(fixed.valid[p], 0) << p;
    }
    EXPECT_EQ(count, 5);
}

// Both backends write the capture offsets alike: where relocation can move a probe (a grid with
// cells), even if none moved, and not for a single probe, which has no cell to move within (the gpu
// backend wrote them, all zero, where the cpu did not).
TEST_F(SceneCommand, CaptureOffsetsAreWrittenAlikeByBothBackends) {
    const std::string scene = cornellBox();
    for (const char* grid : {"1,1,1", "2,2,2"})
        for (const char* backend : {"cpu", "gpu"}) {
            const std::string output = file(std::string("offsets_") + backend + ".shpv");
            runOk({"scene", scene, "--grid", grid, "--bounds", "-0.3,0.5,-0.3,0.3,1.5,0.3", "--face-size",
                   "4", "--bounces", "0", "--backend", backend, "-q", "-o", output});
            EXPECT_EQ(bytesOf(output).find("\"capture_offsets\": true") != std::string::npos,
                      grid == std::string("2,2,2"))
                << grid << " on " << backend;
        }
}

// The two rooms of scene_fixtures.h (a lit room, a closed one, a 2 cm wall between them) with 5^3
// probes, 25 of them inside the wall (x = 0; cells 0.9 x 0.4 x 0.4), faces 16^2, one bounce: what the
// closed room's floor, back wall and ceiling receive as a share of the lit room's, with each measure
// against leaks on and off (docs/scene-probes.md's table). No light reaches the closed room: its own
// probes give it 0.0035% (the cache's cells across the wall's foot), and with visibility 0.010% with
// every measure on (one wall probe moved into the lit room), but 11.6% where the wall's probes are
// filled from their neighbours, the lit room's among them, and not moved. Checks: relocation moves
// the 25 probes out of the wall; with every measure on the share is under the 1% a renderer cannot
// show (the closed room's probes seeing the sun through the room's edges gave 1.8%), and under a
// quarter of dilation's without relocation.
TEST_F(SceneCommand, LeakMeasuresInTheTwoRooms) {
    const std::string scene = file("rooms.glb");
    testing::writeGltf(scene, testing::twoRoomsScene(), testing::GltfContainer::Glb);
    const std::vector<std::string> common{
        "scene",       scene, "--grid",    "5,5,5", "--bounds",         "-1.8,0.2,-0.8,1.8,1.8,0.8",
        "--face-size", "16",  "--bounces", "1",     "--rays-per-texel", "1",
        "--backend",   "cpu", "-q"};
    struct Measures {
        const char* name;
        std::vector<std::string> options;
    };
    const Measures bakes[] = {
        {"none", {"--invalid-back-faces", "1", "--relocation-limit", "0", "--no-dilation"}},
        {"validity", {"--relocation-limit", "0", "--no-dilation"}},
        {"validity + relocation", {"--no-dilation"}},
        {"validity + dilation", {"--relocation-limit", "0"}},
        {"validity + relocation + dilation", {}},
    };
    std::vector<double> shares;
    for (const Measures& bake : bakes) {
        std::vector<std::string> args = common;
        args.insert(args.end(), bake.options.begin(), bake.options.end());
        args.insert(args.end(), {"-o", file("rooms.shpv")});
        runOk(args);
        ProbeVolume volume = readProbeVolume(file("rooms.shpv"));
        const double seeing =
            testing::twoRoomsIrradiance(volume, 0.01, 2.0) / testing::twoRoomsIrradiance(volume, -2.0, -0.01);
        volume.visibilitySize = 0;
        volume.visibility.clear();
        const double blind =
            testing::twoRoomsIrradiance(volume, 0.01, 2.0) / testing::twoRoomsIrradiance(volume, -2.0, -0.01);
        const size_t moved =
            size_t(std::count_if(volume.offsets.begin(), volume.offsets.end(),
                                 [](const glm::vec3& offset) { return offset != glm::vec3(0.0f); }));
        std::printf(
            "%-34s %zu invalid, %2zu moved: the closed room receives %.4f%%, %.4f%% with visibility\n",
            bake.name, size_t(std::count(volume.valid.begin(), volume.valid.end(), uint8_t(0))), moved,
            100.0 * blind, 100.0 * seeing);
        if (!bake.options.empty() && bake.options[0] == "--no-dilation") {
            EXPECT_EQ(moved, 25u);
        }
        shares.push_back(seeing);
    }
    EXPECT_LT(shares[4], 0.01);
    EXPECT_LT(shares[4], 0.25 * shares[3]);

    // The gpu backend shades the same hits by the same rules, its invalid probes relocated and
    // filled as the cpu's: the same bound.
    std::vector<std::string> gpu = common;
    std::replace(gpu.begin(), gpu.end(), std::string("cpu"), std::string("gpu"));
    gpu.insert(gpu.end(), {"-o", file("rooms_gpu.shpv")});
    runOk(gpu);
    const ProbeVolume volume = readProbeVolume(file("rooms_gpu.shpv"));
    const double seeing =
        testing::twoRoomsIrradiance(volume, 0.01, 2.0) / testing::twoRoomsIrradiance(volume, -2.0, -0.01);
    std::printf("gpu backend, default measures: the closed room receives %.4f%% with visibility\n",
                100.0 * seeing);
    EXPECT_LT(seeing, 0.01);
}

// The open Cornell box with its blocks and a sun through the opening (shadows), under a root node
// scaling it by `scale`: every position, and so the default grid's bounds, scaled.
void writeScaledCornellBox(const std::string& path, float scale,
                           const glm::vec3& translation = glm::vec3(0.0f)) {
    testing::FixtureScene scene = testing::cornellBoxScene(
        {.innerBoxes = true, .sun = testing::FixtureSun{.towardsLight = {0.3f, 0.6f, 1.0f}}});
    scene.nodes.push_back({.translation = translation, .scale = glm::vec3(scale), .children = scene.roots});
    scene.roots = {int(scene.nodes.size() - 1)};
    testing::writeGltf(path, scene, testing::GltfContainer::Glb);
}

// The largest difference of two volumes' coefficients over the largest |L00| of the first.
double largestDifference(const ProbeVolume& a, const ProbeVolume& b) {
    double difference = 0.0, largest = 0.0;
    for (size_t i = 0; i < a.radiance.size(); ++i) {
        difference = std::max<double>(difference, glm::length(a.radiance[i] - b.radiance[i]));
        if (i % 9 == 0) largest = std::max<double>(largest, glm::length(a.radiance[i]));
    }
    return difference / largest;
}

// Radiance does not depend on the scene's scale (the same materials, emission and sky, and a sun's
// irradiance in lux): the room at 1e-6, 1 and 1e6 times its size, probes scaled with it, bakes to
// the same coefficients on both backends. Float rounds the scaled positions (2^-24 of each
// coordinate) and everything computed from them, so hits, shadows and sums differ in their last
// bits: the bound, 1e-4 of the largest L00, is some 100 times that rounding summed over a probe's
// texels, and far below any real change (a surface lost to a near plane changes L00 by 10-100%).
// The gpu shades its hits in float, where the cpu uses double: a texel-centre ray that meets the
// room's corner exactly (probes of a regular grid in an axis-aligned room do) takes the floor or the
// wall as rounding decides, and with them different cached light (measured 1.0% and 1.2% of the
// largest L00 at 1e-6 and 1e6; bound 2%). Its shadow rays leave from the hit moved back along the
// ray too, or rounding let a corner's shadow ray leave the room at 1e-6 (a sunlit texel lost: 10%).
TEST_F(SceneCommand, ScaledScenesBakeTheSameVolume) {
    for (const char* backend : {"cpu", "gpu"}) {
        const std::array<float, 3> scales{1e-6f, 1.0f, 1e6f};
        std::vector<ProbeVolume> volumes;
        for (size_t s = 0; s < scales.size(); ++s) {
            const std::string scene = file("room" + std::to_string(s) + ".glb");
            const std::string volume = file(std::string(backend) + std::to_string(s) + ".shpv");
            writeScaledCornellBox(scene, scales[s]);
            runOk({"scene", scene, "--grid", "2,2,2", "--face-size", "8", "--bounces", "1", "--backend",
                   backend, "-q", "-o", volume});
            volumes.push_back(readProbeVolume(volume));
        }
        const ProbeVolume& unit = volumes[1];
        for (size_t s : {size_t(0), size_t(2)}) {
            SCOPED_TRACE(std::string(backend) + " at scale " + std::to_string(scales[s]));
            const ProbeVolume& scaled = volumes[s];
            for (int a = 0; a < 3; ++a) {
                EXPECT_NEAR(scaled.grid.boundsMin[a] / scales[s], unit.grid.boundsMin[a], 1e-6);
                EXPECT_NEAR(scaled.grid.boundsMax[a] / scales[s], unit.grid.boundsMax[a], 1e-6);
            }
            EXPECT_EQ(scaled.valid, unit.valid);
            const double difference = largestDifference(unit, scaled);
            std::printf("%s, scale %g: largest coefficient difference %.3g of the largest L00\n", backend,
                        double(scales[s]), difference);
            EXPECT_LT(difference, std::string(backend) == "cpu" ? 1e-4 : 0.02);
        }
    }
}

// Where float cannot hold the scene, both backends refuse it in one line naming the scale: smaller
// than 1e-10 across, coordinates past 1e10, or a room 3.46 across a million units from the origin,
// where rays would leave a surface 30 units off it.
// A sky's small bright patch counts by its area on both backends: a probe in the open (a 1 m
// quad 100 m below, so that the scene has a size) under a black 256 x 128 sky holding a 2 x 2
// pixel patch of radiance 2e4 (0.6 of the sky's light) gets the sky's own projection, computed here
// from the cube map the bake loads. The patch covers 6e-4 sr; a probe texel of faces 16^2 covers
// 8e-3 sr, so texel rays that meet the patch or miss it by chance (the sky read at its own 64^2)
// put L00 off by up to +-100%. Averaged to the rays' footprints (48^2 for the default 3 x 3 rays a
// texel, 16^2 for one through each centre, each texel the solid-angle mean of those it covers) the
// sky keeps every texel's share of the integral: centre rays are then exact to float rounding (they
// read the averaged texels), jittered rays equal to 5 digits (4e-4 off at 2 x 2: they weigh a
// texel's averaged sky texels by where they fall, not by their solid angles), and the quad hides
// 1e-4 sr of black sky: bound 0.25% of L00, on both backends.
TEST_F(SceneCommand, SmallBrightPatchesOfTheSkyCountByTheirArea) {
    Image sky = makeImage(256, 128);
    for (int y = 50; y < 52; ++y)
        for (int x = 100; x < 102; ++x)
            sky.at(x, y) = glm::vec4(2e4f, 2e4f, 2e4f, 1.0f);
    writeImage(file("patch.exr"), sky);
    testing::FixtureScene scene;
    testing::FixtureMesh quad;
    testing::addQuad(quad, {0.0f, -100.0f, 0.0f}, {0.5f, 0.0f, 0.0f}, {0.0f, 0.0f, -0.5f});
    scene.meshes.push_back(quad);
    scene.nodes.push_back({.mesh = 0});
    scene.roots = {0};
    testing::writeGltf(file("open.glb"), scene, testing::GltfContainer::Glb);
    const glm::dvec3 exact = projectCubemap(loadEnvironment(file("patch.exr"), {}).cubemap, 3).rgb[0];
    struct Case {
        const char* backend;
        const char* raysPerTexel;
        const char* averaged;
    };
    for (const Case c :
         {Case{"cpu", "0", "averaged to 48^2 faces"}, Case{"gpu", "0", "averaged to 48^2 faces"},
          Case{"gpu", "1", "averaged to 16^2 faces"}}) {
        const std::string name = std::string(c.backend) + "_" + c.raysPerTexel;
        const RunResult bake =
            run({"scene", file("open.glb"), "--sky", file("patch.exr"), "--grid", "1,1,1", "--bounds",
                 "-1,-1,-1,1,1,1", "--face-size", "16", "--bounces", "0", "--rays-per-texel", c.raysPerTexel,
                 "--backend", c.backend, "-o", file(name + ".shpv")});
        ASSERT_EQ(bake.exitCode, 0) << describe(bake);
        EXPECT_CONTAINS(bake.out, c.averaged);
        const glm::vec3 l00 = readProbeVolume(file(name + ".shpv")).radiance[0];
        std::printf("%s: L00 %.5g against the sky's %.5g\n", name.c_str(), l00.r, exact.r);
        EXPECT_NEAR(l00.r, exact.r, 0.0025 * exact.r) << name;
    }
}

TEST_F(SceneCommand, ScalesFloatCannotHoldAreRefused) {
    writeScaledCornellBox(file("tiny.glb"), 1e-12f);
    writeScaledCornellBox(file("huge.glb"), 1e11f);
    writeScaledCornellBox(file("far.glb"), 1.0f, glm::vec3(1e6f, 0.0f, 0.0f));
    testing::FixtureScene point =
        testing::boxScene(); // without a sun, which a scale of 0 leaves no direction
    point.nodes.push_back({.scale = glm::vec3(0.0f), .children = point.roots});
    point.roots = {int(point.nodes.size() - 1)};
    testing::writeGltf(file("point.glb"), point, testing::GltfContainer::Glb);
    point.nodes.back().scale = glm::vec3(1.0f, 0.0f, 0.0f); // every corner on the x axis
    testing::writeGltf(file("line.glb"), point, testing::GltfContainer::Glb);
    // 0.1 across at 1e7, where float's spacing is 1: flat along x by rounding alone, which --bounds
    // would not mend.
    writeScaledCornellBox(file("farther.glb"), 0.1f, glm::vec3(1e7f, 0.0f, 0.0f));
    for (const char* backend : {"cpu", "gpu"}) {
        auto refused = [&](const std::string& scene, std::vector<std::string> mentions) {
            expectFailure(
                {{"scene", scene, "--grid", "2,2,2", "--face-size", "8", "--backend", backend, "-o", "OUT"},
                 2,
                 mentions,
                 "out.shpv"});
        };
        refused(file("tiny.glb"),
                {file("tiny.glb") + " (", "3.46e-12 across", "1e-10", "scale the scene up"});
        refused(file("huge.glb"), {file("huge.glb") + " (", "reach 2e+11", "1e+10", "scale the scene down"});
        refused(file("far.glb"), {file("far.glb") + " (", "reach 1e+06", "3.46 across", "nearer the origin"});
        refused(file("point.glb"), {file("point.glb") + " (", "all its vertices lie at one point"});
        // Flat along two axes, it needs --bounds for its grid: then no ray would meet it.
        expectFailure({{"scene", file("line.glb"), "--grid", "2,2,2", "--bounds", "-1,-1,-1,1,1,1",
                        "--face-size", "8", "--backend", backend, "-o", "OUT"},
                       2,
                       {file("line.glb") + " (", "no triangle has any area"},
                       "out.shpv"});
        refused(file("farther.glb"), {file("farther.glb") + " (", "reach 1e+07", "nearer the origin"});
    }
}

// A volume knows its scene by the hash of its files (the glTF, its buffer and its texture), not by
// the path typed: baked in the scene's folder as "BoxTextured.gltf", it is rendered with
// "./BoxTextured.gltf" and with the absolute path, a gpu bounce continues it (--previous) under
// another path, and bricks baked from a copy of the folder elsewhere merge to the whole bake byte for
// byte. A changed scene (a material colour) is refused by render, --previous and merge.
TEST_F(SceneCommand, VolumesKnowTheirSceneByContent) {
    const fs::path models = SHPROBE_GLTF_MODELS_DIR "/BoxTextured-glTF";
    const fs::path here = folder() / "here", there = folder() / "there";
    fs::copy(models, here);
    fs::copy(models, there);
    const std::string name = "BoxTextured.gltf";
    const std::string absolute = (here / name).string(), copy = (there / name).string();
    auto bake = [&](const std::string& scene, std::vector<std::string> extra) {
        std::vector<std::string> args{
            "scene",       scene, "--grid",    "2,2,2", "--bounds", "-2,-2,-2,2,2,2",
            "--face-size", "8",   "--backend", "cpu",   "-q"};
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    auto inHere = [&](const std::vector<std::string>& args) {
        const RunResult result = run(args, {.workingFolder = here.string()});
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_EQ(result.err, "") << describe(result);
    };
    inHere(bake(name, {"-o", "v.shpv"}));
    const std::string volume = (here / "v.shpv").string();
    EXPECT_CONTAINS(readProbeVolume(volume).sourceHash, "fnv1a64:");
    inHere({"render", "--scene", "./" + name, "--volume", "v.shpv", "--size", "32x24", "-o", "dot.png"});
    runOk({"render", "--scene", absolute, "--volume", volume, "--size", "32x24", "-o", file("absolute.png")});

    inHere(bake(name, {"--brick", "0/2", "-o", "b0.shpv"}));
    runOk(bake(copy, {"--brick", "1/2", "-o", file("b1.shpv")}));
    runOk({"merge", file("b1.shpv"), (here / "b0.shpv").string(), "-o", file("merged.shpv")});
    EXPECT_EQ(bytesOf(file("merged.shpv")), bytesOf(volume));

    const std::vector<std::string> gpu{"--face-size",    "8",         "--grid", "2,2,2", "--bounds",
                                       "-2,-2,-2,2,2,2", "--backend", "gpu",    "-q"};
    std::vector<std::string> bounce0{"scene", name, "-o", "g0.shpv"},
        bounce1{"scene", copy, "--previous", (here / "g0.shpv").string()};
    bounce0.insert(bounce0.end(), gpu.begin(), gpu.end());
    bounce1.insert(bounce1.end(), gpu.begin(), gpu.end());
    inHere(bounce0);
    std::vector<std::string> next = bounce1;
    next.insert(next.end(), {"-o", file("g1.shpv")});
    runOk(next);
    // Continuing with other settings or another grid names what differs and both values.
    const std::string previous = (here / "g0.shpv").string();
    expectFailure({{"scene", copy, "--previous", previous, "--face-size", "4", "--grid", "2,2,2", "--bounds",
                    "-2,-2,-2,2,2,2", "--backend", "gpu", "-o", "OUT"},
                   2,
                   {previous + ": setting \"face_size\" is 8 in the volume, 4 in this bake"},
                   "out.shpv"});
    expectFailure({{"scene", copy, "--previous", previous, "--face-size", "8", "--grid", "2,2,2", "--bounds",
                    "-1,-2,-2,2,2,2", "--backend", "gpu", "-o", "OUT"},
                   2,
                   {previous + ": bounds [-2.0,-2.0,-2.0]..[2.0,2.0,2.0] in the volume, "
                               "[-1.0,-2.0,-2.0]..[2.0,2.0,2.0] in this bake"},
                   "out.shpv"});

    // The copy's material turns pink: its hash changes, and the volumes baked before are refused.
    std::string text = readText(copy);
    const size_t at = text.find("\"metallicFactor\"");
    ASSERT_NE(at, std::string::npos);
    text.insert(at, "\"baseColorFactor\": [1.0, 0.5, 0.5, 1.0], ");
    writeText(copy, text);
    expectFailure({{"render", "--scene", copy, "--volume", volume, "-o", "OUT"},
                   2,
                   {volume + ": baked in BoxTextured.gltf", "fnv1a64:", "bake it again"},
                   "out.png"});
    bounce1.insert(bounce1.end(), {"-o", "OUT"});
    expectFailure({bounce1, 2, {"g0.shpv: baked in BoxTextured.gltf", "bake it again"}, "out.shpv"});
    runOk(bake(copy, {"--brick", "1/2", "-o", file("pink1.shpv")}));
    expectFailure({{"merge", (here / "b0.shpv").string(), file("pink1.shpv"), "-o", "OUT"},
                   2,
                   {"not bricks of one bake: source", "fnv1a64:"},
                   "out.shpv"});
}

// A volume knows its sky by content too (settings "sky", the cube map's hash; "sky_source" the path
// as typed): bricks lit by one sky under two paths merge to the whole bake byte for byte, and a gpu
// bounce continues a volume lit by it under another path. Once the sky's file changes, bricks lit
// by it under its one name are refused by merge, whether baked or relit, and so is a --previous
// bounce, each naming the skies.
TEST_F(SceneCommand, VolumesKnowTheirSkyByContent) {
    const fs::path here = folder() / "here", there = folder() / "there";
    fs::create_directories(here);
    fs::create_directories(there);
    auto writeSky = [](const fs::path& path, float radiance) {
        Image sky = makeImage(32, 16);
        for (int y = 0; y < 8; ++y) // light from above only, so that its strength is not uniform
            for (int x = 0; x < 32; ++x)
                sky.at(x, y) = glm::vec4(radiance, radiance, radiance, 1.0f);
        writeImage(path.string(), sky);
    };
    const std::string sky = (here / "sky.exr").string(), copy = (there / "sky.exr").string();
    writeSky(sky, 1.0f);
    writeSky(copy, 1.0f);
    const std::string scene = file("open.glb");
    testing::writeCornellBoxGltf(scene, {.innerBoxes = true});
    auto bake = [&](const std::string& lit, const std::vector<std::string>& extra,
                    const std::string& output) {
        runWithOutput({"scene", scene, "--sky", lit, "--grid", "2,2,2", "--face-size", "8", "--bounces", "0",
                       "--transfer", "-q"},
                      extra, output);
    };
    bake(sky, {}, file("whole.shpv"));
    const ProbeVolume whole = readProbeVolume(file("whole.shpv"));
    EXPECT_CONTAINS(whole.skySource, sky);
    EXPECT_CONTAINS(whole.settings, "\"sky\":\"fnv1a64:");
    bake(sky, {"--sky-face-size", "4"}, file("coarse.shpv")); // another light of one file
    const ProbeVolume coarse = readProbeVolume(file("coarse.shpv"));
    EXPECT_EQ(coarse.skySource, whole.skySource + " resampled to 4^2 faces");
    EXPECT_NE(coarse.settings, whole.settings);
    bake(sky, {"--brick", "0/2"}, file("b0.shpv"));
    bake(copy, {"--brick", "1/2"}, file("b1.shpv"));
    runOk({"merge", file("b1.shpv"), file("b0.shpv"), "-o", file("merged.shpv")});
    EXPECT_EQ(bytesOf(file("merged.shpv")), bytesOf(file("whole.shpv")));
    runOk({"relight", file("b0.shpv"), "--sky", sky, "-q", "-o", file("r0.shpv")});
    const std::vector<std::string> gpu{"scene",       scene, "--grid",    "2,2,2",
                                       "--face-size", "8",   "--backend", "gpu"};
    auto onGpu = [&](const std::vector<std::string>& extra) {
        std::vector<std::string> args = gpu;
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    runOk(onGpu({"--sky", sky, "-q", "-o", file("g0.shpv")}));
    runOk(onGpu({"--sky", copy, "--previous", file("g0.shpv"), "-q", "-o", file("g1.shpv")}));
    // A volume written before volumes held sky_source names its sky by description, and is continued
    // by it.
    ProbeVolume old = readProbeVolume(file("g0.shpv"));
    nlohmann::json oldSettings = nlohmann::json::parse(old.settings);
    oldSettings["sky"] = old.skySource;
    old.settings = oldSettings.dump();
    old.skySource.clear();
    writeProbeVolume(file("g0_old.shpv"), old);
    runOk(onGpu({"--sky", sky, "--previous", file("g0_old.shpv"), "-q", "-o", file("g1_old.shpv")}));
    EXPECT_EQ(readProbeVolume(file("g1_old.shpv")).radiance, readProbeVolume(file("g1.shpv")).radiance);

    writeSky(sky, 2.0f); // the same name, another sky
    const std::string described = "\"" + sky + " (equirect 32x16)\" (fnv1a64:";
    bake(sky, {"--brick", "1/2"}, file("b1_brighter.shpv"));
    expectFailure({{"merge", file("b0.shpv"), file("b1_brighter.shpv"), "-o", "OUT"},
                   2,
                   {"not bricks of one bake: sky " + described, "in " + file("b0.shpv") + ", " + described},
                   "out.shpv"});
    runOk({"relight", file("b1.shpv"), "--sky", sky, "-q", "-o", file("r1.shpv")});
    expectFailure({{"merge", file("r0.shpv"), file("r1.shpv"), "-o", "OUT"},
                   2,
                   {"not bricks of one bake: sky " + described},
                   "out.shpv"});
    expectFailure({onGpu({"--sky", sky, "--previous", file("g0.shpv"), "-o", "OUT"}),
                   2,
                   {file("g0.shpv") + ": sky " + described, "in the volume, " + described, "in this bake"},
                   "out.shpv"});
}

// The real engine model bakes with the defaults but a small grid; some probes lie inside its parts
// and are reported invalid, others not.
TEST_F(SceneCommand, RealSceneBakes) {
    const std::string engine = SHPROBE_GLTF_MODELS_DIR "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
    const RunResult result = runOk({"scene", engine, "--grid", "2,2,2", "--face-size", "8", "--bounces", "0",
                                    "-o", file("engine.shpv")});
    EXPECT_CONTAINS(result.out, "121496 triangles");
    const ProbeVolume volume = readProbeVolume(file("engine.shpv"));
    EXPECT_EQ(volume.probeCount(), 8u);
}

// --invalid-back-faces sets the share of back faces in a probe's view above which the probe is
// invalid. Of the closed Cornell box's 27 probes, those in the room see no back face, and one lies
// inside a block, whose open bottom shows it the floor's front: most of its view, not all, is back
// faces. So it is invalid by default (0.5) and with 0 (any back face), valid with 0.99 (none moved
// out or filled from its neighbours: --relocation-limit 0, --no-dilation); a share outside 0..1 is
// refused.
TEST_F(SceneCommand, TheBackFaceShareForValidityIsAnOption) {
    const std::string scene = cornellBox();
    auto invalidAt = [&](const std::string& share) {
        runOk({"scene", scene, "--grid", "3,3,3", "--face-size", "8", "--bounces", "0",
               "--invalid-back-faces", share, "--relocation-limit", "0", "--no-dilation", "-q", "-o",
               file("v.shpv")});
        const ProbeVolume volume = readProbeVolume(file("v.shpv"));
        return std::count(volume.valid.begin(), volume.valid.end(), uint8_t(0));
    };
    EXPECT_EQ(invalidAt("0.5"), 1);
    EXPECT_EQ(invalidAt("0"), 1);
    EXPECT_EQ(invalidAt("0.99"), 0);
    expectFailure({{"scene", scene, "--grid", "2,2,2", "--invalid-back-faces", "1.5", "-o", "OUT"},
                   2,
                   {"--invalid-back-faces"},
                   "out.shpv"});
}

// On the cpu backend an invalid probe is filled from its valid neighbours: 2CylinderEngine at 4^3
// probes has 15 inside its parts (none moved out: --relocation-limit 0). Filled, each holds the mean of the
// valid probes of its 3x3x3 block weighed by 1 / distance in cells (checked against the unfilled volume, to
// float rounding of the sums: 1e-5 of the largest coefficient), and is valid; --no-dilation leaves them
// invalid; bricks fill their probes exactly as the whole bake does.
TEST_F(SceneCommand, InvalidProbesAreFilledFromTheirNeighbours) {
    const std::string engine = SHPROBE_GLTF_MODELS_DIR "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
    const std::vector<std::string> common{
        "scene",     engine, "--grid",    "4,4,4", "--face-size",        "8",
        "--bounces", "0",    "--backend", "cpu",   "--relocation-limit", "0"};
    auto bake = [&](std::vector<std::string> extra, const std::string& output) {
        std::vector<std::string> args = common;
        args.insert(args.end(), extra.begin(), extra.end());
        args.insert(args.end(), {"-o", output});
        return runOk(args);
    };
    EXPECT_CONTAINS(bake({}, file("filled.shpv")).out, "filled   15 invalid probes");
    bake({"--no-dilation", "-q"}, file("empty.shpv"));
    const ProbeVolume filled = readProbeVolume(file("filled.shpv"));
    const ProbeVolume empty = readProbeVolume(file("empty.shpv"));
    EXPECT_EQ(std::count(empty.valid.begin(), empty.valid.end(), uint8_t(0)), 15);
    EXPECT_EQ(std::count(filled.valid.begin(), filled.valid.end(), uint8_t(0)), 0);
    float largest = 0.0f, worst = 0.0f;
    for (uint32_t p = 0; p < empty.probeCount(); ++p) {
        if (empty.valid[p]) continue;
        const glm::ivec3 cell = probeCell(empty.grid, p);
        glm::dvec3 sum(0.0);
        double weights = 0.0;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const glm::ivec3 next = cell + glm::ivec3(dx, dy, dz);
                    if ((dx | dy | dz) == 0 || glm::any(glm::lessThan(next, glm::ivec3(0))) ||
                        glm::any(glm::greaterThanEqual(next, empty.grid.counts)))
                        continue;
                    const uint32_t q = probeIndex(empty.grid, next);
                    if (!empty.valid[q]) continue;
                    const double distance = std::sqrt(double(dx * dx + dy * dy + dz * dz));
                    sum += glm::dvec3(empty.radiance[q * 9]) / distance;
                    weights += 1.0 / distance;
                }
        ASSERT_GT(weights, 0.0) << "probe " << p;
        worst = std::max(worst, glm::length(filled.radiance[p * 9] - glm::vec3(sum / weights)));
        largest = std::max(largest, glm::length(filled.radiance[p * 9]));
    }
    EXPECT_LT(worst, 1e-5f * largest);
    std::vector<std::string> merge{"merge"};
    for (const char* brick : {"0/3", "1/3", "2/3"}) {
        const std::string name = file(std::string("filled_") + brick[0] + ".shpv");
        bake({"--brick", brick, "-q"}, name);
        merge.push_back(name);
    }
    merge.insert(merge.end(), {"-o", file("merged.shpv")});
    runOk(merge);
    EXPECT_EQ(bytesOf(file("merged.shpv")), bytesOf(file("filled.shpv")));
}

// `shprobe render --scene` draws the scene lit by its volume: the surfaces reflect the volume's
// irradiance (the Cornell box's walls are lit, so the picture is not black), and --show-probes adds
// the probes' spheres (the picture changes). A brick is refused, and so are --scene without
// --volume, the sphere's options (--order, --grid, --face-size) with it, and the scene's options
// (--volume, --sky, --show-probes) without it.
TEST_F(SceneCommand, RenderDrawsTheSceneLitByItsVolume) {
    const std::string scene = file("open.glb");
    testing::writeCornellBoxGltf(scene, {.innerBoxes = true});
    runOk({"scene", scene, "--grid", "3,3,3", "--face-size", "16", "--bounces", "1", "-q", "-o",
           file("v.shpv")});
    runOk({"scene", scene, "--grid", "3,3,3", "--face-size", "16", "--brick", "0/2", "-q", "-o",
           file("brick.shpv")});
    runOk(
        {"render", "--scene", scene, "--volume", file("v.shpv"), "--size", "64x48", "-o", file("plain.exr")});
    runOk({"render", "--scene", scene, "--volume", file("v.shpv"), "--size", "64x48", "--show-probes", "-o",
           file("probes.exr")});
    const Image plain = readImage(file("plain.exr")), probes = readImage(file("probes.exr"));
    ASSERT_EQ(plain.width, 64);
    size_t lit = 0, changed = 0;
    for (size_t t = 0; t < plain.texels.size(); ++t) {
        lit += glm::length(glm::vec3(plain.texels[t])) > 0.0f;
        changed += glm::vec3(plain.texels[t]) != glm::vec3(probes.texels[t]);
    }
    EXPECT_GT(lit, plain.texels.size() / 2);
    EXPECT_GT(changed, 0u);
    expectFailure({{"render", "--scene", scene, "-o", "OUT"}, 2, {"--volume"}, "out.png"});
    for (const std::vector<std::string>& sphereOnly :
         std::vector<std::vector<std::string>>{{"--order", "5"}, {"--grid"}, {"--face-size", "16"}}) {
        std::vector<std::string> args{"render", "--scene", scene, "--volume", file("v.shpv"), "-o", "OUT"};
        args.insert(args.end(), sphereOnly.begin(), sphereOnly.end());
        expectFailure({args, 2, {sphereOnly[0]}, "out.png"});
    }
    // The scene's options without a scene would be ignored: they are refused.
    for (const std::vector<std::string>& sceneOnly : std::vector<std::vector<std::string>>{
             {"--sky", scene}, {"--show-probes"}, {"--volume", file("v.shpv")}}) {
        std::vector<std::string> args{"render", "-o", "OUT"};
        args.insert(args.end(), sceneOnly.begin(), sceneOnly.end());
        expectFailure({args, 2, {sceneOnly[0], "--scene"}, "out.png"});
    }
    expectFailure(
        {{"render", "--scene", scene, "--volume", file("brick.shpv"), "-o", "OUT"}, 2, {"brick"}, "out.png"});
}

// A light that float cannot hold in the probes' sums is the input's fault: one line saying so, exit
// 2, no file; not the failed write the volume writer's own check would report. Inside a closed box
// glowing 3e38 (glTF's factor 1 times KHR_materials_emissive_strength, each texel finite), L00 is
// 3e38 sqrt(4 pi) = 1.1e39, past float's 3.4e38.
TEST_F(SceneCommand, LightThatOverflowsFloatIsRefused) {
    const std::string scene = file("blinding.glb");
    testing::writeBoxGltf(scene, {.emission = glm::vec3(3e38f)});
    for (const char* backend : {"cpu", "gpu"})
        expectFailure({{"scene", scene, "--grid", "1,1,1", "--face-size", "8", "--bounces", "0", "--backend",
                        backend, "-o", "OUT"},
                       2,
                       {"overflows float: the light of " + scene, "is far too strong"},
                       "out.shpv"});
}

// A sky image is read as bake reads its inputs, with bake's --sanitize and --max-pixels, which the
// refusals name: a sky with a NaN texel is refused by scene, relight and render --scene, and taken
// as 0 with --sanitize (said in the volume's sky_source); a sky past --max-pixels is refused from
// its header.
TEST_F(SceneCommand, SkyImagesTakeSanitizeAndMaxPixels) {
    const std::string scene = file("open.glb");
    testing::writeCornellBoxGltf(scene, {});
    Image sky = makeImage(32, 16, glm::vec4(1.0f));
    sky.texels[40].g = std::numeric_limits<float>::quiet_NaN();
    writeImage(file("nan.exr"), sky);
    const std::vector<std::string> bake{"scene",       scene, "--grid",     "1,1,1",
                                        "--face-size", "4",   "--transfer", "-q"};
    auto with = [&](std::vector<std::string> args, const std::vector<std::string>& extra) {
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    expectFailure({with(bake, {"--sky", file("nan.exr"), "-o", "OUT"}), 2, {"use --sanitize"}, "out.shpv"});
    runWithOutput(bake, {"--sky", file("nan.exr"), "--sanitize"}, file("sane.shpv"));
    EXPECT_CONTAINS(readProbeVolume(file("sane.shpv")).skySource, "1 NaN/Inf texel replaced with 0");
    expectFailure({with(bake, {"--sky", file("nan.exr"), "--max-pixels", "511", "-o", "OUT"}),
                   2,
                   {"raise it with --max-pixels"},
                   "out.shpv"});
    const std::vector<std::string> relight{"relight", file("sane.shpv"), "--sky", file("nan.exr"), "-q"};
    expectFailure({with(relight, {"-o", "OUT"}), 2, {"use --sanitize"}, "out.shpv"});
    runOk(with(relight, {"--sanitize", "-o", file("relit.shpv")}));
    EXPECT_EQ(readProbeVolume(file("relit.shpv")).radiance, readProbeVolume(file("sane.shpv")).radiance);
    const std::vector<std::string> render{"render", "--scene",       scene,    "--volume", file("sane.shpv"),
                                          "--sky",  file("nan.exr"), "--size", "8"};
    expectFailure({with(render, {"-o", "OUT"}), 2, {"use --sanitize"}, "out.png"});
    runOk(with(render, {"--sanitize", "-o", file("render.png")}));
}

// A glTF sun whose colour times intensity float cannot hold is refused by the reader, naming the
// file and the light (it was "scene: sun 0 has no direction or a non-finite irradiance").
TEST_F(SceneCommand, SunPastFloatIsRefusedNamingTheFile) {
    const std::string scene = file("sunny.glb");
    testing::writeCornellBoxGltf(scene,
                                 {.sun = testing::FixtureSun{.colour = glm::vec3(3e38f), .intensity = 2.0f}});
    expectFailure({{"scene", scene, "--grid", "1,1,1", "-o", "OUT"},
                   2,
                   {scene + ": lights[0]: its colour times its intensity is past what float holds"},
                   "out.shpv"});
}

// Each broken glTF of assimp-testmodels: one line naming the file, exit 2, nothing written.
TEST_F(SceneCommand, BrokenScenesAreRefused) {
    const std::string models = SHPROBE_GLTF_MODELS_DIR;
    for (const char* broken :
         {"/IndexOutOfRange/IndexOutOfRange.gltf", "/IndexOutOfRange/AllIndicesOutOfRange.gltf",
          "/MissingBin/BoxTextured.gltf", "/RecursiveNodes/RecursiveNodes.gltf",
          "/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "/IncorrectVertexArrays/Box.gltf",
          "/wrongTypes/badArray.gltf"})
        expectFailure(
            {{"scene", models + broken, "--grid", "2,2,2", "-o", "OUT"}, 2, {models + broken}, "out.shpv"});
}

// The cpu backends cast their rays through Embree, a plugin loaded on first use
// (scene/ray_caster.h): where it cannot be loaded, `scene` and `transfer` stop with one line naming
// it and why (exit 4, as for a missing device) and write nothing; the gpu backend never loads it.
TEST_F(SceneCommand, AnEmbreePluginThatCannotBeLoadedIsNamed) {
    const std::string scene = cornellBox();
    const std::string missing = file("no-such-plugin.so");
    const testing::EnvironmentChanges noEmbree{{"SHPROBE_EMBREE_PLUGIN", missing}};
    const std::vector<std::string> says{
        "casting rays on the CPU needs Embree, and its plugin libshprobe_embree.so",
        "(SHPROBE_EMBREE_PLUGIN: loading " + missing + " failed"};
    expectFailure({{"scene", scene, "--grid", "2,2,2", "--backend", "cpu", "-o", "OUT"},
                   4,
                   says,
                   "out.shpv",
                   noEmbree});
    expectFailure({{"transfer", scene, "--backend", "cpu", "-o", "OUT"}, 4, says, "out.glb", noEmbree});
    const RunResult gpu = run({"scene", scene, "--grid", "2,2,2", "--face-size", "4", "--backend", "gpu",
                               "-q", "-o", file("gpu.shpv")},
                              {.environment = noEmbree});
    EXPECT_EQ(gpu.exitCode, 0) << gpu.err;
}

// Bad options get one line each before any work: a grid that is not three counts, bricks without a
// whole previous bounce's volume, the cpu's cache refinement for the gpu, a probe's view of more rays
// than its paths can number (6 x 4096^2 x 64 = 6.4e9 on either backend), a scene on standard input
// (its buffers lie beside its file, and it is read more than once: it was taken for empty).
TEST_F(SceneCommand, BadOptionsAreRefused) {
    const std::string scene = cornellBox();
    expectFailure({{"scene", "-", "--grid", "1,1,1", "-o", "OUT"},
                   2,
                   {"-: a scene is read from its file, not standard input"},
                   "out.shpv"});
    expectFailure({{"transfer", "-", "-o", "OUT"},
                   2,
                   {"-: a scene is read from its file, not standard input"},
                   "out.glb"});
    expectFailure({{"scene", scene, "--grid", "2,2,2", "--transfer", "--device", "0", "-o", "OUT"},
                   2,
                   {"--device is for a Vulkan device, and --transfer bakes on the cpu"},
                   "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "3,3", "-o", "OUT"}, 2, {"--grid"}, "out.shpv"});
    expectFailure(
        {{"scene", scene, "--grid", "2,2,2", "--brick", "2/2", "-o", "OUT"}, 2, {"--brick"}, "out.shpv"});
    expectFailure(
        {{"scene", scene, "--grid", "2,2,2", "--cache-refinement", "2", "--backend", "gpu", "-o", "OUT"},
         2,
         {"--cache-refinement"},
         "out.shpv"});
    expectFailure(
        {{"scene", scene, "--grid", "2,2,2", "--previous", scene, "-o", "OUT"}, 2, {scene}, "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "2,2,2", "--previous", scene, "--backend", "cpu", "-o", "OUT"},
                   2,
                   {"--previous", "cpu"},
                   "out.shpv"});
    // Rays from a probe that far would be past what the ray tests hold (Embree asserts on them).
    for (const char* backend : {"cpu", "gpu"})
        expectFailure({{"scene", scene, "--grid", "2,2,2", "--bounds", "0,0,0,1e19,1,1", "--backend", backend,
                        "-o", "OUT"},
                       2,
                       {"--bounds", "reaches 1e19, beyond the 1e+10"},
                       "out.shpv"});
    expectFailure({{"scene", scene, "--grid", "2,2,2", "--backend", "rays", "-o", "OUT"},
                   2,
                   {"--backend"},
                   "out.shpv"});
    expectFailure(
        {{"scene", scene, "--grid", "2,2,2", "--probe-directions", "sphere", "--backend", "gpu", "-o", "OUT"},
         2,
         {"--probe-directions sphere is for the cpu backend"},
         "out.shpv"});
    for (const char* backend : {"cpu", "gpu"})
        expectFailure({{"scene", scene, "--grid", "2,2,2", "--face-size", "4096", "--rays-per-texel", "64",
                        "--backend", backend, "-o", "OUT"},
                       2,
                       {"faces 4096 and 64 rays a texel", "more than 2^28 rays"},
                       "out.shpv"});
    // Within 2^28 rays but past the 128 MiB lavapipe binds as one storage buffer (its hit distances,
    // 4 bytes a ray): the gpu names the device's limit and the options that size it.
    expectFailure({{"scene", scene, "--grid", "2,2,2", "--face-size", "128", "--rays-per-texel", "1024",
                    "--backend", "gpu", "-o", "OUT"},
                   2,
                   {"faces 128 and 1024 rays a texel", "384 MiB", "llvmpipe", "128 MiB", "--rays-per-texel",
                    "--backend cpu"},
                   "out.shpv"});
}

// The regular files under `folder` and their bytes, to tell that a refused run changed none.
std::map<std::string, std::string> filesUnder(const fs::path& folder) {
    std::map<std::string, std::string> files;
    for (const fs::directory_entry& entry : fs::recursive_directory_iterator(folder))
        if (entry.is_regular_file() && !entry.is_symlink())
            files[entry.path().string()] = readText(entry.path());
    return files;
}

// Every file a scene job reads is one of its inputs: an output onto the scene's buffer or texture
// (by its name or through a link) is refused before any work, the files left as they were.
TEST_F(SceneCommand, OutputOntoAFileTheSceneReadsIsRefused) {
    fs::copy(SHPROBE_GLTF_MODELS_DIR "/BoxTextured-glTF", folder() / "box", fs::copy_options::recursive);
    const std::string scene = file("box/BoxTextured.gltf"), buffer = file("box/BoxTextured0.bin"),
                      texture = file("box/CesiumLogoFlat.png"), volume = file("v.shpv");
    runOk({"scene", scene, "--grid", "2,2,2", "--face-size", "8", "--bounces", "0", "-q", "-o", volume});
    fs::create_symlink(buffer, folder() / "alias.bin");
    const std::map<std::string, std::string> before = filesUnder(folder() / "box");
    const std::string volumeBytes = bytesOf(volume);
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"scene", scene, "--grid", "2,2,2", "-o", buffer}, buffer},
        {{"scene", scene, "--grid", "2,2,2", "-o", texture}, texture},
        {{"scene", scene, "--grid", "2,2,2", "-o", file("alias.bin")}, file("alias.bin")},
        {{"render", "--scene", scene, "--volume", volume, "-o", texture}, texture},
    };
    for (const auto& [args, output] : cases) {
        const RunResult result = run(args);
        expectMessage({{}, 3, {"cannot write " + output, "it is the input"}}, result);
        EXPECT_LT(result.seconds, 5.0) << "refused before any work";
    }
    EXPECT_EQ(filesUnder(folder() / "box"), before);
    EXPECT_EQ(bytesOf(volume), volumeBytes);
}

// A buffer or image URI that leads out of the scene's folder (by "..", an absolute path, an escape,
// a link to a file or a folder outside) is refused in one line naming it, before the file is
// opened: FIFOs outside would otherwise be said to be no regular file. Files in subfolders, and
// links that stay inside, are read as before.
TEST_F(SceneCommand, UrisOutsideTheSceneFolderAreRefused) {
    const fs::path models = SHPROBE_GLTF_MODELS_DIR "/BoxTextured-glTF";
    const std::string gltf = readText(models / "BoxTextured.gltf");
    for (const char* place : {"box/sub", "elsewhere"}) {
        fs::create_directories(folder() / place);
        for (const char* name : {"BoxTextured0.bin", "CesiumLogoFlat.png"})
            fs::copy_file(models / name, folder() / place / name);
    }
    ASSERT_EQ(mkfifo(file("fifo.bin").c_str(), 0644), 0);
    ASSERT_EQ(mkfifo(file("fifo.png").c_str(), 0644), 0);
    fs::create_symlink(folder() / "elsewhere/BoxTextured0.bin", folder() / "box/out.bin");
    fs::create_directory_symlink(folder() / "elsewhere", folder() / "box/linked");
    fs::create_symlink("sub/BoxTextured0.bin", folder() / "box/in.bin");
    auto sceneWith = [&](const std::string& name, const std::string& bufferUri, const std::string& imageUri) {
        std::string text = gltf;
        const std::pair<std::string, std::string> uris[] = {{"\"BoxTextured0.bin\"", bufferUri},
                                                            {"\"CesiumLogoFlat.png\"", imageUri}};
        for (const auto& [from, to] : uris)
            text.replace(text.find(from), from.size(), "\"" + to + "\"");
        writeText(folder() / "box" / name, text);
        return file("box/" + name);
    };
    runOk({"scene", sceneWith("inside.gltf", "in.bin", "sub/CesiumLogoFlat.png"), "--grid", "2,2,2",
           "--face-size", "8", "--bounces", "0", "-q", "-o", file("inside.shpv")});
    const std::string longUri = [] {
        std::string uri;
        for (int i = 0; i < 300; ++i)
            uri += "../";
        return uri + "etc/passwd";
    }();
    const std::vector<std::pair<std::string, std::string>> buffers = {
        {"../../../../../../../../etc/passwd", "\"../../../../../../../../etc/passwd\""},
        {"/etc/passwd", "\"/etc/passwd\""},
        {"%2E%2E/elsewhere/BoxTextured0.bin", "\"%2E%2E/elsewhere/BoxTextured0.bin\""},
        {"sub/../../elsewhere/BoxTextured0.bin", "\"sub/../../elsewhere/BoxTextured0.bin\""},
        {"out.bin", "\"out.bin\""},
        {"../fifo.bin", "\"../fifo.bin\""},
        {longUri, "\"" + longUri.substr(0, 200) + "...\" (" + std::to_string(longUri.size()) + " bytes)"},
    };
    std::vector<std::pair<std::string, std::string>> scenes; // the scene, what its line quotes
    for (size_t i = 0; i < buffers.size(); ++i)
        scenes.push_back(
            {sceneWith("b" + std::to_string(i) + ".gltf", buffers[i].first, "sub/CesiumLogoFlat.png"),
             "buffers[0].uri " + buffers[i].second});
    const std::string images[] = {"../elsewhere/CesiumLogoFlat.png", "linked/CesiumLogoFlat.png",
                                  "../fifo.png"};
    for (size_t i = 0; i < std::size(images); ++i)
        scenes.push_back({sceneWith("i" + std::to_string(i) + ".gltf", "sub/BoxTextured0.bin", images[i]),
                          "images[0].uri \"" + images[i] + "\""});
    const std::map<std::string, std::string> before = filesUnder(folder() / "box"),
                                             outside = filesUnder(folder() / "elsewhere");
    for (const auto& [scene, quoted] : scenes) {
        expectFailure({{"scene", scene, "--grid", "2,2,2", "-o", "OUT"},
                       2,
                       {scene + ": " + quoted, "is outside the scene's folder"},
                       "out.shpv"});
        const RunResult result = run({"scene", scene, "--grid", "2,2,2", "-o", file("x.shpv")});
        EXPECT_LT(result.err.size(), 600u) << "the URI is cut";
    }
    EXPECT_FALSE(fs::exists(file("x.shpv")));
    EXPECT_EQ(filesUnder(folder() / "box"), before);
    EXPECT_EQ(filesUnder(folder() / "elsewhere"), outside);
}

// Input a message quotes is cut to a few hundred bytes, so that the one line stays short: a data
// URI of megabytes that tinygltf quotes whole (its decoded size is not the buffer's byteLength; the
// line had 64 MB), an extension's name of megabytes, one required. Each line, less the scene's path,
// is under 400 bytes.
TEST_F(SceneCommand, QuotedInputIsCutShort) {
    const std::string longText(4'000'000, 'A');
    const std::string dataUri = "data:application/octet-stream;base64," + longText;
    const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
        {R"({"asset": {"version": "2.0"}, "buffers": [{"uri": ")" + dataUri + R"(", "byteLength": 60}]})",
         {"data:application/octet-stream;base64,AAAA", "A... (4000"}},
        {R"({"asset": {"version": "2.0", "extensions": {")" + longText + R"(": 1}}})",
         {"asset.extensions.AAAA", "... (4000000 bytes) must be an object, not a number (1)"}},
        {R"({"asset": {"version": "2.0"}, "extensionsRequired": [")" + longText + R"("]})",
         {"the file requires extension \"AAAA", "...\" (4000000 bytes), which is not read"}},
    };
    for (size_t i = 0; i < cases.size(); ++i) {
        const std::string scene = file("long" + std::to_string(i) + ".gltf");
        writeText(scene, cases[i].first);
        const RunResult result = run({"scene", scene, "--grid", "1,1,1", "-o", file("out.shpv")});
        expectMessage({{}, 2, cases[i].second}, result);
        EXPECT_LT(result.err.size() - scene.size(), 400u) << "the input is cut; the path is the test's";
        EXPECT_FALSE(fs::exists(file("out.shpv")));
    }
}

// ---- Sizes a file claims ----------------------------------------------------------------------

using nlohmann::json;

// Little-endian bytes of floats and integers, for a scene's .bin.
template <typename T> std::string binaryOf(const std::vector<T>& values) {
    std::string bytes(values.size() * sizeof(T), '\0');
    if (!values.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
    return bytes;
}

// A one-triangle scene: positions (3 vertices, 36 bytes) and texture coordinates (24 bytes) in
// buffer 0, "h.bin", with a view each; the mesh draws them, indexed by nothing. Tests change it.
json triangleScene() {
    return json{
        {"asset", {{"version", "2.0"}}},
        {"buffers", json::array({{{"uri", "h.bin"}, {"byteLength", 60}}})},
        {"bufferViews", json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 36}},
                                     {{"buffer", 0}, {"byteOffset", 36}, {"byteLength", 24}}})},
        {"accessors",
         json::array({{{"bufferView", 0}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"}},
                      {{"bufferView", 1}, {"componentType", 5126}, {"count", 3}, {"type", "VEC2"}}})},
        {"meshes", json::array({{{"primitives", json::array({{{"attributes", {{"POSITION", 0}}}}})}}})},
        {"nodes", json::array({{{"mesh", 0}}})},
    };
}

std::string triangleBin() {
    return binaryOf(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}) +
           binaryOf(std::vector<float>{0, 0, 1, 0, 0, 1});
}

class HostileScene : public SceneCommand {
  protected:
    // The peak memory of a refused run that reads nothing (a missing scene): the program itself.
    void SetUp() override {
        const RunResult empty = run({"scene", file("missing.gltf"), "--grid", "1,1,1", "-o", file("m.shpv")});
        ASSERT_EQ(empty.exitCode, 2) << describe(empty);
        baselineKiB_ = empty.peakKiB;
    }

    // Writes the scene (and `bin` as h.bin beside it) and runs `shprobe scene` on it: refused with
    // exit 2 in one line holding `mentions`, nothing written. A refusal must come from the counts and
    // headers alone: within 5 s (it took 36 s to allocate 11.7 GB for a claimed count; a loaded CI
    // machine may be slow, so a generous bound) and within 64 MiB of the run that reads nothing
    // (the hostile files are a few kilobytes; reading what they claim takes gigabytes).
    void expectRefusedFromItsCounts(const std::string& name, const json& scene, const std::string& bin,
                                    const std::vector<std::string>& mentions) {
        SCOPED_TRACE(name);
        writeText(folder() / name, scene.dump());
        writeText(folder() / "h.bin", bin);
        const std::string output = file("out.shpv");
        const RunResult result = run({"scene", file(name), "--grid", "1,1,1", "-o", output});
        expectMessage({{}, 2, mentions}, result);
        EXPECT_FALSE(fs::exists(output));
        EXPECT_LT(result.seconds, 5.0) << "refused from the counts, before reading";
        EXPECT_LT(result.peakKiB, baselineKiB_ + 64 * 1024)
            << "peak " << result.peakKiB << " KiB; a run reading nothing: " << baselineKiB_ << " KiB";
        std::printf("%s: %.3f s, peak %ld KiB (reading nothing: %ld KiB)\n", name.c_str(), result.seconds,
                    result.peakKiB, baselineKiB_);
    }

    long baselineKiB_ = 0;
};

// Every accessor's count is checked against the bytes of the buffer view that holds it (offset +
// stride * (count - 1) + element size), from the JSON, before tinygltf reads a buffer: a 648-byte
// view whose POSITION claims 10^9 or 2^31 vertices, a stride or an offset past the view, sparse
// indices past theirs. An accessor without a buffer view (zeros) is held to the vertex limit.
TEST_F(HostileScene, AccessorCountsAreCheckedAgainstTheirBytes) {
    // 54 vertices in a 648-byte view, then 3 indices in a 12-byte one.
    std::vector<float> positions(54 * 3, 0.0f);
    for (size_t i = 0; i < positions.size(); ++i)
        positions[i] = float(i % 7);
    const std::string bin = binaryOf(positions) + binaryOf(std::vector<uint32_t>{0, 1, 2});
    auto indexed = [](json position) {
        json scene = triangleScene();
        scene["buffers"][0]["byteLength"] = 660;
        scene["bufferViews"] = json::array({{{"buffer", 0}, {"byteLength", 648}, {"byteStride", 12}},
                                            {{"buffer", 0}, {"byteOffset", 648}, {"byteLength", 12}}});
        position.merge_patch({{"componentType", 5126}, {"type", "VEC3"}});
        scene["accessors"] = json::array(
            {position, {{"bufferView", 1}, {"componentType", 5125}, {"count", 3}, {"type", "SCALAR"}}});
        scene["meshes"][0]["primitives"][0]["indices"] = 1;
        return scene;
    };
    expectRefusedFromItsCounts("billion.gltf", indexed({{"bufferView", 0}, {"count", 1'000'000'000}}), bin,
                               {"accessors[0] claims 1000000000 elements of 12 bytes, 12 apart, from byte 0",
                                "need 12000000000 bytes of bufferViews[0], which has 648"});
    expectRefusedFromItsCounts("two31.gltf", indexed({{"bufferView", 0}, {"count", int64_t(1) << 31}}), bin,
                               {"accessors[0] claims 2147483648 elements", "which has 648"});
    json strided = indexed({{"bufferView", 0}, {"count", 4}});
    strided["bufferViews"][0]["byteStride"] = 252;
    expectRefusedFromItsCounts("stride.gltf", strided, bin,
                               {"accessors[0] claims 4 elements of 12 bytes, 252 apart", "need 768 bytes"});
    expectRefusedFromItsCounts("offset.gltf", indexed({{"bufferView", 0}, {"count", 1}, {"byteOffset", 640}}),
                               bin, {"accessors[0] claims 1 element of 12 bytes from byte 640", "need 652"});
    expectRefusedFromItsCounts(
        "sparse.gltf",
        indexed({{"count", 54},
                 {"sparse",
                  {{"count", 54},
                   {"indices", {{"bufferView", 1}, {"componentType", 5125}}},
                   {"values", {{"bufferView", 0}}}}}}),
        bin, {"accessors[0].sparse.indices claims 54 elements of 4 bytes", "bufferViews[1], which has 12"});
    expectRefusedFromItsCounts("zeros.gltf", indexed({{"count", int64_t(1) << 31}}), bin,
                               {"POSITION has 2147483648 vertices, more than the limit of 60000000"});
}

// The triangle limit holds for the scene's total, every node that instances a mesh counted, and is
// checked before any vertex is read: 21 nodes instancing a mesh of a million triangles (positions
// without a buffer view, zeros) took 2.5 GB reading 20 of them before the 21st was refused.
TEST_F(HostileScene, InstancedTrianglesAreCountedBeforeReading) {
    json scene = triangleScene();
    scene["accessors"].push_back({{"componentType", 5126}, {"count", 3'000'000}, {"type", "VEC3"}});
    scene["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 2;
    scene["nodes"] = json::array();
    json children = json::array();
    for (int n = 1; n <= 21; ++n) {
        scene["nodes"].push_back({{"mesh", 0}, {"translation", {n, 0, 0}}});
        children.push_back(n);
    }
    scene["nodes"].insert(scene["nodes"].begin(), json{{"children", children}});
    expectRefusedFromItsCounts(
        "instances.gltf", scene, triangleBin(),
        {"the scene's 21 mesh instances make 21000000 triangles, more than the limit of 20000000 triangles"});
}

// Texture pixels are summed over the images the drawn materials use, from their headers, before any
// is decoded: 24 textures of 4096 x 4096 (each within the limit of one texture) in a scene of a few
// hundred kilobytes needed 4 GB decoded.
TEST_F(HostileScene, TexturePixelsAreSummedFromTheHeaders) {
    { // released before the runs: a forked child's peak memory counts this process's pages
        const std::vector<uint8_t> grey(size_t(4096) * 4096 * 4, 128);
        writeText(folder() / "big.png", encodeRgba8("png", 4096, 4096, grey));
    }
    ASSERT_LT(fs::file_size(folder() / "big.png"), 1u << 20);
    json scene = triangleScene();
    scene["images"] = scene["textures"] = scene["materials"] = scene["meshes"][0]["primitives"] =
        json::array();
    for (int i = 0; i < 24; ++i) {
        scene["images"].push_back({{"uri", "big.png"}});
        scene["textures"].push_back({{"source", i}});
        scene["materials"].push_back({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", i}}}}}});
        scene["meshes"][0]["primitives"].push_back(
            {{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}}, {"material", i}});
    }
    expectRefusedFromItsCounts("textures.gltf", scene, triangleBin(),
                               {"the 24 textures the scene's materials use have 402653184 pixels",
                                "more than the limit of 134217728 pixels in all"});
}

} // namespace
} // namespace shprobe
