// Finding and loading the OpenImageIO plugin (image/oiio_plugin.h) on first use.
#include "shprobe/image/oiio_plugin.h"

#include <cstdlib>
#include <dlfcn.h>
#include <filesystem>
#include <mutex>
#include <vector>

namespace shprobe {
namespace {

namespace fs = std::filesystem;
constexpr const char* kPluginName = "libshprobe_oiio.so";

// The folder of the file holding this code: the program when the library is linked statically,
// libshprobe.so when shared.
fs::path folderOfThisCode() {
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&oiioPlugin), &info) == 0 || !info.dli_fname) return {};
    std::error_code error;
    fs::path file = fs::canonical(info.dli_fname, error);
    return error ? fs::path() : file.parent_path();
}

// Where the plugin may be, in order: SHPROBE_OIIO_PLUGIN; beside the code (the build tree's
// program; an installed libshprobe.so's folder has it in shprobe/); one folder up (tests in the
// build tree); the installed layout seen from bin/ (../lib/shprobe); the configured install
// location; the build tree it was built in.
std::vector<fs::path> candidates() {
    if (const char* named = std::getenv("SHPROBE_OIIO_PLUGIN"); named && *named) return {named};
    std::vector<fs::path> places;
    if (fs::path here = folderOfThisCode(); !here.empty())
        places = {here / kPluginName, here / "shprobe" / kPluginName, here.parent_path() / kPluginName,
                  here.parent_path() / SHPROBE_INSTALL_LIBDIR_NAME / "shprobe" / kPluginName};
    places.push_back(fs::path(SHPROBE_INSTALL_PLUGIN_DIR) / kPluginName);
    places.push_back(fs::path(SHPROBE_BUILD_PLUGIN_DIR) / kPluginName);
    return places;
}

struct Loaded {
    const OiioPlugin* plugin = nullptr;
    std::string failure; // why not, with the places looked in
};

Loaded load() {
    std::string tried;
    for (const fs::path& place : candidates()) {
        std::error_code error;
        if (!fs::is_regular_file(place, error)) {
            tried += (tried.empty() ? "" : ", ") + place.string();
            continue;
        }
        void* module = dlopen(place.c_str(), RTLD_NOW | RTLD_LOCAL); // kept open for the process
        if (!module) return {nullptr, "loading " + place.string() + " failed: " + dlerror()};
        using Entry = const OiioPlugin* (*)();
        auto entry = reinterpret_cast<Entry>(dlsym(module, SHPROBE_OIIO_PLUGIN_ENTRY));
        if (!entry) return {nullptr, place.string() + " has no " SHPROBE_OIIO_PLUGIN_ENTRY};
        return {entry(), {}};
    }
    return {nullptr, "looked in " + tried};
}

} // namespace

const OiioPlugin& oiioPlugin(ErrorKind kind, const std::string& what) {
    static std::once_flag once;
    static Loaded loaded;
    std::call_once(once, [] { loaded = load(); });
    if (!loaded.plugin)
        throw Error(kind, what + ": this format needs OpenImageIO, and its plugin " + kPluginName +
                              " could not be loaded (" + loaded.failure + ")");
    return *loaded.plugin;
}

} // namespace shprobe
