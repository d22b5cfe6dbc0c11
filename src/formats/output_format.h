// The rules that tie an output's name to its format (the table of formats/engine_export.h): which
// format an -o name chooses, the extension a format's files get, and whether they are text.
#pragma once
#include "common/output_file.h"
#include "formats/engine_export.h"

#include <string>

namespace shprobe {

// The format named by --format; Error(Input) listing the formats for any other name.
const ExportFormat& formatNamed(const std::string& name);
// Whether the format is a shader header (glsl, cpp), which folds the probe to orders 1 to 3.
bool isHeaderFormat(const std::string& format);

// The extension a format's files get: ".json", ".bin", ".glsl", ".h", ".exr".
const char* formatExtension(const std::string& format);

// Settles a format and an output name: without a format, the output's extension chooses it (json
// when the extension names none); without an output, it is "probe" and the format's extension. An
// output extension that names another format is refused (Error(Input)).
void settleFormatAndOutput(std::string& format, std::string& output);

// Whether the format's files are text (json, glsl, cpp) or binary (standard output takes both;
// a terminal only text).
OutputContent formatContent(const std::string& format);

// --map-size for the format, checked before any work: an irradiance-equirect map's width even and at
// least 2, gltf's specularImageSize a power of two from 32 to 512 (image/specular_prefilter.h);
// Error(Input) otherwise. 0 is the writer's default.
void requireMapSizeFits(const std::string& format, int mapSize);

} // namespace shprobe
