// Other ways to hand a probe to a renderer than the JSON file (probe_file.h): a packed binary file,
// and the irradiance itself drawn into an equirect map or a horizontal-cross cube map (EXR).
#pragma once
#include "sh/coefficients.h"

#include <cstdint>
#include <span>
#include <string>
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

std::string probesToBinary(std::span<const ShCoefficients> probes);
// All probes must share order and quantity. Written atomically; throws Error(Output) naming the file.
void writeBinaryProbes(const std::string& path, std::span<const ShCoefficients> probes);
// Parses and validates; throws Error(Input) naming `name` and what is wrong.
std::vector<ShCoefficients> parseBinaryProbes(std::string_view bytes, const std::string& name);
std::vector<ShCoefficients> readBinaryProbes(const std::string& path);

// The irradiance of a probe (its convolution when it holds radiance) drawn as the radiance a white
// Lambertian surface facing each direction reflects, E(n) / pi: a W x W/2 equirect map (directions
// of CONVENTIONS.md) or a horizontal cross (4:3) of faceSize faces, empty cells black. EXR (linear
// float); written atomically.
void writeIrradianceEquirect(const std::string& path, const ShCoefficients& probe, int width);
void writeIrradianceCross(const std::string& path, const ShCoefficients& probe, int faceSize);

} // namespace shprobe
