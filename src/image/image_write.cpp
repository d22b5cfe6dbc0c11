// Writing images: EXR, HDR, PNG and JPEG by shprobe's own encoders (image/codec.h), other formats
// through the OpenImageIO plugin, always into memory first, then to the destination through
// OutputFile.
#include "image/image_write.h"

#include "common/error.h"
#include "common/output_file.h"
#include "image/codec.h"
#include "image/oiio_plugin.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace shprobe {
namespace {

// The exact sRGB OETF (IEC 61966-2-1), inverse of the decode in image_read.cpp.
float linearToSrgb(float linear) {
    double c = std::max(double(linear), 0.0);
    return float(c <= 0.0031308 ? c * 12.92 : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055);
}

Image srgbEncoded(const Image& image) {
    Image encoded = image;
    for (glm::vec4& texel : encoded.texels)
        texel = glm::vec4(linearToSrgb(texel.r), linearToSrgb(texel.g), linearToSrgb(texel.b), texel.a);
    return encoded;
}

// 8-bit values of encoded floats, rounded to nearest, as a float-to-uint8 conversion stores them.
std::vector<uint8_t> toBytes(const Image& encoded) {
    std::vector<uint8_t> bytes(encoded.texels.size() * 4);
    for (size_t i = 0; i < encoded.texels.size(); ++i)
        for (int c = 0; c < 4; ++c)
            bytes[4 * i + size_t(c)] = uint8_t(std::clamp(encoded.texels[i][c], 0.0f, 1.0f) * 255.0f + 0.5f);
    return bytes;
}

[[noreturn]] void failWrite(const std::string& destination, const std::string& why) {
    throw Error(ErrorKind::Output, "cannot write " + destination + ": " + why);
}

FloatPixels rgbOf(const Image& image) {
    return {image.width, image.height, 3, 4, &image.texels[0].x};
}

// The bytes of the file in a native format, or an empty optional for OpenImageIO's formats.
std::optional<std::string> encodeNatively(ImageFormat format, const BytePixels& pixels,
                                          const std::string& what) {
    switch (format) {
    case ImageFormat::Png:
        return encodePng(pixels, what);
    case ImageFormat::Jpeg:
        return encodeJpeg(pixels, what);
    default:
        return std::nullopt;
    }
}

// Through the plugin: OpenImageIO writes into a MemoryFile. The OutputFile exists first, so that a
// run interrupted while encoding removes its temporary file.
void writeThroughOiio(OiioImageRequest request) {
    const OiioPlugin& plugin = oiioPlugin(ErrorKind::Output, "cannot write " + request.destination);
    OutputFile file(request.destination, OutputContent::Binary);
    MemoryFile memory;
    request.memoryPath = memory.path();
    plugin.encode(request);
    file.write(memory.contents());
    file.commit();
}

void writeBytes(const std::string& path, const std::string& contents) {
    OutputFile file(path, OutputContent::Binary);
    file.write(contents);
    file.commit();
}

ImageFormat formatOf(const std::string& path, const std::string& format) {
    if (format == "openexr") return ImageFormat::Exr;
    return format.empty() ? imageFormatOfName(path) : ImageFormat::Other;
}

} // namespace

void writeImage(const std::string& path, const Image& image, const std::string& format) {
    if (image.width < 1 || image.height < 1 || image.texels.size() != size_t(image.width) * image.height)
        failWrite(path, "the image has no pixels or a wrong texel count");
    const ImageFormat kind = formatOf(path, format);
    if (kind == ImageFormat::Exr) return writeBytes(path, encodeExr(rgbOf(image), path));
    if (kind == ImageFormat::Hdr) return writeBytes(path, encodeHdr(rgbOf(image), path));
    if (kind == ImageFormat::Png || kind == ImageFormat::Jpeg) {
        // Integer formats hold sRGB, which readImage decodes.
        const std::vector<uint8_t> bytes = toBytes(srgbEncoded(image));
        return writeBytes(path, *encodeNatively(kind, {image.width, image.height, 3, 4, bytes.data()}, path));
    }
    Image encoded;
    writeThroughOiio({.destination = path,
                      .format = format,
                      .width = image.width,
                      .height = image.height,
                      .floats = [&](bool storesFloats) {
                          if (storesFloats) return rgbOf(image);
                          encoded = srgbEncoded(image);
                          return rgbOf(encoded);
                      }});
}

int64_t maxWrittenPixels(const std::string& path) {
    const ImageFormat format = imageFormatOfName(path);
    const bool stb = format == ImageFormat::Hdr || format == ImageFormat::Png || format == ImageFormat::Jpeg;
    return stb ? maxStbPixels(3) : INT64_MAX;
}

std::string encodeRgba8(const std::string& format, int width, int height, const std::vector<uint8_t>& rgba) {
    const std::string what = "a " + format + " image";
    if (width < 1 || height < 1 || rgba.size() != size_t(width) * size_t(height) * 4)
        failWrite(what, "the image has no pixels or a wrong byte count");
    const BytePixels pixels{width, height, 4, 4, rgba.data()};
    if (std::optional<std::string> bytes = encodeNatively(imageFormatOfName("." + format), pixels, what))
        return *bytes;
    const OiioPlugin& plugin = oiioPlugin(ErrorKind::Output, "cannot write " + what);
    MemoryFile memory;
    plugin.encode({.destination = what,
                   .format = format,
                   .memoryPath = memory.path(),
                   .width = width,
                   .height = height,
                   .channels = 4,
                   .bytes = &pixels});
    return memory.contents();
}

void writeSrgbImage(const std::string& path, int width, int height, const std::vector<uint8_t>& rgba) {
    if (width < 1 || height < 1 || rgba.size() != size_t(width) * size_t(height) * 4)
        failWrite(path, "the image has no pixels or a wrong byte count");
    const BytePixels pixels{width, height, 3, 4, rgba.data()}; // alpha dropped: 4-byte pixel stride
    if (std::optional<std::string> bytes = encodeNatively(imageFormatOfName(path), pixels, path))
        return writeBytes(path, *bytes);
    writeThroughOiio({.destination = path, .width = width, .height = height, .bytes = &pixels});
}

} // namespace shprobe
