// checkImageHeader on any bytes, as the file it reads before OpenImageIO opens an image: only
// shprobe::Error may come out, and the header it accepts lies within the file. OpenEXR headers
// are what it is for (the seeds are EXR files and hand-made headers); a PNG signature sends the
// bytes to the PNG chunk scan instead, which is covered the same way.
#include "fuzz_support.h"
#include "image/channels.h"

#include <sys/mman.h>
#include <unistd.h>

using namespace shprobe;

namespace {

// One in-memory file for every input, rewritten each time.
int memoryFile() {
    static int fd = memfd_create("fuzz_exr_header", MFD_CLOEXEC);
    if (fd < 0) fuzz::finding("memfd_create failed");
    return fd;
}

void writeAll(int fd, const uint8_t* data, size_t size) {
    if (ftruncate(fd, 0) != 0) fuzz::finding("ftruncate failed");
    for (size_t done = 0; done < size;) {
        ssize_t n = pwrite(fd, data + done, size - done, off_t(done));
        if (n <= 0) fuzz::finding("pwrite failed");
        done += size_t(n);
    }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    int fd = memoryFile();
    writeAll(fd, data, size);
    fuzz::expectOnlyShprobeErrors("checkImageHeader", [&] {
        uint64_t headerBytes = checkImageHeader(fd, "fuzz.exr");
        if (headerBytes > size)
            fuzz::finding("a header of " + std::to_string(headerBytes) + " bytes in a file of " +
                          std::to_string(size));
    });
    return 0;
}
