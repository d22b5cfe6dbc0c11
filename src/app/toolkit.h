// Commands and options for working on probes (toolkit.cpp): `shprobe rotate`, `shprobe light`, and
// the light and window options that `shprobe bake` shares with them.
#pragma once
#include "sh/coefficients.h"

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

namespace shprobe {

// Analytic lights as typed on the command line (parsed when applied, so errors name the option).
struct LightOptions {
    std::vector<std::string> ambient;     // R,G,B
    std::vector<std::string> directional; // X,Y,Z R,G,B pairs
    std::vector<std::string> sphere;      // X,Y,Z RADIUS_DEGREES R,G,B triples
};
void addLightOptions(CLI::App& command, LightOptions& options);
bool hasLights(const LightOptions& options);
// Adds the lights to radiance coefficients; throws Error(Input) naming the malformed option.
void addLights(ShCoefficients& radiance, const LightOptions& options);

// --window none | hanning:WIDTH | lanczos:WIDTH | dering | dering-lanczos
void addWindowOption(CLI::App& command, std::string& window);
// Per-band factors for l < order: fixed windows from their width, de-ringing from the radiance
// (the weakest window that keeps irradiance non-negative). std::nullopt for "none".
std::optional<std::vector<double>> windowFactorsFor(const std::string& window,
                                                    const ShCoefficients& radiance);

struct RotateOptions {
    std::string input;
    std::string output;
    std::vector<double> euler;      // alpha, beta, gamma in degrees, R = Rz(gamma) Ry(beta) Rz(alpha)
    std::vector<double> quaternion; // w, x, y, z
    std::vector<double> matrix;     // 9 numbers, row-major
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
