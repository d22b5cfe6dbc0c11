#include "formats/output_format.h"

#include "common/error.h"
#include "formats/probe_export.h"
#include "image/specular_prefilter.h"

#include <string_view>

namespace shprobe {

namespace {

// The format an output name's extension names; empty when it names none (".txt", "/dev/null").
std::string formatOfExtension(const std::string& path) {
    const ExportFormat* format = formatOfOutputName(path);
    return format ? format->name : "";
}

// The extension names no format, the format itself, the other irradiance map, or a format whose
// whole extension ends the format's own (-o x.json --format threejs: ".three.json" ends in ".json";
// -o x.godot.json --format unity names godot, whose ".godot.json" does not end ".unity.json").
bool extensionAgrees(const std::string& named, const std::string& format) {
    return named.empty() || named == format ||
           (named == "irradiance-equirect" && format == "irradiance-cross") ||
           std::string_view(formatNamed(format).extension).ends_with(formatNamed(named).extension);
}

} // namespace

const ExportFormat& formatNamed(const std::string& name) {
    const ExportFormat* format = findExportFormat(name);
    if (!format) throw Error(ErrorKind::Input, "--format " + name + " is not one of " + exportFormatNames());
    return *format;
}

bool isHeaderFormat(const std::string& format) {
    return format == "glsl" || format == "cpp";
}

const char* formatExtension(const std::string& format) {
    return formatNamed(format).extension;
}

void settleFormatAndOutput(std::string& format, std::string& output) {
    const std::string named = output.empty() ? "" : formatOfExtension(output);
    if (format.empty()) format = named.empty() ? "json" : named;
    if (!extensionAgrees(named, format))
        throw Error(ErrorKind::Input, "-o " + output + " names a file of --format " + named +
                                          ", but --format is " + format + "; use the extension " +
                                          formatExtension(format) + " or leave out --format");
    if (output.empty()) output = std::string("probe") + formatExtension(format);
}

OutputContent formatContent(const std::string& format) {
    return formatNamed(format).content;
}

void requireMapSizeFits(const std::string& format, int mapSize) {
    if (format == "irradiance-equirect" && mapSize != 0 && !isEquirectMapWidth(mapSize))
        throw Error(ErrorKind::Input,
                    "--map-size: an equirect map's width must be even and at least 2, not " +
                        std::to_string(mapSize));
    if (format == "gltf" && mapSize != 0 && !isSpecularSize(mapSize))
        throw Error(ErrorKind::Input, "--map-size: gltf's specularImageSize must be a power of two from " +
                                          std::to_string(kMinSpecularSize) + " to " +
                                          std::to_string(kMaxSpecularSize) + ", not " +
                                          std::to_string(mapSize));
}

} // namespace shprobe
