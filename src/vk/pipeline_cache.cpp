#include "vk/pipeline_cache.h"

#include "io/atomic_file.h"
#include "sh/error.h"
#include "vk/check.h"

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

namespace shprobe {

namespace {

// The header every pipeline cache's data starts with (VkPipelineCacheHeaderVersionOne).
bool headerMatches(const std::vector<char>& data, const VkPhysicalDeviceProperties& properties) {
    VkPipelineCacheHeaderVersionOne header;
    if (data.size() < sizeof(header)) return false;
    std::memcpy(&header, data.data(), sizeof(header));
    return header.headerVersion == VK_PIPELINE_CACHE_HEADER_VERSION_ONE && header.vendorID == properties.vendorID &&
           header.deviceID == properties.deviceID &&
           std::memcmp(header.pipelineCacheUUID, properties.pipelineCacheUUID, VK_UUID_SIZE) == 0;
}

std::string cacheFolder() {
    if (const char* dir = std::getenv("SHPROBE_CACHE_DIR"); dir && *dir) return dir;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::string(xdg) + "/shprobe";
    if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/shprobe";
    return {};
}

} // namespace

std::string pipelineCachePath(const Context& context) {
    std::string folder = cacheFolder();
    if (folder.empty()) return {};
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(context.physicalDevice, &properties);
    static const char* kHex = "0123456789abcdef";
    std::string uuid;
    for (uint8_t byte : properties.pipelineCacheUUID) {
        uuid += kHex[byte >> 4];
        uuid += kHex[byte & 15];
    }
    return folder + "/pipelines-" + uuid + ".bin";
}

VkPipelineCache loadPipelineCache(const Context& context, const std::string& path) {
    std::vector<char> data;
    if (!path.empty()) {
        std::ifstream file(path, std::ios::binary);
        if (file) data.assign(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
    }
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(context.physicalDevice, &properties);
    if (!headerMatches(data, properties)) data.clear();

    VkPipelineCacheCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO};
    info.initialDataSize = data.size();
    info.pInitialData = data.empty() ? nullptr : data.data();
    VkPipelineCache cache = VK_NULL_HANDLE;
    VK_CHECK(vkCreatePipelineCache(context.device, &info, nullptr, &cache));
    return cache;
}

bool savePipelineCache(const Context& context, VkPipelineCache cache, const std::string& path) {
    if (path.empty() || !cache) return false;
    size_t size = 0;
    if (vkGetPipelineCacheData(context.device, cache, &size, nullptr) != VK_SUCCESS) return false;
    std::string data(size, '\0');
    if (vkGetPipelineCacheData(context.device, cache, &size, data.data()) != VK_SUCCESS) return false;
    data.resize(size);
    std::error_code ignored;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ignored);
    try {
        writeFileAtomic(path, data);
    } catch (const Error&) {
        return false;
    }
    return true;
}

} // namespace shprobe
