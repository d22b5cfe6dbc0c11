// Writing images through OpenImageIO, atomically (temporary file in the same folder, then rename).
#pragma once
#include "sh/cubemap.h"
#include <string>

namespace shprobe {

// Writes a linear float image; the format follows the extension (EXR keeps floats; integer
// formats such as PNG get the sRGB encoding that readImage decodes).
// Throws Error(Output) naming the file on failure, leaving no partial file.
void writeImage(const std::string& path, const Image& image);

} // namespace shprobe
