// The Vulkan commands of vk/vulkan_commands.h: nothing of the loader is in the process until a
// command is called, and then any command, called first, loads them all (as an engine calling a
// helper of vk/image.h on its own command buffer does, before any context or borrowed device).
// One test, in a process of its own: the first call must be this test's.
#include "vk/vulkan_commands.h"

#include <dlfcn.h>
#include <gtest/gtest.h>

namespace shprobe {
namespace {

bool loaderInProcess() {
    void* loader = dlopen("libvulkan.so.1", RTLD_LAZY | RTLD_NOLOAD);
    if (loader) dlclose(loader); // drops the reference RTLD_NOLOAD took, not the loader
    return loader != nullptr;
}

TEST(VulkanCommands, TheFirstCallOfAnyCommandLoadsThemAll) {
    ASSERT_FALSE(loaderInProcess()) << "the program links the Vulkan loader, or something loaded it";
    uint32_t version = 0;
    ASSERT_EQ(vkEnumerateInstanceVersion(&version), VK_SUCCESS); // through its first-call loader
    EXPECT_GE(version, VK_API_VERSION_1_1);
    ASSERT_TRUE(loaderInProcess());
    void* loader = dlopen("libvulkan.so.1", RTLD_LAZY | RTLD_NOLOAD);
    ASSERT_NE(loader, nullptr);
    // Every command now the loader's own, the one called first too.
    EXPECT_EQ(reinterpret_cast<void*>(vkEnumerateInstanceVersion),
              dlsym(loader, "vkEnumerateInstanceVersion"));
    EXPECT_EQ(reinterpret_cast<void*>(vkCmdDispatch), dlsym(loader, "vkCmdDispatch"));
    EXPECT_EQ(reinterpret_cast<void*>(vkQueuePresentKHR), dlsym(loader, "vkQueuePresentKHR"));
    dlclose(loader);
}

} // namespace
} // namespace shprobe
