// `shprobe rotate` and `shprobe light`, and the light and window options shared with `bake`.
#include "app/toolkit.h"

#include "app/commands.h"

#include "common/error.h"
#include "common/output_file.h"
#include "formats/probe_file.h"
#include "sh/basis.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/rotation.h"
#include "sh/windowing.h"

#include <cmath>
#include <numbers>
#include <sstream>

namespace shprobe {

namespace {

// "1.5,2,3" as exactly `count` finite numbers; throws Error(Input) naming the option otherwise.
std::vector<double> parseNumbers(const std::string& text, size_t count, const std::string& option) {
    std::vector<double> values;
    std::stringstream stream(text);
    std::string item;
    while (std::getline(stream, item, ',')) {
        try {
            size_t used = 0;
            values.push_back(std::stod(item, &used));
            if (used != item.size() || !std::isfinite(values.back())) throw std::invalid_argument(item);
        } catch (const std::exception&) {
            throw Error(ErrorKind::Input, option + ": '" + text + "' is not a list of numbers");
        }
    }
    if (values.size() != count)
        throw Error(ErrorKind::Input,
                    option + ": '" + text + "' needs " + std::to_string(count) + " numbers");
    return values;
}

glm::dvec3 parseVector(const std::string& text, const std::string& option) {
    std::vector<double> v = parseNumbers(text, 3, option);
    return {v[0], v[1], v[2]};
}

glm::dvec3 parseDirection(const std::string& text, const std::string& option) {
    glm::dvec3 direction = parseVector(text, option);
    double length = std::sqrt(glm::dot(direction, direction));
    if (length == 0.0) throw Error(ErrorKind::Input, option + ": the direction " + text + " has no length");
    return direction / length;
}

double parseRadiusRadians(const std::string& text, const std::string& option) {
    double degrees = parseNumbers(text, 1, option)[0];
    if (degrees <= 0.0 || degrees > 180.0)
        throw Error(ErrorKind::Input, option + ": the radius " + text + " must be in (0, 180] degrees");
    return degrees * std::numbers::pi / 180.0;
}

glm::dmat3 chosenRotation(const RotateOptions& options) {
    int given = !options.euler.empty() + !options.quaternion.empty() + !options.matrix.empty();
    if (given != 1) throw Error(ErrorKind::Input, "rotate: give exactly one of --euler, --quat, --matrix");
    if (!options.euler.empty())
        return rotationFromEulerZYZ(options.euler[0], options.euler[1], options.euler[2]);
    if (!options.quaternion.empty()) {
        const std::vector<double>& q = options.quaternion;
        return rotationFromQuaternion(q[0], q[1], q[2], q[3]);
    }
    // A reflection (det -1) is allowed: a change to a left-handed frame needs one.
    return orthogonalFromRowMajor(std::span<const double, 9>(options.matrix.data(), 9));
}

std::string joined(const std::vector<double>& values) {
    std::ostringstream text;
    for (size_t i = 0; i < values.size(); ++i)
        text << (i ? "," : "") << values[i];
    return text.str();
}

std::string rotationDescription(const RotateOptions& options) {
    if (!options.euler.empty()) return "euler " + joined(options.euler);
    if (!options.quaternion.empty()) return "quat " + joined(options.quaternion);
    return "matrix " + joined(options.matrix);
}

// "hanning:4" -> (Hanning, 4); throws Error(Input) for anything else.
std::pair<WindowKind, double> parseFixedWindow(const std::string& window) {
    size_t colon = window.find(':');
    std::string kind = window.substr(0, colon);
    if (colon == std::string::npos || (kind != "hanning" && kind != "lanczos"))
        throw Error(ErrorKind::Input,
                    "--window: '" + window +
                        "' is not none, hanning:WIDTH, lanczos:WIDTH, dering or dering-lanczos");
    double width = parseNumbers(window.substr(colon + 1), 1, "--window")[0];
    if (width <= 0.0) throw Error(ErrorKind::Input, "--window: the width must be positive");
    return {kind == "hanning" ? WindowKind::Hanning : WindowKind::Lanczos, width};
}

} // namespace

void addLightOptions(CLI::App& command, LightOptions& options) {
    command.add_option("--ambient", options.ambient, "Uniform radiance R,G,B added to the probe");
    command
        .add_option(
            "--directional", options.directional,
            "Directional light X,Y,Z R,G,B (intensity I lights a facing white surface to I); repeatable")
        ->type_size(2)
        ->allow_extra_args(false);
    command
        .add_option("--sphere", options.sphere,
                    "Spherical light X,Y,Z RADIUS_DEGREES R,G,B (uniform radiance over the disc); repeatable")
        ->type_size(3)
        ->allow_extra_args(false);
}

bool hasLights(const LightOptions& options) {
    return !options.ambient.empty() || !options.directional.empty() || !options.sphere.empty();
}

void addLights(ShCoefficients& radiance, const LightOptions& options) {
    for (const std::string& rgb : options.ambient)
        addAmbient(radiance, parseVector(rgb, "--ambient"));
    for (size_t i = 0; i + 1 < options.directional.size(); i += 2)
        addDirectionalLight(radiance, {parseDirection(options.directional[i], "--directional"),
                                       parseVector(options.directional[i + 1], "--directional")});
    for (size_t i = 0; i + 2 < options.sphere.size(); i += 3)
        addSphericalLight(radiance, {parseDirection(options.sphere[i], "--sphere"),
                                     parseRadiusRadians(options.sphere[i + 1], "--sphere"),
                                     parseVector(options.sphere[i + 2], "--sphere")});
}

void addWindowOption(CLI::App& command, std::string& window) {
    command
        .add_option(
            "--window", window,
            "Windowing against ringing: none, hanning:WIDTH, lanczos:WIDTH, or dering / dering-lanczos "
            "(the weakest Hanning / Lanczos window that keeps irradiance non-negative)")
        ->capture_default_str();
}

std::optional<std::vector<double>> windowFactorsFor(const std::string& window,
                                                    const ShCoefficients& radiance) {
    if (window == "none") return std::nullopt;
    if (window == "dering" || window == "dering-lanczos") {
        DeringOptions options;
        options.window = window == "dering" ? WindowKind::Hanning : WindowKind::Lanczos;
        return deringWindow(radiance, options).bandFactors;
    }
    auto [kind, width] = parseFixedWindow(window);
    return windowFactors(kind, width, radiance.order);
}

void addRotateOptions(CLI::App& command, RotateOptions& options) {
    command.add_option("probe", options.input, "Coefficient file (JSON)")->required();
    command.add_option("-o,--output", options.output, "Rotated coefficient file")->required();
    command
        .add_option("--euler", options.euler, "ALPHA,BETA,GAMMA degrees: R = Rz(gamma) Ry(beta) Rz(alpha)")
        ->expected(3)
        ->delimiter(',')
        ->check(numberFrom(-360.0, 360.0));
    command.add_option("--quat", options.quaternion, "W,X,Y,Z unit quaternion")
        ->expected(4)
        ->delimiter(',')
        ->check(numberFrom(-HUGE_VAL, HUGE_VAL)); // rotationFromQuaternion says when it is not unit
    command
        .add_option("--matrix", options.matrix,
                    "R00,R01,...,R22 orthogonal matrix, row-major: a rotation, or a reflection (det -1) "
                    "for a change of handedness")
        ->expected(9)
        ->delimiter(',')
        ->check(numberFrom(-HUGE_VAL, HUGE_VAL)); // orthogonalFromRowMajor says when it is not orthogonal
}

void runRotate(const RotateOptions& options) {
    checkOutputPath(options.output);
    checkOutputsAreNotInputs({&options.output, 1}, {&options.input, 1});
    Probe probe = readProbe(options.input);
    const glm::dmat3 rotation = chosenRotation(options);
    ProbeMetadata metadata;
    metadata.source = options.input + " rotated by " + rotationDescription(options);
    // The sun taken out of the coefficients turns with them: a light from d then comes from R d.
    metadata.sun = probe.sun;
    if (metadata.sun) metadata.sun->direction = glm::normalize(rotation * metadata.sun->direction);
    const ShCoefficients& coefficients = probe.coefficients;
    writeProbeFile(options.output, rotate(makeShRotation(rotation, coefficients.order), coefficients),
                   metadata);
    std::fprintf(reportStream(options.output), "shprobe rotate: %s -> %s (%s)\n", options.input.c_str(),
                 options.output.c_str(), rotationDescription(options).c_str());
}

void addLightOptions(CLI::App& command, LightCommandOptions& options) {
    command.add_option("-o,--output", options.output, "Coefficient file (JSON)")->required();
    command.add_option("--order", options.order, "SH order")
        ->check(CLI::Range(1, kMaxOrder))
        ->capture_default_str();
    command.add_flag("--irradiance", options.irradiance, "Write irradiance instead of radiance");
    addLightOptions(command, options.lights);
}

void runLight(const LightCommandOptions& options) {
    if (!hasLights(options.lights))
        throw Error(ErrorKind::Input, "light: give at least one --ambient, --directional or --sphere");
    checkOutputPath(options.output);
    ShCoefficients radiance = makeCoefficients(options.order, Quantity::Radiance);
    addLights(radiance, options.lights);
    ProbeMetadata metadata;
    metadata.source = "analytic lights";
    writeProbeFile(options.output, options.irradiance ? convolveIrradiance(radiance) : radiance, metadata);
    std::fprintf(reportStream(options.output),
                 "shprobe light: %zu ambient, %zu directional, %zu spherical -> %s\n",
                 options.lights.ambient.size(), options.lights.directional.size() / 2,
                 options.lights.sphere.size() / 3, options.output.c_str());
}

} // namespace shprobe
