// probe_reader: shprobe's C++ library through the installed package. Reads a probe file, rotates it
// and prints its irradiance at one surface normal.
//
//   probe_reader PROBE.json ALPHA,BETA,GAMMA X,Y,Z
//
// The rotation is R = Rz(gamma) Ry(beta) Rz(alpha), in degrees, as `shprobe rotate --euler`: a light
// that came from d comes from R d. X,Y,Z is the normal n, of any length. A radiance probe is first
// convolved with the clamped cosine, so the second line printed is E(n) of the rotated probe:
//   shprobe 0.1.0, order 3
//   irradiance R G B
// A sun taken out of the probe (its "sun" field) is not added back: E is the probe's own part.
#include <shprobe/formats/probe_file.h>
#include <shprobe/sh/irradiance.h>
#include <shprobe/sh/rotation.h>
#include <shprobe/version.h>

#include <glm/geometric.hpp>

#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>

namespace {

// "X,Y,Z": three numbers and nothing else.
glm::dvec3 parseTriple(const std::string& text) {
    glm::dvec3 v{};
    int used = 0;
    if (std::sscanf(text.c_str(), "%lf,%lf,%lf%n", &v.x, &v.y, &v.z, &used) != 3 || used != int(text.size()))
        throw std::runtime_error("expected three numbers X,Y,Z, got \"" + text + "\"");
    return v;
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: probe_reader PROBE.json ALPHA,BETA,GAMMA X,Y,Z\n");
        return 2;
    }
    try {
        shprobe::Probe probe = shprobe::readProbe(argv[1]);
        glm::dvec3 euler = parseTriple(argv[2]);
        glm::dvec3 normal = parseTriple(argv[3]);
        if (glm::length(normal) == 0.0) throw std::runtime_error("the normal must not be 0,0,0");

        shprobe::ShCoefficients irradiance = probe.coefficients;
        if (irradiance.quantity == shprobe::Quantity::Radiance)
            irradiance = shprobe::convolveIrradiance(irradiance);
        glm::dmat3 R = shprobe::rotationFromEulerZYZ(euler.x, euler.y, euler.z);
        irradiance = shprobe::rotate(shprobe::makeShRotation(R, irradiance.order), irradiance);
        glm::dvec3 e = shprobe::evaluate(irradiance, glm::normalize(normal));

        std::printf("shprobe %s, order %d\n", SHPROBE_VERSION_STRING, irradiance.order);
        std::printf("irradiance %.17g %.17g %.17g\n", e.r, e.g, e.b);
        return 0;
    } catch (const std::exception& error) { // shprobe::Error names the file and the field at fault
        std::fprintf(stderr, "probe_reader: %s\n", error.what());
        return 1;
    }
}
