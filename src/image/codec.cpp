// The formats shprobe reads and writes itself, told from a file's first bytes or an output's name
// (image/codec.h).
#include "image/codec.h"

#include "common/file_extension.h"

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
    if (hasExtension(path, ".exr")) return ImageFormat::Exr;
    if (hasExtension(path, ".hdr")) return ImageFormat::Hdr;
    if (hasExtension(path, ".png")) return ImageFormat::Png;
    if (hasExtension(path, ".jpg") || hasExtension(path, ".jpeg")) return ImageFormat::Jpeg;
    return ImageFormat::Other;
}

} // namespace shprobe
