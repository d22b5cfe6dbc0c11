#include "io/probe_export.h"

#include "image/image_write.h"
#include "io/atomic_file.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/error.h"
#include "sh/irradiance.h"

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>
#include <sstream>

namespace shprobe {

namespace {

constexpr char kMagic[4] = {'S', 'H', 'P', 'B'};

void appendWord(std::string& bytes, uint32_t value) {
    for (int i = 0; i < 4; ++i) bytes.push_back(char((value >> (8 * i)) & 0xffu));
}

uint32_t wordAt(std::string_view bytes, size_t offset) {
    uint32_t value = 0;
    for (int i = 0; i < 4; ++i) value |= uint32_t(uint8_t(bytes[offset + i])) << (8 * i);
    return value;
}

void appendFloat(std::string& bytes, float value) {
    uint32_t word;
    std::memcpy(&word, &value, sizeof(word));
    appendWord(bytes, word);
}

float floatAt(std::string_view bytes, size_t offset) {
    uint32_t word = wordAt(bytes, offset);
    float value;
    std::memcpy(&value, &word, sizeof(value));
    return value;
}

[[noreturn]] void fail(const std::string& name, const std::string& problem) {
    throw Error(ErrorKind::Input, name + ": " + problem);
}

void checkSameKind(std::span<const ShCoefficients> probes) {
    if (probes.empty()) throw Error(ErrorKind::Input, "binary probes: no probe to write");
    for (const ShCoefficients& probe : probes)
        if (probe.order != probes[0].order || probe.quantity != probes[0].quantity)
            throw Error(ErrorKind::Input, "binary probes: all probes of a file must share order and quantity");
}

ShCoefficients irradianceOf(const ShCoefficients& probe) {
    return probe.quantity == Quantity::Irradiance ? probe : convolveIrradiance(probe);
}

glm::vec4 reflectedRadiance(const ShCoefficients& irradiance, const glm::dvec3& direction) {
    return glm::vec4(glm::vec3(evaluate(irradiance, direction) / std::numbers::pi), 1.0f);
}

// Where each face sits in a horizontal cross, in face units (CONVENTIONS.md):
// [ . +Y . . ] [ -X +Z +X -Z ] [ . -Y . . ], indexed by Face.
constexpr std::array<std::array<int, 2>, kFaceCount> kCrossSlots{{{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}}};

} // namespace

std::string probesToBinary(std::span<const ShCoefficients> probes) {
    checkSameKind(probes);
    std::string bytes(kMagic, sizeof(kMagic));
    appendWord(bytes, kBinaryProbeVersion);
    appendWord(bytes, uint32_t(probes[0].order));
    appendWord(bytes, probes[0].quantity == Quantity::Radiance ? 0u : 1u);
    appendWord(bytes, uint32_t(probes.size()));
    appendWord(bytes, kBinaryProbeHeaderBytes);
    appendWord(bytes, 0);
    appendWord(bytes, 0);
    for (const ShCoefficients& probe : probes)
        for (const glm::dvec3& c : probe.rgb)
            for (int channel = 0; channel < 3; ++channel) appendFloat(bytes, float(c[channel]));
    return bytes;
}

void writeBinaryProbes(const std::string& path, std::span<const ShCoefficients> probes) {
    writeFileAtomic(path, probesToBinary(probes));
}

std::vector<ShCoefficients> parseBinaryProbes(std::string_view bytes, const std::string& name) {
    if (bytes.size() < kBinaryProbeHeaderBytes) fail(name, "too short for a binary probe header");
    if (std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) fail(name, "not a binary probe file (magic)");
    if (wordAt(bytes, 4) != kBinaryProbeVersion) fail(name, "unknown version " + std::to_string(wordAt(bytes, 4)));
    uint32_t order = wordAt(bytes, 8), quantity = wordAt(bytes, 12), count = wordAt(bytes, 16);
    uint32_t dataOffset = wordAt(bytes, 20);
    if (order < 1 || order > uint32_t(kMaxOrder)) fail(name, "order " + std::to_string(order) + " is outside 1..8");
    if (quantity > 1) fail(name, "quantity " + std::to_string(quantity) + " is neither 0 nor 1");
    if (dataOffset < kBinaryProbeHeaderBytes || dataOffset > bytes.size()) fail(name, "bad header size");
    uint64_t expected = uint64_t(count) * order * order * 3 * sizeof(float);
    if (bytes.size() - dataOffset != expected)
        fail(name, "holds " + std::to_string(bytes.size() - dataOffset) + " data bytes, not " +
                       std::to_string(expected) + " for " + std::to_string(count) + " probes of order " +
                       std::to_string(order));
    std::vector<ShCoefficients> probes;
    size_t offset = dataOffset;
    for (uint32_t p = 0; p < count; ++p) {
        ShCoefficients probe = makeCoefficients(int(order), quantity == 0 ? Quantity::Radiance : Quantity::Irradiance);
        for (glm::dvec3& c : probe.rgb)
            for (int channel = 0; channel < 3; ++channel, offset += 4) {
                c[channel] = floatAt(bytes, offset);
                if (!std::isfinite(c[channel])) fail(name, "probe " + std::to_string(p) + " holds a non-finite value");
            }
        probes.push_back(std::move(probe));
    }
    return probes;
}

std::vector<ShCoefficients> readBinaryProbes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path, "cannot open the file");
    std::stringstream bytes;
    bytes << in.rdbuf();
    return parseBinaryProbes(bytes.str(), path);
}

void writeIrradianceEquirect(const std::string& path, const ShCoefficients& probe, int width) {
    if (width < 2 || width % 2 != 0) throw Error(ErrorKind::Input, "equirect width must be even and at least 2");
    ShCoefficients irradiance = irradianceOf(probe);
    Image image = makeImage(width, width / 2);
    for (int j = 0; j < image.height; ++j)
        for (int i = 0; i < image.width; ++i)
            image.at(i, j) = reflectedRadiance(irradiance, equirectDirection(i, j, image.width, image.height));
    writeImage(path, image);
}

void writeIrradianceCross(const std::string& path, const ShCoefficients& probe, int faceSize) {
    if (faceSize < 1) throw Error(ErrorKind::Input, "cube-map face size must be at least 1");
    ShCoefficients irradiance = irradianceOf(probe);
    Image cross = makeImage(4 * faceSize, 3 * faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < faceSize; ++j)
            for (int i = 0; i < faceSize; ++i)
                cross.at(kCrossSlots[face][0] * faceSize + i, kCrossSlots[face][1] * faceSize + j) =
                    reflectedRadiance(irradiance, texelDirection(face, i, j, faceSize));
    writeImage(path, cross);
}

} // namespace shprobe
