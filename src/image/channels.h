// What an image file holds, decided before its pixels are read: which of its channels make the
// colour, chosen by their names, and whether an OpenEXR or PNG header claims only what the file
// holds. Neither needs OpenImageIO (the fuzz targets drive them directly); image_read.cpp applies
// both to every image it reads.
#pragma once
#include <array>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <string>
#include <vector>

namespace shprobe {

// ---- Channels by name ---------------------------------------------------------------------------

// How the colour is made from the channels a plan names.
enum class ChannelMeaning {
    Grey,           // one channel, copied to R, G and B
    Rgb,            // red, green and blue
    LuminanceChroma // Y, RY and BY, OpenEXR's luminance/chroma, converted to RGB
};

struct ChannelPlan {
    ChannelMeaning meaning = ChannelMeaning::Rgb;
    // Indices into the file's channel list: R, G, B; or Y, RY, BY; or (grey) the first only.
    std::array<int, 3> channels{0, 1, 2};

    int count() const { return meaning == ChannelMeaning::Grey ? 1 : 3; }
};

// The channels to read, from the names OpenImageIO gives them (ImageSpec::channelnames). Names
// are matched exactly, case included, as OpenEXR does; a layer prefix ("diffuse.R") is the part
// up to the last '.'. The unprefixed layer is preferred, then the layers in the order of their
// first channel; the first layer holding one of these wins, and within it:
//   R, G, B      RGB (alpha and any other channel ignored)
//   Y, RY, BY    luminance/chroma
//   Y            grey (alpha and other channels ignored; RY or BY alone is refused)
// Exactly two channels named R and G are grey and alpha: OpenImageIO gives those names to every
// two-channel image whose format names no channels (TIFF, Targa, SGI, and EXRs it writes from a
// two-channel buffer), and those formats' two-channel images are grey and alpha.
// Anything else throws Error(Input) "PATH: no R,G,B, Y or Y,RY,BY channels (found: Z, A)".
ChannelPlan planChannels(const std::vector<std::string>& names, const std::string& path);

// The primaries and white point of an OpenEXR file's "chromaticities" attribute (CIE 1931 xy),
// by default those of ITU-R BT.709 with a D65 white, as OpenEXR assumes when a file has none.
struct Chromaticities {
    glm::dvec2 red{0.6400, 0.3300};
    glm::dvec2 green{0.3000, 0.6000};
    glm::dvec2 blue{0.1500, 0.0600};
    glm::dvec2 white{0.3127, 0.3290};
};

// The luminance of unit red, green and blue, summing to 1: the Y row of the RGB-to-XYZ matrix of
// the primaries, scaled so that RGB (1, 1, 1) is the white point with Y = 1 (SMPTE RP 177).
// BT.709 gives (0.2126, 0.7152, 0.0722). Throws Error(Input) naming `path` for primaries that give
// no finite weights or a green weight of 0 or less (the conversion divides by it).
glm::vec3 luminanceWeights(const Chromaticities& chromaticities, const std::string& path);

// RGB of one luminance/chroma texel, as OpenEXR's RgbaInputFile converts it (the luminance/chroma
// (YCA) conversion of OpenEXR, "ImfRgbaYca"): R = (RY + 1) Y, B = (BY + 1) Y,
// G = (Y - R w.r - B w.b) / w.g, and grey Y exactly when both chroma values are 0.
glm::vec3 luminanceChromaToRgb(float y, float ry, float by, const glm::vec3& weights);

// ---- Headers read within bounds ------------------------------------------------------------------

// Limits of an OpenEXR header beyond which it is refused: OpenImageIO keeps every part's header
// (about 20 kB for a part of 11 attributes), so the counts, not the bytes, bound what it holds.
constexpr int kMaxExrNameBytes = 255; // OpenEXR's own limit for long names
constexpr int kMaxExrAttributesPerHeader = 1000;
constexpr int kMaxExrAttributes = 20000; // in all the headers of a multi-part file
constexpr int kMaxExrParts = 1000;

// Reads the header of the open file `fd` (an OpenEXR or a PNG file, told by its first bytes; any
// other file is left alone) within the file's size, before OpenImageIO opens it: its readers
// allocate what a header claims before they find that the file is shorter. Reads the header
// bytes only (through a 4 KiB window, so at most that much past them), never the pixels, with
// pread (the file offset is left as it is). Throws Error(Input) "PATH: ..." for:
//   OpenEXR  an attribute whose size is negative or more than the bytes left in the file, or not
//            the size the OpenEXR library reads for its type; a name longer than 255 bytes; more
//            attributes or parts than the limits above; subsampled channels (OpenImageIO reads
//            none);
//   PNG      a chunk before the pixels (IDAT) longer than 2^31 - 1 bytes or than the file's rest.
// A header cut short by the end of the file is left to OpenImageIO, which reads no further and
// says so. Returns the number of bytes scanned: the header's (0 for other formats).
uint64_t checkImageHeader(int fd, const std::string& path);

} // namespace shprobe
