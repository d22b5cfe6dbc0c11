// Radiance HDR, PNG and JPEG read with stb_image and written with stb_image_write (image/codec.h),
// both compiled here, header-only, with only the decoders shprobe reads. What OpenImageIO (libpng,
// its RGBE reader) did besides decoding, and stb_image does not, is done here: a PNG's chunks are
// walked as libpng walked them (CRCs, unknown critical chunks, the tRNS chunks it ignores, a file
// cut in its pixels) and its colour space is told from its sRGB, gAMA and tEXt chunks as
// OpenImageIO told it; an HDR's scanlines are walked before stb_image decodes them (a file cut
// short, a run of length 0 on which stb_image would never return); a JPEG that ends before its
// pixels do is said to be truncated.
#include "image/codec.h"

#include "common/error.h"
#include "common/input_file.h"
#include "common/scope_exit.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <new>
#include <string_view>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

// stb_image: the three decoders, from memory only, with its own functions private to this file.
// Its failure reason is thread-local (STBI_THREAD_LOCAL is thread_local in C++11), so images may
// be decoded on several threads at once; nothing here touches its other (global) settings.
#define STBI_ONLY_HDR
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#define STBI_FAILURE_USERMSG // "Corrupt PNG" rather than "bad ctype"
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
// stb_image_write's HDR writer needs stdio (sprintf), so its file functions stay in, unused.
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include <stb_image.h>
#include <stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace shprobe {

namespace {

// ---- The file's bytes ---------------------------------------------------------------------------

// A file read from its start as far as asked: the header is read first, the rest only when the
// pixels are (readImage refuses a header claiming too many pixels before anything else is read).
class FileBytes {
  public:
    explicit FileBytes(const std::string& path) : path_(path) {
        fd_ = open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY);
        if (fd_ < 0) throwInputError(path, errno);
        struct stat status {};
        if (fstat(fd_, &status) == 0 && status.st_size > 0) size_ = uint64_t(status.st_size);
    }
    ~FileBytes() { closeFile(); }
    FileBytes(const FileBytes&) = delete;
    FileBytes& operator=(const FileBytes&) = delete;

    // Whether the file holds at least `count` bytes; reads up to them (and a little more).
    bool have(uint64_t count) {
        while (bytes_.size() < count && fd_ >= 0)
            readMore(std::max<uint64_t>(count - bytes_.size(), kStep));
        return bytes_.size() >= count;
    }
    // Reads the rest of the file.
    void readAll() {
        while (fd_ >= 0)
            readMore(std::max<uint64_t>(size_ > bytes_.size() ? size_ - bytes_.size() : 0, kStep));
    }
    const unsigned char* data() const { return reinterpret_cast<const unsigned char*>(bytes_.data()); }
    unsigned char* mutableData() { return reinterpret_cast<unsigned char*>(bytes_.data()); }
    // Edits of what was read (the file itself is left alone).
    void truncate(size_t size) { bytes_.resize(std::min(size, bytes_.size())); }
    void append(const std::string& bytes) { bytes_ += bytes; }
    size_t size() const { return bytes_.size(); }

  private:
    static constexpr uint64_t kStep = 64 * 1024;

    void readMore(uint64_t count) {
        const size_t start = bytes_.size();
        bytes_.resize(start + size_t(count));
        size_t got = 0;
        while (got < count) {
            ssize_t n = read(fd_, bytes_.data() + start + got, size_t(count) - got);
            if (n < 0 && errno == EINTR) continue;
            if (n < 0) {
                int error = errno;
                bytes_.resize(start + got);
                throwInputError(path_, error);
            }
            if (n == 0) {
                closeFile(); // the end of the file
                break;
            }
            got += size_t(n);
        }
        bytes_.resize(start + got);
    }
    void closeFile() {
        if (fd_ >= 0) close(fd_);
        fd_ = -1;
    }

    std::string path_;
    int fd_ = -1;
    uint64_t size_ = 0; // as fstat said at the start: how much to read at once
    std::string bytes_;
};

// stb_image reads through these, so that a read past the end of the file is seen: stb_image
// itself reads zeros there and may decode a cut file without complaint (JPEG, HDR).
struct MemoryReader {
    const unsigned char* data = nullptr;
    size_t size = 0;
    size_t at = 0;
    bool pastEnd = false; // asked for a byte after the last

    static int read(void* user, char* out, int count) {
        auto& reader = *static_cast<MemoryReader*>(user);
        size_t n = std::min(size_t(std::max(count, 0)), reader.size - reader.at);
        if (n == 0 && count > 0) reader.pastEnd = true;
        std::memcpy(out, reader.data + reader.at, n);
        reader.at += n;
        return int(n);
    }
    static void skip(void* user, int count) {
        auto& reader = *static_cast<MemoryReader*>(user);
        if (count < 0) {
            reader.at -= std::min(reader.at, size_t(-int64_t(count)));
        } else if (size_t(count) > reader.size - reader.at) {
            reader.at = reader.size;
            reader.pastEnd = true;
        } else {
            reader.at += size_t(count);
        }
    }
    static int eof(void* user) {
        auto& reader = *static_cast<MemoryReader*>(user);
        return reader.at >= reader.size;
    }
    stbi_io_callbacks callbacks() const {
        return {&MemoryReader::read, &MemoryReader::skip, &MemoryReader::eof};
    }
};

// ---- PNG chunks ---------------------------------------------------------------------------------
// Deflate packs at most 258 bytes (its longest match) into 2 bits, when a block's codes give that
// match and its distance one bit each (RFC 1951, 3.2.5): no stream is smaller than 1/1032 of what
// it inflates to.
constexpr uint64_t kDeflateMostPacked = 1032;

// PNG specification (ISO/IEC 15948), 5.3: a chunk is a 4-byte big-endian length, a 4-byte type,
// the data and a CRC-32 of type and data. A type whose first letter is upper case is critical.

uint32_t bigEndian32(const unsigned char* bytes) {
    return uint32_t(bytes[0]) << 24 | uint32_t(bytes[1]) << 16 | uint32_t(bytes[2]) << 8 | uint32_t(bytes[3]);
}

// CRC-32 (ISO 3309, the PNG specification's annex D), eight bytes a step ("slicing by 8").
struct CrcTables {
    uint32_t table[8][256];
    constexpr CrcTables() : table{} {
        for (uint32_t n = 0; n < 256; ++n) {
            uint32_t c = n;
            for (int k = 0; k < 8; ++k)
                c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
            table[0][n] = c;
        }
        for (uint32_t n = 0; n < 256; ++n)
            for (int k = 1; k < 8; ++k)
                table[k][n] = (table[k - 1][n] >> 8) ^ table[0][table[k - 1][n] & 0xff];
    }
};
constexpr CrcTables kCrc;

uint32_t crc32(const unsigned char* bytes, size_t count) {
    uint32_t c = 0xffffffffu;
    for (; count >= 8; count -= 8, bytes += 8) {
        uint32_t low = c ^ (uint32_t(bytes[0]) | uint32_t(bytes[1]) << 8 | uint32_t(bytes[2]) << 16 |
                            uint32_t(bytes[3]) << 24);
        uint32_t high = uint32_t(bytes[4]) | uint32_t(bytes[5]) << 8 | uint32_t(bytes[6]) << 16 |
                        uint32_t(bytes[7]) << 24;
        c = kCrc.table[7][low & 0xff] ^ kCrc.table[6][(low >> 8) & 0xff] ^ kCrc.table[5][(low >> 16) & 0xff] ^
            kCrc.table[4][low >> 24] ^ kCrc.table[3][high & 0xff] ^ kCrc.table[2][(high >> 8) & 0xff] ^
            kCrc.table[1][(high >> 16) & 0xff] ^ kCrc.table[0][high >> 24];
    }
    for (; count > 0; --count, ++bytes)
        c = kCrc.table[0][(c ^ *bytes) & 0xff] ^ (c >> 8);
    return ~c;
}

struct PngChunk {
    uint64_t offset = 0; // of its length field
    uint32_t length = 0;
    std::string type;
    const unsigned char* data = nullptr;
    bool crcGood = false;

    bool critical() const { return !(static_cast<unsigned char>(type[0]) & 0x20); }
    uint64_t next() const { return offset + 12 + length; }
};

// A type fit for a message: its four letters, or their codes.
std::string chunkName(const std::string& type) {
    std::string name;
    for (unsigned char c : type)
        name += std::isalpha(c) ? std::string(1, char(c)) : "\\x" + std::to_string(c);
    return name;
}

// What the header chunks (those before the first IDAT) say, as libpng read them.
struct PngHeader {
    uint32_t width = 0, height = 0;
    int depth = 0, colourType = 0;
    bool palette = false;       // a PLTE chunk
    uint32_t paletteLength = 0; // its bytes: 3 per entry
    bool transparency = false;  // a tRNS chunk that libpng expands to an alpha channel
    bool srgbChunk = false;
    uint32_t gamma = 0;          // gAMA's value (gamma times 100000), 0 if none or out of range
    std::string textColourSpace; // a tEXt chunk "oiio:ColorSpace" (OpenImageIO writes one)
    uint64_t firstIdat = 0;

    // Samples a pixel holds in the file (a palette index is one).
    int storedSamples() const {
        static constexpr int kSamples[] = {1, 0, 3, 1, 2, 0, 4}; // by colour type
        return kSamples[colourType];
    }
    // The bytes the pixels inflate to, non-interlaced: each row a filter byte and its samples
    // (PNG specification, 7.2); an interlaced image's passes take more.
    uint64_t inflatedBytes() const {
        return uint64_t(height) *
               (1 + (uint64_t(width) * uint64_t(storedSamples()) * uint64_t(depth) + 7) / 8);
    }

    int channels() const {
        switch (colourType) {
        case 0:
            return 1 + transparency;
        case 2:
            return 3 + transparency;
        case 3:
            return 3 + transparency;
        case 4:
            return 2;
        default:
            return 4;
        }
    }
    // OpenImageIO 2.4's PNG colour space (png_pvt.h, read_info), and isSrgbEncoded's reading of it:
    // an sRGB chunk says "sRGB"; else a gAMA whose 1/gamma, rounded to hundredths, is 1 says
    // "linear" and any other "GammaX" (decoded as sRGB); a tEXt "oiio:ColorSpace" says what it says.
    bool srgb() const {
        std::string space;
        if (srgbChunk) {
            space = "sRGB";
        } else if (gamma > 0) {
            float g = float(1.0 / (double(gamma) / 100000.0));
            space = std::round(100.0f * g) / 100.0f == 1.0f ? "linear" : "Gamma";
        }
        if (!textColourSpace.empty()) space = textColourSpace;
        std::transform(space.begin(), space.end(), space.begin(),
                       [](unsigned char c) { return char(std::tolower(c)); });
        return space.find("linear") == std::string::npos && !space.starts_with("lin_");
    }
};

enum class ChunkRead {
    Whole,   // header, data and CRC
    Header,  // the header only (asked for)
    Cut,     // the file ends within the chunk, or before it
    TooLong, // a length above 2^31 - 1, which the PNG specification forbids
};

// Reads the chunk at `offset`: its length and type, then (if `whole`) its data and CRC.
ChunkRead readChunk(FileBytes& file, uint64_t offset, PngChunk& chunk, bool whole = true) {
    if (!file.have(offset + 8)) return ChunkRead::Cut;
    const unsigned char* start = file.data() + offset;
    chunk.offset = offset;
    chunk.length = bigEndian32(start);
    chunk.type = std::string(reinterpret_cast<const char*>(start + 4), 4);
    chunk.data = nullptr;
    chunk.crcGood = false;
    if (chunk.length > 0x7fffffffu) return ChunkRead::TooLong;
    if (!whole) return ChunkRead::Header;
    if (!file.have(offset + 12 + chunk.length)) return ChunkRead::Cut;
    start = file.data() + offset; // `have` may have moved the bytes
    chunk.data = start + 8;
    chunk.crcGood = crc32(start + 4, size_t(chunk.length) + 4) == bigEndian32(start + 8 + chunk.length);
    return ChunkRead::Whole;
}

// IHDR's fields are those the PNG specification allows (11.2.2).
bool validBitDepth(int colourType, int depth) {
    switch (colourType) {
    case 0:
        return depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16;
    case 3:
        return depth == 1 || depth == 2 || depth == 4 || depth == 8;
    case 2:
    case 4:
    case 6:
        return depth == 8 || depth == 16;
    default:
        return false;
    }
}

// ---- Radiance HDR orientation --------------------------------------------------------------------
// The resolution line after the header names the scan order (Radiance's resolu.h): two axes, each
// with its sign and size, the first the one scanlines advance along, the second the one pixels of
// a scanline advance along. X grows to the right, Y upwards: "-Y H +X W", the usual one, stores
// rows from the top, each from the left; "+Y H -X W" rows from the bottom, each from the right;
// "+X W -Y H" (X first) stores columns from the left, each from the top. stb_image reads only
// "-Y H +X W": any other line is rewritten to it (its sizes those of the scanlines as stored), and
// the pixels decoded are moved to their places afterwards.

struct HdrOrientation {
    bool columns = false;     // scanlines are columns (X first)
    bool rightToLeft = false; // -X
    bool bottomToTop = false; // +Y
    uint64_t scanlines = 0;   // as stored: how many
    uint64_t length = 0;      // and the pixels of each

    bool standard() const { return !columns && !rightToLeft && !bottomToTop; }
    int width() const { return int(columns ? scanlines : length); }
    int height() const { return int(columns ? length : scanlines); }
};

// Where the resolution line starts: after the program-type line and the header lines up to an
// empty one (for stb_image a line whose first byte is '\n' or 0 is empty). npos when the bytes end
// before it does.
size_t hdrResolutionLine(const unsigned char* bytes, size_t size) {
    size_t at = 0;
    for (bool programType = true;; programType = false) {
        const void* newline = std::memchr(bytes + at, '\n', size - at);
        if (!newline) return std::string::npos;
        const bool empty = bytes[at] == '\n' || bytes[at] == 0;
        at = size_t(static_cast<const unsigned char*>(newline) - bytes) + 1;
        if (empty && !programType) break;
    }
    return std::memchr(bytes + at, '\n', size - at) ? at : std::string::npos;
}

// The line quoted for a message: printable ASCII, others as \xNN, at most 80 characters.
std::string quotedLine(const unsigned char* line, size_t size) {
    static const char kHex[] = "0123456789abcdef";
    std::string text = "\"";
    for (size_t i = 0; i < size && i < 80; ++i) {
        if (line[i] >= 0x20 && line[i] < 0x7f && line[i] != '"' && line[i] != '\\') {
            text += char(line[i]);
        } else {
            text += "\\x";
            text += kHex[line[i] >> 4];
            text += kHex[line[i] & 15];
        }
    }
    return text + (size > 80 ? "...\"" : "\"");
}

// Reads the resolution line at `line` ("[+-][XY] N [+-][XY] M", what follows M ignored, as
// Radiance's str2resolu does). On any orientation but "-Y +X", writes "-Y" and "+X" over its two
// axes, so that stb_image reads the scanlines as stored. False if it names none of the eight.
bool readHdrOrientation(unsigned char* line, size_t size, HdrOrientation& orientation) {
    size_t at = 0;
    unsigned char* axes[2] = {};
    uint64_t sizes[2] = {};
    for (int i = 0; i < 2; ++i) {
        while (i > 0 && at < size && line[at] == ' ')
            ++at;
        if (size - at < 3 || (line[at] != '+' && line[at] != '-') ||
            (line[at + 1] != 'X' && line[at + 1] != 'Y') || line[at + 2] != ' ')
            return false;
        axes[i] = line + at;
        at += 2;
        while (at < size && line[at] == ' ')
            ++at;
        if (at >= size || !std::isdigit(line[at])) return false;
        for (; at < size && std::isdigit(line[at]); ++at) {
            sizes[i] = sizes[i] * 10 + uint64_t(line[at] - '0');
            if (sizes[i] > uint64_t(INT_MAX)) return false;
        }
    }
    if (axes[0][1] == axes[1][1]) return false;
    orientation.columns = axes[0][1] == 'X';
    const unsigned char* x = orientation.columns ? axes[0] : axes[1];
    const unsigned char* y = orientation.columns ? axes[1] : axes[0];
    orientation.rightToLeft = x[0] == '-';
    orientation.bottomToTop = y[0] == '+';
    orientation.scanlines = sizes[0];
    orientation.length = sizes[1];
    if (!orientation.standard()) {
        std::memcpy(axes[0], "-Y", 2);
        std::memcpy(axes[1], "+X", 2);
    }
    return true;
}

// Moves the decoded pixels (3 floats each), in the order stored, to rows from the top, each from
// the left.
void reorderHdrPixels(float* pixels, const HdrOrientation& orientation) {
    const uint64_t width = uint64_t(orientation.width()), height = uint64_t(orientation.height());
    std::vector<float> stored(pixels, pixels + width * height * 3);
    for (uint64_t s = 0; s < orientation.scanlines; ++s)
        for (uint64_t p = 0; p < orientation.length; ++p) {
            uint64_t x = orientation.columns ? s : p, row = orientation.columns ? p : s;
            if (orientation.rightToLeft) x = width - 1 - x;
            if (orientation.bottomToTop) row = height - 1 - row;
            std::memcpy(pixels + (row * width + x) * 3, stored.data() + (s * orientation.length + p) * 3,
                        3 * sizeof(float));
        }
}

// ---- Decoders -----------------------------------------------------------------------------------

// "not a PNG image (...)": the format the file's first bytes named, not the decoder's name.
std::string notReadable(const std::string& path, ImageFormat format, const std::string& reason) {
    const char* name = format == ImageFormat::Hdr    ? "a Radiance HDR image"
                       : format == ImageFormat::Png  ? "a PNG image"
                       : format == ImageFormat::Jpeg ? "a JPEG image"
                                                     : "an image shprobe reads itself";
    return path + ": not " + name + " (" + reason + ")";
}
std::string pixelsUnreadable(const std::string& path, const std::string& reason) {
    return path + ": cannot read the pixels; the file may be truncated or corrupt (" + reason + ")";
}

const char* failureReason() {
    const char* reason = stbi_failure_reason();
    return reason ? reason : "unknown error";
}

class StbDecoder final : public ImageDecoder {
  public:
    StbDecoder(const std::string& path, ImageFormat format) : path_(path), format_(format), file_(path) {
        if (format == ImageFormat::Png) {
            readPngHeader();
        } else {
            readStbHeader();
        }
    }

    void readChannels(int begin, int end, float* first) override {
        if (begin < 0 || end > int(header_.channels.size()) || begin >= end || end - begin > 4)
            throw Error(ErrorKind::Input, path_ + ": no channels " + std::to_string(begin) + " to " +
                                              std::to_string(end) + " to read");
        if (!pixels_) decode();
        const size_t texels = size_t(header_.width) * size_t(header_.height);
        const size_t stride = header_.channels.size();
        for (int c = begin; c < end; ++c) {
            float* out = first + (c - begin);
            if (format_ == ImageFormat::Hdr) {
                const float* in = static_cast<const float*>(pixels_.get()) + c;
                for (size_t t = 0; t < texels; ++t)
                    out[4 * t] = in[stride * t];
            } else if (sixteenBit_) {
                // As OpenImageIO converts UINT16 to float: times 1/65535 in single precision.
                const auto* in = static_cast<const uint16_t*>(pixels_.get()) + c;
                for (size_t t = 0; t < texels; ++t)
                    out[4 * t] = float(in[stride * t]) * (1.0f / 65535.0f);
            } else {
                const auto* in = static_cast<const unsigned char*>(pixels_.get()) + c;
                for (size_t t = 0; t < texels; ++t)
                    out[4 * t] = float(in[stride * t]) * (1.0f / 255.0f);
            }
        }
    }

  private:
    struct StbFree {
        void operator()(void* pixels) const { stbi_image_free(pixels); }
    };

    [[noreturn]] void failHeader(const std::string& reason) const {
        throw Error(ErrorKind::Input, notReadable(path_, format_, reason));
    }
    [[noreturn]] void failPixels(const std::string& reason) const {
        throw Error(ErrorKind::Input, pixelsUnreadable(path_, reason));
    }

    static std::vector<std::string> channelNames(int count) {
        switch (count) {
        case 1:
            return {"Y"};
        case 2:
            return {"Y", "A"};
        case 3:
            return {"R", "G", "B"};
        default:
            return {"R", "G", "B", "A"};
        }
    }

    // HDR and JPEG: stb_image's own header reader, on the first 64 KiB, or on the whole file when
    // the header is longer (a JPEG's metadata segments come before its frame header).
    void readStbHeader() {
        file_.have(64 * 1024);
        if (format_ == ImageFormat::Hdr) readHdrResolution();
        int width = 0, height = 0, components = 0;
        bool known = stbi_info_from_memory(file_.data(), int(std::min<size_t>(file_.size(), INT_MAX)), &width,
                                           &height, &components);
        if (!known && file_.have(file_.size() + 1)) {
            file_.readAll();
            if (file_.size() > size_t(INT_MAX)) failHeader("the file is larger than 2 GiB");
            known = stbi_info_from_memory(file_.data(), int(file_.size()), &width, &height, &components);
        }
        if (!known) failHeader(failureReason());
        header_.width = width;
        header_.height = height;
        if (format_ == ImageFormat::Hdr) {
            hdr_.scanlines = uint64_t(height); // as stb_image read them: the line is rewritten
            hdr_.length = uint64_t(width);
            header_.width = hdr_.width();
            header_.height = hdr_.height();
            header_.channels = {"R", "G", "B"}; // stb_image reads RGBE as RGB
            header_.srgb = false;
        } else {
            header_.channels = channelNames(components); // 1 (grey) or 3 (YCbCr, RGB, CMYK)
            header_.srgb = true;
        }
    }

    // The resolution line, read here (and rewritten for stb_image) if it is not "-Y H +X W".
    void readHdrResolution() {
        size_t line = hdrResolutionLine(file_.data(), file_.size());
        if (line == std::string::npos && file_.have(file_.size() + 1)) {
            file_.readAll();
            line = hdrResolutionLine(file_.data(), file_.size());
        }
        if (line == std::string::npos) return; // stb_image says what is missing
        unsigned char* start = file_.mutableData() + line;
        const size_t length =
            size_t(static_cast<const unsigned char*>(std::memchr(start, '\n', file_.size() - line)) - start);
        if (!readHdrOrientation(start, length, hdr_))
            failHeader("the resolution line " + quotedLine(start, length) +
                       " names none of Radiance's eight orientations, such as \"-Y 512 +X 1024\"");
    }

    // PNG: the chunks up to the first IDAT, walked here as libpng walks them: a critical chunk
    // with a bad CRC or of an unknown type is an error, an ancillary one with a bad CRC is ignored.
    void readPngHeader() {
        if (!file_.have(8) || std::memcmp(file_.data(), "\x89PNG", 4) != 0) failHeader("no PNG signature");
        if (std::memcmp(file_.data() + 4, "\r\n\x1a\n", 4) != 0)
            failHeader("the PNG signature is damaged: its last four bytes are " +
                       quotedLine(file_.data() + 4, 4) +
                       ", not \"\\x0d\\x0a\\x1a\\x0a\" (as after a transfer as text)");
        PngChunk chunk;
        for (uint64_t offset = 8;; offset = chunk.next()) {
            const bool first = offset == 8;
            ChunkRead read = readChunk(file_, offset, chunk, /*whole=*/false);
            if (read == ChunkRead::Header && chunk.type == "IDAT" && !first) {
                png_.firstIdat = offset; // its data and CRC are the pixels' (checkPngChunks)
                break;
            }
            if (read == ChunkRead::Header) read = readChunk(file_, offset, chunk);
            if (read == ChunkRead::TooLong)
                failHeader("chunk " + chunkName(chunk.type) + " claims " + std::to_string(chunk.length) +
                           " bytes");
            if (read == ChunkRead::Cut) failHeader("the file ends before its first IDAT chunk: end of file");
            if (first && chunk.type != "IHDR")
                failHeader("the first chunk is " + chunkName(chunk.type) + ", not IHDR");
            if (!chunk.crcGood) {
                if (chunk.critical()) failHeader(chunkName(chunk.type) + ": CRC error");
                if (chunk.type == "tRNS") hideChunk(chunk);
            } else if (chunk.type == "IHDR") {
                if (!first) failHeader("a second IHDR chunk");
                readIhdr(chunk);
            } else if (chunk.type == "PLTE") {
                png_.palette = true;
                png_.paletteLength = chunk.length;
            } else if (chunk.type == "tRNS") {
                readTrns(chunk);
            } else if (chunk.type == "gAMA") {
                uint32_t gamma = chunk.length == 4 ? bigEndian32(chunk.data) : 0;
                png_.gamma = gamma >= 16 && gamma <= 625000000 ? gamma : 0; // libpng's range
            } else if (chunk.type == "sRGB") {
                png_.srgbChunk = chunk.length == 1;
            } else if (chunk.type == "tEXt") {
                std::string_view text(reinterpret_cast<const char*>(chunk.data), chunk.length);
                constexpr std::string_view kKey("oiio:ColorSpace\0", 16);
                if (text.starts_with(kKey)) png_.textColourSpace = std::string(text.substr(kKey.size()));
            } else if (chunk.type == "IEND") {
                failHeader("no IDAT chunk");
            } else if (chunk.critical()) {
                failHeader(chunkName(chunk.type) + ": unknown critical chunk");
            }
        }
        if (png_.colourType == 3 && !png_.palette) failHeader("a palette image without a PLTE chunk");
        header_.width = int(png_.width);
        header_.height = int(png_.height);
        header_.channels = channelNames(png_.channels());
        header_.srgb = png_.srgb();
        sixteenBit_ = png_.depth == 16;
    }

    void readIhdr(const PngChunk& chunk) {
        if (chunk.length != 13) failHeader("IHDR is " + std::to_string(chunk.length) + " bytes, not 13");
        png_.width = bigEndian32(chunk.data);
        png_.height = bigEndian32(chunk.data + 4);
        png_.depth = chunk.data[8];
        png_.colourType = chunk.data[9];
        if (png_.width == 0 || png_.height == 0 || png_.width > 0x7fffffffu || png_.height > 0x7fffffffu)
            failHeader("IHDR gives the size " + std::to_string(png_.width) + "x" +
                       std::to_string(png_.height));
        if (!validBitDepth(png_.colourType, png_.depth))
            failHeader("IHDR gives colour type " + std::to_string(png_.colourType) + " with bit depth " +
                       std::to_string(png_.depth));
        if (chunk.data[10] != 0 || chunk.data[11] != 0 || chunk.data[12] > 1)
            failHeader("IHDR gives an unknown compression, filter or interlace method");
    }

    // libpng (png_handle_tRNS) uses the first tRNS before IDAT that fits the colour type: 2 bytes
    // for grey, 6 for RGB, 1 to the palette's size after PLTE, none with an alpha channel; it
    // ignores any other (a warning). stb_image would refuse some of those and use others, so they
    // are hidden from it.
    void readTrns(const PngChunk& chunk) {
        const uint32_t paletteEntries = png_.paletteLength / 3;
        const bool fits =
            !png_.transparency &&
            ((png_.colourType == 0 && chunk.length == 2) || (png_.colourType == 2 && chunk.length == 6) ||
             (png_.colourType == 3 && png_.palette && chunk.length >= 1 && chunk.length <= paletteEntries));
        if (fits)
            png_.transparency = true;
        else
            hideChunk(chunk);
    }

    // Renames the chunk in the bytes stb_image decodes to a type it skips (ancillary, unknown).
    void hideChunk(const PngChunk& chunk) { file_.mutableData()[chunk.offset + 7] = 'x'; }

    // The pixels: the IDAT chunks from the first on, each whole with its CRC, as libpng reads them.
    // OpenImageIO's reader stopped there (it read no chunk after the pixels, IEND included, and
    // read a file cut after them); stb_image reads to IEND. So the bytes it decodes end with the
    // IDAT chunks and an IEND chunk put after them.
    void checkPngChunks() {
        PngChunk chunk;
        uint64_t offset = png_.firstIdat, compressed = 0;
        for (;; offset = chunk.next()) {
            const ChunkRead read = readChunk(file_, offset, chunk);
            // The file may end after the IDAT chunks, even within the next chunk, but not in one.
            if (read == ChunkRead::Cut && (!file_.have(offset + 8) || chunk.type != "IDAT")) break;
            if (read == ChunkRead::Cut)
                failPixels("the file ends before its last IDAT chunk does: end of file");
            if (read == ChunkRead::TooLong)
                failPixels("chunk " + chunkName(chunk.type) + " claims " + std::to_string(chunk.length) +
                           " bytes");
            if (chunk.type != "IDAT") break;
            if (!chunk.crcGood) failPixels("IDAT: CRC error");
            compressed += chunk.length;
        }
        if (compressed * kDeflateMostPacked < png_.inflatedBytes())
            failPixels("the IDAT chunks hold " + std::to_string(compressed) + " bytes, too few for " +
                       std::to_string(png_.width) + "x" + std::to_string(png_.height) +
                       " pixels at deflate's best: end of file");
        file_.truncate(size_t(offset));
        file_.append(std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12));
    }

    // Radiance's scanlines (Greg Ward, "Real Pixels", Graphics Gems II; Radiance's color.c), walked
    // as stb_image reads them, before it does: it reads zeros past the end of the data, and loops
    // for ever on a run-length-encoded count of 0. Widths below 8 or above 32767 are flat RGBE;
    // else each scanline is 2, 2, its width (16 bits), then each of its four components as runs
    // (a count above 128: that many repeats of the next byte) and dumps (a count up to 128: that
    // many bytes). A scanline not starting 2, 2 makes stb_image read flat pixels from there on.
    // What stb_image would refuse only after allocating the image is refused here, in its words.
    void checkHdrScanlines() {
        const unsigned char* bytes = file_.data();
        const size_t size = file_.size();
        // The data starts after the program-type line, the header lines to an empty one, and the
        // resolution line.
        size_t at = 0;
        // Whether the line from `at` is empty (to stb_image: its first byte is '\n' or 0); -1 when
        // the file ends before its '\n'. `at` moves past it.
        auto nextLineEmpty = [&]() -> int {
            const void* newline = std::memchr(bytes + at, '\n', size - at);
            if (!newline) return -1;
            const bool empty = bytes[at] == '\n' || bytes[at] == 0;
            at = size_t(static_cast<const unsigned char*>(newline) - bytes) + 1;
            return empty;
        };
        const char* cut = "the file ends before its last scanline: end of file";
        if (nextLineEmpty() < 0) failPixels(cut); // #?RADIANCE
        for (int empty = 0; empty != 1;)
            if ((empty = nextLineEmpty()) < 0) failPixels(cut);
        if (nextLineEmpty() < 0) failPixels(cut);                    // -Y height +X width
        const uint64_t width = hdr_.length, height = hdr_.scanlines; // as stored
        auto needFlat = [&](uint64_t pixels) {
            if (size - at < pixels * 4) failPixels(cut);
        };
        if (width < 8 || width >= 32768) return needFlat(width * height);
        for (uint64_t row = 0; row < height; ++row) {
            if (size - at < 4) failPixels(cut);
            const unsigned char* start = bytes + at;
            if (start[0] != 2 || start[1] != 2 || (start[2] & 0x80)) return needFlat(width * height);
            const uint64_t said = uint64_t(start[2]) << 8 | start[3];
            if (said != width)
                failPixels("corrupt HDR: scanline " + std::to_string(row) + " says it is " +
                           std::to_string(said) + " pixels long, not " + std::to_string(width));
            at += 4;
            for (int component = 0; component < 4; ++component)
                for (uint64_t x = 0; x < width;) {
                    if (at >= size) failPixels(cut);
                    const unsigned count = bytes[at++];
                    const auto overrun = [&] {
                        failPixels("corrupt HDR: a run of scanline " + std::to_string(row) +
                                   " passes its end");
                    };
                    if (count > 128) {
                        if (count - 128 > width - x) overrun();
                        if (at >= size) failPixels(cut);
                        at += 1;
                        x += count - 128;
                    } else {
                        if (count == 0)
                            failPixels("scanline " + std::to_string(row) + " holds a run of length 0");
                        if (count > width - x) overrun();
                        if (size - at < count) failPixels(cut);
                        at += count;
                        x += count;
                    }
                }
        }
    }

  public:
    // The whole file read, and a PNG's chunks or an HDR's scanlines walked, as decode needs them.
    void checkData() override {
        if (checked_) return;
        if (header_.width < 1 || header_.height < 1) failPixels("the image has no pixels");
        file_.readAll();
        if (file_.size() > size_t(INT_MAX)) failPixels("the file is larger than 2 GiB");
        if (format_ == ImageFormat::Png) checkPngChunks();
        if (format_ == ImageFormat::Hdr) checkHdrScanlines();
        checked_ = true;
    }

  private:
    void decode() {
        checkData();
        MemoryReader reader{file_.data(), file_.size()};
        const stbi_io_callbacks callbacks = reader.callbacks();
        const int channels = int(header_.channels.size());
        int width = 0, height = 0, components = 0;
        void* pixels = nullptr;
        if (format_ == ImageFormat::Hdr)
            pixels = stbi_loadf_from_callbacks(&callbacks, &reader, &width, &height, &components, channels);
        else if (sixteenBit_)
            pixels = stbi_load_16_from_callbacks(&callbacks, &reader, &width, &height, &components, channels);
        else
            pixels = stbi_load_from_callbacks(&callbacks, &reader, &width, &height, &components, channels);
        pixels_.reset(pixels);
        // A decoder that asked for more than the file holds met its end before the pixels'.
        if (reader.pastEnd)
            failPixels(std::string(format_ == ImageFormat::Hdr ? "the file ends before its last scanline"
                                                               : "the file ends before its last pixels") +
                       ": end of file");
        if (!pixels && std::string_view(failureReason()).find("too large") != std::string_view::npos)
            throw Error(ErrorKind::Input,
                        path_ + ": the image is too large to decode (" + failureReason() + ")");
        if (!pixels) failPixels(failureReason());
        const bool hdr = format_ == ImageFormat::Hdr;
        const int storedWidth = hdr ? int(hdr_.length) : header_.width;
        const int storedHeight = hdr ? int(hdr_.scanlines) : header_.height;
        if (width != storedWidth || height != storedHeight)
            failPixels("the pixels are " + std::to_string(width) + "x" + std::to_string(height) +
                       ", the header says " + std::to_string(storedWidth) + "x" +
                       std::to_string(storedHeight));
        if (hdr && !hdr_.standard()) reorderHdrPixels(static_cast<float*>(pixels_.get()), hdr_);
    }

    std::string path_;
    ImageFormat format_;
    FileBytes file_;
    PngHeader png_;
    HdrOrientation hdr_; // the standard one until the resolution line says otherwise
    bool sixteenBit_ = false;
    bool checked_ = false; // checkData done
    std::unique_ptr<void, StbFree> pixels_;
};

// ---- Encoders -----------------------------------------------------------------------------------

// stb_image_write's output, appended to a string; an allocation failure is kept for after.
struct Sink {
    std::string bytes;
    bool failed = false;

    static void write(void* context, void* data, int size) {
        auto& sink = *static_cast<Sink*>(context);
        try {
            sink.bytes.append(static_cast<const char*>(data), size_t(std::max(size, 0)));
        } catch (const std::bad_alloc&) {
            sink.failed = true;
        }
    }
};

[[noreturn]] void failOutput(const std::string& what, const std::string& reason) {
    throw Error(ErrorKind::Output, "cannot write " + what + ": " + reason);
}

// stb_image_write counts bytes in int: the image's values must fit with room to spare.
void checkSize(int width, int height, int channels, int pixelStride, bool hasData, const std::string& what) {
    if (width < 1 || height < 1)
        failOutput(what,
                   "the image has no pixels (" + std::to_string(width) + "x" + std::to_string(height) + ")");
    if (channels < 1 || channels > 4 || pixelStride < channels)
        failOutput(what, std::to_string(channels) + " channels every " + std::to_string(pixelStride) +
                             " values cannot be written");
    if (!hasData) failOutput(what, "no pixels given");
    if (int64_t(width) * height > maxStbPixels(channels))
        failOutput(what, "the image is " + std::to_string(width) + "x" + std::to_string(height) +
                             ", too large to encode");
}

// The values packed, `channels` per pixel, as stb_image_write takes them.
template <typename T>
std::vector<T> packed(const T* data, int width, int height, int channels, int pixelStride) {
    std::vector<T> out(size_t(width) * size_t(height) * size_t(channels));
    const size_t pixels = size_t(width) * size_t(height);
    for (size_t p = 0; p < pixels; ++p)
        for (int c = 0; c < channels; ++c)
            out[p * size_t(channels) + size_t(c)] = data[p * size_t(pixelStride) + size_t(c)];
    return out;
}

std::string finish(int ok, Sink& sink, const std::string& what) {
    if (sink.failed) failOutput(what, "out of memory");
    if (!ok) failOutput(what, "the image could not be encoded");
    return std::move(sink.bytes);
}

} // namespace

std::unique_ptr<ImageDecoder> openStbDecoder(const std::string& path, ImageFormat format) {
    if (format != ImageFormat::Hdr && format != ImageFormat::Png && format != ImageFormat::Jpeg)
        throw Error(ErrorKind::Input, notReadable(path, format, "not a Radiance HDR, PNG or JPEG file"));
    return std::make_unique<StbDecoder>(path, format);
}

std::string encodeHdr(const FloatPixels& pixels, const std::string& what) {
    checkSize(pixels.width, pixels.height, pixels.channels, pixels.pixelStride, pixels.data != nullptr, what);
    std::vector<float> values =
        packed(pixels.data, pixels.width, pixels.height, pixels.channels, pixels.pixelStride);
    // RGBE holds no negative, infinite or NaN value, and no exponent above 127: stb_image_write
    // would wrap them into garbage. Negative and NaN become 0, the rest at most just under 2^127.
    const float largest = std::nextafter(std::ldexp(1.0f, 127), 0.0f);
    for (float& value : values)
        value = value > 0.0f ? std::min(value, largest) : 0.0f;
    Sink sink;
    int ok = stbi_write_hdr_to_func(&Sink::write, &sink, pixels.width, pixels.height, pixels.channels,
                                    values.data());
    return finish(ok, sink, what);
}

namespace {

// Packs the pixels and hands them to one of stb_image_write's encoders, which writes to `sink`.
template <typename Encode>
std::string encodeBytes(const BytePixels& pixels, const std::string& what, Encode encode) {
    checkSize(pixels.width, pixels.height, pixels.channels, pixels.pixelStride, pixels.data != nullptr, what);
    std::vector<uint8_t> values =
        packed(pixels.data, pixels.width, pixels.height, pixels.channels, pixels.pixelStride);
    Sink sink;
    return finish(encode(sink, values.data()), sink, what);
}

} // namespace

std::string encodePng(const BytePixels& pixels, const std::string& what) {
    return encodeBytes(pixels, what, [&](Sink& sink, const uint8_t* values) {
        return stbi_write_png_to_func(&Sink::write, &sink, pixels.width, pixels.height, pixels.channels,
                                      values, pixels.width * pixels.channels);
    });
}

std::string encodeJpeg(const BytePixels& pixels, const std::string& what) {
    // Quality 95: stb_image_write then keeps chroma at full resolution (it subsamples at 90 and below).
    return encodeBytes(pixels, what, [&](Sink& sink, const uint8_t* values) {
        return stbi_write_jpg_to_func(&Sink::write, &sink, pixels.width, pixels.height, pixels.channels,
                                      values, 95);
    });
}

RgbCodes readRgbCodesHeader(std::span<const unsigned char> bytes, const std::string& what) {
    if (bytes.size() > size_t(INT_MAX))
        throw Error(ErrorKind::Input, what + ": the image is larger than 2 GiB");
    RgbCodes image;
    int channels = 0;
    if (!stbi_info_from_memory(bytes.data(), int(bytes.size()), &image.width, &image.height, &channels))
        throw Error(ErrorKind::Input, what + ": not a PNG or JPEG image (" + failureReason() + ")");
    image.bits = stbi_is_16_bit_from_memory(bytes.data(), int(bytes.size())) ? 16 : 8;
    return image;
}

void decodeRgbCodes(std::span<const unsigned char> bytes, RgbCodes& image, const std::string& what) {
    const int size = int(bytes.size());
    int channels = 0;
    void* pixels = image.bits == 16
                       ? static_cast<void*>(stbi_load_16_from_memory(bytes.data(), size, &image.width,
                                                                     &image.height, &channels, 3))
                       : static_cast<void*>(stbi_load_from_memory(bytes.data(), size, &image.width,
                                                                  &image.height, &channels, 3));
    if (!pixels) throw Error(ErrorKind::Input, what + ": cannot decode the image (" + failureReason() + ")");
    ScopeExit release([&] { stbi_image_free(pixels); });
    image.codes.resize(size_t(image.width) * size_t(image.height) * 3);
    if (image.bits == 16)
        std::copy_n(static_cast<const uint16_t*>(pixels), image.codes.size(), image.codes.begin());
    else
        std::copy_n(static_cast<const uint8_t*>(pixels), image.codes.size(), image.codes.begin());
}

} // namespace shprobe
