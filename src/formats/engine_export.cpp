// The table of output formats and the engine formats' coefficients and files. Each engine's frame,
// basis sign and scaling is taken from the engine function named beside it (docs/exports.md has
// the derivations); the formulas are transcribed, no engine code is copied.
#include "formats/engine_export.h"

#include "image/image_write.h"
#include "image/specular_prefilter.h"

#include "common/error.h"
#include "common/file_extension.h"
#include "formats/json_reading.h"
#include "formats/probe_export.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/folding.h"
#include "sh/irradiance.h"
#include "sh/rotation.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <vector>

namespace shprobe {

namespace {

constexpr int kEngineOrder = 3; // every engine format holds bands 0..2

// ---- Frames ----------------------------------------------------------------------------------

glm::dmat3 fromRows(std::array<double, 9> rows) {
    glm::dmat3 m(0.0);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            m[c][r] = rows[size_t(3 * r + c)];
    return m;
}

// ---- Coefficients ----------------------------------------------------------------------------

// What an engine's nine values are, before its frame and basis sign.
enum class EngineQuantity {
    Radiance,               // L_lm
    Irradiance,             // E_lm = A_l L_lm
    IrradianceOverPi,       // E_lm / pi
    FoldedIrradianceOverPi, // k_i A_l L_lm / pi: sum c_i p_i(n) = E(n) / pi, y_20 not split
};

struct EngineConvention {
    EngineQuantity quantity;
    bool condonShortley; // false: the engine's y_lm is ours times (-1)^m
};

EngineConvention conventionOf(Engine engine) {
    switch (engine) {
    case Engine::ThreeJs: // SphericalHarmonics3.getBasisAt: 0.488603 y, ... (no phase)
        return {EngineQuantity::Radiance, false};
    case Engine::Babylon: // sphericalPolynomial.ts SH3ylmBasisConstants: -sqrt(3/4pi) y, ...
        return {EngineQuantity::IrradianceOverPi, true};
    case Engine::Gltf: // glTF loader EXT_lights_image_based.ts: FromArray, then / pi
        return {EngineQuantity::Irradiance, true};
    case Engine::Filament: // CubemapSH::preprocessSHForShader
    case Engine::Unity:    // UnityCG.cginc SHEvalLinearL0L1 / SHEvalLinearL2 on the stored values
        return {EngineQuantity::FoldedIrradianceOverPi, true};
    case Engine::Godot: // scene_forward_clustered.glsl lightmap capture: 2 c2 sh[1] y, ... (no phase)
        return {EngineQuantity::Radiance, false};
    }
    return {EngineQuantity::Radiance, true};
}

// Bands 0..2 of the probe's radiance, missing bands 0.
ShCoefficients radianceBands(const ShCoefficients& probe) {
    const int kept = std::min(probe.order, kEngineOrder);
    std::optional<ShCoefficients> radiance = radianceOf(probe, kept); // A_l != 0 for l <= 2
    ShCoefficients bands = makeCoefficients(kEngineOrder, Quantity::Radiance);
    std::copy(radiance->rgb.begin(), radiance->rgb.end(), bands.rgb.begin());
    return bands;
}

double quantityScale(EngineQuantity quantity, int index) {
    const double a = irradianceBandFactor(shBand(index));
    switch (quantity) {
    case EngineQuantity::Radiance:
        return 1.0;
    case EngineQuantity::Irradiance:
        return a;
    case EngineQuantity::IrradianceOverPi:
        return a / std::numbers::pi;
    case EngineQuantity::FoldedIrradianceOverPi:
        return basisPolynomialScale(index) * a / std::numbers::pi;
    }
    return 1.0;
}

// (-1)^m: our basis has the Condon-Shortley phase, an engine without it flips odd m.
double phaseSign(int index) {
    const int l = shBand(index);
    return (index - l * (l + 1)) % 2 == 0 ? 1.0 : -1.0;
}

// ---- Text ------------------------------------------------------------------------------------

// The shortest decimal that reads back to the same double.
std::string number(double value) {
    char text[32];
    std::to_chars_result result = std::to_chars(text, text + sizeof text, value);
    return std::string(text, result.ptr);
}

std::string rgbArray(const glm::dvec3& c) {
    return "[" + number(c.r) + ", " + number(c.g) + ", " + number(c.b) + "]";
}

// [[r, g, b], ...] one row a line, indented.
std::string rowsArray(const EngineCoefficients& c, const std::string& indent) {
    std::string text = "[\n";
    for (size_t i = 0; i < c.size(); ++i)
        text += indent + "  " + rgbArray(c[i]) + (i + 1 < c.size() ? ",\n" : "\n");
    return text + indent + "]";
}

// A name-based UUID (version 8 layout) from the text's FNV-1a hashes: the same probe gives the
// same file.
std::string uuidOf(const std::string& text) {
    uint64_t h1 = 1469598103934665603ull, h2 = 1099511628211ull * 31;
    for (unsigned char c : text) {
        h1 = (h1 ^ c) * 1099511628211ull;
        h2 = (h2 ^ c) * 1099511628211ull + 7;
    }
    char out[40];
    std::snprintf(out, sizeof out, "%08x-%04x-8%03x-%04x-%012llx", unsigned(h1 >> 32),
                  unsigned(h1 >> 16) & 0xffff, unsigned(h1) & 0xfff, unsigned(0x8000 | (h2 >> 48 & 0x3fff)),
                  static_cast<unsigned long long>(h2 & 0xffffffffffffull));
    return out;
}

// three.js: the object LightProbe.toJSON writes (Object3D.toJSON + Light.toJSON + data.object.sh
// = sh.toArray(): coefficient after coefficient, r g b), as ObjectLoader.parseObject reads it
// (case 'LightProbe': new SphericalHarmonics3().fromArray(data.sh), data.intensity).
std::string threeJsText(const EngineCoefficients& c) {
    std::string sh;
    for (size_t i = 0; i < c.size(); ++i)
        sh += (i ? ", " : "") + number(c[i].r) + ", " + number(c[i].g) + ", " + number(c[i].b);
    return "{\n"
           "  \"metadata\": {\"version\": 4.6, \"type\": \"Object\", \"generator\": \"shprobe\"},\n"
           "  \"object\": {\n"
           "    \"uuid\": \"" +
           uuidOf(sh) +
           "\",\n"
           "    \"type\": \"LightProbe\",\n"
           "    \"name\": \"shprobe\",\n"
           "    \"layers\": 1,\n"
           "    \"matrix\": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],\n"
           "    \"up\": [0, 1, 0],\n"
           "    \"color\": 16777215,\n"
           "    \"intensity\": 1,\n"
           "    \"sh\": [" +
           sh +
           "]\n"
           "  }\n"
           "}\n";
}

// Filament: the lines `cmgen --sh-shader` writes to sh.txt, "(r, g, b); // Llm, ...".
std::string filamentText(const EngineCoefficients& c) {
    std::string text;
    for (int i = 0; i < int(c.size()); ++i) {
        const int l = shBand(i);
        text += "(" + number(c[size_t(i)].r) + ", " + number(c[size_t(i)].g) + ", " + number(c[size_t(i)].b) +
                "); // L" + std::to_string(l) + std::to_string(i - l * (l + 1)) +
                ", irradiance, pre-scaled base\n";
    }
    return text;
}

// Unity: SphericalHarmonicsL2's 27 floats channel-major (sh[channel, coefficient] at
// 9 channel + coefficient), under "coefficients" so that JsonUtility reads it into a float[].
std::string unityText(const EngineCoefficients& c) {
    std::string values;
    for (int channel = 0; channel < 3; ++channel)
        for (size_t i = 0; i < c.size(); ++i)
            values += std::string(channel || i ? ", " : "") + number(c[i][channel]);
    return "{\n  \"type\": \"UnityEngine.Rendering.SphericalHarmonicsL2\",\n"
           "  \"layout\": \"channel-major: sh[channel, i] = coefficients[9 * channel + i]\",\n"
           "  \"coefficients\": [" +
           values + "]\n}\n";
}

// ---- glTF --------------------------------------------------------------------------------------

// RGBD as EXT_lights_image_based's PNGs hold HDR (Babylon's toRGBD in helperFunctions.fx):
// D = floor(max(255 / max(rgb), 1)) / 255, rgb' = (rgb D)^(1/2.2), alpha D. Values above 255 clip
// (D cannot fall below 1/255); a non-finite value is taken as the largest float (NaN as 0).
std::array<uint8_t, 4> rgbd(glm::dvec3 color) {
    for (int c = 0; c < 3; ++c)
        color[c] = std::isnan(color[c]) ? 0.0 : std::min(color[c], double(std::numeric_limits<float>::max()));
    const double maxRgb = std::max({color.r, color.g, color.b, 1e-6});
    const double d = std::clamp(std::floor(std::max(255.0 / maxRgb, 1.0)) / 255.0, 0.0, 1.0);
    auto byte = [](double v) { return uint8_t(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); };
    auto gamma = [&](double v) { return byte(std::pow(std::max(v * d, 0.0), 1.0 / 2.2)); };
    return {gamma(color.r), gamma(color.g), gamma(color.b), byte(d)};
}

std::string base64(std::string_view bytes) {
    static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < bytes.size(); i += 3) {
        uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
        if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
        if (i + 2 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 2]));
        out += digits[v >> 18 & 63];
        out += digits[v >> 12 & 63];
        out += i + 1 < bytes.size() ? digits[v >> 6 & 63] : '=';
        out += i + 2 < bytes.size() ? digits[v & 63] : '=';
    }
    return out;
}

// The probe's radiance at its order; an irradiance probe whose odd bands past 1 were lost (A_l = 0)
// gives bands 0..2.
ShCoefficients probeRadiance(const ShCoefficients& probe) {
    if (std::optional<ShCoefficients> radiance = radianceOf(probe, probe.order)) return *radiance;
    return *radianceOf(probe, std::min(probe.order, kEngineOrder));
}

// The specular chain and the words for asset.extras: prefiltered from the source the caller gave,
// else from the probe's own band-limited radiance.
std::vector<Cubemap> specularChain(const ShCoefficients& probe, const ExportOptions& options,
                                   std::string& what) {
    const int size = options.mapSize > 0 ? options.mapSize : kDefaultSpecularSize;
    const int mips = specularMipCount(size);
    std::string source;
    std::vector<Cubemap> chain;
    if (options.specular.radiance) {
        source = "the environment's radiance, " + options.specular.what;
        chain = prefilterSpecular(*options.specular.radiance, size);
    } else {
        const ShCoefficients radiance = probeRadiance(probe);
        source = "the probe's radiance from its order-" + std::to_string(radiance.order) +
                 " coefficients (band-limited, negatives clamped to 0)";
        chain = prefilterSpecular(radianceCubemap(radiance, size), size);
    }
    what = "GGX-prefiltered (split sum, n = v = R) from " + source + ": " + std::to_string(mips) +
           " mips, faces " + std::to_string(size) + " down to " + std::to_string(kSmallestSpecularMip) +
           ", mip i at roughness i/" + std::to_string(mips - 1) + " (GGX alpha = roughness^2)";
    return chain;
}

// One face of a mip (face orientation of docs/conventions.md) as an RGBD PNG, flipped about its
// vertical axis as the extension asks of every face image.
std::string specularFacePng(const Cubemap& mip, int face) {
    const int n = mip.faceSize;
    std::vector<uint8_t> rgba;
    rgba.reserve(size_t(4) * size_t(n) * size_t(n));
    for (int j = 0; j < n; ++j)
        for (int i = n - 1; i >= 0; --i)
            for (uint8_t b : rgbd(glm::dvec3(glm::vec3(mip.at(face, i, j)))))
                rgba.push_back(b);
    return encodeRgba8("png", n, n, rgba);
}

// A glTF 2.0 asset holding one EXT_lights_image_based light, referenced by the scene: its
// irradiance coefficients and its specular chain, mip after mip, six RGBD PNGs each.
std::string gltfText(const ShCoefficients& probe, const EngineCoefficients& c, const ExportOptions& options) {
    std::string what;
    const std::vector<Cubemap> chain = specularChain(probe, options, what);
    std::string images, mips;
    for (size_t mip = 0; mip < chain.size(); ++mip) {
        std::string faces;
        for (int face = 0; face < kFaceCount; ++face) {
            images += std::string(mip || face ? ",\n" : "") +
                      "    {\"mimeType\": \"image/png\", \"uri\": \"data:image/png;base64," +
                      base64(specularFacePng(chain[mip], face)) + "\"}";
            faces += (face ? ", " : "") + std::to_string(int(mip) * kFaceCount + face);
        }
        mips += std::string(mip ? ",\n" : "\n") + "          [" + faces + "]";
    }
    return "{\n"
           "  \"asset\": {\"version\": \"2.0\", \"generator\": \"shprobe\", \"extras\": {\"source\": " +
           jsonText(options.metadata.source) + ", \"specularImages\": " + jsonText(what) +
           "}},\n"
           "  \"extensionsUsed\": [\"EXT_lights_image_based\"],\n"
           "  \"extensions\": {\n"
           "    \"EXT_lights_image_based\": {\n"
           "      \"lights\": [{\n"
           "        \"name\": \"shprobe\",\n"
           "        \"rotation\": [0, 0, 0, 1],\n"
           "        \"intensity\": 1,\n"
           "        \"irradianceCoefficients\": " +
           rowsArray(c, "        ") +
           ",\n"
           "        \"specularImageSize\": " +
           std::to_string(chain[0].faceSize) +
           ",\n"
           "        \"specularImages\": [" +
           mips +
           "\n        ]\n"
           "      }]\n"
           "    }\n"
           "  },\n"
           "  \"images\": [\n" +
           images +
           "\n  ],\n"
           "  \"scene\": 0,\n"
           "  \"scenes\": [{\"extensions\": {\"EXT_lights_image_based\": {\"light\": 0}}}]\n"
           "}\n";
}

// ---- Numbers the writers write -----------------------------------------------------------------

// The coefficients as they are (json, binary).
std::vector<WrittenNumber> coefficientNumbers(const ShCoefficients& probe, const ExportOptions&) {
    std::vector<WrittenNumber> numbers;
    for (int i = 0; i < int(probe.rgb.size()); ++i)
        for (int c = 0; c < 3; ++c)
            numbers.push_back({probe.rgb[size_t(i)][c], c, i, i + 1});
    return numbers;
}

// The folded coefficients of a header. Entry 0 also holds Sloan's split of y_20 (folding.h), whose
// own entry 6 is three times that part, so a y_20 too large for entry 0 is too large for entry 6.
std::vector<WrittenNumber> headerNumbers(const ShCoefficients& probe, const ExportOptions&) {
    if (probe.order < 1 || probe.order > kMaxFoldedOrder) return {}; // the writer refuses it
    const FoldedCoefficients folded = headerCoefficients(probe);
    std::vector<WrittenNumber> numbers;
    for (int i = 0; i < int(probe.rgb.size()); ++i)
        for (int c = 0; c < 3; ++c)
            numbers.push_back({folded[size_t(i)][c], c, i, i + 1});
    return numbers;
}

// The irradiance maps draw E(n) / pi = (1/pi) sum_l sum_m E_lm y_lm(n). By Cauchy-Schwarz and the
// addition theorem (sum_m y_lm(n)^2 = (2l+1) / 4pi at any unit n), each band's sum is at most
// |E_l| sqrt((2l+1) / 4pi), |E_l| the norm of its 2l+1 coefficients, so every pixel of a channel is
// at most (1/pi) sum_l sqrt((2l+1) / 4pi) |E_l|: that bound, made of all the channel's
// coefficients, stands for its pixels. (The rounding of the double evaluation, a few ulps, stays
// far below the half ulp by which a float rounds down to FLT_MAX.)
std::vector<WrittenNumber> irradianceMapNumbers(const ShCoefficients& probe, const ExportOptions&) {
    const ShCoefficients irradiance = irradianceMapCoefficients(probe);
    std::vector<WrittenNumber> numbers;
    for (int c = 0; c < 3; ++c) {
        double bound = 0.0;
        for (int l = 0; l < irradiance.order; ++l) {
            double squares = 0.0;
            for (int i = l * l; i < (l + 1) * (l + 1); ++i)
                squares += irradiance.rgb[size_t(i)][c] * irradiance.rgb[size_t(i)][c];
            bound += std::sqrt((2.0 * l + 1.0) / (4.0 * std::numbers::pi)) * std::sqrt(squares);
        }
        numbers.push_back({bound / std::numbers::pi, c, 0, int(probe.rgb.size())});
    }
    return numbers;
}

// The engine's nine values; each is made of its band (the frame turns a band within itself).
template <Engine engine>
std::vector<WrittenNumber> engineNumbers(const ShCoefficients& probe, const ExportOptions& options) {
    const EngineCoefficients values = engineCoefficients(probe, engine, options.mirror);
    std::vector<WrittenNumber> numbers;
    for (int i = 0; i < int(values.size()); ++i) {
        const int l = shBand(i);
        const int end = std::min((l + 1) * (l + 1), int(probe.rgb.size()));
        for (int c = 0; c < 3; ++c)
            numbers.push_back({values[size_t(i)][c], c, std::min(l * l, end), end});
    }
    return numbers;
}

// A float holds every value that rounds to a finite float: below the midpoint between FLT_MAX and
// 2^128 (FLT_MAX written in 9 digits, 3.40282347e+38, reads back a little above it).
bool representable(double value, NumberType type) {
    if (!std::isfinite(value)) return false;
    return type == NumberType::Double || std::abs(value) < 0x1.ffffffp127;
}

std::string numberText(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", value);
    return text;
}

// ---- The table -------------------------------------------------------------------------------

void writeEngineFile(const std::string& path, const ShCoefficients& probe, const ExportOptions& options,
                     Engine engine) {
    writeOutputFile(path, engineFileText(probe, engine, options), OutputContent::Text);
}

template <Engine engine>
void writeEngine(const std::string& path, const ShCoefficients& probe, const ExportOptions& options) {
    writeEngineFile(path, probe, options, engine);
}

constexpr ExportFormat kFormats[] = {
    {"json", ".json", OutputContent::Text, SunHandling::Written, kMaxOrder,
     "the coefficient file of docs/conventions.md", NumberType::Double, coefficientNumbers,
     [](const std::string& path, const ShCoefficients& probe, const ExportOptions& options) {
         writeProbeFile(path, probe, options.metadata);
     }},
    {"binary", ".bin", OutputContent::Binary, SunHandling::Refused, kMaxOrder,
     "packed float32, docs/formats.md", NumberType::Float, coefficientNumbers,
     [](const std::string& path, const ShCoefficients& probe, const ExportOptions&) {
         writeBinaryProbes(path, std::span(&probe, 1));
     }},
    {"glsl", ".glsl", OutputContent::Text, SunHandling::Refused, kMaxFoldedOrder,
     "GLSL header folded for sh_irradiance.glsl", NumberType::Float, headerNumbers,
     [](const std::string& path, const ShCoefficients& probe, const ExportOptions& options) {
         writeProbeHeader(path, probe, HeaderLanguage::Glsl, options.metadata.source);
     }},
    {"cpp", ".h", OutputContent::Text, SunHandling::Refused, kMaxFoldedOrder,
     "C/C++ header folded for sh_irradiance.glsl", NumberType::Float, headerNumbers,
     [](const std::string& path, const ShCoefficients& probe, const ExportOptions& options) {
         writeProbeHeader(path, probe, HeaderLanguage::C, options.metadata.source);
     }},
    {"irradiance-equirect", ".exr", OutputContent::Binary, SunHandling::Refused, kMaxOrder,
     "E/pi drawn as an equirect EXR", NumberType::Float, irradianceMapNumbers,
     [](const std::string& path, const ShCoefficients& probe, const ExportOptions& options) {
         writeIrradianceEquirect(path, probe, options.mapSize > 0 ? options.mapSize : 512);
     }},
    {"irradiance-cross", ".exr", OutputContent::Binary, SunHandling::Refused, kMaxOrder,
     "E/pi drawn as a cross EXR", NumberType::Float, irradianceMapNumbers,
     [](const std::string& path, const ShCoefficients& probe, const ExportOptions& options) {
         writeIrradianceCross(path, probe, options.mapSize > 0 ? options.mapSize : 128);
     }},
    {"threejs", ".three.json", OutputContent::Text, SunHandling::Refused, kEngineOrder,
     "three.js LightProbe JSON (ObjectLoader, LightProbe.fromJSON)", NumberType::Float,
     engineNumbers<Engine::ThreeJs>, writeEngine<Engine::ThreeJs>},
    {"babylon", ".babylon.json", OutputContent::Text, SunHandling::Refused, kEngineOrder,
     "Babylon.js SphericalHarmonics.FromArray array (E/pi, left-handed scene)", NumberType::Float,
     engineNumbers<Engine::Babylon>, writeEngine<Engine::Babylon>},
    {"gltf", ".gltf", OutputContent::Text, SunHandling::Refused, kEngineOrder,
     "glTF 2.0 asset with an EXT_lights_image_based light", NumberType::Float, engineNumbers<Engine::Gltf>,
     writeEngine<Engine::Gltf>},
    {"filament", ".filament.txt", OutputContent::Text, SunHandling::Refused, kEngineOrder,
     "Filament sh.txt as cmgen --sh-shader writes it (see --mirror)", NumberType::Float,
     engineNumbers<Engine::Filament>, writeEngine<Engine::Filament>},
    {"unity", ".unity.json", OutputContent::Text, SunHandling::Refused, kEngineOrder,
     "Unity SphericalHarmonicsL2, 27 floats channel-major", NumberType::Float, engineNumbers<Engine::Unity>,
     writeEngine<Engine::Unity>},
    {"godot", ".godot.json", OutputContent::Text, SunHandling::Refused, kEngineOrder,
     "Godot LightmapGI capture SH: 9 radiance colors", NumberType::Float, engineNumbers<Engine::Godot>,
     writeEngine<Engine::Godot>},
};

} // namespace

void requireRepresentable(const ExportFormat& format, const ShCoefficients& probe,
                          const ExportOptions& options) {
    // Of the coefficients the unrepresentable numbers are made of, the largest names the problem.
    int worstIndex = -1, worstChannel = 0;
    auto magnitude = [&](int index, int channel) {
        const double value = std::abs(probe.rgb[size_t(index)][channel]);
        return std::isnan(value) ? std::numeric_limits<double>::infinity() : value;
    };
    bool refused = false;
    double written = 0.0; // what the format makes of the worst coefficient
    for (const WrittenNumber& number : format.numbersOf(probe, options)) {
        if (representable(number.value, format.type)) continue;
        refused = true;
        for (int i = number.first; i < number.end; ++i)
            if (worstIndex < 0 || magnitude(i, number.channel) > magnitude(worstIndex, worstChannel))
                worstIndex = i, worstChannel = number.channel, written = number.value;
    }
    if (!refused) return;
    const std::string name = options.metadata.source.empty() ? "the probe" : options.metadata.source;
    const std::string holds = std::string("beyond what --format ") + format.name + " holds (" +
                              (format.type == NumberType::Float ? "float" : "finite double") + ")";
    if (worstIndex < 0) throw Error(ErrorKind::Input, name + ": a value is " + holds);
    static const char* const kChannels[] = {"red", "green", "blue"};
    const int l = shBand(worstIndex);
    // 3e38 fits a float, but gltf writes pi times it: say so where the format's scaling is at fault.
    const double value = probe.rgb[size_t(worstIndex)][worstChannel];
    const std::string scaled = representable(value, format.type)
                                   ? " and makes a written value of " + numberText(written)
                                   : std::string();
    throw Error(ErrorKind::Input, name + ": coefficient l=" + std::to_string(l) +
                                      " m=" + std::to_string(worstIndex - l * (l + 1)) + " (" +
                                      kChannels[worstChannel] + ") is " + numberText(value) + scaled + ", " +
                                      holds);
}

void requireSunFits(const ExportFormat& format, const ExportOptions& options) {
    if (!options.metadata.sun || format.sun != SunHandling::Refused) return;
    const std::string name = options.metadata.source.empty() ? "the probe" : options.metadata.source;
    throw Error(
        ErrorKind::Input,
        name + " has a sun beside its coefficients, which the " + format.name +
            " format cannot hold; write json (an output name ending in .json, or --format json where the "
            "command takes it), or bake again without --extract-sun to keep the sun in the coefficients");
}

void ExportFormat::write(const std::string& path, const ShCoefficients& probe,
                         const ExportOptions& options) const {
    requireSunFits(*this, options);
    requireRepresentable(*this, probe, options);
    writeFile(path, probe, options);
}

std::span<const ExportFormat> exportFormats() {
    return kFormats;
}

const ExportFormat* findExportFormat(std::string_view name) {
    for (const ExportFormat& format : kFormats)
        if (name == format.name) return &format;
    return nullptr;
}

const ExportFormat* formatOfOutputName(const std::string& path) {
    const ExportFormat* best = nullptr;
    for (const ExportFormat& format : kFormats) {
        const std::string_view extension = format.extension;
        bool matches = path.size() > extension.size() && hasExtension(path, extension);
        if (matches && (!best || extension.size() > std::string_view(best->extension).size())) best = &format;
    }
    if (!best && hasExtension(path, ".hpp")) return findExportFormat("cpp");
    return best;
}

std::string exportFormatNames() {
    std::string names;
    for (const ExportFormat& format : kFormats)
        names += std::string(names.empty() ? "" : ", ") + format.name;
    return names;
}

glm::dmat3 engineFrame(Engine engine, bool mirror) {
    switch (engine) {
    case Engine::ThreeJs: // common.glsl.js equirectUv: u = atan(z, x) / 2pi + 0.5: centre +X, right +Z
        return fromRows({0, 0, -1, 0, 1, 0, 1, 0, 0});
    case Engine::Babylon: // panoramaToCubemap.ts CalcProjectionSpherical: centre +Z, right +X, left-handed
        return fromRows({1, 0, 0, 0, 1, 0, 0, 0, -1});
    case Engine::Gltf: // right-handed, Y up; cube faces +X..-Z as docs/conventions.md's (OpenGL's)
        return glm::dmat3(1.0);
    case Engine::Filament: // CubemapUtils::equirectangularToCubemap, then mirrorCubemap (x -> -x)
        return mirror ? fromRows({-1, 0, 0, 0, 1, 0, 0, 0, -1}) : fromRows({1, 0, 0, 0, 1, 0, 0, 0, -1});
    case Engine::Unity: // Skybox-Panoramic.shader ToRadialCoords: centre +X, right -Z, left-handed
        return fromRows({0, 0, -1, 0, 1, 0, -1, 0, 0});
    case Engine::Godot: // sky.glsl panorama coordinates atan(x, -z): centre +Z, right -X
        return fromRows({-1, 0, 0, 0, 1, 0, 0, 0, -1});
    }
    return glm::dmat3(1.0);
}

EngineCoefficients engineCoefficients(const ShCoefficients& probe, Engine engine, bool mirror) {
    const EngineConvention convention = conventionOf(engine);
    const ShCoefficients turned =
        rotate(makeShRotation(engineFrame(engine, mirror), kEngineOrder), radianceBands(probe));
    EngineCoefficients c{};
    for (int i = 0; i < int(c.size()); ++i) {
        const double sign = convention.condonShortley ? 1.0 : phaseSign(i);
        c[size_t(i)] = sign * quantityScale(convention.quantity, i) * turned.rgb[size_t(i)];
    }
    return c;
}

std::string engineFileText(const ShCoefficients& probe, Engine engine, const ExportOptions& options) {
    const EngineCoefficients c = engineCoefficients(probe, engine, options.mirror);
    switch (engine) {
    case Engine::ThreeJs:
        return threeJsText(c);
    case Engine::Babylon:
    case Engine::Godot:
        return rowsArray(c, "") + "\n";
    case Engine::Gltf:
        return gltfText(probe, c, options);
    case Engine::Filament:
        return filamentText(c);
    case Engine::Unity:
        return unityText(c);
    }
    return {};
}

} // namespace shprobe
