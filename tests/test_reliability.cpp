// The program's second round of reliability, one test per class of the table of docs/reliability.md
// that test_bad_inputs does not hold: a full file system, outputs that are links, devices,
// FIFOs and standard output, file-system errors as one line, the pipeline cache, number options,
// output names, outputs that are inputs, memory bounded by what a file holds, and bad options refused
// before any work. Each failure follows test_bad_inputs' rules (ProgramTest::expectFailure): its exit
// code, exactly one line "shprobe: error: ...", no file left behind, an existing output unchanged.
//
// ctest runs this with VK_ICD_FILENAMES = lavapipe and SHPROBE_VALIDATION=1, which the children
// inherit. Some cases need root (mounting a small tmpfs to fill it) or another user (permission
// bits): they are skipped with a message where this process cannot have them.
#include "child_program.h"
#include "formats/engine_export.h"
#include "formats/probe_file.h"
#include "image/image_write.h"
#include "sh/basis.h"
#include "sh/rotation.h"
#include "test_support.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace shprobe {
namespace {

using Reliability = ProgramTest;

constexpr double kY00 = 0.28209479177387814; // 1 / (2 sqrt(pi))

bool isCharacterDevice(const char* path) {
    struct stat status {};
    return stat(path, &status) == 0 && S_ISCHR(status.st_mode);
}

// Every command that writes, with an output of each kind it writes. The bakes are of the built-in
// sky at face size 4 (a few milliseconds); bench is left out: its report takes the same path.
std::vector<Failure> everyWriter(const std::string& probe) {
    return {
        {{"bake", "--face-size", "4", "-q", "-o", "OUT"}, 3, {}, "probe.json"},
        {{"bake", "--face-size", "4", "-q", "-o", "OUT"}, 3, {}, "probe.bin"},
        {{"bake", "--face-size", "4", "-q", "-o", "OUT"}, 3, {}, "probe.glsl"},
        {{"bake", "--face-size", "4", "-q", "-o", "OUT"}, 3, {}, "probe.h"},
        {{"bake", "--face-size", "4", "-q", "--map-size", "8", "-o", "OUT"}, 3, {}, "map.exr"},
        {{"bake", "--face-size", "4", "-q", "--format", "irradiance-cross", "--map-size", "4", "-o", "OUT"},
         3,
         {},
         "cross.exr"},
        {{"rotate", probe, "--euler", "0,90,0", "-o", "OUT"}, 3, {}, "rotated.json"},
        {{"light", "--ambient", "1,1,1", "-o", "OUT"}, 3, {}, "light.json"},
        {{"render", probe, "--size", "8", "-o", "OUT"}, 3, {}, "render.png"},
        {{"render", probe, "--size", "8", "-o", "OUT"}, 3, {}, "render.jpg"},
        {{"render", probe, "--size", "8", "-o", "OUT"}, 3, {}, "render.exr"},
        {{"render", probe, "--size", "8", "-o", "OUT"}, 3, {}, "render.hdr"},
    };
}

// A tmpfs of 256 KiB mounted over `folder` for the test's lifetime, then filled to the last
// byte: every further write fails with ENOSPC, as on a full disk.
class FullFileSystem {
  public:
    explicit FullFileSystem(const fs::path& folder) : folder_(folder) {
        fs::create_directories(folder_);
        mounted_ = mount("tmpfs", folder_.c_str(), "tmpfs", 0, "size=256k,nr_inodes=1000") == 0;
        error_ = mounted_ ? "" : std::strerror(errno);
    }
    ~FullFileSystem() {
        if (mounted_) umount2(folder_.c_str(), MNT_DETACH);
    }
    bool mounted() const { return mounted_; }
    const std::string& error() const { return error_; }
    // Writes the filler until the file system refuses another byte.
    void fill() const {
        int file = open((folder_ / "filler").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ASSERT_GE(file, 0);
        std::string block(4096, 'x');
        for (size_t size : {block.size(), size_t(1)})
            while (write(file, block.data(), size) == ssize_t(size)) {
            }
        close(file);
    }

  private:
    fs::path folder_;
    bool mounted_ = false;
    std::string error_;
};

// Every writer on a full file system: exit 3 saying so, no file added (the temporary one is gone
// too) and an existing output unchanged. OpenImageIO's PNG writer returned success after short
// writes and left a truncated file: the program now writes every byte itself.
TEST_F(Reliability, FullFileSystemLosesNothing) {
    if (geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root";
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    FullFileSystem full(folder() / "full");
    if (!full.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here: " << full.error();
    const std::string before = "an earlier good output\n";
    std::vector<std::string> names{"filler"};
    for (const Failure& writer : everyWriter(file("probe.json"))) {
        writeText(folder() / "full" / writer.output, before);
        names.push_back(writer.output);
    }
    std::sort(names.begin(), names.end());
    full.fill();
    for (Failure writer : everyWriter(file("probe.json"))) {
        SCOPED_TRACE(writer.args[0] + " -> " + writer.output);
        writer.mentions = {"no space left on device"};
        for (const std::string& name : {writer.output, "new_" + writer.output})
            expectMessage(writer, run(withOutput(writer.args, (folder() / "full" / name).string())));
    }
    EXPECT_EQ(entriesOf(folder() / "full"), names);
    for (const std::string& name : names) {
        if (name == "filler") continue;
        EXPECT_EQ(readText(folder() / "full" / name), before) << name;
    }
}

// A link is followed and its target replaced (created when missing), in the target's folder; the
// link stays a link.
TEST_F(Reliability, LinksAreFollowedAndKept) {
    fs::create_directories(folder() / "elsewhere");
    fs::create_symlink(folder() / "elsewhere" / "target.json", folder() / "link.json");
    fs::create_symlink("elsewhere/target.png", folder() / "link.png"); // relative to the link's folder
    for (int run = 0; run < 2; ++run) {                                // creates the target, then replaces it
        runOk({"light", "--ambient", std::to_string(run + 1) + ",1,1", "-o", file("link.json")});
        runOk({"render", file("link.json"), "--size", "8", "-o", file("link.png")});
    }
    EXPECT_TRUE(fs::is_symlink(folder() / "link.json"));
    EXPECT_TRUE(fs::is_symlink(folder() / "link.png"));
    ShCoefficients written = readProbeFile(file("elsewhere/target.json"));
    EXPECT_GT(written.rgb[0].r, written.rgb[0].g) << "the second run replaced the target";
    EXPECT_EQ(entriesOf(folder() / "elsewhere"), (std::vector<std::string>{"target.json", "target.png"}));
}

// Devices, FIFOs and standard output are written through as streams, never replaced by a file:
// /dev/full fails as a full disk does, /dev/null takes anything, /dev/stdout and "-" reach the
// program's stdout (the report then goes to stderr), a FIFO reaches its reader.
TEST_F(Reliability, DevicesFifosAndStandardOutputAreStreams) {
    expectMessage({{}, 3, {"cannot write /dev/full", "no space left on device"}},
                  run({"light", "--ambient", "1,1,1", "-o", "/dev/full"}));
    EXPECT_TRUE(isCharacterDevice("/dev/full"));
    runOk({"bake", "--face-size", "4", "-q", "--format", "binary", "-o", "/dev/null"});
    EXPECT_TRUE(isCharacterDevice("/dev/null"));
    for (const char* standardOutput : {"-", "/dev/stdout"}) {
        SCOPED_TRACE(standardOutput);
        RunResult result = run({"light", "--ambient", "1,2,3", "-o", standardOutput});
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        const double l00 = 3.0 * kY00 * 4.0 * std::numbers::pi; // uniform radiance 3
        EXPECT_NEAR(parseProbe(result.out, "stdout").coefficients.rgb[0].b, l00, 1e-6 * l00)
            << "the probe alone is on stdout";
        EXPECT_CONTAINS(result.err, "shprobe light:");
    }
    EXPECT_TRUE(fs::is_symlink("/dev/stdout"));

    ASSERT_EQ(mkfifo(file("probe.fifo").c_str(), 0644), 0);
    std::string received;
    std::thread reader([&] { received = readText(folder() / "probe.fifo"); });
    runOk({"light", "--ambient", "1,1,1", "-o", file("probe.fifo")});
    reader.join();
    EXPECT_NO_THROW(parseProbe(received, "fifo"));
    EXPECT_EQ(fs::status(folder() / "probe.fifo").type(), fs::file_type::fifo);
}

// A reader that goes away: the write fails with EPIPE, said in one line with exit 3, rather than
// the program ending by SIGPIPE without a word.
TEST_F(Reliability, ABrokenPipeIsAWriteError) {
    int pipeEnds[2];
    ASSERT_EQ(pipe(pipeEnds), 0);
    close(pipeEnds[0]); // no reader
    RunResult result =
        run({"light", "--order", "8", "--ambient", "1,1,1", "-o", "-"}, {.standardOutput = pipeEnds[1]});
    close(pipeEnds[1]);
    expectMessage({{}, 3, {"cannot write -: broken pipe"}}, result);
}

// A replaced file keeps its permissions; a file the user may not write is not replaced (as a
// shell's > would refuse it), even though the folder would allow the rename.
TEST_F(Reliability, ReplacedFilesKeepTheirPermissions) {
    writeText(folder() / "private.json", "earlier\n");
    fs::permissions(folder() / "private.json", fs::perms::owner_read | fs::perms::owner_write);
    runOk({"light", "--ambient", "1,1,1", "-o", file("private.json")});
    EXPECT_EQ(fs::status(folder() / "private.json").permissions(),
              fs::perms::owner_read | fs::perms::owner_write);
    if (geteuid() != 0) GTEST_SKIP() << "the read-only case needs root to run the program as user nobody";
    fs::permissions(folder(), fs::perms::all); // the folder lets nobody rename into it
    writeText(folder() / "readonly.json", "earlier\n");
    fs::permissions(folder() / "readonly.json", fs::perms::owner_read | fs::perms::others_read);
    expectMessage({{}, 3, {"cannot write " + file("readonly.json"), "permission denied"}},
                  run({"light", "--ambient", "1,1,1", "-o", file("readonly.json")}, {.asOtherUser = true}));
    EXPECT_EQ(readText(folder() / "readonly.json"), "earlier\n");
}

// The kernel's rule for links in shared sticky folders (fs.protected_symlinks), applied by the
// writer that follows links itself: another user's link in /tmp is not followed, so root cannot
// be made to replace the file it points to.
TEST_F(Reliability, AnotherUsersLinkInASharedStickyFolderIsNotFollowed) {
    if (geteuid() != 0) GTEST_SKIP() << "needs root to give the link to another user";
    fs::create_directories(folder() / "shared");
    fs::permissions(folder() / "shared", fs::perms::all | fs::perms::sticky_bit);
    writeText(folder() / "victim.txt", "victim\n");
    fs::create_symlink(folder() / "victim.txt", folder() / "shared" / "probe.json");
    ASSERT_EQ(lchown(file("shared/probe.json").c_str(), kNobody, kNobody), 0);
    expectMessage({{}, 3, {"permission denied", "sticky"}},
                  run({"light", "--ambient", "1,1,1", "-o", file("shared/probe.json")}));
    EXPECT_EQ(readText(folder() / "victim.txt"), "victim\n");
}

// Probe readers take "-" for standard input; a device or a FIFO in place of a probe file is
// refused at once, never read (a FIFO would wait for a writer, /dev/zero never end).
TEST_F(Reliability, ProbeReadersTakeStandardInputAndNoSpecialFiles) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    RunResult rotated = run({"rotate", "-", "--euler", "0,0,0", "-o", file("rotated.json")},
                            {.standardInput = file("probe.json")});
    EXPECT_EQ(rotated.exitCode, 0) << describe(rotated);
    EXPECT_NEAR(readProbeFile(file("rotated.json")).rgb[4].r, testing::distinctProbe(3).rgb[4].r, 1e-7);
    RunResult rendered =
        run({"render", "-", "--size", "8", "-o", file("r.png")}, {.standardInput = file("probe.json")});
    EXPECT_EQ(rendered.exitCode, 0) << describe(rendered);
    ASSERT_EQ(mkfifo(file("probe_fifo.json").c_str(), 0644), 0);
    for (const std::string& special : {std::string("/dev/zero"), file("probe_fifo.json")}) {
        expectFailure(
            {{"rotate", special, "--euler", "0,90,0", "-o", "OUT"}, 2, {special, "not a regular file"}});
        expectFailure({{"render", special + ".json", "-o", "OUT"}, 2, {}, "out.png"});
    }
    expectFailure({{"rotate", "-", "--euler", "0,90,0", "-o", "OUT"}, 2, {"standard input", "empty"}});
}

// File-system failures name the path and the system's reason, with the exit code of their side
// (2 inputs, 3 outputs), never "internal error".
TEST_F(Reliability, FileSystemErrorsAreOneLine) {
    fs::create_symlink(folder() / "loop_b", folder() / "loop_a");
    fs::create_symlink(folder() / "loop_a", folder() / "loop_b");
    const std::string loop = file("loop_a"), longName = file(std::string(300, 'n') + ".exr");
    const std::string loopReason = "too many levels of symbolic links", longReason = "file name too long";
    expectFailure({{"bake", loop, "-o", "OUT"}, 2, {loop, loopReason}});
    expectFailure({{"rotate", loop, "--euler", "0,90,0", "-o", "OUT"}, 2, {loop, loopReason}});
    expectFailure({{"bake", longName, "-o", "OUT"}, 2, {longReason}});
    for (const std::string& output : {loop + "/probe.json", loop, file(std::string(300, 'o') + ".json")}) {
        RunResult result = run({"light", "--ambient", "1,1,1", "-o", output});
        expectMessage({{}, 3, {"cannot write " + output, output.size() > 300 ? longReason : loopReason}},
                      result);
    }
    RunResult outDir = run({"bake", "--out-dir", loop, file("a.exr"), file("b.exr")});
    expectMessage({{}, 3, {loop, loopReason}}, outDir);

    // A relative input once the working folder is gone: its name and "no such file"; a relative
    // output: the folder "was removed". Neither reaches std::filesystem's current_path.
    fs::create_directories(folder() / "gone");
    RunResult goneInput = run({"bake", "sky.exr", "-o", file("gone.json")},
                              {.workingFolder = file("gone"), .removeWorkingFolder = true});
    expectMessage({{}, 2, {"sky.exr: no such file"}}, goneInput);
    fs::create_directories(folder() / "gone");
    RunResult goneOutput = run({"light", "--ambient", "1,1,1", "-o", "light.json"},
                               {.workingFolder = file("gone"), .removeWorkingFolder = true});
    expectMessage({{}, 3, {"cannot write light.json", "was removed"}}, goneOutput);
}

// A mode-000 input, or an input in a folder that may not be searched, is "permission denied" for
// a user other than root (root ignores the bits: the program runs as user nobody).
TEST_F(Reliability, UnreadableInputsSayPermissionDenied) {
    if (geteuid() != 0) GTEST_SKIP() << "needs root to run the program as user nobody";
    writeImage(file("sky.exr"), makeImage(8, 4));
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    fs::create_directories(folder() / "closed");
    writeProbeFile(file("closed/probe.json"), testing::distinctProbe(3), {});
    fs::permissions(folder(), fs::perms::all); // nobody may write its outputs here
    fs::permissions(folder() / "sky.exr", fs::perms::none);
    fs::permissions(folder() / "probe.json", fs::perms::none);
    fs::permissions(folder() / "closed", fs::perms::none);
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"bake", file("sky.exr"), "-o", file("a.json")}, file("sky.exr")},
        {{"rotate", file("probe.json"), "--euler", "0,90,0", "-o", file("b.json")}, file("probe.json")},
        {{"rotate", file("closed/probe.json"), "--euler", "0,90,0", "-o", file("c.json")},
         file("closed/probe.json")},
    };
    for (const auto& [args, input] : cases)
        expectMessage({{}, 2, {input, "permission denied"}}, run(args, {.asOtherUser = true}));
    fs::permissions(folder() / "closed", fs::perms::owner_all);
}

// The pipeline cache is only an optimization: a FIFO, a link to /dev/zero or a folder in place of
// the cache file, or a cache folder that is a loop of links, too long a name or a file, costs one warning
// line and nothing else (the probe is written, exit 0, within seconds). Runs sharing one cache
// folder at once all succeed without a word.
TEST_F(Reliability, PipelineCacheNeverHangsNorFails) {
    const std::string cache = file("cache");
    fs::create_directories(cache);
    RunResult first = run({"bake", "--backend", "gpu", "--face-size", "4", "-q", "-o", file("first.json")},
                          {.environment = {{"SHPROBE_CACHE_DIR", cache}}});
    ASSERT_EQ(first.exitCode, 0) << describe(first);
    std::vector<std::string> created = entriesOf(cache);
    ASSERT_EQ(created.size(), 1u) << "the first run writes its cache";
    const fs::path cacheFile = fs::path(cache) / created[0];

    fs::create_symlink(folder() / "loop_b", folder() / "loop_a");
    fs::create_symlink(folder() / "loop_a", folder() / "loop_b");
    const std::vector<std::pair<std::string, std::function<void()>>> breakages = {
        {"a FIFO", [&] { ASSERT_EQ(mkfifo(cacheFile.c_str(), 0644), 0); }},
        {"a link to /dev/zero", [&] { fs::create_symlink("/dev/zero", cacheFile); }},
        {"a folder", [&] { fs::create_directories(cacheFile); }},
    };
    auto expectWarning = [&](const std::string& what, const std::string& folderName) {
        SCOPED_TRACE(what);
        RunResult result =
            run({"bake", "--backend", "gpu", "--face-size", "4", "-q", "-o", file("probe.json")},
                {.environment = {{"SHPROBE_CACHE_DIR", folderName}}});
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_LT(result.seconds, 20.0) << "the cache must not make the run wait";
        EXPECT_EQ(linesOf(result.err).size(), 1u) << result.err;
        EXPECT_CONTAINS(result.err, "shprobe: warning: pipeline cache not used");
        EXPECT_NO_THROW(readProbeFile(file("probe.json")));
    };
    for (const auto& [what, breakCache] : breakages) {
        fs::remove(cacheFile);
        breakCache();
        expectWarning(what, cache);
    }
    expectWarning("a loop of links", file("loop_a"));
    expectWarning("too long a name", file(std::string(300, 'c')));
    expectWarning("a file for its folder", file("first.json"));

    const std::string shared = file("shared");
    std::vector<std::unique_ptr<Child>> runs;
    for (int i = 0; i < 4; ++i)
        runs.push_back(std::make_unique<Child>(
            std::vector<std::string>{"bake", "--backend", "gpu", "--face-size", "8", "-q", "-o",
                                     file("run" + std::to_string(i) + ".json")},
            folder() / "logs", RunOptions{.environment = {{"SHPROBE_CACHE_DIR", shared}}}));
    for (std::unique_ptr<Child>& child : runs) {
        RunResult result = child->wait();
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_EQ(result.err, "") << describe(result);
    }
}

// A sun (bake --extract-sun, or a probe file that has one) is kept or refused, never dropped without
// a word: json keeps it; binary, whose header has no place for it, is refused like the headers, the
// engine formats and the irradiance maps, in one line that says so and names the format that holds
// it. The advice names
// only what the program can do (no `shprobe light` adds a sun back).
TEST_F(Reliability, SunIsKeptOrRefusedNeverDropped) {
    for (const std::string output : {"probe.bin", "probe.h", "probe.unity.json"}) {
        const bool byName = output != "probe.bin";
        std::vector<std::string> args = {"bake", "--face-size", "16", "--extract-sun", "-q", "-o", "OUT"};
        if (!byName) args.insert(args.end(), {"--format", "binary"});
        expectFailure({args, 2, {"--extract-sun", "cannot hold the sun", "--format json"}, output});
    }
    expectFailure({{"bake", "--face-size", "16", "--extract-sun", "-q", "-o", "OUT"},
                   2,
                   {"--format binary cannot hold the sun", "--format json"},
                   "probe.bin"});

    runOk({"bake", "--extract-sun", "-q", "-o", file("sun.json")}); // the built-in sky's sun
    ASSERT_TRUE(readProbe(file("sun.json")).sun.has_value());
    expectFailure(
        {{"bake", "--face-size", "16", "--extract-sun", "--format", "irradiance-cross", "-q", "-o", "OUT"},
         2,
         {"--format irradiance-cross cannot hold the sun", "--format json"},
         "cross.exr"});
    for (const std::string format : {"binary", "cpp", "godot", "irradiance-equirect"}) {
        SCOPED_TRACE(format);
        RunResult refused = run({"convert", file("sun.json"), "--format", format, "-o", file("out")});
        expectMessage(
            {{}, 2, {"sun.json has a sun", "the " + format + " format cannot hold", "--format json"}},
            refused);
        EXPECT_EQ(refused.err.find("shprobe light"), std::string::npos) << refused.err;
        EXPECT_FALSE(fs::exists(file("out")));
    }
    runOk({"convert", file("sun.json"), "--format", "json", "-o", file("copy.json")});
    EXPECT_TRUE(readProbe(file("copy.json")).sun.has_value());
}

// The pipeline cache's folder: $XDG_CACHE_HOME/shprobe when XDG_CACHE_HOME is an absolute path, else
// $HOME/.cache/shprobe when HOME is a folder that exists. A missing home is never created (the
// cache made ~/.cache/shprobe, and with it HOME, where HOME did not exist): the bake runs without a
// cache after one warning line. A relative XDG_CACHE_HOME is ignored.
TEST_F(Reliability, PipelineCacheFollowsXdgAndNeverMakesAHome) {
    const std::vector<std::string> bake = {"bake", "--backend", "gpu", "--face-size",
                                           "4",    "-q",        "-o",  file("probe.json")};
    const std::string missingHome = file("nonexistent/x");
    RunResult homeless = run(bake, {.environment = {{"HOME", missingHome},
                                                    {"XDG_CACHE_HOME", std::nullopt},
                                                    {"SHPROBE_CACHE_DIR", std::nullopt}}});
    EXPECT_EQ(homeless.exitCode, 0) << describe(homeless);
    EXPECT_EQ(linesOf(homeless.err).size(), 1u) << homeless.err;
    EXPECT_CONTAINS(homeless.err, "shprobe: warning: pipeline cache not used: no folder for it");
    EXPECT_CONTAINS(homeless.err, "HOME (" + missingHome + ") is not a folder");
    EXPECT_FALSE(fs::exists(file("nonexistent"))) << "the bake created the missing home's parent";
    EXPECT_NO_THROW(readProbeFile(file("probe.json")));

    const std::string xdg = file("xdg");
    RunResult withXdg =
        run(bake, {.environment = {
                       {"HOME", missingHome}, {"XDG_CACHE_HOME", xdg}, {"SHPROBE_CACHE_DIR", std::nullopt}}});
    EXPECT_EQ(withXdg.exitCode, 0) << describe(withXdg);
    EXPECT_EQ(withXdg.err, "") << describe(withXdg);
    ASSERT_TRUE(fs::is_directory(xdg + "/shprobe"));
    const std::vector<std::string> cached = entriesOf(xdg + "/shprobe");
    ASSERT_EQ(cached.size(), 1u);
    EXPECT_EQ(cached[0].rfind("pipelines-", 0), 0u) << cached[0];
    EXPECT_FALSE(fs::exists(file("nonexistent")));

    const std::string home = file("home");
    fs::create_directories(home);
    fs::create_directories(file("work"));
    RunResult relative = run(
        bake,
        {.environment = {{"HOME", home}, {"XDG_CACHE_HOME", "relative"}, {"SHPROBE_CACHE_DIR", std::nullopt}},
         .workingFolder = file("work")});
    EXPECT_EQ(relative.exitCode, 0) << describe(relative);
    EXPECT_EQ(relative.err, "") << describe(relative);
    EXPECT_EQ(entriesOf(home + "/.cache/shprobe").size(), 1u);
    // (Mesa's own shader cache may take the relative folder: only shprobe's is checked.)
    EXPECT_FALSE(fs::exists(file("work/relative/shprobe")));
}

// Every number option is refused at parse time unless finite and in its range, with a short line
// that says what is allowed.
TEST_F(Reliability, NumberOptionsMustBeFiniteAndInRange) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    const std::string probe = file("probe.json");
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"render", probe, "--exposure", "nan", "-o", "OUT"},
         "--exposure: nan is not a number from -64 to 64"},
        {{"render", probe, "--exposure", "-inf", "-o", "OUT"}, "--exposure: -inf is not"},
        {{"render", probe, "--yaw", "inf", "-o", "OUT"}, "--yaw: inf is not a number from -360 to 360"},
        {{"render", probe, "--pitch", "nan", "-o", "OUT"}, "--pitch: nan is not a number from -85 to 85"},
        {{"view", probe, "--exposure", "nan", "--frames", "1", "--screenshot", "OUT"}, "--exposure: nan"},
        {{"rotate", probe, "--euler", "0,nan,0", "-o", "OUT"}, "--euler: nan is not"},
        {{"rotate", probe, "--quat", "inf,0,0,0", "-o", "OUT"}, "--quat: inf is not a finite number"},
        {{"rotate", probe, "--matrix", "1,0,0,0,1,0,0,0,nan", "-o", "OUT"}, "--matrix: nan is not"},
    };
    for (const auto& [args, message] : cases) {
        const std::string output = args[0] == "view" || args[0] == "render" ? "out.png" : "out.json";
        expectFailure({args, 2, {message}, output});
        RunResult result = run(withOutput(args, file(output)));
        EXPECT_LT(result.err.size(), 120u) << "error lines stay short: " << result.err;
    }
}

// Whole-number options and options given twice are refused in the project's words, not CLI11's
// ("Value 1e9 not in range 1 to 4294967296", "At Most 1 required but received 2").
TEST_F(Reliability, WholeNumberAndRepeatedOptionsAreRefusedInPlainWords) {
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    const std::string probe = file("probe.json");
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"render", probe, "--max-pixels", "1e9", "-o", "OUT"},
         "--max-pixels: 1e9 is not a whole number from 1 to 4294967296"},
        {{"bake", "--face-size", "0", "-o", "OUT"}, "--face-size: 0 is not a whole number from 1 to 16384"},
        {{"bake", "--order", "2.5", "-o", "OUT"}, "--order: 2.5 is not a whole number from 1 to 8"},
        {{"bake", "--batch-bytes", "1e9", "--out-dir", "OUT", probe},
         "--batch-bytes: 1e9 is not a whole number from 1 to 9223372036854775807"},
        {{"render", probe, "--order", "3", "--order", "5", "-o", "OUT"},
         "--order: given 2 times; give it once"},
        {{"bake", "--order", "3", "--order", "5", "--order", "4", "-o", "OUT"},
         "--order: given 3 times; give it once"},
    };
    for (const auto& [args, message] : cases) {
        const std::string output = args[0] == "render" ? "out.png" : "out.json";
        expectFailure({args, 2, {message}, output});
        RunResult result = run(withOutput(args, file(output)));
        EXPECT_EQ(result.err.find("Value "), std::string::npos) << result.err;
        EXPECT_EQ(result.err.find("At Most"), std::string::npos) << result.err;
    }
}

// --mirror takes on or off, as its help says: not a number or yes, which CLI11 would take for a bool
// (its help showed the default as 1, which it refused).
TEST_F(Reliability, MirrorTakesOnOrOff) {
    for (const char* value : {"1", "2", "yes", "maybe"})
        expectFailure({{"bake", "--format", "filament", "--mirror", value, "-o", "OUT"},
                       2,
                       {std::string("--mirror: ") + value + " is not on or off"},
                       "sky.filament.txt"});
    EXPECT_CONTAINS(run({"convert", "--help"}).out, "--mirror on|off");
}

// --map-size and --mirror are refused where the format has no map or no mirroring to set: they were
// ignored, exit 0, so a user asking for a 64-texel map got none and no word of it.
TEST_F(Reliability, FormatOptionsTheFormatDoesNotUseAreRefused) {
    writeProbeFile(file("p.json"), testing::distinctProbe(3), {});
    for (const std::string command : {"bake", "convert"}) {
        std::vector<std::string> base = {command};
        if (command == "convert") base.push_back(file("p.json"));
        auto with = [&](std::vector<std::string> more) {
            more.insert(more.begin(), base.begin(), base.end());
            return more;
        };
        expectFailure({with({"--map-size", "64", "-o", "OUT"}),
                       2,
                       {"--map-size sizes the maps of --format irradiance-equirect, irradiance-cross and "
                        "gltf; --format json has none"}});
        expectFailure({with({"--mirror", "off", "-o", "OUT"}),
                       2,
                       {"--mirror is for --format filament, not threejs"},
                       "out.three.json"});
    }
}

// A whole number is read in decimal, as it is checked: "08" is eight (CLI11 alone reads a leading 0
// as octal and refuses 08), "+16" sixteen.
TEST_F(Reliability, WholeNumbersAreReadInDecimal) {
    RunResult result = run({"bake", "--order", "08", "--face-size", "+16", "-o", file("probe.json")});
    ASSERT_EQ(result.exitCode, 0) << describe(result);
    EXPECT_EQ(readProbeFile(file("probe.json")).order, 8);
}

// --directional and --sphere repeat as the help says: two lights give the sum of their probes.
TEST_F(Reliability, RepeatedLightOptionsAddUp) {
    const std::vector<std::string> a = {"--directional", "0,1,0", "1,2,3"},
                                   b = {"--directional", "1,0,0", "2,2,2"};
    const std::vector<std::string> c = {"--sphere", "0,0,1", "10", "1,1,1"},
                                   d = {"--sphere", "0,-1,0", "5", "3,2,1"};
    auto probeOf = [&](std::vector<std::vector<std::string>> lights, const std::string& name) {
        std::vector<std::string> args = {"light", "-o", file(name)};
        for (const std::vector<std::string>& light : lights)
            args.insert(args.end(), light.begin(), light.end());
        RunResult result = run(args);
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        return readProbeFile(file(name));
    };
    ShCoefficients all = probeOf({a, b, c, d}, "all.json");
    ShCoefficients parts[] = {probeOf({a}, "a.json"), probeOf({b}, "b.json"), probeOf({c}, "c.json"),
                              probeOf({d}, "d.json")};
    for (size_t i = 0; i < all.rgb.size(); ++i)
        for (int channel = 0; channel < 3; ++channel) {
            double sum = 0.0;
            for (const ShCoefficients& part : parts)
                sum += part.rgb[i][channel];
            EXPECT_NEAR(all.rgb[i][channel], sum, 1e-6 * (1.0 + std::abs(sum))) << i; // 9 digits in the files
        }
}

// --list reads a small regular file only: a folder or a device is named for what it is, at once.
TEST_F(Reliability, ListMustBeARegularFile) {
    fs::create_directories(folder() / "listdir");
    expectFailure({{"bake", "--list", file("listdir"), "--out-dir", "OUT"},
                   2,
                   {"is a folder, not a list of inputs"},
                   "probes"});
    expectFailure({{"bake", "--list", "/dev/zero", "--out-dir", "OUT"},
                   2,
                   {"/dev/zero: not a regular file"},
                   "probes"});
    EXPECT_LT(run({"bake", "--list", "/dev/zero", "--out-dir", file("probes")}).seconds, 5.0);
}

// The window a probe was baked with (bake --window) is said in what convert and rotate write from
// it, whose coefficients stay windowed: both dropped it. A window that is not a string is refused;
// null is no window.
TEST_F(Reliability, ConvertAndRotateKeepTheWindow) {
    ProbeMetadata metadata;
    metadata.window = "hanning:6";
    writeProbeFile(file("windowed.json"), testing::distinctProbe(5), metadata);
    runOk({"convert", file("windowed.json"), "-o", file("converted.json")});
    runOk({"rotate", file("windowed.json"), "--euler", "0,90,0", "-o", file("turned.json")});
    for (const char* name : {"converted.json", "turned.json"})
        EXPECT_EQ(readProbe(file(name)).window, "hanning:6") << name;
    std::string text = readText(file("windowed.json"));
    text.replace(text.find("\"hanning:6\""), 11, "6");
    writeText(file("bad.json"), text);
    expectFailure({{"convert", file("bad.json"), "-o", "OUT"}, 2, {"field \"window\" must be a string"}});
    text.replace(text.find("\"window\": 6"), 11, "\"window\": null");
    writeText(file("none.json"), text);
    EXPECT_EQ(readProbe(file("none.json")).window, "");
}

// A number list takes subnormal numbers, which are numbers: --directional 1e-320,1e-320,0 is the
// light of (1, 1, 0); it was refused as "not a list of numbers" (std::stod calls them out of range).
TEST_F(Reliability, SubnormalNumbersAreNumbers) {
    runOk({"light", "--directional", "1e-320,1e-320,0", "1,1,1", "-o", file("tiny.json")});
    runOk({"light", "--directional", "1, 1, 0", "1,1,1", "-o", file("unit.json")});
    const ShCoefficients tiny = readProbeFile(file("tiny.json")), unit = readProbeFile(file("unit.json"));
    ASSERT_EQ(tiny.rgb.size(), unit.rgb.size());
    for (size_t i = 0; i < tiny.rgb.size(); ++i)
        EXPECT_NEAR(tiny.rgb[i].g, unit.rgb[i].g, 1e-12) << i;
}

// `rotate` turns the sun taken out of a probe with its coefficients: a light from d comes from R d.
TEST_F(Reliability, RotateTurnsTheSun) {
    ProbeMetadata metadata;
    metadata.sun = ProbeSun{glm::normalize(glm::dvec3(1.0, 2.0, 3.0)), glm::dvec3(100.0, 90.0, 80.0), 0.01};
    writeProbeFile(file("sun.json"), testing::distinctProbe(3), metadata);
    runOk({"rotate", file("sun.json"), "--euler", "90,30,0", "-o", file("turned.json")});
    Probe turned = readProbe(file("turned.json"));
    ASSERT_TRUE(turned.sun.has_value()) << "the sun was dropped";
    glm::dvec3 expected = rotationFromEulerZYZ(90.0, 30.0, 0.0) * metadata.sun->direction;
    EXPECT_LT(glm::length(turned.sun->direction - expected), 1e-8);
    EXPECT_NEAR(turned.sun->radiance.r, 100.0, 1e-6);
    EXPECT_NEAR(turned.sun->angularRadius, 0.01, 1e-9);
}

// Without -o the output's name follows the format; without --format the extension chooses it;
// an extension that names another format than --format is refused before any work.
TEST_F(Reliability, OutputNamesFollowTheFormat) {
    const std::vector<std::pair<std::string, std::string>> defaults = {{"json", "probe.json"},
                                                                       {"binary", "probe.bin"},
                                                                       {"glsl", "probe.glsl"},
                                                                       {"cpp", "probe.h"},
                                                                       {"irradiance-equirect", "probe.exr"}};
    for (const auto& [format, name] : defaults) {
        fs::create_directories(folder() / format);
        std::vector<std::string> args = {"bake", "--face-size", "4", "-q", "--format", format};
        if (format == "irradiance-equirect") args.insert(args.end(), {"--map-size", "8"});
        RunResult result = run(args, {.workingFolder = file(format)});
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_EQ(entriesOf(folder() / format), std::vector<std::string>{name}) << format;
    }
    runOk({"bake", "--face-size", "4", "-q", "-o", file("chosen.bin")});
    EXPECT_EQ(readText(folder() / "chosen.bin").substr(0, 4), "SHPB");
    runOk({"bake", "--face-size", "4", "-q", "-o", file("chosen.h")});
    EXPECT_CONTAINS(readText(folder() / "chosen.h"), "chosen_sh[25][4]");
    runOk({"bake", "--face-size", "4", "-q", "--map-size", "8", "-o", file("chosen.exr")});
    EXPECT_TRUE(OIIO::ImageInput::open(file("chosen.exr"))) << "an irradiance map";
    runOk({"bake", "--face-size", "4", "-q", "-o", file("chosen.txt")});
    EXPECT_NO_THROW(readProbeFile(file("chosen.txt"))) << "an extension naming no format: json";
    expectFailure({{"bake", "--format", "binary", "-o", "OUT"},
                   2,
                   {"names a file of --format json, but --format is binary", ".bin"}});
    // An engine's double extension names that engine: another engine's format is refused, while a
    // plain .json (the last part of every engine's extension) takes any of them.
    writeProbeFile(file("p.json"), testing::distinctProbe(3), {});
    expectFailure({{"convert", file("p.json"), "--format", "unity", "-o", "OUT"},
                   2,
                   {"names a file of --format godot, but --format is unity", ".unity.json"},
                   "x.godot.json"});
    runOk({"convert", file("p.json"), "--format", "unity", "-o", file("x.json")});
    EXPECT_CONTAINS(readText(folder() / "x.json"), "{");
}

// Standard streams the caller closed or shares with an input (shell redirections, run by bash):
// with standard output closed, "-" is refused (exit 3), not written into the /dev/null that stands
// in for it; an output that is the open file standard input reads (0<>, >>) is refused before
// anything is written, and the file stays as it was.
TEST_F(Reliability, ClosedOrSharedStandardStreamsAreRefused) {
    writeProbeFile(file("p.json"), testing::distinctProbe(3), {});
    const std::string before = readText(folder() / "p.json");
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"\"$1\" convert p.json --format gltf -o - >&-", "cannot write -: descriptor 1 was closed"},
        {"\"$1\" rotate - --euler 0,90,0 -o /dev/stdin 0<>p.json",
         "cannot write /dev/stdin: it is the input -"},
        {"\"$1\" convert - --format json -o /dev/stdin 0<>p.json",
         "cannot write /dev/stdin: it is the input -"},
        {"\"$1\" rotate - --euler 0,90,0 -o - <p.json >>p.json", "cannot write -: it is the input -"},
    };
    for (const auto& [command, message] : cases) {
        writeText(folder() / "run.sh", "cd \"$2\" && " + command + " 2>err.txt\n");
        const std::string shell =
            "bash " + file("run.sh") + " " + SHPROBE_EXECUTABLE + " " + folder().string();
        const int status = std::system(shell.c_str());
        SCOPED_TRACE(command);
        ASSERT_TRUE(WIFEXITED(status));
        EXPECT_EQ(WEXITSTATUS(status), 3);
        const std::string err = readText(folder() / "err.txt");
        EXPECT_CONTAINS(err, message);
        EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
        EXPECT_EQ(readText(folder() / "p.json"), before);
    }
}

// An output that is an input, by name or through a link, is refused before any work, and the
// input stays as it was; a batch's --list counts as an input.
TEST_F(Reliability, OutputThatIsAnInputIsRefused) {
    Image sky = makeImage(8, 4);
    writeImage(file("sky.exr"), sky);
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    fs::create_symlink(folder() / "sky.exr", folder() / "alias.exr");
    fs::create_directories(folder() / "list");
    writeText(folder() / "list/sky.json", file("sky.exr") + "\n"); // baked to list/sky.json: the list
    const std::string skyBytes = readText(folder() / "sky.exr"),
                      probeBytes = readText(folder() / "probe.json"),
                      listBytes = readText(folder() / "list/sky.json");
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"bake", file("sky.exr"), "-o", file("sky.exr")}, file("sky.exr")},
        {{"bake", file("sky.exr"), "--format", "irradiance-cross", "-o", file("alias.exr")},
         file("alias.exr")},
        {{"render", file("sky.exr"), "-o", file("sky.exr")}, file("sky.exr")},
        {{"rotate", file("probe.json"), "--euler", "0,90,0", "-o", file("probe.json")}, file("probe.json")},
        {{"bake", file("sky.exr"), "--format", "irradiance-equirect", "--out-dir", folder().string()},
         file("sky.exr")},
        {{"bake", "--list", file("list/sky.json"), "--out-dir", file("list")}, file("list/sky.json")},
    };
    for (const auto& [args, output] : cases) {
        RunResult result = run(args);
        expectMessage({{}, 3, {"cannot write " + output, "it is the input"}}, result);
        EXPECT_LT(result.seconds, 5.0) << "refused before any work";
    }
    EXPECT_EQ(readText(folder() / "sky.exr"), skyBytes);
    EXPECT_EQ(readText(folder() / "probe.json"), probeBytes);
    EXPECT_EQ(readText(folder() / "list/sky.json"), listBytes);
    EXPECT_EQ(entriesOf(folder() / "list"), std::vector<std::string>{"sky.json"});
}

// An output name of 250 bytes and more, up to the longest a folder takes, is written: the
// temporary file's name is never longer than that.
TEST_F(Reliability, LongestOutputNamesAreWritten) {
    for (const std::string& name : {std::string(245, 'p') + ".json", std::string(250, 'q') + ".json"})
        runOk({"light", "--ambient", "1,1,1", "-o", file(name)});
    runOk({"render", file(std::string(245, 'p') + ".json"), "--size", "8", "-o",
           file(std::string(251, 'r') + ".png")});
    runOk({"bake", "--face-size", "4", "-q", "-o", file(std::string(251, 'b') + ".bin")});
    EXPECT_EQ(entriesOf(folder()).size(), 5u) << "four outputs and the logs, no temporary file";
}

// What a file claims is not allocated before it is checked: an EXR of a few hundred bytes whose
// header claims a 2 GiB attribute, and probe files of brackets, are refused in well under a
// second with memory near what a run that reads nothing takes.
TEST_F(Reliability, MemoryIsBoundedByWhatTheFileHolds) {
    Image small = makeImage(64, 32);
    {
        std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create("exr");
        OIIO::ImageSpec spec(64, 32, 3, OIIO::TypeDesc::FLOAT);
        spec.attribute("ImageDescription", "claims");
        ASSERT_TRUE(output->open(file("claims.exr"), spec));
        ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, small.texels.data(), sizeof(glm::vec4)));
        output->close();
    }
    // The "comments" attribute (OIIO's ImageDescription): name, type "string", a 4-byte size.
    std::string bytes = readText(folder() / "claims.exr");
    size_t at = bytes.find(std::string("comments\0string\0", 16));
    ASSERT_NE(at, std::string::npos);
    const uint32_t claimed = 0x7fffffff;
    std::memcpy(&bytes[at + 16], &claimed, 4); // little-endian, as the file is
    writeText(folder() / "claims.exr", bytes);
    writeText(folder() / "brackets.json", std::string(15700000, '['));
    writeText(folder() / "deep.json", std::string(1 << 20, '['));

    RunResult baseline = run({"bake", file("missing.exr"), "-o", file("base.json")});
    ASSERT_EQ(baseline.exitCode, 2) << describe(baseline);
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"bake", file("claims.exr"), "--max-pixels", "2048", "-o", "OUT"}, "comments"},
        {{"rotate", file("brackets.json"), "--euler", "0,90,0", "-o", "OUT"}, "bytes"},
        {{"rotate", file("deep.json"), "--euler", "0,90,0", "-o", "OUT"}, "nested deeper than"},
    };
    for (const auto& [args, mention] : cases) {
        expectFailure({args, 2, {mention}});
        RunResult result = run(withOutput(args, file("out.json")));
        EXPECT_LT(result.seconds, 1.0) << "refused at once";
        EXPECT_LT(result.peakKiB, baseline.peakKiB + 64 * 1024) << "baseline " << baseline.peakKiB << " KiB";
        RecordProperty(args[1].substr(args[1].rfind('/') + 1) + "_peak_kib", std::to_string(result.peakKiB));
    }
}

// An input too large for the machine's memory is one bad input of a batch: its error names it, the
// inputs before and after it are baked and written, and the exit code is the memory failure's (1).
// A constant 8192 x 4096 EXR (a few hundred kilobytes, ZIP) needs 512 MiB of texels, past the
// address space the program is given: 192 MiB (a small bake needed less than 200 MB here) and 24 MiB
// a core for the stacks of the threads it starts (8 MiB each, in up to three pools), which stays
// below 512 MiB up to 12 cores.
TEST_F(Reliability, AnInputTooLargeForMemoryIsSkippedInABatch) {
    if (testing::underSanitizer()) GTEST_SKIP() << "a sanitizer reserves more address space than the limit";
    const rlim_t cores = std::max(1u, std::thread::hardware_concurrency());
    if (cores > 12)
        GTEST_SKIP() << "the threads of " << cores << " cores need more address space than the image";
    writeImage(file("a.exr"), makeImage(8, 4));
    writeImage(file("c.exr"), makeImage(8, 4));
    {
        std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create("exr");
        OIIO::ImageSpec spec(8192, 4096, 3, OIIO::TypeDesc::HALF);
        spec.attribute("compression", "zip");
        ASSERT_TRUE(output->open(file("big.exr"), spec)) << output->geterror();
        const std::vector<float> row(size_t(3) * 8192, 0.5f);
        for (int y = 0; y < 4096; ++y)
            ASSERT_TRUE(output->write_scanline(y, 0, OIIO::TypeDesc::FLOAT, row.data()))
                << output->geterror();
        ASSERT_TRUE(output->close());
    }
    const std::string out = file("probes");
    RunResult result = run({"bake", file("a.exr"), file("big.exr"), file("c.exr"), "--out-dir", out},
                           {.addressSpaceBytes = (rlim_t(192) + 24 * cores) << 20});
    EXPECT_EQ(result.exitCode, 1) << describe(result);
    EXPECT_NE(result.err.find(file("big.exr") + ": out of memory"), std::string::npos) << result.err;
    EXPECT_TRUE(fs::exists(out + "/a.json")) << result.err;
    EXPECT_TRUE(fs::exists(out + "/c.json")) << result.err;
    EXPECT_FALSE(fs::exists(out + "/big.json"));
}

// The file an output of each command is named, by its extension.
std::string outputNameFor(const std::string& command) {
    if (command == "scene") return "out.shpv";
    if (command == "render" || command == "view") return "out.png";
    if (command == "convert") return "out.exr";
    return "out.json";
}

// Every option is checked as the command line is read or right after, so that a malformed value is
// refused before an input is decoded, a device created or an output touched, however large the job:
// each bad option below is refused (exit 2, one line) in less than `shprobe COMMAND --help` takes
// plus 0.1 s. Neither reads anything; the margin is for the scheduling of a short process on a busy
// machine, and far below what decoding forest.exr into 2048^2 faces or starting Vulkan takes. The
// best of three runs of each counts, the one least disturbed by other work.
TEST_F(Reliability, BadOptionsAreRefusedBeforeAnyWork) {
    const std::string sky = "/usr/share/blender/datafiles/studiolights/world/forest.exr";
    const std::string scene = SHPROBE_GLTF_MODELS_DIR "/BoxTextured-glTF/BoxTextured.gltf";
    if (!fs::exists(sky) || !fs::exists(scene))
        GTEST_SKIP() << "needs " << sky << " (blender-data) and " << scene << " (assimp-testmodels)";
    writeProbeFile(file("probe.json"), testing::distinctProbe(3), {});
    const std::string probe = file("probe.json");
    using Args = std::vector<std::string>;
    auto with = [](Args args, const Args& more) {
        args.insert(args.end(), more.begin(), more.end());
        return args;
    };
    const Args bake = {"bake", sky, "--face-size", "2048", "--backend", "reference", "-q", "-o", "OUT"};
    const Args render = {"render", sky, "--face-size", "2048", "-o", "OUT"};
    const Args sceneBake = {"scene",           scene,  "--face-size", "4096", "--sky", sky,
                            "--sky-face-size", "2048", "-o",          "OUT"};
    std::vector<std::pair<Args, std::string>> cases = {
        {with(bake, {"--window", "hanning:bogus"}), "--window: 'bogus' is not a list of numbers"},
        {with(bake, {"--window", "gauss:3"}), "--window: 'gauss:3' is not none, hanning:WIDTH"},
        {with(bake, {"--window", "lanczos:0"}), "--window: the width must be positive"},
        {with(bake, {"--directional", "0,1", "1,1,1"}), "--directional: '0,1' needs 3 numbers"},
        {with(bake, {"--directional", "0,0,0", "1,1,1"}), "--directional: the direction 0,0,0 has no length"},
        {with(bake, {"--sphere", "0,1,0", "-5", "1,1,1"}), "--sphere: the radius -5 must be in (0, 180]"},
        {with(bake, {"--sphere", "0,1,0", "5", "1,1"}), "--sphere: '1,1' needs 3 numbers"},
        {with(bake, {"--ambient", "1,x,1"}), "--ambient: '1,x,1' is not a list of numbers"},
        {with(bake, {"--device", "0"}),
         "--device is for a Vulkan device, which --backend reference does not use"},
        {{"light", "--sphere", "0,1,0", "200", "1,1,1", "-o", "OUT"}, "--sphere: the radius 200"},
        {with(render, {"--size", "64x"}), "--size must be N or WxH with sides 1..16384, not '64x'"},
        {with(render, {"--size", "0"}), "--size must be N or WxH with sides 1..16384, not '0'"},
        {with(render, {"--grid", "--size", "320x100"}),
         "--size 320x100 with --grid: the size is the cell width"},
        {{"rotate", probe, "--euler", "0,400,0", "-o", "OUT"},
         "--euler: 400 is not a number from -360 to 360"},
        {{"rotate", probe, "--euler", "0,90", "-o", "OUT"}, "--euler"},
        {{"rotate", probe, "--quat", "2,0,0,0", "-o", "OUT"}, "is not a unit quaternion"},
        {{"rotate", probe, "--matrix", "1,0,0,0,1,0,0,0,2", "-o", "OUT"}, "is not orthonormal"},
        {{"rotate", probe, "-o", "OUT"}, "give exactly one of --euler, --quat, --matrix"},
        {with(sceneBake, {"--grid", "2,x,2"}), "--grid: '2,x,2' is not 3 whole numbers NX,NY,NZ"},
        {with(sceneBake, {"--grid", "2,2,2", "--backend", "cpu", "--validation"}),
         "--validation is for a Vulkan device, which --backend cpu does not use"},
        {with(sceneBake, {"--grid", "2,2"}), "--grid: '2,2' needs 3 counts NX,NY,NZ"},
        {with(sceneBake, {"--grid", "2,2,2", "--bounds", "1,0,0,0,1,1"}), "the minimum corner comes first"},
        {with(sceneBake, {"--grid", "2,2,2", "--bounds", "0,0,0,0,1,1"}),
         "--grid/--bounds: the grid's bounds"},
        {with(sceneBake, {"--grid", "2,2,2", "--brick", "2/2"}),
         "--brick: '2/2': bricks are numbered from 0"},
        {with(sceneBake, {"--grid", "2,2,2", "--brick", "0/9"}), "--brick 0/9: the grid has 8 probes"},
        {{"convert", probe, "--format", "irradiance-equirect", "--map-size", "7", "-o", "OUT"},
         "--map-size: an equirect map's width must be even and at least 2, not 7"},
        {{"bench", "--sizes", "256", "0", "--json", "OUT"}, "cube-map face size must be positive, got 0"},
        {{"bench", "--sizes", "256", "100000", "--json", "OUT"},
         "--sizes: 100000 is more than the 16384 a bake takes as --face-size"},
    };
    // shprobe view runs shprobe-view, which a build without GLFW lacks.
    if (fs::exists(fs::path(SHPROBE_EXECUTABLE).parent_path() / "shprobe-view")) {
        const Args view = {"view", sky, "--face-size", "2048", "--frames", "1", "--screenshot", "OUT"};
        cases.push_back({with(view, {"--keys", "5,x"}), "unknown key 'x'"});
        cases.push_back({with(view, {"--size", "960x"}), "--size must be N or WxH"});
        cases.push_back(
            {{"view", sky, "--face-size", "2048", "--screenshot", "OUT"}, "--screenshot needs --frames N"});
    }

    std::map<std::string, double> helpSeconds;
    auto best = [&](const Args& args, int exitCode, const std::string& message) {
        double seconds = HUGE_VAL;
        for (int attempt = 0; attempt < 3; ++attempt) {
            const RunResult result = this->run(args);
            if (exitCode == 0)
                EXPECT_EQ(result.exitCode, 0) << describe(result);
            else
                expectMessage({args, exitCode, {message}}, result);
            seconds = std::min(seconds, result.seconds);
        }
        return seconds;
    };
    for (const auto& [args, message] : cases) {
        SCOPED_TRACE(::testing::Message() << "shprobe " << joined(args));
        const std::string& command = args[0];
        if (!helpSeconds.count(command)) helpSeconds[command] = best({command, "--help"}, 0, "");
        const std::string output = file(outputNameFor(command));
        const double refused = best(withOutput(args, output), 2, message);
        EXPECT_FALSE(fs::exists(output)) << "a refused run wrote its output";
        EXPECT_LT(refused, helpSeconds[command] + 0.1) << "--help took " << helpSeconds[command] << " s";
        std::printf("%.4f s (--help %.4f s): shprobe %s\n", refused, helpSeconds[command],
                    joined(args).c_str());
    }
}

// A number a format cannot hold, after the format's own scaling, folding or convolution (a float
// beyond FLT_MAX, an irradiance map's pixels that could overflow), is refused naming the
// coefficient, before anything is written: no "inf" in a header, no infinite pixel in a map.
TEST_F(Reliability, ValuesAFormatCannotHoldAreRefused) {
    ShCoefficients huge = testing::distinctProbe(3);
    huge.rgb[1].r = 1e300; // l=1 m=-1, red: a finite double, far beyond float
    writeProbeFile(file("huge.json"), huge, {});
    for (const ExportFormat& format : exportFormats()) {
        const std::string name = format.name;
        if (name == "json") continue; // doubles: 1e300 is written as it is (below)
        expectFailure({{"convert", file("huge.json"), "--format", name, "-o", "OUT"},
                       2,
                       {file("huge.json") + ": coefficient l=1 m=-1 (red) is 1e+300",
                        "beyond what --format " + name + " holds (float)"},
                       "out" + std::string(format.extension)});
    }
    runOk({"convert", file("huge.json"), "--format", "json", "-o", file("copy.json")});
    EXPECT_EQ(readProbeFile(file("copy.json")).rgb[1].r, 1e300);

    // 3e38 fits a float, but an irradiance probe whose m = 0 coefficients of order 8 are all 3e38 draws
    // E/pi = 3e38 (1/pi) sum_l sqrt((2l+1)/4pi) = 5.8e38 towards +z: at the default sizes, texels
    // that close to +z are infinite floats.
    ShCoefficients bright = makeCoefficients(8, Quantity::Irradiance);
    for (int l = 0; l < 8; ++l)
        bright.rgb[size_t(l * (l + 1))] = glm::dvec3(3e38, 0.5, 0.25);
    writeProbeFile(file("bright.json"), bright, {});
    for (const std::string format : {"irradiance-equirect", "irradiance-cross"})
        expectFailure({{"convert", file("bright.json"), "--format", format, "-o", "OUT"},
                       2,
                       {file("bright.json") + ": coefficient l=0 m=0 (red) is 3e+38",
                        "beyond what --format " + format + " holds (float)"},
                       "map.exr"});
    runOk({"convert", file("bright.json"), "--format", "binary", "-o", file("bright.bin")});

    // FLT_MAX itself fits: written as 3.40282347e+38 (9 digits), which reads back a little above it
    // and was refused by the binary format, yet rounds to it.
    ShCoefficients largest = testing::distinctProbe(3);
    largest.rgb[0].r = double(std::numeric_limits<float>::max());
    writeProbeFile(file("largest.json"), largest, {});
    EXPECT_CONTAINS(readText(folder() / "largest.json"), "3.40282347e+38");
    runOk({"convert", file("largest.json"), "--format", "binary", "-o", file("largest.bin")});
}

// The codec plugins load only from the program's own tree, by absolute path. SHPROBE_EXR_PLUGIN
// and SHPROBE_OIIO_PLUGIN must name an absolute path; a plugin in a folder every user may write,
// or writable by every user itself, is refused; a load that fails says the dynamic loader's reason.
TEST_F(Reliability, PluginsLoadOnlyFromTrustedAbsolutePaths) {
    writeImage(file("sky.exr"), makeImage(8, 4));
    writeImage(file("sky.tif"), makeImage(8, 4), "tiff");
    const fs::path built = fs::path(SHPROBE_EXECUTABLE).parent_path() / "libshprobe_exr.so";
    const std::vector<std::string> bakeExr{"bake", file("sky.exr"), "--backend", "cpu", "-o", "OUT"};
    const std::string needsExr =
        file("sky.exr") + ": this format needs OpenEXR, and its plugin libshprobe_exr.so";
    expectFailure({bakeExr,
                   2,
                   {needsExr, "SHPROBE_EXR_PLUGIN=libshprobe_exr.so is not an absolute path"},
                   "out.json",
                   {{"SHPROBE_EXR_PLUGIN", "libshprobe_exr.so"}}});
    expectFailure({{"bake", file("sky.tif"), "--backend", "cpu", "-o", "OUT"},
                   2,
                   {file("sky.tif") + ": this format needs OpenImageIO",
                    "SHPROBE_OIIO_PLUGIN=./libshprobe_oiio.so is not an absolute path"},
                   "out.json",
                   {{"SHPROBE_OIIO_PLUGIN", "./libshprobe_oiio.so"}}});
    const std::string missing = file("no-such-plugin.so");
    expectFailure({bakeExr,
                   2,
                   {needsExr, "SHPROBE_EXR_PLUGIN: loading " + missing + " failed: " + missing +
                                  ": cannot open shared object file: No such file or directory"},
                   "out.json",
                   {{"SHPROBE_EXR_PLUGIN", missing}}});

    // A copy of the plugin in a private folder loads; in a folder every user may write, or writable
    // by every user itself, it is refused.
    const fs::path trusted = folder() / "trusted";
    fs::create_directories(trusted);
    fs::permissions(trusted, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                 fs::perms::others_read | fs::perms::others_exec);
    fs::copy_file(built, trusted / "libshprobe_exr.so");
    RunResult loaded =
        run({"bake", file("sky.exr"), "--backend", "cpu", "-q", "-o", file("loaded.json")},
            {.environment = {{"SHPROBE_EXR_PLUGIN", (trusted / "libshprobe_exr.so").string()}}});
    EXPECT_EQ(loaded.exitCode, 0) << describe(loaded);
    EXPECT_EQ(loaded.err, "") << describe(loaded);

    std::string shared = (folder() / "sharedXXXXXX").string();
    ASSERT_NE(mkdtemp(shared.data()), nullptr) << std::strerror(errno);
    ASSERT_EQ(chmod(shared.c_str(), 0777), 0);
    const std::string sharedPlugin = shared + "/libshprobe_exr.so";
    fs::copy_file(built, sharedPlugin);
    expectFailure(
        {bakeExr,
         2,
         {needsExr, "refusing " + sharedPlugin + ": its folder " + shared + " is writable by every user"},
         "out.json",
         {{"SHPROBE_EXR_PLUGIN", sharedPlugin}}});

    const fs::path writable = trusted / "writable.so";
    fs::copy_file(built, writable);
    fs::permissions(writable, fs::perms::others_write, fs::perm_options::add);
    expectFailure({bakeExr,
                   2,
                   {needsExr, "the file " + writable.string() + " is writable by every user"},
                   "out.json",
                   {{"SHPROBE_EXR_PLUGIN", writable.string()}}});
}

// VK_ICD_FILENAMES (or VK_DRIVER_FILES) set but empty lists no driver at all: the message names
// the variable rather than asking for a driver to be installed.
TEST_F(Reliability, AnEmptyDriverListIsNamed) {
    const std::vector<std::string> bake{"bake", "--face-size", "4", "--backend", "gpu", "-o", "OUT"};
    expectFailure({bake,
                   4,
                   {"no Vulkan driver found: VK_ICD_FILENAMES is set but empty, which lists no driver"},
                   "out.json",
                   {{"VK_ICD_FILENAMES", ""}, {"VK_DRIVER_FILES", std::nullopt}}});
    const char* lavapipe = std::getenv("VK_ICD_FILENAMES");
    expectFailure(
        {bake,
         4,
         {"VK_DRIVER_FILES is set but empty, which lists no driver (it overrides VK_ICD_FILENAMES)"},
         "out.json",
         {{"VK_ICD_FILENAMES", lavapipe ? lavapipe : "/no/driver.json"}, {"VK_DRIVER_FILES", ""}}});
}

// A Radiance HDR file in flat RGBE: `pixels` in the order stored, under the resolution line given.
void writeRadiance(const fs::path& path, const std::string& resolution,
                   const std::vector<glm::u8vec4>& pixels) {
    std::string bytes = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + resolution + "\n";
    for (const glm::u8vec4& pixel : pixels)
        bytes.append({char(pixel.r), char(pixel.g), char(pixel.b), char(pixel.a)});
    writeText(path, bytes);
}

// Radiance defines eight scan orders (resolution lines "-Y H +X W", "+Y H +X W", ..., "+X W -Y H",
// ...): the same image stored in each bakes to the same coefficients; a line naming none is refused.
TEST_F(Reliability, RadianceFilesReadInEveryOrientation) {
    constexpr int kWidth = 16, kHeight = 8;
    auto pixel = [](int x, int row) {
        return glm::u8vec4((x * 13 + row * 7) % 200 + 20, (x * 3 + row * 29) % 200 + 20,
                           (x + row * 11) % 200 + 20, 129);
    };
    // Each orientation: its line, and the pixel (x, row from the top) stored n-th.
    struct Orientation {
        std::string line;
        std::function<glm::u8vec4(int)> stored;
    };
    const std::vector<Orientation> orientations{
        {"-Y 8 +X 16", [&](int n) { return pixel(n % kWidth, n / kWidth); }},
        {"+Y 8 +X 16", [&](int n) { return pixel(n % kWidth, kHeight - 1 - n / kWidth); }},
        {"-Y 8 -X 16", [&](int n) { return pixel(kWidth - 1 - n % kWidth, n / kWidth); }},
        {"+X 16 -Y 8", [&](int n) { return pixel(n / kHeight, n % kHeight); }},
        {"-X 16 +Y 8", [&](int n) { return pixel(kWidth - 1 - n / kHeight, kHeight - 1 - n % kHeight); }},
    };
    auto bakedCoefficients = [&](const std::string& path) {
        RunResult baked = run({"bake", path, "--backend", "cpu", "-q", "-o", path + ".json"});
        EXPECT_EQ(baked.exitCode, 0) << describe(baked);
        EXPECT_EQ(baked.err, "") << describe(baked);
        return baked.exitCode == 0 ? readProbeFile(path + ".json").rgb : std::vector<glm::dvec3>{};
    };
    std::vector<glm::dvec3> standard;
    for (size_t i = 0; i < orientations.size(); ++i) {
        SCOPED_TRACE(orientations[i].line);
        std::vector<glm::u8vec4> pixels;
        for (int n = 0; n < kWidth * kHeight; ++n)
            pixels.push_back(orientations[i].stored(n));
        const std::string path = file("o" + std::to_string(i) + ".hdr");
        writeRadiance(path, orientations[i].line, pixels);
        std::vector<glm::dvec3> baked = bakedCoefficients(path);
        ASSERT_EQ(baked.size(), 9u);
        if (i == 0) standard = baked;
        EXPECT_EQ(baked, standard);
    }
    // The rows bottom to top under the standard line bake to other coefficients.
    std::vector<glm::u8vec4> flipped;
    for (int n = 0; n < kWidth * kHeight; ++n)
        flipped.push_back(orientations[1].stored(n));
    writeRadiance(file("flipped.hdr"), "-Y 8 +X 16", flipped);
    EXPECT_NE(bakedCoefficients(file("flipped.hdr")), standard);

    writeRadiance(file("z.hdr"), "-Z 8 +X 16", flipped);
    expectFailure(
        {{"bake", file("z.hdr"), "--backend", "cpu", "-o", "OUT"},
         2,
         {file("z.hdr") + ": not a Radiance HDR image (the resolution line \"-Z 8 +X 16\" names none "
                          "of Radiance's eight orientations"}});
}

// A PNG whose signature was damaged (a text-mode transfer), read by shprobe's own reader, and a PNG
// with a bad CRC inside an icon, read by OpenImageIO through libpng, which prints its own
// "libpng error: ..." line: either way stderr holds the one line of the program, libpng's words in it.
TEST_F(Reliability, PngLibraryMessagesAreFoldedIntoTheOneLine) {
    writeImage(file("good.png"), makeImage(16, 8));
    std::string png = readText(file("good.png"));
    ASSERT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    std::string damaged = png;
    damaged[7] = 'J';
    writeText(file("damaged.png"), damaged);
    expectFailure({{"bake", file("damaged.png"), "--backend", "cpu", "-o", "OUT"},
                   2,
                   {file("damaged.png") + ": not a PNG image (the PNG signature is damaged"}});

    const size_t idat = png.find("IDAT");
    ASSERT_NE(idat, std::string::npos);
    const uint32_t length = uint32_t(uint8_t(png[idat - 4])) << 24 | uint32_t(uint8_t(png[idat - 3])) << 16 |
                            uint32_t(uint8_t(png[idat - 2])) << 8 | uint32_t(uint8_t(png[idat - 1]));
    png[idat + 4 + length] ^= 1; // the first byte of IDAT's CRC
    // An icon (ICONDIR, one ICONDIRENTRY: 16 x 8, 32 bits, the PNG's size and offset 22) of that PNG.
    auto little = [](uint32_t value, int bytes) {
        std::string text;
        for (int i = 0; i < bytes; ++i)
            text += char((value >> (8 * i)) & 0xff);
        return text;
    };
    writeText(file("icon.ico"), little(0, 2) + little(1, 2) + little(1, 2) + std::string{16, 8, 0, 0} +
                                    little(1, 2) + little(32, 2) + little(uint32_t(png.size()), 4) +
                                    little(22, 4) + png);
    expectFailure({{"bake", file("icon.ico"), "--backend", "cpu", "--layout", "equirect", "-o", "OUT"},
                   2,
                   {file("icon.ico") + ": cannot read the pixels; the file may be truncated or corrupt",
                    "IDAT: CRC error"}});
}

} // namespace
} // namespace shprobe
