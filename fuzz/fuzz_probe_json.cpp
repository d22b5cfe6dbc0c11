// parseProbeJson on arbitrary bytes: it must return a valid probe or throw shprobe::Error, never
// crash or throw anything else. A probe it accepts must also survive probeToJson and read back the same.
#include "formats/probe_file.h"
#include "fuzz_support.h"
#include "sh/basis.h"

#include <cmath>
#include <string_view>

using namespace shprobe;

namespace {

void checkProbe(const ShCoefficients& probe) {
    if (probe.order < 1 || probe.order > kMaxOrder)
        fuzz::finding("accepted order " + std::to_string(probe.order));
    if (probe.rgb.size() != size_t(probe.order) * size_t(probe.order)) fuzz::finding("rows != order^2");
    for (const auto& rgb : probe.rgb)
        for (int c = 0; c < 3; ++c)
            if (!std::isfinite(rgb[c])) fuzz::finding("accepted a non-finite coefficient");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::string_view text(reinterpret_cast<const char*>(data), size);
    fuzz::expectOnlyShprobeErrors("parseProbeJson", [&] {
        ShCoefficients probe = parseProbeJson(text, "fuzz.json");
        checkProbe(probe);

        // Round trip. Files hold 9 significant digits, so values come back to about 1e-8; values
        // within that of DBL_MAX may round to infinity when written, so they are left out.
        for (const auto& rgb : probe.rgb)
            for (int c = 0; c < 3; ++c)
                if (std::abs(rgb[c]) > 1e300) return;
        ShCoefficients again = parseProbeJson(probeToJson(probe, ProbeMetadata{}), "round-trip.json");
        if (again.order != probe.order || again.quantity != probe.quantity ||
            again.rgb.size() != probe.rgb.size())
            fuzz::finding("round trip changed the order, quantity or row count");
        for (size_t i = 0; i < probe.rgb.size(); ++i)
            for (int c = 0; c < 3; ++c) {
                double a = probe.rgb[i][c], b = again.rgb[i][c];
                // Subnormals keep fewer digits; compare them absolutely.
                if (std::abs(a - b) > 1e-8 * std::abs(a) + 1e-300)
                    fuzz::finding("round trip changed coefficient " + std::to_string(i));
            }
    });
    return 0;
}
