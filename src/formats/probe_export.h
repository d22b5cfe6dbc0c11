// Other ways to hand a probe to a renderer than the JSON file (probe_file.h): a packed binary file,
// a GLSL or C/C++ header of coefficients folded for the render shader, and the irradiance itself
// drawn into an equirect map or a horizontal-cross cube map (EXR).
#pragma once
#include "sh/coefficients.h"
#include "sh/folding.h"

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace shprobe {

// Packed binary probes, little-endian:
//   offset  0  char[4]  magic "SHPB"
//           4  uint32   version (1)
//           8  uint32   order n (1..8)
//          12  uint32   quantity (0 radiance L_lm, 1 irradiance E_lm)
//          16  uint32   count: number of probes
//          20  uint32   header size in bytes (32): data starts there
//          24  uint32   reserved (0), 28 uint32 reserved (0)
//          32  float32  count x n^2 x 3: probe after probe, coefficients in flat-index order, r g b
constexpr uint32_t kBinaryProbeVersion = 1;
constexpr uint32_t kBinaryProbeHeaderBytes = 32;
// 10,000 probes of order 8 take 7.7 MB; a file far larger than that is not read.
constexpr uint64_t kMaxBinaryProbeFileBytes = uint64_t(256) << 20;

std::string probesToBinary(std::span<const ShCoefficients> probes);
// All probes must share order and quantity. Written atomically; throws Error(Output) naming the file.
void writeBinaryProbes(const std::string& path, std::span<const ShCoefficients> probes);
// Whether the bytes begin with the magic "SHPB" (readProbe takes such a file, whatever its name).
bool isBinaryProbeData(std::string_view bytes);
// Validates the header against the file's size and returns the number of probes, reading none;
// throws Error(Input) naming `name` and what is wrong.
uint32_t binaryProbeCount(std::string_view bytes, const std::string& name);
// Parses and validates; throws Error(Input) naming `name` and what is wrong.
std::vector<ShCoefficients> parseBinaryProbes(std::string_view bytes, const std::string& name);
std::vector<ShCoefficients> readBinaryProbes(const std::string& path);

// Headers with the coefficients folded for src/glsl/sh_irradiance.glsl (sh/folding.h), as
// Filament cmgen's --sh-shader writes them: the basis constants and, for irradiance, the
// convolution A_l / pi are multiplied in, so the shader spends one multiply-add per coefficient.
// A radiance probe folds with s_l = 1 for shRadiance (L(d)), an irradiance probe with A_l / pi for
// shIrradianceOverPi (E(n) / pi). The header states order, quantity, source and the call that
// evaluates it, and holds one array of SH_FOLDED_COUNT (25) rgb entries with w = 0, entries past
// the order 0, named after the file: for "sunset.h", `sunset_sh` and the order SUNSET_SH_ORDER
// (C/C++: `static const float sunset_sh[25][4]`, 16 bytes per entry as the shader's vec4 array in
// std140 or std430; GLSL: `const vec4 sunset_sh[SH_FOLDED_COUNT]` and `const uint
// sunset_sh_order`, to include after sh_irradiance.glsl). Values are the float nearest the double
// fold, printed in the shortest form that reads back to the same float.
enum class HeaderLanguage { Glsl, C };

// The identifier a header derives from a file stem: letters, digits and '_' kept, any other byte
// (and runs of them) one '_', no leading, trailing or double '_'; "probe_" in front of a leading
// digit or GLSL's reserved "gl_", and "probe" for an empty result.
std::string headerIdentifier(std::string_view stem);

// Order 1..5 (the shader's); throws Error(Input) otherwise. `identifier` names the array
// (identifier + "_sh"); `source` is copied into a comment (control characters and '\' replaced).
std::string probeToHeader(const ShCoefficients& probe, HeaderLanguage language, const std::string& identifier,
                          const std::string& source);
// The coefficients a header holds for the probe (order 1..5): folded to shRadiance for a radiance
// probe, to shIrradianceOverPi for an irradiance one.
FoldedCoefficients headerCoefficients(const ShCoefficients& probe);
// The identifier is headerIdentifier(stem of path). Written atomically.
void writeProbeHeader(const std::string& path, const ShCoefficients& probe, HeaderLanguage language,
                      const std::string& source);

// The irradiance of a probe (its convolution when it holds radiance) drawn as the radiance a white
// Lambertian surface facing each direction reflects, E(n) / pi: a W x W/2 equirect map (directions
// of docs/conventions.md) or a horizontal cross (4:3) of faceSize faces, empty cells black. EXR (linear
// float); written atomically.
// The irradiance coefficients E_lm the maps draw (the probe's, or their convolution).
ShCoefficients irradianceMapCoefficients(const ShCoefficients& probe);
void writeIrradianceEquirect(const std::string& path, const ShCoefficients& probe, int width);
void writeIrradianceCross(const std::string& path, const ShCoefficients& probe, int faceSize);
// Whether writeIrradianceEquirect takes this width (even, at least 2), so that an option can be
// checked before any work (requireMapSizeFits).
bool isEquirectMapWidth(int width);

} // namespace shprobe
