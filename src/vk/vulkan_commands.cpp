#include "shprobe/vk/vulkan_commands.h"

#include "shprobe/sh/error.h"

#include <dlfcn.h>
#include <mutex>
#include <string>

namespace shprobe {

#define SHPROBE_DEFINE_VULKAN_COMMAND(name) PFN_##name name = nullptr;
SHPROBE_VULKAN_COMMANDS(SHPROBE_DEFINE_VULKAN_COMMAND)
#undef SHPROBE_DEFINE_VULKAN_COMMAND

namespace {

// The loader's soname, as the Vulkan loader's Linux ABI names it and every distribution installs it.
constexpr const char* kVulkanLoader = "libvulkan.so.1";

void loadCommands() {
    // Kept open for the process. A program that links the loader itself gets the same copy back.
    void* loader = dlopen(kVulkanLoader, RTLD_NOW | RTLD_LOCAL);
    if (!loader)
        throw Error(ErrorKind::Device,
                    std::string("no Vulkan loader: ") + dlerror() +
                        "; install libvulkan1 (1.1 or newer), or bake with `--backend cpu`");
        // The loader exports every command of the list as a trampoline that dispatches on its first
        // argument, as the symbols of a program linked to it do.
#define SHPROBE_LOAD_VULKAN_COMMAND(name)                                                                    \
    name = reinterpret_cast<PFN_##name>(dlsym(loader, #name));                                               \
    if (!name)                                                                                               \
        throw Error(ErrorKind::Device,                                                                       \
                    std::string(kVulkanLoader) +                                                             \
                        " has no " #name ": install libvulkan1 1.1 or newer, or bake with `--backend cpu`");
    SHPROBE_VULKAN_COMMANDS(SHPROBE_LOAD_VULKAN_COMMAND)
#undef SHPROBE_LOAD_VULKAN_COMMAND
}

} // namespace

void loadVulkanCommands() {
    static std::once_flag once;
    std::call_once(once, loadCommands);
}

} // namespace shprobe
