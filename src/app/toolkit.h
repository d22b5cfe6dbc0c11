// Commands and options for working on probes (toolkit.cpp): `shprobe rotate`, `shprobe light`, and
// the light and window options that `shprobe bake` shares with them.
#pragma once
#include "sh/coefficients.h"
#include "sh/lights.h"

#include <CLI/CLI.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <vector>

namespace shprobe {

// Analytic lights from the command line, parsed as CLI11 reads them.
struct LightOptions {
    std::vector<glm::dvec3> ambient;           // --ambient R,G,B
    std::vector<DirectionalLight> directional; // --directional X,Y,Z R,G,B
    std::vector<SphericalLight> spheres;       // --sphere X,Y,Z RADIUS_DEGREES R,G,B
};
// A malformed light is refused while the command line is parsed: Error(Input) naming the option.
void addLightOptions(CLI::App& command, LightOptions& options);
bool hasLights(const LightOptions& options);
// The largest magnitude among the probe's coefficients (NaN counts as infinite).
double largestMagnitude(const ShCoefficients& probe);
// Adds the lights; throws Error(Input) naming `name` when they take the probe or its irradiance (pi
// L00 at most) past float's range, or further past it: neither the GPU nor the files engines read
// hold it.
void addLights(ShCoefficients& radiance, const LightOptions& options, const std::string& name);

// --window none | hanning:WIDTH | lanczos:WIDTH | dering | dering-lanczos
struct Window {
    enum class Kind { None, Hanning, Lanczos, Dering, DeringLanczos };
    Kind kind = Kind::None;
    double width = 0.0;        // Hanning and Lanczos: their width
    std::string text = "none"; // as typed: the report and the probe's metadata name the window so
    bool none() const { return kind == Kind::None; }
};
// Throws Error(Input) naming --window for anything but the forms above.
Window parseWindow(const std::string& text);
void addWindowOption(CLI::App& command, Window& window);
// Per-band factors for l < order: fixed windows from their width, de-ringing from the radiance
// (the weakest window that keeps irradiance non-negative). std::nullopt for none.
std::optional<std::vector<double>> windowFactorsFor(const Window& window, const ShCoefficients& radiance);

// A rotation as --euler, --quat or --matrix gave it: its matrix, and the option and numbers for the
// report and the probe's source.
struct GivenRotation {
    glm::dmat3 matrix{1.0};
    std::string description; // "euler 0,90,0"
};

struct RotateOptions {
    std::string input;
    std::string output;
    // One for each of --euler (alpha, beta, gamma in degrees, R = Rz(gamma) Ry(beta) Rz(alpha)),
    // --quat (w, x, y, z) and --matrix (9 numbers, row-major) given; runRotate needs exactly one.
    std::vector<GivenRotation> rotations;
};
void addRotateOptions(CLI::App& command, RotateOptions& options);
void runRotate(const RotateOptions& options);

struct LightCommandOptions {
    std::string output;
    int order = 3;
    bool irradiance = false;
    LightOptions lights;
};
void addLightOptions(CLI::App& command, LightCommandOptions& options);
void runLight(const LightCommandOptions& options);

} // namespace shprobe
