// Output files appear whole or not at all: data goes to a temporary file in the destination's
// folder (same file system, so rename is atomic), which replaces the destination on commit().
// Every file the program writes goes through here: probe files, binary probes, images.
#pragma once
#include <string>
#include <string_view>

namespace shprobe {

class AtomicFile {
public:
    // Checks that the destination's folder exists and is writable, then creates the temporary
    // file (empty, a name no other file has); throws Error(Output) naming the destination if not.
    explicit AtomicFile(std::string destination);
    ~AtomicFile(); // removes the temporary file unless committed
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    // Where to write (open it for writing and truncate it). It keeps the destination's extension,
    // so writers that choose the format from the name (OpenImageIO) pick the right one.
    const std::string& temporaryPath() const { return temporary_; }
    // Renames the temporary file over the destination; throws Error(Output) on failure.
    void commit();

private:
    std::string destination_;
    std::string temporary_;
    bool committed_ = false;
};

// Throws Error(Output) if path could not be written (missing or read-only folder, a folder
// itself), so a run can refuse before doing any work.
void checkOutputPath(const std::string& path);

// Writes contents to path atomically (flushed to the disk before the rename); throws Error(Output)
// naming the file on failure.
void writeFileAtomic(const std::string& path, std::string_view contents);

// Ctrl-C (SIGINT), SIGTERM and SIGHUP end the program at once, whatever it is doing (a GPU wait
// included), after removing the temporary file of every AtomicFile still open: no partial file is
// left and an existing destination is untouched. The process then ends by the same signal, so
// its parent sees it killed by SIGINT (a shell reports exit status 130, 143 for SIGTERM, 129 for
// SIGHUP). Signals ignored when the program started (nohup, background jobs) stay ignored.
// Call once, first thing in main, before any other thread exists: the signals are blocked in the
// calling thread and every thread it starts later, and one thread waits for them.
void removeTemporaryFilesOnInterrupt();

} // namespace shprobe
