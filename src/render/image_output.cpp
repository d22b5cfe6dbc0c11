#include "render/image_output.h"

#include "common/error.h"
#include "common/file_extension.h"
#include "common/output_file.h"
#include "image/image_write.h"

namespace shprobe {

namespace {

enum class OutputKind { Linear, Display, Unknown };

OutputKind outputKind(const std::string& path) {
    if (hasExtension(path, ".exr") || hasExtension(path, ".hdr")) return OutputKind::Linear;
    if (hasExtension(path, ".png") || hasExtension(path, ".jpg") || hasExtension(path, ".jpeg"))
        return OutputKind::Display;
    return OutputKind::Unknown;
}

} // namespace

void checkRenderOutputPath(const std::string& path) {
    if (outputKind(path) == OutputKind::Unknown) {
        checkOutputPath(path, OutputContent::Binary); // "out.png/" names a folder, whatever its type
        throw Error(ErrorKind::Input, path +
                                          ": unknown image type; use .exr or .hdr (linear) or .png or .jpg "
                                          "(tonemapped sRGB)");
    }
    checkOutputPath(path, OutputContent::Binary);
}

void checkRenderOutputSize(const std::string& path, uint32_t width, uint32_t height,
                           const std::string& asked) {
    const int64_t pixels = int64_t(width) * height, limit = maxWrittenPixels(path);
    if (pixels <= limit) return;
    throw Error(ErrorKind::Input, asked + ": " + path + " would be " + std::to_string(width) + "x" +
                                      std::to_string(height) + ", " + std::to_string(pixels) +
                                      " pixels; shprobe writes PNG, JPEG and HDR files of at most " +
                                      std::to_string(limit) + " pixels: write .exr, or ask a smaller size");
}

void writeRenderedImage(const std::string& path, const RenderedImage& image) {
    switch (outputKind(path)) {
    case OutputKind::Linear:
        writeImage(path, image.linear);
        return;
    case OutputKind::Display:
        writeSrgbImage(path, image.linear.width, image.linear.height, image.display);
        return;
    case OutputKind::Unknown:
        break;
    }
    checkRenderOutputPath(path); // throws with the reason
}

} // namespace shprobe
