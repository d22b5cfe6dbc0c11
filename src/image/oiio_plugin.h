// OpenImageIO behind a plugin (libshprobe_oiio.so, oiio_plugin.cpp), for the image formats
// shprobe does not read and write itself (TIFF, Targa, PFM, ...). It is loaded with dlopen the
// first time such a file is met, so the program only links OpenImageIO's hundreds of shared
// libraries into the runs that need them. The plugin is built with the library and lives beside
// it: in the build tree next to the program, installed in <libdir>/shprobe.
#pragma once
#include "common/error.h"
#include "image/codec.h"

#include <functional>
#include <memory>
#include <string>

namespace shprobe {

// What the program asks OpenImageIO to write: an image of `channels` channels, rows top down.
struct OiioImageRequest {
    std::string destination; // for messages, and for the format when `format` is empty
    std::string format;      // OpenImageIO's format name ("tiff"), or empty: from the destination
    std::string memoryPath;  // where OpenImageIO writes the file (a MemoryFile, common/output_file.h)
    int width = 0;
    int height = 0;
    int channels = 3;
    // 8-bit data written as it is (alpha unassociated), when set; else floats:
    const BytePixels* bytes = nullptr;
    // The float pixels, given whether the file stores floats (linear) or integers (sRGB-encoded:
    // the caller encodes them, as readImage decodes them).
    std::function<FloatPixels(bool storesFloats)> floats;
};

// The plugin's entry points. Errors are shprobe::Error: Input from openDecoder (the messages of
// image/codec.h, "not an image OpenImageIO can read (...)"), Output from encode.
struct OiioPlugin {
    std::unique_ptr<ImageDecoder> (*openDecoder)(const std::string& path);
    void (*encode)(const OiioImageRequest& request);
};

// The name of the function the plugin exports: const OiioPlugin* shprobe_oiio_plugin_v1().
#define SHPROBE_OIIO_PLUGIN_ENTRY "shprobe_oiio_plugin_v1"

// The plugin, loaded on first use (thread-safe). Throws Error(kind) naming `what` and the places
// looked in when it cannot be loaded: "WHAT: this format needs OpenImageIO, and its plugin
// libshprobe_oiio.so was not found (...)". SHPROBE_OIIO_PLUGIN names the file to load instead.
const OiioPlugin& oiioPlugin(ErrorKind kind, const std::string& what);

} // namespace shprobe
