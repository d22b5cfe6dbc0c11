// Loading HDR environments into cube maps: equirect, horizontal and vertical crosses, six face
// files, and the built-in procedural sky. Layouts and orientations follow docs/conventions.md.
#pragma once
#include "common/work_counter.h"
#include "sh/cubemap.h"
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace shprobe {

enum class Layout { Auto, Equirect, HorizontalCross, VerticalCross, Faces };

// "auto", "equirect", "hcross", "vcross", "faces"; throws Error(Input) for anything else.
Layout parseLayout(const std::string& name);
const char* layoutName(Layout layout);

// Layout from an image's aspect ratio: 2:1 equirect, 4:3 horizontal cross, 3:4 vertical cross.
// Throws Error(Input) naming the size when it matches none.
Layout detectLayout(int width, int height);

// What to do with texels that are NaN or infinite. Other values are baked as they are: negative
// ones too (the projection is linear, and resampled HDRs hold small negative lobes around bright
// spots), and huge finite ones (1e30 bakes; sums that overflow are refused when the coefficients
// are written, since no file holds infinities).
enum class NonFinitePolicy {
    Refuse,  // throw Error(Input) with their count
    Replace, // replace them with 0 and report the count
};

// The largest image read by default: 16384 x 8192 pixels, an equirect of the largest size in common
// use, and 2 GiB once held as RGBA32F. A header claiming more is refused before any pixel is read
// (files can claim any size); the limit can be raised (the programs' --max-pixels).
constexpr int64_t kDefaultMaxImagePixels = int64_t(16384) * 8192;
// Sides are limited too, whatever the pixel limit: no layout uses a longer one.
constexpr int64_t kMaxImageSide = 65536;

struct LoadOptions {
    Layout layout = Layout::Auto;
    int faceSize = 0; // 0: chosen from the input (equirect width / 4, cross or face size)
    NonFinitePolicy nonFinite = NonFinitePolicy::Refuse;
    int64_t maxPixels = kDefaultMaxImagePixels; // per image file (each face of six face files)
    // With faceSize 0, an equirect image is kept as it was decoded (Environment::equirect), for a
    // projection that integrates it directly, instead of being resampled to a cube map.
    bool keepEquirect = false;
    // With faceSize 0, a cross image is kept as it was decoded (Environment::cross), for a
    // projection that reads the faces where they lie (crossFaceRows), instead of being copied into a
    // cube map.
    bool keepCross = false;
    // Counts the cube-map rows an equirect image is resampled into, for a progress line.
    WorkCounter* progress = nullptr;
};

// A cube map, an equirect map kept as it was decoded (LoadOptions::keepEquirect) or a cross kept
// as it was decoded (LoadOptions::keepCross, `layout` saying which cross): exactly one of the three
// holds texels.
struct Environment {
    Cubemap cubemap;
    Image equirect;
    Image cross;
    Layout layout = Layout::Auto; // the layout actually used
    std::string description;      // e.g. "sky.exr (equirect 1024x512)"
    size_t replacedTexels = 0;    // non-finite texels replaced under NonFinitePolicy::Replace

    bool keptEquirect() const { return equirect.width > 0; }
    bool keptCross() const { return cross.width > 0; }
    // The cube map's, or the kept cross's; 0 for a kept equirect map.
    int faceSize() const;
    // The texels a projection reads: the cross's six faces, not its empty slots.
    size_t texelCount() const;
};

// Reads an image file: EXR, Radiance HDR, PNG and JPEG by shprobe's own readers, any other format
// OpenImageIO reads through its plugin (image/codec.h); the format is the one the file's first
// bytes name, whatever its extension. 8-bit and 16-bit integer images are taken as sRGB and
// decoded to linear, unless the file's colour space says linear; float images (EXR, HDR) as
// linear. Channels are chosen by name (planChannels, image/channels.h): R, G, B (of the
// unprefixed layer, else of the first layer holding all three), OpenEXR's luminance/chroma Y, RY,
// BY converted to RGB, or Y alone as grey (copied to R, G and B); only those channels are read,
// and alpha and any further channel are ignored, never multiplied in. Texel values are kept as
// stored: NaN and infinities are left to applyNonFinitePolicy, negative and huge finite values
// are kept. Throws Error(Input) naming the file on any failure: "PATH: REASON" in the system's
// words when the file cannot be opened (common/input_file.h: "permission denied", "too many levels of
// symbolic links", ...); from the header, before a reader opens the file, when an EXR or PNG
// header claims more bytes than the file holds (checkImageHeader); and from the header, before any
// pixel is read, when the image has more than maxPixels pixels or a side longer than
// kMaxImageSide.
Image readImage(const std::string& path, int64_t maxPixels = kDefaultMaxImagePixels);

// Resolves the six face files of a folder (px, nx, py, ny, pz, nz with any image extension) or of
// a pattern containing "{face}". Returns the paths in Face order; throws Error(Input) if one is
// missing, and "PATH: REASON" when the folder, a face file or the path itself cannot be looked up
// (a loop of links, a name too long, a folder that may not be searched). isFacesSource tells
// whether a path names such a source (a folder or a pattern); it throws as resolveFaceFiles does.
std::array<std::string, kFaceCount> resolveFaceFiles(const std::string& path);
bool isFacesSource(const std::string& path);

// Loads an environment from a file, folder or pattern, as a cube map of options.faceSize, or as the
// equirect image itself (options.keepEquirect).
Environment loadEnvironment(const std::string& path, const LoadOptions& options);

// Throws Error(Input) unless the size is 2:1: a full sphere spans 360 by 180 degrees, and any other
// shape would be stretched without a word.
void checkEquirectShape(int width, int height);

// Cube map of an equirect map: each texel is the mean of the equirect's pixels over its footprint
// on the sphere, each weighed by the solid angle the two share, so the map's power is kept. Its
// rows (of all six faces) are counted into `progress`. The pixels must be finite (the loader's NaN
// policy): a texel's sums run along rows past pixels outside it.
Cubemap equirectToCubemap(const Image& equirect, int faceSize, WorkCounter* progress = nullptr);
// The face size of a cross of that size (HorizontalCross or VerticalCross). Throws Error(Input)
// unless the size has the cross's aspect ratio, 4:3 or 3:4 (since 3 and 4 are coprime, the ratio
// alone makes the width a multiple of the columns).
int crossFaceSize(int width, int height, Layout layout);
// Cube map of a cross image (HorizontalCross or VerticalCross), at the cross's own face size.
Cubemap crossToCubemap(const Image& cross, Layout layout);
// The six faces of a cross image where they lie in it, for projectFacesFast: nothing is copied but
// a vertical cross's -Z, which the cross holds turned 180 degrees and which is turned back into
// `turned` (faceSize^2 texels; it must outlive the FaceRows).
FaceRows crossFaceRows(const Image& cross, Layout layout, std::vector<glm::vec4>& turned);
// A kept cross (Environment::keptCross) made a cube map, for what needs one (the GPU, the
// reference projection); anything else is left as it is.
void copyCrossToCubemap(Environment& environment);
// Resamples every face to a new size (area average when shrinking, bilinear when growing).
Cubemap resizeCubemap(const Cubemap& cubemap, int faceSize);
// A smaller cube map of radiance whose every texel is the solid-angle mean of the map over it, a
// texel of the map that straddles its edges counted by the part inside: each texel keeps exactly its
// share of the integral at any two sizes (a resize by face area does not: texels shrink towards a
// face's corners). The map itself where faceSize is not smaller.
Cubemap averageCubemap(const Cubemap& cubemap, int faceSize);

// The built-in default environment: a sky gradient, darker ground and a small, very bright sun
// disc, as radiance in linear units.
struct SkyParameters {
    glm::dvec3 sunDirection{0.32, 0.72, -0.61};        // normalized on use
    double sunAngularRadius = 0.02;                    // radians (about 1.1 degrees)
    glm::dvec3 sunRadiance{60000.0, 54000.0, 45000.0}; // bright enough that order-3 and order-5
                                                       // irradiance ring negative (de-ringing)
    glm::dvec3 zenith{0.25, 0.45, 1.0};
    glm::dvec3 horizon{0.9, 0.95, 1.0};
    glm::dvec3 ground{0.3, 0.25, 0.2};
};
glm::dvec3 skyRadiance(const SkyParameters& sky, const glm::dvec3& direction);
// Each texel holds the sky at its center; texels the sun disc may touch hold the solid-angle mean
// over a grid fine enough to resolve the disc, so the sun keeps its power at any face size.
Cubemap makeDefaultSky(int faceSize, const SkyParameters& sky = {});

// Counts texels that are NaN or infinite and applies the policy. Returns the number replaced.
size_t applyNonFinitePolicy(std::span<glm::vec4> texels, NonFinitePolicy policy, const std::string& what);

} // namespace shprobe
