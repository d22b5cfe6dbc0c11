#include "image/channels.h"

#include "common/error.h"
#include "common/input_file.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>
#include <map>
#include <set>
#include <string_view>
#include <sys/stat.h>
#include <unistd.h>

namespace shprobe {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
    throw Error(ErrorKind::Input, path + ": " + problem);
}

// ---- Channels by name ---------------------------------------------------------------------------

// A name as it may appear in a one-line message: control bytes become '?'.
std::string printable(std::string_view name) {
    std::string text(name);
    for (char& c : text)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return text;
}

// "Z, A", at most 16 names, then how many more; "none" for no channel.
std::string channelListText(const std::vector<std::string>& names) {
    constexpr size_t kShown = 16;
    if (names.empty()) return "none";
    std::string text;
    for (size_t i = 0; i < std::min(names.size(), kShown); ++i)
        text += (i ? ", " : "") + printable(names[i]);
    if (names.size() > kShown) text += " and " + std::to_string(names.size() - kShown) + " more";
    return text;
}

// OpenEXR's layers: channel "diffuse.R" is channel R of the layer with prefix "diffuse."; "R" is
// in the unprefixed layer (prefix "").
std::string_view layerPrefix(std::string_view name) {
    size_t dot = name.rfind('.');
    return dot == std::string_view::npos ? std::string_view() : name.substr(0, dot + 1);
}

// The channels by name (the first of a repeated name), and the layer prefixes in the order of
// their first channel, the unprefixed layer first.
struct ChannelIndex {
    std::map<std::string, int, std::less<>> byName;
    std::vector<std::string_view> layers;
};

ChannelIndex indexChannels(const std::vector<std::string>& names) {
    ChannelIndex index;
    index.layers.push_back({});
    std::set<std::string_view> seen{{}};
    for (size_t i = 0; i < names.size(); ++i) {
        index.byName.emplace(names[i], int(i));
        std::string_view layer = layerPrefix(names[i]);
        if (seen.insert(layer).second) index.layers.push_back(layer);
    }
    return index;
}

// Index of channel `base` of the layer, or -1.
int findChannel(const ChannelIndex& index, std::string_view layer, std::string_view base) {
    auto found = index.byName.find(std::string(layer) + std::string(base));
    return found == index.byName.end() ? -1 : found->second;
}

// The plan one layer gives, if any.
bool planLayer(const std::vector<std::string>& names, const ChannelIndex& index, std::string_view layer,
               const std::string& path, ChannelPlan& plan) {
    int r = findChannel(index, layer, "R"), g = findChannel(index, layer, "G"),
        b = findChannel(index, layer, "B");
    if (r >= 0 && g >= 0 && b >= 0) {
        plan = {ChannelMeaning::Rgb, {r, g, b}};
        return true;
    }
    int y = findChannel(index, layer, "Y");
    if (y < 0) return false;
    int ry = findChannel(index, layer, "RY"), by = findChannel(index, layer, "BY");
    if ((ry >= 0) != (by >= 0))
        fail(path, "chroma channel " + printable(names[size_t(std::max(ry, by))]) +
                       " without its pair (RY and BY come together; found: " + channelListText(names) + ")");
    plan = ry >= 0 ? ChannelPlan{ChannelMeaning::LuminanceChroma, {y, ry, by}}
                   : ChannelPlan{ChannelMeaning::Grey, {y, y, y}};
    return true;
}

// ---- Headers read within bounds ------------------------------------------------------------------

// Reads a file front to back through a small window, with pread: never more than the window past
// the last byte asked for, never past the end of the file.
class HeaderReader {
  public:
    HeaderReader(int fd, uint64_t size, const std::string& path) : fd_(fd), size_(size), path_(path) {}
    HeaderReader(const HeaderReader&) = delete;
    HeaderReader& operator=(const HeaderReader&) = delete;

    uint64_t offset() const { return offset_; }
    uint64_t left() const { return size_ - offset_; }
    const std::string& path() const { return path_; }

    // False (nothing read) when fewer than `count` bytes are left.
    bool read(void* out, size_t count) {
        if (count > left()) return false;
        auto* bytes = static_cast<unsigned char*>(out);
        for (size_t i = 0; i < count; ++i)
            bytes[i] = byteAt(offset_ + i);
        offset_ += count;
        return true;
    }
    bool peek(unsigned char& out) {
        if (left() == 0) return false;
        out = byteAt(offset_);
        return true;
    }
    bool skip(uint64_t count) {
        if (count > left()) return false;
        offset_ += count;
        return true;
    }

  private:
    static constexpr size_t kWindow = 4096;

    unsigned char byteAt(uint64_t at) {
        if (at < windowStart_ || at >= windowStart_ + windowSize_) fill(at);
        return window_[at - windowStart_];
    }
    void fill(uint64_t at) {
        size_t wanted = size_t(std::min<uint64_t>(kWindow, size_ - at));
        size_t got = 0;
        while (got < wanted) {
            ssize_t n = pread(fd_, window_ + got, wanted - got, off_t(at + got));
            if (n < 0 && errno == EINTR) continue;
            if (n < 0) throwInputError(path_, errno);
            if (n == 0) fail(path_, "the file became shorter while its header was read");
            got += size_t(n);
        }
        windowStart_ = at;
        windowSize_ = got;
    }

    int fd_;
    uint64_t size_;
    std::string path_;
    uint64_t offset_ = 0;
    unsigned char window_[kWindow];
    uint64_t windowStart_ = 0;
    size_t windowSize_ = 0;
};

uint32_t littleEndian32(const unsigned char* bytes) {
    return uint32_t(bytes[0]) | uint32_t(bytes[1]) << 8 | uint32_t(bytes[2]) << 16 | uint32_t(bytes[3]) << 24;
}

uint32_t bigEndian32(const unsigned char* bytes) {
    return uint32_t(bytes[0]) << 24 | uint32_t(bytes[1]) << 16 | uint32_t(bytes[2]) << 8 | uint32_t(bytes[3]);
}

// ---- OpenEXR -------------------------------------------------------------------------------------
// The layout is that of "OpenEXR File Layout" (openexr.com): the magic number 76 2f 31 01, a
// 4-byte version field (version 2 in its low byte; flags 0x200 single-part tiled, 0x400 long
// names, 0x800 deep data, 0x1000 multi-part), then the header: attributes, each
// `name\0 type\0 int32 size, size bytes of value`, until an empty name. A multi-part file has one
// header per part and an empty header (a lone 0 byte) after the last. Integers are little-endian.
//
// The OpenEXR library reads a value of a type it knows by that type, not by the size written
// before it: a size that disagrees would make it read the rest of the header from elsewhere than
// this scan does. So the scan holds each known type to the size the library reads, and anything
// it cannot follow as the library would is refused.

constexpr unsigned char kExrMagic[4] = {0x76, 0x2f, 0x31, 0x01};
constexpr uint32_t kExrMultiPart = 0x1000;

struct FixedSizeType {
    std::string_view type;
    int32_t bytes;
};
// The attribute types of the OpenEXR library whose values have one size ("OpenEXR File Layout",
// "Attribute Types").
constexpr std::array<FixedSizeType, 24> kFixedSizeTypes{{
    {"box2i", 16},
    {"box2f", 16},
    {"chromaticities", 32},
    {"compression", 1},
    {"deepImageState", 1},
    {"double", 8},
    {"envmap", 1},
    {"float", 4},
    {"int", 4},
    {"keycode", 28},
    {"lineOrder", 1},
    {"m33f", 36},
    {"m33d", 72},
    {"m44f", 64},
    {"m44d", 128},
    {"rational", 8},
    {"tiledesc", 9},
    {"timecode", 8},
    {"v2i", 8},
    {"v2f", 8},
    {"v2d", 16},
    {"v3i", 12},
    {"v3f", 12},
    {"v3d", 24},
}};

[[noreturn]] void failExr(const HeaderReader& in, const std::string& problem) {
    fail(in.path(), "the OpenEXR header " + problem);
}

// A header cut short by the end of the file: the library reads no further either, and says so
// (checkImageHeader stops the scan quietly).
struct HeaderCutShort {};

[[noreturn]] void cutShort() {
    throw HeaderCutShort{};
}

int32_t readInt32(HeaderReader& in) {
    unsigned char bytes[4];
    if (!in.read(bytes, sizeof bytes)) cutShort();
    return int32_t(littleEndian32(bytes));
}

// A 0-terminated name of at most kMaxExrNameBytes bytes.
std::string readName(HeaderReader& in, const char* where) {
    std::string name;
    for (;;) {
        char c = 0;
        if (!in.read(&c, 1)) cutShort();
        if (c == 0) return name;
        if (name.size() == size_t(kMaxExrNameBytes))
            failExr(in, std::string("holds ") + where + " longer than " + std::to_string(kMaxExrNameBytes) +
                            " bytes (at byte " + std::to_string(in.offset()) + ")");
        name += c;
    }
}

// The channel list ("chlist"): per channel `name\0 int32 pixel type, uint8 pLinear, 3 reserved,
// int32 xSampling, int32 ySampling`, ended by an empty name; read as the library reads it, to its
// empty name, and held to the size claimed. Subsampled channels (OpenEXR's luminance/chroma images
// keep chroma at half resolution) are not read: said here, in words about the file.
void checkChannelList(HeaderReader& in, const std::string& attribute, int32_t size) {
    const uint64_t start = in.offset();
    for (std::string name = readName(in, "a channel name"); !name.empty();
         name = readName(in, "a channel name")) {
        if (!in.skip(8)) cutShort(); // pixel type, pLinear, reserved
        int32_t xSampling = readInt32(in), ySampling = readInt32(in);
        if (xSampling != 1 || ySampling != 1)
            fail(in.path(), "channel " + printable(name) + " is subsampled (" + std::to_string(xSampling) +
                                " x " + std::to_string(ySampling) +
                                "), and shprobe reads only full-resolution EXR channels; store the image at "
                                "full resolution");
    }
    if (in.offset() - start != uint64_t(size))
        failExr(in, attribute + " claims " + std::to_string(size) + " bytes but its channels take " +
                        std::to_string(in.offset() - start));
}

const FixedSizeType* fixedSizeType(std::string_view type) {
    for (const FixedSizeType& known : kFixedSizeTypes)
        if (known.type == type) return &known;
    return nullptr;
}

// One attribute; false at the empty name that ends the header.
bool checkAttribute(HeaderReader& in) {
    std::string name = readName(in, "an attribute name");
    if (name.empty()) return false;
    std::string type = readName(in, "an attribute type");
    int32_t size = readInt32(in);
    std::string attribute = "attribute \"" + printable(name) + "\" (" + printable(type) + ")";
    if (size < 0) failExr(in, attribute + " claims a negative size (" + std::to_string(size) + " bytes)");
    if (uint64_t(size) > in.left())
        failExr(in, attribute + " claims " + std::to_string(size) + " bytes, more than the " +
                        std::to_string(in.left()) + " left in the file");
    if (const FixedSizeType* fixed = fixedSizeType(type); fixed && size != fixed->bytes)
        failExr(in, attribute + " claims " + std::to_string(size) + " bytes; a " + std::string(fixed->type) +
                        " value has " + std::to_string(fixed->bytes));
    if (type == "floatvector" && size % 4 != 0)
        failExr(in, attribute + " claims " + std::to_string(size) + " bytes, not a whole number of floats");
    if (type == "chlist")
        checkChannelList(in, attribute, size);
    else
        in.skip(uint64_t(size));
    return true;
}

// One header; `attributes` counts those of all the headers so far.
void checkExrHeader(HeaderReader& in, int& attributes) {
    for (int inHeader = 1; checkAttribute(in); ++inHeader) {
        if (inHeader > kMaxExrAttributesPerHeader)
            failExr(in, "has more than " + std::to_string(kMaxExrAttributesPerHeader) + " attributes");
        if (++attributes > kMaxExrAttributes)
            failExr(in,
                    "has more than " + std::to_string(kMaxExrAttributes) + " attributes in all its parts");
    }
}

// Whether the next byte is the empty header that ends a multi-part file (consumed if so).
bool atEmptyHeader(HeaderReader& in) {
    unsigned char next = 0;
    if (!in.peek(next)) cutShort();
    if (next != 0) return false;
    in.skip(1);
    return true;
}

uint64_t checkExrHeaders(HeaderReader& in, uint32_t version) {
    if ((version & 0xff) != 2)
        fail(in.path(), "OpenEXR file format version " + std::to_string(version & 0xff) +
                            " is not supported (OpenEXR files are version 2)");
    int attributes = 0;
    if (!(version & kExrMultiPart)) {
        checkExrHeader(in, attributes);
        return in.offset();
    }
    for (int parts = 0; !atEmptyHeader(in); ++parts) {
        if (parts == kMaxExrParts) failExr(in, "has more than " + std::to_string(kMaxExrParts) + " parts");
        checkExrHeader(in, attributes);
    }
    return in.offset();
}

// ---- PNG -----------------------------------------------------------------------------------------
// Chunks after the 8-byte signature, each `uint32 length, 4-byte type, data, uint32 CRC`, the
// length big-endian and at most 2^31 - 1 (W3C, "Portable Network Graphics (PNG) Specification",
// 5.3). libpng allocates a chunk's length before it reads the chunk; OpenImageIO reads the chunks
// before the first IDAT when it opens a file, then streams the pixels and stops at their end.

constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
constexpr uint32_t kMaxPngChunkLength = 0x7fffffffu;

uint64_t checkPngChunks(HeaderReader& in) {
    for (;;) {
        unsigned char head[8];
        if (!in.read(head, sizeof head)) return in.offset(); // cut short: libpng says so
        uint32_t length = bigEndian32(head);
        std::string type = printable(std::string_view(reinterpret_cast<const char*>(head + 4), 4));
        // The pixels: libpng streams IDAT data, and a cut in it is reported as a truncated file.
        if (type == "IDAT" || type == "IEND") return in.offset() - sizeof head;
        uint64_t dataLeft = in.left() >= 4 ? in.left() - 4 : 0; // the CRC follows the data
        if (length > kMaxPngChunkLength || length > dataLeft)
            fail(in.path(), "the PNG chunk \"" + type + "\" claims " + std::to_string(length) +
                                " bytes, more than the " + std::to_string(dataLeft) + " left in the file");
        in.skip(uint64_t(length) + 4);
    }
}

} // namespace

ChannelPlan planChannels(const std::vector<std::string>& names, const std::string& path) {
    const ChannelIndex index = indexChannels(names);
    ChannelPlan plan;
    for (std::string_view layer : index.layers)
        if (planLayer(names, index, layer, path, plan)) return plan;
    if (names.size() == 2 && names[0] == "R" && names[1] == "G") return {ChannelMeaning::Grey, {0, 0, 0}};
    fail(path, "no R,G,B, Y or Y,RY,BY channels (found: " + channelListText(names) + ")");
}

glm::vec3 luminanceWeights(const Chromaticities& c, const std::string& path) {
    // Columns: XYZ of each primary with Y = 1; scaled by `scale`, they sum to the white point's XYZ.
    auto xyz = [](glm::dvec2 xy) { return glm::dvec3(xy.x / xy.y, 1.0, (1.0 - xy.x - xy.y) / xy.y); };
    glm::dmat3 primaries(xyz(c.red), xyz(c.green), xyz(c.blue));
    glm::dvec3 scale = glm::inverse(primaries) * xyz(c.white);
    const glm::vec3 weights(scale / (scale.x + scale.y + scale.z));
    bool finite = std::isfinite(weights.r) && std::isfinite(weights.g) && std::isfinite(weights.b);
    if (!finite || !(weights.g > 0.0f))
        fail(path, "the chromaticities give no usable luminance weights for its Y, RY, BY channels");
    return weights;
}

glm::vec3 luminanceChromaToRgb(float y, float ry, float by, const glm::vec3& w) {
    // Both chroma 0 is grey; said exactly rather than through the rounding of the general case.
    if (ry == 0.0f && by == 0.0f) return glm::vec3(y);
    float r = (ry + 1.0f) * y;
    float b = (by + 1.0f) * y;
    float g = (y - r * w.r - b * w.b) / w.g;
    return glm::vec3(r, g, b);
}

uint64_t checkImageHeader(int fd, const std::string& path) {
    struct stat status {};
    if (fstat(fd, &status) != 0) throwInputError(path, errno);
    HeaderReader in(fd, uint64_t(std::max<off_t>(status.st_size, 0)), path);
    unsigned char start[8] = {};
    if (!in.read(start, sizeof start)) return 0; // shorter than any header: the readers say what it is
    try {
        if (std::memcmp(start, kExrMagic, sizeof kExrMagic) == 0)
            return checkExrHeaders(in, littleEndian32(start + 4));
        if (std::memcmp(start, kPngSignature, sizeof kPngSignature) == 0) return checkPngChunks(in);
    } catch (const HeaderCutShort&) {
        return in.offset();
    }
    return 0;
}

} // namespace shprobe
