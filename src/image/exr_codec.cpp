// The OpenEXR plugin (image/exr_plugin.h): EXR files read and written with the OpenEXR library
// itself, built as libshprobe_exr.so. Like the OpenImageIO plugin it uses nothing of the shprobe
// libraries but their headers, so that it loads into a program that links them statically as well
// as shared.
#include "image/exr_plugin.h"

#include "image/environment.h"

#include <OpenEXR/IexBaseExc.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfChromaticitiesAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfThreading.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <string_view>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace shprobe {

namespace {

// OpenEXR decodes and encodes the chunks of a file (16 scanlines each with ZIP, 32 with PIZ and
// DWAA, 256 with DWAB) on its global thread pool, which has no thread until it is given some:
// here one per core, set once, before the first file is opened or written (test_codecs times
// both ways on blender-data's files).
void startThreadPool() {
    static std::once_flag once;
    std::call_once(once,
                   [] { Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency()))); });
}

bool iequals(std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
               return std::tolower(static_cast<unsigned char>(x)) ==
                      std::tolower(static_cast<unsigned char>(y));
           });
}

// The order in which OpenImageIO 2.4 presents an OpenEXR file's channels (its exrinput.cpp,
// "sorting into canonical order"), kept so that the channels planChannels sees, and so the plans,
// are those of before: by layer (the name up to its last '.'), then within a layer the reserved
// names in this order, then the others by name. A layer holding X and Y or Z (positions, normals)
// puts X, Y, Z after B instead of Y after B. The file itself holds them sorted by full name, which
// would, for one, make OpenImageIO's two-channel R, G (grey and alpha) G, R.
struct ChannelName {
    std::string name;
    size_t layerLength = 0; // of the layer: the name up to and with its last '.', or 0
    int rank = 10000;       // index among the reserved names; others last

    std::string_view layer() const { return std::string_view(name).substr(0, layerLength); }
    std::string_view suffix() const { return std::string_view(name).substr(layerLength); }
};

constexpr std::array<std::string_view, 20> kReservedNames{
    "R",     "Red", "G",  "Green", "B",  "Blue", "Y",  "real", "imag",  "A",
    "Alpha", "AR",  "RA", "AG",    "GA", "AB",   "BA", "Z",    "Depth", "Zback"};
constexpr std::array<std::string_view, 21> kReservedNamesXyz{
    "R", "Red",   "G",  "Green", "B",  "Blue", "X",  "Y",  "Z",     "real", "imag",
    "A", "Alpha", "AR", "RA",    "AG", "GA",   "AB", "BA", "Depth", "Zback"};

template <size_t N> int rankAmong(std::string_view suffix, const std::array<std::string_view, N>& names) {
    for (size_t i = 0; i < N; ++i)
        if (iequals(suffix, names[i])) return int(i);
    return 10000;
}

std::vector<std::string> channelsInOpenImageIoOrder(const Imf::ChannelList& list) {
    std::vector<ChannelName> channels;
    for (auto channel = list.begin(); channel != list.end(); ++channel) {
        std::string name = channel.name();
        size_t dot = name.rfind('.');
        channels.push_back({name, dot == std::string::npos ? 0 : dot + 1, 10000});
    }
    std::stable_sort(channels.begin(), channels.end(),
                     [](const ChannelName& a, const ChannelName& b) { return a.layer() < b.layer(); });
    for (auto begin = channels.begin(); begin != channels.end();) {
        auto end = std::find_if(begin, channels.end(),
                                [&](const ChannelName& c) { return c.layer() != begin->layer(); });
        auto has = [&](std::string_view suffix) {
            return std::any_of(begin, end, [&](const ChannelName& c) { return iequals(c.suffix(), suffix); });
        };
        const bool xyz = has("X") && (has("Y") || has("Z"));
        for (auto channel = begin; channel != end; ++channel)
            channel->rank = xyz ? rankAmong(channel->suffix(), kReservedNamesXyz)
                                : rankAmong(channel->suffix(), kReservedNames);
        std::sort(begin, end, [](const ChannelName& a, const ChannelName& b) {
            return a.rank != b.rank ? a.rank < b.rank : a.suffix() < b.suffix();
        });
        begin = end;
    }
    std::vector<std::string> names;
    for (ChannelName& channel : channels)
        names.push_back(std::move(channel.name));
    return names;
}

// A name as it may appear in a one-line message: control bytes become '?'.
std::string printable(std::string text) {
    for (char& c : text)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return text;
}

glm::dvec2 xy(const Imath::V2f& v) {
    return {double(v.x), double(v.y)};
}

// A file read whole into memory, which OpenEXR reads as if it were mapped: it decodes each chunk
// where it lies, instead of copying it first into a buffer of its own for each chunk in flight
// (twice as many as threads, each as large as the chunk uncompressed, each touched first as fresh
// pages).
class FileInMemory final : public Imf::IStream {
  public:
    FileInMemory(const std::string& path, std::unique_ptr<char[]> bytes, uint64_t size)
        : Imf::IStream(path.c_str()), bytes_(std::move(bytes)), size_(size) {}
    bool isMemoryMapped() const override { return true; }
    bool read(char c[], int n) override {
        std::memcpy(c, take(n), size_t(n));
        return position_ < size_;
    }
    char* readMemoryMapped(int n) override { return take(n); }
    uint64_t tellg() override { return position_; }
    void seekg(uint64_t position) override { position_ = position; }

  private:
    // The words of OpenEXR's own file stream for a file that ends early.
    char* take(int n) {
        const uint64_t left = position_ < size_ ? size_ - position_ : 0;
        if (n < 0 || uint64_t(n) > left)
            throw Iex::InputExc("Early end of file: read " + std::to_string(left) + " out of " +
                                std::to_string(n) + " requested bytes.");
        char* at = bytes_.get() + position_;
        position_ += uint64_t(n);
        return at;
    }

    std::unique_ptr<char[]> bytes_;
    uint64_t size_ = 0;
    uint64_t position_ = 0;
};

// Compressions of 32 or more scanlines a chunk, whose chunk buffers reading whole saves; each has
// a decompressor, which writes a chunk into a buffer of its full size whatever the file says. (An
// uncompressed chunk is used where it lies: one that says it is shorter than its lines would be
// read past the end of the file's bytes, so such files are read as a stream.)
bool hasLargeCompressedChunks(const Imf::Header& header) {
    switch (header.compression()) {
    case Imf::PIZ_COMPRESSION:
    case Imf::B44_COMPRESSION:
    case Imf::B44A_COMPRESSION:
    case Imf::DWAA_COMPRESSION:
    case Imf::DWAB_COMPRESSION:
        return true;
    default:
        return false;
    }
}

// The file read whole, if it is a regular file of at most kExrBytesReadWhole bytes that can be read
// to its end; else none, and it is read as a stream, which says what went wrong.
std::unique_ptr<Imf::IStream> readSmallFile(const std::string& path) {
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return nullptr;
    struct stat status {};
    std::unique_ptr<char[]> bytes;
    size_t done = 0;
    if (fstat(fd, &status) == 0 && S_ISREG(status.st_mode) && status.st_size <= kExrBytesReadWhole) {
        bytes = std::make_unique_for_overwrite<char[]>(size_t(status.st_size));
        while (bytes && done < size_t(status.st_size)) {
            const ssize_t got = ::read(fd, bytes.get() + done, size_t(status.st_size) - done);
            if (got < 0 && errno == EINTR) continue;
            if (got < 0) bytes.reset();
            if (got <= 0) break; // an error, or a file that shrank: what was there is read
            done += size_t(got);
        }
    }
    close(fd);
    return bytes ? std::make_unique<FileInMemory>(path, std::move(bytes), done) : nullptr;
}

// The file as a stream, then, if its first part is scanlines or tiles in large compressed chunks
// and it is small, read whole.
std::unique_ptr<Imf::MultiPartInputFile> openFile(const std::string& path,
                                                  std::unique_ptr<Imf::IStream>& stream) {
    auto file = std::make_unique<Imf::MultiPartInputFile>(path.c_str(), Imf::globalThreadCount());
    const Imf::Header& header = file->header(0);
    if ((header.hasType() && Imf::isDeepData(header.type())) || !hasLargeCompressedChunks(header))
        return file;
    stream = readSmallFile(path);
    return stream ? std::make_unique<Imf::MultiPartInputFile>(*stream, Imf::globalThreadCount())
                  : std::move(file);
}

class ExrDecoder final : public ImageDecoder {
  public:
    explicit ExrDecoder(const std::string& path) : path_(path) {
        startThreadPool();
        try {
            file_ = openFile(path, stream_);
            const Imf::Header& header = file_->header(0);
            // The image is the display window; the pixels stored (the data window) may cover part
            // of it, the rest black, as OpenEXR defines it, or reach past it (overscan), cut off.
            dataWindow_ = header.dataWindow();
            displayWindow_ = header.displayWindow();
            header_.width = windowWidth(displayWindow_);
            header_.height = windowHeight(displayWindow_);
            checkDataWindow(path);
            header_.volumeOrDeep = header.hasType() && Imf::isDeepData(header.type());
            header_.channels = channelsInOpenImageIoOrder(header.channels());
            header_.srgb = false; // OpenEXR holds linear values; OpenImageIO named them "Linear"
            if (const auto* attribute =
                    header.findTypedAttribute<Imf::ChromaticitiesAttribute>("chromaticities")) {
                const Imf::Chromaticities& c = attribute->value();
                header_.chromaticities = Chromaticities{xy(c.red), xy(c.green), xy(c.blue), xy(c.white)};
            }
            for (auto channel = header.channels().begin(); channel != header.channels().end(); ++channel)
                if (channel.channel().xSampling != 1 || channel.channel().ySampling != 1)
                    throw Error(ErrorKind::Input, path + ": channel " + printable(channel.name()) +
                                                      " is subsampled (" +
                                                      std::to_string(channel.channel().xSampling) + " x " +
                                                      std::to_string(channel.channel().ySampling) +
                                                      "), and shprobe reads only full-resolution EXR "
                                                      "channels; store the image at full resolution");
            if (!header_.volumeOrDeep) part_ = std::make_unique<Imf::InputPart>(*file_, 0);
        } catch (const Error&) {
            throw;
        } catch (const std::bad_alloc&) { // not a bad file: the machine's memory
            throw Error(ErrorKind::Memory, path + ": out of memory reading its header");
        } catch (const std::exception& error) {
            throw Error(ErrorKind::Input,
                        path + ": not an image the EXR reader can read (" + oneLine(error.what()) + ")");
        }
    }

    void readChannels(int begin, int end, float* first) override {
        if (!part_) throw Error(ErrorKind::Input, path_ + ": deep images are not supported");
        if (begin < 0 || end > int(header_.channels.size()) || begin >= end || end - begin > 4)
            throw Error(ErrorKind::Input, path_ + ": no channels " + std::to_string(begin) + " to " +
                                              std::to_string(end) + " to read");
        if (dataWindow_ == displayWindow_) {
            readRows(begin, end, first, dataWindow_.min.y, dataWindow_.max.y);
            return;
        }
        readWindows(begin, end, first);
    }

    // A scanline image's chunks lie in the file in its line order, so a file cut short lacks the
    // last: that one chunk is read raw (not decompressed). Tiles, in any order, are left to
    // readChannels.
    void checkData() override {
        if (!part_) return;
        const Imf::Header& header = part_->header();
        if (header.hasTileDescription()) return;
        const int last = header.lineOrder() == Imf::DECREASING_Y ? dataWindow_.min.y : dataWindow_.max.y;
        try {
            const char* data = nullptr;
            int size = 0;
            part_->rawPixelData(last, data, size);
        } catch (const std::exception& error) {
            failPixels(error);
        }
    }

  private:
    static int windowWidth(const Imath::Box2i& window) {
        return int(std::min<int64_t>(int64_t(window.max.x) - window.min.x + 1, INT32_MAX));
    }
    static int windowHeight(const Imath::Box2i& window) {
        return int(std::min<int64_t>(int64_t(window.max.y) - window.min.y + 1, INT32_MAX));
    }

    static std::string windowText(const Imath::Box2i& w) {
        return "(" + std::to_string(w.min.x) + ", " + std::to_string(w.min.y) + ") to (" +
               std::to_string(w.max.x) + ", " + std::to_string(w.max.y) + ")";
    }

    // The stored pixels must meet the image, and be no wider or taller than an image may be: they are
    // read a whole row at a time.
    void checkDataWindow(const std::string& path) const {
        if (dataWindow_ == displayWindow_) return;
        const std::string windows =
            "its data window " + windowText(dataWindow_) + ", display window " + windowText(displayWindow_);
        const bool meets =
            dataWindow_.min.x <= displayWindow_.max.x && dataWindow_.max.x >= displayWindow_.min.x &&
            dataWindow_.min.y <= displayWindow_.max.y && dataWindow_.max.y >= displayWindow_.min.y;
        if (!meets)
            throw Error(ErrorKind::Input, path + ": no pixel of the image is stored (" + windows + ")");
        if (windowWidth(dataWindow_) > kMaxImageSide || windowHeight(dataWindow_) > kMaxImageSide)
            throw Error(ErrorKind::Input, path + ": the stored pixels are longer than the limit of " +
                                              std::to_string(kMaxImageSide) + " pixels per side (" + windows +
                                              ")");
    }

    // The display window's texels where the data window differs: black, then the stored pixels
    // within it, read a strip of rows at a time (OpenEXR reads whole rows of the data window) so that
    // overscan costs a strip, not a second image.
    void readWindows(int begin, int end, float* first) {
        const int channels = end - begin;
        for (size_t t = 0; t < size_t(header_.width) * size_t(header_.height); ++t)
            std::fill_n(first + 4 * t, channels, 0.0f);
        constexpr int kStripRows = 64;
        const int top = std::max(dataWindow_.min.y, displayWindow_.min.y);
        const int bottom = std::min(dataWindow_.max.y, displayWindow_.max.y);
        const int left = std::max(dataWindow_.min.x, displayWindow_.min.x);
        const int right = std::min(dataWindow_.max.x, displayWindow_.max.x);
        const size_t dataWidth = size_t(windowWidth(dataWindow_));
        std::vector<float> strip;
        try {
            strip.resize(4 * dataWidth * size_t(std::min(kStripRows, bottom - top + 1)));
        } catch (const std::bad_alloc&) {
            throw Error(ErrorKind::Memory, path_ + ": out of memory for a strip of its stored rows");
        }
        for (int y0 = top; y0 <= bottom; y0 += kStripRows) {
            const int y1 = std::min(bottom, y0 + kStripRows - 1);
            readRows(begin, end, strip.data(), y0, y1);
            for (int y = y0; y <= y1; ++y)
                for (int x = left; x <= right; ++x) {
                    const float* from =
                        &strip[4 * (size_t(y - y0) * dataWidth + size_t(x - dataWindow_.min.x))];
                    float* to = first + 4 * (size_t(y - displayWindow_.min.y) * size_t(header_.width) +
                                             size_t(x - displayWindow_.min.x));
                    std::copy_n(from, channels, to);
                }
        }
    }

    // Channels [begin, end) of the data window's rows top..bottom into texels of 4 floats from
    // `first` on, a row of the data window's width each.
    void readRows(int begin, int end, float* first, int top, int bottom) {
        try {
            const Imf::ChannelList& list = part_->header().channels();
            constexpr size_t kTexel = 4 * sizeof(float);
            const size_t row = kTexel * size_t(windowWidth(dataWindow_));
            const Imath::Box2i window(Imath::V2i(dataWindow_.min.x, top),
                                      Imath::V2i(dataWindow_.max.x, bottom));
            Imf::FrameBuffer frame;
            std::vector<float*> unsignedChannels;
            for (int c = begin; c < end; ++c) {
                const std::string& name = header_.channels[size_t(c)];
                float* at = first + (c - begin);
                // Unsigned integers land as they are and are normalized below, as OpenImageIO did
                // (OpenEXR itself would convert them to float unscaled).
                const bool isUnsigned = list.findChannel(name)->type == Imf::UINT;
                if (isUnsigned) unsignedChannels.push_back(at);
                frame.insert(name,
                             Imf::Slice::Make(isUnsigned ? Imf::UINT : Imf::FLOAT, at, window, kTexel, row));
            }
            part_->setFrameBuffer(frame);
            part_->readPixels(top, bottom);
            const size_t texels = size_t(windowWidth(dataWindow_)) * size_t(bottom - top + 1);
            for (float* at : unsignedChannels)
                for (size_t t = 0; t < texels; ++t) {
                    uint32_t value;
                    std::memcpy(&value, at + 4 * t, sizeof value);
                    at[4 * t] = float(value) * (1.0f / 4294967295.0f); // as OpenImageIO's convert_type
                }
        } catch (const std::exception& error) {
            failPixels(error);
        }
    }

    // OpenEXR's message on one line. rawPixelData puts "Error reading pixel data from image file
    // \"X\". " before a message that may begin so already: the sentence is said once.
    [[noreturn]] void failPixels(const std::exception& error) const {
        if (dynamic_cast<const std::bad_alloc*>(&error)) // not a bad file: the machine's memory
            throw Error(ErrorKind::Memory, path_ + ": out of memory reading the pixels");
        std::string text = oneLine(error.what());
        const size_t end = text.find(". ");
        if (end != std::string::npos && text.compare(end + 2, end + 2, text, 0, end + 2) == 0)
            text.erase(0, end + 2);
        throw Error(ErrorKind::Input,
                    path_ + ": cannot read the pixels; the file may be truncated or corrupt (" + text + ")");
    }

    std::string path_;
    std::unique_ptr<Imf::IStream> stream_; // the file in memory, which file_ reads; or none
    std::unique_ptr<Imf::MultiPartInputFile> file_;
    std::unique_ptr<Imf::InputPart> part_;
    Imath::Box2i dataWindow_;
    Imath::Box2i displayWindow_;
};

// An output stream into a string; OpenEXR seeks back to fill in the offset table at the end.
class StringStream final : public Imf::OStream {
  public:
    explicit StringStream(std::string& bytes) : Imf::OStream("memory"), bytes_(bytes) {}
    void write(const char c[], int n) override {
        if (n <= 0) return;
        if (position_ + uint64_t(n) > bytes_.size()) bytes_.resize(size_t(position_) + size_t(n));
        std::memcpy(bytes_.data() + position_, c, size_t(n));
        position_ += uint64_t(n);
    }
    uint64_t tellp() override { return position_; }
    void seekp(uint64_t position) override { position_ = position; }

  private:
    std::string& bytes_;
    uint64_t position_ = 0;
};

void checkPixels(const FloatPixels& pixels, const std::string& what) {
    auto fail = [&](const std::string& reason) {
        throw Error(ErrorKind::Output, "cannot write " + what + ": " + reason);
    };
    if (pixels.width < 1 || pixels.height < 1)
        fail("the image has no pixels (" + std::to_string(pixels.width) + "x" +
             std::to_string(pixels.height) + ")");
    if (pixels.channels < 1 || pixels.channels > 4 || pixels.pixelStride < pixels.channels)
        fail(std::to_string(pixels.channels) + " channels every " + std::to_string(pixels.pixelStride) +
             " values cannot be written");
    if (!pixels.data) fail("no pixels given");
}

std::unique_ptr<ImageDecoder> openDecoder(const std::string& path) {
    return std::make_unique<ExrDecoder>(path);
}

std::string encode(const FloatPixels& pixels, const std::string& what) {
    checkPixels(pixels, what);
    startThreadPool();
    // The channel names OpenImageIO gave 1 to 4 channels: Y; Y, A; R, G, B; R, G, B, A.
    static const std::array<std::vector<const char*>, 4> kNames{
        {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}}};
    const std::vector<const char*>& names = kNames[size_t(pixels.channels - 1)];
    std::string bytes;
    try {
        Imf::Header header(pixels.width, pixels.height, 1.0f, Imath::V2f(0, 0), 1.0f, Imf::INCREASING_Y,
                           Imf::ZIP_COMPRESSION);
        for (const char* name : names)
            header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        StringStream stream(bytes);
        Imf::OutputFile file(stream, header, Imf::globalThreadCount());
        const size_t texel = sizeof(float) * size_t(pixels.pixelStride);
        Imf::FrameBuffer frame;
        for (size_t c = 0; c < names.size(); ++c)
            frame.insert(names[c],
                         Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(pixels.data + c)),
                                    texel, texel * size_t(pixels.width)));
        file.setFrameBuffer(frame);
        file.writePixels(pixels.height);
    } catch (const std::exception& error) {
        throw Error(ErrorKind::Output, "cannot write " + what + ": " + oneLine(error.what()));
    }
    return bytes;
}

constexpr ExrPlugin kPlugin{openDecoder, encode};

} // namespace
} // namespace shprobe

extern "C" __attribute__((visibility("default"))) const shprobe::ExrPlugin* shprobe_exr_plugin_v1() {
    return &shprobe::kPlugin;
}
