// OpenEXR behind a plugin (libshprobe_exr.so, exr_codec.cpp), loaded with dlopen the first time an
// EXR file is read or written, as OpenImageIO is (image/oiio_plugin.h): OpenEXR and the libraries
// it links (Iex, IlmThread, Imath, libdeflate) take longer to load than the rest of the program, so
// commands that meet no EXR file start without them. Built with the library and installed beside
// the OpenImageIO plugin.
#pragma once
#include "common/error.h"
#include "image/codec.h"

#include <cstdint>
#include <memory>
#include <string>

namespace shprobe {

// The plugin's entry points, the EXR codec of image/codec.h: the first part of a file, scanline or
// tiled (its base level), as OpenImageIO read it; and 32-bit float files with ZIP compression,
// encoded into memory. Errors: those of ImageDecoder, and Error(Output) "cannot write WHAT: REASON".
struct ExrPlugin {
    std::unique_ptr<ImageDecoder> (*openDecoder)(const std::string& path);
    std::string (*encode)(const FloatPixels& pixels, const std::string& what);
};

// Files up to this size whose chunks are large (PIZ, B44, B44A, DWAA, DWAB: 32 or more scanlines)
// are read whole into memory and decoded where each chunk lies; others are read as a stream, chunk
// by chunk, so that a bake's peak memory stays the decoded image's and a few chunks'. Either way
// the pixels and the messages for a short file are the same.
constexpr int64_t kExrBytesReadWhole = int64_t(16) << 20;

// The name of the function the plugin exports: const ExrPlugin* shprobe_exr_plugin_v1().
#define SHPROBE_EXR_PLUGIN_ENTRY "shprobe_exr_plugin_v1"

// The plugin, loaded on first use (thread-safe). Throws Error(kind) naming `what` and the places
// looked in when it cannot be loaded: "WHAT: this format needs OpenEXR, and its plugin
// libshprobe_exr.so could not be loaded (...)". SHPROBE_EXR_PLUGIN names the file to load instead.
const ExrPlugin& exrPlugin(ErrorKind kind, const std::string& what);

} // namespace shprobe
