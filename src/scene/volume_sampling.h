// Trilinear sampling of a probe volume on the CPU: the reference for the shaders that sample one.
//
// A point between probes takes the 8 probes of the grid cell around it (the nearest probes, once
// clamped to the grid, outside it) with trilinear weights. A probe the bake found unusable
// (ProbeVolume::valid 0) gets weight 0 and the others are scaled to sum to 1, so that a probe
// inside a wall darkens nothing near it; where every probe of non-zero weight is invalid, the
// sample is 0 (black), which a renderer sees and may fill with another light.
//
// Where the volume holds visibility, a surface point also weighs each probe as DDGI does (Majercik
// et al., "Dynamic Diffuse Global Illumination with Ray-Traced Irradiance Fields", JCGT 2019): by
// how much the probe lies in front of the surface, ((cos + 1) / 2)^2 + 0.2, and by Chebyshev's
// bound on the chance that the probe sees the point, from the mean and variance of the distances
// it recorded towards it: a probe behind a wall, which saw the wall nearer than the point, gets
// almost no weight, so light does not leak through. Both terms take the probe where the bake captured
// it (its grid position plus the volume's capture offset, where a probe was moved out of geometry),
// as DDGI does with relocated probes; the trilinear weights stay those of the grid positions.
#pragma once
#include "formats/probe_volume.h"

#include <array>
#include <cstdint>
#include <glm/vec3.hpp>

namespace shprobe {

struct ProbeWeights {
    std::array<uint32_t, 8>
        probes{}; // flat indices; corner n is (i0 + (n & 1), j0 + (n >> 1 & 1), k0 + (n >> 2))
    std::array<double, 8> weights{}; // sum to 1, or all 0 (see above)
};

// The probes around `position` and their weights, validity included. The volume must hold the whole
// grid (a brick does not: merge first); throws Error(Input) otherwise or for a non-finite position.
ProbeWeights volumeProbeWeights(const ProbeVolume& volume, const glm::dvec3& position);

// The texel of a size x size octahedral map (Cigolle et al., "A Survey of Efficient Representations
// for Independent Unit Vectors", JCGT 2014) that direction d (any length) falls in, row by row:
// the upper hemisphere (z >= 0) is the inner diamond, the lower one folded over its edges.
int octahedralTexel(const glm::dvec3& direction, int size);

// volumeProbeWeights for a surface point of unit normal `normal`, with the volume's visibility
// where it holds one (above); without visibility, the same weights.
ProbeWeights surfaceProbeWeights(const ProbeVolume& volume, const glm::dvec3& position,
                                 const glm::dvec3& normal);

// E(n) at `position` for a surface of normal `normal` (normalized here): the irradiance
// coefficients blended with surfaceProbeWeights and evaluated at n. Probes of weight 0 are not
// read, so what an invalid probe holds (NaN included) has no effect. Throws Error(Input) when the
// volume holds no irradiance or the normal has no length.
glm::dvec3 sampleVolumeIrradiance(const ProbeVolume& volume, const glm::dvec3& position,
                                  const glm::dvec3& normal);

} // namespace shprobe
