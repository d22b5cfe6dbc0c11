// Where the probes of a scene's grid are, the options that make a grid (`--grid`, `--bounds`) and
// its split into bricks (`--brick I/N`), each baked by its own run and joined by `shprobe merge`.
//
// Probes sit at the corners of the grid's cells, both ends included, as in DDGI and Unity's probe
// volumes: probe (i, j, k) of an NX x NY x NZ grid lies at
//   boundsMin + (boundsMax - boundsMin) * (i / (NX - 1), j / (NY - 1), k / (NZ - 1)),
// an axis holding a single probe places it at the middle of the bounds, and the flat index of
// probe (i, j, k) is i + NX * (j + NY * k) (x fastest). Between probes a renderer interpolates
// trilinearly (scene/volume_sampling.h), and no extrapolation is needed up to the bounds.
#pragma once
#include "formats/probe_volume.h"
#include "scene/scene.h"

#include <cstdint>
#include <glm/vec3.hpp>
#include <string>
#include <vector>

namespace shprobe {

// "NX,NY,NZ" (`--grid`): three whole numbers, each at least 1, kMaxGridProbes probes at most.
// Throws Error(Input) "--grid: ..." naming what is wrong.
glm::ivec3 parseGridCounts(const std::string& text);

struct GridBounds {
    glm::dvec3 min{0.0};
    glm::dvec3 max{0.0};
};

// "X0,Y0,Z0,X1,Y1,Z1" (`--bounds`): six finite numbers, the minimum corner first (X0 <= X1, ...).
// Throws Error(Input) "--bounds: ..." naming what is wrong.
GridBounds parseGridBounds(const std::string& text);

// The grid of `counts` probes spanning `bounds`, corners included. Throws Error(Input) where they
// do not make a grid (checkProbeGrid: bounds flat along an axis that holds several probes).
ProbeGrid makeProbeGrid(const glm::ivec3& counts, const GridBounds& bounds);

// The grid without `--bounds`: the world's bounding box, inset by half a cell on each side, so that
// the probes lie at the centres of the cells of the box divided into counts cells. No probe then
// sits on the outermost geometry (the floor, the walls of a room), where it would see half of its
// sphere behind the surface, and the margins are even on every side; a single probe on an axis is
// at the box's middle. Throws Error(Input) naming the world when its box is flat along an axis (a
// lone ground plane) or empty: where the probes should be is then for --bounds to say; first, as
// checkSceneScale does, for a scale the rays cannot hold (a box may look flat by rounding alone).
ProbeGrid probeGridInWorld(const glm::ivec3& counts, const World& world);

glm::dvec3 probePosition(const ProbeGrid& grid, const glm::ivec3& cell);
uint32_t probeIndex(const ProbeGrid& grid, const glm::ivec3& cell);
glm::ivec3 probeCell(const ProbeGrid& grid, uint32_t index);

// A position as continuous probe coordinates: (i, j, k) = (1.5, 0, 2) is halfway between probes
// (1, 0, 2) and (2, 0, 2). Clamped to the grid, [0, N - 1] on each axis (0 on an axis of one probe):
// outside the bounds the nearest probes' values hold.
glm::dvec3 gridCoordinates(const ProbeGrid& grid, const glm::dvec3& position);

// The shortest side of the grid's cells, over the axes of more than one probe; 0 for a grid of one
// probe. The scale of everything a sampler or a bake measures in cells.
double smallestCellEdge(const ProbeGrid& grid);

// Brick `index` of `count` (`--brick I/N`), numbered from 0 as the probes are: 0/4, 1/4, 2/4 and
// 3/4 are the four bricks of a grid.
struct Brick {
    uint32_t index = 0;
    uint32_t count = 1;
};

// "I/N" with 0 <= I < N, N from 1 to kMaxGridProbes. Throws Error(Input) "--brick: ..." otherwise.
Brick parseBrick(const std::string& text);

// Probes [begin, end) by flat index.
struct ProbeRange {
    uint32_t begin = 0;
    uint32_t end = 0;
};

// The flat indices brick I of N bakes: [floor(I T / N), floor((I + 1) T / N)) of the grid's T
// probes. The bricks follow each other, cover the grid exactly once and differ in size by one at
// most, so that merging is concatenation in brick order. More bricks than probes would leave some
// empty, which no bake needs: refused with Error(Input) naming the largest N the grid allows.
ProbeRange brickRange(const ProbeGrid& grid, const Brick& brick);

// The positions of probes [range.begin, range.end), in flat-index order.
std::vector<glm::dvec3> probePositions(const ProbeGrid& grid, ProbeRange range);

} // namespace shprobe
