#include "common/input_file.h"

#include "common/error.h"

#include <cctype>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

namespace shprobe {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
    throw Error(ErrorKind::Input, path + ": " + problem);
}

// Closes the descriptor on every way out.
struct Descriptor {
    int fd = -1;
    ~Descriptor() {
        if (fd >= 0) close(fd);
    }
};

// Opens a regular file for reading, without blocking, and checks what it is from the open file
// itself (fstat), so nothing can be swapped in between the check and the read.
int openRegular(const std::string& path, const char* what, struct stat& status) {
    int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        if (errno == ENOENT) fail(path, "no such file");
        throwInputError(path, errno);
    }
    if (fstat(fd, &status) != 0) {
        int error = errno;
        close(fd);
        throwInputError(path, error);
    }
    const char* problem = nullptr;
    if (S_ISDIR(status.st_mode))
        problem = "is a folder, not ";
    else if (!S_ISREG(status.st_mode))
        problem = "not a regular file";
    else if (status.st_size == 0)
        problem = "the file is empty";
    if (!problem) return fd;
    close(fd);
    fail(path, S_ISDIR(status.st_mode) ? problem + std::string(what) : std::string(problem));
}

std::string readAll(int fd, const std::string& path, uint64_t maxBytes, const char* what) {
    std::string text;
    char buffer[1 << 16];
    for (;;) {
        ssize_t got = read(fd, buffer, sizeof(buffer));
        if (got < 0 && errno == EINTR) continue;
        if (got < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) { // a non-blocking pipe, empty for now
            struct pollfd ready {
                fd, POLLIN, 0
            };
            poll(&ready, 1, -1);
            continue;
        }
        if (got < 0) throwInputError(path, errno);
        if (got == 0) return text;
        if (text.size() + size_t(got) > maxBytes)
            fail(path, "more than " + std::to_string(maxBytes) + " bytes, more than " + what + " can have");
        text.append(buffer, size_t(got));
    }
}

} // namespace

std::string systemReason(int error) {
    std::string reason = std::strerror(error);
    if (!reason.empty()) reason[0] = char(std::tolower(static_cast<unsigned char>(reason[0])));
    return reason;
}

void throwInputError(const std::string& path, int error) {
    fail(path, systemReason(error));
}

PathKind inputPathKind(const std::string& path) {
    struct stat status {};
    if (stat(path.c_str(), &status) != 0) {
        if (errno == ENOENT || errno == ENOTDIR) return PathKind::Missing;
        throwInputError(path, errno);
    }
    if (S_ISREG(status.st_mode)) return PathKind::Regular;
    if (S_ISDIR(status.st_mode)) return PathKind::Folder;
    return PathKind::Other;
}

uint64_t checkInputFile(const std::string& path, const char* what) {
    struct stat status {};
    Descriptor file{openRegular(path, what, status)};
    return uint64_t(status.st_size);
}

std::string sizeLimitText(uint64_t bytes, uint64_t maxBytes, const char* what) {
    return "the file has " + std::to_string(bytes) + " bytes, more than " + what + " can have (" +
           std::to_string(maxBytes) + " at most)";
}

std::string readInputFile(const std::string& path, uint64_t maxBytes, const char* what) {
    if (path == "-") {
        std::string text = readAll(STDIN_FILENO, "standard input", maxBytes, what);
        if (text.empty()) fail("standard input", "nothing was read (empty input)");
        return text;
    }
    struct stat status {};
    Descriptor file{openRegular(path, what, status)};
    if (uint64_t(status.st_size) > maxBytes)
        fail(path, sizeLimitText(uint64_t(status.st_size), maxBytes, what));
    return readAll(file.fd, path, maxBytes, what);
}

} // namespace shprobe
