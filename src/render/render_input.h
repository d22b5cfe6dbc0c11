// What the render and view commands light their shapes with: a probe file as it is, or an
// environment image (or the built-in sky) baked on the GPU first, keeping the cube map for the
// background.
#pragma once
#include "gpu/host_bake.h"
#include "gpu/probe_baker.h"
#include "image/environment.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"
#include "sh/lights.h"

#include <glm/mat3x3.hpp>
#include <optional>
#include <string>

namespace shprobe {

// Environments are baked at order 5; order 3 is their first 9 coefficients.
constexpr int kRenderBakeOrder = 5;
// Face size of the built-in sky (its sun is supersampled, so a small map keeps its power).
constexpr int kRenderSkyFaceSize = 128;

struct RenderInputOptions {
    int faceSize = 0;                           // 0: from the input (equirect width / 4, ...)
    bool sanitize = false;                      // replace NaN/Inf texels with 0 instead of refusing them
    int64_t maxPixels = kDefaultMaxImagePixels; // larger image files are refused from their header
};

struct RenderInput {
    std::string name;                   // the path, or "built-in sky"
    ShCoefficients probe;               // radiance or irradiance coefficients
    std::optional<SphericalLight> sun;  // a probe file's "sun" (bake --extract-sun), not in `probe`
    std::optional<Cubemap> environment; // for environment inputs
    double bakeMilliseconds = 0.0;      // GPU bake wall time (0 for probe files)
};

// A path ending in .json or .bin is a probe file (read with readProbe: bad files get an error naming
// the file and field; a JSON file's sun, if any, comes along); anything else an environment (baked
// whole, the sun left in); an empty path the built-in sky.
// ".json", ".bin", or "-": a probe on standard input.
bool isProbeFile(const std::string& path);
RenderInput readProbeInput(const std::string& path); // probe files only; needs no device
RenderInput loadRenderInput(const Context& context, const std::string& path,
                            const RenderInputOptions& options);

// The baker environments are baked with: order kRenderBakeOrder, texels uploaded as RGBA32F.
// destroyProbeBaker when done.
ProbeBaker createRenderBaker(const Device& device);

// Bakes radiance at the baker's order; `milliseconds` gets the wall time of the bake.
ShCoefficients bakeRadiance(const Context& context, const ProbeBaker& baker, const Cubemap& cubemap,
                            double& milliseconds);

// The environment rotated by R: the light that came from d comes from R d (docs/conventions.md,
// "Rotations"). Each texel takes the bilinear sample of the source at R^T d.
Cubemap rotateCubemap(const Cubemap& cubemap, const glm::dmat3& rotation);

} // namespace shprobe
