#include "render/grid.h"

#include "common/error.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <string>

namespace shprobe {

namespace {

Scene panoramaCell(const OffscreenRenderer& renderer, int column) {
    Scene scene;
    scene.camera.projection = Projection::Panorama;
    scene.order = column == 1 ? 3 : 5;
    bool environment = column == 0 && renderer.scene.hasEnvironment;
    bool radiance = column > 0 && renderer.scene.probe.hasRadiance;
    scene.background = environment ? Background::Environment
                       : radiance  ? Background::Radiance
                                   : Background::Shading;
    scene.shading = ShadingMode::Irradiance;
    return scene;
}

// Camera yaw that sees the sphere lit from the side: 90 degrees around +Y from the azimuth of the
// probe's main light (the Rec. 709 luminance of its L1 vector, with the sun's when the probe has
// one), so the lit side, the terminator and the side away from the light, where orders 3 and 5
// differ most, all show.
float sideLitYaw(const ProbeShading& probe) {
    const glm::vec3 luminance(0.2126f, 0.7152f, 0.0722f);
    glm::vec3 light(glm::dot(glm::vec3(probe.l1[1]), luminance), glm::dot(glm::vec3(probe.l1[2]), luminance),
                    glm::dot(glm::vec3(probe.l1[3]), luminance));
    if (probe.sun) {
        // R1 = (1/4pi) int L w over the cap = L pi sin^2(r) d / (4 pi).
        double s = std::sin(probe.sun->angularRadius);
        light += glm::vec3(glm::normalize(probe.sun->direction) *
                           (glm::dot(probe.sun->radiance, glm::dvec3(luminance)) * s * s / 4.0));
    }
    if (glm::length(glm::vec2(light.x, light.z)) < 1e-6f * (1.0f + glm::length(light))) return 0.0f;
    return glm::degrees(std::atan2(light.x, light.z)) + 90.0f;
}

Scene sphereCell(const OffscreenRenderer& renderer, int column) {
    static constexpr ShadingMode kModes[kGridColumns] = {ShadingMode::L1NonLinear, ShadingMode::Irradiance,
                                                         ShadingMode::Irradiance};
    Background background = renderer.scene.hasEnvironment      ? Background::Environment
                            : renderer.scene.probe.hasRadiance ? Background::Radiance
                                                               : Background::Color;
    Camera camera = orbitCamera(sideLitYaw(renderer.scene.probe), 10.0f, 3.0f, 40.0f);
    Scene scene = sphereScene(camera, column == 1 ? 3 : 5, kModes[column], background);
    scene.backgroundColor = glm::vec3(0.05f);
    return scene;
}

// Copies a cell into the grid at pixel (x0, y0).
void placeCell(RenderedImage& grid, const RenderedImage& cell, int x0, int y0) {
    const int gridWidth = grid.linear.width, width = cell.linear.width;
    for (int y = 0; y < cell.linear.height; ++y) {
        size_t from = size_t(y) * width, to = size_t(y0 + y) * gridWidth + x0;
        std::copy_n(cell.linear.texels.begin() + from, width, grid.linear.texels.begin() + to);
        std::copy_n(cell.directions.texels.begin() + from, width, grid.directions.texels.begin() + to);
        std::copy_n(cell.display.begin() + from * 4, width * 4, grid.display.begin() + to * 4);
    }
}

// What a panorama cell shows, in the summary's words.
std::string panoramaName(const Scene& cell) {
    const std::string order = "order-" + std::to_string(cell.order) + " ";
    if (cell.background == Background::Environment) return "environment";
    return order + (cell.background == Background::Radiance ? "radiance" : "E/pi");
}

} // namespace

std::string describeGrid(const OffscreenRenderer& renderer) {
    std::string top;
    for (int column = 0; column < kGridColumns; ++column)
        top += (column ? " | " : "") + panoramaName(panoramaCell(renderer, column));
    return top + "; spheres: l1-nonlinear | irradiance 3 | irradiance 5, in front of the " +
           backgroundName(sphereCell(renderer, 0).background);
}

VkExtent2D gridCellExtent(uint32_t cellWidth) {
    const uint32_t width = std::max(cellWidth, 2u);
    return {width, width / 2};
}

RenderedImage renderGrid(const Context& context, OffscreenRenderer& renderer, const GridOptions& options) {
    if (renderer.scene.probe.order < 5)
        throw Error(ErrorKind::Input,
                    "the grid compares orders 3 and 5: it needs a probe of order 5 or more");
    const auto [width, height] = gridCellExtent(options.cellWidth);
    RenderedImage grid;
    grid.linear = makeImage(int(width) * kGridColumns, int(height) * kGridRows);
    grid.directions = makeImage(grid.linear.width, grid.linear.height);
    grid.display.assign(grid.linear.texels.size() * 4, 0);
    for (int column = 0; column < kGridColumns; ++column) {
        Scene cells[kGridRows] = {panoramaCell(renderer, column), sphereCell(renderer, column)};
        for (int row = 0; row < kGridRows; ++row) {
            RenderedImage cell =
                renderOffscreen(context, renderer, cells[row], {width, height}, options.exposure);
            placeCell(grid, cell, column * int(width), row * int(height));
        }
    }
    return grid;
}

} // namespace shprobe
