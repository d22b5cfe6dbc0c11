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

} // namespace

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

glm::dvec3 sampleVolumeIrradiance(const ProbeVolume& volume, const glm::dvec3& position,
                                  const glm::dvec3& normal) {
    if (volume.irradiance.empty()) fail("the volume holds no irradiance coefficients");
    const double length = glm::length(normal);
    if (!(length > 0.0) || !std::isfinite(length)) fail("the normal has no length");
    const ProbeWeights probes = volumeProbeWeights(volume, position);
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
