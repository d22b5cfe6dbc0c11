// Texture images decoded with stb_image from memory. image/stb_codec.cpp compiles stb_image too,
// but privately (STB_IMAGE_STATIC) and reading from files only, so this file compiles its own
// private copy of the two decoders glTF allows, PNG and JPEG.
#include "scene/scene_images.h"

#include "common/error.h"
#include "image/codec.h"

#include <climits>
#include <cmath>
#include <memory>
#include <vector>

#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#define STBI_FAILURE_USERMSG // "Corrupt PNG" rather than "bad ctype"
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include <stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace shprobe {

namespace {

[[noreturn]] void fail(const std::string& what, const std::string& problem) {
    throw Error(ErrorKind::Input, what + ": " + problem);
}

struct StbFree {
    void operator()(void* pixels) const { stbi_image_free(pixels); }
};

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

template <typename Code>
void decodeRgb(const Code* codes, const std::vector<float>& table, SceneTexture& texture) {
    for (size_t i = 0; i < texture.texels.size(); ++i, codes += 3)
        texture.texels[i] = glm::vec4(table[codes[0]], table[codes[1]], table[codes[2]], 1.0f);
}

} // namespace

SceneTexture decodeColourTexture(std::span<const unsigned char> bytes, int64_t maxPixels,
                                 const std::string& what) {
    const ImageFormat format = sniffImageFormat(bytes.data(), bytes.size());
    if (format != ImageFormat::Png && format != ImageFormat::Jpeg)
        fail(what, "not a PNG or JPEG image (the texture formats of glTF 2.0)");
    if (bytes.size() > size_t(INT_MAX)) fail(what, "the image is larger than 2 GiB");
    const int size = int(bytes.size());
    int width = 0, height = 0, channels = 0;
    if (!stbi_info_from_memory(bytes.data(), size, &width, &height, &channels))
        fail(what, std::string("not an image stb_image can read (") + stbi_failure_reason() + ")");
    if (int64_t(width) * height > maxPixels)
        fail(what, "the image is " + std::to_string(width) + "x" + std::to_string(height) +
                       ", more than the limit of " + std::to_string(maxPixels) + " pixels per texture");
    const bool sixteenBit = stbi_is_16_bit_from_memory(bytes.data(), size);
    std::unique_ptr<void, StbFree> pixels(
        sixteenBit
            ? static_cast<void*>(stbi_load_16_from_memory(bytes.data(), size, &width, &height, &channels, 3))
            : static_cast<void*>(stbi_load_from_memory(bytes.data(), size, &width, &height, &channels, 3)));
    if (!pixels) fail(what, std::string("cannot decode the image (") + stbi_failure_reason() + ")");
    SceneTexture texture;
    texture.width = width;
    texture.height = height;
    texture.texels.resize(size_t(width) * size_t(height));
    if (sixteenBit)
        decodeRgb(static_cast<const uint16_t*>(pixels.get()), srgbTable(16), texture);
    else
        decodeRgb(static_cast<const uint8_t*>(pixels.get()), srgbTable(8), texture);
    return texture;
}

} // namespace shprobe
