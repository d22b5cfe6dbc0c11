// A probe: RGB SH coefficients of radiance or irradiance, in flat-index order.
#pragma once
#include <cstddef>
#include <glm/vec3.hpp>
#include <vector>

namespace shprobe {

enum class Quantity { Radiance, Irradiance };

struct ShCoefficients {
    int order = 0;
    Quantity quantity = Quantity::Radiance;
    std::vector<glm::dvec3> rgb; // order^2 entries
};

inline ShCoefficients makeCoefficients(int order, Quantity quantity) {
    return ShCoefficients{order, quantity, std::vector<glm::dvec3>(size_t(order) * size_t(order))};
}

} // namespace shprobe
