// Finding and loading the plugins (common/plugin_loader.h).
#include "common/plugin_loader.h"

#include <algorithm>
#include <cstdlib>
#include <dlfcn.h>
#include <filesystem>
#include <link.h>
#include <mutex>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <utility>
#include <vector>

namespace shprobe {
namespace {

namespace fs = std::filesystem;

// The folder of the file holding this code: libshprobe_sh.so (which holds the common floor) when the
// libraries are shared, else the program. For the program the loader's name is its argv[0] ("shprobe" when
// run through PATH), so the program's own file is taken from /proc/self/exe.
fs::path folderOfThisCode() {
    Dl_info info{};
    link_map* module = nullptr;
    if (dladdr1(reinterpret_cast<void*>(&folderOfThisCode), &info, reinterpret_cast<void**>(&module),
                RTLD_DL_LINKMAP) == 0 ||
        !module)
        return {};
    const bool program = module->l_name == nullptr || module->l_name[0] == '\0';
    std::error_code error;
    fs::path file = fs::canonical(program ? "/proc/self/exe" : module->l_name, error);
    return error ? fs::path() : file.parent_path();
}

// Why `path` may not be loaded, or "" if it may: the plugin runs with the user's rights, so the file
// and the folder it lies in must be owned by root or the user and not writable by every user.
// Checked for the path as named and for the file a link leads to.
std::string refusal(const fs::path& path) {
    auto check = [](const fs::path& place, const char* what) -> std::string {
        struct stat status {};
        if (stat(place.c_str(), &status) != 0) return {}; // missing: the loader says so
        const std::string named = std::string(what) + " " + place.string();
        if (status.st_uid != 0 && status.st_uid != geteuid())
            return named + " belongs to user " + std::to_string(status.st_uid) +
                   ", neither root nor the user running shprobe";
        if (status.st_mode & S_IWOTH) return named + " is writable by every user";
        return {};
    };
    std::error_code error;
    const fs::path real = fs::canonical(path, error);
    std::vector<std::pair<fs::path, const char*>> places{{path.parent_path(), "its folder"}};
    if (!error) places.insert(places.end(), {{real, "the file"}, {real.parent_path(), "its folder"}});
    for (const auto& [place, what] : places)
        if (std::string why = check(place, what); !why.empty()) return why;
    return {};
}

// `folder` less its trailing `tail` (both made of whole names), or "" if it does not end so.
fs::path withoutTail(const fs::path& folder, const fs::path& tail) {
    fs::path head = folder;
    std::vector<fs::path> names(tail.begin(), tail.end());
    for (auto name = names.rbegin(); name != names.rend(); ++name) {
        if (name->empty()) continue; // a trailing '/'
        if (head.filename() != *name) return {};
        head = head.parent_path();
    }
    return head;
}

// Where the plugin may be, in order, each an absolute path of the program's own tree: beside the
// code (the build tree's program); shprobe/ beside it (an installed shared library); for a program
// installed in <prefix>/bin, <prefix>/lib/shprobe; the configured install location; and for code
// inside the build tree it was built in (its tests), that build tree. Never a folder above.
std::vector<fs::path> candidates(const PluginName& plugin) {
    std::vector<fs::path> places;
    const fs::path here = folderOfThisCode();
    if (!here.empty()) {
        places = {here / plugin.file, here / "shprobe" / plugin.file};
        if (fs::path prefix = withoutTail(here, SHPROBE_INSTALL_BINDIR_NAME); !prefix.empty())
            places.push_back(prefix / SHPROBE_INSTALL_LIBDIR_NAME / "shprobe" / plugin.file);
    }
    places.push_back(fs::path(SHPROBE_INSTALL_PLUGIN_DIR) / plugin.file);
    std::error_code error;
    const fs::path build = fs::canonical(SHPROBE_BUILD_PLUGIN_DIR, error);
    if (!error && !here.empty()) {
        if (std::mismatch(build.begin(), build.end(), here.begin(), here.end()).first == build.end())
            places.push_back(build / plugin.file);
    }
    return places;
}

// The dynamic loader's reason for the last failure.
std::string loaderReason() {
    const char* reason = dlerror();
    return reason && *reason ? reason : "the dynamic loader gave no reason";
}

// Loads the plugin at `place` (an absolute path, checked by `refusal`) and finds its entry.
PluginFound load(const fs::path& place, const PluginName& plugin) {
    if (std::string why = refusal(place); !why.empty())
        return {nullptr, "refusing " + place.string() + ": " + why};
    dlerror();
    void* module = dlopen(place.c_str(), RTLD_NOW | RTLD_LOCAL); // kept open for the process
    if (!module) return {nullptr, "loading " + place.string() + " failed: " + loaderReason()};
    void* entry = dlsym(module, plugin.entry);
    if (!entry) return {nullptr, place.string() + " has no " + plugin.entry + ": " + loaderReason()};
    return {entry, {}};
}

} // namespace

PluginFound findPlugin(const PluginName& plugin) {
    // The variable, when set (empty is not set), names the one file to load, by its absolute path:
    // a relative one would be looked up in the working folder or the loader's search path.
    if (const char* named = std::getenv(plugin.environment); named && *named) {
        if (named[0] != '/')
            return {nullptr, std::string(plugin.environment) + "=" + named +
                                 " is not an absolute path; name the plugin by its absolute path"};
        PluginFound found = load(named, plugin);
        if (!found.entry) found.failure = std::string(plugin.environment) + ": " + found.failure;
        return found;
    }
    std::string tried;
    for (const fs::path& place : candidates(plugin)) {
        std::error_code error;
        if (place.is_relative() || !fs::exists(place, error)) {
            tried += (tried.empty() ? "" : ", ") + place.string();
            continue;
        }
        return load(place, plugin);
    }
    return {nullptr, "looked in " + tried};
}

} // namespace shprobe
