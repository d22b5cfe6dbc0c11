// What the program reads, asked of the file system in one place: each failure becomes one
// Error(Input) naming the path and the system's reason ("permission denied", "too many levels of
// symbolic links", "file name too long"), never a std::filesystem exception. Readers of whole
// files are bounded: they read regular files (or standard input, "-") of at most a stated size,
// opened without blocking, so that a FIFO, a device or a huge file is refused at once.
#pragma once
#include <cstdint>
#include <string>

namespace shprobe {

// What a path names once its links are followed.
enum class PathKind { Missing, Regular, Folder, Other };

// stat(2) of path: Missing when it (or a folder on the way) does not exist; any other failure
// (a loop of links, a name too long, a folder that may not be searched) throws Error(Input)
// "PATH: REASON".
PathKind inputPathKind(const std::string& path);

// Throws Error(Input) "PATH: REASON" for the errno value `error`, in the system's words
// (strerror, first letter lowered: "permission denied").
[[noreturn]] void throwInputError(const std::string& path, int error);
std::string systemReason(int error);

// A regular, non-empty file that this process may read: opens it (without blocking, so a FIFO
// swapped in cannot hang the run) and closes it again. `what` names what the file should be, for
// the folder case ("an image file" -> "PATH: is a folder, not an image file"). Returns its size.
uint64_t checkInputFile(const std::string& path, const char* what);

// The whole file, or standard input for "-", of at most maxBytes bytes (a larger one is refused
// before it is read, or as soon as standard input passes the limit). Only regular files are
// opened; the rest are refused as checkInputFile does.
std::string readInputFile(const std::string& path, uint64_t maxBytes, const char* what);
// "the file has B bytes, more than WHAT can have (M at most)", readInputFile's refusal.
std::string sizeLimitText(uint64_t bytes, uint64_t maxBytes, const char* what);

} // namespace shprobe
