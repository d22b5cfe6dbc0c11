// project.comp's dispatch plan (shaders/include/dispatch_plan.h) against what shaders/INTERFACE.md
// states of it. The plan exists once, in the header that the baker, the shader's walk and
// examples/bake_probe share; the document's numbers are the ones a reader without the header goes
// by, so every row of its two tables (maxPositions by order, and the worked plans) is recomputed
// here, and a row that no longer matches the header fails. scripts/example.sh holds the example's
// printed plan to the same table. Then the plan's promises, for any input rather than the
// document's rows: the positions per invocation stay within the loop cap, the groups within
// maxGroups, the walk covers every position, and a bake is refused only when no plan fits.
#undef NDEBUG
#include "shprobe/glsl/dispatch_plan.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace plan = shprobe::gpu;

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

// Checks: the document's maxPositions for orders 1 to 8, the loop cap's table, are the header's.
TEST(DispatchPlan, LoopCapTableMatchesTheHeader) {
    const auto rows = table(document(), "| order n |");
    ASSERT_EQ(rows.size(), 1u);
    const std::vector<std::string>& caps = rows[0];
    ASSERT_EQ(caps.size(), 9u) << "maxPositions and orders 1 to 8";
    EXPECT_EQ(caps[0], "maxPositions");
    for (uint32_t order = 1; order <= 8; ++order)
        EXPECT_EQ(number(caps[order]), plan::maxPositionsPerInvocation(order)) << "order " << order;
}

// Checks: every row of the document's worked plans, from its inputs (N, order, probes, texels per
// invocation, width and the two device limits), gives the header's P, maxGroups, maxPositions,
// positions per invocation and groups; "0" and "-" where the bake does not fit. The table must
// keep a row for each way the plan can turn out (requested, raised by maxGroups, capped, refused).
TEST(DispatchPlan, WorkedPlansMatchTheHeader) {
    const auto rows = table(document(), "| N | n | probes |");
    ASSERT_GE(rows.size(), 4u);
    bool requested = false, raised = false, capped = false, refused = false;
    for (const std::vector<std::string>& row : rows) {
        std::string line;
        for (const std::string& cell : row)
            line += cell + " ";
        SCOPED_TRACE(line);
        ASSERT_EQ(row.size(), 12u);
        const uint32_t faceSize = number(row[0]), order = number(row[1]), probes = number(row[2]);
        const uint32_t texels = number(row[3]), width = number(row[4]);
        const uint32_t maxWorkGroupCountX = number(row[5]), maxStorageBufferRange = number(row[6]);
        const uint32_t positions = plan::projectionPositions(faceSize);
        const uint32_t maxGroups =
            plan::maxGroupsPerProbe(maxWorkGroupCountX, maxStorageBufferRange, order * order * 16u, probes);
        const uint32_t maxPositions = plan::maxPositionsPerInvocation(order);
        const uint32_t perInvocation =
            plan::planPositionsPerInvocation(positions, texels, width, maxGroups, maxPositions);
        EXPECT_EQ(number(row[7]), positions) << "P";
        EXPECT_EQ(number(row[8]), maxGroups) << "maxGroups";
        EXPECT_EQ(number(row[9]), maxPositions) << "maxPositions";
        EXPECT_EQ(number(row[10]), perInvocation) << "positions per invocation";
        if (perInvocation == 0) {
            EXPECT_EQ(row[11], "-") << "groups of a bake that does not fit";
            refused = true;
            continue;
        }
        EXPECT_EQ(number(row[11]), plan::planGroups(positions, perInvocation, width)) << "groups";
        const uint32_t wanted = plan::divideRoundingUp(texels, plan::kTexelsPerPosition);
        requested |= perInvocation == wanted;
        raised |= perInvocation > wanted;
        capped |= perInvocation < wanted;
    }
    EXPECT_TRUE(requested && raised && capped && refused)
        << "requested " << requested << ", raised by maxGroups " << raised << ", capped " << capped
        << ", refused " << refused;
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

// Checks, over face sizes 1..4096 (all up to 70, then spread out), orders 1..8, 1 to 4096 probes,
// texels per invocation 1 to 2^20, widths 1 to 1024 and small to large device limits: when the plan
// gives positions, they are within the loop cap, the groups within maxGroups (so within the device's
// dispatch row and storage-buffer range), the shader's walk (positionsPerInvocation) stays within
// the plan's positions per invocation, and the groups cover every position; when it refuses, no
// number of positions per invocation within the cap fits maxGroups. Exhaustive over the grid.
TEST(DispatchPlan, PlansKeepTheirBoundsAndRefuseOnlyWhatCannotFit) {
    std::vector<uint32_t> faceSizes;
    for (uint32_t n = 1; n <= 70; ++n)
        faceSizes.push_back(n);
    for (uint32_t n : {127u, 128u, 255u, 511u, 1000u, 1024u, 2047u, 2048u, 4095u, 4096u})
        faceSizes.push_back(n);
    int plans = 0, refusals = 0;
    for (uint32_t faceSize : faceSizes)
        for (uint32_t order = 1; order <= 8; ++order)
            for (uint32_t probes : {1u, 7u, 256u, 4096u})
                for (uint32_t texels : {1u, 24u, 25u, 256u, 4096u, 1u << 20})
                    for (uint32_t width : {1u, 3u, 32u, 64u, 1024u})
                        for (uint32_t maxWorkGroupCountX : {1u, 65535u, 0x7fffffffu})
                            for (uint32_t range : {1u << 14, 1u << 27, 0xffffffffu}) {
                                const uint32_t positions = plan::projectionPositions(faceSize);
                                const uint32_t maxGroups = plan::maxGroupsPerProbe(
                                    maxWorkGroupCountX, range, order * order * 16u, probes);
                                const uint32_t cap = plan::maxPositionsPerInvocation(order);
                                const uint32_t perInvocation = plan::planPositionsPerInvocation(
                                    positions, texels, width, maxGroups, cap);
                                const auto where = [&] {
                                    return "N " + std::to_string(faceSize) + ", order " +
                                           std::to_string(order) + ", probes " + std::to_string(probes) +
                                           ", texels " + std::to_string(texels) + ", width " +
                                           std::to_string(width) + ", maxComputeWorkGroupCount[0] " +
                                           std::to_string(maxWorkGroupCountX) + ", maxStorageBufferRange " +
                                           std::to_string(range);
                                };
                                if (perInvocation == 0) {
                                    ++refusals;
                                    ASSERT_TRUE(maxGroups == 0 ||
                                                plan::planGroups(positions, cap, width) > maxGroups)
                                        << "refused although the cap fits: " << where();
                                    continue;
                                }
                                ++plans;
                                const uint32_t groups = plan::planGroups(positions, perInvocation, width);
                                ASSERT_LE(perInvocation, cap) << where();
                                ASSERT_GE(groups, 1u) << where();
                                ASSERT_LE(groups, maxGroups) << where();
                                ASSERT_LE(uint64_t(probes) * groups * order * order * 16u, range) << where();
                                ASSERT_LE(plan::positionsPerInvocation(positions, groups, width),
                                          perInvocation)
                                    << where();
                                ASSERT_GE(uint64_t(groups) * width * perInvocation, positions) << where();
                            }
    EXPECT_GT(plans, 0);
    EXPECT_GT(refusals, 0);
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
