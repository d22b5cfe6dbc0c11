// `shprobe rotate` and `shprobe light`, and the light and window options shared with `bake`.
#include "app/toolkit.h"

#include "app/commands.h"
#include "app/parsed_option.h"
#include "app/program.h"

#include "common/error.h"
#include "common/output_file.h"
#include "common/short_number.h"
#include "formats/engine_export.h"
#include "formats/output_format.h"
#include "formats/probe_file.h"
#include "sh/basis.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/rotation.h"
#include "sh/windowing.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
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
        // strtod, not stod: stod refuses a subnormal such as 1e-320 as out of range.
        char* end = nullptr;
        const double value = std::strtod(item.c_str(), &end);
        if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(value))
            throw Error(ErrorKind::Input, option + ": '" + text + "' is not a list of numbers");
        values.push_back(value);
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
    const glm::dvec3 direction = parseVector(text, option);
    if (direction == glm::dvec3(0.0))
        throw Error(ErrorKind::Input, option + ": the direction " + text + " has no length");
    return unitDirection(direction);
}

double parseRadiusRadians(const std::string& text, const std::string& option) {
    double degrees = parseNumbers(text, 1, option)[0];
    if (degrees <= 0.0 || degrees > 180.0)
        throw Error(ErrorKind::Input, option + ": the radius " + text + " must be in (0, 180] degrees");
    return degrees * std::numbers::pi / 180.0;
}

std::string joined(const std::vector<double>& values) {
    std::ostringstream text;
    for (size_t i = 0; i < values.size(); ++i)
        text << (i ? "," : "") << values[i];
    return text.str();
}

GivenRotation eulerRotation(const std::vector<double>& angles) {
    return {rotationFromEulerZYZ(angles[0], angles[1], angles[2]), "euler " + joined(angles)};
}

GivenRotation quaternionRotation(const std::vector<double>& q) {
    return {rotationFromQuaternion(q[0], q[1], q[2], q[3]), "quat " + joined(q)};
}

// A reflection (det -1) is allowed: a change to a left-handed frame needs one.
GivenRotation matrixRotation(const std::vector<double>& rowMajor) {
    return {orthogonalFromRowMajor(std::span<const double, 9>(rowMajor.data(), 9)),
            "matrix " + joined(rowMajor)};
}

// --euler, --quat or --matrix: `count` numbers, each checked by CLI11, then made a rotation by
// `rotation` (which refuses a quaternion that is not unit, a matrix that is not orthogonal).
void addRotationOption(CLI::App& command, const char* name, RotateOptions& options, int count,
                       GivenRotation (*rotation)(const std::vector<double>&), const std::string& help,
                       const CLI::Validator& numbers) {
    command
        .add_option_function<std::vector<double>>(
            name,
            [&options, rotation](const std::vector<double>& values) {
                options.rotations.push_back(rotation(values));
            },
            help)
        ->expected(count)
        ->delimiter(',')
        ->check(numbers);
}

const GivenRotation& chosenRotation(const RotateOptions& options) {
    if (options.rotations.size() != 1)
        throw Error(ErrorKind::Input, "rotate: give exactly one of --euler, --quat, --matrix");
    return options.rotations.front();
}

// "hanning:4" -> (Hanning, 4); throws Error(Input) for anything else.
Window parseFixedWindow(const std::string& text) {
    size_t colon = text.find(':');
    std::string kind = text.substr(0, colon);
    if (colon == std::string::npos || (kind != "hanning" && kind != "lanczos"))
        throw Error(ErrorKind::Input,
                    "--window: '" + text +
                        "' is not none, hanning:WIDTH, lanczos:WIDTH, dering or dering-lanczos");
    double width = parseNumbers(text.substr(colon + 1), 1, "--window")[0];
    if (width <= 0.0) throw Error(ErrorKind::Input, "--window: the width must be positive");
    return {kind == "hanning" ? Window::Kind::Hanning : Window::Kind::Lanczos, width, text};
}

std::vector<glm::dvec3> parseAmbient(const std::vector<std::string>& texts) {
    std::vector<glm::dvec3> lights;
    for (const std::string& rgb : texts)
        lights.push_back(parseVector(rgb, "--ambient"));
    return lights;
}

// X,Y,Z R,G,B pairs.
std::vector<DirectionalLight> parseDirectionalLights(const std::vector<std::string>& texts) {
    std::vector<DirectionalLight> lights;
    for (size_t i = 0; i + 1 < texts.size(); i += 2)
        lights.push_back(
            {parseDirection(texts[i], "--directional"), parseVector(texts[i + 1], "--directional")});
    return lights;
}

// X,Y,Z RADIUS_DEGREES R,G,B triples.
std::vector<SphericalLight> parseSphericalLights(const std::vector<std::string>& texts) {
    std::vector<SphericalLight> lights;
    for (size_t i = 0; i + 2 < texts.size(); i += 3)
        lights.push_back({parseDirection(texts[i], "--sphere"), parseRadiusRadians(texts[i + 1], "--sphere"),
                          parseVector(texts[i + 2], "--sphere")});
    return lights;
}

} // namespace

void addLightOptions(CLI::App& command, LightOptions& options) {
    using Texts = std::vector<std::string>;
    addParsedOption<Texts>(command, "--ambient", options.ambient, parseAmbient,
                           "Uniform radiance R,G,B added to the probe");
    addParsedOption<Texts>(
        command, "--directional", options.directional, parseDirectionalLights,
        "Directional light X,Y,Z R,G,B (intensity I lights a facing white surface to I); repeatable")
        ->type_size(2)
        ->allow_extra_args(false);
    addParsedOption<Texts>(
        command, "--sphere", options.spheres, parseSphericalLights,
        "Spherical light X,Y,Z RADIUS_DEGREES R,G,B (uniform radiance over the disc); repeatable")
        ->type_size(3)
        ->allow_extra_args(false);
}

bool hasLights(const LightOptions& options) {
    return !options.ambient.empty() || !options.directional.empty() || !options.spheres.empty();
}

double largestMagnitude(const ShCoefficients& probe) {
    double largest = 0.0;
    for (const glm::dvec3& coefficient : probe.rgb)
        for (int c = 0; c < 3; ++c)
            largest = std::isnan(coefficient[c]) ? HUGE_VAL : std::max(largest, std::abs(coefficient[c]));
    return largest;
}

namespace {

// The format -o's extension names, as bake and convert choose it (json where it names none); its
// output checked before any work.
const ExportFormat& outputFormatOf(const std::string& output) {
    std::string format, path = output;
    settleFormatAndOutput(format, path);
    const ExportFormat& chosen = *findExportFormat(format);
    checkOutputPath(output, chosen.content);
    return chosen;
}

// A probe with a sun goes only where the format keeps it (json): ExportFormat::write refuses it.
void writeInFormat(const ExportFormat& format, const std::string& output, const ShCoefficients& probe,
                   const ProbeMetadata& metadata) {
    ExportOptions options;
    options.metadata = metadata;
    format.write(output, probe, options);
}

} // namespace

void addLights(ShCoefficients& radiance, const LightOptions& options, const std::string& name) {
    const double before =
        std::max(largestMagnitude(radiance), largestMagnitude(convolveIrradiance(radiance)));
    for (const glm::dvec3& ambient : options.ambient)
        addAmbient(radiance, ambient);
    for (const DirectionalLight& light : options.directional)
        addDirectionalLight(radiance, light);
    for (const SphericalLight& light : options.spheres)
        addSphericalLight(radiance, light);
    const double floatMax = std::numeric_limits<float>::max();
    const double lit = largestMagnitude(radiance),
                 irradiance = largestMagnitude(convolveIrradiance(radiance));
    if (std::max(lit, irradiance) <= floatMax || !(std::max(lit, irradiance) > before)) return;
    const bool radianceOver = !(lit <= floatMax);
    throw Error(ErrorKind::Input,
                name + ": with the lights of --ambient, --directional and --sphere the probe's " +
                    (radianceOver ? "radiance" : "irradiance") + " reaches " +
                    shortNumber(radianceOver ? lit : irradiance) + ", past float's " + shortNumber(floatMax) +
                    ": make them weaker");
}

Window parseWindow(const std::string& text) {
    if (text == "none") return {};
    if (text == "dering") return {Window::Kind::Dering, 0.0, text};
    if (text == "dering-lanczos") return {Window::Kind::DeringLanczos, 0.0, text};
    return parseFixedWindow(text);
}

void addWindowOption(CLI::App& command, Window& window) {
    addParsedOption(
        command, "--window", window, parseWindow,
        "Windowing against ringing: none, hanning:WIDTH, lanczos:WIDTH, or dering / dering-lanczos "
        "(the weakest Hanning / Lanczos window that keeps irradiance non-negative)")
        ->default_str(window.text);
}

std::optional<std::vector<double>> windowFactorsFor(const Window& window, const ShCoefficients& radiance) {
    switch (window.kind) {
    case Window::Kind::None:
        return std::nullopt;
    case Window::Kind::Hanning:
        return windowFactors(WindowKind::Hanning, window.width, radiance.order);
    case Window::Kind::Lanczos:
        return windowFactors(WindowKind::Lanczos, window.width, radiance.order);
    case Window::Kind::Dering:
    case Window::Kind::DeringLanczos:
        break;
    }
    DeringOptions options;
    options.window = window.kind == Window::Kind::Dering ? WindowKind::Hanning : WindowKind::Lanczos;
    return deringWindow(radiance, options).bandFactors;
}

void addRotateOptions(CLI::App& command, RotateOptions& options) {
    command.add_option("probe", options.input, "Probe file: JSON, or binary of one probe")->required();
    command
        .add_option("-o,--output", options.output,
                    "Rotated probe, in the format its extension names (as bake's -o; JSON where none)")
        ->required()
        ->check(nonEmptyName());
    addRotationOption(command, "--euler", options, 3, eulerRotation,
                      "ALPHA,BETA,GAMMA degrees: R = Rz(gamma) Ry(beta) Rz(alpha)",
                      numberFrom(-360.0, 360.0));
    // rotationFromQuaternion says when it is not unit, orthogonalFromRowMajor when it is not orthogonal.
    addRotationOption(command, "--quat", options, 4, quaternionRotation, "W,X,Y,Z unit quaternion",
                      numberFrom(-HUGE_VAL, HUGE_VAL));
    addRotationOption(command, "--matrix", options, 9, matrixRotation,
                      "R00,R01,...,R22 orthogonal matrix, row-major: a rotation, or a reflection (det -1) "
                      "for a change of handedness",
                      numberFrom(-HUGE_VAL, HUGE_VAL));
}

void runRotate(const RotateOptions& options) {
    const GivenRotation& given = chosenRotation(options);
    const ExportFormat& format = outputFormatOf(options.output);
    checkOutputsAreNotInputs({&options.output, 1}, {&options.input, 1});
    Probe probe = readProbe(options.input);
    const glm::dmat3& rotation = given.matrix;
    ProbeMetadata metadata;
    metadata.source = options.input + " rotated by " + given.description;
    // The sun taken out of the coefficients turns with them: a light from d then comes from R d.
    metadata.sun = probe.sun;
    if (metadata.sun) metadata.sun->direction = glm::normalize(rotation * metadata.sun->direction);
    metadata.window = probe.window; // a window scales whole bands, which a rotation keeps apart
    const ShCoefficients& coefficients = probe.coefficients;
    writeInFormat(format, options.output, rotate(makeShRotation(rotation, coefficients.order), coefficients),
                  metadata);
    std::fprintf(reportStream(options.output), "shprobe rotate: %s -> %s (%s)\n", options.input.c_str(),
                 options.output.c_str(), given.description.c_str());
}

void addLightOptions(CLI::App& command, LightCommandOptions& options) {
    command
        .add_option("-o,--output", options.output,
                    "Probe file, in the format its extension names (as bake's -o; JSON where none)")
        ->required()
        ->check(nonEmptyName());
    addRangeOption(command, "--order", options.order, "SH order", 1, kMaxOrder);
    command.add_flag("--irradiance", options.irradiance, "Write irradiance instead of radiance");
    addLightOptions(command, options.lights);
}

void runLight(const LightCommandOptions& options) {
    if (!hasLights(options.lights))
        throw Error(ErrorKind::Input, "light: give at least one --ambient, --directional or --sphere");
    const ExportFormat& format = outputFormatOf(options.output);
    ShCoefficients radiance = makeCoefficients(options.order, Quantity::Radiance);
    addLights(radiance, options.lights, "light");
    ProbeMetadata metadata;
    metadata.source = "analytic lights";
    writeInFormat(format, options.output, options.irradiance ? convolveIrradiance(radiance) : radiance,
                  metadata);
    std::fprintf(reportStream(options.output),
                 "shprobe light: %zu ambient, %zu directional, %zu spherical -> %s\n",
                 options.lights.ambient.size(), options.lights.directional.size(),
                 options.lights.spheres.size(), options.output.c_str());
}

} // namespace shprobe
