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
// An includer that has the volume's visibility defines SHPROBE_PROBE_VOLUME_VISIBILITY and
//   uint probeVolumeVisibilitySize()
//   vec2 probeVolumeVisibility(uint probe, uint texel)
//   vec3 probeVolumeOffset(uint probe)
// the size of the volume's visibility maps (0 where it holds none), a probe's (mean, mean square)
// distance in octahedral texel `texel`, and where the bake captured it from its grid position (the
// volume's capture offset; vec3(0) where it holds none). The visibility terms take each probe at its
// captured position, the trilinear weights at its grid position. With visibility, each probe is also weighed as
// DDGI does (Majercik et al., "Dynamic Diffuse Global Illumination with Ray-Traced Irradiance
// Fields", JCGT 2019), exactly as scene/volume_sampling.h does on the CPU: ((cos + 1) / 2)^2 + 0.2
// for facing the surface, times Chebyshev's bound, cubed, that it sees the point moved 0.1 of the
// smallest cell edge along n.
#ifndef SHPROBE_PROBE_VOLUME_GLSL
#define SHPROBE_PROBE_VOLUME_GLSL
#include "sh_basis.glsl"

struct ProbeVolumeGrid {
    vec3 boundsMin;
    vec3 boundsMax;
    uvec3 counts;
};

#ifdef SHPROBE_PROBE_VOLUME_VISIBILITY
// The texel of a size x size octahedral map that d falls in (scene/volume_sampling.h).
uint probeVolumeOctahedralTexel(vec3 d, uint size) {
    vec3 o = d / (abs(d.x) + abs(d.y) + abs(d.z));
    vec2 p = o.xy;
    if (o.z < 0.0) p = (vec2(1.0) - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
    uvec2 texel = uvec2(clamp(ivec2((p * 0.5 + 0.5) * float(size)), ivec2(0), ivec2(int(size) - 1)));
    return texel.y * size + texel.x;
}

// How much a probe at `probe` counts for the surface point x of normal n (above).
float probeVolumeVisibilityWeight(uint index, vec3 probe, vec3 x, vec3 biased, vec3 n) {
    float weight = 1.0;
    vec3 toProbe = probe - x;
    float toLength = length(toProbe);
    if (toLength > 0.0) {
        float facing = (dot(toProbe / toLength, n) + 1.0) * 0.5;
        weight *= facing * facing + 0.2;
    }
    vec3 fromProbe = biased - probe;
    float distance = length(fromProbe);
    if (distance == 0.0) return weight;
    uint size = probeVolumeVisibilitySize();
    vec2 moments = probeVolumeVisibility(index, probeVolumeOctahedralTexel(fromProbe, size));
    if (distance <= moments.x) return weight;
    float variance = max(moments.y - moments.x * moments.x, 1e-12 * moments.y);
    float seen = variance / (variance + (distance - moments.x) * (distance - moments.x));
    return weight * seen * seen * seen;
}
#endif

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
#ifdef SHPROBE_PROBE_VOLUME_VISIBILITY
    bool visibility = probeVolumeVisibilitySize() > 0u;
#else
    bool visibility = false;
#endif
    vec3 spacing = extent / max(cells, vec3(1.0));
    float edge = 0.0;
    for (int a = 0; a < 3; ++a)
        if (grid.counts[a] > 1u) edge = edge == 0.0 ? spacing[a] : min(edge, spacing[a]);
    vec3 biased = x + 0.1 * edge * n;
    vec3 sum = vec3(0.0);
    float weightSum = 0.0;
    for (uint corner = 0u; corner < 8u; ++corner) {
        ivec3 o = ivec3(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        ivec3 p = min(base + o, last);
        uint probe = uint(p.x) + grid.counts.x * (uint(p.y) + grid.counts.y * uint(p.z));
        if (probeVolumeCoefficient(probe, 0u).w < 0.5) continue;
        vec3 w3 = mix(vec3(1.0) - f, f, vec3(o));
        float w = w3.x * w3.y * w3.z;
#ifdef SHPROBE_PROBE_VOLUME_VISIBILITY
        if (visibility && w > 0.0) {
            vec3 at = mix(0.5 * (grid.boundsMin + grid.boundsMax), grid.boundsMin + spacing * vec3(p),
                          greaterThan(grid.counts, uvec3(1u))) +
                      probeVolumeOffset(probe);
            w *= probeVolumeVisibilityWeight(probe, at, x, biased, n);
        }
#endif
        vec3 e = vec3(0.0);
        for (uint i = 0u; i < SH_COEFFICIENTS; ++i)
            e += probeVolumeCoefficient(probe, i).rgb * y[i];
        sum += w * e;
        weightSum += w;
    }
    return weightSum > 0.0 ? sum / weightSum : vec3(0.0);
}

#endif
