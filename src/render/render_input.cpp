#include "render/render_input.h"

#include "common/error.h"
#include "common/file_extension.h"
#include "common/scope_exit.h"
#include "formats/probe_file.h"
#include "image/environment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <glm/matrix.hpp>

namespace shprobe {

namespace {

Environment loadEnvironmentInput(const std::string& path, const RenderInputOptions& options) {
    if (path.empty()) {
        Environment sky;
        sky.cubemap = makeDefaultSky(options.faceSize > 0 ? options.faceSize : kRenderSkyFaceSize);
        sky.description = "built-in sky";
        return sky;
    }
    LoadOptions load;
    load.faceSize = options.faceSize;
    load.nonFinite = options.sanitize ? NonFinitePolicy::Replace : NonFinitePolicy::Refuse;
    load.maxPixels = options.maxPixels;
    return loadEnvironment(path, load);
}

// Bilinear sample within the face the direction hits (edges clamp to the face).
glm::vec4 sampleCubemap(const Cubemap& cubemap, const glm::dvec3& d) {
    FacePoint point = directionToFace(d);
    const int n = cubemap.faceSize;
    double x = std::clamp((point.a + 1.0) * 0.5 * n - 0.5, 0.0, n - 1.0);
    double y = std::clamp((point.b + 1.0) * 0.5 * n - 0.5, 0.0, n - 1.0);
    int i0 = int(x), j0 = int(y);
    int i1 = std::min(i0 + 1, n - 1), j1 = std::min(j0 + 1, n - 1);
    float fx = float(x - i0), fy = float(y - j0);
    glm::vec4 top = glm::mix(cubemap.at(point.face, i0, j0), cubemap.at(point.face, i1, j0), fx);
    glm::vec4 bottom = glm::mix(cubemap.at(point.face, i0, j1), cubemap.at(point.face, i1, j1), fx);
    return glm::mix(top, bottom, fy);
}

} // namespace

bool isProbeFile(const std::string& path) {
    if (path == "-") return true; // a probe on standard input
    return hasExtension(path, ".json") || hasExtension(path, ".bin");
}

ProbeBaker createRenderBaker(const Device& device) {
    return createProbeBaker(
        device, {.order = kRenderBakeOrder, .cubemaps = uploadBinding(device, TexelFormat::Rgba32F)});
}

ShCoefficients bakeRadiance(const Context& context, const ProbeBaker& baker, const Cubemap& cubemap,
                            double& milliseconds) {
    auto start = std::chrono::steady_clock::now();
    GpuBake bake = bakeCubemap(context, baker, cubemap);
    milliseconds =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return bake.radiance;
}

RenderInput readProbeInput(const std::string& path) {
    RenderInput input;
    input.name = path;
    Probe probe = readProbe(path);
    input.probe = std::move(probe.coefficients);
    if (probe.sun)
        input.sun = SphericalLight{probe.sun->direction, probe.sun->angularRadius, probe.sun->radiance};
    return input;
}

RenderInput loadRenderInput(const Context& context, const std::string& path,
                            const RenderInputOptions& options) {
    if (isProbeFile(path)) return readProbeInput(path);
    RenderInput input;
    input.name = path.empty() ? "built-in sky" : path;
    Environment environment = loadEnvironmentInput(path, options);
    ProbeBaker baker = createRenderBaker(context);
    ScopeExit releaseBaker([&] { destroyProbeBaker(context, baker); });
    input.probe = bakeRadiance(context, baker, environment.cubemap, input.bakeMilliseconds);
    input.environment = std::move(environment.cubemap);
    return input;
}

Cubemap rotateCubemap(const Cubemap& cubemap, const glm::dmat3& rotation) {
    Cubemap rotated = makeCubemap(cubemap.faceSize);
    const glm::dmat3 inverse = glm::transpose(rotation);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < cubemap.faceSize; ++j)
            for (int i = 0; i < cubemap.faceSize; ++i)
                rotated.at(face, i, j) =
                    sampleCubemap(cubemap, inverse * texelDirection(face, i, j, cubemap.faceSize));
    return rotated;
}

} // namespace shprobe
