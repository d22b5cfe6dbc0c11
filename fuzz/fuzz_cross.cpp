// Images of small, decoded sizes filled with arbitrary texels (NaN and infinity included), turned
// into cube maps as the loader does: crossToCubemap, equirectToCubemap and resizeCubemap, for the
// detected layout or a forced one. Only shprobe::Error may come out, and a cube map that comes out
// must have the expected size.
//
// Input: shape, forced layout, a size n, a perturbation, a face size (1 byte each), then texels as
// little-endian floats (RGB; missing ones are 0).
#include "fuzz_support.h"
#include "image/environment.h"

#include <array>
#include <cstdint>
#include <string>

using namespace shprobe;

namespace {

constexpr int kMaxUnit = 24;     // images up to 4 x 24 = 96 pixels per side
constexpr int kMaxFaceSize = 40; // resize and equirect targets

Image decodeImage(fuzz::ByteReader& in) {
    uint8_t shape = in.u8();
    int n = in.u8() % (kMaxUnit + 1); // 0 gives empty images
    int perturbation = int(in.u8() % 5) - 2;
    int width = 0, height = 0;
    switch (shape % 4) {
    case 0: // equirect-shaped
        width = 2 * n, height = n;
        break;
    case 1: // horizontal cross
        width = 4 * n, height = 3 * n;
        break;
    case 2: // vertical cross
        width = 3 * n, height = 4 * n;
        break;
    default: // any shape
        width = int(in.u8() % (4 * kMaxUnit + 1));
        height = int(in.u8() % (4 * kMaxUnit + 1));
        break;
    }
    // Perturb one side by up to 2 pixels, so near-misses of the ratios are tried.
    if (shape & 4)
        width = std::max(0, width + perturbation);
    else
        height = std::max(0, height + perturbation);

    // Built directly rather than through makeImage so that 0 x N images reach the layout code.
    Image image{width, height,
                std::vector<glm::vec4>(size_t(width) * size_t(height), glm::vec4(0.0f, 0.0f, 0.0f, 1.0f))};
    for (glm::vec4& texel : image.texels) {
        if (in.remaining() == 0) break;
        texel = glm::vec4(in.f32(), in.f32(), in.f32(), 1.0f);
    }
    return image;
}

void checkCubemap(const Cubemap& cubemap, int faceSize, const char* what) {
    if (cubemap.faceSize != faceSize || cubemap.texels.size() != size_t(kFaceCount) * faceSize * faceSize)
        fuzz::finding(std::string(what) + " returned faces of " + std::to_string(cubemap.faceSize) +
                      " (expected " + std::to_string(faceSize) + ") with " +
                      std::to_string(cubemap.texels.size()) + " texels");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz::ByteReader in(data, size);
    constexpr std::array<Layout, 5> kLayouts{Layout::Auto, Layout::Equirect, Layout::HorizontalCross,
                                             Layout::VerticalCross, Layout::Faces};
    Layout forced = kLayouts[in.u8() % kLayouts.size()];
    int faceSize = int(in.u8() % (kMaxFaceSize + 2)) - 1; // -1 and 0 must be refused
    Image image = decodeImage(in);

    fuzz::expectOnlyShprobeErrors("image to cube map", [&] {
        Layout layout = forced == Layout::Auto ? detectLayout(image.width, image.height) : forced;
        Cubemap cubemap;
        if (layout == Layout::Equirect) {
            cubemap = equirectToCubemap(image, faceSize);
            checkCubemap(cubemap, faceSize, "equirectToCubemap");
        } else {
            cubemap = crossToCubemap(image, layout); // refuses Faces: not a cross
            int crossFace = layout == Layout::HorizontalCross ? image.width / 4 : image.width / 3;
            checkCubemap(cubemap, crossFace, "crossToCubemap");
            // +Z sits at column 1, row 1 of both crosses, unrotated.
            for (int j = 0; j < crossFace; ++j)
                for (int i = 0; i < crossFace; ++i) {
                    const glm::vec4& a = cubemap.at(int(Face::PositiveZ), i, j);
                    const glm::vec4& b = image.at(crossFace + i, crossFace + j);
                    if (std::memcmp(&a, &b, sizeof a) != 0) fuzz::finding("crossToCubemap moved a +Z texel");
                }
            Cubemap resized = resizeCubemap(cubemap, faceSize);
            checkCubemap(resized, faceSize, "resizeCubemap");
        }
    });
    return 0;
}
