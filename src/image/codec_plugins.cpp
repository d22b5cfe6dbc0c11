// The codec plugins (image/exr_plugin.h, image/oiio_plugin.h) loaded on first use, and the EXR codec
// of image/codec.h through its plugin.
#include "common/plugin_loader.h"
#include "image/exr_plugin.h"
#include "image/oiio_plugin.h"

#include <string>

namespace shprobe {
namespace {

constexpr PluginName kExr{"libshprobe_exr.so", SHPROBE_EXR_PLUGIN_ENTRY, "SHPROBE_EXR_PLUGIN",
                          "this format needs OpenEXR"};
constexpr PluginName kOiio{"libshprobe_oiio.so", SHPROBE_OIIO_PLUGIN_ENTRY, "SHPROBE_OIIO_PLUGIN",
                           "this format needs OpenImageIO"};

} // namespace

const ExrPlugin& exrPlugin(ErrorKind kind, const std::string& what) {
    return loadPlugin<ExrPlugin>(kExr, kind, what);
}

const OiioPlugin& oiioPlugin(ErrorKind kind, const std::string& what) {
    return loadPlugin<OiioPlugin>(kOiio, kind, what);
}

std::unique_ptr<ImageDecoder> openExrDecoder(const std::string& path) {
    return exrPlugin(ErrorKind::Input, path).openDecoder(path);
}

std::string encodeExr(const FloatPixels& pixels, const std::string& what) {
    return exrPlugin(ErrorKind::Output, "cannot write " + what).encode(pixels, what);
}

} // namespace shprobe
