// planChannels on channel lists decoded from the bytes, and the luminance/chroma conversion on
// chromaticities decoded from them: only shprobe::Error may come out, and a plan must name
// channels that exist and mean what it says (R, G, B; Y, RY, BY; or Y) of one layer, preferring
// the unprefixed layer.
//
// Input: one byte of flags; with bit 0, 8 chromaticity floats and 3 texel floats (little-endian);
// then the channel names, separated by 0 bytes.
#include "fuzz_support.h"
#include "image/channels.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

using namespace shprobe;

namespace {

std::vector<std::string> decodeNames(const std::string& text) {
    std::vector<std::string> names;
    size_t start = 0;
    for (size_t end; (end = text.find('\0', start)) != std::string::npos; start = end + 1)
        names.push_back(text.substr(start, end - start));
    if (start < text.size()) names.push_back(text.substr(start));
    return names;
}

bool hasUnprefixedRgb(const std::vector<std::string>& names) {
    auto has = [&](const char* name) { return std::find(names.begin(), names.end(), name) != names.end(); };
    return has("R") && has("G") && has("B");
}

// The plan's channels are `prefix + bases[i]` for one prefix.
bool namesOneLayer(const std::vector<std::string>& names, const ChannelPlan& plan,
                   const std::vector<std::string_view>& bases, std::string& prefix) {
    for (size_t i = 0; i < bases.size(); ++i) {
        std::string_view name = names[size_t(plan.channels[i])];
        if (!name.ends_with(bases[i])) return false;
        std::string_view its = name.substr(0, name.size() - bases[i].size());
        if (i == 0) prefix = std::string(its);
        if (its != prefix || (!prefix.empty() && prefix.back() != '.')) return false;
    }
    return true;
}

void checkPlan(const std::vector<std::string>& names, const ChannelPlan& plan) {
    for (int i = 0; i < plan.count(); ++i)
        if (plan.channels[size_t(i)] < 0 || size_t(plan.channels[size_t(i)]) >= names.size())
            fuzz::finding("plan index " + std::to_string(plan.channels[size_t(i)]) + " of " +
                          std::to_string(names.size()) + " channels");
    std::string prefix;
    bool named = false;
    switch (plan.meaning) {
    case ChannelMeaning::Rgb:
        named = namesOneLayer(names, plan, {"R", "G", "B"}, prefix);
        break;
    case ChannelMeaning::LuminanceChroma:
        named = namesOneLayer(names, plan, {"Y", "RY", "BY"}, prefix);
        break;
    case ChannelMeaning::Grey: // Y, or OpenImageIO's default names R, G of a two-channel image
        named = namesOneLayer(names, plan, {"Y"}, prefix) ||
                (names == std::vector<std::string>{"R", "G"} && plan.channels[0] == 0);
        break;
    }
    if (!named) fuzz::finding("the plan's channels do not name what it means");
    if (hasUnprefixedRgb(names) && (plan.meaning != ChannelMeaning::Rgb || !prefix.empty()))
        fuzz::finding("unprefixed R, G, B were not chosen");
}

void checkConversion(fuzz::ByteReader& in) {
    Chromaticities chromaticities;
    for (glm::dvec2* xy :
         {&chromaticities.red, &chromaticities.green, &chromaticities.blue, &chromaticities.white})
        *xy = glm::dvec2(in.f32(), in.f32());
    float y = in.f32(), ry = in.f32(), by = in.f32();
    fuzz::expectOnlyShprobeErrors("luminanceWeights", [&] {
        glm::vec3 weights = luminanceWeights(chromaticities, "fuzz.exr");
        if (!std::isfinite(weights.r) || !std::isfinite(weights.b) || !(weights.g > 0.0f))
            fuzz::finding("luminanceWeights accepted unusable weights");
        glm::vec3 rgb = luminanceChromaToRgb(y, ry, by, weights);
        if (ry == 0.0f && by == 0.0f && rgb != glm::vec3(y) && std::isfinite(y))
            fuzz::finding("zero chroma did not give grey");
    });
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    fuzz::ByteReader in(data, size);
    uint8_t flags = in.u8();
    if (flags & 1) checkConversion(in);
    std::vector<std::string> names = decodeNames(in.rest());
    fuzz::expectOnlyShprobeErrors("planChannels", [&] { checkPlan(names, planChannels(names, "fuzz.exr")); });
    return 0;
}
