#include "scene/probe_grid.h"

#include "common/error.h"
#include "common/short_number.h"
#include "scene/surface_shading.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <string_view>
#include <vector>

namespace shprobe {

namespace {

const char* kAxes = "xyz";

[[noreturn]] void fail(const std::string& problem) {
    throw Error(ErrorKind::Input, problem);
}

// "a,b,,c" -> {"a", "b", "", "c"}: empty items are kept, and refused as numbers.
std::vector<std::string_view> splitCommas(std::string_view text) {
    std::vector<std::string_view> items;
    for (size_t start = 0;;) {
        size_t comma = text.find(',', start);
        items.push_back(text.substr(start, comma == std::string_view::npos ? comma : comma - start));
        if (comma == std::string_view::npos) return items;
        start = comma + 1;
    }
}

// The whole of `text` as a number: no sign '+', no spaces, nothing after it.
template <class Number> bool parseNumber(std::string_view text, Number& value) {
    auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    return error == std::errc() && end == text.data() + text.size();
}

std::string quoted(const std::string& option, const std::string& text) {
    return option + ": '" + text + "'";
}

} // namespace

glm::ivec3 parseGridCounts(const std::string& text) {
    std::vector<std::string_view> items = splitCommas(text);
    if (items.size() != 3) fail(quoted("--grid", text) + " needs 3 counts NX,NY,NZ");
    ProbeGrid grid{{}, glm::dvec3(0.0), glm::dvec3(1.0)}; // unit bounds: only the counts are checked
    for (int a = 0; a < 3; ++a) {
        int64_t count = 0;
        if (!parseNumber(items[size_t(a)], count))
            fail(quoted("--grid", text) + " is not 3 whole numbers NX,NY,NZ");
        if (count < 1) fail(quoted("--grid", text) + ": the count along " + kAxes[a] + " must be at least 1");
        if (count > int64_t(kMaxGridProbes))
            fail(quoted("--grid", text) + " has more than " + std::to_string(kMaxGridProbes) + " probes");
        grid.counts[a] = int(count);
    }
    checkProbeGrid(grid, "--grid"); // their product
    return grid.counts;
}

GridBounds parseGridBounds(const std::string& text) {
    std::vector<std::string_view> items = splitCommas(text);
    if (items.size() != 6) fail(quoted("--bounds", text) + " needs 6 numbers X0,Y0,Z0,X1,Y1,Z1");
    double values[6];
    for (size_t n = 0; n < 6; ++n) {
        auto [end, error] = std::from_chars(items[n].data(), items[n].data() + items[n].size(), values[n]);
        if (end != items[n].data() + items[n].size() ||
            (error != std::errc() && error != std::errc::result_out_of_range))
            fail(quoted("--bounds", text) + " is not a list of 6 numbers X0,Y0,Z0,X1,Y1,Z1");
        if (error == std::errc::result_out_of_range || !std::isfinite(values[n]))
            fail(quoted("--bounds", text) + " holds a value that is not finite");
        // As far as the scene's own coordinates may reach (checkSceneScale): beyond, a probe's rays
        // are past what the ray tests hold.
        if (std::abs(values[n]) > kMaxSceneCoordinate)
            fail(quoted("--bounds", text) + " reaches " + std::string(items[n]) + ", beyond the " +
                 shortNumber(kMaxSceneCoordinate) + " a probe's rays hold");
    }
    GridBounds bounds{{values[0], values[1], values[2]}, {values[3], values[4], values[5]}};
    for (int a = 0; a < 3; ++a)
        if (bounds.min[a] > bounds.max[a])
            fail(quoted("--bounds", text) + ": the minimum corner comes first, but " + char('X' + a) +
                 "0 > " + char('X' + a) + "1");
    return bounds;
}

ProbeGrid makeProbeGrid(const glm::ivec3& counts, const GridBounds& bounds) {
    ProbeGrid grid{counts, bounds.min, bounds.max};
    checkProbeGrid(grid, "--grid/--bounds");
    return grid;
}

ProbeGrid probeGridInWorld(const glm::ivec3& counts, const World& world) {
    if (world.triangleCount() == 0) fail(world.description + ": the scene has no triangles; give --bounds");
    checkSceneScale(world); // a scale the rays cannot hold first: its box may look flat only by rounding
    GridBounds bounds;
    for (int a = 0; a < 3; ++a) {
        const double low = world.boundsMin[a], high = world.boundsMax[a];
        if (!(low < high) || !std::isfinite(high - low))
            fail(world.description + ": the scene is flat along " + kAxes[a] +
                 "; give --bounds to place the probes");
        const double halfCell = (high - low) / (2.0 * counts[a]);
        // A single probe: both ends at the middle itself, which low + half and high - half might
        // miss by a rounding each, in opposite directions.
        bounds.min[a] = counts[a] == 1 ? low + 0.5 * (high - low) : low + halfCell;
        bounds.max[a] = counts[a] == 1 ? bounds.min[a] : high - halfCell;
    }
    return makeProbeGrid(counts, bounds);
}

glm::dvec3 probePosition(const ProbeGrid& grid, const glm::ivec3& cell) {
    glm::dvec3 position;
    for (int a = 0; a < 3; ++a) {
        const double low = grid.boundsMin[a], high = grid.boundsMax[a];
        if (grid.counts[a] == 1) {
            position[a] = low + 0.5 * (high - low);
            continue;
        }
        // (1 - t) low + t high: exactly low at t = 0 and exactly high at t = 1.
        const double t = double(cell[a]) / double(grid.counts[a] - 1);
        position[a] = (1.0 - t) * low + t * high;
    }
    return position;
}

uint32_t probeIndex(const ProbeGrid& grid, const glm::ivec3& cell) {
    return uint32_t(cell.x) +
           uint32_t(grid.counts.x) * (uint32_t(cell.y) + uint32_t(grid.counts.y) * uint32_t(cell.z));
}

glm::ivec3 probeCell(const ProbeGrid& grid, uint32_t index) {
    const uint32_t nx = uint32_t(grid.counts.x), ny = uint32_t(grid.counts.y);
    return {int(index % nx), int(index / nx % ny), int(index / (nx * ny))};
}

glm::dvec3 gridCoordinates(const ProbeGrid& grid, const glm::dvec3& position) {
    glm::dvec3 coordinates(0.0);
    for (int a = 0; a < 3; ++a) {
        if (grid.counts[a] == 1) continue;
        const double last = double(grid.counts[a] - 1);
        const double u = (position[a] - grid.boundsMin[a]) / (grid.boundsMax[a] - grid.boundsMin[a]) * last;
        coordinates[a] = std::clamp(u, 0.0, last);
    }
    return coordinates;
}

double smallestCellEdge(const ProbeGrid& grid) {
    double edge = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        if (grid.counts[a] > 1)
            edge = std::min(edge, (grid.boundsMax[a] - grid.boundsMin[a]) / (grid.counts[a] - 1));
    }
    return std::isfinite(edge) ? edge : 0.0;
}

Brick parseBrick(const std::string& text) {
    const size_t slash = text.find('/');
    uint64_t index = 0, count = 0;
    if (slash == std::string::npos || !parseNumber(std::string_view(text).substr(0, slash), index) ||
        !parseNumber(std::string_view(text).substr(slash + 1), count))
        fail(quoted("--brick", text) + " is not I/N (brick I of N, numbered from 0)");
    if (count < 1 || count > kMaxGridProbes)
        fail(quoted("--brick", text) + ": N must be from 1 to " + std::to_string(kMaxGridProbes));
    if (index >= count)
        fail(quoted("--brick", text) + ": bricks are numbered from 0, so I runs from 0 to " +
             std::to_string(count - 1));
    return {uint32_t(index), uint32_t(count)};
}

ProbeRange brickRange(const ProbeGrid& grid, const Brick& brick) {
    const uint64_t total = grid.probeCount();
    const std::string name = "--brick " + std::to_string(brick.index) + "/" + std::to_string(brick.count);
    if (brick.count < 1 || brick.index >= brick.count) fail(name + ": not a brick (I must be below N)");
    if (brick.count > total)
        fail(name + ": the grid has " + std::to_string(total) + " probes, fewer than " +
             std::to_string(brick.count) + " bricks (" + std::to_string(total) + " at most)");
    // T <= 2^24 and N <= T: the products fit 64 bits.
    return {uint32_t(brick.index * total / brick.count),
            uint32_t((brick.index + 1ull) * total / brick.count)};
}

std::vector<glm::dvec3> probePositions(const ProbeGrid& grid, ProbeRange range) {
    std::vector<glm::dvec3> positions;
    for (uint32_t p = range.begin; p < range.end; ++p)
        positions.push_back(probePosition(grid, probeCell(grid, p)));
    return positions;
}

} // namespace shprobe
