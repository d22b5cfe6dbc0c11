// Runs the shprobe program with its stderr on a pseudo-terminal, for the tests of progress lines,
// which are drawn only where isatty(2) holds: stdout goes into a file, and what the program writes
// on the terminal is read while it runs, so that it never blocks on a full terminal.
#pragma once
#include "render/run_program.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <spawn.h>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace shprobe::testing {

struct TerminalRun {
    int exitCode = -1;
    std::string terminal; // all the program wrote on stderr
    double seconds = 0.0;
};

inline TerminalRun runOnTerminal(const std::vector<std::string>& args,
                                 const std::filesystem::path& stdoutPath) {
    TerminalRun result;
    const int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) {
        ADD_FAILURE() << "cannot open a pseudo-terminal: " << std::strerror(errno);
        return result;
    }
    const int terminal = open(ptsname(master), O_RDWR | O_NOCTTY);
    std::vector<std::string> argStrings{SHPROBE_EXECUTABLE};
    argStrings.insert(argStrings.end(), args.begin(), args.end());
    std::vector<std::string> envStrings = changedEnvironment({});
    std::vector<char*> argv = pointersTo(argStrings), envp = pointersTo(envStrings);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, stdoutPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, terminal, 2);
    const auto start = std::chrono::steady_clock::now();
    pid_t pid = 0;
    const int spawnError = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    close(terminal);
    if (spawnError != 0) {
        ADD_FAILURE() << "cannot start " << argv[0] << ": " << std::strerror(spawnError);
        close(master);
        return result;
    }
    fcntl(master, F_SETFL, O_NONBLOCK);
    char buffer[4096];
    int status = 0;
    for (bool running = true; running;) {
        running = waitpid(pid, &status, WNOHANG) == 0;
        for (ssize_t n; (n = read(master, buffer, sizeof buffer)) > 0;)
            result.terminal.append(buffer, size_t(n));
        if (running) usleep(20000);
    }
    close(master);
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return result;
}

// How many times the terminal text draws a line that starts with `start` ("\rprobes ").
inline size_t drawsOf(const std::string& terminal, const std::string& start) {
    size_t draws = 0;
    for (size_t at = terminal.find(start); at != std::string::npos; at = terminal.find(start, at + 1))
        ++draws;
    return draws;
}

} // namespace shprobe::testing
