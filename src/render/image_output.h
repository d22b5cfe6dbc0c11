// Writing rendered images: EXR and HDR get the linear float colour, PNG and JPEG the tonemapped
// sRGB bytes. Atomic, like every output of shprobe.
#pragma once
#include "render/offscreen.h"

#include <cstdint>
#include <string>

namespace shprobe {

// Throws Error(Input) for an extension that is neither (before any rendering is done), and
// Error(Output) if the file's folder is missing or read-only.
void checkRenderOutputPath(const std::string& path);

// Throws Error(Input) where the format of `path` cannot hold a width x height image (PNG, JPEG and
// HDR: maxWrittenPixels), naming `asked` (the option that sized it, "--size 16384x8192") and the
// limit: before any rendering, which at that size takes minutes and gigabytes.
void checkRenderOutputSize(const std::string& path, uint32_t width, uint32_t height,
                           const std::string& asked);

// Writes `image` to `path` by its extension; throws Error(Output) naming the file on failure.
void writeRenderedImage(const std::string& path, const RenderedImage& image);

} // namespace shprobe
