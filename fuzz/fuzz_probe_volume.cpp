// parseProbeVolume on arbitrary bytes: it must return a consistent volume or throw shprobe::Error,
// never crash, allocate what the bytes only claim, or throw anything else. A volume it accepts
// must also write and read back: the same probes, the valid ones with the same coefficients (the
// writer zeroes an invalid probe's, whatever the file held for it).
#include "formats/probe_volume.h"
#include "fuzz_support.h"

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string_view>
#include <unistd.h>

using namespace shprobe;

namespace {

void checkVolume(const ProbeVolume& volume) {
    const size_t probes = volume.probeCount();
    const size_t coefficients = probes * size_t(volume.order) * size_t(volume.order);
    if (volume.end < volume.begin || volume.end > volume.grid.probeCount())
        fuzz::finding("probe range outside the grid");
    if (volume.valid.size() != probes) fuzz::finding("validity count != probe count");
    if (!volume.radiance.empty() && volume.radiance.size() != coefficients) fuzz::finding("radiance size");
    if (!volume.irradiance.empty() && volume.irradiance.size() != coefficients)
        fuzz::finding("irradiance size");
    if (volume.radiance.empty() && volume.irradiance.empty())
        fuzz::finding("accepted a volume holding nothing");
}

std::string readAll(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    fuzz::expectOnlyShprobeErrors("parseProbeVolume", [&] {
        const ProbeVolume volume = parseProbeVolume(bytes, "fuzz.shpv");
        checkVolume(volume);
        const std::string path = "/tmp/fuzz_probe_volume_" + std::to_string(getpid()) + ".shpv";
        writeProbeVolume(path, volume);
        const std::string written = readAll(path);
        std::remove(path.c_str());
        const ProbeVolume again = parseProbeVolume(written, "round-trip.shpv");
        if (again.valid != volume.valid || again.begin != volume.begin || again.end != volume.end ||
            again.order != volume.order || again.radiance.size() != volume.radiance.size() ||
            again.irradiance.size() != volume.irradiance.size())
            fuzz::finding("the round trip changed the volume's probes");
        const size_t perProbe = size_t(volume.order) * size_t(volume.order);
        for (size_t p = 0; p < volume.valid.size(); ++p)
            for (size_t i = p * perProbe; volume.valid[p] && i < (p + 1) * perProbe; ++i)
                if ((!volume.radiance.empty() && again.radiance[i] != volume.radiance[i]) ||
                    (!volume.irradiance.empty() && again.irradiance[i] != volume.irradiance[i]))
                    fuzz::finding("the round trip changed a valid probe's coefficient");
    });
    return 0;
}
