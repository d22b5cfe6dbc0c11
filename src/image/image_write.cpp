// Writing linear RGB images through OpenImageIO, atomically via AtomicFile.
#include "image/image_write.h"

#include "io/atomic_file.h"
#include "sh/error.h"

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

bool writePixels(OIIO::ImageOutput& output, const Image& image) {
    constexpr OIIO::stride_t texelStride = sizeof(glm::vec4);
    return output.write_image(OIIO::TypeDesc::FLOAT, image.texels.data(), texelStride,
                              texelStride * image.width);
}

[[noreturn]] void failWrite(const std::string& destination, const std::string& why) {
    throw Error(ErrorKind::Output, "cannot write " + destination + ": " + why);
}

// Writes to file (the temporary one); errors name the destination, the file the user asked for.
void writeTo(const std::string& file, const std::string& destination, const Image& image) {
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(destination); // by its extension
    if (!output) failWrite(destination, "no image format for this extension (" + OIIO::geterror() + ")");
    OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::FLOAT);
    if (!output->open(file, spec)) failWrite(destination, output->geterror());
    // The format may store integers (PNG, JPEG...): those hold sRGB, which readImage decodes.
    // OIIO converts our floats to the file's type.
    bool linear = output->spec().format.is_floating_point();
    bool written = linear ? writePixels(*output, image) : writePixels(*output, srgbEncoded(image));
    if (!written) failWrite(destination, output->geterror());
    if (!output->close()) failWrite(destination, output->geterror());
}

} // namespace

void writeImage(const std::string& path, const Image& image) {
    if (image.width < 1 || image.height < 1 || image.texels.size() != size_t(image.width) * image.height)
        throw Error(ErrorKind::Output,
                    "cannot write " + path + ": the image has no pixels or a wrong texel count");
    AtomicFile file(path);
    writeTo(file.temporaryPath(), path, image);
    file.commit();
}

} // namespace shprobe
