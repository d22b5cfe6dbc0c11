// The probe-volume file of docs/probe-volume.md: a 16-byte preamble (magic, header length), a JSON
// header padded to a multiple of 16 bytes, then the payload: radiance, irradiance (those held), the
// visibility maps, capture offsets and transfer (where held), one validity byte per probe.
#include "formats/probe_volume.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/input_file.h"
#include "common/output_file.h"
#include "common/quoted.h"
#include "formats/json_reading.h"
#include "sh/basis.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <functional>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <sys/stat.h>
#include <unistd.h>
#include <utility>

namespace shprobe {

namespace {

using nlohmann::json;

// The payload is copied to and from the host's float32 and bytes as they are.
static_assert(std::endian::native == std::endian::little,
              "probe volumes are little-endian: a big-endian host needs a byte swap here");
static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "coefficients are read into glm::vec3 arrays");
static_assert(sizeof(glm::vec2) == 2 * sizeof(float), "visibility is read into glm::vec2 arrays");

constexpr uint64_t kPreambleBytes = 16; // magic, then the header's length as a uint64
// The header and the payload start at multiples of 16 bytes, so that a reader may map the file
// and use the coefficients in place.
constexpr uint64_t kAlignment = 16;
// A header is well under a kilobyte plus the baker's settings; a "header" far larger is not one.
constexpr uint64_t kMaxHeaderBytes = 1u << 20;
// A visibility map of more texels a side is finer than any probe's rays resolve.
constexpr int kMaxVisibilitySize = 64;
// The header nests a few levels (the object, "grid", "settings" and what the baker puts in it);
// the parser stops at this depth before it builds the levels below.
constexpr int kMaxJsonDepth = 16;

const char* kFormat = "shprobe.volume";
const int kVersion = 1;
const char* kAxes = "xyz";

[[noreturn]] void fail(const std::string& what, const std::string& problem) {
    throw Error(ErrorKind::Input, what + ": " + problem);
}

std::string text(uint64_t value) {
    return std::to_string(value);
}

// "probes 100 to 149": a half-open range [begin, end) as a reader of the message counts.
std::string probeSpan(uint64_t begin, uint64_t end) {
    return end - begin == 1 ? "probe " + text(begin) : "probes " + text(begin) + " to " + text(end - 1);
}

std::string missingProbes(uint64_t begin, uint64_t end) {
    return "merge: " + probeSpan(begin, end) + (end - begin == 1 ? " is" : " are") +
           " in no brick (the bricks are incomplete)";
}

bool isFinite(const glm::vec3& rgb) {
    return std::isfinite(rgb.r) && std::isfinite(rgb.g) && std::isfinite(rgb.b);
}

size_t coefficientsPerProbe(const ProbeVolume& volume) {
    return size_t(coefficientCount(volume.order));
}

// ---- The volume in memory ----------------------------------------------------------------------

std::string quantitiesText(const ProbeVolume& volume) {
    if (!volume.radiance.empty() && !volume.irradiance.empty()) return "radiance and irradiance";
    return volume.radiance.empty() ? "irradiance" : "radiance";
}

// JSON text of an object that a reader accepts inside the header (one level deeper than itself).
std::optional<json> settingsObject(const std::string& settings) {
    json value;
    try {
        value = parseBoundedJson(settings, kMaxJsonDepth - 1);
    } catch (const json::exception&) {
        return std::nullopt;
    } catch (const JsonTooDeep&) {
        return std::nullopt;
    }
    if (!value.is_object()) return std::nullopt;
    return value;
}

// "the QUANTITY of probe P" for the first valid probe with a coefficient that is not finite; empty
// where there is none. Invalid probes are written as zeros, whatever they hold.
std::string nonFiniteProbe(const ProbeVolume& volume, const std::vector<glm::vec3>& coefficients,
                           const char* quantity) {
    if (coefficients.empty()) return "";
    const size_t perProbe = coefficientsPerProbe(volume);
    for (uint32_t p = 0; p < volume.probeCount(); ++p) {
        if (!volume.valid[p]) continue;
        for (size_t c = 0; c < perProbe; ++c)
            if (!isFinite(coefficients[p * perProbe + c]))
                return std::string("the ") + quantity + " of probe " + text(volume.begin + p);
    }
    return "";
}

void checkCoefficients(const ProbeVolume& volume, const std::vector<glm::vec3>& coefficients,
                       const char* quantity, const std::string& what) {
    if (coefficients.empty()) return;
    const size_t perProbe = coefficientsPerProbe(volume);
    if (coefficients.size() != size_t(volume.probeCount()) * perProbe)
        fail(what, std::string(quantity) + " holds " + counted(coefficients.size(), "coefficient") +
                       ", not " + text(size_t(volume.probeCount()) * perProbe) + " for " +
                       counted(volume.probeCount(), "probe") + " of order " + text(uint64_t(volume.order)));
    if (const std::string probe = nonFiniteProbe(volume, coefficients, quantity); !probe.empty())
        fail(what, probe + " is not finite");
}

void checkValidity(const ProbeVolume& volume, const std::string& what) {
    if (volume.valid.size() != volume.probeCount())
        fail(what, "holds " + counted(volume.valid.size(), "validity byte") + " for " +
                       counted(volume.probeCount(), "probe"));
    for (uint32_t p = 0; p < volume.probeCount(); ++p)
        if (volume.valid[p] > 1)
            fail(what, "probe " + text(volume.begin + p) + " has validity " + text(volume.valid[p]) +
                           ", neither 0 nor 1");
}

size_t visibilityTexels(const ProbeVolume& volume) {
    return size_t(volume.probeCount()) * size_t(volume.visibilitySize) * size_t(volume.visibilitySize);
}

// The capture offsets: none, or one finite offset per probe.
void checkOffsets(const ProbeVolume& volume, const std::string& what) {
    if (!volume.offsets.empty() && volume.offsets.size() != volume.probeCount())
        fail(what, "holds " + counted(volume.offsets.size(), "capture offset") + " for " +
                       counted(volume.probeCount(), "probe"));
    for (size_t p = 0; p < volume.offsets.size(); ++p)
        if (!isFinite(volume.offsets[p]))
            fail(what, "the capture offset of probe " + text(volume.begin + p) + " is not finite");
}

// Each texel's mean distance and mean square: finite, not negative.
void checkVisibility(const ProbeVolume& volume, const std::string& what) {
    if (volume.visibilitySize < 0 || volume.visibilitySize > kMaxVisibilitySize)
        fail(what, "the visibility maps' size " + std::to_string(volume.visibilitySize) + " is outside 0.." +
                       text(kMaxVisibilitySize));
    if (volume.visibility.size() != visibilityTexels(volume))
        fail(what, "holds " + text(volume.visibility.size()) + " visibility texels, not " +
                       text(visibilityTexels(volume)) + " for maps of " +
                       text(uint64_t(volume.visibilitySize)) + "^2");
    const size_t perProbe = size_t(volume.visibilitySize) * size_t(volume.visibilitySize);
    for (size_t t = 0; t < volume.visibility.size(); ++t) {
        const glm::vec2 moments = volume.visibility[t];
        if (!(std::isfinite(moments.x) && std::isfinite(moments.y) && moments.x >= 0.0f && moments.y >= 0.0f))
            fail(what, "the visibility of probe " + text(volume.begin + t / perProbe) +
                           " is not a finite distance");
    }
}

// The transfer: none, or static radiance and transfer of every probe (zeros, and so finite, where invalid).
void checkTransfer(const ProbeVolume& volume, const std::string& what) {
    if (volume.staticRadiance.empty() && volume.transfer.empty()) return;
    if (volume.staticRadiance.empty()) fail(what, "holds a transfer without its static radiance");
    checkCoefficients(volume, volume.staticRadiance, "static radiance", what);
    const size_t perProbe = coefficientsPerProbe(volume) * coefficientsPerProbe(volume);
    if (volume.transfer.size() != size_t(volume.probeCount()) * perProbe)
        fail(what, "the transfer holds " + text(volume.transfer.size()) + " entries, not " +
                       text(size_t(volume.probeCount()) * perProbe) + " for " +
                       counted(volume.probeCount(), "probe") + " of order " + text(uint64_t(volume.order)));
    for (size_t t = 0; t < volume.transfer.size(); ++t)
        if (volume.valid[t / perProbe] && !isFinite(volume.transfer[t]))
            fail(what, "the transfer of probe " + text(volume.begin + t / perProbe) + " is not finite");
}

// Everything writeProbeVolume and mergeProbeVolumes rely on; throws Error(Input) "WHAT: PROBLEM".
void checkVolume(const ProbeVolume& volume, const std::string& what) {
    checkProbeGrid(volume.grid, what);
    if (volume.order < 1 || volume.order > kMaxOrder)
        fail(what, "order " + std::to_string(volume.order) + " is outside 1.." + text(kMaxOrder));
    if (volume.begin >= volume.end || volume.end > volume.grid.probeCount())
        fail(what, "the probe range [" + text(volume.begin) + ", " + text(volume.end) +
                       ") is not a non-empty range of the grid's " +
                       counted(volume.grid.probeCount(), "probe"));
    if (volume.radiance.empty() && volume.irradiance.empty())
        fail(what, "holds neither radiance nor irradiance coefficients");
    if (volume.bounces < 0) fail(what, "a negative bounce count (" + std::to_string(volume.bounces) + ")");
    if (!settingsObject(volume.settings))
        fail(what,
             "the settings are not a JSON object (nested at most " + text(kMaxJsonDepth - 1) + " levels)");
    checkValidity(volume, what);
    checkVisibility(volume, what);
    checkOffsets(volume, what);
    checkCoefficients(volume, volume.radiance, "radiance", what);
    checkCoefficients(volume, volume.irradiance, "irradiance", what);
    checkTransfer(volume, what);
}

// ---- Writing -----------------------------------------------------------------------------------

json vectorJson(const glm::dvec3& v) {
    return json::array({v.x, v.y, v.z});
}

nlohmann::ordered_json headerJson(const ProbeVolume& volume) {
    nlohmann::ordered_json header = nlohmann::ordered_json::object();
    header["format"] = kFormat;
    header["version"] = kVersion;
    header["convention"] = kConventionName;
    header["order"] = volume.order;
    header["coefficient_count"] = coefficientCount(volume.order);
    json quantities = json::array();
    if (!volume.radiance.empty()) quantities.push_back("radiance");
    if (!volume.irradiance.empty()) quantities.push_back("irradiance");
    header["quantities"] = quantities;
    nlohmann::ordered_json grid = nlohmann::ordered_json::object();
    grid["counts"] = json::array({volume.grid.counts.x, volume.grid.counts.y, volume.grid.counts.z});
    grid["bounds_min"] = vectorJson(volume.grid.boundsMin);
    grid["bounds_max"] = vectorJson(volume.grid.boundsMax);
    header["grid"] = grid;
    nlohmann::ordered_json probes = nlohmann::ordered_json::object();
    probes["begin"] = volume.begin;
    probes["end"] = volume.end;
    header["probes"] = probes;
    if (volume.visibilitySize > 0) header["visibility"] = volume.visibilitySize;
    if (!volume.offsets.empty()) header["capture_offsets"] = true;
    if (!volume.transfer.empty()) header["transfer"] = true;
    header["bounces"] = volume.bounces;
    header["source"] = volume.source;
    if (!volume.sourceHash.empty()) header["source_hash"] = volume.sourceHash;
    if (!volume.skySource.empty()) header["sky_source"] = volume.skySource;
    header["settings"] = *settingsObject(volume.settings); // keys sorted: one text per value
    return header;
}

// One field per line, so that `head -c 1024 volume.shpv` reads as the table it is; spaces before
// the last newline pad it to a multiple of kAlignment.
std::string headerText(const ProbeVolume& volume) {
    const nlohmann::ordered_json fields = headerJson(volume);
    std::string header = "{\n";
    for (const auto& [key, value] : fields.items())
        header += "  " + json(key).dump() + ": " + jsonText(value) + ",\n";
    header.erase(header.size() - 2, 1); // the last field's comma
    header += "}";
    header.append((kAlignment - (header.size() + 1) % kAlignment) % kAlignment, ' ');
    header += "\n";
    return header;
}

std::string preamble(uint64_t headerBytes) {
    std::string bytes(kProbeVolumeMagic);
    for (int i = 0; i < 8; ++i)
        bytes.push_back(char((headerBytes >> (8 * i)) & 0xffu));
    return bytes;
}

// Collects small pieces into large writes: one write call per probe would be millions of calls.
class BufferedOutput {
  public:
    explicit BufferedOutput(OutputFile& file) : file_(file) {}
    void append(const void* data, size_t bytes) {
        buffer_.append(static_cast<const char*>(data), bytes);
        if (buffer_.size() >= kFlushBytes) flush();
    }
    void flush() {
        file_.write(buffer_);
        buffer_.clear();
    }

  private:
    static constexpr size_t kFlushBytes = size_t(1) << 20;
    OutputFile& file_;
    std::string buffer_;
};

// `perProbe` values a probe, zeros for an invalid one.
void writePerProbe(BufferedOutput& out, const ProbeVolume& volume, const std::vector<glm::vec3>& coefficients,
                   size_t perProbe) {
    if (coefficients.empty()) return;
    const std::vector<glm::vec3> zeros(perProbe, glm::vec3(0.0f));
    for (uint32_t p = 0; p < volume.probeCount(); ++p)
        out.append(volume.valid[p] ? &coefficients[p * perProbe] : zeros.data(),
                   perProbe * sizeof(glm::vec3));
}

// ---- Reading -----------------------------------------------------------------------------------

// Where a volume's bytes come from: a file, read piece by piece so that a large volume is not held
// in memory twice, or memory. read() fills `count` bytes at `offset`, within [0, size).
struct VolumeBytes {
    uint64_t size = 0;
    std::function<void(uint64_t offset, char* out, size_t count)> read;
};

// What the header says, before the payload is read.
struct VolumeHeader {
    ProbeVolume volume; // coefficients and validity not allocated yet
    bool radiance = false;
    bool irradiance = false;
    bool offsets = false;  // capture_offsets
    bool transfer = false; // static radiance and transfer
};

int64_t requireInteger(const json& value, const std::string& field, int64_t low, int64_t high,
                       const std::string& name) {
    // Unsigned values past INT64_MAX would wrap to negative numbers in get<int64_t>.
    bool fits =
        value.is_number_integer() && !(value.is_number_unsigned() && value.get<uint64_t>() > INT64_MAX);
    if (!fits || value.get<int64_t>() < low || value.get<int64_t>() > high)
        fail(name,
             "field \"" + field + "\" must be " +
                 (low == high ? std::to_string(low)
                              : "an integer from " + std::to_string(low) + " to " + std::to_string(high)));
    return value.get<int64_t>();
}

const json& requireObject(const json& object, const char* field, const std::string& name) {
    const json& value = requireField(object, field, name);
    if (!value.is_object()) fail(name, std::string("field \"") + field + "\" must be an object");
    return value;
}

const json& requireTriple(const json& object, const char* field, const std::string& where,
                          const std::string& name) {
    const json& value = requireField(object, field, name);
    if (!value.is_array() || value.size() != 3)
        fail(name, "field \"" + where + field + "\" must be an array of 3 numbers");
    return value;
}

glm::dvec3 requireVector(const json& object, const char* field, const std::string& name) {
    const json& value = requireTriple(object, field, "grid.", name);
    glm::dvec3 v;
    for (int a = 0; a < 3; ++a) {
        if (!value[a].is_number())
            fail(name, std::string("field \"grid.") + field + "\" must be an array of 3 numbers");
        v[a] = value[a].get<double>();
    }
    return v;
}

ProbeGrid parseGrid(const json& root, const std::string& name) {
    const json& grid = requireObject(root, "grid", name);
    const json& counts = requireTriple(grid, "counts", "grid.", name);
    ProbeGrid result;
    for (int a = 0; a < 3; ++a)
        result.counts[a] = int(
            requireInteger(counts[a], std::string("grid.counts[") + kAxes[a] + "]", 1, kMaxGridProbes, name));
    result.boundsMin = requireVector(grid, "bounds_min", name);
    result.boundsMax = requireVector(grid, "bounds_max", name);
    checkProbeGrid(result, name);
    return result;
}

// ["radiance"], ["irradiance"] or ["radiance", "irradiance"]: the payload's sections in order.
void parseQuantities(const json& root, VolumeHeader& header, const std::string& name) {
    const json& quantities = requireField(root, "quantities", name);
    if (quantities == json::array({"radiance"}) || quantities == json::array({"irradiance"}) ||
        quantities == json::array({"radiance", "irradiance"})) {
        header.radiance = quantities[0] == "radiance";
        header.irradiance = quantities.back() == "irradiance";
        return;
    }
    fail(name,
         "field \"quantities\" must be [\"radiance\"], [\"irradiance\"] or [\"radiance\", \"irradiance\"]");
}

void parseProbeRange(const json& root, ProbeVolume& volume, const std::string& name) {
    const json& probes = requireObject(root, "probes", name);
    const int64_t total = volume.grid.probeCount();
    volume.begin =
        uint32_t(requireInteger(requireField(probes, "begin", name), "probes.begin", 0, total - 1, name));
    volume.end = uint32_t(requireInteger(requireField(probes, "end", name), "probes.end",
                                         int64_t(volume.begin) + 1, total, name));
}

json parseJson(std::string_view header, const std::string& name) {
    // The JSON reader would take a NUL byte for the end of the text and ignore what follows.
    if (size_t nul = header.find('\0'); nul != std::string_view::npos)
        fail(name, "the header is not valid JSON (a NUL byte at offset " + text(kPreambleBytes + nul) + ")");
    try {
        return parseBoundedJson(header, kMaxJsonDepth);
    } catch (const json::exception& error) {
        fail(name, "the header is not valid JSON (" + jsonProblem(error) + ")");
    } catch (const JsonTooDeep&) {
        fail(name, "the header nests JSON deeper than " + text(kMaxJsonDepth) + " levels");
    }
}

VolumeHeader parseHeader(std::string_view headerText, const std::string& name) {
    json root = parseJson(headerText, name);
    if (!root.is_object()) fail(name, "the header must be a JSON object");
    if (requireString(root, "format", name) != kFormat)
        fail(name, std::string("field \"format\" must be \"") + kFormat + "\"");
    requireInteger(requireField(root, "version", name), "version", kVersion, kVersion, name);
    if (requireString(root, "convention", name) != kConventionName)
        fail(name, std::string("field \"convention\" must be \"") + kConventionName + "\"");
    VolumeHeader header;
    ProbeVolume& volume = header.volume;
    volume.order = int(requireInteger(requireField(root, "order", name), "order", 1, kMaxOrder, name));
    const int count = coefficientCount(volume.order);
    requireInteger(requireField(root, "coefficient_count", name), "coefficient_count", count, count, name);
    parseQuantities(root, header, name);
    volume.grid = parseGrid(root, name);
    parseProbeRange(root, volume, name);
    if (root.contains("visibility"))
        volume.visibilitySize =
            int(requireInteger(root["visibility"], "visibility", 1, kMaxVisibilitySize, name));
    if (root.contains("capture_offsets")) {
        if (!root["capture_offsets"].is_boolean())
            fail(name, "field \"capture_offsets\" must be true or false");
        header.offsets = root["capture_offsets"].get<bool>();
    }
    if (root.contains("transfer")) {
        if (!root["transfer"].is_boolean()) fail(name, "field \"transfer\" must be true or false");
        header.transfer = root["transfer"].get<bool>();
    }
    volume.bounces = int(requireInteger(requireField(root, "bounces", name), "bounces", 0, INT_MAX, name));
    volume.source = requireString(root, "source", name);
    if (root.contains("source_hash")) volume.sourceHash = requireString(root, "source_hash", name);
    if (root.contains("sky_source")) volume.skySource = requireString(root, "sky_source", name);
    volume.settings = requireObject(root, "settings", name).dump();
    return header;
}

uint64_t readPreamble(const VolumeBytes& bytes, const std::string& name) {
    if (bytes.size < kPreambleBytes)
        fail(name, "truncated: " + text(bytes.size) + " bytes, fewer than the " + text(kPreambleBytes) +
                       " of a probe volume's preamble");
    char start[kPreambleBytes];
    bytes.read(0, start, sizeof(start));
    if (!std::string_view(start, sizeof(start)).starts_with(kProbeVolumeMagic))
        fail(name, "not a probe volume (it does not start with \"SHPROBEV\")");
    uint64_t headerBytes = 0;
    for (int i = 0; i < 8; ++i)
        headerBytes |= uint64_t(uint8_t(start[8 + i])) << (8 * i);
    if (headerBytes < kAlignment || headerBytes > kMaxHeaderBytes)
        fail(name, "the header length " + text(headerBytes) + " is outside " + text(kAlignment) + ".." +
                       text(kMaxHeaderBytes));
    if (headerBytes % kAlignment != 0)
        fail(name, "the header length " + text(headerBytes) + " is not a multiple of " + text(kAlignment));
    if (headerBytes > bytes.size - kPreambleBytes)
        fail(name, "truncated: the header ends at byte " + text(kPreambleBytes + headerBytes) +
                       ", past the file's end at " + text(bytes.size));
    return headerBytes;
}

uint64_t payloadBytes(const VolumeHeader& header) {
    const uint64_t floats = uint64_t(coefficientCount(header.volume.order)) * 3 * sizeof(float);
    const uint64_t visibility =
        uint64_t(header.volume.visibilitySize) * header.volume.visibilitySize * 2 * sizeof(float);
    const uint64_t offsets = header.offsets ? 3 * sizeof(float) : 0;
    const uint64_t transfer =
        header.transfer ? floats * (1 + uint64_t(coefficientCount(header.volume.order))) : 0;
    return uint64_t(header.volume.probeCount()) *
           ((int(header.radiance) + int(header.irradiance)) * floats + visibility + offsets + transfer + 1);
}

template <class T>
void readSection(const VolumeBytes& bytes, uint64_t& offset, std::vector<T>& out, size_t count) {
    out.resize(count);
    if (count == 0) return; // an absent section: no bytes, and no buffer to copy them to
    bytes.read(offset, reinterpret_cast<char*>(out.data()), count * sizeof(T));
    offset += count * sizeof(T);
}

ProbeVolume parseVolume(const VolumeBytes& bytes, const std::string& name) {
    const uint64_t headerBytes = readPreamble(bytes, name);
    std::string headerText(headerBytes, '\0');
    bytes.read(kPreambleBytes, headerText.data(), headerText.size());
    VolumeHeader header = parseHeader(headerText, name);

    // The header's claims are held against the file's size before anything is allocated for them.
    uint64_t offset = kPreambleBytes + headerBytes;
    const uint64_t expected = offset + payloadBytes(header);
    if (bytes.size < expected)
        fail(name, "truncated: the header describes " + text(expected) + " bytes, the file has " +
                       text(bytes.size));
    if (bytes.size > expected)
        fail(name, text(bytes.size) + " bytes, more than the " + text(expected) + " its header describes");

    ProbeVolume& volume = header.volume;
    const size_t coefficients = size_t(volume.probeCount()) * coefficientsPerProbe(volume);
    if (header.radiance) readSection(bytes, offset, volume.radiance, coefficients);
    if (header.irradiance) readSection(bytes, offset, volume.irradiance, coefficients);
    readSection(bytes, offset, volume.visibility, visibilityTexels(volume));
    readSection(bytes, offset, volume.offsets, header.offsets ? volume.probeCount() : 0);
    readSection(bytes, offset, volume.staticRadiance, header.transfer ? coefficients : 0);
    readSection(bytes, offset, volume.transfer,
                header.transfer ? coefficients * coefficientsPerProbe(volume) : 0);
    readSection(bytes, offset, volume.valid, volume.probeCount());
    checkValidity(volume, name);
    checkVisibility(volume, name);
    checkOffsets(volume, name);
    // Invalid probes are written as zeros: a non-finite value there is damage as anywhere else.
    const size_t perProbe = coefficientsPerProbe(volume);
    const std::pair<const std::vector<glm::vec3>*, const char*> sections[] = {
        {&volume.radiance, "radiance"},
        {&volume.irradiance, "irradiance"},
        {&volume.staticRadiance, "static radiance"},
        {&volume.transfer, "transfer"}};
    for (const auto& [values, section] : sections) {
        const size_t valuesPerProbe = values == &volume.transfer ? perProbe * perProbe : perProbe;
        for (size_t i = 0; i < values->size(); ++i)
            if (!isFinite((*values)[i]))
                fail(name, std::string("the ") + section + " of probe " +
                               text(volume.begin + i / valuesPerProbe) + " is not finite");
    }
    return std::move(header.volume);
}

// Closes the descriptor on every way out.
struct Descriptor {
    int fd = -1;
    ~Descriptor() {
        if (fd >= 0) close(fd);
    }
};

void readAt(int fd, const std::string& path, uint64_t offset, char* out, size_t count) {
    while (count > 0) {
        ssize_t got = pread(fd, out, std::min(count, size_t(1) << 30), off_t(offset));
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) throwInputError(path, errno);
        if (got == 0) fail(path, "the file became shorter while it was read");
        out += got;
        offset += uint64_t(got);
        count -= size_t(got);
    }
}

// ---- Merging -----------------------------------------------------------------------------------

std::string countsText(const glm::ivec3& counts) {
    return std::to_string(counts.x) + "x" + std::to_string(counts.y) + "x" + std::to_string(counts.z);
}

std::string boundsText(const ProbeGrid& grid) {
    return vectorJson(grid.boundsMin).dump() + ".." + vectorJson(grid.boundsMax).dump();
}

// "X in A, Y in B": two bakes' values of one thing.
std::string inEach(const std::string& x, const std::string& y, const std::string& nameA,
                   const std::string& nameB) {
    return x + " in " + nameA + ", " + y + " in " + nameB;
}

std::string hashText(const ProbeVolume& volume) {
    return volume.sourceHash.empty() ? "no source hash" : clipped(volume.sourceHash);
}

// What differs between two bricks' bakes, in words; empty when they are of one bake.
std::string bakeDifference(const ProbeVolume& a, const ProbeVolume& b, const std::string& nameA,
                           const std::string& nameB) {
    auto both = [&](const std::string& x, const std::string& y) { return inEach(x, y, nameA, nameB); };
    if (const std::string grid = gridDifference(a.grid, b.grid, nameA, nameB); !grid.empty()) return grid;
    if (a.order != b.order) return "order " + both(std::to_string(a.order), std::to_string(b.order));
    if (quantitiesText(a) != quantitiesText(b)) return both(quantitiesText(a), quantitiesText(b));
    if (a.visibilitySize != b.visibilitySize)
        return "visibility maps " + both(std::to_string(a.visibilitySize), std::to_string(b.visibilitySize));
    if (a.offsets.empty() != b.offsets.empty())
        return "capture offsets " +
               both(a.offsets.empty() ? "absent" : "present", b.offsets.empty() ? "absent" : "present");
    if (a.transfer.empty() != b.transfer.empty())
        return "transfer " +
               both(a.transfer.empty() ? "absent" : "present", b.transfer.empty() ? "absent" : "present");
    if (a.bounces != b.bounces)
        return "bounces " + both(std::to_string(a.bounces), std::to_string(b.bounces));
    // One scene under two paths (bricks baked on several machines) is one source: the hashes say.
    if (a.sourceHash != b.sourceHash)
        return "source " + both(jsonText(a.source) + " (" + hashText(a) + ")",
                                jsonText(b.source) + " (" + hashText(b) + ")");
    if (a.sourceHash.empty() && a.source != b.source)
        return "source " + both(jsonText(a.source), jsonText(b.source));
    if (std::string sky = skyDifference({a.settings, a.skySource}, {b.settings, b.skySource}, nameA, nameB);
        !sky.empty())
        return sky;
    return settingsDifference(a.settings, b.settings, nameA, nameB);
}

// Bricks sorted by their first probe must follow each other without a gap or an overlap, from
// probe 0 to the grid's last.
void checkCoverage(std::span<const ProbeVolume> bricks, const std::vector<size_t>& sorted,
                   const std::function<std::string(size_t)>& nameOf) {
    uint32_t next = 0; // the first probe not covered yet
    for (size_t n = 0; n < sorted.size(); ++n) {
        const ProbeVolume& brick = bricks[sorted[n]];
        if (brick.begin > next) throw Error(ErrorKind::Input, missingProbes(next, brick.begin));
        if (brick.begin < next) {
            const size_t previous = sorted[n - 1];
            fail("merge", nameOf(previous) + " (" + probeSpan(bricks[previous].begin, bricks[previous].end) +
                              ") and " + nameOf(sorted[n]) + " (" + probeSpan(brick.begin, brick.end) +
                              ") overlap");
        }
        next = brick.end;
    }
    if (next < bricks[0].grid.probeCount())
        throw Error(ErrorKind::Input, missingProbes(next, bricks[0].grid.probeCount()));
}

void append(std::vector<glm::vec3>& to, const std::vector<glm::vec3>& from) {
    to.insert(to.end(), from.begin(), from.end());
}

} // namespace

std::string nonFiniteLight(const ProbeVolume& volume) {
    if (std::string probe = nonFiniteProbe(volume, volume.radiance, "radiance"); !probe.empty()) return probe;
    return nonFiniteProbe(volume, volume.irradiance, "irradiance");
}

std::string gridDifference(const ProbeGrid& a, const ProbeGrid& b, const std::string& nameA,
                           const std::string& nameB) {
    auto both = [&](const std::string& x, const std::string& y) { return inEach(x, y, nameA, nameB); };
    if (a.counts != b.counts) return "grid " + both(countsText(a.counts), countsText(b.counts));
    if (a.boundsMin != b.boundsMin || a.boundsMax != b.boundsMax)
        return "bounds " + both(boundsText(a), boundsText(b));
    return "";
}

std::string settingsDifference(const std::string& a, const std::string& b, const std::string& nameA,
                               const std::string& nameB) {
    const std::optional<json> firstObject = settingsObject(a), secondObject = settingsObject(b);
    if (!firstObject || !secondObject) return "settings that are not both JSON objects";
    auto valueIn = [](const json& settings, const std::string& key) -> std::optional<json> {
        auto it = settings.find(key);
        return it == settings.end() ? std::nullopt : std::optional<json>(*it);
    };
    auto shown = [](const std::optional<json>& value) {
        return value ? clipped(value->dump()) : std::string("missing");
    };
    json keys = *firstObject;
    keys.update(*secondObject);
    for (const auto& [key, unused] : keys.items()) {
        const std::optional<json> first = valueIn(*firstObject, key), second = valueIn(*secondObject, key);
        if (first != second)
            return "setting " + quotedInput(key) + " is " + inEach(shown(first), shown(second), nameA, nameB);
    }
    return "";
}

std::string skyDifference(const BakeSky& a, const BakeSky& b, const std::string& nameA,
                          const std::string& nameB) {
    const std::optional<json> first = settingsObject(a.settings), second = settingsObject(b.settings);
    if (!first || !second) return "";
    const json skyA = first->value("sky", json()), skyB = second->value("sky", json());
    if (skyA == skyB) return "";
    auto shown = [](const BakeSky& sky, const json& identity) {
        const std::string named = identity.is_string() ? clipped(identity.get<std::string>())
                                  : identity.is_null() ? "no sky setting"
                                                       : clipped(identity.dump());
        return sky.source.empty() ? named : jsonText(sky.source) + " (" + named + ")";
    };
    return "sky " + inEach(shown(a, skyA), shown(b, skyB), nameA, nameB);
}

void checkProbeGrid(const ProbeGrid& grid, const std::string& what) {
    uint64_t total = 1;
    for (int a = 0; a < 3; ++a) {
        if (grid.counts[a] < 1)
            fail(what, std::string("the grid's count along ") + kAxes[a] + " must be at least 1, not " +
                           std::to_string(grid.counts[a]));
        total *= uint64_t(grid.counts[a]); // each count fits 32 bits, so no step overflows 64
        if (total > kMaxGridProbes)
            fail(what, "the grid " + countsText(grid.counts) + " has more than " + text(kMaxGridProbes) +
                           " probes");
    }
    for (int a = 0; a < 3; ++a) {
        const double low = grid.boundsMin[a], high = grid.boundsMax[a];
        if (!std::isfinite(low) || !std::isfinite(high))
            fail(what, std::string("the grid's bounds along ") + kAxes[a] + " are not finite");
        if (!std::isfinite(high - low)) // positions and sampling divide by it
            fail(what, std::string("the grid's extent along ") + kAxes[a] + " is not finite");
        if (low > high)
            fail(what, std::string("the grid's bounds are inverted along ") + kAxes[a] + " (" +
                           json(low).dump() + " > " + json(high).dump() + ")");
        if (low == high && grid.counts[a] > 1)
            fail(what, std::string("the grid's bounds are flat along ") + kAxes[a] + " (at " +
                           json(low).dump() + ") but it has " + std::to_string(grid.counts[a]) +
                           " probes along " + kAxes[a]);
    }
}

std::string sceneMismatch(const ProbeVolume& volume, const std::string& hash,
                          const std::string& description) {
    if (!volume.sourceHash.empty()) {
        if (volume.sourceHash == hash) return "";
        return "baked in " + volume.source + " (" + clipped(volume.sourceHash) + "), not in " + description +
               " (" + hash +
               "): the scene's files (the glTF file, its buffers and images) are not those the volume was "
               "baked from; bake it again from this scene";
    }
    if (volume.source == description) return "";
    return "baked in " + volume.source + ", not " + description +
           " (the volume holds no source hash, so the scene is known by its description, path and all)";
}

void writeProbeVolume(const std::string& path, const ProbeVolume& volume) {
    checkVolume(volume, "cannot write " + path);
    const std::string header = headerText(volume);
    OutputFile file(path, OutputContent::Binary);
    BufferedOutput out(file);
    const std::string start = preamble(header.size());
    out.append(start.data(), start.size());
    out.append(header.data(), header.size());
    const size_t perProbe = coefficientsPerProbe(volume);
    writePerProbe(out, volume, volume.radiance, perProbe);
    writePerProbe(out, volume, volume.irradiance, perProbe);
    out.append(volume.visibility.data(), volume.visibility.size() * sizeof(glm::vec2));
    out.append(volume.offsets.data(), volume.offsets.size() * sizeof(glm::vec3));
    writePerProbe(out, volume, volume.staticRadiance, perProbe);
    writePerProbe(out, volume, volume.transfer, perProbe * perProbe);
    out.append(volume.valid.data(), volume.valid.size());
    out.flush();
    file.commit();
}

ProbeVolume parseProbeVolume(std::string_view bytes, const std::string& name) {
    return parseVolume(
        {bytes.size(), [bytes](uint64_t offset, char* out,
                               size_t count) { std::memcpy(out, bytes.data() + offset, count); }},
        name);
}

ProbeVolume readProbeVolume(const std::string& path) {
    checkInputFile(path, "a probe volume"); // the project's words for a missing file, a folder, an empty file
    Descriptor file{open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY)};
    if (file.fd < 0) throwInputError(path, errno);
    struct stat status {};
    if (fstat(file.fd, &status) != 0) throwInputError(path, errno);
    if (!S_ISREG(status.st_mode)) fail(path, "not a regular file");
    return parseVolume(
        {uint64_t(status.st_size),
         [&](uint64_t offset, char* out, size_t count) { readAt(file.fd, path, offset, out, count); }},
        path);
}

ProbeVolume mergeProbeVolumes(std::span<const ProbeVolume> bricks, std::span<const std::string> names) {
    if (bricks.empty()) fail("merge", "no bricks to merge");
    if (!names.empty() && names.size() != bricks.size())
        fail("merge", counted(names.size(), "name") + " for " + counted(bricks.size(), "brick"));
    auto nameOf = [&](size_t i) { return names.empty() ? "brick " + text(i + 1) : names[i]; };
    for (size_t i = 0; i < bricks.size(); ++i) {
        checkVolume(bricks[i], nameOf(i));
        if (std::string difference = bakeDifference(bricks[0], bricks[i], nameOf(0), nameOf(i));
            !difference.empty())
            fail("merge", nameOf(0) + " and " + nameOf(i) + " are not bricks of one bake: " + difference);
    }
    std::vector<size_t> sorted(bricks.size());
    std::iota(sorted.begin(), sorted.end(), size_t(0));
    // Stable: of two bricks starting at one probe, the message names them in the order given.
    std::stable_sort(sorted.begin(), sorted.end(),
                     [&](size_t a, size_t b) { return bricks[a].begin < bricks[b].begin; });
    checkCoverage(bricks, sorted, nameOf);

    // The brick of probe 0 names the source, so that the bricks' order does not change the file.
    const ProbeVolume& first = bricks[sorted[0]];
    ProbeVolume whole{.grid = first.grid,
                      .order = first.order,
                      .begin = 0,
                      .end = first.grid.probeCount(),
                      .visibilitySize = first.visibilitySize,
                      .bounces = first.bounces,
                      .source = first.source,
                      .sourceHash = first.sourceHash,
                      .skySource = first.skySource,
                      .settings = first.settings};
    for (size_t i : sorted) {
        append(whole.radiance, bricks[i].radiance);
        append(whole.irradiance, bricks[i].irradiance);
        whole.visibility.insert(whole.visibility.end(), bricks[i].visibility.begin(),
                                bricks[i].visibility.end());
        append(whole.offsets, bricks[i].offsets);
        append(whole.staticRadiance, bricks[i].staticRadiance);
        append(whole.transfer, bricks[i].transfer);
        whole.valid.insert(whole.valid.end(), bricks[i].valid.begin(), bricks[i].valid.end());
    }
    return whole;
}

} // namespace shprobe
