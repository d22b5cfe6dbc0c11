// Runs the shprobe program as a child (posix_spawn with an argv array: no shell parses a path),
// stdout and stderr captured through files, the environment ours with some variables changed. The
// program runs under tests/peak_launcher.cpp, which reports its own peak memory.
#pragma once
#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <spawn.h>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

extern char** environ;

namespace shprobe::testing {

struct RunResult {
    int exitCode = -1; // the exit status, or 128 + signal
    std::string out;
    std::string err;
    long peakKiB = 0; // the program's peak resident memory (ru_maxrss, as peak_launcher saw it)
};

// The program and its arguments, under peak_launcher, which writes the program's peak to its
// descriptor 3.
inline std::vector<std::string> launchedProgram(const std::vector<std::string>& args) {
    std::vector<std::string> argStrings{SHPROBE_PEAK_LAUNCHER, "3", SHPROBE_EXECUTABLE};
    argStrings.insert(argStrings.end(), args.begin(), args.end());
    return argStrings;
}

inline long peakKiBIn(const std::filesystem::path& path) {
    std::ifstream in(path);
    long kib = 0;
    if (!(in >> kib)) ADD_FAILURE() << "peak_launcher wrote no peak to " << path;
    return kib;
}

// A value sets the variable, nullopt removes it.
using EnvironmentChanges = std::map<std::string, std::optional<std::string>>;

inline std::string readText(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

inline std::vector<char*> pointersTo(std::vector<std::string>& strings) {
    std::vector<char*> pointers;
    for (std::string& text : strings)
        pointers.push_back(text.data());
    pointers.push_back(nullptr);
    return pointers;
}

inline std::vector<std::string> changedEnvironment(const EnvironmentChanges& changes) {
    std::vector<std::string> variables;
    for (char** entry = environ; *entry; ++entry) {
        std::string variable(*entry);
        if (!changes.count(variable.substr(0, variable.find('=')))) variables.push_back(variable);
    }
    for (const auto& [name, value] : changes)
        if (value) variables.push_back(name + "=" + *value);
    return variables;
}

inline RunResult runProgram(const std::vector<std::string>& args, const std::filesystem::path& logFolder,
                            const EnvironmentChanges& changes = {}) {
    static int runs = 0;
    std::filesystem::create_directories(logFolder);
    std::filesystem::path outPath = logFolder / ("run" + std::to_string(++runs) + ".stdout");
    std::filesystem::path errPath = logFolder / ("run" + std::to_string(runs) + ".stderr");
    std::filesystem::path peakPath = logFolder / ("run" + std::to_string(runs) + ".peak");
    std::vector<std::string> argStrings = launchedProgram(args);
    std::vector<std::string> envStrings = changedEnvironment(changes);
    std::vector<char*> argv = pointersTo(argStrings), envp = pointersTo(envStrings);

    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, outPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, errPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 3, peakPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = 0;
    int spawnError = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    RunResult result;
    if (spawnError != 0) {
        ADD_FAILURE() << "cannot start " << argv[0] << ": " << std::strerror(spawnError);
        return result;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) {
            ADD_FAILURE() << "waitpid failed: " << std::strerror(errno);
            return result;
        }
    result.peakKiB = peakKiBIn(peakPath);
    result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    result.out = readText(outPath);
    result.err = readText(errPath);
    return result;
}

inline std::string describe(const RunResult& run) {
    return "exit " + std::to_string(run.exitCode) + "\n--- stdout:\n" + run.out + "--- stderr:\n" + run.err;
}

// A fresh folder under the system's temporary one, removed by the destructor.
class TemporaryFolder {
  public:
    explicit TemporaryFolder(const std::string& name)
        : path_(std::filesystem::temp_directory_path() / (name + "_" + std::to_string(getpid()))) {
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~TemporaryFolder() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    const std::filesystem::path& path() const { return path_; }
    std::string operator/(const std::string& name) const { return (path_ / name).string(); }

  private:
    std::filesystem::path path_;
};

} // namespace shprobe::testing
