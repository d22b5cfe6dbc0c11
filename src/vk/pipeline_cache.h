// A VkPipelineCache kept on disk between runs, so that a second run does not compile the shaders
// again (lavapipe compiles every pipeline with LLVM).
#pragma once
#include "vk/context.h"

#include <string>

namespace shprobe {

// The cache file for this device: $SHPROBE_CACHE_DIR, else $XDG_CACHE_HOME/shprobe (an absolute
// path), else $HOME/.cache/shprobe (HOME an existing folder: a missing home is never created), then
// "pipelines-<pipelineCacheUUID>.bin". Empty, after one warning line on stderr, when none can be
// used (no cache on disk then).
std::string pipelineCachePath(const Device& device);

// A cache holding the file's data when it was written for this device (same vendor, device and
// pipelineCacheUUID in its header, Vulkan spec "Pipeline Cache Header"); empty otherwise, or when
// the file is missing or unreadable: a cache is only ever an optimization.
VkPipelineCache loadPipelineCache(const Device& device, const std::string& path);

// Writes the cache's data to path atomically (temporary file, then rename). Returns false, after
// creating the folder failed or writing failed, without throwing: a run does not fail for its cache.
bool savePipelineCache(const Device& device, VkPipelineCache cache, const std::string& path);

} // namespace shprobe
