// One picture comparing a probe's representations side by side (`shprobe render --grid`):
//
//   +----------------------+----------------------+----------------------+
//   | environment          | order-3 radiance     | order-5 radiance     |  panoramas (equirect)
//   +----------------------+----------------------+----------------------+
//   | sphere, non-linear L1| sphere, order-3 E/pi | sphere, order-5 E/pi |  in front of the environment
//   +----------------------+----------------------+----------------------+
//
// The spheres are seen from 90 degrees around +Y from the probe's main light, lit from the side.
// Without an environment (probe files), the top-left cell shows the order-5 irradiance map (what
// a white surface facing each direction shows) and the spheres stand in front of the order-5
// radiance; irradiance probes, which lack radiance, show irradiance maps instead.
#pragma once
#include "render/offscreen.h"

#include <string>

namespace shprobe {

constexpr int kGridColumns = 3;
constexpr int kGridRows = 2;

struct GridOptions {
    uint32_t cellWidth = 384; // each cell is cellWidth x cellWidth / 2
    float exposure = 1.0f;    // linear, before the display curve
};

// One cell's pixels: cellWidth (at least 2) x half of it. The picture is kGridColumns x kGridRows cells.
VkExtent2D gridCellExtent(uint32_t cellWidth);

// What the cells show, as `render --grid` says it: "environment | order-3 radiance | order-5
// radiance; spheres: ..., in front of the environment", or what stands in for them.
std::string describeGrid(const OffscreenRenderer& renderer);

// The renderer must hold the probe folded at order 5 (and the environment, if any).
RenderedImage renderGrid(const Context& context, OffscreenRenderer& renderer, const GridOptions& options);

} // namespace shprobe
