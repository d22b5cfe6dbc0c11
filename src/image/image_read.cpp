// Reading environment images (image/codec.h) and loading them as cube maps: single images
// (equirect or cross) and six face files. Every failure is an Error(Input) naming the file.
#include "image/environment.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/parallel.h"
#include "common/scope_exit.h"
#include "image/channels.h"
#include "image/codec.h"
#include "image/oiio_plugin.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fcntl.h>
#include <filesystem>
#include <memory>
#include <numeric>
#include <span>
#include <string_view>
#include <unistd.h>

namespace shprobe {
namespace fs = std::filesystem;

namespace {

// File names of the faces in Face order (+X, -X, +Y, -Y, +Z, -Z), and the pattern placeholder.
constexpr std::array<std::string_view, kFaceCount> kFaceNames{"px", "nx", "py", "ny", "pz", "nz"};
constexpr std::string_view kFacePlaceholder = "{face}";

std::string sizeText(int width, int height) {
    return std::to_string(width) + "x" + std::to_string(height);
}

// What a file of shprobe's other kinds is, from its first bytes, for the refusal of an image input;
// nullptr for any other file (an image, or what OpenImageIO may read).
const char* otherFileKind(std::string_view start) {
    if (start.starts_with("SHPROBEV")) return "a probe volume (shprobe scene)";
    if (start.starts_with("SHPB")) return "a binary probe file";
    if (start.starts_with("SHPT")) return "a transfer file (shprobe transfer)";
    if (start.starts_with("glTF")) return "a binary glTF scene";
    const size_t first = start.find_first_not_of(" \t\r\n");
    if (first != std::string_view::npos && start[first] == '{') return "JSON (a probe file or a glTF scene)";
    return nullptr;
}

// Image readers allocate what a header claims before they find the file shorter (an EXR
// attribute claiming 2 GiB, a PNG text chunk as long): the header is read within the file's size
// first (image/channels.h). The format is the one the file's first bytes name.
ImageFormat checkHeaderAndFormat(const std::string& path) {
    int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) throwInputError(path, errno);
    ScopeExit closeFile([&] { close(fd); });
    checkImageHeader(fd, path);
    unsigned char start[512] = {};
    const size_t got = size_t(std::max<ssize_t>(pread(fd, start, sizeof start, 0), 0));
    // No format shprobe is meant to read begins with 512 zero bytes, and OpenImageIO's DICOM reader,
    // offered a file no other reader takes, reads such a file to its end 4 bytes at a time
    // (docs/reliability.md).
    if (got == sizeof start && std::all_of(start, start + got, [](unsigned char b) { return b == 0; }))
        throw Error(ErrorKind::Input,
                    path + ": not an image: its first " + std::to_string(got) + " bytes are all zero");
    if (const char* kind = otherFileKind({reinterpret_cast<const char*>(start), got}))
        throw Error(ErrorKind::Input, path + ": " + kind + ", not an image");
    return sniffImageFormat(start, got);
}

std::unique_ptr<ImageDecoder> openDecoder(const std::string& path, ImageFormat format) {
    switch (format) {
    case ImageFormat::Exr:
        return openExrDecoder(path);
    case ImageFormat::Hdr:
    case ImageFormat::Png:
    case ImageFormat::Jpeg:
        return openStbDecoder(path, format);
    case ImageFormat::Other:
        break;
    }
    return oiioPlugin(ErrorKind::Input, path).openDecoder(path);
}

// "134217728 pixels (16384 x 8192)" for the default, the plain count for any other limit.
std::string pixelLimitText(int64_t maxPixels) {
    std::string text = std::to_string(maxPixels) + " pixels";
    return maxPixels == kDefaultMaxImagePixels ? text + " (16384x8192)" : text;
}

// From the header alone: nothing of the size it claims has been allocated yet.
void checkHeader(const std::string& path, const ImageHeader& header, int64_t maxPixels) {
    if (header.width < 1 || header.height < 1)
        throw Error(ErrorKind::Input,
                    path + ": the image has no pixels (" + sizeText(header.width, header.height) + ")");
    const int64_t pixels = int64_t(header.width) * header.height;
    if (header.width > kMaxImageSide || header.height > kMaxImageSide)
        throw Error(ErrorKind::Input, path + ": the image is " + sizeText(header.width, header.height) +
                                          ", longer than the limit of " + std::to_string(kMaxImageSide) +
                                          " pixels per side");
    if (pixels > maxPixels)
        throw Error(ErrorKind::Input, path + ": the image is " + sizeText(header.width, header.height) +
                                          " (" + std::to_string(pixels) +
                                          " pixels), more than the limit of " + pixelLimitText(maxPixels) +
                                          "; raise it with --max-pixels");
    if (header.volumeOrDeep)
        throw Error(ErrorKind::Input, path + ": volume and deep images are not supported");
    if (header.channels.empty()) throw Error(ErrorKind::Input, path + ": the image has no channels");
}

// Reads the planned channels only, straight into the RGBA texels: in one read when they lie
// within four channels of each other (the usual R, G, B, or Y, BY, RY), else one read each.
// Returns the texel component each planned channel landed in.
std::array<int, 3> readPlannedChannels(ImageDecoder& decoder, const ChannelPlan& plan,
                                       std::span<glm::vec4> texels) {
    const auto planned = std::span(plan.channels).first(size_t(plan.count()));
    const auto [low, high] = std::minmax_element(planned.begin(), planned.end());
    const int begin = *low, end = *high + 1;
    if (end - begin <= 4) {
        decoder.readChannels(begin, end, &texels[0].x);
        return {plan.channels[0] - begin, plan.channels[1] - begin, plan.channels[2] - begin};
    }
    for (size_t i = 0; i < planned.size(); ++i)
        decoder.readChannels(planned[i], planned[i] + 1, &texels[0][int(i)]);
    return {0, 1, 2};
}

// The exact sRGB EOTF (IEC 61966-2-1), evaluated in double.
float srgbToLinear(float encoded) {
    double c = encoded;
    return float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

void decodeSrgb(std::span<glm::vec4> texels) {
    for (glm::vec4& texel : texels)
        texel = glm::vec4(srgbToLinear(texel.r), srgbToLinear(texel.g), srgbToLinear(texel.b), texel.a);
}

// An image file whose header has been read and checked, and the channels to read from it.
struct OpenedImage {
    std::string path;
    std::unique_ptr<ImageDecoder> decoder;
    ChannelPlan plan;

    const ImageHeader& header() const { return decoder->header(); }
};

OpenedImage openImage(const std::string& path, int64_t maxPixels) {
    checkInputFile(path, "an image file");
    OpenedImage opened{path, openDecoder(path, checkHeaderAndFormat(path)), {}};
    checkHeader(path, opened.header(), maxPixels);
    opened.plan = planChannels(opened.header().channels, path);
    opened.decoder->checkData();
    return opened;
}

// Whether a texel's colour is NaN or infinite (the unused alpha is not looked at).
bool isNonFinite(const glm::vec4& texel) {
    return !(std::isfinite(texel.r) & std::isfinite(texel.g) & std::isfinite(texel.b));
}

// Whether any texel readPixels leaves is NaN or infinite: a float whose exponent bits are all
// ones. Its alpha is the blank texel's 1, so all four floats are looked at, one after another: a
// loop of integer compares that vectorizes on any x86-64 (std::count_if with isNonFinite does not).
bool anyNonFinite(std::span<const glm::vec4> texels) {
    static_assert(sizeof(glm::vec4) == 4 * sizeof(float), "texels are four packed floats");
    constexpr uint32_t kExponentBits = 0x7f800000u;
    const float* values = reinterpret_cast<const float*>(texels.data());
    uint32_t found = 0;
    for (size_t i = 0; i < 4 * texels.size(); ++i)
        found |= uint32_t((std::bit_cast<uint32_t>(values[i]) & kExponentBits) == kExponentBits);
    return found != 0;
}

// Texels to read an image into: black, with the unused alpha 1 as in every cube map the library
// makes, so that the decoder's R, G, B land in texels that are already whole.
constexpr glm::vec4 kBlankTexel(0.0f, 0.0f, 0.0f, 1.0f);

// Reads the channels the plan names into `texels` (width x height of them, each kBlankTexel) and
// makes them RGB, decoded to linear if the file is sRGB. Returns whether any texel is NaN or
// infinite, for applyNonFinitePolicy. The usual R, G, B in place need no pass of their own: only
// that check reads them again.
bool readPixels(const OpenedImage& opened, std::span<glm::vec4> texels) {
    const ImageHeader& header = opened.header();
    const ChannelPlan& plan = opened.plan;
    const std::string& path = opened.path;
    const std::array<int, 3> at = readPlannedChannels(*opened.decoder, plan, texels);
    if (plan.meaning == ChannelMeaning::Rgb && at == std::array<int, 3>{0, 1, 2} && !header.srgb)
        return anyNonFinite(texels);
    const glm::vec3 weights = plan.meaning == ChannelMeaning::LuminanceChroma
                                  ? luminanceWeights(header.chromaticities.value_or(Chromaticities{}), path)
                                  : glm::vec3(0.0f);
    for (glm::vec4& texel : texels) {
        glm::vec3 stored(texel[at[0]], texel[at[1]], texel[at[2]]);
        glm::vec3 rgb = plan.meaning == ChannelMeaning::Grey ? glm::vec3(stored[0])
                        : plan.meaning == ChannelMeaning::Rgb
                            ? stored
                            : luminanceChromaToRgb(stored[0], stored[1], stored[2], weights);
        texel = glm::vec4(rgb, 1.0f);
    }
    if (header.srgb) decodeSrgb(texels);
    return anyNonFinite(texels);
}

// The policy for the texels readPixels found NaN or infinite, if it found any.
size_t applyPolicyToFound(std::span<glm::vec4> texels, bool found, NonFinitePolicy policy,
                          const std::string& what) {
    return found ? applyNonFinitePolicy(texels, policy, what) : 0;
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

// Every face square and of the first face's size, from the headers: before any pixel is read.
void checkFaceSizes(const std::array<OpenedImage, kFaceCount>& faces) {
    const ImageHeader& first = faces[0].header();
    for (const OpenedImage& face : faces) {
        const ImageHeader& header = face.header();
        std::string size = sizeText(header.width, header.height);
        if (header.width != header.height)
            throw Error(ErrorKind::Input, face.path + ": the face is " + size + "; faces must be square");
        if (header.width != first.width)
            throw Error(ErrorKind::Input, face.path + " is " + size + " but " + faces[0].path + " is " +
                                              sizeText(first.width, first.height) +
                                              "; the six faces must be the same size");
    }
}

Cubemap resizedTo(Cubemap cubemap, int faceSize) {
    return faceSize == 0 ? cubemap : resizeCubemap(cubemap, faceSize);
}

// Face texels worth a thread: 128 x 128 of them, far more work than starting the thread costs.
constexpr size_t kFaceTexelsPerThread = size_t(1) << 14;

// Each face file is decoded straight into its face of the cube map: no image of its own to copy.
Environment loadFaces(const std::string& source, const LoadOptions& options) {
    std::array<std::string, kFaceCount> paths = resolveFaceFiles(source);
    std::array<OpenedImage, kFaceCount> faces;
    for (int face = 0; face < kFaceCount; ++face)
        faces[size_t(face)] = openImage(paths[size_t(face)], options.maxPixels);
    checkFaceSizes(faces);
    const int size = faces[0].header().width;
    const size_t faceTexels = size_t(size) * size;
    Cubemap cubemap = makeCubemap(size, kBlankTexel);
    // The faces decode side by side, each into its own face: six small files spend much of their
    // time where the decoder's own threads do not help (the file, the header, the NaN count). A
    // failure is the first face's in face order, as one after another.
    std::array<size_t, kFaceCount> replaced{};
    std::array<std::exception_ptr, kFaceCount> failures;
    forEachItem(kFaceCount, threadCount(kFaceCount * faceTexels, kFaceTexelsPerThread), [&](int face) {
        try {
            std::span<glm::vec4> texels(cubemap.texels.data() + face * faceTexels, faceTexels);
            const bool found = readPixels(faces[size_t(face)], texels);
            replaced[size_t(face)] =
                applyPolicyToFound(texels, found, options.nonFinite, paths[size_t(face)]);
        } catch (...) {
            failures[size_t(face)] = std::current_exception();
        }
    });
    for (const std::exception_ptr& failure : failures)
        if (failure) std::rethrow_exception(failure);
    Environment environment;
    environment.cubemap = resizedTo(std::move(cubemap), options.faceSize);
    environment.layout = Layout::Faces;
    environment.description = source + " (faces " + sizeText(size, size) + ")";
    environment.replacedTexels = std::accumulate(replaced.begin(), replaced.end(), size_t(0));
    return environment;
}

// The layout to use: the one asked for, or the one the aspect ratio gives.
Layout chooseLayout(const Image& image, Layout requested) {
    if (requested == Layout::Faces)
        throw Error(ErrorKind::Input, "layout faces needs a folder or a pattern containing {face}");
    if (requested == Layout::Equirect) checkEquirectShape(image.width, image.height);
    return requested == Layout::Auto ? detectLayout(image.width, image.height) : requested;
}

Cubemap imageToCubemap(const Image& image, Layout layout, const LoadOptions& options) {
    const int faceSize = options.faceSize;
    if (layout == Layout::Equirect)
        return equirectToCubemap(image, faceSize > 0 ? faceSize : std::max(1, image.width / 4),
                                 options.progress);
    return resizedTo(crossToCubemap(image, layout), faceSize);
}

// An image and whether readPixels found any of its texels NaN or infinite.
struct DecodedImage {
    Image image;
    bool nonFinite = false;
};

DecodedImage decodeImage(const std::string& path, int64_t maxPixels) {
    OpenedImage opened = openImage(path, maxPixels);
    const ImageHeader& header = opened.header();
    DecodedImage decoded{makeImage(header.width, header.height, kBlankTexel)};
    decoded.nonFinite = readPixels(opened, decoded.image.texels);
    return decoded;
}

Environment loadSingleImage(const std::string& path, const LoadOptions& options) {
    auto [image, nonFinite] = decodeImage(path, options.maxPixels);
    Environment environment;
    environment.replacedTexels = applyPolicyToFound(image.texels, nonFinite, options.nonFinite, path);
    try {
        environment.layout = chooseLayout(image, options.layout);
        const bool equirect = environment.layout == Layout::Equirect;
        const bool kept = options.faceSize == 0 && (equirect ? options.keepEquirect : options.keepCross);
        if (kept) {
            if (!equirect) crossFaceSize(image.width, image.height, environment.layout); // or throws
            (equirect ? environment.equirect : environment.cross) = std::move(image);
        } else {
            environment.cubemap = imageToCubemap(image, environment.layout, options);
        }
    } catch (const Error& error) {
        throw Error(error.kind(), path + ": " + error.what());
    }
    const Image& decoded = environment.keptEquirect() ? environment.equirect
                           : environment.keptCross()  ? environment.cross
                                                      : image;
    environment.description =
        path + " (" + layoutName(environment.layout) + " " + sizeText(decoded.width, decoded.height) + ")";
    return environment;
}

} // namespace

Image readImage(const std::string& path, int64_t maxPixels) {
    return decodeImage(path, maxPixels).image;
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

size_t applyNonFinitePolicy(std::span<glm::vec4> texels, NonFinitePolicy policy, const std::string& what) {
    size_t count = size_t(std::count_if(texels.begin(), texels.end(), isNonFinite));
    if (count == 0) return 0;
    if (policy == NonFinitePolicy::Refuse)
        throw Error(ErrorKind::Input, what + ": " + counted(count, "texel") + (count == 1 ? " is" : " are") +
                                          " NaN or infinite; use --sanitize to replace " +
                                          (count == 1 ? "it" : "them") + " with 0");
    for (glm::vec4& texel : texels)
        if (isNonFinite(texel)) texel = glm::vec4(0.0f, 0.0f, 0.0f, texel.a);
    return count;
}

} // namespace shprobe
