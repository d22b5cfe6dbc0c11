#include "io/atomic_file.h"

#include "sh/error.h"

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <mutex>
#include <pthread.h>
#include <random>
#include <set>
#include <thread>
#include <unistd.h>

namespace shprobe {
namespace fs = std::filesystem;

namespace {

// The temporary files of the AtomicFiles alive, for the thread that removes them on an interrupt.
// Created once and never destroyed: that thread may still use it while static objects are
// destroyed at exit. The mutex makes creating, committing and removing a temporary file one step
// that an interrupt sees whole.
struct TemporaryFiles {
    std::mutex mutex;
    std::set<std::string> paths;
};

TemporaryFiles& temporaryFiles() {
    static TemporaryFiles* files = new TemporaryFiles;
    return *files;
}

std::string parentFolder(const std::string& path) {
    fs::path parent = fs::path(path).parent_path();
    return parent.empty() ? std::string(".") : parent.string();
}

// .<name>.<random>.tmp<ext>: hidden, unique, and with the destination's extension last.
std::string temporaryName(const std::string& destination) {
    fs::path path(destination);
    std::random_device random;
    char tag[16];
    std::snprintf(tag, sizeof(tag), "%08x", unsigned(random()));
    std::string name = "." + path.stem().string() + "." + tag + ".tmp" + path.extension().string();
    return (fs::path(parentFolder(destination)) / name).string();
}

[[noreturn]] void failWrite(const std::string& destination, int error) {
    throw Error(ErrorKind::Output, "cannot write " + destination + ": " + std::strerror(error));
}

// A new, empty file at a temporary name no other file has (O_EXCL).
std::string createTemporaryFile(const std::string& destination) {
    for (int attempt = 0;; ++attempt) {
        std::string path = temporaryName(destination);
        int file = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (file >= 0) {
            close(file);
            return path;
        }
        if (errno != EEXIST || attempt == 100) failWrite(destination, errno);
    }
}

// The data reaches the disk before the rename makes it the destination, so that not even a crash
// of the machine can leave a destination that is shorter than what was written.
void flushToDisk(const std::string& path, const std::string& destination) {
    int file = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (file < 0) failWrite(destination, errno);
    int result = fsync(file);
    int error = errno;
    close(file);
    if (result != 0 && error != EINVAL) failWrite(destination, error); // EINVAL: no fsync there
}

void writeAll(int file, std::string_view contents, const std::string& destination) {
    while (!contents.empty()) {
        ssize_t written = write(file, contents.data(), contents.size());
        if (written < 0 && errno == EINTR) continue;
        if (written < 0) {
            int error = errno;
            close(file);
            failWrite(destination, error);
        }
        contents.remove_prefix(size_t(written));
    }
}

const int kInterruptSignals[] = {SIGINT, SIGTERM, SIGHUP};

// Removes the temporary files and ends the process by `signal`. The registry's mutex stays locked:
// no temporary file is created or renamed into place after this point.
[[noreturn]] void endByInterrupt(int signal) {
    TemporaryFiles& files = temporaryFiles();
    files.mutex.lock();
    for (const std::string& path : files.paths) unlink(path.c_str());
    struct sigaction defaultAction {};
    defaultAction.sa_handler = SIG_DFL;
    sigaction(signal, &defaultAction, nullptr);
    sigset_t only;
    sigemptyset(&only);
    sigaddset(&only, signal);
    pthread_sigmask(SIG_UNBLOCK, &only, nullptr);
    raise(signal);
    _exit(128 + signal); // not reached: the default action of these signals ends the process
}

void waitForInterrupt(sigset_t signals) {
    for (;;) {
        int signal = 0;
        if (sigwait(&signals, &signal) == 0) endByInterrupt(signal);
    }
}

} // namespace

void checkOutputPath(const std::string& path) {
    std::string folder = parentFolder(path);
    if (!fs::is_directory(folder))
        throw Error(ErrorKind::Output, "cannot write " + path + ": folder " + folder + " does not exist");
    if (fs::is_directory(path)) throw Error(ErrorKind::Output, "cannot write " + path + ": it is a folder");
    if (access(folder.c_str(), W_OK) != 0)
        throw Error(ErrorKind::Output, "cannot write " + path + ": folder " + folder + " is not writable");
}

AtomicFile::AtomicFile(std::string destination) : destination_(std::move(destination)) {
    checkOutputPath(destination_);
    TemporaryFiles& files = temporaryFiles();
    std::lock_guard lock(files.mutex);
    temporary_ = createTemporaryFile(destination_);
    files.paths.insert(temporary_);
}

AtomicFile::~AtomicFile() {
    if (committed_) return;
    TemporaryFiles& files = temporaryFiles();
    std::lock_guard lock(files.mutex);
    unlink(temporary_.c_str());
    files.paths.erase(temporary_);
}

void AtomicFile::commit() {
    flushToDisk(temporary_, destination_);
    TemporaryFiles& files = temporaryFiles();
    std::lock_guard lock(files.mutex);
    if (std::rename(temporary_.c_str(), destination_.c_str()) != 0) failWrite(destination_, errno);
    committed_ = true;
    files.paths.erase(temporary_);
}

void writeFileAtomic(const std::string& path, std::string_view contents) {
    AtomicFile file(path);
    int out = open(file.temporaryPath().c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (out < 0) failWrite(path, errno);
    writeAll(out, contents, path);
    if (close(out) != 0) failWrite(path, errno);
    file.commit();
}

void removeTemporaryFilesOnInterrupt() {
    sigset_t signals;
    sigemptyset(&signals);
    for (int signal : kInterruptSignals) {
        struct sigaction current {};
        sigaction(signal, nullptr, &current);
        if (current.sa_handler != SIG_IGN) sigaddset(&signals, signal);
    }
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    std::thread(waitForInterrupt, signals).detach();
}

} // namespace shprobe
