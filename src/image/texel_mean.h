// The mean of a function of direction over one cube-map texel, for texels a small feature (a sun
// disc, a light's cap) only partly covers, where the value at the texel's centre would drop the
// feature or inflate it to the whole texel.
#pragma once
#include "sh/cubemap.h"

#include <cmath>
#include <glm/vec3.hpp>

namespace shprobe {

// Mean of radianceToward(d) over an n x n grid in texel (i, j), each sample weighted by the solid
// angle per unit face area, 1 / (1 + a^2 + b^2)^(3/2), so that mean x texel solid angle is the
// integral.
template <typename Radiance>
glm::dvec3 texelMean(int face, int i, int j, int faceSize, int n, const Radiance& radianceToward) {
    const double step = 2.0 / (double(faceSize) * n);
    glm::dvec3 sum(0.0);
    double weights = 0.0;
    for (int sj = 0; sj < n; ++sj) {
        for (int si = 0; si < n; ++si) {
            const double a = -1.0 + (i * n + si + 0.5) * step;
            const double b = -1.0 + (j * n + sj + 0.5) * step;
            const double weight = std::pow(1.0 + a * a + b * b, -1.5);
            sum += weight * radianceToward(faceDirection(face, a, b));
            weights += weight;
        }
    }
    return sum / weights;
}

} // namespace shprobe
