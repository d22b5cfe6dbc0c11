// Irradiance from a probe volume (docs/probe-volume.md), for any shader: the irradiance SH of the
// eight probes around a point, weighted trilinearly, probes inside geometry (invalid) left out and
// the weights of the others renormalized, evaluated at the surface normal. Probe (i, j, k) of a
// grid of counts (nx, ny, nz) lies at boundsMin + (boundsMax - boundsMin) * (i, j, k) / (counts - 1)
// (an axis of one probe: its centre), flat index i + nx (j + ny k); points outside the bounds take
// the nearest face's values.
//
// The includer declares `const uint SH_ORDER` (the volume's order) and, before including, defines
//   vec4 probeVolumeCoefficient(uint probe, uint index)
// returning irradiance coefficient `index` (flat l(l+1) + m) of a probe in rgb, and in w 1 for a
// valid probe, 0 for one inside geometry: from a storage buffer, or a 3D texture of coefficients.
#ifndef SHPROBE_PROBE_VOLUME_GLSL
#define SHPROBE_PROBE_VOLUME_GLSL
#include "sh_basis.glsl"

struct ProbeVolumeGrid {
    vec3 boundsMin;
    vec3 boundsMax;
    uvec3 counts;
};

// E(n) at x; zero where none of the eight probes is valid.
vec3 probeVolumeIrradiance(ProbeVolumeGrid grid, vec3 x, vec3 n) {
    ivec3 last = ivec3(grid.counts) - 1;
    vec3 cells = vec3(last);
    vec3 extent = grid.boundsMax - grid.boundsMin;
    vec3 t = clamp((x - grid.boundsMin) / max(extent, vec3(1e-30)) * cells, vec3(0.0), cells);
    ivec3 base = min(ivec3(floor(t)), max(last - 1, ivec3(0)));
    vec3 f = t - vec3(base);
    float y[SH_BASIS_CAPACITY];
    shEvalBasis(n, y);
    vec3 sum = vec3(0.0);
    float weightSum = 0.0;
    for (uint corner = 0u; corner < 8u; ++corner) {
        ivec3 o = ivec3(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        ivec3 p = min(base + o, last);
        uint probe = uint(p.x) + grid.counts.x * (uint(p.y) + grid.counts.y * uint(p.z));
        if (probeVolumeCoefficient(probe, 0u).w < 0.5) continue;
        vec3 w3 = mix(vec3(1.0) - f, f, vec3(o));
        float w = w3.x * w3.y * w3.z;
        vec3 e = vec3(0.0);
        for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
            e += probeVolumeCoefficient(probe, i).rgb * y[i];
        sum += w * e;
        weightSum += w;
    }
    return weightSum > 0.0 ? sum / weightSum : vec3(0.0);
}

#endif
