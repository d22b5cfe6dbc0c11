// The subcommands of the shprobe program. Each adds its options to the parser and runs from a
// plain options struct; library errors (shprobe::Error) reach main, which prints them.
#pragma once
#include "app/program.h"
#include "app/toolkit.h"
#include "common/error.h"
#include "glsl/dispatch_plan.h"
#include "image/environment.h"
#include "scene/probe_grid.h"

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace shprobe {

struct Context;    // vk/context.h
struct LitScene;   // render/lit_scene.h
struct RelitLight; // render/relit_scene.h

struct BakeOptions {
    std::vector<std::string> inputs; // files, folders or {face} patterns; none: the built-in sky
    std::string output;              // empty: "probe" and the format's extension
    std::string outDir;              // batch: one output per input in this folder, named after it
    std::string listFile;            // batch: more inputs, one path per line
    uint64_t batchBytes = 0;         // batch: most texel bytes per GPU submission (0: the device's limit)
    int order = 3;
    std::string layout = "auto";
    int faceSize = 0;                           // 0: from the input (256 for the built-in sky)
    std::string backend = "auto";               // auto | gpu | cpu (fast float) | reference (double)
    bool irradiance = false;                    // write E_lm instead of L_lm
    bool sanitize = false;                      // replace NaN/Inf texels with 0 instead of refusing
    int64_t maxPixels = kDefaultMaxImagePixels; // larger image files are refused from their header
    std::string device;
    bool validation = false;
    uint32_t workgroupSize = glsl::kDefaultWorkgroupWidth;
    uint32_t texelsPerInvocation = glsl::kDefaultTexelsPerInvocation;
    bool quiet = false;         // no coefficient table
    bool timings = false;       // single GPU bake: print each phase's time
    LightOptions lights;        // analytic lights added to the environment's radiance
    Window window;              // none | hanning:W | lanczos:W | dering | dering-lanczos
    bool extractSun = false;    // take the sun out and write it beside the probe
    std::string format;         // json | binary | glsl | cpp | irradiance-equirect | irradiance-cross;
                                // empty: from the output's extension, else json
    int mapSize = 0;            // irradiance maps: equirect width or face size (0: 512 / 128)
    std::optional<bool> mirror; // filament: cmgen's default mirroring (off: cmgen --no-mirror); unset: on
};

// `shprobe convert IN -o OUT [--format F]`: a probe file in, any output format out (convert.cpp).
struct ConvertOptions {
    std::string input;  // a probe file (JSON; .bin: the first probe of a binary file); "-": stdin
    std::string output; // empty: "probe" and the format's extension
    std::string format; // empty: from the output's extension, else json
    int mapSize = 0;
    std::optional<bool> mirror;
};

struct InfoOptions {
    bool validation = false;
};

// The glTF scene that render and view draw instead of a sphere, lit by its probe volume
// (render_scene.cpp).
struct LitSceneOptions {
    std::string scene;       // .gltf or .glb
    std::string volume;      // its probe volume (shprobe scene)
    std::string sky;         // the scene's sky; empty: the built-in sky
    bool showProbes = false; // the volume's probes as spheres (the viewer: initially; key P)
    // --transfer: the scene's per-vertex transfer (shprobe transfer) relit by --sky or --probe,
    // turned by the light's yaw (about +Y) and pitch (about +X), degrees: R = Ry(yaw) Rx(pitch).
    bool transfer = false;
    std::string probe;
    float lightYaw = 0.0f;
    float lightPitch = 0.0f;
    bool drawn() const { return !scene.empty() || !volume.empty(); }
};

// "N" (N x N) or "WxH", each 1..16384; throws Error(Input) naming the option otherwise.
struct ImageSize {
    uint32_t width = 0;
    uint32_t height = 0;
};
ImageSize parseImageSize(const std::string& text, const char* option);
// --size of render and view, parsed as CLI11 reads it.
CLI::Option* addSizeOption(CLI::App& command, std::optional<ImageSize>& size, const std::string& help);

struct RenderOptions {
    std::string input;                 // probe (.json), environment image, or empty: the built-in sky
    std::string output = "render.png"; // .png/.jpg tonemapped sRGB, .exr/.hdr linear
    int order = 3;                     // 3 or 5
    std::string mode = "irradiance";   // radiance | irradiance | l1-nonlinear
    std::optional<ImageSize> size;     // N or WxH; none: 512 (with --grid: the cell width, 384)
    bool grid = false;                 // environment, order-3 and order-5 side by side
    std::string background = "auto";   // auto | environment | radiance (sh) | shading | color
    float exposure = 0.0f;             // stops relative to the automatic exposure
    float yaw = 0.0f;                  // camera orbit, degrees
    float pitch = 10.0f;
    int faceSize = 0; // environment cube-map face size (0: from the input)
    bool sanitize = false;
    int64_t maxPixels = kDefaultMaxImagePixels;
    std::string device;
    bool validation = false;
    LitSceneOptions scene;
};

struct ViewOptions {
    std::string input;             // like RenderOptions::input
    std::optional<ImageSize> size; // window size, N or WxH; none: 960x600
    int order = 3;
    std::string mode = "irradiance";
    std::string screenshot; // save frame --frames to this PNG and exit
    int frames = 0;         // > 0: exit after this many frames
    std::vector<int> keys;  // key presses to replay, one per frame (tests, scripts): GLFW key codes
    float exposure = 0.0f;
    int faceSize = 0;
    bool sanitize = false;
    int64_t maxPixels = kDefaultMaxImagePixels;
    std::string device;
    bool validation = false;
    LitSceneOptions scene;
};

// --brick I/N: the brick, and the option as typed for the report.
struct BrickOption {
    Brick brick;
    std::string text;
};

// `shprobe scene SCENE --grid NX,NY,NZ -o VOLUME`: probes baked inside a glTF scene (scene.cpp).
struct SceneOptions {
    std::string scene;                  // .gltf or .glb
    std::string output = "volume.shpv"; // probe volume (docs/probe-volume.md)
    glm::ivec3 grid{1};                 // NX,NY,NZ
    std::optional<GridBounds> bounds;   // X0,Y0,Z0,X1,Y1,Z1; none: the scene's box, inset by half a cell
    int order = 3;
    int faceSize = 32;
    int bounces = 1;
    bool bouncesGiven = false;                  // --bounces on the command line (not with --previous)
    std::string sky;                            // any input bake takes; empty: the built-in sky
    int skyFaceSize = 0;                        // 0: the sky's own (128 for the built-in sky)
    bool sanitize = false;                      // the sky's NaN and infinite texels as 0, not refused
    int64_t maxPixels = kDefaultMaxImagePixels; // larger sky image files are refused from their header
    std::optional<BrickOption> brick;           // I/N: one brick of the grid, one bounce
    std::string previous;                       // the previous bounce's whole volume
    uint32_t probesPerBatch = 32;
    std::string backend = "auto";  // auto | gpu (rasterized captures) | cpu (rays: scene/ray_bake.h)
    int raysPerTexel = 0;          // 0: 9 (3 x 3) on both backends; 1: the texel's centre
    double cacheSpacing = 0.0;     // cpu: 0 is the world's diagonal / 64
    int gatherRays = 64;           // cpu: per cache point
    int cacheRefinement = 0;       // cpu: the most times a cache cell is halved
    double invalidBackFaces = 0.5; // a probe is invalid where more of its view meets back faces
    bool dilate = true;            // invalid probes filled from their valid neighbours
    double relocationLimit = 0.45; // cpu: the longest move out of geometry, in smallest cell sides
    bool transfer = false;         // cpu: the volume's radiance transfer (scene/volume_bake.h)
    std::string device;
    bool validation = false;
    bool quiet = false;
    // cpu: texels | sphere, the directions of a probe's view (scene/ray_bake.h ProbeDirections)
    std::string probeDirections = "texels";
    // cpu: auto | cache | paths, where bounced light comes from (scene/ray_bake.h BounceLight)
    std::string bounceLight = "auto";
};

// `shprobe merge BRICKS... -o VOLUME` (scene.cpp).
struct MergeOptions {
    std::vector<std::string> bricks;
    std::string output;
    bool quiet = false;
};

// `shprobe transfer SCENE -o OUT`: per-vertex radiance transfer written into the scene (transfer.cpp).
struct TransferCommandOptions {
    std::string scene;              // .gltf or .glb
    std::string output;             // .glb, or the binary file (.shpt)
    std::string model = "shadowed"; // unshadowed | shadowed | interreflected
    int order = 3;
    int rays = 256;
    int bounces = 1;              // interreflected only
    bool bouncesGiven = false;    // --bounces on the command line
    bool raysGiven = false;       // --rays on the command line
    std::string format;           // glb | binary; empty: binary for a .shpt output, else glb
    std::string backend = "auto"; // auto | gpu | cpu
    std::string device;
    bool validation = false;
    bool quiet = false;
};

// `shprobe relight VOLUME -o NEW`: a volume baked with --transfer lit by another sky (relight.cpp).
struct RelightOptions {
    std::string volume;
    std::string output;
    std::string sky;       // any input bake takes; empty: the built-in sky (unless probe)
    std::string probe;     // a radiance probe file instead of a sky
    bool sanitize = false; // the sky's NaN and infinite texels as 0, not refused
    int64_t maxPixels = kDefaultMaxImagePixels; // larger sky image files are refused from their header
    double yaw = 0.0;                           // the light's turn, degrees (sh/rotation.h lightRotation)
    double pitch = 0.0;
    bool timings = false; // relight timed against reading the transfer's bytes (the bound)
    bool quiet = false;
};

// Every number option is checked at parse time: finite (CLI11 reads "nan" and "inf" as numbers)
// and within [min, max] (infinite bounds: none). The error says what is allowed: "--yaw: nan is not a number
// from -360 to 360".
inline CLI::Validator numberFrom(double min, double max) {
    auto text = [](double value) {
        std::ostringstream out;
        out << value;
        return out.str();
    };
    std::string allowed = std::isinf(min) && std::isinf(max) ? "a finite number"
                          : std::isinf(max)                  ? "a number of at least " + text(min)
                                            : "a number from " + text(min) + " to " + text(max);
    return CLI::Validator(
        [=](const std::string& input) {
            char* end = nullptr;
            double value = std::strtod(input.c_str(), &end);
            bool number = !input.empty() && *end == '\0' && std::isfinite(value);
            if (number && value >= min && value <= max) return std::string();
            return input + " is not " + allowed;
        },
        allowed.substr(2));
}

// --device and --validation, as bake, render and view take them.
inline void addDeviceOptions(CLI::App& command, std::string& device, bool& validation) {
    command.add_option("--device", device, "Vulkan device index or name part (see `shprobe info`)");
    command.add_flag("--validation", validation, "Enable the Khronos validation layer; fail on messages");
}

// --device and --validation ask for Vulkan, which a CPU backend never starts: refused with one
// rather than ignored (SHPROBE_DEVICE and SHPROBE_VALIDATION, set for a whole session, are not).
inline void requireDeviceUsed(const std::string& backend, const std::string& device, bool validation) {
    if (backend != "cpu" && backend != "reference") return;
    const char* option = !device.empty() ? "--device" : validation ? "--validation" : nullptr;
    if (option)
        throw Error(ErrorKind::Input, std::string(option) + " is for a Vulkan device, which --backend " +
                                          backend + " does not use");
}

// The Vulkan context of the commands that draw (render, scene): a queue that does graphics too
// (render.cpp).
Context createGraphicsContext(const std::string& device, bool validation);
// The graphics context of `shprobe render` at `size` (--size or its default): refused in words naming
// --size (Error(Input)), before any image is made, where the device cannot create its render targets.
Context createRenderContext(const RenderOptions& options, ImageSize size);

// --exposure of render and view: stops relative to the automatic exposure (2^64 either way
// is already far past black and white).
inline void addExposureOption(CLI::App& command, float& exposure) {
    command.add_option("--exposure", exposure, "Exposure in stops relative to the automatic one")
        ->check(numberFrom(-64.0, 64.0))
        ->capture_default_str();
}

// --max-pixels: image files with more pixels are refused from their header, before any pixel is
// read (LoadOptions::maxPixels).
inline void addImageLimitOption(CLI::App& command, int64_t& maxPixels) {
    command
        .add_option("--max-pixels", maxPixels,
                    "Largest image file to read, in pixels (16384x8192 by default); larger ones are "
                    "refused from their header")
        ->transform(wholeNumberFrom(1, kMaxImageSide * kMaxImageSide))
        ->capture_default_str();
}

// The files an input names: the six face files of a faces source, when they resolve, else the
// input itself (none for the built-in sky); an output must be none of them.
std::vector<std::string> filesReadBy(const std::string& input);

void addBakeOptions(CLI::App& command, BakeOptions& options);
void runBake(const BakeOptions& options);

// --format (the formats of formats/engine_export.h), --map-size and --mirror, as bake and convert take them.
void addFormatOptions(CLI::App& command, std::string& format, int& mapSize, std::optional<bool>& mirror);
// Refuses --map-size and --mirror where `format` has no map or no mirroring to set.
void requireFormatOptionsUsed(const std::string& format, int mapSize, const std::optional<bool>& mirror);

void addConvertOptions(CLI::App& command, ConvertOptions& options);
void runConvert(const ConvertOptions& options);

void addInfoOptions(CLI::App& command, InfoOptions& options);
void addSceneOptions(CLI::App& command, SceneOptions& options);
void runScene(const SceneOptions& options);
void addTransferOptions(CLI::App& command, TransferCommandOptions& options);
void runTransfer(const TransferCommandOptions& options);
void addMergeOptions(CLI::App& command, MergeOptions& options);
void runMerge(const MergeOptions& options);
void addRelightOptions(CLI::App& command, RelightOptions& options);
void runRelight(const RelightOptions& options);
// How a scene's sky is read: as a cube map of faceSize (0: its own; 128 for the built-in sky), and
// its image files as `bake` reads its inputs (--sanitize, --max-pixels).
struct SkyReading {
    int faceSize = 0;
    bool sanitize = false;
    int64_t maxPixels = kDefaultMaxImagePixels;
};
// The sky of a scene's probes: an environment input as `bake` takes it, or the built-in sky (empty
// path).
Environment loadSceneSky(const std::string& path, const SkyReading& reading = {});
// --sanitize and --max-pixels of the commands that read a sky (scene, relight).
void addSkyReadingOptions(CLI::App& command, bool& sanitize, int64_t& maxPixels);
// A sky by content, whatever path named it, for a volume's settings: "fnv1a64:" and 16 hex digits
// (common/content_hash.h) over the face size and each texel's red, green and blue floats (alpha
// carries no light), or over the order and the radiance coefficients' doubles of a probe.
std::string skyContentHash(const Cubemap& sky);
std::string skyContentHash(const ShCoefficients& radiance);
// Refuses, before it is written, a baked or relit volume whose light overflowed float: "PROBE
// overflows float: LIGHT is far too strong", LIGHT naming what lit it (a bad input, not a failed write).
void requireFiniteLight(const ProbeVolume& volume, const std::string& light);
// The sky as the ray paths read it: its sun, where it has one (sh/lights.h extractSun), taken out
// as a directional sun of the same power, which they sample explicitly (a sun of 1e-3 sr is found
// by less than one ray in a thousand); the rest stays in the cube map.
struct SplitSky {
    Cubemap residual;
    std::vector<SceneSun> suns;
};
SplitSky splitSceneSky(const Environment& sky);
// The files a scene job reads: the scene, its buffer and image files (when the scene can be read;
// the load reports it otherwise) and the sky's files; an output must be none of them.
std::vector<std::string> sceneInputs(const std::string& scene, const std::string& sky);
void runInfo(const InfoOptions& options);

// --face-size and --sanitize for an environment given to render or view (baked before showing it).
void addEnvironmentInputOptions(CLI::App& command, int& faceSize, bool& sanitize, int64_t& maxPixels);

void addRenderOptions(CLI::App& command, RenderOptions& options);
// `shprobe render --scene SCENE --volume VOLUME`: the scene lit by its probe volume.
void runSceneRender(const RenderOptions& options, uint32_t width, uint32_t height);
// A probe file's radiance at `order`: cut, or padded with zeros (the bands it has not); refused
// for irradiance and for a probe with a sun apart (render_transfer.cpp).
ShCoefficients probeFileRadiance(const std::string& path, int order);
// `shprobe render --scene OUT.glb --transfer`: the scene relit from its transfer (render_transfer.cpp).
void runTransferRender(const RenderOptions& options, uint32_t width, uint32_t height);
// The light of a relit scene: --probe's radiance coefficients (cut or padded with zeros to
// `order`; Error(Input) for irradiance or a probe with a sun) or --sky (the built-in sky when neither).
RelitLight loadRelitLight(const LitSceneOptions& options, int order, const SkyReading& sky);
// --scene, --volume, --sky and --show-probes of render and view; --scene excludes the options of the
// sphere named in sphereOnly, and the others need --scene.
void addLitSceneOptions(CLI::App& command, LitSceneOptions& options,
                        std::initializer_list<const char*> sphereOnly);
// The files a lit scene reads: sceneInputs and the volume.
std::vector<std::string> litSceneInputs(const LitSceneOptions& options);
// The scene, its whole volume (baked in that scene) and its sky, for render and view --scene; throws
// Error(Input) for a missing half, a brick, or a volume of another scene.
LitScene loadLitScene(const LitSceneOptions& options, const SkyReading& sky);
void runRender(const RenderOptions& options);

// The viewer, shprobe-view (view.cpp, view_main.cpp): a program of its own, the only one that links
// GLFW; `shprobe view ARGS` runs it with ARGS.
inline constexpr char kViewSummary[] = "Open a window: environment, lit sphere and torus, orbit camera";
void addViewOptions(CLI::App& command, ViewOptions& options);
void runView(const ViewOptions& options);

} // namespace shprobe
