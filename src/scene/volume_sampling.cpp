#include "scene/volume_sampling.h"

#include "common/error.h"
#include "scene/probe_grid.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace shprobe {

namespace {

[[noreturn]] void fail(const std::string& problem) {
    throw Error(ErrorKind::Input, "probe volume sampling: " + problem);
}

// Along one axis: the lower probe, the upper one (the same on an axis of one probe) and the
// upper one's weight.
struct AxisSpan {
    int lower = 0;
    int upper = 0;
    double fraction = 0.0;
};

AxisSpan axisSpan(double coordinate, int count) {
    if (count == 1) return {};
    const int lower = std::min(int(std::floor(coordinate)), count - 2); // the last probe: fraction 1
    return {lower, lower + 1, coordinate - double(lower)};
}

// Surface points are moved this many of the grid's smallest cell edges along their normal before
// the visibility test, so that a probe that sees the surface sees the point (DDGI's normal bias).
constexpr double kNormalBias = 0.1;

// DDGI's weight of a probe at `probe` for a surface point: in front of the surface, and seen.
double visibilityWeight(const ProbeVolume& volume, uint32_t index, const glm::dvec3& probe,
                        const glm::dvec3& position, const glm::dvec3& biased, const glm::dvec3& normal) {
    double weight = 1.0;
    const glm::dvec3 toProbe = probe - position;
    const double length = glm::length(toProbe);
    if (length > 0.0) {
        const double facing = (glm::dot(toProbe / length, normal) + 1.0) * 0.5;
        weight *= facing * facing + 0.2;
    }
    const glm::dvec3 fromProbe = biased - probe;
    const double distance = glm::length(fromProbe);
    if (distance == 0.0) return weight;
    const size_t texels = size_t(volume.visibilitySize) * size_t(volume.visibilitySize);
    const glm::dvec2 moments(
        volume.visibility[index * texels + size_t(octahedralTexel(fromProbe, volume.visibilitySize))]);
    if (distance <= moments.x) return weight;
    const double variance = std::max(moments.y - moments.x * moments.x, 1e-12 * moments.y);
    const double seen = variance / (variance + (distance - moments.x) * (distance - moments.x));
    return weight * seen * seen * seen;
}

} // namespace

int octahedralTexel(const glm::dvec3& direction, int size) {
    const glm::dvec3 d = direction / (std::abs(direction.x) + std::abs(direction.y) + std::abs(direction.z));
    glm::dvec2 p(d.x, d.y);
    if (d.z < 0.0) {
        const glm::dvec2 sign(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
        p = (1.0 - glm::abs(glm::dvec2(p.y, p.x))) * sign;
    }
    const int i = std::clamp(int((p.x * 0.5 + 0.5) * size), 0, size - 1);
    const int j = std::clamp(int((p.y * 0.5 + 0.5) * size), 0, size - 1);
    return j * size + i;
}

ProbeWeights volumeProbeWeights(const ProbeVolume& volume, const glm::dvec3& position) {
    if (volume.begin != 0 || volume.end != volume.grid.probeCount())
        fail("the volume holds probes " + std::to_string(volume.begin) + " to " +
             std::to_string(volume.end - 1) + " of " + std::to_string(volume.grid.probeCount()) +
             ", not the whole grid (merge the bricks first)");
    if (!std::isfinite(position.x) || !std::isfinite(position.y) || !std::isfinite(position.z))
        fail("the position is not finite");
    const glm::dvec3 coordinates = gridCoordinates(volume.grid, position);
    AxisSpan spans[3];
    for (int a = 0; a < 3; ++a)
        spans[a] = axisSpan(coordinates[a], volume.grid.counts[a]);

    ProbeWeights result;
    double validSum = 0.0;
    for (int n = 0; n < 8; ++n) {
        glm::ivec3 cell;
        double weight = 1.0;
        for (int a = 0; a < 3; ++a) {
            const bool upper = (n >> a) & 1;
            cell[a] = upper ? spans[a].upper : spans[a].lower;
            weight *= upper ? spans[a].fraction : 1.0 - spans[a].fraction;
        }
        result.probes[n] = probeIndex(volume.grid, cell);
        result.weights[n] = volume.valid[result.probes[n]] ? weight : 0.0;
        validSum += result.weights[n];
    }
    for (double& weight : result.weights)
        weight = validSum > 0.0 ? weight / validSum : 0.0;
    return result;
}

ProbeWeights surfaceProbeWeights(const ProbeVolume& volume, const glm::dvec3& position,
                                 const glm::dvec3& normal) {
    ProbeWeights result = volumeProbeWeights(volume, position);
    if (volume.visibilitySize == 0) return result;
    const glm::dvec3 biased = position + kNormalBias * smallestCellEdge(volume.grid) * normal;
    double sum = 0.0;
    for (int n = 0; n < 8; ++n) {
        if (result.weights[n] == 0.0) continue;
        // Where the probe was captured (moved out of geometry, perhaps): what its visibility saw.
        glm::dvec3 probe = probePosition(volume.grid, probeCell(volume.grid, result.probes[n]));
        if (!volume.offsets.empty()) probe += glm::dvec3(volume.offsets[result.probes[n]]);
        result.weights[n] *= visibilityWeight(volume, result.probes[n], probe, position, biased, normal);
        sum += result.weights[n];
    }
    for (double& weight : result.weights)
        weight = sum > 0.0 ? weight / sum : 0.0;
    return result;
}

glm::dvec3 sampleVolumeIrradiance(const ProbeVolume& volume, const glm::dvec3& position,
                                  const glm::dvec3& normal) {
    if (volume.irradiance.empty()) fail("the volume holds no irradiance coefficients");
    const double length = glm::length(normal);
    if (!(length > 0.0) || !std::isfinite(length)) fail("the normal has no length");
    const ProbeWeights probes = surfaceProbeWeights(volume, position, normal / length);
    const size_t perProbe = size_t(coefficientCount(volume.order));
    ShCoefficients blend = makeCoefficients(volume.order, Quantity::Irradiance);
    for (int n = 0; n < 8; ++n) {
        if (probes.weights[n] == 0.0) continue; // 0 * NaN would still be NaN
        const glm::vec3* coefficients = &volume.irradiance[probes.probes[n] * perProbe];
        for (size_t c = 0; c < perProbe; ++c)
            blend.rgb[c] += probes.weights[n] * glm::dvec3(coefficients[c]);
    }
    return evaluate(blend, normal / length);
}

} // namespace shprobe
