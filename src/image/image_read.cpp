// Reading environment images through OpenImageIO and loading them as cube maps: single images
// (equirect or cross) and six face files. Every failure is an Error(Input) naming the file.
#include "shprobe/image/environment.h"

#include "shprobe/image/channels.h"
#include "shprobe/io/input_file.h"
#include "shprobe/sh/error.h"
#include "shprobe/sh/scope_exit.h"

#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fcntl.h>
#include <filesystem>
#include <memory>
#include <mutex>
#include <span>
#include <string_view>
#include <sys/mman.h>
#include <unistd.h>

namespace shprobe {
namespace fs = std::filesystem;

namespace {

// Library messages may span lines; an error is one line, so their lines are joined with "; ".
std::string oneLine(std::string text) {
    while (!text.empty() && text.back() == '\n')
        text.pop_back();
    for (size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at))
        text.replace(at, 1, "; ");
    return text;
}

// libpng prints its errors and warnings to stderr itself ("libpng error: ..."), and OpenImageIO
// then reports the same text as its error, which our one error line carries. While images are
// opened and read, the process's stderr (fd 2) goes to an in-memory file; when the last read in
// progress ends, every line printed meanwhile is passed on to the real stderr except libpng's.
// Reads on several threads share one capture. Sanitizer builds leave stderr alone: a report must
// reach it even if the read crashes.
#if defined(__SANITIZE_ADDRESS__)
#define SHPROBE_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SHPROBE_ADDRESS_SANITIZER 1
#endif
#endif

class LibraryChatter {
  public:
    LibraryChatter() {
#if !defined(SHPROBE_ADDRESS_SANITIZER)
        Capture& capture = shared();
        std::lock_guard lock(capture.mutex);
        if (capture.readers++ == 0) capture.start();
#endif
    }
    ~LibraryChatter() {
#if !defined(SHPROBE_ADDRESS_SANITIZER)
        Capture& capture = shared();
        std::lock_guard lock(capture.mutex);
        if (--capture.readers == 0) capture.stop();
#endif
    }
    LibraryChatter(const LibraryChatter&) = delete;
    LibraryChatter& operator=(const LibraryChatter&) = delete;

  private:
    struct Capture {
        std::mutex mutex;
        int readers = 0;
        int file = -1;  // the in-memory file fd 2 points to
        int saved = -1; // the real stderr
        void start() {
            std::fflush(stderr);
            file = memfd_create("shprobe-image-messages", MFD_CLOEXEC);
            saved = file >= 0 ? dup(STDERR_FILENO) : -1;
            if (saved < 0 || dup2(file, STDERR_FILENO) < 0) release();
        }
        void stop() {
            if (saved < 0) return;
            std::fflush(stderr);
            dup2(saved, STDERR_FILENO);
            passOn();
            release();
        }
        void passOn() const {
            std::string text;
            char buffer[4096];
            ssize_t got = 0;
            for (off_t at = 0; (got = pread(file, buffer, sizeof(buffer), at)) > 0; at += got)
                text.append(buffer, size_t(got));
            for (size_t start = 0; start < text.size();) {
                size_t end = std::min(text.find('\n', start), text.size() - 1) + 1;
                std::string_view line(text.data() + start, end - start);
                if (!line.starts_with("libpng ")) std::fwrite(line.data(), 1, line.size(), stderr);
                start = end;
            }
        }
        void release() {
            if (saved >= 0) close(saved);
            if (file >= 0) close(file);
            saved = file = -1;
        }
    };
    static Capture& shared() {
        static Capture* capture = new Capture; // never destroyed: reads may run while statics are
        return *capture;
    }
};

// File names of the faces in Face order (+X, -X, +Y, -Y, +Z, -Z), and the pattern placeholder.
constexpr std::array<std::string_view, kFaceCount> kFaceNames{"px", "nx", "py", "ny", "pz", "nz"};
constexpr std::string_view kFacePlaceholder = "{face}";

std::string sizeText(int width, int height) {
    return std::to_string(width) + "x" + std::to_string(height);
}

// OpenImageIO's readers allocate what a header claims before they find the file shorter (an EXR
// attribute claiming 2 GiB, a PNG text chunk as long): the header is read within the file's size
// first (image/channels.h).
void checkHeaderBounds(const std::string& path) {
    int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) throwInputError(path, errno);
    ScopeExit closeFile([&] { close(fd); });
    checkImageHeader(fd, path);
}

std::unique_ptr<OIIO::ImageInput> openImage(const std::string& path) {
    // Alpha is ignored, so colour must come as stored: OIIO would otherwise premultiply the
    // unassociated alpha of PNG and similar formats into it.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path, &config);
    if (!input)
        throw Error(ErrorKind::Input,
                    path + ": not an image OpenImageIO can read (" + oneLine(OIIO::geterror()) + ")");
    return input;
}

// "134217728 pixels (16384 x 8192)" for the default, the plain count for any other limit.
std::string pixelLimitText(int64_t maxPixels) {
    std::string text = std::to_string(maxPixels) + " pixels";
    return maxPixels == kDefaultMaxImagePixels ? text + " (16384x8192)" : text;
}

// From the header alone: nothing of the size it claims has been allocated yet.
void checkSpec(const std::string& path, const OIIO::ImageSpec& spec, int64_t maxPixels) {
    if (spec.width < 1 || spec.height < 1)
        throw Error(ErrorKind::Input,
                    path + ": the image has no pixels (" + sizeText(spec.width, spec.height) + ")");
    const int64_t pixels = int64_t(spec.width) * spec.height;
    if (spec.width > kMaxImageSide || spec.height > kMaxImageSide)
        throw Error(ErrorKind::Input, path + ": the image is " + sizeText(spec.width, spec.height) +
                                          ", longer than the limit of " + std::to_string(kMaxImageSide) +
                                          " pixels per side");
    if (pixels > maxPixels)
        throw Error(ErrorKind::Input, path + ": the image is " + sizeText(spec.width, spec.height) + " (" +
                                          std::to_string(pixels) + " pixels), more than the limit of " +
                                          pixelLimitText(maxPixels) + "; raise it with --max-pixels");
    // Volume and deep images hold more than width x height values per channel.
    if (spec.depth > 1 || spec.deep)
        throw Error(ErrorKind::Input, path + ": volume and deep images are not supported");
    if (spec.nchannels < 1) throw Error(ErrorKind::Input, path + ": the image has no channels");
}

// Integer images are sRGB-encoded unless the file says otherwise; float images are linear.
bool isSrgbEncoded(const OIIO::ImageSpec& spec) {
    if (spec.format.is_floating_point()) return false;
    std::string space = spec.get_string_attribute("oiio:ColorSpace");
    bool linear = OIIO::Strutil::icontains(space, "linear") || OIIO::Strutil::istarts_with(space, "lin_");
    return !linear;
}

// Reads channels [begin, end) into consecutive components of every texel from `first` on,
// converted to float (integers normalized to [0, 1]).
void readChannelRange(const std::string& path, OIIO::ImageInput& input, int begin, int end, float* first,
                      int width) {
    constexpr OIIO::stride_t texelStride = sizeof(glm::vec4);
    if (!input.read_image(0, 0, begin, end, OIIO::TypeDesc::FLOAT, first, texelStride, texelStride * width))
        throw Error(ErrorKind::Input, path +
                                          ": cannot read the pixels; the file may be truncated or corrupt (" +
                                          oneLine(input.geterror()) + ")");
}

// Reads the planned channels only, straight into the RGBA texels: in one read when they lie
// within four channels of each other (the usual R, G, B, or Y, BY, RY), else one read each.
// Returns the texel component each planned channel landed in.
std::array<int, 3> readPlannedChannels(const std::string& path, OIIO::ImageInput& input,
                                       const ChannelPlan& plan, Image& image) {
    const auto planned = std::span(plan.channels).first(size_t(plan.count()));
    const auto [low, high] = std::minmax_element(planned.begin(), planned.end());
    const int begin = *low, end = *high + 1;
    if (end - begin <= 4) {
        readChannelRange(path, input, begin, end, &image.texels[0].x, image.width);
        return {plan.channels[0] - begin, plan.channels[1] - begin, plan.channels[2] - begin};
    }
    for (size_t i = 0; i < planned.size(); ++i)
        readChannelRange(path, input, planned[i], planned[i] + 1, &image.texels[0][int(i)], image.width);
    return {0, 1, 2};
}

// The file's chromaticities attribute (float[8]: red, green, blue, white xy), or BT.709's.
Chromaticities chromaticitiesOf(const OIIO::ImageSpec& spec) {
    Chromaticities chromaticities;
    float xy[8];
    if (!spec.getattribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), xy))
        return chromaticities;
    chromaticities.red = {xy[0], xy[1]};
    chromaticities.green = {xy[2], xy[3]};
    chromaticities.blue = {xy[4], xy[5]};
    chromaticities.white = {xy[6], xy[7]};
    return chromaticities;
}

// Reads the channels the plan names and makes them RGB. The unused alpha is set to 1, as in every
// cube map the library makes.
Image readPixels(const std::string& path, OIIO::ImageInput& input, const OIIO::ImageSpec& spec,
                 const ChannelPlan& plan) {
    Image image = makeImage(spec.width, spec.height);
    const std::array<int, 3> at = readPlannedChannels(path, input, plan, image);
    const glm::vec3 weights = plan.meaning == ChannelMeaning::LuminanceChroma
                                  ? luminanceWeights(chromaticitiesOf(spec), path)
                                  : glm::vec3(0.0f);
    for (glm::vec4& texel : image.texels) {
        glm::vec3 stored(texel[at[0]], texel[at[1]], texel[at[2]]);
        glm::vec3 rgb = plan.meaning == ChannelMeaning::Grey ? glm::vec3(stored[0])
                        : plan.meaning == ChannelMeaning::Rgb
                            ? stored
                            : luminanceChromaToRgb(stored[0], stored[1], stored[2], weights);
        texel = glm::vec4(rgb, 1.0f);
    }
    return image;
}

// The exact sRGB EOTF (IEC 61966-2-1), evaluated in double.
float srgbToLinear(float encoded) {
    double c = encoded;
    return float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

void decodeSrgb(Image& image) {
    for (glm::vec4& texel : image.texels)
        texel = glm::vec4(srgbToLinear(texel.r), srgbToLinear(texel.g), srgbToLinear(texel.b), texel.a);
}

std::string replaceAll(std::string text, std::string_view from, std::string_view to) {
    for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
        text.replace(at, from.size(), to);
    return text;
}

// A face file that exists; anything else wrong with it (a folder, a device, no permission) is said
// when it is read. A loop of links or a name too long is said here: "PATH: REASON".
std::string faceFileFromPattern(const std::string& pattern, std::string_view name) {
    std::string path = replaceAll(pattern, kFacePlaceholder, name);
    if (inputPathKind(path) == PathKind::Missing)
        throw Error(ErrorKind::Input, pattern + ": face file " + path + " does not exist");
    return path;
}

// The folder's entries, sorted; "FOLDER: REASON" when it cannot be listed.
std::vector<fs::path> folderEntries(const std::string& folder) {
    std::error_code error;
    std::vector<fs::path> entries;
    fs::directory_iterator entry(folder, error);
    for (; !error && entry != fs::directory_iterator(); entry.increment(error))
        entries.push_back(entry->path());
    if (error) throwInputError(folder, error.value());
    std::sort(entries.begin(), entries.end());
    return entries;
}

// The one regular file of the folder named <name>.<any extension>. Only entries of that name are
// looked at, so a loop of links among the other files does not matter; in one of them it is said.
std::string faceFileInFolder(const std::string& folder, std::string_view name) {
    std::vector<std::string> matches;
    for (const fs::path& entry : folderEntries(folder))
        if (entry.stem() == name && inputPathKind(entry.string()) == PathKind::Regular)
            matches.push_back(entry.string());
    std::string expected = std::string(name) + ".<extension>";
    if (matches.empty())
        throw Error(ErrorKind::Input,
                    folder + ": no face file " + expected + " (a faces folder holds px, nx, py, ny, pz, nz)");
    if (matches.size() > 1)
        throw Error(ErrorKind::Input,
                    folder + ": both " + matches[0] + " and " + matches[1] + " could be face " + expected);
    return matches[0];
}

// Every face square and of the first face's size.
void checkFaceSizes(const std::array<std::string, kFaceCount>& paths,
                    const std::array<Image, kFaceCount>& faces) {
    for (int face = 0; face < kFaceCount; ++face) {
        const Image& image = faces[size_t(face)];
        std::string size = sizeText(image.width, image.height);
        if (image.width != image.height)
            throw Error(ErrorKind::Input,
                        paths[size_t(face)] + ": the face is " + size + "; faces must be square");
        if (image.width != faces[0].width)
            throw Error(ErrorKind::Input, paths[size_t(face)] + " is " + size + " but " + paths[0] + " is " +
                                              sizeText(faces[0].width, faces[0].height) +
                                              "; the six faces must be the same size");
    }
}

Cubemap assembleFaces(const std::array<Image, kFaceCount>& faces) {
    Cubemap cubemap = makeCubemap(faces[0].width);
    size_t faceTexels = size_t(cubemap.faceSize) * cubemap.faceSize;
    for (int face = 0; face < kFaceCount; ++face)
        std::copy(faces[size_t(face)].texels.begin(), faces[size_t(face)].texels.end(),
                  cubemap.texels.begin() + std::ptrdiff_t(face * faceTexels));
    return cubemap;
}

Cubemap resizedTo(Cubemap cubemap, int faceSize) {
    return faceSize == 0 ? cubemap : resizeCubemap(cubemap, faceSize);
}

Environment loadFaces(const std::string& source, const LoadOptions& options) {
    std::array<std::string, kFaceCount> paths = resolveFaceFiles(source);
    std::array<Image, kFaceCount> faces;
    size_t replaced = 0;
    for (int face = 0; face < kFaceCount; ++face) {
        faces[size_t(face)] = readImage(paths[size_t(face)], options.maxPixels);
        replaced += applyNonFinitePolicy(faces[size_t(face)].texels, options.nonFinite, paths[size_t(face)]);
    }
    checkFaceSizes(paths, faces);
    Environment environment;
    environment.cubemap = resizedTo(assembleFaces(faces), options.faceSize);
    environment.layout = Layout::Faces;
    environment.description = source + " (faces " + sizeText(faces[0].width, faces[0].height) + ")";
    environment.replacedTexels = replaced;
    return environment;
}

// The layout to use: the one asked for, or the one the aspect ratio gives.
Layout chooseLayout(const Image& image, Layout requested) {
    if (requested == Layout::Faces)
        throw Error(ErrorKind::Input, "layout faces needs a folder or a pattern containing {face}");
    return requested == Layout::Auto ? detectLayout(image.width, image.height) : requested;
}

Cubemap imageToCubemap(const Image& image, Layout layout, int faceSize) {
    if (layout == Layout::Equirect)
        return equirectToCubemap(image, faceSize > 0 ? faceSize : std::max(1, image.width / 4));
    return resizedTo(crossToCubemap(image, layout), faceSize);
}

Environment loadSingleImage(const std::string& path, const LoadOptions& options) {
    Image image = readImage(path, options.maxPixels);
    Environment environment;
    environment.replacedTexels = applyNonFinitePolicy(image.texels, options.nonFinite, path);
    try {
        environment.layout = chooseLayout(image, options.layout);
        environment.cubemap = imageToCubemap(image, environment.layout, options.faceSize);
    } catch (const Error& error) {
        throw Error(error.kind(), path + ": " + error.what());
    }
    environment.description =
        path + " (" + layoutName(environment.layout) + " " + sizeText(image.width, image.height) + ")";
    return environment;
}

} // namespace

Image readImage(const std::string& path, int64_t maxPixels) {
    checkInputFile(path, "an image file");
    checkHeaderBounds(path);
    Image image;
    bool srgb = false;
    {
        LibraryChatter quiet;
        std::unique_ptr<OIIO::ImageInput> input = openImage(path);
        const OIIO::ImageSpec& spec = input->spec();
        checkSpec(path, spec, maxPixels);
        image = readPixels(path, *input, spec, planChannels(spec.channelnames, path));
        srgb = isSrgbEncoded(spec);
    }
    if (srgb) decodeSrgb(image);
    return image;
}

bool isFacesSource(const std::string& path) {
    return path.find(kFacePlaceholder) != std::string::npos || inputPathKind(path) == PathKind::Folder;
}

std::array<std::string, kFaceCount> resolveFaceFiles(const std::string& path) {
    bool pattern = path.find(kFacePlaceholder) != std::string::npos;
    if (!pattern && inputPathKind(path) != PathKind::Folder)
        throw Error(ErrorKind::Input, path + ": six face files need a folder or a pattern containing {face}");
    std::array<std::string, kFaceCount> paths;
    for (int face = 0; face < kFaceCount; ++face) {
        std::string_view name = kFaceNames[size_t(face)];
        paths[size_t(face)] = pattern ? faceFileFromPattern(path, name) : faceFileInFolder(path, name);
    }
    return paths;
}

Environment loadEnvironment(const std::string& path, const LoadOptions& options) {
    if (options.faceSize < 0)
        throw Error(ErrorKind::Input, "face size must be positive (or 0 for automatic), not " +
                                          std::to_string(options.faceSize));
    if (options.maxPixels < 1)
        throw Error(ErrorKind::Input,
                    "--max-pixels must be at least 1, not " + std::to_string(options.maxPixels));
    bool faces = options.layout == Layout::Faces || (options.layout == Layout::Auto && isFacesSource(path));
    return faces ? loadFaces(path, options) : loadSingleImage(path, options);
}

size_t applyNonFinitePolicy(std::vector<glm::vec4>& texels, NonFinitePolicy policy, const std::string& what) {
    auto nonFinite = [](const glm::vec4& t) {
        return !std::isfinite(t.r) || !std::isfinite(t.g) || !std::isfinite(t.b);
    };
    size_t count = size_t(std::count_if(texels.begin(), texels.end(), nonFinite));
    if (count == 0) return 0;
    if (policy == NonFinitePolicy::Refuse)
        throw Error(ErrorKind::Input,
                    what + ": " + std::to_string(count) +
                        " texels are NaN or infinite; use --sanitize to replace them with 0");
    for (glm::vec4& texel : texels)
        if (nonFinite(texel)) texel = glm::vec4(0.0f, 0.0f, 0.0f, texel.a);
    return count;
}

} // namespace shprobe
