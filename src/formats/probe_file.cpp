#include "formats/probe_file.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/output_file.h"
#include "common/quoted.h"
#include "common/scope_exit.h"
#include "formats/json_reading.h"
#include "formats/probe_export.h"
#include "formats/probe_volume.h"
#include "sh/basis.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fcntl.h>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <sys/stat.h>
#include <unistd.h>

namespace shprobe {

namespace {

using nlohmann::json;

// A JSON coefficient file of order 8 is a few kilobytes; anything far larger is not one, and is
// not parsed.
constexpr uint64_t kMaxProbeFileBytes = 1u << 20;
// A coefficient file nests three levels (the object, "coefficients", a row). The parser stops
// at this depth, before it builds the levels below: "[[[[..." is refused at once.
constexpr int kMaxJsonDepth = 16;

const char* kFormat = "shprobe.sh";
const int kVersion = 1;

[[noreturn]] void fail(const std::string& name, const std::string& problem) {
    throw Error(ErrorKind::Input, name + ": " + problem);
}

int orderField(const json& root, const std::string& name) {
    const json& value = requireField(root, "order", name);
    if (!value.is_number_integer() || value.get<int64_t>() < 1 || value.get<int64_t>() > kMaxOrder)
        fail(name, "field \"order\" must be an integer from 1 to " + std::to_string(kMaxOrder));
    return value.get<int>();
}

Quantity requireQuantity(const json& root, const std::string& name) {
    std::string quantity = requireString(root, "quantity", name);
    if (quantity == "radiance") return Quantity::Radiance;
    if (quantity == "irradiance") return Quantity::Irradiance;
    fail(name,
         "field \"quantity\" is " + quotedInput(quantity) + "; expected \"radiance\" or \"irradiance\"");
}

glm::dvec3 parseRow(const json& row, size_t index, const std::string& name) {
    std::string where = "coefficients[" + std::to_string(index) + "]";
    if (!row.is_array() || row.size() != 3) fail(name, where + " must be an array of 3 numbers [r, g, b]");
    glm::dvec3 rgb;
    for (int c = 0; c < 3; ++c) {
        if (!row[c].is_number()) fail(name, where + " must be an array of 3 numbers [r, g, b]");
        rgb[c] = row[c].get<double>();
        if (!std::isfinite(rgb[c])) fail(name, where + " holds a value that is not finite");
    }
    return rgb;
}

// "sun": {"direction": [x, y, z], "radiance": [r, g, b], "angular_radius_degrees": a}.
glm::dvec3 parseSunTriple(const json& sun, const char* field, const std::string& name, bool nonNegative) {
    std::string where = std::string("field \"sun.") + field + "\"";
    auto it = sun.find(field);
    if (it == sun.end()) fail(name, "missing " + where);
    const json& value = *it;
    const char* what = nonNegative ? " must be an array of 3 numbers [r, g, b], each >= 0"
                                   : " must be an array of 3 numbers [x, y, z]";
    if (!value.is_array() || value.size() != 3) fail(name, where + what);
    glm::dvec3 triple;
    for (int c = 0; c < 3; ++c) {
        if (!value[c].is_number()) fail(name, where + what);
        triple[c] = value[c].get<double>();
        if (!std::isfinite(triple[c])) fail(name, where + " holds a value that is not finite");
        if (nonNegative && triple[c] < 0.0) fail(name, where + what);
    }
    return triple;
}

ProbeSun parseSun(const json& sun, const std::string& name) {
    if (!sun.is_object())
        fail(name, "field \"sun\" must be an object with \"direction\", \"radiance\" and "
                   "\"angular_radius_degrees\"");
    ProbeSun result;
    glm::dvec3 direction = parseSunTriple(sun, "direction", name, false);
    // Scaled by its largest component first, so that neither tiny nor huge components over- or underflow.
    double largest = std::max({std::abs(direction.x), std::abs(direction.y), std::abs(direction.z)});
    if (largest == 0.0) fail(name, "field \"sun.direction\" is the zero vector");
    direction /= largest;
    result.direction = direction / std::sqrt(direction.x * direction.x + direction.y * direction.y +
                                             direction.z * direction.z);
    result.radiance = parseSunTriple(sun, "radiance", name, true);
    auto radius = sun.find("angular_radius_degrees");
    if (radius == sun.end()) fail(name, "missing field \"sun.angular_radius_degrees\"");
    double degrees = radius->is_number() ? radius->get<double>() : std::nan("");
    if (!(degrees > 0.0 && degrees <= 90.0))
        fail(name, "field \"sun.angular_radius_degrees\" must be a number in (0, 90]");
    result.angularRadius = degrees * M_PI / 180.0;
    // A radius so small that it is 0 in radians (1e-322 degrees) would be written as 0 and refused.
    if (!(result.angularRadius > 0.0))
        fail(name, "field \"sun.angular_radius_degrees\" must be a number in (0, 90]");
    return result;
}

// A coefficient as text that reads back as itself: a float (the GPU's) in 9 significant digits,
// which give that float back; a double (the CPU's, a rotation's) in the shortest digits that give
// the double back, at most 17. Nine digits of a double could fall on the other side of a float
// rounding midpoint, so that the JSON and binary files of one bake differed by an ulp; the binary
// file now holds float(JSON value), whichever is written.
std::string formatNumber(double value) {
    char text[32];
    const bool isFloat =
        std::abs(value) <= double(std::numeric_limits<float>::max()) && double(float(value)) == value;
    const auto written = isFloat
                             ? std::to_chars(text, text + sizeof(text), value, std::chars_format::general, 9)
                             : std::to_chars(text, text + sizeof(text), value);
    return std::string(text, written.ptr);
}

} // namespace

const char* quantityName(Quantity quantity) {
    return quantity == Quantity::Radiance ? "radiance" : "irradiance";
}

std::string probeToJson(const ShCoefficients& coefficients, const ProbeMetadata& metadata) {
    // JSON has no NaN or infinity: refuse rather than write a file no reader accepts.
    for (size_t i = 0; i < coefficients.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            if (!std::isfinite(coefficients.rgb[i][c]))
                throw Error(ErrorKind::Input, "coefficient " + std::to_string(i) + " is not finite");
    nlohmann::ordered_json header = nlohmann::ordered_json::object();
    header["format"] = kFormat;
    header["version"] = kVersion;
    header["convention"] = kConventionName;
    header["order"] = coefficients.order;
    header["quantity"] = quantityName(coefficients.quantity);
    if (!metadata.source.empty()) header["source"] = metadata.source;
    if (metadata.faceSize > 0) header["face_size"] = metadata.faceSize;
    if (!metadata.weighting.empty()) header["weighting"] = metadata.weighting;
    if (!metadata.backend.empty()) header["backend"] = metadata.backend;
    if (!metadata.device.empty()) header["device"] = metadata.device;
    if (!metadata.window.empty()) header["window"] = metadata.window;
    if (metadata.sun) {
        const ProbeSun& sun = *metadata.sun;
        header["sun"] = {{"direction", {sun.direction.x, sun.direction.y, sun.direction.z}},
                         {"radiance", {sun.radiance.r, sun.radiance.g, sun.radiance.b}},
                         {"angular_radius_degrees", sun.angularRadius * 180.0 / M_PI}};
    }

    // One coefficient row per line, so the file reads like the table it is.
    std::string text = "{\n";
    for (const auto& [key, value] : header.items())
        text += "  " + jsonText(json(key)) + ": " + jsonText(value) + ",\n";
    text += "  \"coefficients\": [\n";
    for (size_t i = 0; i < coefficients.rgb.size(); ++i) {
        const glm::dvec3& c = coefficients.rgb[i];
        text += "    [" + formatNumber(c.r) + ", " + formatNumber(c.g) + ", " + formatNumber(c.b) + "]";
        text += i + 1 < coefficients.rgb.size() ? ",\n" : "\n";
    }
    text += "  ]\n}\n";
    return text;
}

void writeProbeFile(const std::string& path, const ShCoefficients& coefficients,
                    const ProbeMetadata& metadata) {
    std::string text;
    try {
        text = probeToJson(coefficients, metadata);
    } catch (const Error& error) {
        throw Error(error.kind(),
                    "cannot write " + path + ": " + error.what() + " (is the input's radiance too large?)");
    }
    writeOutputFile(path, text);
}

Probe parseProbe(std::string_view text, const std::string& name) {
    // The JSON reader would take a NUL byte for the end of the text and ignore what follows (the
    // zeros a crash can leave at the end of a file, say).
    if (size_t nul = text.find('\0'); nul != std::string_view::npos)
        fail(name, "not valid JSON (a NUL byte at offset " + std::to_string(nul) + ")");
    json root;
    try {
        root = parseBoundedJson(text, kMaxJsonDepth);
    } catch (const json::exception& error) {
        fail(name, "not valid JSON (" + jsonProblem(error) + ")");
    } catch (const JsonTooDeep&) {
        fail(name, "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels; not a probe file");
    }
    if (!root.is_object()) fail(name, "the top level must be a JSON object");
    if (requireString(root, "format", name) != kFormat)
        fail(name, std::string("field \"format\" must be \"") + kFormat + "\"");
    const json& version = requireField(root, "version", name);
    if (!version.is_number_integer() || version.get<int64_t>() != kVersion)
        fail(name, "field \"version\" must be " + std::to_string(kVersion));
    std::string convention = requireString(root, "convention", name);
    if (convention != kConventionName)
        fail(name,
             "field \"convention\" is " + quotedInput(convention) + "; expected \"" + kConventionName + "\"");

    ShCoefficients coefficients = makeCoefficients(orderField(root, name), requireQuantity(root, name));
    const json& rows = requireField(root, "coefficients", name);
    if (!rows.is_array() || rows.size() != coefficients.rgb.size())
        fail(name, "field \"coefficients\" must hold " + counted(coefficients.rgb.size(), "row") +
                       " for order " + std::to_string(coefficients.order) + ", not " +
                       (rows.is_array() ? std::to_string(rows.size()) : std::string("a non-array")));
    for (size_t i = 0; i < rows.size(); ++i)
        coefficients.rgb[i] = parseRow(rows[i], i, name);
    Probe probe{std::move(coefficients), std::nullopt, {}};
    if (auto sun = root.find("sun"); sun != root.end()) probe.sun = parseSun(*sun, name);
    if (auto window = root.find("window"); window != root.end() && !window->is_null()) {
        if (!window->is_string()) fail(name, "field \"window\" must be a string");
        probe.window = window->get<std::string>();
    }
    return probe;
}

// The first bytes of a regular file, up to 16; none for anything else, which readInputFile then
// refuses or reads (opened without blocking: a FIFO must not hang the run here).
std::string fileStart(const std::string& path) {
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) return {};
    ScopeExit closeFile([&] { close(fd); });
    struct stat status {};
    char start[16] = {};
    if (fstat(fd, &status) != 0 || !S_ISREG(status.st_mode)) return {};
    const ssize_t read = pread(fd, start, sizeof start, 0);
    return read > 0 ? std::string(start, size_t(read)) : std::string();
}

// Files of the formats beside probe files, known by their first bytes, are named as what they are
// rather than refused as JSON that does not parse.
void refuseOtherFormats(std::string_view start, const std::string& name) {
    constexpr std::pair<std::string_view, std::string_view> kFormats[] = {
        {kProbeVolumeMagic, "a probe volume"},
        {std::string_view("\x76\x2f\x31\x01", 4), "an OpenEXR image"},
        {"#?RADIANCE", "a Radiance HDR image"},
        {"#?RGBE", "a Radiance HDR image"},
        {"\x89PNG", "a PNG image"},
        {"glTF", "a binary glTF scene"},
    };
    for (const auto& [magic, format] : kFormats)
        if (start.starts_with(magic))
            fail(name, std::string(format) + ", not a probe file (JSON, or binary of one probe)");
}

// A batch's binary file may be larger than any JSON probe file: the limit follows the file's first
// bytes, so that a batch is refused for holding many probes, not for its size, and a large JSON file
// before it is read. Standard input cannot be looked at first: it gets the binary limit, and JSON past
// its own is refused before it is parsed.
Probe readProbe(const std::string& path) {
    const bool standardInput = path == "-";
    const std::string name = standardInput ? "standard input" : path;
    const std::string start = standardInput ? std::string() : fileStart(path);
    refuseOtherFormats(start, name);
    const std::string bytes = standardInput || isBinaryProbeData(start)
                                  ? readInputFile(path, kMaxBinaryProbeFileBytes, "a binary probe file")
                                  : readInputFile(path, kMaxProbeFileBytes, "a JSON probe file");
    if (!isBinaryProbeData(bytes)) {
        refuseOtherFormats(bytes, name);
        if (bytes.size() > kMaxProbeFileBytes)
            throw Error(ErrorKind::Input,
                        name + ": " + sizeLimitText(bytes.size(), kMaxProbeFileBytes, "a JSON probe file"));
        return parseProbe(bytes, name);
    }
    const uint32_t count = binaryProbeCount(bytes, name);
    if (count != 1)
        throw Error(ErrorKind::Input, name + ": the binary file holds " + counted(count, "probe") +
                                          "; give a file of one probe");
    return Probe{std::move(parseBinaryProbes(bytes, name).front()), std::nullopt, {}};
}

ShCoefficients parseProbeJson(std::string_view text, const std::string& name) {
    return parseProbe(text, name).coefficients;
}

ShCoefficients readProbeFile(const std::string& path) {
    return readProbe(path).coefficients;
}

} // namespace shprobe
