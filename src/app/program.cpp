#include "app/program.h"

#include "shprobe/io/output_file.h"
#include "shprobe/sh/error.h"
#include "shprobe/version.h"

#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fcntl.h>
#include <string>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace shprobe {

namespace {

int exitCode(ErrorKind kind) {
    switch (kind) {
    case ErrorKind::Input:
        return 2;
    case ErrorKind::Output:
        return 3;
    case ErrorKind::Device:
        return 4;
    }
    return 1;
}

// An error is one line; a library's message may hold several.
std::string oneLine(std::string text) {
    while (!text.empty() && text.back() == '\n')
        text.pop_back();
    for (char& c : text)
        if (c == '\n') c = ' ';
    return text;
}

// Descriptors 0-2 that the parent closed are opened on /dev/null, so that no file the program
// opens takes their place (a probe file read as standard input, an output sent to standard
// output). A reader that goes away makes a write fail with EPIPE ("cannot write -: broken pipe",
// exit 3) instead of ending the program by SIGPIPE without a word.
void prepareStandardStreams() {
    for (int fd = 0; fd <= 2; ++fd)
        if (fcntl(fd, F_GETFD) < 0) open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY);
    std::signal(SIGPIPE, SIG_IGN);
}

// A bake allocates its large buffers (the decoded image, OpenEXR's chunk buffers) once per input
// and touches every page of them, and each first touch of a fresh 4 KiB page is a fault: about
// 3.4 us on the 2-core CI VM, and a bake of courtyard.exr took 4,220 of them (14 ms of its 41).
// glibc's defaults also give such buffers back to the kernel when freed (mmap and munmap above a
// threshold that a same-size request then still exceeds), so a batch faults on every input again.
// Here the program keeps freed memory for reuse, all threads allocate from the main heap, and the
// first 64 MiB of that heap are advised as transparent huge pages (where the kernel offers them
// on request, as Debian's does), so that a first touch costs one fault per 2 MiB: what glibc's
// tunable glibc.malloc.hugetlb=1 does, which only the environment can set. docs/benchmark.md,
// "Memory faults", has the counts and times. Other C libraries keep their defaults.
void prepareHeap() {
#if defined(__GLIBC__)
    constexpr size_t kMiB = size_t(1) << 20;
    constexpr uintptr_t kHugePage = 2 * kMiB;
    constexpr size_t kAdvised = 64 * kMiB;
    mallopt(M_MMAP_THRESHOLD, int(32 * kMiB)); // the largest glibc accepts: larger images stay mmap'ed
    mallopt(M_TRIM_THRESHOLD, int(512 * kMiB));
    mallopt(M_ARENA_MAX, 1);
    mallopt(M_TOP_PAD, int(kAdvised));
    // The heap grows by the request and the pad: madvise that part of it, if it is where the break
    // says (not, for one, under a sanitizer's allocator, or where the break could not move).
    void* grown = std::malloc(kHugePage);
    const uintptr_t end = reinterpret_cast<uintptr_t>(sbrk(0)) & ~(kHugePage - 1);
    const uintptr_t begin = (reinterpret_cast<uintptr_t>(grown) + kHugePage - 1) & ~(kHugePage - 1);
    if (grown && begin < end && end - begin <= kAdvised + 2 * kHugePage)
        madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
    std::free(grown);
    mallopt(M_TOP_PAD, int(kMiB));
#endif
}

} // namespace

void addVersionFlag(CLI::App& app, const char* program) {
    app.add_flag_callback(
        "--version",
        [program] {
            std::printf("%s %s\n", program, SHPROBE_VERSION_STRING);
            throw CLI::Success();
        },
        "Print the version and exit");
}

int runProgram(CLI::App& app, const char* name, int argc, char** argv, const std::function<void()>& run) {
    prepareStandardStreams();
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e); // --help, --version
        std::fprintf(stderr, "%s: error: %s (see --help)\n", name, oneLine(e.what()).c_str());
        return 2;
    }

    // Only once a command runs: parsing writes no file, and the handler's thread is a tenth of
    // what `shprobe --help` took (0.1-0.2 ms of 1.5-2.0).
    removeTemporaryFilesOnInterrupt(); // Ctrl-C: exit at once, no partial files
    prepareHeap();
    try {
        run();
    } catch (const Error& e) {
        std::fprintf(stderr, "%s: error: %s\n", name, oneLine(e.what()).c_str());
        return exitCode(e.kind());
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "%s: error: out of memory\n", name);
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: internal error: %s\n", name, oneLine(e.what()).c_str());
        return 1;
    }
    return 0;
}

} // namespace shprobe
