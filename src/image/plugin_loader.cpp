// Finding and loading the codec plugins (image/exr_plugin.h, image/oiio_plugin.h) on first use, and
// the EXR codec of image/codec.h through its plugin.
#include "image/exr_plugin.h"
#include "image/oiio_plugin.h"

#include <cstdlib>
#include <dlfcn.h>
#include <filesystem>
#include <link.h>
#include <mutex>
#include <vector>

namespace shprobe {
namespace {

namespace fs = std::filesystem;

// A plugin: its file, the function it exports, the variable that names another file, and the
// library it wraps (for the message when it cannot be loaded).
struct PluginName {
    const char* file;
    const char* entry;
    const char* environment;
    const char* library;
};

constexpr PluginName kExr{"libshprobe_exr.so", SHPROBE_EXR_PLUGIN_ENTRY, "SHPROBE_EXR_PLUGIN", "OpenEXR"};
constexpr PluginName kOiio{"libshprobe_oiio.so", SHPROBE_OIIO_PLUGIN_ENTRY, "SHPROBE_OIIO_PLUGIN",
                           "OpenImageIO"};

// The folder of the file holding this code: libshprobe.so when the library is shared, else the
// program. For the program the loader's name is its argv[0] ("shprobe" when run through PATH),
// so the program's own file is taken from /proc/self/exe.
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

// Where the plugin may be, in order: the file its variable names; beside the code (the build tree's
// program; an installed libshprobe.so's folder has it in shprobe/); one folder up (tests in the
// build tree); the installed layout seen from bin/ (../lib/shprobe); the configured install
// location; the build tree it was built in.
std::vector<fs::path> candidates(const PluginName& plugin) {
    if (const char* named = std::getenv(plugin.environment); named && *named) return {named};
    std::vector<fs::path> places;
    if (fs::path here = folderOfThisCode(); !here.empty())
        places = {here / plugin.file, here / "shprobe" / plugin.file, here.parent_path() / plugin.file,
                  here.parent_path() / SHPROBE_INSTALL_LIBDIR_NAME / "shprobe" / plugin.file};
    places.push_back(fs::path(SHPROBE_INSTALL_PLUGIN_DIR) / plugin.file);
    places.push_back(fs::path(SHPROBE_BUILD_PLUGIN_DIR) / plugin.file);
    return places;
}

struct Found {
    void* entry = nullptr; // the plugin's entry function
    std::string failure;   // why none, with the places looked in
};

Found find(const PluginName& plugin) {
    std::string tried;
    for (const fs::path& place : candidates(plugin)) {
        std::error_code error;
        if (!fs::is_regular_file(place, error)) {
            tried += (tried.empty() ? "" : ", ") + place.string();
            continue;
        }
        void* module = dlopen(place.c_str(), RTLD_NOW | RTLD_LOCAL); // kept open for the process
        if (!module) return {nullptr, "loading " + place.string() + " failed: " + dlerror()};
        void* entry = dlsym(module, plugin.entry);
        if (!entry) return {nullptr, place.string() + " has no " + plugin.entry};
        return {entry, {}};
    }
    return {nullptr, "looked in " + tried};
}

// The plugin's entry points, loaded once per kind of plugin (thread-safe). The entry function is
// called through its own type, `const EntryPoints* ()`.
template <class EntryPoints>
const EntryPoints& entryPointsOf(const PluginName& plugin, ErrorKind kind, const std::string& what) {
    static std::once_flag once;
    static const EntryPoints* entryPoints = nullptr;
    static std::string failure;
    std::call_once(once, [&] {
        Found found = find(plugin);
        if (found.entry)
            entryPoints = reinterpret_cast<const EntryPoints* (*)()>(found.entry)();
        else
            failure = std::move(found.failure);
    });
    if (!entryPoints)
        throw Error(kind, what + ": this format needs " + plugin.library + ", and its plugin " + plugin.file +
                              " could not be loaded (" + failure + ")");
    return *entryPoints;
}

} // namespace

const ExrPlugin& exrPlugin(ErrorKind kind, const std::string& what) {
    return entryPointsOf<ExrPlugin>(kExr, kind, what);
}

const OiioPlugin& oiioPlugin(ErrorKind kind, const std::string& what) {
    return entryPointsOf<OiioPlugin>(kOiio, kind, what);
}

std::unique_ptr<ImageDecoder> openExrDecoder(const std::string& path) {
    return exrPlugin(ErrorKind::Input, path).openDecoder(path);
}

std::string encodeExr(const FloatPixels& pixels, const std::string& what) {
    return exrPlugin(ErrorKind::Output, "cannot write " + what).encode(pixels, what);
}

} // namespace shprobe
