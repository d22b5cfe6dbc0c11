// readProbe("-") with the bytes as standard input (an in-memory file put on fd 0): it must return
// a valid probe or throw shprobe::Error, and a probe it accepts, sun included, must read back the
// same once written by probeToJson.
#include "formats/probe_file.h"
#include "fuzz_support.h"
#include "sh/basis.h"

#include <cmath>
#include <sys/mman.h>
#include <unistd.h>

using namespace shprobe;

namespace {

// The bytes as a fresh standard input, read from its start.
void becomeStandardInput(const uint8_t* data, size_t size) {
    int fd = memfd_create("fuzz_probe_stdin", MFD_CLOEXEC);
    if (fd < 0) fuzz::finding("memfd_create failed");
    for (size_t done = 0; done < size;) {
        ssize_t n = write(fd, data + done, size - done);
        if (n <= 0) fuzz::finding("write failed");
        done += size_t(n);
    }
    if (lseek(fd, 0, SEEK_SET) != 0 || dup2(fd, STDIN_FILENO) != STDIN_FILENO) fuzz::finding("dup2 failed");
    close(fd);
}

// Files hold coefficients to 9 significant digits (the sun to 17); subnormals keep fewer, so
// they are compared absolutely as well.
bool near(double a, double b, double relative) {
    return std::abs(a - b) <= relative * std::abs(a) + 1e-300;
}

void checkSameSun(const ProbeSun& a, const ProbeSun& b) {
    for (int c = 0; c < 3; ++c)
        if (!near(a.direction[c], b.direction[c], 1e-12) || !near(a.radiance[c], b.radiance[c], 1e-12))
            fuzz::finding("round trip changed the sun's direction or radiance");
    if (!near(a.angularRadius, b.angularRadius, 1e-12)) fuzz::finding("round trip changed the sun's radius");
}

void checkRoundTrip(const Probe& probe) {
    // Values within a rounding of DBL_MAX may become infinite when written: left out.
    for (const auto& rgb : probe.coefficients.rgb)
        for (int c = 0; c < 3; ++c)
            if (std::abs(rgb[c]) > 1e300) return;
    ProbeMetadata metadata;
    metadata.sun = probe.sun;
    Probe again;
    try { // a probe that was accepted must be written and read again: an Error here is a finding
        again = parseProbe(probeToJson(probe.coefficients, metadata), "round-trip.json");
    } catch (const Error& error) {
        fuzz::finding(std::string("an accepted probe does not read back: ") + error.what());
    }
    const ShCoefficients &a = probe.coefficients, &b = again.coefficients;
    if (a.order != b.order || a.quantity != b.quantity || a.rgb.size() != b.rgb.size())
        fuzz::finding("round trip changed the order, quantity or row count");
    for (size_t i = 0; i < a.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            if (!near(a.rgb[i][c], b.rgb[i][c], 1e-8))
                fuzz::finding("round trip changed coefficient " + std::to_string(i));
    if (probe.sun.has_value() != again.sun.has_value()) fuzz::finding("round trip lost or added the sun");
    if (probe.sun) checkSameSun(*probe.sun, *again.sun);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    becomeStandardInput(data, size);
    fuzz::expectOnlyShprobeErrors("readProbe(\"-\")", [&] {
        Probe probe = readProbe("-");
        if (probe.coefficients.order < 1 || probe.coefficients.order > kMaxOrder)
            fuzz::finding("accepted order " + std::to_string(probe.coefficients.order));
        if (probe.coefficients.rgb.size() !=
            size_t(probe.coefficients.order) * size_t(probe.coefficients.order))
            fuzz::finding("rows != order^2");
        checkRoundTrip(probe);
    });
    return 0;
}
