#include "common/output_file.h"

#include "common/error.h"
#include "common/input_file.h"

#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <map>
#include <mutex>
#include <optional>
#include <poll.h>
#include <pthread.h>
#include <random>
#include <set>
#include <sys/mman.h>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>

namespace shprobe {

namespace {

// The temporary files of the OutputFiles alive, for the thread that removes them on an interrupt.
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

[[noreturn]] void failWrite(const std::string& destination, const std::string& why) {
    throw Error(ErrorKind::Output, "cannot write " + destination + ": " + why);
}

[[noreturn]] void failWriteErrno(const std::string& destination, int error) {
    failWrite(destination, systemReason(error));
}

// The folder and the name of a path, as written: "a/b.json" -> "a", "b.json"; "b.json" -> ".".
std::string folderOf(const std::string& path) {
    size_t slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    return slash == 0 ? "/" : path.substr(0, slash);
}

std::string nameOf(const std::string& path) {
    size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

// Where the data of a destination goes.
struct OutputTarget {
    enum Kind { File, Stream, Descriptor } kind = File;
    std::string path; // File: the file to replace (the link's final target); Stream: the node
    int descriptor = -1;
};

// Links are followed one at a time, like the kernel does, to at most this many (Linux's limit).
constexpr int kMaxLinks = 40;

// The standard descriptors the process was started without (openClosedStandardDescriptors).
bool closedAtStart[3] = {false, false, false};

// The descriptor an output goes to, refused when the process was started without it.
int startedDescriptor(const std::string& destination, int descriptor) {
    if (descriptor <= 2 && closedAtStart[descriptor])
        failWrite(destination,
                  "descriptor " + std::to_string(descriptor) + " was closed when shprobe started");
    return descriptor;
}

// The descriptor N when folder/name is /proc/self/fd/N (or /dev/fd/N): a descriptor of this process.
int ownDescriptor(const std::string& folder, const std::string& name) {
    char* real = realpath(folder.c_str(), nullptr);
    if (!real) return -1;
    std::string resolved = real;
    std::free(real);
    if (resolved != "/proc/self/fd" && resolved != "/proc/" + std::to_string(getpid()) + "/fd") return -1;
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos || name.size() > 6)
        return -1;
    return std::stoi(name);
}

// The kernel's rule for links in sticky, world-writable folders (/tmp; Linux's
// fs.protected_symlinks): such a link is followed only when its owner is the follower or the
// folder's owner, so that nobody can plant /tmp/probe.json -> /etc/passwd for root to replace.
// The links are followed here by hand, so the rule is applied here too.
bool mayFollowLink(const std::string& folder, const struct stat& link) {
    struct stat status {};
    if (stat(folder.c_str(), &status) != 0) return false;
    const bool shared = (status.st_mode & S_ISVTX) && (status.st_mode & S_IWOTH);
    return !shared || link.st_uid == geteuid() || link.st_uid == status.st_uid;
}

// The folder a new or replaced file goes into must exist and be writable.
void checkFolder(const std::string& destination, const std::string& folder) {
    struct stat status {};
    if (stat(folder.c_str(), &status) != 0) {
        if (errno == ENOENT) failWrite(destination, "folder " + folder + " does not exist");
        failWriteErrno(destination, errno);
    }
    if (!S_ISDIR(status.st_mode)) failWrite(destination, folder + " is not a folder");
    if (status.st_nlink == 0)
        failWrite(destination, "folder " + folder + " was removed"); // a removed working folder
    if (access(folder.c_str(), W_OK) != 0) failWrite(destination, "folder " + folder + " is not writable");
}

OutputTarget resolveTarget(const std::string& destination) {
    if (destination == "-") return {OutputTarget::Descriptor, "", startedDescriptor("-", STDOUT_FILENO)};
    if (destination.empty()) failWrite("''", "no file name given");
    std::string path = destination;
    for (int links = 0; links <= kMaxLinks; ++links) {
        const std::string folder = folderOf(path), name = nameOf(path);
        if (name.empty() || name == "." || name == "..")
            failWrite(destination, "it names a folder, not a file (a file's name does not end in / . or ..)");
        if (name.size() > NAME_MAX) failWriteErrno(destination, ENAMETOOLONG);
        struct stat status {};
        if (lstat(path.c_str(), &status) != 0) {
            if (errno != ENOENT) failWriteErrno(destination, errno);
            checkFolder(destination, folder);
            return {OutputTarget::File, path};
        }
        if (S_ISLNK(status.st_mode)) {
            if (int descriptor = ownDescriptor(folder, name); descriptor >= 0)
                return {OutputTarget::Descriptor, path, startedDescriptor(destination, descriptor)};
            if (!mayFollowLink(folder, status))
                failWrite(destination,
                          "permission denied (a link in a shared sticky folder owned by another user)");
            char target[PATH_MAX];
            ssize_t length = readlink(path.c_str(), target, sizeof(target) - 1);
            if (length < 0) failWriteErrno(destination, errno);
            std::string next(target, size_t(length));
            path = next.starts_with('/') ? next : folder + "/" + next;
            continue;
        }
        if (S_ISREG(status.st_mode)) {
            checkFolder(destination, folder);
            // Replacing is renaming, which the folder allows; a file the user may not write is left
            // alone all the same, as a shell's > would.
            if (access(path.c_str(), W_OK) != 0) failWriteErrno(destination, errno);
            return {OutputTarget::File, path};
        }
        if (S_ISDIR(status.st_mode)) failWrite(destination, "it is a folder");
        if (S_ISCHR(status.st_mode) || S_ISFIFO(status.st_mode)) {
            if (access(path.c_str(), W_OK) != 0) failWriteErrno(destination, errno);
            return {OutputTarget::Stream, path};
        }
        failWrite(destination, "not a regular file, character device or FIFO; nothing is written there");
    }
    failWriteErrno(destination, ELOOP);
}

// A terminal is no place for binary data. A FIFO is not opened here: that waits for its reader.
void checkStreamTakes(const std::string& destination, const OutputTarget& target, OutputContent content) {
    if (target.kind == OutputTarget::Descriptor) {
        int flags = fcntl(target.descriptor, F_GETFL);
        if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY)
            failWrite(destination,
                      "descriptor " + std::to_string(target.descriptor) + " is not open for writing");
        if (content == OutputContent::Binary && isatty(target.descriptor))
            failWrite(destination, "it is a terminal; binary output goes to a file or a pipe");
        return;
    }
    if (target.kind != OutputTarget::Stream || content != OutputContent::Binary) return;
    struct stat status {};
    if (stat(target.path.c_str(), &status) != 0 || !S_ISCHR(status.st_mode)) return;
    int fd = open(target.path.c_str(), O_WRONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    bool terminal = fd >= 0 && isatty(fd);
    if (fd >= 0) close(fd);
    if (terminal) failWrite(destination, "it is a terminal; binary output goes to a file or a pipe");
}

OutputTarget checkedTarget(const std::string& destination, OutputContent content) {
    OutputTarget target = resolveTarget(destination);
    checkStreamTakes(destination, target, content);
    return target;
}

// .<name>.<random>.tmp<ext>: hidden, unique, with the destination's extension last, and no longer
// than the longest name a folder takes (the name is shortened, never the folder's limit exceeded).
std::string temporaryName(const std::string& target) {
    std::string name = nameOf(target);
    size_t dot = name.find_last_of('.');
    std::string stem = dot == std::string::npos || dot == 0 ? name : name.substr(0, dot);
    std::string extension = stem.size() == name.size() ? "" : name.substr(stem.size());
    std::random_device random;
    char tag[16];
    std::snprintf(tag, sizeof(tag), ".%08x.tmp", unsigned(random()));
    const size_t fixed = 1 + std::string(tag).size();
    // The folder's own limit (143 bytes on eCryptfs, 255 on most file systems).
    long folderLimit = pathconf(folderOf(target).c_str(), _PC_NAME_MAX);
    const size_t limit = folderLimit > long(fixed) ? size_t(folderLimit) : size_t(NAME_MAX);
    if (fixed + extension.size() > limit) extension.clear();
    if (stem.size() > limit - fixed - extension.size()) {
        stem.resize(limit - fixed - extension.size());
        // Cut at a character: file systems that check UTF-8 refuse half a character.
        while (!stem.empty() && (static_cast<unsigned char>(stem.back()) & 0xC0) == 0x80)
            stem.pop_back();
        if (!stem.empty() && static_cast<unsigned char>(stem.back()) >= 0xC0) stem.pop_back();
    }
    return folderOf(target) + "/." + stem + tag + extension;
}

// A new, empty file at a temporary name no other file has (O_EXCL), kept open for writing.
std::pair<std::string, int> createTemporaryFile(const std::string& destination, const std::string& target) {
    for (int attempt = 0;; ++attempt) {
        std::string path = temporaryName(target);
        int file = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (file >= 0) return {path, file};
        if (errno != EEXIST || attempt == 100) failWriteErrno(destination, errno);
    }
}

int openStream(const std::string& destination, const OutputTarget& target) {
    int fd = target.kind == OutputTarget::Descriptor
                 ? fcntl(target.descriptor, F_DUPFD_CLOEXEC, 3)
                 : open(target.path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) failWriteErrno(destination, errno);
    return fd;
}

// The rename itself reaches the disk with the folder's entry: after a crash the new file is there,
// not the old one. Best effort: a folder that cannot be opened or synced is left as it is.
void syncFolder(const std::string& folder) {
    int fd = open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    fsync(fd);
    close(fd);
}

const int kInterruptSignals[] = {SIGINT, SIGTERM, SIGHUP};

// Removes the temporary files and ends the process by `signal`. The registry's mutex stays locked:
// no temporary file is created or renamed into place after this point.
[[noreturn]] void endByInterrupt(int signal) {
    TemporaryFiles& files = temporaryFiles();
    files.mutex.lock();
    for (const std::string& path : files.paths)
        unlink(path.c_str());
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

void checkOutputPath(const std::string& path, OutputContent content) {
    checkedTarget(path, content);
}

void openClosedStandardDescriptors() {
    for (int fd = 0; fd <= 2; ++fd) {
        if (fcntl(fd, F_GETFD) >= 0) continue;
        closedAtStart[fd] = true;
        open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY);
    }
}

namespace {

// The regular file a name stands for ("-": the standard stream `standard`), if it is one.
std::optional<std::pair<dev_t, ino_t>> regularFileOf(const std::string& path, int standard) {
    struct stat status {};
    const int result = path == "-" ? fstat(standard, &status) : stat(path.c_str(), &status);
    if (result != 0 || !S_ISREG(status.st_mode)) return std::nullopt;
    return std::pair(status.st_dev, status.st_ino);
}

} // namespace

void checkOutputsAreNotInputs(std::span<const std::string> outputs, std::span<const std::string> inputs) {
    std::map<std::pair<dev_t, ino_t>, const std::string*> inputFiles;
    for (const std::string& input : inputs)
        if (auto file = regularFileOf(input, STDIN_FILENO)) inputFiles.emplace(*file, &input);
    for (const std::string& output : outputs) {
        const auto file = regularFileOf(output, STDOUT_FILENO);
        if (!file) continue;
        auto input = inputFiles.find(*file);
        if (input != inputFiles.end())
            failWrite(output, "it is the input " + *input->second + "; name another output");
    }
}

bool isStandardOutput(const std::string& path) {
    try {
        OutputTarget target = resolveTarget(path);
        return target.kind == OutputTarget::Descriptor && target.descriptor == STDOUT_FILENO;
    } catch (const Error&) {
        return false;
    }
}

OutputFile::OutputFile(std::string destination, OutputContent content)
    : destination_(std::move(destination)) {
    OutputTarget target = checkedTarget(destination_, content);
    if (target.kind != OutputTarget::File) {
        descriptor_ = openStream(destination_, target);
        return;
    }
    target_ = target.path;
    TemporaryFiles& files = temporaryFiles();
    std::lock_guard lock(files.mutex);
    std::tie(temporary_, descriptor_) = createTemporaryFile(destination_, target_);
    files.paths.insert(temporary_);
}

OutputFile::~OutputFile() {
    if (descriptor_ >= 0) close(descriptor_);
    if (committed_ || temporary_.empty()) return;
    TemporaryFiles& files = temporaryFiles();
    std::lock_guard lock(files.mutex);
    unlink(temporary_.c_str());
    files.paths.erase(temporary_);
}

void OutputFile::write(std::string_view bytes) {
    while (!bytes.empty()) {
        ssize_t written = ::write(descriptor_, bytes.data(), bytes.size());
        if (written < 0 && errno == EINTR) continue;
        if (written < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) { // a non-blocking pipe is full
            struct pollfd ready {
                descriptor_, POLLOUT, 0
            };
            poll(&ready, 1, -1);
            continue;
        }
        if (written < 0) failWriteErrno(destination_, errno);
        if (written == 0) failWriteErrno(destination_, ENOSPC);
        bytes.remove_prefix(size_t(written));
    }
}

void OutputFile::commit() {
    // The data reaches the disk before the rename makes it the destination, so that not even a
    // crash of the machine can leave a destination shorter than what was written. Streams have
    // nothing to flush (pipes and devices answer fsync with EINVAL).
    if (!temporary_.empty() && fsync(descriptor_) != 0 && errno != EINVAL)
        failWriteErrno(destination_, errno);
    // A replaced file keeps its permissions (a private file stays private).
    struct stat replaced {};
    if (!temporary_.empty() && stat(target_.c_str(), &replaced) == 0)
        fchmod(descriptor_, replaced.st_mode & 07777);
    int descriptor = descriptor_;
    descriptor_ = -1;
    if (close(descriptor) != 0 && errno != EINTR) failWriteErrno(destination_, errno);
    if (temporary_.empty()) {
        committed_ = true;
        return;
    }
    TemporaryFiles& files = temporaryFiles();
    std::lock_guard lock(files.mutex);
    if (std::rename(temporary_.c_str(), target_.c_str()) != 0) failWriteErrno(destination_, errno);
    committed_ = true;
    files.paths.erase(temporary_);
    syncFolder(folderOf(target_));
}

void writeOutputFile(const std::string& path, std::string_view contents, OutputContent content) {
    OutputFile file(path, content);
    file.write(contents);
    file.commit();
}

MemoryFile::MemoryFile() {
    descriptor_ = memfd_create("shprobe-output", MFD_CLOEXEC);
    if (descriptor_ < 0)
        throw Error(ErrorKind::Output,
                    "cannot make an in-memory file for the output: " + systemReason(errno));
    path_ = "/proc/self/fd/" + std::to_string(descriptor_);
}

MemoryFile::~MemoryFile() {
    close(descriptor_);
}

std::string MemoryFile::contents() const {
    std::string bytes;
    char buffer[1 << 16];
    ssize_t got = 0;
    for (off_t at = 0; (got = pread(descriptor_, buffer, sizeof(buffer), at)) > 0; at += got)
        bytes.append(buffer, size_t(got));
    if (got < 0) throw Error(ErrorKind::Output, "cannot read the in-memory output: " + systemReason(errno));
    return bytes;
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
