// The formats shprobe reads and writes itself, told from a file's first bytes or an output's name
// (image/codec.h).
#include "image/codec.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <string_view>

namespace shprobe {

namespace {

bool startsWith(const unsigned char* bytes, size_t count, std::string_view magic) {
    return count >= magic.size() && std::memcmp(bytes, magic.data(), magic.size()) == 0;
}

} // namespace

ImageFormat sniffImageFormat(const unsigned char* bytes, size_t count) {
    // "OpenEXR File Layout": the magic number 20000630 as a little-endian int32.
    if (startsWith(bytes, count, std::string_view("\x76\x2f\x31\x01", 4))) return ImageFormat::Exr;
    // The PNG signature (PNG specification, 5.2). As for libpng, its first four bytes make a PNG,
    // one whose other four are damaged (a text-mode transfer) refused as such by the PNG reader.
    if (startsWith(bytes, count, std::string_view("\x89PNG", 4))) return ImageFormat::Png;
    // JPEG: the SOI marker FF D8 and the first byte of the next marker.
    if (startsWith(bytes, count, std::string_view("\xff\xd8\xff", 3))) return ImageFormat::Jpeg;
    // Radiance's "program type" line (Radiance's own files say RADIANCE; Greg Ward's rgbe.c RGBE),
    // the two stb_image accepts.
    if (startsWith(bytes, count, "#?RADIANCE") || startsWith(bytes, count, "#?RGBE")) return ImageFormat::Hdr;
    return ImageFormat::Other;
}

ImageFormat imageFormatOfName(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    const size_t dot = path.find_last_of('.');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return ImageFormat::Other;
    std::string extension = path.substr(dot + 1);
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (extension == "exr") return ImageFormat::Exr;
    if (extension == "hdr") return ImageFormat::Hdr;
    if (extension == "png") return ImageFormat::Png;
    if (extension == "jpg" || extension == "jpeg") return ImageFormat::Jpeg;
    return ImageFormat::Other;
}

} // namespace shprobe
