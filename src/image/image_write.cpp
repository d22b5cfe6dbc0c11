// Writing images through OpenImageIO into memory, then to the destination through OutputFile.
#include "shprobe/image/image_write.h"

#include "shprobe/io/output_file.h"
#include "shprobe/sh/error.h"

#include <OpenImageIO/imageio.h>
#include <algorithm>
#include <cmath>

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

[[noreturn]] void failWrite(const std::string& destination, const std::string& why) {
    throw Error(ErrorKind::Output, "cannot write " + destination + ": " + why);
}

// Encodes with OpenImageIO into a MemoryFile, then writes its bytes to the destination. The
// OutputFile exists first, so that a run interrupted while encoding removes its temporary file.
// writePixels(output, format) writes the pixels; `format` is the file's pixel type.
template <typename WritePixels>
std::string encodeInMemory(const std::string& destination, const std::string& format,
                           const OIIO::ImageSpec& spec, WritePixels writePixels) {
    MemoryFile memory;
    std::unique_ptr<OIIO::ImageOutput> output =
        OIIO::ImageOutput::create(format.empty() ? destination : format);
    if (!output) failWrite(destination, "no image format for this extension (" + OIIO::geterror() + ")");
    if (!output->open(memory.path(), spec)) failWrite(destination, output->geterror());
    if (!writePixels(*output, output->spec().format)) failWrite(destination, output->geterror());
    if (!output->close()) failWrite(destination, output->geterror());
    return memory.contents();
}

template <typename WritePixels>
void encodeImage(const std::string& destination, const std::string& format, const OIIO::ImageSpec& spec,
                 WritePixels writePixels) {
    OutputFile file(destination, OutputContent::Binary);
    file.write(encodeInMemory(destination, format, spec, writePixels));
    file.commit();
}

bool writeTexels(OIIO::ImageOutput& output, const Image& image) {
    constexpr OIIO::stride_t texelStride = sizeof(glm::vec4);
    return output.write_image(OIIO::TypeDesc::FLOAT, image.texels.data(), texelStride,
                              texelStride * image.width);
}

} // namespace

void writeImage(const std::string& path, const Image& image, const std::string& format) {
    if (image.width < 1 || image.height < 1 || image.texels.size() != size_t(image.width) * image.height)
        failWrite(path, "the image has no pixels or a wrong texel count");
    OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::FLOAT);
    encodeImage(path, format, spec, [&](OIIO::ImageOutput& output, OIIO::TypeDesc stored) {
        // The format may store integers (PNG, JPEG...): those hold sRGB, which readImage decodes.
        // OIIO converts our floats to the file's type.
        return stored.is_floating_point() ? writeTexels(output, image)
                                          : writeTexels(output, srgbEncoded(image));
    });
}

std::string encodeRgba8(const std::string& format, int width, int height, const std::vector<uint8_t>& rgba) {
    const std::string what = "a " + format + " image";
    if (width < 1 || height < 1 || rgba.size() != size_t(width) * size_t(height) * 4)
        failWrite(what, "the image has no pixels or a wrong byte count");
    OIIO::ImageSpec spec(width, height, 4, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:UnassociatedAlpha", 1); // the bytes as they are: alpha is not multiplied in
    return encodeInMemory(what, format, spec, [&](OIIO::ImageOutput& output, OIIO::TypeDesc) {
        return output.write_image(OIIO::TypeDesc::UINT8, rgba.data());
    });
}

void writeSrgbImage(const std::string& path, int width, int height, const std::vector<uint8_t>& rgba) {
    if (width < 1 || height < 1 || rgba.size() != size_t(width) * size_t(height) * 4)
        failWrite(path, "the image has no pixels or a wrong byte count");
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    encodeImage(path, "", spec, [&](OIIO::ImageOutput& output, OIIO::TypeDesc) {
        // Alpha is dropped: 4-byte pixel stride over 3 channels.
        return output.write_image(OIIO::TypeDesc::UINT8, rgba.data(), 4, OIIO::stride_t(width) * 4);
    });
}

} // namespace shprobe
