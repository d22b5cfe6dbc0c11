#include "vk/vulkan_commands.h"

#include "common/error.h"

#include <atomic>
#include <dlfcn.h>
#include <mutex>
#include <string>

namespace shprobe {

// Until the commands are loaded each pointer holds a function that loads them and then makes its call,
// so that a command called first, on handles made elsewhere (an engine's own Device, a helper of
// vk/image.h on its command buffer), finds the loader as a linked program would.
#define SHPROBE_DEFINE_VULKAN_COMMAND(name)                                                                  \
    PFN_##name name = [](auto... arguments) {                                                                \
        loadVulkanCommands();                                                                                \
        return name(arguments...);                                                                           \
    };
SHPROBE_VULKAN_COMMANDS(SHPROBE_DEFINE_VULKAN_COMMAND)
#undef SHPROBE_DEFINE_VULKAN_COMMAND

namespace {

// The loader's soname, as the Vulkan loader's Linux ABI names it and every distribution installs it.
constexpr const char* kVulkanLoader = "libvulkan.so.1";

// A command of the loader's; throws before anything is assigned when it lacks one.
void* loaderCommand(void* loader, const char* name) {
    void* command = dlsym(loader, name);
    if (!command)
        throw Error(ErrorKind::Device, std::string(kVulkanLoader) + " has no " + name +
                                           ": install libvulkan1 1.1 or newer, or bake with `--backend cpu`");
    return command;
}

// The loader exports every command of the list as a trampoline that dispatches on its first
// argument, as the symbols of a program linked to it do.
void loadCommands() {
    // Kept open for the process. A program that links the loader itself gets the same copy back.
    void* loader = dlopen(kVulkanLoader, RTLD_NOW | RTLD_LOCAL);
    if (!loader)
        throw Error(ErrorKind::Device,
                    std::string("no Vulkan loader: ") + dlerror() +
                        "; install libvulkan1 (1.1 or newer), or bake with `--backend cpu`");
#define SHPROBE_LOAD_VULKAN_COMMAND(name) name = reinterpret_cast<PFN_##name>(loaderCommand(loader, #name));
    SHPROBE_VULKAN_COMMANDS(SHPROBE_LOAD_VULKAN_COMMAND)
#undef SHPROBE_LOAD_VULKAN_COMMAND
}

} // namespace

// A mutex and a flag rather than std::call_once, whose retry after an exception hangs with some
// C++ runtimes (GCC bug 66146).
void loadVulkanCommands() {
    static std::atomic<bool> loaded{false};
    static std::mutex loading;
    if (loaded.load(std::memory_order_acquire)) return;
    std::lock_guard lock(loading);
    if (loaded.load(std::memory_order_relaxed)) return;
    loadCommands();
    loaded.store(true, std::memory_order_release);
}

} // namespace shprobe
