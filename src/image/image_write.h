// Writing images: EXR, HDR, PNG and JPEG by shprobe's own encoders, other formats through the
// OpenImageIO plugin (image/codec.h). The encoded file goes to the destination through OutputFile
// (common/output_file.h): whole or not at all, every write checked.
#pragma once
#include "sh/cubemap.h"

#include <cstdint>
#include <string>
#include <vector>

namespace shprobe {

// Writes a linear float image; the format is OpenImageIO's format name `format` ("openexr", "tiff"),
// or, when empty, follows the extension (EXR keeps floats; integer formats such as PNG get the sRGB
// encoding that readImage decodes). Throws Error(Output) naming the file on failure, leaving no
// partial file.
void writeImage(const std::string& path, const Image& image, const std::string& format = "");

// Writes RGBA8 bytes (rows top down, already sRGB-encoded) as an 8-bit RGB file of the
// extension's format (PNG, JPEG); alpha is dropped.
void writeSrgbImage(const std::string& path, int width, int height, const std::vector<uint8_t>& rgba);

// The most pixels writeImage and writeSrgbImage put in a file named `path` (RGB): stb_image_write's
// limit for HDR, PNG and JPEG, none (INT64_MAX) for EXR and OpenImageIO's formats.
int64_t maxWrittenPixels(const std::string& path);

// The bytes of an 8-bit RGBA file of OpenImageIO's format `format` ("png") holding RGBA8 bytes
// (rows top down) as they are, for files embedded in others (a glTF's data URIs).
std::string encodeRgba8(const std::string& format, int width, int height, const std::vector<uint8_t>& rgba);

} // namespace shprobe
