#include "render/image_output.h"

#include "image/image_write.h"
#include "io/atomic_file.h"
#include "sh/error.h"

#include <OpenImageIO/imageio.h>
#include <algorithm>
#include <cctype>
#include <filesystem>

namespace shprobe {

namespace {

enum class OutputKind { Linear, Display, Unknown };

OutputKind outputKind(const std::string& path) {
    std::string extension = std::filesystem::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (extension == ".exr" || extension == ".hdr") return OutputKind::Linear;
    if (extension == ".png" || extension == ".jpg" || extension == ".jpeg") return OutputKind::Display;
    return OutputKind::Unknown;
}

[[noreturn]] void failWrite(const std::string& path, const std::string& why) {
    throw Error(ErrorKind::Output, "cannot write " + path + ": " + why);
}

} // namespace

void checkRenderOutputPath(const std::string& path) {
    if (outputKind(path) == OutputKind::Unknown)
        throw Error(ErrorKind::Input, path +
                                          ": unknown image type; use .exr or .hdr (linear) or .png or .jpg "
                                          "(tonemapped sRGB)");
    checkOutputPath(path);
}

void writeDisplayImage(const std::string& path, int width, int height, const std::vector<uint8_t>& rgba) {
    if (width < 1 || height < 1 || rgba.size() != size_t(width) * size_t(height) * 4)
        failWrite(path, "the image has no pixels or a wrong byte count");
    AtomicFile file(path);
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(path);
    if (!output) failWrite(path, "no image format for this extension (" + OIIO::geterror() + ")");
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    if (!output->open(file.temporaryPath(), spec)) failWrite(path, output->geterror());
    // Alpha is dropped: 4-byte pixel stride over 3 channels.
    if (!output->write_image(OIIO::TypeDesc::UINT8, rgba.data(), 4, OIIO::stride_t(width) * 4))
        failWrite(path, output->geterror());
    if (!output->close()) failWrite(path, output->geterror());
    file.commit();
}

void writeRenderedImage(const std::string& path, const RenderedImage& image) {
    switch (outputKind(path)) {
    case OutputKind::Linear:
        writeImage(path, image.linear);
        return;
    case OutputKind::Display:
        writeDisplayImage(path, image.linear.width, image.linear.height, image.display);
        return;
    case OutputKind::Unknown:
        break;
    }
    checkRenderOutputPath(path); // throws with the reason
}

} // namespace shprobe
