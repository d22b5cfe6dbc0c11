// Texture images decoded from memory (image/codec.h's stb_image decoders) into linear RGB.
#include "scene/scene_images.h"

#include "common/error.h"
#include "image/codec.h"

#include <cmath>
#include <vector>

namespace shprobe {

namespace {

[[noreturn]] void fail(const std::string& what, const std::string& problem) {
    throw Error(ErrorKind::Input, what + ": " + problem);
}

// The linear value of every code of `bits`-bit sRGB (the exact EOTF, in double).
std::vector<float> srgbTable(int bits) {
    std::vector<float> table(size_t(1) << bits);
    const double largest = double(table.size() - 1);
    for (size_t code = 0; code < table.size(); ++code) {
        const double c = double(code) / largest;
        table[code] = float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return table;
}

void decodeRgb(const uint16_t* codes, const std::vector<float>& table, SceneTexture& texture) {
    for (size_t i = 0; i < texture.texels.size(); ++i, codes += 3)
        texture.texels[i] = glm::vec4(table[codes[0]], table[codes[1]], table[codes[2]], 1.0f);
}

} // namespace

namespace {

RgbCodes checkedHeader(std::span<const unsigned char> bytes, int64_t maxPixels, const std::string& what) {
    const ImageFormat format = sniffImageFormat(bytes.data(), bytes.size());
    if (format != ImageFormat::Png && format != ImageFormat::Jpeg)
        fail(what, "not a PNG or JPEG image (the texture formats of glTF 2.0)");
    RgbCodes image = readRgbCodesHeader(bytes, what);
    if (int64_t(image.width) * image.height > maxPixels)
        fail(what, "the image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                       ", more than the limit of " + std::to_string(maxPixels) + " pixels per texture");
    return image;
}

} // namespace

int64_t colourTexturePixels(std::span<const unsigned char> bytes, int64_t maxPixels,
                            const std::string& what) {
    const RgbCodes image = checkedHeader(bytes, maxPixels, what);
    return int64_t(image.width) * image.height;
}

SceneTexture decodeColourTexture(std::span<const unsigned char> bytes, int64_t maxPixels,
                                 const std::string& what) {
    RgbCodes image = checkedHeader(bytes, maxPixels, what);
    decodeRgbCodes(bytes, image, what);
    SceneTexture texture;
    texture.width = image.width;
    texture.height = image.height;
    texture.texels.resize(size_t(image.width) * size_t(image.height));
    decodeRgb(image.codes.data(), srgbTable(image.bits), texture);
    return texture;
}

} // namespace shprobe
