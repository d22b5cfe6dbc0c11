// The packed binary probe file of formats/probe_export.h: its own file, so that the readers that
// take it (readProbe, in the fuzzers too) need nothing else of the exports.
#include "common/counted.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/output_file.h"
#include "formats/probe_export.h"
#include "sh/basis.h"

#include <cmath>
#include <cstring>

namespace shprobe {

namespace {

constexpr char kMagic[4] = {'S', 'H', 'P', 'B'};

void appendWord(std::string& bytes, uint32_t value) {
    for (int i = 0; i < 4; ++i)
        bytes.push_back(char((value >> (8 * i)) & 0xffu));
}

uint32_t wordAt(std::string_view bytes, size_t offset) {
    uint32_t value = 0;
    for (int i = 0; i < 4; ++i)
        value |= uint32_t(uint8_t(bytes[offset + i])) << (8 * i);
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
            throw Error(ErrorKind::Input,
                        "binary probes: all probes of a file must share order and quantity");
}

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
            for (int channel = 0; channel < 3; ++channel)
                appendFloat(bytes, float(c[channel]));
    return bytes;
}

void writeBinaryProbes(const std::string& path, std::span<const ShCoefficients> probes) {
    writeOutputFile(path, probesToBinary(probes), OutputContent::Binary);
}

bool isBinaryProbeData(std::string_view bytes) {
    return bytes.size() >= sizeof(kMagic) && std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) == 0;
}

uint32_t binaryProbeCount(std::string_view bytes, const std::string& name) {
    if (!isBinaryProbeData(bytes)) fail(name, "not a binary probe file (magic)");
    if (bytes.size() < kBinaryProbeHeaderBytes) fail(name, "too short for a binary probe header");
    if (wordAt(bytes, 4) != kBinaryProbeVersion)
        fail(name, "unknown version " + std::to_string(wordAt(bytes, 4)));
    uint32_t order = wordAt(bytes, 8), quantity = wordAt(bytes, 12), count = wordAt(bytes, 16);
    uint32_t dataOffset = wordAt(bytes, 20);
    if (order < 1 || order > uint32_t(kMaxOrder))
        fail(name, "order " + std::to_string(order) + " is outside 1.." + std::to_string(kMaxOrder));
    if (quantity > 1) fail(name, "quantity " + std::to_string(quantity) + " is neither 0 nor 1");
    if (dataOffset < kBinaryProbeHeaderBytes || dataOffset > bytes.size()) fail(name, "bad header size");
    uint64_t expected = uint64_t(count) * order * order * 3 * sizeof(float);
    if (bytes.size() - dataOffset != expected)
        fail(name, "holds " + counted(bytes.size() - dataOffset, "data byte") + ", not " +
                       std::to_string(expected) + " for " + counted(count, "probe") + " of order " +
                       std::to_string(order));
    return count;
}

std::vector<ShCoefficients> parseBinaryProbes(std::string_view bytes, const std::string& name) {
    const uint32_t count = binaryProbeCount(bytes, name);
    const uint32_t order = wordAt(bytes, 8), quantity = wordAt(bytes, 12), dataOffset = wordAt(bytes, 20);
    std::vector<ShCoefficients> probes;
    size_t offset = dataOffset;
    for (uint32_t p = 0; p < count; ++p) {
        ShCoefficients probe =
            makeCoefficients(int(order), quantity == 0 ? Quantity::Radiance : Quantity::Irradiance);
        for (glm::dvec3& c : probe.rgb)
            for (int channel = 0; channel < 3; ++channel, offset += 4) {
                c[channel] = floatAt(bytes, offset);
                if (!std::isfinite(c[channel]))
                    fail(name, "probe " + std::to_string(p) + " holds a non-finite value");
            }
        probes.push_back(std::move(probe));
    }
    return probes;
}

std::vector<ShCoefficients> readBinaryProbes(const std::string& path) {
    return parseBinaryProbes(readInputFile(path, kMaxBinaryProbeFileBytes, "a binary probe file"), path);
}

} // namespace shprobe
