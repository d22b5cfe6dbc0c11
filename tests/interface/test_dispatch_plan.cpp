// The projections' dispatch plans (src/glsl/dispatch_plan.h: project.comp's and
// project_equirect.comp's) against what shaders/INTERFACE.md states of them. The plan exists once, in the
// header that the baker, the shader's walk and examples/bake_probe share; the document's numbers are the ones
// a reader without the header goes by, so every row of its two tables (maxPositions by order, and the worked
// plans) is recomputed here, and a row that no longer matches the header fails. scripts/example.sh holds the
// example's printed plan to the same table. Then the plan's promises, for any input rather than the
// document's rows: the positions per invocation stay within the loop cap, the groups within
// maxGroups, the walk covers every position, and a bake is refused only when no plan fits.
#undef NDEBUG
#include "glsl/dispatch_plan.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace plan = shprobe::glsl;

std::string readFile(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw std::runtime_error("cannot read " + path);
    std::ostringstream text;
    text << file.rdbuf();
    return text.str();
}

// The cells of a markdown table row, trimmed: "| a | b |" gives {"a", "b"}.
std::vector<std::string> cells(const std::string& line) {
    std::vector<std::string> result;
    std::istringstream stream(line.substr(1));
    for (std::string cell; std::getline(stream, cell, '|');) {
        const size_t first = cell.find_first_not_of(' ');
        const size_t last = cell.find_last_not_of(' ');
        result.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
    }
    return result;
}

// The rows of the markdown table whose header row starts with `header`, below its separator row.
std::vector<std::vector<std::string>> table(const std::string& text, const std::string& header) {
    std::istringstream stream(text);
    std::vector<std::vector<std::string>> rows;
    bool inTable = false, seenSeparator = false;
    for (std::string line; std::getline(stream, line);) {
        if (!inTable) {
            inTable = line.rfind(header, 0) == 0;
            continue;
        }
        if (line.empty() || line[0] != '|') break;
        if (!seenSeparator) {
            seenSeparator = true;
            continue;
        }
        rows.push_back(cells(line));
    }
    if (!inTable) throw std::runtime_error("INTERFACE.md has no table starting " + header);
    return rows;
}

uint32_t number(const std::string& cell) {
    size_t end = 0;
    const unsigned long value = std::stoul(cell, &end);
    if (end != cell.size()) throw std::runtime_error("not a number: " + cell);
    return uint32_t(value);
}

const std::string& document() {
    static const std::string text = readFile(SHPROBE_INTERFACE_DOC);
    return text;
}

// The document with every run of white space as one space, for phrases that may wrap.
std::string flowingText() {
    std::string flowing;
    for (char c : document()) {
        const bool space = c == ' ' || c == '\n';
        if (space && !flowing.empty() && flowing.back() == ' ') continue;
        flowing += space ? ' ' : c;
    }
    return flowing;
}

// Checks: the document's maxPositions and maxEquirectPositions for orders 1 to 8, the loop cap's
// table, are the header's.
TEST(DispatchPlan, LoopCapTableMatchesTheHeader) {
    const auto rows = table(document(), "| order n |");
    ASSERT_EQ(rows.size(), 2u);
    for (const std::vector<std::string>& caps : rows)
        ASSERT_EQ(caps.size(), 9u) << "the cap's name and orders 1 to 8";
    EXPECT_EQ(rows[0][0], "maxPositions");
    EXPECT_EQ(rows[1][0], "maxEquirectPositions");
    for (uint32_t order = 1; order <= 8; ++order) {
        EXPECT_EQ(number(rows[0][order]), plan::maxPositionsPerInvocation(order)) << "order " << order;
        EXPECT_EQ(number(rows[1][order]), plan::maxEquirectPositionsPerInvocation(order))
            << "order " << order;
    }
}

// A projection's positions per probe, texels per position and loop cap, from the size columns of a
// table row and the order.
struct Shape {
    uint32_t positions;
    uint32_t texelsPerPosition;
    uint32_t maxPositions;
};
using ShapeOf = std::function<Shape(const std::vector<uint32_t>& size, uint32_t order)>;

// project.comp's, for an N x N face (size {N}).
Shape cubemapShape(const std::vector<uint32_t>& size, uint32_t order) {
    return {plan::projectionPositions(size[0]), plan::kTexelsPerPosition,
            plan::maxPositionsPerInvocation(order)};
}

// project_equirect.comp's, for a W x H map (size {W, H}).
Shape equirectShape(const std::vector<uint32_t>& size, uint32_t order) {
    return {plan::equirectProjectionPositions(size[0], size[1]), plan::equirectTexelsPerPosition(size[0]),
            plan::maxEquirectPositionsPerInvocation(order)};
}

// Checks every row of a table of worked plans, whose first sizeColumns cells give the size, then n,
// probes, texels per invocation, width, the two device limits, P, maxGroups, maxPositions,
// positions per invocation and groups: from its inputs, the header gives the same P, maxGroups,
// maxPositions, positions per invocation and groups; "0" and "-" where the bake does not fit. The
// table must keep a row for each way the plan can turn out (requested, raised by maxGroups, capped,
// refused).
void expectWorkedPlans(const std::vector<std::vector<std::string>>& rows, size_t sizeColumns,
                       const ShapeOf& shapeOf) {
    ASSERT_GE(rows.size(), 4u);
    bool requested = false, raised = false, capped = false, refused = false;
    for (const std::vector<std::string>& row : rows) {
        std::string line;
        for (const std::string& cell : row)
            line += cell + " ";
        SCOPED_TRACE(line);
        ASSERT_EQ(row.size(), sizeColumns + 11u);
        std::vector<uint32_t> size;
        for (size_t c = 0; c < sizeColumns; ++c)
            size.push_back(number(row[c]));
        const std::vector<std::string> rest(row.begin() + std::ptrdiff_t(sizeColumns), row.end());
        const uint32_t order = number(rest[0]), probes = number(rest[1]);
        const uint32_t texels = number(rest[2]), width = number(rest[3]);
        const uint32_t maxWorkGroupCountX = number(rest[4]), maxStorageBufferRange = number(rest[5]);
        const Shape shape = shapeOf(size, order);
        const uint32_t maxGroups =
            plan::maxGroupsPerProbe(maxWorkGroupCountX, maxStorageBufferRange, order * order * 16u, probes);
        const uint32_t perInvocation = plan::planPositionsOf(shape.positions, shape.texelsPerPosition, texels,
                                                             width, maxGroups, shape.maxPositions);
        EXPECT_EQ(number(rest[6]), shape.positions) << "P";
        EXPECT_EQ(number(rest[7]), maxGroups) << "maxGroups";
        EXPECT_EQ(number(rest[8]), shape.maxPositions) << "maxPositions";
        EXPECT_EQ(number(rest[9]), perInvocation) << "positions per invocation";
        if (perInvocation == 0) {
            EXPECT_EQ(rest[10], "-") << "groups of a bake that does not fit";
            refused = true;
            continue;
        }
        EXPECT_EQ(number(rest[10]), plan::planGroups(shape.positions, perInvocation, width)) << "groups";
        const uint32_t wanted = plan::divideRoundingUp(texels, shape.texelsPerPosition);
        requested |= perInvocation == wanted;
        raised |= perInvocation > wanted;
        capped |= perInvocation < wanted;
    }
    EXPECT_TRUE(requested && raised && capped && refused)
        << "requested " << requested << ", raised by maxGroups " << raised << ", capped " << capped
        << ", refused " << refused;
}

// Checks: every row of the document's worked plans of project.comp (N x N faces), as above, and
// that planPositionsPerInvocation is planPositionsOf with project.comp's shape.
TEST(DispatchPlan, WorkedPlansMatchTheHeader) {
    expectWorkedPlans(table(document(), "| N | n | probes |"), 1,
                      [](const std::vector<uint32_t>& size, uint32_t order) {
                          const Shape shape = cubemapShape(size, order);
                          EXPECT_EQ(plan::planPositionsPerInvocation(shape.positions, 256u, 64u, 65535u,
                                                                     shape.maxPositions),
                                    plan::planPositionsOf(shape.positions, shape.texelsPerPosition, 256u, 64u,
                                                          65535u, shape.maxPositions));
                          return shape;
                      });
}

// Checks: every row of the document's worked plans of project_equirect.comp (W x H maps), as above,
// and that planEquirectPositionsPerInvocation is planPositionsOf with the equirect shape.
TEST(DispatchPlan, WorkedEquirectPlansMatchTheHeader) {
    expectWorkedPlans(table(document(), "| W | H | n | probes |"), 2,
                      [](const std::vector<uint32_t>& size, uint32_t order) {
                          const Shape shape = equirectShape(size, order);
                          EXPECT_EQ(plan::planEquirectPositionsPerInvocation(size[0], size[1], 256u, 64u,
                                                                             65535u, shape.maxPositions),
                                    plan::planPositionsOf(shape.positions, shape.texelsPerPosition, 256u, 64u,
                                                          65535u, shape.maxPositions));
                          return shape;
                      });
}

// Checks: the equirect positions the document states: P = ceil(W / 4) ceil(H / 2) positions of 8
// texels for even W, ceil(W / 2) ceil(H / 2) of 4 for odd W.
TEST(DispatchPlan, EquirectPositionsAreAsStated) {
    for (uint32_t width = 1; width <= 70; ++width)
        for (uint32_t height = 1; height <= 9; ++height) {
            const bool even = width % 2 == 0;
            EXPECT_EQ(plan::equirectProjectionPositions(width, height),
                      (even ? (width + 3) / 4 : (width + 1) / 2) * ((height + 1) / 2))
                << width << " x " << height;
            EXPECT_EQ(plan::equirectTexelsPerPosition(width), even ? 8u : 4u) << width;
        }
    const std::string text = flowingText();
    EXPECT_NE(
        text.find("So `P = ceil(W / 4) ceil(H / 2)` for even W and `ceil(W / 2) ceil(H / 2)` for odd W."),
        std::string::npos);
}

// Checks: the document's defaults and per-position texel count are the header's (the prose gives
// them as numbers: 24 texels, 256 texels per invocation, 11 positions, width 64).
TEST(DispatchPlan, StatedConstantsMatchTheHeader) {
    EXPECT_EQ(plan::kTexelsPerPosition, 24u);
    EXPECT_EQ(plan::kDefaultTexelsPerInvocation, 256u);
    EXPECT_EQ(plan::divideRoundingUp(plan::kDefaultTexelsPerInvocation, plan::kTexelsPerPosition), 11u);
    EXPECT_EQ(plan::kDefaultWorkgroupWidth, 64u);
    const std::string text = flowingText();
    EXPECT_NE(text.find("six faces (24 texels, `kTexelsPerPosition`"), std::string::npos);
    EXPECT_NE(text.find("`texelsPerInvocation = 256` (11 positions per invocation) and a width of 64"),
              std::string::npos);
}

// The promises of a plan for `shape` that gives perInvocation positions per invocation (0: refused):
// within the loop cap, the groups within maxGroups (so within the device's dispatch row and
// storage-buffer range), the shader's walk (positionsPerInvocation) within perInvocation, and the
// groups covering every position; a refusal only when no number of positions per invocation within
// the cap fits maxGroups.
void expectPlanKeepsItsBounds(const Shape& shape, uint32_t width, uint32_t maxGroups,
                              uint64_t slotBytesAllProbes, uint32_t range, uint32_t perInvocation,
                              const std::string& where) {
    if (perInvocation == 0) {
        ASSERT_TRUE(maxGroups == 0 ||
                    plan::planGroups(shape.positions, shape.maxPositions, width) > maxGroups)
            << "refused although the cap fits: " << where;
        return;
    }
    const uint32_t groups = plan::planGroups(shape.positions, perInvocation, width);
    ASSERT_LE(perInvocation, shape.maxPositions) << where;
    ASSERT_GE(groups, 1u) << where;
    ASSERT_LE(groups, maxGroups) << where;
    ASSERT_LE(groups * slotBytesAllProbes, range) << where;
    ASSERT_LE(plan::positionsPerInvocation(shape.positions, groups, width), perInvocation) << where;
    ASSERT_GE(uint64_t(groups) * width * perInvocation, shape.positions) << where;
}

// Checks expectPlanKeepsItsBounds for every size of `sizes`, orders 1..8, 1 to 4096 probes, the
// given texels per invocation and workgroup widths and small to large device limits; exhaustive
// over the grid, which must hold plans and refusals both.
void expectPlansKeepTheirBounds(const std::vector<std::vector<uint32_t>>& sizes, const ShapeOf& shapeOf,
                                std::initializer_list<uint32_t> texelsPerInvocation,
                                std::initializer_list<uint32_t> widths) {
    int plans = 0, refusals = 0;
    for (const std::vector<uint32_t>& size : sizes)
        for (uint32_t order = 1; order <= 8; ++order)
            for (uint32_t probes : {1u, 7u, 256u, 4096u})
                for (uint32_t texels : texelsPerInvocation)
                    for (uint32_t width : widths)
                        for (uint32_t maxWorkGroupCountX : {1u, 65535u, 0x7fffffffu})
                            for (uint32_t range : {1u << 14, 1u << 27, 0xffffffffu}) {
                                const Shape shape = shapeOf(size, order);
                                const uint32_t maxGroups = plan::maxGroupsPerProbe(
                                    maxWorkGroupCountX, range, order * order * 16u, probes);
                                const uint32_t perInvocation =
                                    plan::planPositionsOf(shape.positions, shape.texelsPerPosition, texels,
                                                          width, maxGroups, shape.maxPositions);
                                std::string where = "size";
                                for (uint32_t side : size)
                                    where += " " + std::to_string(side);
                                where += ", order " + std::to_string(order) + ", probes " +
                                         std::to_string(probes) + ", texels " + std::to_string(texels) +
                                         ", width " + std::to_string(width) +
                                         ", maxComputeWorkGroupCount[0] " +
                                         std::to_string(maxWorkGroupCountX) + ", maxStorageBufferRange " +
                                         std::to_string(range);
                                expectPlanKeepsItsBounds(shape, width, maxGroups,
                                                         uint64_t(probes) * order * order * 16u, range,
                                                         perInvocation, where);
                                if (::testing::Test::HasFatalFailure()) return;
                                ++(perInvocation == 0 ? refusals : plans);
                            }
    EXPECT_GT(plans, 0);
    EXPECT_GT(refusals, 0);
}

// Checks, over face sizes 1..4096 (all up to 70, then spread out), texels per invocation 1 to 2^20
// and widths 1 to 1024: project.comp's plan keeps its bounds (expectPlanKeepsItsBounds).
TEST(DispatchPlan, PlansKeepTheirBoundsAndRefuseOnlyWhatCannotFit) {
    std::vector<std::vector<uint32_t>> faceSizes;
    for (uint32_t n = 1; n <= 70; ++n)
        faceSizes.push_back({n});
    for (uint32_t n : {127u, 128u, 255u, 511u, 1000u, 1024u, 2047u, 2048u, 4095u, 4096u})
        faceSizes.push_back({n});
    expectPlansKeepTheirBounds(faceSizes, cubemapShape, {1u, 24u, 25u, 256u, 4096u, 1u << 20},
                               {1u, 3u, 32u, 64u, 1024u});
}

// Checks, over equirect maps (widths 1..70 and up to 16384, heights from 1 up to 8192), texels per
// invocation 1 to 2^20 and widths 1 to 1024: project_equirect.comp's plan keeps the same bounds.
TEST(DispatchPlan, EquirectPlansKeepTheirBoundsAndRefuseOnlyWhatCannotFit) {
    std::vector<std::vector<uint32_t>> sizes;
    for (uint32_t w = 1; w <= 70; ++w)
        sizes.push_back({w, (w + 1) / 2});
    for (const auto& [w, h] :
         {std::pair{1u, 1u}, std::pair{3u, 1u}, std::pair{1u, 5u}, std::pair{1023u, 511u},
          std::pair{2048u, 1024u}, std::pair{4095u, 2048u}, std::pair{16384u, 8192u}})
        sizes.push_back({w, h});
    expectPlansKeepTheirBounds(sizes, equirectShape, {1u, 8u, 9u, 256u, 1u << 20}, {1u, 3u, 64u, 1024u});
}

// Checks: the rounding-up division is exact at the edges of 32-bit numbers, where (a + b - 1) / b
// would overflow.
TEST(DispatchPlan, DivisionRoundsUpWithoutOverflow) {
    EXPECT_EQ(plan::divideRoundingUp(0u, 7u), 0u);
    EXPECT_EQ(plan::divideRoundingUp(7u, 7u), 1u);
    EXPECT_EQ(plan::divideRoundingUp(8u, 7u), 2u);
    EXPECT_EQ(plan::divideRoundingUp(0xffffffffu, 0x7fffffffu), 3u);
    EXPECT_EQ(plan::divideRoundingUp(0xffffffffu, 1u), 0xffffffffu);
    EXPECT_EQ(plan::divideRoundingUp(0xfffffffeu, 0xffffffffu), 1u);
}

} // namespace
