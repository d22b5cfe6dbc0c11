// Inputs the program tests write into their temporary folders: a small equirect environment and
// probe files, good and bad. No binary file is checked in.
#pragma once
#include "formats/probe_file.h"
#include "image/image_write.h"
#include "sh/basis.h"
#include "sh/cubemap.h"

#include <cmath>
#include <fstream>
#include <glm/geometric.hpp>
#include <string>

namespace shprobe::testing {

// 64 x 32 equirect: a sky gradient, dark ground and a warm bright lobe up and to the right.
inline void writeTestEnvironment(const std::string& path) {
    const int width = 64, height = 32;
    Image image = makeImage(width, height);
    const glm::dvec3 sun = glm::normalize(glm::dvec3(0.6, 0.5, -0.4));
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) {
            glm::dvec3 d = equirectDirection(i, j, width, height);
            glm::dvec3 sky =
                d.y > 0.0 ? glm::dvec3(0.3, 0.5, 1.0) * (0.5 + d.y) : glm::dvec3(0.25, 0.2, 0.15);
            double lobe = std::pow(std::max(glm::dot(d, sun), 0.0), 16.0);
            image.at(i, j) = glm::vec4(glm::vec3(sky + glm::dvec3(20.0, 16.0, 10.0) * lobe), 1.0f);
        }
    writeImage(path, image);
}

// A radiance probe of `order` whose coefficients fall off with the band.
inline ShCoefficients testProbe(int order, Quantity quantity = Quantity::Radiance) {
    ShCoefficients probe = makeCoefficients(order, quantity);
    for (int i = 0; i < coefficientCount(order); ++i) {
        double falloff = 1.0 / (1.0 + shBand(i));
        probe.rgb[size_t(i)] =
            glm::dvec3(1.0 + 0.1 * (i % 3), 0.9, 0.8) * (i == 0 ? 3.0 : 0.4 * falloff * ((i % 2) ? 1 : -1));
    }
    return probe;
}

inline void writeText(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

} // namespace shprobe::testing
