// Writing rendered images: EXR and HDR get the linear float colour, PNG and JPEG the tonemapped
// sRGB bytes. Atomic, like every output of shprobe.
#pragma once
#include "render/offscreen.h"

#include <string>

namespace shprobe {

// Throws Error(Input) for an extension that is neither (before any rendering is done), and
// Error(Output) if the file's folder is missing or read-only.
void checkRenderOutputPath(const std::string& path);

// Writes `image` to `path` by its extension; throws Error(Output) naming the file on failure.
void writeRenderedImage(const std::string& path, const RenderedImage& image);

// Writes RGBA8 bytes (rows top down) as an 8-bit RGB file; the bytes are already sRGB-encoded.
void writeDisplayImage(const std::string& path, int width, int height, const std::vector<uint8_t>& rgba);

} // namespace shprobe
