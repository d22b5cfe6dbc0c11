// Runs the shprobe program as a child for the tests of what it does with hostile inputs and
// outputs (test_bad_inputs, test_reliability, test_cli, test_scene_cli): stdout and stderr captured through
// files, and a fixture whose expectFailure checks the rules every failure follows (the exit code, exactly one
// line "shprobe: error: ...", no file left behind, an existing output unchanged).
#pragma once
#include "render/run_program.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <grp.h>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace shprobe {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::changedEnvironment;
using testing::EnvironmentChanges;
using testing::pointersTo;
using testing::readText;

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "in: " << (text)

// ---- Running the program ----------------------------------------------------------------------

struct RunResult {
    int exitCode = -1; // the exit status, or 128 + the signal that ended the child
    std::string out;
    std::string err;
    double seconds = 0.0;
    long peakKiB = 0; // the program's peak resident memory (ru_maxrss, as peak_launcher saw it)
};

struct RunOptions {
    EnvironmentChanges environment;
    // Run as user nobody when this process is root, for whom permission bits do not count.
    bool asOtherUser = false;
    std::string standardInput = "/dev/null";
    int standardOutput = -1; // a descriptor for stdout instead of the log file (a pipe)
    // Where the child runs; with removeWorkingFolder it removes that (empty) folder before it
    // starts shprobe, which then runs in a working folder that no longer exists.
    std::string workingFolder;
    bool removeWorkingFolder = false;
    rlim_t addressSpaceBytes = 0; // RLIMIT_AS for the program, so that a large allocation fails; 0: none
    bool errorsToOutput = false;  // stderr into stdout's file, as a terminal shows both: RunResult::out
};

constexpr uid_t kNobody = 65534;

void writeText(const fs::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

// A running shprobe: stdin /dev/null (or RunOptions::standardInput), stdout and stderr into files, the
// interrupt signals with their default action (as a terminal's Ctrl-C finds them, whatever this process
// inherited: a shell starts background jobs with SIGINT ignored). fork and exec, with only async-signal-safe
// calls in between, so that the child can become another user.
class Child {
  public:
    Child(const std::vector<std::string>& args, const fs::path& logFolder, const RunOptions& options) {
        static int runs = 0;
        fs::create_directories(logFolder);
        outPath_ = logFolder / ("run" + std::to_string(++runs) + ".stdout");
        errPath_ = logFolder / ("run" + std::to_string(runs) + ".stderr");
        peakPath_ = logFolder / ("run" + std::to_string(runs) + ".peak");
        std::vector<std::string> argStrings = testing::launchedProgram(args);
        std::vector<std::string> envStrings = changedEnvironment(options.environment);
        std::vector<char*> argv = pointersTo(argStrings), envp = pointersTo(envStrings);
        const bool drop = options.asOtherUser && geteuid() == 0;
        start_ = Clock::now();
        pid_ = fork();
        if (pid_ == 0) becomeShprobe(argv.data(), envp.data(), drop, options);
        if (pid_ < 0) ADD_FAILURE() << "fork failed: " << std::strerror(errno);
    }
    ~Child() {
        if (pid_ > 0 && !waited_) {
            kill(pid_, SIGKILL);
            while (waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
            }
        }
    }
    Child(const Child&) = delete;
    Child& operator=(const Child&) = delete;

    void signal(int number) const { kill(pid_, number); }
    bool running() const { return pid_ > 0 && !waited_ && waitpid(pid_, nullptr, WNOHANG) == 0; }

    RunResult wait() {
        RunResult result;
        int status = 0;
        while (waitpid(pid_, &status, 0) < 0)
            if (errno != EINTR) {
                ADD_FAILURE() << "waitpid failed: " << std::strerror(errno);
                return result;
            }
        waited_ = true;
        result.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
        result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        result.peakKiB = testing::peakKiBIn(peakPath_);
        result.out = readText(outPath_);
        result.err = readText(errPath_);
        return result;
    }

  private:
    [[noreturn]] void becomeShprobe(char** argv, char** envp, bool drop, const RunOptions& options) const {
        // Close-on-exec, so that only the copies dup2 makes (0 to 3) reach the program.
        constexpr int kWrite = O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC;
        int in = open(options.standardInput.c_str(), O_RDONLY | O_CLOEXEC);
        int out = options.standardOutput >= 0 ? options.standardOutput : open(outPath_.c_str(), kWrite, 0644);
        int err = options.errorsToOutput ? out : open(errPath_.c_str(), kWrite, 0644);
        if (in < 0 || out < 0 || err < 0 || dup2(in, 0) < 0 || dup2(out, 1) < 0 || dup2(err, 2) < 0)
            _exit(126);
        int peak = open(peakPath_.c_str(), kWrite, 0644); // before any drop
        if (peak < 0 || dup2(peak, 3) < 0) _exit(126);
        struct sigaction standard {};
        standard.sa_handler = SIG_DFL;
        for (int number : {SIGINT, SIGTERM, SIGHUP})
            sigaction(number, &standard, nullptr);
        sigset_t none;
        sigemptyset(&none);
        sigprocmask(SIG_SETMASK, &none, nullptr);
        if (drop && (setgroups(0, nullptr) != 0 || setgid(kNobody) != 0 || setuid(kNobody) != 0)) _exit(126);
        const char* folder = options.workingFolder.c_str();
        if (*folder && chdir(folder) != 0) _exit(126);
        if (options.removeWorkingFolder && rmdir(folder) != 0) _exit(126);
        const rlimit limit{options.addressSpaceBytes, options.addressSpaceBytes};
        if (options.addressSpaceBytes > 0 && setrlimit(RLIMIT_AS, &limit) != 0) _exit(126);
        execve(argv[0], argv, envp);
        _exit(127);
    }

    pid_t pid_ = -1;
    bool waited_ = false;
    fs::path outPath_, errPath_, peakPath_;
    Clock::time_point start_;
};

std::string describe(const RunResult& run) {
    return "exit " + std::to_string(run.exitCode) + "\n--- stdout:\n" + run.out + "--- stderr:\n" + run.err;
}

std::vector<std::string> linesOf(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
        lines.push_back(line);
    return lines;
}

// Every entry of a folder, hidden ones (temporary files) included.
std::vector<std::string> entriesOf(const fs::path& folder) {
    std::vector<std::string> names;
    std::error_code ignored;
    for (const fs::directory_entry& entry : fs::directory_iterator(folder, ignored))
        names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

// ---- Fixture ----------------------------------------------------------------------------------

struct Failure {
    std::vector<std::string> args;       // "OUT" is replaced by the output path
    int exitCode;                        // docs/commands.md: 2 input or usage, 3 output, 4 device
    std::vector<std::string> mentions;   // parts the one error line must contain
    std::string output = "out.json";     // the output's file name (the extension picks the format)
    EnvironmentChanges environment = {}; // for the runs
};

class ProgramTest : public ::testing::Test {
  protected:
    ProgramTest() {
        const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
        folder_ = fs::temp_directory_path() / ("shprobe_test_" + std::string(test->test_suite_name()) + "_" +
                                               std::to_string(getpid()) + "_" + test->name());
        fs::remove_all(folder_);
        fs::create_directories(folder_);
    }
    ~ProgramTest() override {
        std::error_code ignored;
        fs::permissions(folder_ / "readonly", fs::perms::owner_all, ignored); // left by a failed test
        fs::remove_all(folder_, ignored);
    }
    std::string file(const std::string& name) const { return (folder_ / name).string(); }
    const fs::path& folder() const { return folder_; }

    RunResult run(const std::vector<std::string>& args, const RunOptions& options = {}) const {
        return Child(args, folder_ / "logs", options).wait();
    }
    RunResult runOk(const std::vector<std::string>& args) const {
        RunResult result = run(args);
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        EXPECT_EQ(result.err, "") << describe(result);
        return result;
    }

    // Runs the failure into an empty folder (no file may appear, not even a temporary one) and onto
    // an existing output file (left byte for byte as it was); both must fail the same way.
    void expectFailure(const Failure& failure) const {
        SCOPED_TRACE(::testing::Message() << "shprobe " << joined(failure.args));
        fs::path fresh = folder_ / "fresh_out", existing = folder_ / "existing_out";
        fs::remove_all(fresh);
        fs::remove_all(existing);
        fs::create_directories(fresh);
        fs::create_directories(existing);
        const std::string before = "an earlier good output\n";
        writeText(existing / failure.output, before);
        for (const fs::path& output : {fresh / failure.output, existing / failure.output})
            expectMessage(failure, run(withOutput(failure.args, output.string()),
                                       {.environment = failure.environment}));
        EXPECT_EQ(entriesOf(fresh), std::vector<std::string>{}) << "a failed run left files behind";
        EXPECT_EQ(entriesOf(existing), std::vector<std::string>{failure.output});
        EXPECT_EQ(readText(existing / failure.output), before) << "a failed run changed the existing output";
    }

    // The exit code, and stderr exactly one line "shprobe: error: ..." holding every mention.
    static void expectMessage(const Failure& failure, const RunResult& result) {
        EXPECT_EQ(result.exitCode, failure.exitCode) << describe(result);
        std::vector<std::string> lines = linesOf(result.err);
        EXPECT_EQ(lines.size(), 1u) << "exactly one line expected:\n" << result.err;
        EXPECT_EQ(result.err.rfind("shprobe: error: ", 0), 0u) << result.err;
        EXPECT_TRUE(!result.err.empty() && result.err.back() == '\n') << result.err;
        for (const std::string& part : failure.mentions)
            EXPECT_CONTAINS(result.err, part);
    }

    static std::vector<std::string> withOutput(std::vector<std::string> args, const std::string& output) {
        for (std::string& arg : args)
            if (arg == "OUT") arg = output;
        return args;
    }
    static std::string joined(const std::vector<std::string>& args) {
        std::string text;
        for (const std::string& arg : args)
            text += (text.empty() ? "" : " ") + arg;
        return text;
    }

  private:
    fs::path folder_;
};

} // namespace
} // namespace shprobe
