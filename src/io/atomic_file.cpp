#include "io/atomic_file.h"

#include "sh/error.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <unistd.h>

namespace shprobe {
namespace fs = std::filesystem;

namespace {

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
    temporary_ = temporaryName(destination_);
}

AtomicFile::~AtomicFile() {
    if (!committed_) std::remove(temporary_.c_str());
}

void AtomicFile::commit() {
    if (std::rename(temporary_.c_str(), destination_.c_str()) != 0)
        throw Error(ErrorKind::Output, "cannot write " + destination_ + ": " + std::strerror(errno));
    committed_ = true;
}

void writeFileAtomic(const std::string& path, std::string_view contents) {
    AtomicFile file(path);
    {
        std::ofstream out(file.temporaryPath(), std::ios::binary | std::ios::trunc);
        out.write(contents.data(), std::streamsize(contents.size()));
        out.flush();
        if (!out)
            throw Error(ErrorKind::Output, "cannot write " + path + ": " + std::strerror(errno));
    }
    file.commit();
}

} // namespace shprobe
