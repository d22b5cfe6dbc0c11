// Probe volumes (docs/probe-volume.md): a regular grid of SH light probes in one file, a JSON
// header followed by little-endian float32 coefficients, optional visibility maps, capture
// offsets and radiance transfer, and one validity byte per probe. A volume
// holds the whole grid or one brick of it, a contiguous range of the probes' flat indices; merging
// the bricks of a bake gives the file the whole bake writes, byte for byte.
//
// The grid is described here, with the file, so that a program reading volumes needs only this
// library; scene/probe_grid.h places its probes, parses the options that make one and splits it
// into bricks.
#pragma once
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace shprobe {

// At most 256^3 probes in one grid: flat indices fit 32 bits with room to spare, and a larger grid
// is a typing error rather than a bake anyone waits for (each probe is one capture of the scene).
constexpr uint32_t kMaxGridProbes = 1u << 24;
// The bytes every probe volume starts with.
constexpr std::string_view kProbeVolumeMagic = "SHPROBEV";

// counts.x * counts.y * counts.z probes spanning the box [boundsMin, boundsMax], corners included:
// probe (i, j, k) lies at boundsMin + (boundsMax - boundsMin) * (i, j, k) / (counts - 1), and an
// axis with a single probe holds it at the box's centre. Flat index i + NX * (j + NY * k).
struct ProbeGrid {
    glm::ivec3 counts{1};
    glm::dvec3 boundsMin{0.0};
    glm::dvec3 boundsMax{0.0};

    // Meaningful once checkProbeGrid accepts the grid.
    uint32_t probeCount() const { return uint32_t(counts.x) * uint32_t(counts.y) * uint32_t(counts.z); }
};

// Throws Error(Input) "WHAT: PROBLEM" unless every count is at least 1, there are at most
// kMaxGridProbes probes, the bounds are finite with boundsMin <= boundsMax, and the box is flat
// (boundsMin = boundsMax) only along axes holding a single probe.
void checkProbeGrid(const ProbeGrid& grid, const std::string& what);

// The probes [begin, end) of a grid, by flat index, with their SH coefficients. A quantity the
// volume does not hold is an empty vector; at least one is held. Coefficients are RGB in SH
// flat-index order (docs/conventions.md), order^2 per probe, probe after probe:
// coefficient c of probe begin + p is at [p * order^2 + c].
struct ProbeVolume {
    ProbeGrid grid;
    int order = 3;
    uint32_t begin = 0;
    uint32_t end = 0;
    std::vector<glm::vec3> radiance;   // L_lm
    std::vector<glm::vec3> irradiance; // E_lm = A_l L_lm: evaluated at a normal n it gives E(n)
    // 1 where the probe may be used, 0 where the bake found it unusable (inside geometry, say):
    // a renderer gives it no weight, and its coefficients are written as zeros.
    std::vector<uint8_t> valid;
    // Per probe, visibilitySize^2 octahedral texels (scene/volume_sampling.h) of the mean and the
    // mean square distance to the first surface the probe sees that way: by these a sampler tells
    // whether a probe sees the point it shades. Empty (size 0) where the bake recorded none.
    int visibilitySize = 0;
    std::vector<glm::vec2> visibility;
    // Per probe, where the bake captured it from its grid position (world units): zero unless it
    // was moved out of geometry (probe relocation). A sampler weighs a probe's visibility from there.
    // Empty where the bake recorded none, which reads as every offset zero.
    std::vector<glm::vec3> offsets;
    // Radiance transfer (docs/probe-volume.md, "Relighting"): what a probe's radiance is under any
    // distant sky of SH coefficients S_j (RGB, the volume's order), L_i = static_i + sum_j T_ij S_j,
    // channel by channel. staticRadiance holds order^2 coefficients per probe (the light that does not
    // come from the sky: emission, the scene's suns), transfer order^4 (T_ij at [i * order^2 + j]).
    // Both empty where the bake recorded no transfer; zeros for an invalid probe.
    std::vector<glm::vec3> staticRadiance;
    std::vector<glm::vec3> transfer;
    int bounces = 0;    // indirect bounces in the bake; 0: direct light only
    std::string source; // what was baked, in words, e.g. World::description
    // What was baked, by content, whatever its path: gltfSceneHash (scene/gltf_scene.h),
    // "fnv1a64:..."; empty where unknown (a volume written before volumes held it).
    std::string sourceHash;
    // The distant sky that lit it, in words, e.g. Environment::description; the settings name it by
    // content ("sky"), so that one sky under two paths is one sky. Empty where the baker said none.
    std::string skySource;
    // A JSON object of whatever else decides the bake (face size, sky, window...), set by the
    // baker. Bricks merge only when it is equal, as JSON values.
    std::string settings = "{}";

    uint32_t probeCount() const { return end - begin; }
};

// Whether `volume` was baked in the scene whose gltfSceneHash is `hash` and whose description is
// `description`: by the hashes, or by the descriptions where the volume holds no hash. Empty when it
// was, else why not in words: "baked in DESCRIPTION (HASH), not in DESCRIPTION (HASH): ...".
std::string sceneMismatch(const ProbeVolume& volume, const std::string& hash, const std::string& description);

// "the radiance of probe P" (else "the irradiance of probe P") for the first valid probe holding a
// coefficient that is not finite, as writeProbeVolume refuses it; empty where every one is finite.
// The volume's sizes must be consistent.
std::string nonFiniteLight(const ProbeVolume& volume);

// What differs between two grids (counts first, then bounds), or between two bakes' settings (the
// first key whose value differs), in words naming both: "bounds [0,0,0]..[1,1,1] in A, ... in B",
// "setting \"face_size\" is 8 in A, 4 in B" (settings that are not JSON objects: "settings that
// are not both JSON objects"). Empty where they agree.
std::string gridDifference(const ProbeGrid& a, const ProbeGrid& b, const std::string& nameA,
                           const std::string& nameB);
std::string settingsDifference(const std::string& a, const std::string& b, const std::string& nameA,
                               const std::string& nameB);

// A bake's sky: its settings (a JSON object whose "sky" names the sky by content) and the sky in
// words (ProbeVolume::skySource; empty for a volume written before volumes held it, whose "sky" is
// then that description).
struct BakeSky {
    std::string settings;
    std::string source;
};
// What differs between two bakes' skies, in words naming both: "sky \"sky.exr (...)\" (fnv1a64:...)
// in A, \"sky.exr (...)\" (fnv1a64:...) in B". Empty where their settings' "sky" agree (or either's
// settings are not a JSON object, which settingsDifference says).
std::string skyDifference(const BakeSky& a, const BakeSky& b, const std::string& nameA,
                          const std::string& nameB);

// Writes atomically (common/output_file.h). Throws Error(Input) "cannot write PATH: PROBLEM" for a
// volume that is not consistent (sizes, ranges, validity bytes other than 0 and 1, settings that
// are not a JSON object, a non-finite coefficient of a valid probe), and Error(Output) as
// OutputFile does.
void writeProbeVolume(const std::string& path, const ProbeVolume& volume);

// Reads and checks every field; the payload's size is checked against the file's before anything
// is allocated for it. Throws Error(Input) "PATH: PROBLEM" for anything that is not a volume of
// docs/probe-volume.md (truncated, trailing bytes, a header that does not match the payload).
ProbeVolume readProbeVolume(const std::string& path);
// The same for a volume in memory; `name` stands for the path in messages.
ProbeVolume parseProbeVolume(std::string_view bytes, const std::string& name);

// One volume of the whole grid from its bricks, given in any order: they must be of one bake (the
// same grid, order, quantities, bounces, source hash (else source) and settings) and hold every probe of the
// grid exactly once. Throws Error(Input) naming what differs, what overlaps or what is missing; names (one
// per brick, the files they came from) are used in messages when given, else "brick N".
ProbeVolume mergeProbeVolumes(std::span<const ProbeVolume> bricks, std::span<const std::string> names = {});

} // namespace shprobe
