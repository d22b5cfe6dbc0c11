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

} // namespace shprobe
