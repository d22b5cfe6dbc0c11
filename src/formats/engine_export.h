// Every format shprobe writes a probe in, in one table: the coefficient file and the existing
// exports (probe_file.h, probe_export.h) and the files each engine reads as it is (three.js,
// Babylon.js, glTF EXT_lights_image_based, Filament, Unity, Godot). `bake --format`, `convert
// --format`, the output names and the writers all read the table. docs/exports.md tells, per
// engine, the frame, the basis sign, the pre-scaling and the layout, and the engine source each
// follows.
#pragma once
#include "common/output_file.h"
#include "formats/probe_file.h"
#include "sh/coefficients.h"
#include "sh/cubemap.h"

#include <array>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace shprobe {

// What gltf's specularImages are prefiltered from (image/specular_prefilter.h): a radiance cube map
// (bake: the environment, its analytic lights drawn in) and what it is, for asset.extras. Without
// one, the probe's own radiance from its coefficients.
struct SpecularSource {
    const Cubemap* radiance = nullptr;
    std::string what; // "forest.exr (equirect 1024x512) with --ambient, --sphere"
};

// What a writer may need beside the coefficients.
struct ExportOptions {
    ProbeMetadata metadata; // json keeps it all; the headers and glTF copy metadata.source
    // Irradiance maps: equirect width or face size (0: 512 / 128); gltf: specularImageSize (0: 128).
    int mapSize = 0;
    bool mirror = true;      // filament: the frame of cmgen's default mirroring (cmgen --no-mirror: false)
    SpecularSource specular; // gltf
};

// What a format does with the sun of --extract-sun (or of a probe file that has one).
enum class SunHandling {
    Written, // json: beside the coefficients
    Refused, // every other format: asking for a sun it would drop is an error
};

// What a format stores each of its numbers as.
enum class NumberType {
    Double, // finite doubles (json)
    Float,  // float32: finite, |x| <= FLT_MAX (binary, headers, irradiance maps, engine formats)
};

// A number a format writes (or, for the irradiance maps, a bound on the numbers it writes), in one
// channel and made of the probe's coefficients first..end-1 (flat index) of that channel.
struct WrittenNumber {
    double value;
    int channel; // 0 red, 1 green, 2 blue
    int first, end;
};

struct ExportFormat {
    const char* name;      // the --format value
    const char* extension; // of its files; an output name ending in it chooses the format
    OutputContent content;
    SunHandling sun;
    int maxOrder;     // highest order it holds whole (engine formats: 3; they take bands 0..2)
    const char* what; // one line for --help
    NumberType type;  // what its numbers are stored as
    // The numbers the writer would write for the probe, after the format's own scaling, folding or
    // convolution (none where the writer refuses the probe for another reason).
    std::vector<WrittenNumber> (*numbersOf)(const ShCoefficients& probe, const ExportOptions& options);
    void (*writeFile)(const std::string& path, const ShCoefficients& probe, const ExportOptions& options);

    // Every caller writes through here: refuses a sun the format would drop (requireSunFits) and a
    // number it cannot hold (requireRepresentable), then writes.
    void write(const std::string& path, const ShCoefficients& probe, const ExportOptions& options) const;
};

// Throws Error(Input) when options.metadata has a sun and the format would drop it (SunHandling::
// Refused), naming the probe and the remedy. Nothing is written.
void requireSunFits(const ExportFormat& format, const ExportOptions& options);

// Throws Error(Input) when a number the format would write for the probe is not representable in
// its type (NumberType), naming the probe (options.metadata.source) and its coefficient of largest
// magnitude among those that number is made of: "p.json: coefficient l=1 m=-1 (red) is 1e+300,
// beyond what --format cpp holds (float)". Nothing is written.
void requireRepresentable(const ExportFormat& format, const ShCoefficients& probe,
                          const ExportOptions& options);

std::span<const ExportFormat> exportFormats();
// nullptr for a name that is no format.
const ExportFormat* findExportFormat(std::string_view name);
// The format whose extension the output name ends in (the longest, case-insensitive:
// "x.three.json" is threejs, "x.json" json); nullptr when none (".txt", "/dev/null", "-").
const ExportFormat* formatOfOutputName(const std::string& path);
// "json, binary, ..." for messages and help.
std::string exportFormatNames();

// ---- Engine coefficients ---------------------------------------------------------------------

enum class Engine { ThreeJs, Babylon, Gltf, Filament, Unity, Godot };

// The engine's frame: a direction d of shprobe's frame (docs/conventions.md) is F d in the engine's.
// Improper (det -1) for the left-handed engines and for Filament without mirroring.
glm::dmat3 engineFrame(Engine engine, bool mirror = true);

// The 9 rgb values the engine takes, in its order (flat index l(l+1)+m, as all six use), its frame,
// its basis sign and its pre-scaling (docs/exports.md). Bands past 2 are dropped, missing bands are
// 0; an irradiance probe is turned back into radiance where the engine needs it (bands 0..2 all
// have A_l != 0).
using EngineCoefficients = std::array<glm::dvec3, 9>;
EngineCoefficients engineCoefficients(const ShCoefficients& probe, Engine engine, bool mirror = true);

// The file contents of the text engine formats (what the table's writers write).
std::string engineFileText(const ShCoefficients& probe, Engine engine, const ExportOptions& options);

} // namespace shprobe
