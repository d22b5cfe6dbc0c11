// The native codecs (image/codec.h: OpenEXR, stb_image, stb_image_write) against OpenImageIO as an
// independent implementation: for files OpenImageIO writes, and for PNG files built here chunk by
// chunk, the decoders' headers (size, channel names in OpenImageIO's order, sRGB or linear,
// chromaticities, deep) and pixels must be what OpenImageIO reads; OpenImageIO must read back what
// the encoders write. Tolerances, where there are any, are said where they are used. Also: the
// eight EXRs of Debian's blender-data (DWAB), compared exactly and timed against OpenImageIO.
#include "common/error.h"
#include "image/codec.h"
#include "image/exr_plugin.h"
#include "library_leaks.h"
#include "png_chunks.h"
#include "test_support.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfThreading.h>
#include <OpenImageIO/deepdata.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <thread>
#include <unistd.h>

namespace shprobe {
namespace {
using testing::bigEndian32;
using testing::LibraryLeaksIgnored;
using testing::pngChunk;
namespace fs = std::filesystem;

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "message: " << (text)

// A folder of its own for each test, removed with its contents afterwards.
class Codecs : public ::testing::Test {
  protected:
    Codecs() {
        const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
        folder_ = fs::temp_directory_path() /
                  ("shprobe_test_codecs_" + std::to_string(getpid()) + "_" + test->name());
        fs::remove_all(folder_);
        fs::create_directories(folder_);
    }
    ~Codecs() override {
        std::error_code ignored;
        fs::remove_all(folder_, ignored);
    }
    std::string file(const std::string& name) const { return (folder_ / name).string(); }

  private:
    fs::path folder_;
};

std::string readBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}
void writeBytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary) << bytes;
}
void cutFile(const std::string& from, const std::string& to, uintmax_t size) {
    writeBytes(to, readBytes(from).substr(0, size));
}

// A reproducible stream of numbers (Knuth's MMIX LCG).
class Numbers {
  public:
    explicit Numbers(uint64_t seed) : state_(seed) {}
    uint32_t next() {
        state_ = state_ * 6364136223846793005ull + 1442695040888963407ull;
        return uint32_t(state_ >> 32);
    }
    double unit() { return next() / 4294967296.0; } // [0, 1)

  private:
    uint64_t state_;
};

// Floats of every sign and magnitude a half or float holds: values from 1e-9 to 1e9, and the
// special ones (zeros, a half denormal, half's largest, infinities, NaN).
std::vector<float> mixedFloats(size_t count, uint64_t seed) {
    Numbers numbers(seed);
    const float specials[] = {0.0f,
                              -0.0f,
                              1.0f,
                              5.9604645e-8f,
                              65504.0f,
                              std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity(),
                              std::numeric_limits<float>::quiet_NaN()};
    std::vector<float> values(count);
    for (size_t i = 0; i < count; ++i)
        values[i] = i % 37 < std::size(specials)
                        ? specials[i % 37]
                        : float((numbers.unit() * 2.0 - 1.0) * std::pow(10.0, numbers.unit() * 18.0 - 9.0));
    return values;
}

// ---- Both readers ---------------------------------------------------------------------------------

struct Decoded {
    ImageHeader header;
    std::vector<float> values; // all channels, interleaved
};

std::unique_ptr<ImageDecoder> openNative(const std::string& path) {
    std::string start = readBytes(path).substr(0, 16);
    ImageFormat format = sniffImageFormat(reinterpret_cast<const unsigned char*>(start.data()), start.size());
    if (format == ImageFormat::Exr) return openExrDecoder(path);
    return openStbDecoder(path, format);
}

// Every channel, read four at a time into RGBA texels as readImage reads them. The texel
// components past the ones asked for must be left as they were.
Decoded decodeNative(const std::string& path) {
    std::unique_ptr<ImageDecoder> decoder = openNative(path);
    Decoded decoded{decoder->header(), {}};
    const ImageHeader& header = decoded.header;
    const size_t texels = size_t(header.width) * size_t(header.height), n = header.channels.size();
    if (header.volumeOrDeep) return decoded;
    decoded.values.resize(texels * n);
    constexpr float kUntouched = 12345.0f;
    for (size_t begin = 0; begin < n; begin += 4) {
        const size_t end = std::min(begin + 4, n);
        std::vector<float> rgba(4 * texels, kUntouched);
        decoder->readChannels(int(begin), int(end), rgba.data());
        for (size_t t = 0; t < texels; ++t) {
            for (size_t c = begin; c < end; ++c)
                decoded.values[t * n + c] = rgba[4 * t + c - begin];
            for (size_t c = end - begin; c < 4; ++c)
                if (rgba[4 * t + c] != kUntouched) {
                    ADD_FAILURE() << path << ": component " << c << " of texel " << t << " was written";
                    return decoded;
                }
        }
    }
    return decoded;
}

// What OpenImageIO reads, as readImage read it through OpenImageIO before: alpha unassociated,
// all channels as float, and integer data sRGB unless the colour space says linear.
struct Reference {
    int width = 0, height = 0;
    std::vector<std::string> channels;
    bool srgb = false;
    bool deep = false;
    std::optional<std::array<float, 8>> chromaticities;
    std::vector<float> values;
};

Reference readOiio(const std::string& path) {
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path, &config);
    if (!input) {
        ADD_FAILURE() << "OpenImageIO cannot open " << path << ": " << OIIO::geterror();
        return {};
    }
    const OIIO::ImageSpec& spec = input->spec();
    Reference reference{spec.width, spec.height, spec.channelnames, false, spec.deep, std::nullopt, {}};
    std::string space = spec.get_string_attribute("oiio:ColorSpace");
    reference.srgb = !spec.format.is_floating_point() && !OIIO::Strutil::icontains(space, "linear") &&
                     !OIIO::Strutil::istarts_with(space, "lin_");
    std::array<float, 8> xy{};
    if (spec.getattribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), xy.data()))
        reference.chromaticities = xy;
    if (spec.deep) return reference;
    reference.values.resize(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
    EXPECT_TRUE(input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, reference.values.data()))
        << path << ": " << input->geterror();
    return reference;
}

// Header and pixels equal; `tolerance` 0 means bit for bit (NaN payloads and the sign of zero
// included). Pixels from column `columns` on are not compared. Returns the largest difference.
float expectSameAsOiio(const std::string& path, float tolerance = 0.0f, int columns = INT_MAX) {
    SCOPED_TRACE(path);
    const Reference expected = readOiio(path);
    const Decoded actual = decodeNative(path);
    EXPECT_EQ(actual.header.width, expected.width);
    EXPECT_EQ(actual.header.height, expected.height);
    EXPECT_EQ(actual.header.channels, expected.channels);
    EXPECT_EQ(actual.header.srgb, expected.srgb);
    EXPECT_EQ(actual.header.volumeOrDeep, expected.deep);
    EXPECT_EQ(actual.header.chromaticities.has_value(), expected.chromaticities.has_value());
    if (expected.chromaticities && actual.header.chromaticities) {
        const auto& c = *actual.header.chromaticities;
        const std::array<double, 8> xy{c.red.x,  c.red.y,  c.green.x, c.green.y,
                                       c.blue.x, c.blue.y, c.white.x, c.white.y};
        for (size_t i = 0; i < 8; ++i)
            EXPECT_EQ(xy[i], double((*expected.chromaticities)[i])) << "chromaticity " << i;
    }
    if (actual.values.size() != expected.values.size()) {
        ADD_FAILURE() << actual.values.size() << " values, OpenImageIO " << expected.values.size();
        return std::numeric_limits<float>::infinity();
    }
    size_t differing = 0;
    float largest = 0.0f;
    for (size_t i = 0; i < expected.values.size(); ++i) {
        if (int(i / expected.channels.size()) % expected.width >= columns) continue;
        const float a = actual.values[i], e = expected.values[i];
        if (std::isfinite(a) && std::isfinite(e)) largest = std::max(largest, std::abs(a - e));
        const bool same = tolerance == 0.0f ? std::bit_cast<uint32_t>(a) == std::bit_cast<uint32_t>(e)
                                            : std::abs(a - e) <= tolerance;
        if (!same && differing++ < 5)
            ADD_FAILURE() << "value " << i << " (texel " << i / expected.channels.size() << ", channel "
                          << i % expected.channels.size() << "): " << a << ", OpenImageIO " << e;
    }
    EXPECT_EQ(differing, 0u);
    return largest;
}

// The message of the Error(Input) that f must throw.
std::string inputErrorOf(const std::function<void()>& f) {
    return testing::errorOf(ErrorKind::Input, f);
}
std::string outputErrorOf(const std::function<void()>& f) {
    return testing::errorOf(ErrorKind::Output, f);
}

// Writes `data` (T per channel value, interleaved) through OpenImageIO; `adjust` edits the spec.
template <typename T>
void writeOiio(const std::string& path, int width, int height, const std::vector<std::string>& names,
               int channels, OIIO::TypeDesc fileType, const std::vector<T>& data,
               const std::function<void(OIIO::ImageSpec&)>& adjust = {}) {
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(output) << OIIO::geterror();
    OIIO::ImageSpec spec(width, height, channels, fileType);
    if (!names.empty()) spec.channelnames = names;
    spec.attribute("oiio:UnassociatedAlpha", 1);
    if (adjust) adjust(spec);
    ASSERT_TRUE(output->open(path, spec)) << output->geterror();
    ASSERT_TRUE(output->write_image(OIIO::BaseTypeFromC<T>::value, data.data())) << output->geterror();
    ASSERT_TRUE(output->close()) << output->geterror();
}

// ---- Formats by their bytes and names --------------------------------------------------------------

TEST(ImageFormats, SniffedFromTheMagicNumbers) {
    auto sniff = [](std::string_view bytes) {
        return sniffImageFormat(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
    };
    EXPECT_EQ(sniff(std::string_view("\x76\x2f\x31\x01\x02\x00\x00\x00", 8)), ImageFormat::Exr);
    EXPECT_EQ(sniff("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR"), ImageFormat::Png);
    EXPECT_EQ(sniff("\xff\xd8\xff\xe0"), ImageFormat::Jpeg);
    EXPECT_EQ(sniff("#?RADIANCE\n"), ImageFormat::Hdr);
    EXPECT_EQ(sniff("#?RGBE\n"), ImageFormat::Hdr);
    // Too short, or almost: each magic number whole or nothing, but for PNG's, whose first four
    // bytes make a PNG as for libpng (one damaged after them is refused as such by the reader).
    EXPECT_EQ(sniff(std::string_view("\x76\x2f\x31", 3)), ImageFormat::Other);
    EXPECT_EQ(sniff("\x89PNG\r\n\x1a"), ImageFormat::Png);
    EXPECT_EQ(sniff("\x89PN"), ImageFormat::Other);
    EXPECT_EQ(sniff("\xff\xd8"), ImageFormat::Other);
    EXPECT_EQ(sniff("#?RADIANC"), ImageFormat::Other);
    EXPECT_EQ(sniff("#?"), ImageFormat::Other);
    EXPECT_EQ(sniff(""), ImageFormat::Other);
    EXPECT_EQ(sniff("P6\n1 1\n255\n"), ImageFormat::Other);
    EXPECT_EQ(sniff("II*\0"), ImageFormat::Other); // TIFF: OpenImageIO's
}

TEST(ImageFormats, ToldFromTheExtensionWhateverItsCase) {
    EXPECT_EQ(imageFormatOfName("out.exr"), ImageFormat::Exr);
    EXPECT_EQ(imageFormatOfName("dir/OUT.EXR"), ImageFormat::Exr);
    EXPECT_EQ(imageFormatOfName("a.hdr"), ImageFormat::Hdr);
    EXPECT_EQ(imageFormatOfName("a.Png"), ImageFormat::Png);
    EXPECT_EQ(imageFormatOfName("a.jpg"), ImageFormat::Jpeg);
    EXPECT_EQ(imageFormatOfName("a.JPEG"), ImageFormat::Jpeg);
    EXPECT_EQ(imageFormatOfName("a.tif"), ImageFormat::Other);
    EXPECT_EQ(imageFormatOfName("a.png.tif"), ImageFormat::Other);
    EXPECT_EQ(imageFormatOfName("png"), ImageFormat::Other);
    EXPECT_EQ(imageFormatOfName("folder.exr/image"), ImageFormat::Other);
    EXPECT_EQ(imageFormatOfName(""), ImageFormat::Other);
}

// ---- OpenEXR ---------------------------------------------------------------------------------------

// Every channel set readImage meets (RGB, RGBA, grey, grey and alpha, OpenImageIO's two-channel
// R, G, layers with extra channels and an X, Y, Z layer, luminance/chroma), as float and half,
// scanlines and 16 x 16 tiles, through every compression, on a window that does not start at 0
// (display and data windows alike: OpenImageIO reads the data window, the decoder the display
// window, ExrDisplayWindowIsTheImage), 37 x 19 so that the last tiles are partial.
// OpenImageIO reports the channels in an order of its own (R, G, B, A first in each layer), which
// the decoder must give too, since planChannels sees them in that order.
TEST_F(Codecs, ExrFilesOpenImageIoWritesDecodeAsItReadsThem) {
    const std::vector<std::vector<std::string>> channelSets = {
        {"R", "G", "B"},
        {"R", "G", "B", "A"},
        {"Y"},
        {"Y", "A"},
        {"", ""}, // OpenImageIO's default names for two channels: R, G
        {"diffuse.R", "diffuse.G", "diffuse.B", "A", "Z", "N.X", "N.Y", "N.Z", "spec.r", "alpha"},
        {"Y", "RY", "BY"},
    };
    const char* compressions[] = {"none",  "rle", "zips", "zip",  "piz",
                                  "pxr24", "b44", "b44a", "dwaa", "dwab"};
    const std::array<float, 8> chromaticities{0.713f, 0.293f, 0.165f,   0.830f,
                                              0.128f, 0.044f, 0.32168f, 0.33767f};
    const int w = 37, h = 19;
    int index = 0;
    for (const std::vector<std::string>& names : channelSets)
        for (OIIO::TypeDesc type : {OIIO::TypeDesc::FLOAT, OIIO::TypeDesc::HALF})
            for (bool tiled : {false, true}) {
                const char* compression = compressions[index % std::size(compressions)];
                const std::string path = file("case" + std::to_string(index++) + ".exr");
                const int n = int(names.size());
                std::vector<float> data = mixedFloats(size_t(w * h * n), uint64_t(index));
                writeOiio(path, w, h, names[0].empty() ? std::vector<std::string>{} : names, n, type, data,
                          [&](OIIO::ImageSpec& spec) {
                              spec.x = -3;
                              spec.y = 5;
                              spec.full_x = spec.x;
                              spec.full_y = spec.y;
                              spec.full_width = w;
                              spec.full_height = h;
                              spec.attribute("compression", compression);
                              if (tiled) spec.tile_width = spec.tile_height = 16;
                              if (index % 3 == 0)
                                  spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8),
                                                 chromaticities.data());
                          });
                SCOPED_TRACE(std::string(compression) + (tiled ? " tiled " : " scanlines ") + type.c_str());
                expectSameAsOiio(path);
            }
}

// Unsigned integer channels: OpenImageIO normalized them to [0, 1] (divided by 2^32 - 1), which
// the decoder does too (OpenEXR itself would give the integers as floats); mixed with float and
// half channels in one file.
TEST_F(Codecs, ExrUnsignedChannelsAreNormalizedAsOpenImageIoDid) {
    const int w = 9, h = 3;
    Imf::Header header(w, h);
    header.channels().insert("R", Imf::Channel(Imf::UINT));
    header.channels().insert("G", Imf::Channel(Imf::FLOAT));
    header.channels().insert("B", Imf::Channel(Imf::HALF));
    std::vector<uint32_t> r = {0u, 1u, 7u, 255u, 65535u, 16777217u, 2147483648u, 4294967294u, 4294967295u};
    Numbers numbers(3);
    while (r.size() < size_t(w * h))
        r.push_back(numbers.next());
    std::vector<float> g = mixedFloats(size_t(w * h), 4);
    std::vector<Imath::half> b(size_t(w * h));
    for (size_t i = 0; i < b.size(); ++i)
        b[i] = Imath::half(g[i]);
    {
        Imf::OutputFile out(file("uint.exr").c_str(), header);
        Imf::FrameBuffer frame;
        frame.insert("R", Imf::Slice(Imf::UINT, reinterpret_cast<char*>(r.data()), 4, 4 * w));
        frame.insert("G", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(g.data()), 4, 4 * w));
        frame.insert("B", Imf::Slice(Imf::HALF, reinterpret_cast<char*>(b.data()), 2, 2 * w));
        out.setFrameBuffer(frame);
        out.writePixels(h);
    }
    expectSameAsOiio(file("uint.exr"));
}

// The image is the display window: pixels the data window leaves out of it are black (OpenEXR's
// definition), and those it holds past it (overscan) are cut off. Display window (0, 0) to (7, 69);
// data window (2, -2) to (15, 67): two black columns on the left, two black rows at the bottom,
// overscan right and above, and 68 rows read a strip of 64 at a time, so that the strips' edge is
// crossed. Scanlines and 16 x 16 tiles, float and half (the values are integers below 2048, exact
// in half). A data window beside the display window stores none of its pixels: refused.
TEST_F(Codecs, ExrDisplayWindowIsTheImage) {
    const int x0 = 2, y0 = -2, w = 14, h = 70;
    const auto value = [](int x, int y, int c) { return float(((x - 2) + 14 * ((y + 2) % 45)) * 3 + c + 1); };
    std::vector<float> data(size_t(w * h * 3));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                data[size_t((y * w + x) * 3 + c)] = value(x + x0, y + y0, c);
    for (OIIO::TypeDesc type : {OIIO::TypeDesc::FLOAT, OIIO::TypeDesc::HALF})
        for (bool tiled : {false, true}) {
            SCOPED_TRACE(std::string(tiled ? "tiled " : "scanlines ") + type.c_str());
            writeOiio(file("windows.exr"), w, h, {}, 3, type, data, [&](OIIO::ImageSpec& spec) {
                spec.x = x0;
                spec.y = y0;
                spec.full_x = spec.full_y = 0;
                spec.full_width = 8;
                spec.full_height = 70;
                if (tiled) spec.tile_width = spec.tile_height = 16;
            });
            const Decoded decoded = decodeNative(file("windows.exr"));
            ASSERT_EQ(decoded.header.width, 8);
            ASSERT_EQ(decoded.header.height, 70);
            for (int y = 0; y < 70; ++y)
                for (int x = 0; x < 8; ++x)
                    for (int c = 0; c < 3; ++c)
                        ASSERT_EQ(decoded.values[size_t((y * 8 + x) * 3 + c)],
                                  x >= 2 && y <= 67 ? value(x, y, c) : 0.0f)
                            << "pixel " << x << ", " << y << ", channel " << c;
        }
    writeOiio(file("beside.exr"), w, h, {}, 3, OIIO::TypeDesc::FLOAT, data, [](OIIO::ImageSpec& spec) {
        spec.x = 20;
        spec.full_x = spec.full_y = spec.y = 0;
        spec.full_width = 8;
        spec.full_height = 6;
    });
    try {
        decodeNative(file("beside.exr"));
        ADD_FAILURE() << "a file that stores no pixel of its image was read";
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Input);
        EXPECT_NE(std::string(error.what()).find("no pixel of the image is stored"), std::string::npos)
            << error.what();
    }
}

// A multi-part file: the first part is the image (OpenImageIO's subimage 0).
TEST_F(Codecs, ExrFirstPartOfAMultiPartFile) {
    const int w = 8, h = 4;
    std::vector<float> first = mixedFloats(w * h * 3, 5), second = mixedFloats(w * h * 4, 6);
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create("exr");
    ASSERT_TRUE(output);
    std::array<OIIO::ImageSpec, 2> specs{OIIO::ImageSpec(w, h, 3, OIIO::TypeDesc::FLOAT),
                                         OIIO::ImageSpec(w, h, 4, OIIO::TypeDesc::HALF)};
    specs[0].attribute("oiio:subimagename", "beauty");
    specs[1].attribute("oiio:subimagename", "other");
    ASSERT_TRUE(output->open(file("parts.exr"), 2, specs.data())) << output->geterror();
    ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, first.data())) << output->geterror();
    ASSERT_TRUE(output->open(file("parts.exr"), specs[1], OIIO::ImageOutput::AppendSubimage))
        << output->geterror();
    ASSERT_TRUE(output->write_image(OIIO::TypeDesc::FLOAT, second.data())) << output->geterror();
    ASSERT_TRUE(output->close());
    expectSameAsOiio(file("parts.exr"));
    EXPECT_EQ(decodeNative(file("parts.exr")).header.channels.size(), 3u);
}

// A MIP-mapped tiled texture (maketx's kind): its base level is the image.
TEST_F(Codecs, ExrBaseLevelOfAMipMappedTexture) {
    const int w = 40, h = 20;
    std::vector<float> data = mixedFloats(w * h * 3, 7);
    for (float& value : data)
        if (!std::isfinite(value)) value = 1.0f; // the MIP filter would spread them
    OIIO::ImageBuf source(OIIO::ImageSpec(w, h, 3, OIIO::TypeDesc::FLOAT), data.data());
    OIIO::ImageSpec config;
    config.tile_width = config.tile_height = 16;
    config.attribute("maketx:fileformatname", "exr");
    ASSERT_TRUE(
        OIIO::ImageBufAlgo::make_texture(OIIO::ImageBufAlgo::MakeTxTexture, source, file("tex.exr"), config))
        << OIIO::geterror();
    expectSameAsOiio(file("tex.exr"));
}

// Deep files say so in the header (readImage refuses them there); their pixels are not read.
TEST_F(Codecs, ExrDeepFilesAreToldFromTheHeader) {
    OIIO::ImageSpec spec(4, 2, 2, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"R", "Z"};
    spec.deep = true;
    OIIO::DeepData deep(spec);
    for (int p = 0; p < 8; ++p) {
        deep.set_samples(p, 1);
        deep.set_deep_value(p, 0, 0, 0.5f);
        deep.set_deep_value(p, 1, 0, 2.0f);
    }
    std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create("exr");
    ASSERT_TRUE(output->open(file("deep.exr"), spec)) << output->geterror();
    ASSERT_TRUE(output->write_deep_image(deep)) << output->geterror();
    ASSERT_TRUE(output->close());
    expectSameAsOiio(file("deep.exr"));
    std::unique_ptr<ImageDecoder> decoder = openExrDecoder(file("deep.exr"));
    EXPECT_TRUE(decoder->header().volumeOrDeep);
    std::vector<float> texels(4 * 8);
    EXPECT_CONTAINS(inputErrorOf([&] { decoder->readChannels(0, 1, texels.data()); }), "deep");
}

// Subsampled channels (OpenEXR's luminance/chroma files keep RY, BY at half resolution) are refused
// as they were before: OpenImageIO could not read them.
TEST_F(Codecs, ExrSubsampledChannelsAreRefused) {
    const int w = 8, h = 4;
    Imf::Header header(w, h);
    header.channels().insert("Y", Imf::Channel(Imf::HALF));
    header.channels().insert("RY", Imf::Channel(Imf::HALF, 2, 2));
    header.channels().insert("BY", Imf::Channel(Imf::HALF, 2, 2));
    {
        std::vector<Imath::half> y(w * h, Imath::half(0.5f)), chroma(w * h / 4, Imath::half(0.0f));
        Imf::OutputFile out(file("yc.exr").c_str(), header);
        Imf::FrameBuffer frame;
        frame.insert("Y", Imf::Slice(Imf::HALF, reinterpret_cast<char*>(y.data()), 2, 2 * w));
        frame.insert("RY", Imf::Slice(Imf::HALF, reinterpret_cast<char*>(chroma.data()), 2, w, 2, 2));
        frame.insert("BY", Imf::Slice(Imf::HALF, reinterpret_cast<char*>(chroma.data()), 2, w, 2, 2));
        out.setFrameBuffer(frame);
        out.writePixels(h);
    }
    std::string message = inputErrorOf([&] { openExrDecoder(file("yc.exr")); });
    EXPECT_CONTAINS(message, file("yc.exr") + ": channel BY is subsampled (2 x 2)");
    EXPECT_CONTAINS(message,
                    "shprobe reads only full-resolution EXR channels; store the image at full resolution");
    EXPECT_EQ(message.find("OpenImageIO"), std::string::npos) << message;
}

// The messages test_bad_inputs and test_environment expect: a file cut in its pixels is
// "truncated", one cut in its header is "not an image"; OpenImageIO fails on both too.
TEST_F(Codecs, ExrCutShortSaysWhere) {
    std::vector<float> data = mixedFloats(64 * 32 * 3, 8);
    writeOiio(file("full.exr"), 64, 32, {}, 3, OIIO::TypeDesc::FLOAT, data);
    const uintmax_t size = fs::file_size(file("full.exr"));
    for (uintmax_t cut : {size - 10, size - 40, size / 2}) {
        cutFile(file("full.exr"), file("short.exr"), cut);
        std::unique_ptr<ImageDecoder> decoder = openExrDecoder(file("short.exr"));
        std::vector<float> texels(4 * 64 * 32);
        std::string message = inputErrorOf([&] { decoder->readChannels(0, 3, texels.data()); });
        EXPECT_CONTAINS(message, file("short.exr") +
                                     ": cannot read the pixels; the file may be truncated or corrupt (");
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
    cutFile(file("full.exr"), file("head.exr"), 200);
    std::string message = inputErrorOf([&] { openExrDecoder(file("head.exr")); });
    EXPECT_CONTAINS(message, file("head.exr") + ": not an image the EXR reader can read (");
    EXPECT_FALSE(OIIO::ImageInput::open(file("head.exr"))) << "OpenImageIO refuses it too";
    OIIO::geterror();
    writeBytes(file("notes.exr"), "These are not pixels.\n");
    EXPECT_CONTAINS(inputErrorOf([&] { openExrDecoder(file("notes.exr")); }),
                    "not an image the EXR reader can read");
}

// A file up to kExrBytesReadWhole in large chunks is read whole and decoded where its chunks lie;
// a larger one, or one in small chunks, as a stream. The same pixels stored both ways (PIZ: a few
// MiB, read whole; uncompressed: 18 MiB) decode to the same bits, and each, cut short, says so in
// the same words: OpenEXR's own for a file that ends early.
TEST_F(Codecs, ExrReadWholeOrAsAStreamDecodesAlike) {
    const int w = 2048, h = 768;
    // Rows of every kind of float, each row the one before moved by one texel: PIZ finds it again.
    const std::vector<float> row = mixedFloats(size_t(w + h) * 3, 12);
    std::vector<float> data;
    for (int y = 0; y < h; ++y)
        data.insert(data.end(), row.begin() + 3 * y, row.begin() + 3 * (y + w));
    auto compression = [](const char* name) {
        return [name](OIIO::ImageSpec& spec) { spec.attribute("compression", name); };
    };
    writeOiio(file("whole.exr"), w, h, {}, 3, OIIO::TypeDesc::FLOAT, data, compression("piz"));
    writeOiio(file("stream.exr"), w, h, {}, 3, OIIO::TypeDesc::FLOAT, data, compression("none"));
    ASSERT_LE(fs::file_size(file("whole.exr")), uintmax_t(kExrBytesReadWhole));
    ASSERT_GT(fs::file_size(file("stream.exr")), uintmax_t(kExrBytesReadWhole));
    std::vector<std::vector<float>> decoded;
    for (const char* name : {"whole.exr", "stream.exr"}) {
        std::vector<float> texels(size_t(w) * h * 4);
        openExrDecoder(file(name))->readChannels(0, 3, texels.data());
        decoded.push_back(std::move(texels));
    }
    EXPECT_EQ(std::memcmp(decoded[0].data(), decoded[1].data(), decoded[0].size() * sizeof(float)), 0);
    for (size_t t : {size_t(0), size_t(w) * h / 2 + 17, size_t(w) * h - 1})
        EXPECT_EQ(std::memcmp(&decoded[1][4 * t], &data[3 * t], 3 * sizeof(float)), 0) << "texel " << t;
    for (const char* name : {"whole.exr", "stream.exr"}) {
        cutFile(file(name), file("cut.exr"), fs::file_size(file(name)) * 3 / 4);
        std::vector<float> texels(size_t(w) * h * 4);
        std::unique_ptr<ImageDecoder> decoder = openExrDecoder(file("cut.exr"));
        const std::string message = inputErrorOf([&] { decoder->readChannels(0, 3, texels.data()); });
        EXPECT_CONTAINS(message,
                        file("cut.exr") + ": cannot read the pixels; the file may be truncated or corrupt (");
        EXPECT_CONTAINS(message, "Early end of file: read ");
    }
}

// A small uncompressed file whose last chunk says it holds 4 bytes, where its line takes 768, and
// ends there: OpenEXR 3.1 takes such a chunk as it is and copies a whole line from it, so the file
// is read as a stream, where that line comes from OpenEXR's own buffer and not from past the end
// of the file's bytes. What can be seen of it: the file decodes or is refused in one line naming
// it, and every line but the damaged one decodes to its values. (The overrun itself, were the file
// read whole, is in OpenEXR's uninstrumented copy: AddressSanitizer does not see it.)
TEST_F(Codecs, ExrShortUncompressedChunkStaysInItsBuffer) {
    const int w = 64, h = 32;
    const std::vector<float> data = mixedFloats(size_t(w) * h * 3, 13);
    writeOiio(file("flat.exr"), w, h, {}, 3, OIIO::TypeDesc::FLOAT, data,
              [](OIIO::ImageSpec& spec) { spec.attribute("compression", "none"); });
    std::string bytes = readBytes(file("flat.exr"));
    const size_t lineBytes = size_t(w) * 3 * sizeof(float);
    ASSERT_GT(bytes.size(), lineBytes + 8);
    const size_t last = bytes.size() - lineBytes - 8; // the last chunk: its y, its size, its line
    const int32_t claimed = 4;
    std::memcpy(&bytes[last + 4], &claimed, sizeof claimed);
    writeBytes(file("short-chunk.exr"), bytes.substr(0, last + 8 + size_t(claimed)));
    std::vector<float> texels(size_t(w) * h * 4);
    try {
        openExrDecoder(file("short-chunk.exr"))->readChannels(0, 3, texels.data());
    } catch (const Error& error) {
        EXPECT_CONTAINS(std::string(error.what()), file("short-chunk.exr"));
        EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos);
        return;
    }
    for (size_t t = 0; t < size_t(w) * (h - 1); ++t)
        ASSERT_EQ(std::memcmp(&texels[4 * t], &data[3 * t], 3 * sizeof(float)), 0) << "texel " << t;
}

// ---- Radiance HDR ----------------------------------------------------------------------------------

// OpenImageIO writes run-length-encoded scanlines for widths 8 to 32767 and flat ones otherwise;
// both decode to what it reads, bit for bit (the same RGBE-to-float rule: mantissa 2^(e-136)).
// "#?RGBE", the other program type stb_image accepts, reads the same.
TEST_F(Codecs, HdrFilesOpenImageIoWritesDecodeAsItReadsThem) {
    for (int w : {64, 7, 300}) {
        const int h = 5;
        Numbers numbers{uint64_t(w)};
        std::vector<float> data(size_t(w * h * 3));
        for (size_t i = 0; i < data.size(); ++i)
            data[i] = i % 11 == 0 ? 0.0f : float(std::pow(10.0, numbers.unit() * 12.0 - 6.0));
        const std::string path = file("w" + std::to_string(w) + ".hdr");
        writeOiio(path, w, h, {}, 3, OIIO::TypeDesc::FLOAT, data);
        expectSameAsOiio(path);
        std::string bytes = readBytes(path);
        ASSERT_EQ(bytes.rfind("#?RADIANCE\n", 0), 0u);
        writeBytes(file("rgbe.hdr"), "#?RGBE\n" + bytes.substr(11));
        EXPECT_EQ(decodeNative(file("rgbe.hdr")).values, decodeNative(path).values);
    }
}

// stb_image reads zeros past the end of a file; the decoder says the file is cut instead, as
// OpenImageIO did ("Read error on scanline N"). A format stb_image does not read is not an image.
TEST_F(Codecs, HdrCutShortIsTruncated) {
    std::vector<float> data = mixedFloats(64 * 32 * 3, 9);
    for (float& value : data)
        value = std::isfinite(value) ? std::abs(value) : 1.0f;
    writeOiio(file("full.hdr"), 64, 32, {}, 3, OIIO::TypeDesc::FLOAT, data);
    const uintmax_t size = fs::file_size(file("full.hdr"));
    for (uintmax_t cut : {size - 1, size * 6 / 10}) {
        cutFile(file("full.hdr"), file("cut.hdr"), cut);
        std::unique_ptr<ImageDecoder> decoder = openStbDecoder(file("cut.hdr"), ImageFormat::Hdr);
        std::vector<float> texels(4 * 64 * 32);
        std::string message = inputErrorOf([&] { decoder->readChannels(0, 3, texels.data()); });
        EXPECT_CONTAINS(message,
                        file("cut.hdr") + ": cannot read the pixels; the file may be truncated or corrupt (");
        EXPECT_CONTAINS(message, "end of file");
    }
    // A run-length count of 0, on which stb_image 2.27 would loop for ever (it reads no byte and
    // moves on by none), is refused.
    writeBytes(file("zero.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n" +
                                     std::string("\x02\x02\x00\x08\x00", 5) + std::string(64, '\x01'));
    std::unique_ptr<ImageDecoder> zero = openStbDecoder(file("zero.hdr"), ImageFormat::Hdr);
    std::vector<float> texels(4 * 8);
    EXPECT_CONTAINS(inputErrorOf([&] { zero->readChannels(0, 3, texels.data()); }),
                    file("zero.hdr") +
                        ": cannot read the pixels; the file may be truncated or corrupt (scanline 0 "
                        "holds a run of length 0)");
    writeBytes(file("bad.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 2 +X 2\n");
    EXPECT_CONTAINS(inputErrorOf([&] { openStbDecoder(file("bad.hdr"), ImageFormat::Hdr); }),
                    file("bad.hdr") + ": not a Radiance HDR image (");
}

// ---- PNG -------------------------------------------------------------------------------------------

// 8- and 16-bit grey, grey and alpha, RGB and RGBA as OpenImageIO writes them, every value of the
// bit depth in every channel: the decoder's floats (value / 255 or / 65535, as OpenImageIO
// converts) are OpenImageIO's bit for bit. Also a PNG it writes as linear (gAMA 1, and its own
// tEXt oiio:ColorSpace), which must be read as linear.
TEST_F(Codecs, PngFilesOpenImageIoWritesDecodeAsItReadsThem) {
    for (int channels = 1; channels <= 4; ++channels) {
        const int w8 = 64, h8 = 8; // 512 pixels: each of 256 values twice per channel
        std::vector<uint8_t> bytes(size_t(w8 * h8 * channels));
        for (size_t i = 0; i < bytes.size(); ++i)
            bytes[i] = uint8_t((i / size_t(channels)) * size_t(2 * (i % size_t(channels)) + 1) +
                               i % size_t(channels) * 7);
        writeOiio(file("8.png"), w8, h8, {}, channels, OIIO::TypeDesc::UINT8, bytes);
        expectSameAsOiio(file("8.png"));

        const int w16 = 256, h16 = 256; // every 16-bit value once per channel
        std::vector<uint16_t> words(size_t(w16 * h16 * channels));
        for (size_t i = 0; i < words.size(); ++i)
            words[i] = uint16_t((i / size_t(channels)) * size_t(2 * (i % size_t(channels)) + 1) +
                                i % size_t(channels) * 12345);
        writeOiio(file("16.png"), w16, h16, {}, channels, OIIO::TypeDesc::UINT16, words);
        expectSameAsOiio(file("16.png"));
    }
    std::vector<uint8_t> bytes(48);
    for (size_t i = 0; i < bytes.size(); ++i)
        bytes[i] = uint8_t(i * 5);
    writeOiio(file("linear.png"), 4, 4, {}, 3, OIIO::TypeDesc::UINT8, bytes,
              [](OIIO::ImageSpec& spec) { spec.attribute("oiio:ColorSpace", "linear"); });
    expectSameAsOiio(file("linear.png"));
    EXPECT_FALSE(decodeNative(file("linear.png")).header.srgb);
}

// PNG files put together here chunk by chunk, for what OpenImageIO does not write: palettes, bit
// depths 1, 2 and 4, transparency (tRNS, which libpng made an alpha channel), Adam7 interlacing,
// IDAT split over chunks, ancillary chunks after the pixels, and colour-space chunks. The pixels
// are deflated as stored blocks (RFC 1951, 3.2.4), every row with filter 0.
std::string storedZlib(const std::string& data) {
    std::string out("\x78\x01", 2);
    size_t at = 0;
    do {
        const size_t n = std::min<size_t>(65535, data.size() - at);
        const bool last = at + n == data.size();
        out += char(last ? 1 : 0);
        out += {char(n & 0xff), char(n >> 8), char(~n & 0xff), char((~n >> 8) & 0xff)};
        out += data.substr(at, n);
        at += n;
    } while (at < data.size());
    uint32_t a = 1, b = 0;
    for (unsigned char byte : data) {
        a = (a + byte) % 65521;
        b = (b + a) % 65521;
    }
    return out + bigEndian32(b << 16 | a);
}

struct PngSpec {
    int width = 5, height = 3;
    int depth = 8;
    int colourType = 2; // 0 grey, 2 RGB, 3 palette, 4 grey+alpha, 6 RGBA
    bool interlaced = false;
    std::string beforePixels; // chunks between IHDR and IDAT (PLTE, tRNS, gAMA, ...)
    std::string afterPixels;  // chunks between the last IDAT and IEND
    int idatChunks = 1;
};

int samplesPerPixel(int colourType) {
    return colourType == 0 || colourType == 3 ? 1 : colourType == 2 ? 3 : colourType == 4 ? 2 : 4;
}

// The sample values: distinct, within the bit depth (palette indices within `paletteSize`).
uint32_t sampleValue(const PngSpec& spec, int x, int y, int c, int paletteSize) {
    const uint32_t range = spec.colourType == 3 ? uint32_t(paletteSize) : (1u << spec.depth);
    return uint32_t(x * 7 + y * 13 + c * 5 + (x * y) % 3) * (spec.depth == 16 ? 4099u : 1u) % range;
}

std::string pngFile(const PngSpec& spec, int paletteSize = 256) {
    struct Pass {
        int x0, y0, dx, dy;
    };
    const std::vector<Pass> passes =
        spec.interlaced ? std::vector<Pass>{{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                                            {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}}
                        : std::vector<Pass>{{0, 0, 1, 1}};
    const int samples = samplesPerPixel(spec.colourType);
    std::string raw;
    for (const Pass& pass : passes) {
        const int pw = spec.width > pass.x0 ? (spec.width - pass.x0 + pass.dx - 1) / pass.dx : 0;
        const int ph = spec.height > pass.y0 ? (spec.height - pass.y0 + pass.dy - 1) / pass.dy : 0;
        if (pw == 0 || ph == 0) continue;
        for (int py = 0; py < ph; ++py) {
            raw += '\0'; // filter type 0
            uint32_t bits = 0;
            int count = 0;
            for (int px = 0; px < pw; ++px)
                for (int c = 0; c < samples; ++c) {
                    uint32_t value =
                        sampleValue(spec, pass.x0 + px * pass.dx, pass.y0 + py * pass.dy, c, paletteSize);
                    if (spec.depth == 16) {
                        raw += {char(value >> 8), char(value & 0xff)};
                    } else if (spec.depth == 8) {
                        raw += char(value);
                    } else {
                        bits = bits << spec.depth | value;
                        count += spec.depth;
                        if (count == 8) {
                            raw += char(bits);
                            bits = 0;
                            count = 0;
                        }
                    }
                }
            if (count > 0) raw += char(bits << (8 - count));
        }
    }
    const std::string zlib = storedZlib(raw);
    std::string idat;
    const size_t part = (zlib.size() + size_t(spec.idatChunks) - 1) / size_t(spec.idatChunks);
    for (size_t at = 0; at < zlib.size(); at += part)
        idat += pngChunk("IDAT", zlib.substr(at, part));
    const std::string ihdr = bigEndian32(uint32_t(spec.width)) + bigEndian32(uint32_t(spec.height)) +
                             char(spec.depth) + char(spec.colourType) + '\0' + '\0' + char(spec.interlaced);
    return std::string("\x89PNG\r\n\x1a\n", 8) + pngChunk("IHDR", ihdr) + spec.beforePixels + idat +
           spec.afterPixels + pngChunk("IEND", "");
}

std::string palette(int entries) {
    std::string data;
    for (int i = 0; i < entries; ++i)
        data += {char(i * 37), char(255 - i * 11), char(i * i)};
    return pngChunk("PLTE", data);
}

TEST_F(Codecs, PngVariantsDecodeAsOpenImageIoReadsThem) {
    auto u16 = [](uint32_t value) { return std::string{char(value >> 8), char(value & 0xff)}; };
    struct Case {
        std::string name;
        PngSpec spec;
        int paletteSize = 256;
    };
    std::vector<Case> cases;
    for (int depth : {1, 2, 4, 8, 16})
        cases.push_back({"grey" + std::to_string(depth), {13, 5, depth, 0}});
    cases.push_back({"grey4-trns", {13, 5, 4, 0, false, pngChunk("tRNS", u16(3))}});
    cases.push_back({"grey16-trns", {13, 5, 16, 0, false, pngChunk("tRNS", u16(4099))}});
    cases.push_back({"rgb8-trns", {13, 5, 8, 2, false, pngChunk("tRNS", u16(7) + u16(13) + u16(5))}});
    cases.push_back({"rgb16-trns", {13, 5, 16, 2, false, pngChunk("tRNS", u16(0) + u16(4099) + u16(8198))}});
    cases.push_back({"ga16", {13, 5, 16, 4}});
    cases.push_back({"rgba16", {13, 5, 16, 6}});
    for (int depth : {1, 2, 4, 8}) {
        const int entries = 1 << std::min(depth, 5);
        cases.push_back(
            {"palette" + std::to_string(depth), {13, 5, depth, 3, false, palette(entries)}, entries});
        cases.push_back(
            {"palette" + std::to_string(depth) + "-trns",
             {13, 5, depth, 3, false, palette(entries) + pngChunk("tRNS", std::string("\x00\x80\xff", 3))},
             entries});
    }
    // tRNS chunks libpng ignores (a warning), and so must the decoder: longer than the palette
    // (also palette1-trns above: 3 entries for 2 colours), before PLTE, with an alpha channel, of
    // the wrong length, a second one, one after the pixels.
    cases.push_back(
        {"trns-long", {13, 5, 2, 3, false, palette(4) + pngChunk("tRNS", std::string(5, '\x40'))}, 4});
    cases.push_back({"trns-before-plte", {13, 5, 2, 3, false, pngChunk("tRNS", "\x10") + palette(4)}, 4});
    cases.push_back({"trns-rgba", {13, 5, 8, 6, false, pngChunk("tRNS", u16(1) + u16(2) + u16(3))}});
    cases.push_back({"trns-grey-wrong-length", {13, 5, 8, 0, false, pngChunk("tRNS", u16(1) + u16(2))}});
    cases.push_back(
        {"trns-twice", {13, 5, 8, 0, false, pngChunk("tRNS", u16(3)) + pngChunk("tRNS", u16(4))}});
    cases.push_back({"trns-after-idat", {13, 5, 8, 0, false, "", pngChunk("tRNS", u16(3))}});
    cases.push_back({"trns-bad-crc", {13, 5, 8, 0, false, pngChunk("tRNS", u16(3), 1)}});
    cases.push_back({"adam7-rgb", {13, 11, 8, 2, true}});
    cases.push_back({"adam7-grey1", {13, 11, 1, 0, true}});
    cases.push_back({"adam7-palette4", {3, 2, 4, 3, true, palette(16)}, 16});
    cases.push_back(
        {"split-idat", {13, 5, 8, 6, false, "", pngChunk("tEXt", std::string("Comment\0after", 13)), 4}});
    // Colour spaces: sRGB, else gAMA 1 (within OpenImageIO's rounding of 1/gamma to hundredths) is
    // linear, else sRGB; OpenImageIO's own tEXt oiio:ColorSpace wins over both; gAMA out of
    // libpng's range is ignored, as is an ancillary chunk with a bad CRC.
    for (uint32_t gamma : {45455u, 50000u, 99502u, 99503u, 100000u, 100502u, 100503u, 0u, 10u})
        cases.push_back(
            {"gama" + std::to_string(gamma), {4, 2, 8, 2, false, pngChunk("gAMA", bigEndian32(gamma))}});
    cases.push_back({"srgb-and-gama1",
                     {4, 2, 8, 2, false,
                      pngChunk("sRGB", std::string(1, '\0')) + pngChunk("gAMA", bigEndian32(100000))}});
    cases.push_back(
        {"text-linear", {4, 2, 8, 2, false, pngChunk("tEXt", std::string("oiio:ColorSpace\0Linear", 22))}});
    cases.push_back({"text-srgb-gama1",
                     {4, 2, 8, 2, false,
                      pngChunk("gAMA", bigEndian32(100000)) +
                          pngChunk("tEXt", std::string("oiio:ColorSpace\0sRGB", 20))}});
    cases.push_back({"gama1-bad-crc", {4, 2, 8, 2, false, pngChunk("gAMA", bigEndian32(100000), 1)}});
    for (const Case& c : cases) {
        const std::string path = file(c.name + ".png");
        writeBytes(path, pngFile(c.spec, c.paletteSize));
        expectSameAsOiio(path);
    }
}

// A critical chunk with a bad CRC fails as libpng failed (IHDR on opening, IDAT on reading the
// pixels); so does an unknown critical chunk. OpenImageIO fails on each as well.
TEST_F(Codecs, PngCorruptChunksAreRefused) {
    PngSpec spec{13, 5, 8, 2};
    std::string good = pngFile(spec);
    std::string badHeader = good;
    badHeader[8 + 8 + 13 + 3] ^= 1; // IHDR's CRC
    writeBytes(file("ihdr.png"), badHeader);
    EXPECT_CONTAINS(inputErrorOf([&] { openStbDecoder(file("ihdr.png"), ImageFormat::Png); }),
                    file("ihdr.png") + ": not a PNG image (IHDR: CRC error)");
    EXPECT_FALSE(OIIO::ImageInput::open(file("ihdr.png")));
    OIIO::geterror();

    std::string badPixels = good;
    badPixels[good.find("IEND") - 5] ^= 1; // IDAT's CRC
    writeBytes(file("idat.png"), badPixels);
    std::unique_ptr<ImageDecoder> decoder = openStbDecoder(file("idat.png"), ImageFormat::Png);
    std::vector<float> texels(4 * 13 * 5);
    EXPECT_CONTAINS(inputErrorOf([&] { decoder->readChannels(0, 3, texels.data()); }),
                    file("idat.png") +
                        ": cannot read the pixels; the file may be truncated or corrupt (IDAT: CRC error)");
    {
        std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(file("idat.png"));
        ASSERT_TRUE(input);
        EXPECT_FALSE(input->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, texels.data()));
        input->geterror();
    }

    spec.beforePixels = pngChunk("ABCD", "x");
    writeBytes(file("unknown.png"), pngFile(spec));
    EXPECT_CONTAINS(inputErrorOf([&] { openStbDecoder(file("unknown.png"), ImageFormat::Png); }),
                    "ABCD: unknown critical chunk");
    EXPECT_FALSE(OIIO::ImageInput::open(file("unknown.png")));
    OIIO::geterror();
}

// A PNG cut in its pixels: "truncated" and libpng's "end of file", the words test_bad_inputs
// expects; OpenImageIO fails on it too. Cut after the pixels (in IEND), it reads as OpenImageIO
// read it: whole (libpng stopped after the last IDAT). Cut in its header, it is not an image.
TEST_F(Codecs, PngCutShortSaysEndOfFile) {
    std::vector<uint8_t> noise(64 * 32 * 3);
    Numbers numbers(10);
    for (uint8_t& byte : noise)
        byte = uint8_t(numbers.next());
    writeOiio(file("full.png"), 64, 32, {}, 3, OIIO::TypeDesc::UINT8, noise);
    const uintmax_t size = fs::file_size(file("full.png"));
    for (uintmax_t cut : {size * 6 / 10, size / 2, size - 13}) {
        cutFile(file("full.png"), file("cut.png"), cut);
        std::unique_ptr<ImageDecoder> decoder = openStbDecoder(file("cut.png"), ImageFormat::Png);
        std::vector<float> texels(4 * 64 * 32);
        std::string message = inputErrorOf([&] { decoder->readChannels(0, 3, texels.data()); });
        EXPECT_CONTAINS(message,
                        file("cut.png") + ": cannot read the pixels; the file may be truncated or corrupt (");
        EXPECT_CONTAINS(message, "end of file");
        [[maybe_unused]] LibraryLeaksIgnored leaks;
        std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(file("cut.png"));
        ASSERT_TRUE(input);
        EXPECT_FALSE(input->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, texels.data())) << cut;
        input->geterror();
    }
    for (uintmax_t cut : {size - 1, size - 8, size - 12}) {
        cutFile(file("full.png"), file("cut.png"), cut);
        expectSameAsOiio(file("cut.png"));
    }
    cutFile(file("full.png"), file("head.png"), 20);
    EXPECT_CONTAINS(inputErrorOf([&] { openStbDecoder(file("head.png"), ImageFormat::Png); }),
                    file("head.png") + ": not a PNG image (the file ends before its first IDAT chunk");
}

// ---- JPEG ------------------------------------------------------------------------------------------

// Grey and colour JPEGs with each chroma subsampling OpenImageIO writes, baseline and progressive:
// the header is OpenImageIO's exactly, the pixels within 3/255 of what it reads. stb_image's
// inverse DCT, YCbCr-to-RGB conversion and chroma upsampling are not libjpeg-turbo's and round
// differently (measured: 1/255 for grey, 2/255 for colour at 4:4:4, 3/255 at 4:2:0 and 4:2:2).
// At 4:2:2, the column of the last chroma sample's left half is left out: there stb_image's
// horizontal upsampler (stbi__resample_row_h_2) weighs the last two chroma samples the other way
// round (3/4 the one before last), and differs by up to 25/255 on this image.
TEST_F(Codecs, JpegFilesOpenImageIoWritesDecodeWithinThreeLevels) {
    const int w = 61, h = 37;
    for (int channels : {1, 3})
        for (const char* subsampling : {"4:4:4", "4:2:2", "4:2:0"})
            for (bool progressive : {false, true}) {
                if (channels == 1 && std::string(subsampling) != "4:4:4") continue;
                std::vector<uint8_t> bytes(size_t(w * h * channels));
                for (int y = 0; y < h; ++y)
                    for (int x = 0; x < w; ++x)
                        for (int c = 0; c < channels; ++c)
                            bytes[size_t((y * w + x) * channels + c)] =
                                uint8_t(127.5 + 120.0 * std::sin(0.11 * x * (c + 1) + 0.07 * y) *
                                                    std::cos(0.05 * y * (c + 2)));
                const std::string path = file("image.jpg");
                writeOiio(path, w, h, {}, channels, OIIO::TypeDesc::UINT8, bytes, [&](OIIO::ImageSpec& spec) {
                    spec.attribute("jpeg:subsampling", subsampling);
                    spec.attribute("jpeg:progressive", int(progressive));
                    spec.attribute("CompressionQuality", 90);
                });
                SCOPED_TRACE(std::to_string(channels) + " channels " + subsampling +
                             (progressive ? " progressive" : ""));
                const int chromaWidth = (w + 1) / 2;
                const int columns = std::string(subsampling) == "4:2:2" ? 2 * (chromaWidth - 1) : w;
                const float worst = expectSameAsOiio(path, 3.0f / 255.0f + 1e-6f, columns);
                std::printf("JPEG %d channel(s) %s%s: at most %.0f/255 from OpenImageIO\n", channels,
                            subsampling, progressive ? " progressive" : "", worst * 255.0f);
            }
}

// A JPEG cut short: stb_image (like libjpeg, where OpenImageIO only warned and filled the rest
// with grey) would decode it; the decoder refuses it instead, as an image half grey would bake
// into a wrong probe.
TEST_F(Codecs, JpegCutShortIsTruncated) {
    std::vector<uint8_t> noise(64 * 32 * 3);
    Numbers numbers(11);
    for (uint8_t& byte : noise)
        byte = uint8_t(numbers.next());
    writeOiio(file("full.jpg"), 64, 32, {}, 3, OIIO::TypeDesc::UINT8, noise,
              [](OIIO::ImageSpec& spec) { spec.attribute("jpeg:subsampling", "4:4:4"); });
    expectSameAsOiio(file("full.jpg"), 3.0f / 255.0f + 1e-6f); // as above
    const uintmax_t size = fs::file_size(file("full.jpg"));
    for (uintmax_t cut : {size * 6 / 10, size - 2}) {
        cutFile(file("full.jpg"), file("cut.jpg"), cut);
        std::unique_ptr<ImageDecoder> decoder = openStbDecoder(file("cut.jpg"), ImageFormat::Jpeg);
        std::vector<float> texels(4 * 64 * 32);
        std::string message = inputErrorOf([&] { decoder->readChannels(0, 3, texels.data()); });
        EXPECT_CONTAINS(message,
                        file("cut.jpg") + ": cannot read the pixels; the file may be truncated or corrupt (");
        EXPECT_CONTAINS(message, "end of file");
    }
    writeBytes(file("notes.jpg"), "\xff\xd8\xff not a JPEG");
    EXPECT_CONTAINS(inputErrorOf([&] { openStbDecoder(file("notes.jpg"), ImageFormat::Jpeg); }),
                    file("notes.jpg") + ": not a JPEG image (");
}

// ---- The encoders ----------------------------------------------------------------------------------

// 32-bit float, ZIP, scanlines in increasing y, channels Y / Y, A / R, G, B / R, G, B, A, from
// texels `pixelStride` apart: OpenImageIO reads back every value bit for bit (EXR float is exact),
// infinities, NaN and -0 included; and so does the decoder.
TEST_F(Codecs, ExrEncoderOutputReadsBackExactly) {
    const int w = 37, h = 19;
    const std::vector<std::vector<std::string>> names = {
        {"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    for (int channels = 1; channels <= 4; ++channels) {
        const int stride = channels == 4 ? 4 : channels + 1;
        std::vector<float> texels = mixedFloats(size_t(w * h * stride), uint64_t(20 + channels));
        const std::string bytes = encodeExr({w, h, channels, stride, texels.data()}, "out.exr");
        writeBytes(file("out.exr"), bytes);
        std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(file("out.exr"));
        ASSERT_TRUE(input) << OIIO::geterror();
        const OIIO::ImageSpec& spec = input->spec();
        EXPECT_EQ(spec.width, w);
        EXPECT_EQ(spec.height, h);
        EXPECT_EQ(spec.channelnames, names[size_t(channels - 1)]);
        EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
        EXPECT_EQ(spec.get_string_attribute("compression"), "zip");
        EXPECT_EQ(spec.tile_width, 0);
        Imf::InputFile exr(file("out.exr").c_str());
        EXPECT_EQ(exr.header().lineOrder(), Imf::INCREASING_Y);
        EXPECT_EQ(exr.header().compression(), Imf::ZIP_COMPRESSION);
        EXPECT_FALSE(exr.header().hasTileDescription());
        std::vector<float> back(size_t(w * h * channels));
        ASSERT_TRUE(input->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, back.data()));
        for (size_t p = 0; p < size_t(w * h); ++p)
            for (size_t c = 0; c < size_t(channels); ++c)
                ASSERT_EQ(std::bit_cast<uint32_t>(back[p * size_t(channels) + c]),
                          std::bit_cast<uint32_t>(texels[p * size_t(stride) + c]))
                    << "pixel " << p << " channel " << c;
        expectSameAsOiio(file("out.exr"));
    }
}

// RGBE keeps 8 bits of mantissa per channel under the pixel's largest channel's exponent e
// (largest = m 2^e, m in [0.5, 1)), and stb_image_write truncates: each channel comes back at
// most one step 2^e / 256 below its value (a step is at most 1/128 of the largest channel, and
// 1/256 of 2^e), never above. Negative and NaN values, which RGBE cannot hold, come back 0;
// infinity the largest finite value RGBE holds. The decoder reads the file as OpenImageIO does.
TEST_F(Codecs, HdrEncoderOutputReadsBackWithinOneRgbeStep) {
    const int w = 37, h = 19, stride = 4;
    Numbers numbers(30);
    std::vector<float> texels(size_t(w * h * stride));
    for (float& value : texels)
        value = float(std::pow(10.0, numbers.unit() * 16.0 - 8.0));
    texels[0] = -1.0f;
    texels[1] = std::numeric_limits<float>::quiet_NaN();
    texels[4] = std::numeric_limits<float>::infinity();
    texels[8] = texels[9] = texels[10] = 0.0f;
    writeBytes(file("out.hdr"), encodeHdr({w, h, 3, stride, texels.data()}, "out.hdr"));
    const Reference back = readOiio(file("out.hdr"));
    ASSERT_EQ(back.width, w);
    ASSERT_EQ(back.height, h);
    ASSERT_EQ(back.channels, (std::vector<std::string>{"R", "G", "B"}));
    EXPECT_EQ(back.values[0], 0.0f) << "negative";
    EXPECT_EQ(back.values[1], 0.0f) << "NaN";
    EXPECT_GT(back.values[3], 1e38f) << "infinity";
    EXPECT_TRUE(std::isfinite(back.values[3]));
    EXPECT_EQ(back.values[6], 0.0f);
    for (size_t p = 2; p < size_t(w * h); ++p) {
        const float* in = &texels[p * stride];
        const float largest = std::max({in[0], in[1], in[2]});
        int e = 0;
        std::frexp(largest, &e);
        const float step = std::ldexp(1.0f, e - 8);
        for (size_t c = 0; c < 3; ++c) {
            const float out = back.values[p * 3 + c];
            ASSERT_LE(out, in[c]) << "pixel " << p << " channel " << c;
            ASSERT_GT(out, in[c] - step) << "pixel " << p << " channel " << c;
        }
    }
    expectSameAsOiio(file("out.hdr"));
}

// PNG is lossless: OpenImageIO reads back every byte, for 1 to 4 channels from 4-byte texels.
// Written without colour-space chunks, the file reads as sRGB.
TEST_F(Codecs, PngEncoderOutputReadsBackExactly) {
    const int w = 61, h = 17, stride = 4;
    std::vector<uint8_t> texels(size_t(w * h * stride));
    Numbers numbers(40);
    for (uint8_t& byte : texels)
        byte = uint8_t(numbers.next());
    for (int channels = 1; channels <= 4; ++channels) {
        writeBytes(file("out.png"), encodePng({w, h, channels, stride, texels.data()}, "out.png"));
        OIIO::ImageSpec config;
        config.attribute("oiio:UnassociatedAlpha", 1); // colour as stored, not times alpha
        std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(file("out.png"), &config);
        ASSERT_TRUE(input) << OIIO::geterror();
        ASSERT_EQ(input->spec().nchannels, channels);
        ASSERT_EQ(input->spec().format, OIIO::TypeDesc::UINT8);
        std::vector<uint8_t> back(size_t(w * h * channels));
        ASSERT_TRUE(input->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, back.data()));
        for (size_t p = 0; p < size_t(w * h); ++p)
            for (size_t c = 0; c < size_t(channels); ++c)
                ASSERT_EQ(back[p * size_t(channels) + c], texels[p * stride + c])
                    << "pixel " << p << " channel " << c;
        expectSameAsOiio(file("out.png"));
        EXPECT_TRUE(decodeNative(file("out.png")).header.srgb);
    }
}

// JPEG at quality 95 is lossy: OpenImageIO's reading of the file is within 3/255 of the decoder's
// (the decoders' difference, as above), and within 6/255 of the image written, on a smooth image
// (measured: see the output; quality 95 keeps chroma at full resolution). stb_image_write writes
// every JPEG as colour (YCbCr): grey comes back as three equal channels.
TEST_F(Codecs, JpegEncoderOutputReadsBackClose) {
    const int w = 64, h = 40, stride = 4;
    std::vector<uint8_t> texels(size_t(w * h * stride));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < stride; ++c)
                texels[size_t((y * w + x) * stride + c)] =
                    uint8_t(128 + 100 * std::sin(0.1 * x + 0.2 * c) * std::cos(0.08 * y));
    for (int channels : {1, 3, 4}) {
        writeBytes(file("out.jpg"), encodeJpeg({w, h, channels, stride, texels.data()}, "out.jpg"));
        expectSameAsOiio(file("out.jpg"), 3.0f / 255.0f + 1e-6f);
        const Reference back = readOiio(file("out.jpg"));
        ASSERT_EQ(back.channels, (std::vector<std::string>{"R", "G", "B"}));
        EXPECT_TRUE(back.srgb);
        float worst = 0.0f;
        for (size_t p = 0; p < size_t(w * h); ++p)
            for (size_t c = 0; c < 3; ++c)
                worst = std::max(worst, std::abs(back.values[p * 3 + c] * 255.0f -
                                                 texels[p * stride + (channels == 1 ? 0 : c)]));
        EXPECT_LE(worst, 6.0f) << channels << " channels";
        std::printf("JPEG quality 95 from %d channel(s): at most %.0f/255 from the image written\n", channels,
                    worst);
    }
}

TEST(Encoders, RefuseWhatTheyCannotWrite) {
    const float floats[8] = {};
    const uint8_t bytes[8] = {};
    EXPECT_CONTAINS(outputErrorOf([&] { encodeExr({0, 1, 3, 4, floats}, "a.exr"); }), "cannot write a.exr: ");
    EXPECT_CONTAINS(outputErrorOf([&] { encodeHdr({1, 1, 3, 2, floats}, "a.hdr"); }), "cannot write a.hdr: ");
    EXPECT_CONTAINS(outputErrorOf([&] { encodePng({1, 1, 5, 5, bytes}, "a.png"); }), "cannot write a.png: ");
    EXPECT_CONTAINS(outputErrorOf([&] {
                        encodeJpeg({1, 1, 3, 4, nullptr}, "a.jpg");
                    }),
                    "cannot write a.jpg: ");
    EXPECT_CONTAINS(outputErrorOf([&] { encodePng({65536, 32768, 4, 4, bytes}, "big.png"); }), "too large");
}

// ---- Blender's studio lights -----------------------------------------------------------------------

// The eight equirect EXRs of blender-data (1024 x 512 float RGB, DWAB) decode exactly as
// OpenImageIO reads them. Times (best of 3, open and read, printed for docs/tests.md): the
// decoder on OpenEXR's pool of one thread per core and on none (setGlobalThreadCount(0)), and
// OpenImageIO.
TEST(BlenderStudioLights, DecodeExactlyAsOpenImageIoAndAreTimed) {
    const fs::path folder = "/usr/share/blender/datafiles/studiolights/world";
    if (!fs::is_directory(folder)) GTEST_SKIP() << folder << " is missing (Debian package blender-data)";
    std::vector<fs::path> paths;
    for (const fs::directory_entry& entry : fs::directory_iterator(folder))
        if (entry.path().extension() == ".exr") paths.push_back(entry.path());
    std::sort(paths.begin(), paths.end());
    EXPECT_EQ(paths.size(), 8u);
    auto best = [](const std::function<void()>& f) {
        double seconds = 1e9;
        for (int i = 0; i < 3; ++i) {
            const auto start = std::chrono::steady_clock::now();
            f();
            seconds = std::min(
                seconds, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        return seconds * 1e3;
    };
    const int threads = int(std::max(1u, std::thread::hardware_concurrency()));
    std::printf("%-14s %12s %12s %12s   (ms, best of 3; %d cores)\n", "file", "native", "native 1 thr",
                "OpenImageIO", threads);
    double totals[3] = {};
    for (const fs::path& path : paths) {
        expectSameAsOiio(path.string());
        auto native = [&] {
            std::unique_ptr<ImageDecoder> decoder = openExrDecoder(path.string());
            std::vector<float> texels(4 * size_t(decoder->header().width) * size_t(decoder->header().height));
            decoder->readChannels(0, 3, texels.data());
        };
        auto oiio = [&] {
            std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path.string());
            const OIIO::ImageSpec& spec = input->spec();
            std::vector<float> texels(4 * size_t(spec.width) * size_t(spec.height));
            input->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, texels.data(), 16);
        };
        Imf::setGlobalThreadCount(threads);
        const double multi = best(native);
        Imf::setGlobalThreadCount(0);
        const double single = best(native);
        Imf::setGlobalThreadCount(threads);
        const double reference = best(oiio);
        totals[0] += multi;
        totals[1] += single;
        totals[2] += reference;
        std::printf("%-14s %12.2f %12.2f %12.2f\n", path.filename().c_str(), multi, single, reference);
    }
    std::printf("%-14s %12.2f %12.2f %12.2f\n", "total", totals[0], totals[1], totals[2]);
}

} // namespace
} // namespace shprobe
