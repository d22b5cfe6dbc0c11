// Plugins: modules built beside the program and loaded with dlopen the first time they are needed,
// so that runs which need none of them start without the libraries they link (OpenEXR, OpenImageIO,
// Embree and TBB). Each exports one function returning a table of its entry points.
#pragma once
#include "common/error.h"

#include <mutex>
#include <string>
#include <utility>

namespace shprobe {

// A plugin: its file, the function it exports, the variable that names another file, and what needs
// it (for the message when it cannot be loaded: "this format needs OpenEXR").
struct PluginName {
    const char* file;
    const char* entry;
    const char* environment;
    const char* need;
};

struct PluginFound {
    void* entry = nullptr; // the plugin's entry function
    std::string failure;   // why none, with the places looked in
};

// Looks for the plugin where the program's own tree keeps it (beside the code, <prefix>/lib/shprobe,
// the build tree its tests run from) or, where the variable is set, at the absolute path it names;
// refuses a file or folder another user could have written.
PluginFound findPlugin(const PluginName& plugin);

// The plugin's entry points, loaded once per kind of plugin (thread-safe); the entry function is
// called through its own type, `const EntryPoints* ()`. Throws Error(kind) "WHAT: NEED, and its plugin
// FILE could not be loaded (WHY)".
template <class EntryPoints>
const EntryPoints& loadPlugin(const PluginName& plugin, ErrorKind kind, const std::string& what) {
    static std::once_flag once;
    static const EntryPoints* entryPoints = nullptr;
    static std::string failure;
    std::call_once(once, [&] {
        PluginFound found = findPlugin(plugin);
        if (found.entry)
            entryPoints = reinterpret_cast<const EntryPoints* (*)()>(found.entry)();
        else
            failure = std::move(found.failure);
    });
    if (!entryPoints)
        throw Error(kind, what + ": " + plugin.need + ", and its plugin " + plugin.file +
                              " could not be loaded (" + failure + ")");
    return *entryPoints;
}

} // namespace shprobe
