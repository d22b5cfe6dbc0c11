// The OpenImageIO plugin (image/oiio_plugin.h): a decoder and an encoder over OpenImageIO, built
// as libshprobe_oiio.so and loaded only for the formats shprobe does not handle itself. It uses
// nothing of the shprobe libraries but their headers, so that it loads into a program that links
// them statically as well as shared.
#include "image/oiio_plugin.h"

#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

#include <cctype>
#include <cstdio>
#include <fcntl.h>
#include <mutex>
#include <sstream>
#include <sys/mman.h>
#include <unistd.h>

namespace shprobe {
namespace {

// What the libraries under OpenImageIO print to stderr themselves during one of its calls
// (libpng's default handlers print "libpng error: ..." and "libpng warning: ..." before OpenImageIO
// reports the same), captured in a memory file so that the program's error stays one line. One
// capture at a time: stderr is the process's.
class StderrCapture {
  public:
    explicit StderrCapture(std::string path) : path_(std::move(path)), lock_(mutex()) {
        std::fflush(stderr);
        file_ = memfd_create("shprobe-stderr", MFD_CLOEXEC);
        if (file_ >= 0) saved_ = fcntl(2, F_DUPFD_CLOEXEC, 3);
        if (saved_ >= 0 && dup2(file_, 2) >= 0) return;
        closeAll(); // stderr stays as it is
    }
    ~StderrCapture() {
        // Not folded into an error (the call succeeded, or threw): said as the program's warnings.
        // A line of the program's own, from another thread meanwhile, is passed on as it is.
        std::istringstream lines(finish());
        std::string text;
        for (std::string line; std::getline(lines, line);)
            if (!line.empty())
                text += line.starts_with("shprobe: ") ? line + "\n"
                                                      : "shprobe: warning: " + path_ + ": " + line + "\n";
        if (!text.empty()) (void)!write(2, text.data(), text.size());
    }
    StderrCapture(const StderrCapture&) = delete;
    StderrCapture& operator=(const StderrCapture&) = delete;

    // OpenImageIO's reason, with the captured lines it does not already say: "libpng error: X" is
    // left out of "PNG read error: X". Ends the capture.
    std::string fold(const std::string& reason) {
        std::string folded = oneLine(reason), other;
        std::istringstream lines(finish());
        for (std::string line; std::getline(lines, line);) {
            if (line.starts_with("shprobe: ")) {
                other += line + "\n";
                continue;
            }
            const size_t colon = line.find(": ");
            const std::string tail = colon == std::string::npos ? line : line.substr(colon + 2);
            if (!tail.empty() && folded.find(tail) == std::string::npos)
                folded += (folded.empty() ? "" : "; ") + line;
        }
        if (!other.empty()) (void)!write(2, other.data(), other.size());
        return folded;
    }

  private:
    static std::mutex& mutex() {
        static std::mutex one;
        return one;
    }
    // Restores stderr and gives what was written meanwhile (up to 64 KiB).
    std::string finish() {
        if (saved_ < 0) return {};
        std::fflush(stderr);
        dup2(saved_, 2);
        std::string text(64 * 1024, '\0');
        const ssize_t got = pread(file_, text.data(), text.size(), 0);
        text.resize(size_t(std::max<ssize_t>(got, 0)));
        closeAll();
        return text;
    }
    void closeAll() {
        if (saved_ >= 0) close(saved_);
        if (file_ >= 0) close(file_);
        saved_ = file_ = -1;
    }

    std::string path_;
    std::lock_guard<std::mutex> lock_;
    int file_ = -1;
    int saved_ = -1;
};

// Integer images are sRGB-encoded unless the file says otherwise; float images are linear.
bool isSrgbEncoded(const OIIO::ImageSpec& spec) {
    if (spec.format.is_floating_point()) return false;
    std::string space = spec.get_string_attribute("oiio:ColorSpace");
    bool linear = OIIO::Strutil::icontains(space, "linear") || OIIO::Strutil::istarts_with(space, "lin_");
    return !linear;
}

// The file's chromaticities attribute (float[8]: red, green, blue, white xy), if it has one.
std::optional<Chromaticities> chromaticitiesOf(const OIIO::ImageSpec& spec) {
    float xy[8];
    if (!spec.getattribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), xy))
        return std::nullopt;
    return Chromaticities{{xy[0], xy[1]}, {xy[2], xy[3]}, {xy[4], xy[5]}, {xy[6], xy[7]}};
}

// "the TIFF reader", from the file's extension ("shprobe" for a file without one): an error names the
// format the user gave (a text file named sky.exr: the EXR reader), not the library behind it.
std::string readerOf(const std::string& path) {
    const size_t dot = path.rfind('.');
    if (dot == std::string::npos || dot + 1 == path.size() || path.find('/', dot) != std::string::npos)
        return "shprobe";
    std::string format;
    for (char c : path.substr(dot + 1))
        format += char(std::toupper(static_cast<unsigned char>(c)));
    return "the " + format + " reader";
}

class OiioDecoder : public ImageDecoder {
  public:
    explicit OiioDecoder(const std::string& path) : path_(path) {
        // Alpha is ignored, so colour must come as stored: OIIO would otherwise premultiply the
        // unassociated alpha of Targa and similar formats into it.
        OIIO::ImageSpec config;
        config.attribute("oiio:UnassociatedAlpha", 1);
        StderrCapture capture(path);
        input_ = OIIO::ImageInput::open(path, &config);
        if (!input_)
            throw Error(ErrorKind::Input, path + ": not an image " + readerOf(path) + " can read (" +
                                              capture.fold(OIIO::geterror()) + ")");
        const OIIO::ImageSpec& spec = input_->spec();
        header_.width = spec.width;
        header_.height = spec.height;
        header_.volumeOrDeep = spec.depth > 1 || spec.deep;
        header_.channels = spec.channelnames;
        header_.srgb = isSrgbEncoded(spec);
        header_.chromaticities = chromaticitiesOf(spec);
    }

    void readChannels(int begin, int end, float* first) override {
        constexpr OIIO::stride_t texelStride = 4 * sizeof(float);
        StderrCapture capture(path_);
        if (!input_->read_image(0, 0, begin, end, OIIO::TypeDesc::FLOAT, first, texelStride,
                                texelStride * header_.width))
            throw Error(ErrorKind::Input,
                        path_ + ": cannot read the pixels; the file may be truncated or corrupt (" +
                            capture.fold(input_->geterror()) + ")");
    }

  private:
    std::string path_;
    std::unique_ptr<OIIO::ImageInput> input_;
};

std::unique_ptr<ImageDecoder> openDecoder(const std::string& path) {
    return std::make_unique<OiioDecoder>(path);
}

[[noreturn]] void failWrite(const std::string& destination, const std::string& why) {
    throw Error(ErrorKind::Output, "cannot write " + destination + ": " + why);
}

bool writePixels(OIIO::ImageOutput& output, const OiioImageRequest& request) {
    if (request.bytes) {
        const BytePixels& pixels = *request.bytes;
        const OIIO::stride_t stride = pixels.pixelStride;
        return output.write_image(OIIO::TypeDesc::UINT8, pixels.data, stride, stride * pixels.width);
    }
    const FloatPixels pixels = request.floats(output.spec().format.is_floating_point());
    const OIIO::stride_t stride = OIIO::stride_t(pixels.pixelStride * sizeof(float));
    return output.write_image(OIIO::TypeDesc::FLOAT, pixels.data, stride, stride * pixels.width);
}

void encode(const OiioImageRequest& request) {
    const std::string& destination = request.destination;
    std::unique_ptr<OIIO::ImageOutput> output =
        OIIO::ImageOutput::create(request.format.empty() ? destination : request.format);
    if (!output) failWrite(destination, "no image format for this extension (" + OIIO::geterror() + ")");
    OIIO::ImageSpec spec(request.width, request.height, request.channels,
                         request.bytes ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT);
    if (request.bytes) {
        spec.attribute("oiio:UnassociatedAlpha", 1); // the bytes as they are
        if (request.channels == 3) spec.attribute("oiio:ColorSpace", "sRGB");
    }
    if (!output->open(request.memoryPath, spec)) failWrite(destination, output->geterror());
    if (!writePixels(*output, request)) failWrite(destination, output->geterror());
    if (!output->close()) failWrite(destination, output->geterror());
}

constexpr OiioPlugin kPlugin{openDecoder, encode};

} // namespace
} // namespace shprobe

extern "C" __attribute__((visibility("default"))) const shprobe::OiioPlugin* shprobe_oiio_plugin_v1() {
    return &shprobe::kPlugin;
}
