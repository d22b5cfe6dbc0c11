// Coefficient files (docs/conventions.md, "Coefficient files"): JSON with format "shprobe.sh",
// version 1, the SH convention, order, quantity and order^2 rows of [r, g, b].
#pragma once
#include "sh/coefficients.h"
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <string_view>

namespace shprobe {

// A sun taken out of the environment (sun extraction), written beside the probe of the rest so that
// a renderer can add it back analytically.
struct ProbeSun {
    glm::dvec3 direction{0.0, 1.0, 0.0}; // unit, towards the sun
    glm::dvec3 radiance{0.0};            // uniform over its disc
    double angularRadius = 0.0;          // radians
};

// Optional fields written beside the required ones; readers ignore them.
struct ProbeMetadata {
    std::string source;  // input description
    int faceSize = 0;    // 0: not written
    std::string backend; // "gpu" or "cpu"
    std::string device;
    std::string weighting = "exact-solid-angle";
    std::string window; // e.g. "hanning:4"; empty: none
    std::optional<ProbeSun> sun;
};

std::string probeToJson(const ShCoefficients& coefficients, const ProbeMetadata& metadata);
// Writes atomically; throws Error(Output) naming the file.
void writeProbeFile(const std::string& path, const ShCoefficients& coefficients,
                    const ProbeMetadata& metadata);

// A coefficient file as a renderer needs it: the coefficients and, when the file has one, the sun
// taken out of them (field "sun"; see ProbeSun), to be added back analytically.
struct Probe {
    ShCoefficients coefficients;
    std::optional<ProbeSun> sun;
    std::string window; // the file's "window" (bake --window), which convert and rotate keep
};

// Parses and validates; throws Error(Input) naming `name` and the offending field. The optional
// "sun" is checked when present: "direction" 3 finite numbers, not all 0 (normalized on read),
// "radiance" 3 finite numbers >= 0, "angular_radius_degrees" in (0, 90].
Probe parseProbe(std::string_view text, const std::string& name);
// Reads path ("-": standard input) of at most 1 MiB (a probe file of order 8 has a few KB): JSON, or
// a binary file of one probe (probe_export.h, known by its magic whatever its name; no sun).
Probe readProbe(const std::string& path);
// The coefficients only (the sun, if any, is validated and dropped).
ShCoefficients parseProbeJson(std::string_view text, const std::string& name);
ShCoefficients readProbeFile(const std::string& path);

const char* quantityName(Quantity quantity);

} // namespace shprobe
