// detectLayout and parseLayout on sizes and names decoded from the bytes: either a layout that fits
// the size (or the name) or shprobe::Error, nothing else.
//
// Input: width and height (4 bytes each, little-endian, signed), then the layout name (the rest).
#include "fuzz_support.h"
#include "image/environment.h"

#include <cstdint>
#include <string>

using namespace shprobe;

namespace {

// The sides the program can hand to detectLayout: readImage refuses images over 65536 per side
// before anything else looks at them. Sizes are decoded in [-kSideRange, kSideRange], twice that
// limit, so the refusals around it are covered too.
constexpr int64_t kSideRange = 2 * 65536;

int decodeSide(uint32_t bits) {
    return int(int64_t(bits % uint32_t(2 * kSideRange + 1)) - kSideRange);
}

void checkDetected(Layout layout, int64_t width, int64_t height) {
    bool fits = false;
    switch (layout) {
    case Layout::Equirect:
        fits = width == 2 * height;
        break;
    case Layout::HorizontalCross:
        fits = 3 * width == 4 * height;
        break;
    case Layout::VerticalCross:
        fits = 4 * width == 3 * height;
        break;
    default:
        break;
    }
    if (!fits || width < 1 || height < 1)
        fuzz::finding(std::string("detectLayout gave ") + layoutName(layout) + " for " +
                      std::to_string(width) + "x" + std::to_string(height));
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz::ByteReader in(data, size);
    int width = decodeSide(in.u32());
    int height = decodeSide(in.u32());
    std::string name = in.rest();

    fuzz::expectOnlyShprobeErrors("detectLayout",
                                  [&] { checkDetected(detectLayout(width, height), width, height); });
    fuzz::expectOnlyShprobeErrors("parseLayout", [&] {
        Layout layout = parseLayout(name);
        if (name != layoutName(layout)) fuzz::finding("parseLayout accepted \"" + name + "\"");
    });
    return 0;
}
