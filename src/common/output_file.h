// Every file the program writes goes through OutputFile, which decides from what the destination
// is how it is written, and checks every step (each write, fsync, close, rename):
//   - a regular file, or a name not taken yet: the data goes to a hidden temporary file in the same
//     folder (same file system, so the rename is atomic), flushed to the disk and renamed over the
//     destination: it appears whole or not at all, and an earlier file stays until then;
//   - a symbolic link: followed to its final target (which need not exist yet), and that target is
//     replaced as above, in the target's folder; the link itself stays;
//   - a character device or a FIFO (/dev/null, a named pipe), "-" (standard output) and the
//     process's own descriptors (/dev/stdout, /dev/fd/N): written through as a stream;
//   - anything else (a folder, a socket, a block device) is refused, and never replaced.
// Failures are Error(Output) "cannot write PATH: REASON" (exit code 3).
#pragma once
#include <cstdio>
#include <span>
#include <string>
#include <string_view>

namespace shprobe {

// Binary content is refused when the destination is a terminal.
enum class OutputContent { Text, Binary };

// Checks the destination as OutputFile would find it (its folder exists and may be written, the
// name fits, it is nothing that cannot be written), so that a run can refuse before any work.
void checkOutputPath(const std::string& path, OutputContent content = OutputContent::Text);

// Refuses (Error(Output), before any work) an output that is one of the inputs, after links, as
// files: the input would be lost. "-" is standard input among the inputs and standard output among
// the outputs, so that an output opened on the file standard input reads is refused too. Each path
// is looked at once.
void checkOutputsAreNotInputs(std::span<const std::string> outputs, std::span<const std::string> inputs);

// Opens the standard descriptors (0-2) the process was started without on /dev/null, so that no file
// the program opens takes their place, and remembers them: an output sent to one of them ("-" with
// standard output closed) is refused rather than written into /dev/null.
void openClosedStandardDescriptors();

// Whether path is standard output ("-", /dev/stdout, /dev/fd/1): a command writing its data there
// prints its report on stderr instead (reportStream).
bool isStandardOutput(const std::string& path);
inline FILE* reportStream(const std::string& output) {
    return isStandardOutput(output) ? stderr : stdout;
}

class OutputFile {
  public:
    // Checks the destination; for a file, creates the temporary file (empty, a name no other file
    // has, never longer than a name the folder takes); for a stream, opens it (a FIFO waits here
    // for its reader). Throws Error(Output) naming the destination.
    explicit OutputFile(std::string destination, OutputContent content = OutputContent::Text);
    ~OutputFile(); // not committed: removes the temporary file
    OutputFile(const OutputFile&) = delete;
    OutputFile& operator=(const OutputFile&) = delete;

    void write(std::string_view bytes);
    // Flushes the temporary file to the disk and renames it over the destination, or closes the
    // stream; throws Error(Output) on failure (the destination is then as it was).
    void commit();

    // The temporary file (empty for a stream).
    const std::string& temporaryPath() const { return temporary_; }

  private:
    std::string destination_;
    std::string target_;    // the file replaced: the destination, or its link's final target
    std::string temporary_; // empty for a stream
    int descriptor_ = -1;
    bool committed_ = false;
};

// Writes contents to path through an OutputFile.
void writeOutputFile(const std::string& path, std::string_view contents,
                     OutputContent content = OutputContent::Text);

// A file in memory for the libraries that write to a file name themselves (OpenImageIO): they
// write here, and the bytes then go to the destination through OutputFile. Not every library
// reports a full disk (OpenImageIO 2.4's PNG writer returns success after short writes), so the
// program makes the writes to the disk itself, and checks each.
class MemoryFile {
  public:
    MemoryFile();
    ~MemoryFile();
    MemoryFile(const MemoryFile&) = delete;
    MemoryFile& operator=(const MemoryFile&) = delete;

    // A name that opens this file (/proc/self/fd/N).
    const std::string& path() const { return path_; }
    std::string contents() const;

  private:
    int descriptor_ = -1;
    std::string path_;
};

// Ctrl-C (SIGINT), SIGTERM and SIGHUP end the program at once, whatever it is doing (a GPU wait
// included), after removing the temporary file of every OutputFile still open: no partial file is
// left and an existing destination is untouched. The process then ends by the same signal, so
// its parent sees it killed by SIGINT (a shell reports exit status 130, 143 for SIGTERM, 129 for
// SIGHUP). Signals ignored when the program started (nohup, background jobs) stay ignored.
// Call once, first thing in main, before any other thread exists: the signals are blocked in the
// calling thread and every thread it starts later, and one thread waits for them.
void removeTemporaryFilesOnInterrupt();

} // namespace shprobe
