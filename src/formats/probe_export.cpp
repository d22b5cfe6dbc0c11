#include "formats/probe_export.h"

#include "common/error.h"
#include "common/output_file.h"
#include "image/image_write.h"
#include "sh/basis.h"
#include "sh/cubemap.h"
#include "sh/folding.h"
#include "sh/irradiance.h"

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <sstream>

namespace shprobe {

namespace {

glm::vec4 reflectedRadiance(const ShCoefficients& irradiance, const glm::dvec3& direction) {
    return glm::vec4(glm::vec3(evaluate(irradiance, direction) / std::numbers::pi), 1.0f);
}

// Where each face sits in a horizontal cross, in face units (docs/conventions.md):
// [ . +Y . . ] [ -X +Z +X -Z ] [ . -Y . . ], indexed by Face.
constexpr std::array<std::array<int, 2>, kFaceCount> kCrossSlots{
    {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}}};

// ---- Headers ---------------------------------------------------------------------------------

// The shortest text that reads back to the same float, always with a '.' or an exponent so that C
// and GLSL both take it as a floating-point literal.
std::string floatLiteral(float value, HeaderLanguage language) {
    char text[32];
    std::to_chars_result end = std::to_chars(text, text + sizeof(text), value);
    std::string literal(text, end.ptr);
    if (literal.find_first_of(".e") == std::string::npos) literal += ".0";
    return language == HeaderLanguage::C ? literal + "f" : literal;
}

// Text safe inside a // comment: no line break, and no '\' that could splice the next line in C.
std::string commentText(const std::string& text) {
    std::string safe = text;
    for (char& c : safe)
        if (uint8_t(c) < 0x20 || c == 0x7f || c == '\\') c = '_';
    return safe;
}

std::string upperCase(std::string text) {
    for (char& c : text)
        c = char(std::toupper(uint8_t(c)));
    return text;
}

// The fold and the function of sh_irradiance.glsl that evaluates it. The functions take the order
// (3..5 there; below 3 works as well, since they always evaluate bands 0..2 and the higher entries
// of a lower order are 0).
struct HeaderPlan {
    FoldedQuantity quantity;
    const char* function;
    const char* description;
};

HeaderPlan headerPlan(const ShCoefficients& probe) {
    if (probe.quantity == Quantity::Irradiance)
        return {FoldedQuantity::IrradianceOverPi, "shIrradianceOverPi",
                "irradiance, folded with s_l = A_l / pi: the call returns E(n) / pi, the radiance a white\n"
                "//              Lambertian surface of normal n reflects (multiply by the albedo)"};
    return {FoldedQuantity::Radiance, "shRadiance",
            "radiance, folded with s_l = 1: the call returns L(d), the radiance arriving from direction d"};
}

void appendHeaderComment(std::ostringstream& out, const ShCoefficients& probe, const HeaderPlan& plan,
                         const std::string& array, const std::string& source, HeaderLanguage language) {
    int count = coefficientCount(probe.order);
    out << "// An SH light probe for shprobe/glsl/sh_irradiance.glsl, written by shprobe.\n"
        << "//   source     " << commentText(source) << "\n"
        << "//   order      " << probe.order << ": bands l = 0.." << probe.order - 1 << ", " << count
        << " coefficients (real orthonormal SH with the Condon-Shortley phase)\n"
        << "//   quantity   " << plan.description << "\n"
        << "//   layout     " << array << ": " << kFoldedCount
        << " entries of rgb and w = 0, flat index i = l(l+1) + m;\n"
        << "//              c_i = s_l k_i f_i as sh_irradiance.glsl explains"
        << (count < kFoldedCount ? "; entries from " + std::to_string(count) + " on are 0" : std::string())
        << "\n";
    if (language == HeaderLanguage::Glsl)
        out << "// Evaluate, after #include \"sh_irradiance.glsl\" and this file:\n"
            << "//   vec3 value = " << plan.function << "(" << array << ", n, " << array << "_order);\n";
    else
        out << "// Evaluate: upload " << array
            << " as the shader's vec4 coefficients[SH_FOLDED_COUNT] (16 bytes\n"
            << "// per entry in std140 and std430 alike) and, in GLSL after #include "
               "\"sh_irradiance.glsl\":\n"
            << "//   vec3 value = " << plan.function << "(coefficients, n, " << probe.order << "u);\n";
}

void appendHeaderArray(std::ostringstream& out, const FoldedCoefficients& folded, const std::string& array,
                       HeaderLanguage language) {
    const bool glsl = language == HeaderLanguage::Glsl;
    out << (glsl ? "const vec4 " + array + "[SH_FOLDED_COUNT] = vec4[SH_FOLDED_COUNT](\n"
                 : "static const float " + array + "[" + std::to_string(kFoldedCount) + "][4] = {\n");
    for (int i = 0; i < kFoldedCount; ++i) {
        out << (glsl ? "    vec4(" : "    {");
        for (int c = 0; c < 3; ++c)
            out << floatLiteral(float(folded[size_t(i)][c]), language) << ", ";
        out << floatLiteral(0.0f, language) << (glsl ? ")" : "}") << (i + 1 < kFoldedCount ? "," : "");
        int l = shBand(i);
        out << " // l=" << l << " m=" << (i - l * (l + 1) >= 0 ? "+" : "") << i - l * (l + 1) << "\n";
    }
    out << (glsl ? ");\n" : "};\n");
}

} // namespace

std::string headerIdentifier(std::string_view stem) {
    std::string identifier;
    for (char c : stem) {
        bool keep = std::isalnum(uint8_t(c)) && uint8_t(c) < 0x80;
        char next = keep ? c : '_';
        if (next == '_' && (identifier.empty() || identifier.back() == '_')) continue;
        identifier.push_back(next);
    }
    while (!identifier.empty() && identifier.back() == '_')
        identifier.pop_back();
    if (identifier.empty()) return "probe";
    if (std::isdigit(uint8_t(identifier[0])) || identifier.rfind("gl_", 0) == 0)
        identifier = "probe_" + identifier;
    return identifier;
}

FoldedCoefficients headerCoefficients(const ShCoefficients& probe) {
    return *foldCoefficients(probe, probe.order, headerPlan(probe).quantity);
}

std::string probeToHeader(const ShCoefficients& probe, HeaderLanguage language, const std::string& identifier,
                          const std::string& source) {
    if (probe.order < 1 || probe.order > kMaxFoldedOrder)
        throw Error(ErrorKind::Input, "a header holds orders 1 to " + std::to_string(kMaxFoldedOrder) +
                                          " (sh_irradiance.glsl evaluates up to order 5), not " +
                                          std::to_string(probe.order));
    const HeaderPlan plan = headerPlan(probe);
    const FoldedCoefficients folded = headerCoefficients(probe);
    const bool glsl = language == HeaderLanguage::Glsl;
    const std::string array = identifier + "_sh";
    const std::string guard = "SHPROBE_PROBE_" + upperCase(identifier) + (glsl ? "_GLSL" : "_H");

    std::ostringstream out;
    appendHeaderComment(out, probe, plan, array, source, language);
    out << "#ifndef " << guard << "\n#define " << guard << "\n";
    if (glsl) {
        out << "#ifndef SHPROBE_SH_IRRADIANCE_GLSL\n#error include sh_irradiance.glsl before this "
               "file\n#endif\n\n"
            << "const uint " << array << "_order = " << probe.order << "u;\n";
    } else {
        out << "\n#define " << upperCase(array) << "_ORDER " << probe.order << "\n";
    }
    appendHeaderArray(out, folded, array, language);
    out << "\n#endif\n";
    return out.str();
}

void writeProbeHeader(const std::string& path, const ShCoefficients& probe, HeaderLanguage language,
                      const std::string& source) {
    std::string identifier = headerIdentifier(std::filesystem::path(path).stem().string());
    writeOutputFile(path, probeToHeader(probe, language, identifier, source));
}

ShCoefficients irradianceMapCoefficients(const ShCoefficients& probe) {
    return probe.quantity == Quantity::Irradiance ? probe : convolveIrradiance(probe);
}

bool isEquirectMapWidth(int width) {
    return width >= 2 && width % 2 == 0;
}

void writeIrradianceEquirect(const std::string& path, const ShCoefficients& probe, int width) {
    if (!isEquirectMapWidth(width))
        throw Error(ErrorKind::Input,
                    "equirect width must be even and at least 2, not " + std::to_string(width));
    ShCoefficients irradiance = irradianceMapCoefficients(probe);
    Image image = makeImage(width, width / 2);
    for (int j = 0; j < image.height; ++j)
        for (int i = 0; i < image.width; ++i)
            image.at(i, j) =
                reflectedRadiance(irradiance, equirectDirection(i, j, image.width, image.height));
    writeImage(path, image, "openexr");
}

void writeIrradianceCross(const std::string& path, const ShCoefficients& probe, int faceSize) {
    if (faceSize < 1) throw Error(ErrorKind::Input, "cube-map face size must be at least 1");
    ShCoefficients irradiance = irradianceMapCoefficients(probe);
    Image cross = makeImage(4 * faceSize, 3 * faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        for (int j = 0; j < faceSize; ++j)
            for (int i = 0; i < faceSize; ++i)
                cross.at(kCrossSlots[face][0] * faceSize + i, kCrossSlots[face][1] * faceSize + j) =
                    reflectedRadiance(irradiance, texelDirection(face, i, j, faceSize));
    writeImage(path, cross, "openexr");
}

} // namespace shprobe
