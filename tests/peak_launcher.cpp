// peak_launcher FD PROGRAM [ARGS...]: runs PROGRAM as its child, writes the child's peak resident
// memory in KiB (wait4's ru_maxrss) to the open descriptor FD, and exits as the child did (its
// status, or its signal raised again). SIGINT, SIGTERM and SIGHUP are passed on to the child.
//
// The tests run the program through it because Linux counts the resident memory of the process
// that calls exec into the new program's ru_maxrss: a program started straight from a test process
// of 125 MB reports at least 125 MB, whatever it used. This launcher is small when it forks.
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

volatile sig_atomic_t child = 0;
constexpr int kPassedOn[] = {SIGINT, SIGTERM, SIGHUP};

void passOn(int number) {
    if (child > 0) kill(pid_t(child), number);
}

void setHandlers(void (*handler)(int)) {
    struct sigaction action {};
    action.sa_handler = handler;
    sigemptyset(&action.sa_mask);
    for (int number : kPassedOn)
        sigaction(number, &action, nullptr);
}

} // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: peak_launcher FD PROGRAM [ARGS...]\n");
        return 125;
    }
    const int peakFd = std::atoi(argv[1]);
    fcntl(peakFd, F_SETFD, FD_CLOEXEC);
    // Blocked until the child's pid is known, so that a signal sent meanwhile is passed on.
    sigset_t passed, before;
    sigemptyset(&passed);
    for (int number : kPassedOn)
        sigaddset(&passed, number);
    sigprocmask(SIG_BLOCK, &passed, &before);
    setHandlers(passOn);
    const pid_t parent = getpid();
    const pid_t pid = fork();
    if (pid < 0) return 125;
    if (pid == 0) {
        setHandlers(SIG_DFL);
        sigprocmask(SIG_SETMASK, &before, nullptr);
        prctl(PR_SET_PDEATHSIG, SIGKILL); // the test's SIGKILL of this launcher ends the program too
        if (getppid() != parent) _exit(125);
        execv(argv[2], argv + 2);
        _exit(127);
    }
    child = pid;
    sigprocmask(SIG_SETMASK, &before, nullptr);

    int status = 0;
    struct rusage usage {};
    while (wait4(pid, &status, 0, &usage) < 0)
        if (errno != EINTR) return 125;
    dprintf(peakFd, "%ld\n", usage.ru_maxrss);
    close(peakFd);
    if (!WIFSIGNALED(status)) return WEXITSTATUS(status);
    const struct rlimit noCore {};
    setrlimit(RLIMIT_CORE, &noCore);
    setHandlers(SIG_DFL);
    raise(WTERMSIG(status));
    return 128 + WTERMSIG(status);
}
