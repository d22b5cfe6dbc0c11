// Image codecs behind readImage and the image writers (image/environment.h, image/image_write.h).
// Radiance HDR, PNG and JPEG are read and written by stb_image and stb_image_write, compiled into
// shprobe; EXR by OpenEXR, behind a plugin loaded when the first EXR file is met
// (image/exr_plugin.h); any other format goes through OpenImageIO, also a plugin loaded only when
// such a file is met (image/oiio_plugin.h): a command that reads or writes none of them does not
// pay for their libraries' loading (OpenImageIO's: hundreds of shared libraries).
#pragma once
#include "image/channels.h"

#include <climits>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace shprobe {

// What a decoder knows from the header, before any pixel is read.
struct ImageHeader {
    int width = 0;
    int height = 0;
    bool volumeOrDeep = false;                    // more than width x height values per channel
    std::vector<std::string> channels;            // channel names, in OpenImageIO 2.4's order (planChannels)
    bool srgb = false;                            // integer data that is sRGB-encoded (float data is linear)
    std::optional<Chromaticities> chromaticities; // the file's own, if it states them
};

// An open image file. Errors are Error(Input) naming the file:
//   "PATH: not an image the <FORMAT> reader can read (REASON)"            opening, header
//   "PATH: cannot read the pixels; the file may be truncated or corrupt (REASON)"   pixels
// or Error(Memory) "PATH: out of memory ..." where the machine could not allocate what a decoder
// needs (the EXR decoder's).
class ImageDecoder {
  public:
    virtual ~ImageDecoder() = default;
    const ImageHeader& header() const { return header_; }
    // Channels [begin, end) of every pixel, converted to float (integers normalized to [0, 1]),
    // into consecutive floats from `first` on: pixel (x, y)'s channel begin + c lands at
    // first[4 (y width + x) + c] (the RGBA texels of an Image). Called once per image, or once per
    // planned channel when they lie apart.
    virtual void readChannels(int begin, int end, float* first) = 0;
    // What can be checked of the pixel data without decoding it (a file cut short, compressed data
    // too short for the pixels the header claims), before the caller allocates the image: a tiny
    // file claiming 16384 x 8192 pixels is refused at once, not after 2 GiB are filled. Throws
    // Error(Input); readChannels would find the same later. The default checks nothing.
    virtual void checkData() {}

  protected:
    ImageHeader header_;
};

// A library's message as part of a one-line error: its lines joined with "; ". Inline, as the
// OpenImageIO plugin uses it too and links nothing of shprobe's.
inline std::string oneLine(std::string text) {
    while (!text.empty() && text.back() == '\n')
        text.pop_back();
    for (size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at))
        text.replace(at, 1, "; ");
    return text;
}

// The image formats shprobe reads and writes itself; Other: OpenImageIO's.
enum class ImageFormat { Exr, Hdr, Png, Jpeg, Other };

// From the file's first bytes (magic numbers), whatever its name.
ImageFormat sniffImageFormat(const unsigned char* bytes, size_t count);
// From an output name's extension (case-insensitive): .exr, .hdr, .png, .jpg/.jpeg; else Other.
ImageFormat imageFormatOfName(const std::string& path);

// Native decoders: EXR through the OpenEXR plugin (image/exr_plugin.h, loaded by this call the first
// time), stb_image's (stb_codec.cpp). `path` names a regular file already checked by readImage
// (checkInputFile, checkImageHeader).
std::unique_ptr<ImageDecoder> openExrDecoder(const std::string& path);
std::unique_ptr<ImageDecoder> openStbDecoder(const std::string& path, ImageFormat format); // Hdr, Png, Jpeg

// A PNG or JPEG in memory (a glTF texture) as stb_image decodes it: RGB codes as stored, 8 or 16
// bits, sRGB-encoded. readRgbCodesHeader gives the size and depth alone, so that a caller can refuse
// a size before decoding; Error(Input) "WHAT: ..." for bytes stb_image cannot read.
struct RgbCodes {
    int width = 0;
    int height = 0;
    int bits = 8;
    std::vector<uint16_t> codes; // width x height x 3, rows top down
};
RgbCodes readRgbCodesHeader(std::span<const unsigned char> bytes, const std::string& what);
void decodeRgbCodes(std::span<const unsigned char> bytes, RgbCodes& image, const std::string& what);

// Pixels to encode: rows top down, `channels` interleaved values per pixel, `pixelStride` values
// from one pixel to the next (4 for RGBA texels of which 3 channels are written).
struct FloatPixels {
    int width = 0;
    int height = 0;
    int channels = 3;
    int pixelStride = 4;
    const float* data = nullptr; // linear values
};
struct BytePixels {
    int width = 0;
    int height = 0;
    int channels = 3; // 3: RGB, 4: RGBA (alpha unassociated, written as it is)
    int pixelStride = 4;
    const uint8_t* data = nullptr; // already sRGB-encoded (or data, for RGBA)
};

// stb_image_write counts bytes in int: the most pixels its HDR, PNG and JPEG encoders take at
// `channels` a pixel, (channels + 1) * 4 bytes each with room to spare.
constexpr int64_t maxStbPixels(int channels) {
    return INT_MAX / ((int64_t(channels) + 1) * 4);
}

// The file's bytes. EXR (the OpenEXR plugin's): 32-bit floats, ZIP compression, scanlines; HDR:
// RGBE; PNG and JPEG (quality 95): 8 bits per channel. Errors: Error(Output) "cannot write WHAT:
// REASON".
std::string encodeExr(const FloatPixels& pixels, const std::string& what);
std::string encodeHdr(const FloatPixels& pixels, const std::string& what);
std::string encodePng(const BytePixels& pixels, const std::string& what);
std::string encodeJpeg(const BytePixels& pixels, const std::string& what);

} // namespace shprobe
