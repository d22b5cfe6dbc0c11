#include "vk/pipeline_cache.h"

#include "common/error.h"
#include "common/input_file.h"
#include "common/output_file.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sys/stat.h>

namespace shprobe {

namespace {

// The header every pipeline cache's data starts with (VkPipelineCacheHeaderVersionOne).
bool headerMatches(const std::string& data, const VkPhysicalDeviceProperties& properties) {
    VkPipelineCacheHeaderVersionOne header;
    if (data.size() < sizeof(header)) return false;
    std::memcpy(&header, data.data(), sizeof(header));
    return header.headerVersion == VK_PIPELINE_CACHE_HEADER_VERSION_ONE &&
           header.vendorID == properties.vendorID && header.deviceID == properties.deviceID &&
           std::memcmp(header.pipelineCacheUUID, properties.pipelineCacheUUID, VK_UUID_SIZE) == 0;
}

// A cache is only an optimization: what is wrong with it is said once, and the run goes on.
void warnOnce(const std::string& problem) {
    static bool warned = false;
    if (warned) return;
    warned = true;
    std::fprintf(stderr, "shprobe: warning: pipeline cache not used: %s\n", problem.c_str());
}

bool isFolder(const char* path) {
    struct stat status {};
    return stat(path, &status) == 0 && S_ISDIR(status.st_mode);
}

// SHPROBE_CACHE_DIR as given; else $XDG_CACHE_HOME/shprobe where that is an absolute path (the XDG
// Base Directory rule: a relative one is ignored); else $HOME/.cache/shprobe where $HOME is a folder
// that exists, since a cache must never create a missing home. Else "", with one warning.
std::string cacheFolder() {
    if (const char* dir = std::getenv("SHPROBE_CACHE_DIR"); dir && *dir) return dir;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg == '/')
        return std::string(xdg) + "/shprobe";
    const char* home = std::getenv("HOME");
    if (home && *home == '/' && isFolder(home)) return std::string(home) + "/.cache/shprobe";
    const char* xdg = std::getenv("XDG_CACHE_HOME");
    warnOnce(std::string("no folder for it: ") +
             (xdg && *xdg ? "XDG_CACHE_HOME (" + std::string(xdg) + ") is not an absolute path"
                          : "XDG_CACHE_HOME is not set") +
             " and " +
             (home && *home ? "HOME (" + std::string(home) + ") is not a folder" : "HOME is not set") +
             "; set XDG_CACHE_HOME or SHPROBE_CACHE_DIR to keep compiled shaders between runs");
    return {};
}

// Real caches are a few megabytes at most (lavapipe's: a 32-byte header).
constexpr uint64_t kMaxCacheBytes = uint64_t(64) << 20;

// The cache file's data: nothing when there is no file yet (the first run), and nothing, with a
// warning, when the path holds anything but a regular file of at most kMaxCacheBytes (a FIFO
// would block, /dev/zero never end).
std::string readCache(const std::string& path) {
    try {
        if (path.empty() || inputPathKind(path) == PathKind::Missing) return {};
        return readInputFile(path, kMaxCacheBytes, "a pipeline cache");
    } catch (const Error& error) {
        warnOnce(error.what());
        return {};
    }
}

// Only a regular file, or none yet, is (re)written: a link, a device or a FIFO put in its place
// is left alone.
bool isReplaceableFile(const std::string& path) {
    struct stat status {};
    if (lstat(path.c_str(), &status) != 0) return errno == ENOENT;
    return S_ISREG(status.st_mode);
}

// The cache's folder, made where missing; a warning where it cannot be (a file of its name, a
// parent that cannot be written), since every later run would compile its shaders again.
bool makeCacheFolder(const std::string& path) {
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    std::error_code error;
    std::filesystem::create_directories(folder, error);
    if (isFolder(folder.c_str())) return true;
    struct stat status {};
    warnOnce(stat(folder.c_str(), &status) == 0
                 ? folder.string() + " is not a folder"
                 : "cannot make the folder " + folder.string() + " (" + error.message() + ")");
    return false;
}

} // namespace

std::string pipelineCachePath(const Device& device) {
    std::string folder = cacheFolder();
    if (folder.empty()) return {};
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(device.physicalDevice, &properties);
    static const char* kHex = "0123456789abcdef";
    std::string uuid;
    for (uint8_t byte : properties.pipelineCacheUUID) {
        uuid += kHex[byte >> 4];
        uuid += kHex[byte & 15];
    }
    return folder + "/pipelines-" + uuid + ".bin";
}

VkPipelineCache loadPipelineCache(const Device& device, const std::string& path) {
    std::string data = readCache(path);
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(device.physicalDevice, &properties);
    if (!headerMatches(data, properties)) data.clear();

    VkPipelineCacheCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO};
    info.initialDataSize = data.size();
    info.pInitialData = data.empty() ? nullptr : data.data();
    VkPipelineCache cache = VK_NULL_HANDLE;
    if (!data.empty() && vkCreatePipelineCache(device.device, &info, nullptr, &cache) == VK_SUCCESS)
        return cache;
    if (!data.empty()) warnOnce(path + ": the driver refused the cached data");
    info.initialDataSize = 0;
    info.pInitialData = nullptr;
    VK_CHECK(vkCreatePipelineCache(device.device, &info, nullptr, &cache));
    return cache;
}

bool savePipelineCache(const Device& device, VkPipelineCache cache, const std::string& path) {
    if (path.empty() || !cache || !makeCacheFolder(path) || !isReplaceableFile(path)) return false;
    size_t size = 0;
    if (vkGetPipelineCacheData(device.device, cache, &size, nullptr) != VK_SUCCESS) return false;
    std::string data(size, '\0');
    if (vkGetPipelineCacheData(device.device, cache, &size, data.data()) != VK_SUCCESS) return false;
    data.resize(size);
    try {
        writeOutputFile(path, data, OutputContent::Binary);
    } catch (const Error& error) {
        warnOnce(error.what());
        return false;
    }
    return true;
}

} // namespace shprobe
