// Output files appear whole or not at all: data goes to a temporary file in the destination's
// folder (same file system, so rename is atomic), which replaces the destination on commit().
#pragma once
#include <string>
#include <string_view>

namespace shprobe {

class AtomicFile {
public:
    // Checks that the destination's folder exists and is writable; throws Error(Output) if not.
    explicit AtomicFile(std::string destination);
    ~AtomicFile(); // removes the temporary file unless committed
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    // Where to write. It keeps the destination's extension, so writers that choose the format
    // from the name (OpenImageIO) pick the right one.
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

// Writes contents to path atomically; throws Error(Output) naming the file on failure.
void writeFileAtomic(const std::string& path, std::string_view contents);

} // namespace shprobe
