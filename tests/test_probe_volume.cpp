// Probe grids, probe-volume files, bricks and their merge, and trilinear sampling
// (docs/probe-volume.md): where the probes are, that every malformed option and file is refused
// with its own message, that bricks cover a grid exactly once and merge to the whole bake bit for
// bit, and that sampling reproduces what trilinear interpolation must reproduce exactly.
#include "common/content_hash.h"
#include "common/error.h"
#include "formats/probe_volume.h"
#include "scene/probe_grid.h"
#include "scene/volume_sampling.h"
#include "sh/basis.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <unistd.h>

namespace shprobe {
namespace {

using nlohmann::ordered_json;

// ---- Helpers -----------------------------------------------------------------------------------

// Expects call to throw Error(Input) whose message contains `expected`; returns the message.
std::string expectInputError(const std::function<void()>& call, const std::string& expected) {
    try {
        call();
    } catch (const Error& error) {
        EXPECT_EQ(error.kind(), ErrorKind::Input) << error.what();
        EXPECT_NE(std::string(error.what()).find(expected), std::string::npos)
            << "message: " << error.what() << "\nexpected to contain: " << expected;
        return error.what();
    }
    ADD_FAILURE() << "no error; expected one containing: " << expected;
    return "";
}

// Same bits, not merely equal values: -0 and 0 differ, as they would in the files.
bool sameBits(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
    // An empty vector's data() may be null, which memcmp may not be given even for 0 bytes.
    return a.size() == b.size() &&
           (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(glm::vec3)) == 0);
}

void expectSameVolume(const ProbeVolume& a, const ProbeVolume& b) {
    EXPECT_EQ(a.grid.counts, b.grid.counts);
    EXPECT_EQ(a.grid.boundsMin, b.grid.boundsMin);
    EXPECT_EQ(a.grid.boundsMax, b.grid.boundsMax);
    EXPECT_EQ(a.order, b.order);
    EXPECT_EQ(a.begin, b.begin);
    EXPECT_EQ(a.end, b.end);
    EXPECT_TRUE(sameBits(a.radiance, b.radiance));
    EXPECT_TRUE(sameBits(a.irradiance, b.irradiance));
    EXPECT_EQ(a.valid, b.valid);
    EXPECT_TRUE(sameBits(a.offsets, b.offsets));
    EXPECT_TRUE(sameBits(a.staticRadiance, b.staticRadiance));
    EXPECT_TRUE(sameBits(a.transfer, b.transfer));
    EXPECT_EQ(a.bounces, b.bounces);
    EXPECT_EQ(a.source, b.source);
    EXPECT_EQ(a.sourceHash, b.sourceHash);
    EXPECT_EQ(a.skySource, b.skySource);
    EXPECT_EQ(a.settings, b.settings);
}

ProbeGrid testGrid(glm::ivec3 counts) {
    return ProbeGrid{counts, {-2.0, 0.25, 1.0}, {4.0, 3.0, 5.5}};
}

// A whole volume whose coefficients all differ (and are not round numbers, so that a swapped or
// shifted value shows); every fifth probe is invalid and holds zeros, as a written file has them.
ProbeVolume sampleVolume(const ProbeGrid& grid, int order, bool radiance = true, bool irradiance = true) {
    ProbeVolume volume;
    volume.grid = grid;
    volume.order = order;
    volume.end = grid.probeCount();
    volume.bounces = 2;
    volume.source = "room.glb (12 triangles, 1 material, 1 sun)";
    volume.sourceHash = "fnv1a64:0123456789abcdef";
    volume.skySource = "sky.exr (equirect 64x32)";
    volume.settings = R"({"face_size":32,"sky":"uniform 1,1,1"})";
    const size_t perProbe = size_t(coefficientCount(order));
    volume.valid.resize(volume.end);
    for (uint32_t p = 0; p < volume.end; ++p)
        volume.valid[p] = p % 5 != 3;
    auto fill = [&](std::vector<glm::vec3>& coefficients, float offset) {
        coefficients.resize(volume.end * perProbe);
        for (size_t i = 0; i < coefficients.size(); ++i) {
            const bool valid = volume.valid[i / perProbe];
            const float v = offset + 0.0137f * float(i);
            coefficients[i] = valid ? glm::vec3(v, -v / 3.0f, 1e-7f * v) : glm::vec3(0.0f);
        }
    };
    if (radiance) fill(volume.radiance, 0.5f);
    if (irradiance) fill(volume.irradiance, -1.25f);
    return volume;
}

// The probes [begin, end) of a whole volume, as the bake of one brick makes them.
ProbeVolume sliceOf(const ProbeVolume& whole, ProbeRange range) {
    ProbeVolume brick = whole;
    const size_t perProbe = size_t(coefficientCount(whole.order));
    brick.begin = range.begin;
    brick.end = range.end;
    auto slice = [&](const std::vector<glm::vec3>& all, size_t valuesPerProbe = 0) {
        if (all.empty()) return std::vector<glm::vec3>();
        const size_t per = valuesPerProbe > 0 ? valuesPerProbe : perProbe;
        return std::vector<glm::vec3>(all.begin() + range.begin * per, all.begin() + range.end * per);
    };
    brick.radiance = slice(whole.radiance);
    brick.irradiance = slice(whole.irradiance);
    brick.staticRadiance = slice(whole.staticRadiance);
    brick.transfer = slice(whole.transfer, perProbe * perProbe);
    brick.valid.assign(whole.valid.begin() + range.begin, whole.valid.begin() + range.end);
    if (!whole.offsets.empty())
        brick.offsets.assign(whole.offsets.begin() + range.begin, whole.offsets.begin() + range.end);
    return brick;
}

class TempFolder {
  public:
    TempFolder() {
        static int made = 0; // folders may nest in time: each has its own name
        path_ = std::filesystem::temp_directory_path() /
                ("shprobe_test_volume_" + std::to_string(getpid()) + "_" + std::to_string(made++));
        std::filesystem::create_directories(path_);
    }
    ~TempFolder() { std::filesystem::remove_all(path_); }
    std::string file(const std::string& name) const { return (path_ / name).string(); }

  private:
    std::filesystem::path path_;
};

std::string fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string volumeBytes(const ProbeVolume& volume) {
    TempFolder folder;
    writeProbeVolume(folder.file("volume.shpv"), volume);
    return fileBytes(folder.file("volume.shpv"));
}

uint64_t headerLength(const std::string& bytes) {
    uint64_t length = 0;
    for (int i = 0; i < 8; ++i)
        length |= uint64_t(uint8_t(bytes[size_t(8 + i)])) << (8 * i);
    return length;
}

ordered_json headerOf(const std::string& bytes) {
    return ordered_json::parse(bytes.substr(16, headerLength(bytes)));
}

// The file with its header edited and the payload kept, laid out as docs/probe-volume.md says
// (written here independently of the library's writer): magic, length, header padded with spaces
// to a multiple of 16, payload.
std::string withHeader(const std::string& bytes, const std::function<void(ordered_json&)>& edit) {
    ordered_json header = headerOf(bytes);
    edit(header);
    std::string text = header.dump() + "\n";
    text.insert(text.size() - 1, (16 - text.size() % 16) % 16, ' ');
    std::string out = bytes.substr(0, 8);
    for (int i = 0; i < 8; ++i)
        out.push_back(char((uint64_t(text.size()) >> (8 * i)) & 0xffu));
    return out + text + bytes.substr(16 + headerLength(bytes));
}

// ---- Grids -------------------------------------------------------------------------------------

// Corners-inclusive placement: the first and last probes are the bounds themselves, bit for bit
// ((1 - t) a + t b is exact at t = 0 and 1); interior probes are evenly spaced, to rounding.
TEST(ProbeGrid, ProbesIncludeTheCorners) {
    const ProbeGrid grid = testGrid({4, 3, 2});
    EXPECT_EQ(probePosition(grid, {0, 0, 0}), grid.boundsMin);
    EXPECT_EQ(probePosition(grid, {3, 2, 1}), grid.boundsMax);
    const glm::dvec3 inner = probePosition(grid, {1, 1, 0});
    EXPECT_NEAR(inner.x, 0.0, 1e-15);   // -2 + 6 / 3
    EXPECT_NEAR(inner.y, 1.625, 1e-15); // 0.25 + 2.75 / 2
    EXPECT_EQ(inner.z, grid.boundsMin.z);
}

// An axis of one probe holds it at the middle of the bounds, whatever the bounds' extent.
TEST(ProbeGrid, ASingleProbeAxisIsAtTheCentre) {
    const ProbeGrid grid{{1, 3, 1}, {0.0, 0.0, 0.0}, {2.0, 4.0, 6.0}};
    for (int j = 0; j < 3; ++j) {
        const glm::dvec3 p = probePosition(grid, {0, j, 0});
        EXPECT_EQ(p.x, 1.0);
        EXPECT_EQ(p.y, 2.0 * j);
        EXPECT_EQ(p.z, 3.0);
    }
}

TEST(ProbeGrid, FlatIndexIsXFastest) {
    const ProbeGrid grid = testGrid({3, 4, 5});
    EXPECT_EQ(grid.probeCount(), 60u);
    for (int k = 0; k < 5; ++k)
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 3; ++i) {
                const uint32_t index = probeIndex(grid, {i, j, k});
                EXPECT_EQ(index, uint32_t(i + 3 * (j + 4 * k)));
                EXPECT_EQ(probeCell(grid, index), glm::ivec3(i, j, k));
            }
}

// gridCoordinates inverts probePosition (to rounding of a division: 1e-12 cells) and clamps
// positions outside the bounds to the nearest face.
TEST(ProbeGrid, GridCoordinatesInvertPositionsAndClamp) {
    const ProbeGrid grid = testGrid({4, 3, 2});
    for (uint32_t index = 0; index < grid.probeCount(); ++index) {
        const glm::ivec3 cell = probeCell(grid, index);
        const glm::dvec3 u = gridCoordinates(grid, probePosition(grid, cell));
        for (int a = 0; a < 3; ++a)
            EXPECT_NEAR(u[a], cell[a], 1e-12) << "probe " << index;
    }
    EXPECT_EQ(gridCoordinates(grid, {-100.0, 1e9, 5.5}), glm::dvec3(0.0, 2.0, 1.0));
    EXPECT_EQ(gridCoordinates(ProbeGrid{{1, 1, 1}, {}, {}}, {3.0, 4.0, 5.0}), glm::dvec3(0.0));
}

TEST(ProbeGrid, ParsesGridAndBoundsOptions) {
    EXPECT_EQ(parseGridCounts("4,1,256"), glm::ivec3(4, 1, 256));
    const GridBounds bounds = parseGridBounds("-1.5,0,2e1,3,0,20");
    EXPECT_EQ(bounds.min, glm::dvec3(-1.5, 0.0, 20.0));
    EXPECT_EQ(bounds.max, glm::dvec3(3.0, 0.0, 20.0));
    const ProbeGrid grid = makeProbeGrid({2, 1, 1}, bounds); // flat along y and z, one probe each
    EXPECT_EQ(grid.probeCount(), 2u);
}

// Each malformed option gives its own message, naming the option and the text given.
TEST(ProbeGrid, MalformedOptionsAreRefusedWithTheirReason) {
    const std::pair<const char*, const char*> grids[] = {
        {"4,4", "--grid: '4,4' needs 3 counts NX,NY,NZ"},
        {"4,4,4,4", "needs 3 counts"},
        {"4,a,4", "is not 3 whole numbers"},
        {"4,,4", "is not 3 whole numbers"},
        {"4, 4,4", "is not 3 whole numbers"},
        {"4,+4,4", "is not 3 whole numbers"},
        {"4,4.0,4", "is not 3 whole numbers"},
        {"4,0,4", "the count along y must be at least 1"},
        {"4,4,-2", "the count along z must be at least 1"},
        {"99999999999999999999,1,1", "is not 3 whole numbers"},
        {"16777217,1,1", "more than 16777216 probes"},
        {"512,256,256", "the grid 512x256x256 has more than 16777216 probes"},
        {"", "needs 3 counts"},
    };
    for (const auto& [text, message] : grids)
        expectInputError([text = text] { parseGridCounts(text); }, message);

    const std::pair<const char*, const char*> bounds[] = {
        {"0,0,0,1,1", "--bounds: '0,0,0,1,1' needs 6 numbers X0,Y0,Z0,X1,Y1,Z1"},
        {"0,0,0,1,1,x", "is not a list of 6 numbers"},
        {"0,0,0,1,1,1 ", "is not a list of 6 numbers"},
        {"0,0,0,1,inf,1", "holds a value that is not finite"},
        {"0,0,nan,1,1,1", "holds a value that is not finite"},
        {"0,0,0,1,1e999,1", "holds a value that is not finite"},
        {"0,2,0,1,1,1", "the minimum corner comes first, but Y0 > Y1"},
    };
    for (const auto& [text, message] : bounds)
        expectInputError([text = text] { parseGridBounds(text); }, message);

    expectInputError(
        [] {
            makeProbeGrid({2, 3, 2}, {{0, 1, 0}, {1, 1, 1}});
        },
        "--grid/--bounds: the grid's bounds are flat along y (at 1.0) but it has 3 probes along y");
}

World boxWorld(glm::vec3 low, glm::vec3 high) {
    World world;
    world.positions = {low, high, {low.x, high.y, low.z}};
    world.normals.assign(3, glm::vec3(0.0f, 0.0f, 1.0f));
    world.uvs.assign(3, glm::vec2(0.0f));
    world.indices = {0, 1, 2};
    world.triangleMaterials = {0};
    world.materials.resize(1);
    world.boundsMin = low;
    world.boundsMax = high;
    world.description = "box.glb";
    return world;
}

// Without --bounds, probes sit at the centres of the world box's cells: half a cell in from every
// side (0.5 of 1 along x, 2 of 4 along z), a single probe at the middle. All values are dyadic,
// so the positions are exact.
TEST(ProbeGrid, WorldBoundsAreInsetByHalfACell) {
    const ProbeGrid grid = probeGridInWorld({4, 1, 2}, boxWorld({0.0f, -1.0f, 0.0f}, {4.0f, 2.0f, 8.0f}));
    EXPECT_EQ(grid.boundsMin, glm::dvec3(0.5, 0.5, 2.0));
    EXPECT_EQ(grid.boundsMax, glm::dvec3(3.5, 0.5, 6.0));
    EXPECT_EQ(probePosition(grid, {3, 0, 1}), glm::dvec3(3.5, 0.5, 6.0));

    expectInputError(
        [] {
            probeGridInWorld({2, 2, 2}, boxWorld({0, 0, 0}, {1, 0, 1}));
        },
        "box.glb: the scene is flat along y; give --bounds");
    World empty;
    empty.description = "empty.glb";
    expectInputError([&] { probeGridInWorld({2, 2, 2}, empty); }, "empty.glb: the scene has no triangles");
}

// ---- Bricks ------------------------------------------------------------------------------------

TEST(Bricks, ParseIAndNFromZero) {
    const Brick first = parseBrick("0/1");
    EXPECT_EQ(first.index, 0u);
    EXPECT_EQ(first.count, 1u);
    const Brick last = parseBrick("3/4");
    EXPECT_EQ(last.index, 3u);
    EXPECT_EQ(last.count, 4u);

    const std::pair<const char*, const char*> cases[] = {
        {"4/4", "--brick: '4/4': bricks are numbered from 0, so I runs from 0 to 3"},
        {"1/0", "N must be from 1 to 16777216"},
        {"0/16777217", "N must be from 1 to 16777216"},
        {"3", "is not I/N (brick I of N, numbered from 0)"},
        {"-1/4", "is not I/N"},
        {"1/4/2", "is not I/N"},
        {" 1/4", "is not I/N"},
        {"1/", "is not I/N"},
        {"", "is not I/N"},
    };
    for (const auto& [text, message] : cases)
        expectInputError([text = text] { parseBrick(text); }, message);
}

// For every grid of 1 to 60 probes and every brick count up to the probe count, the bricks follow
// each other from probe 0 to the last, and their sizes differ by one at most.
TEST(Bricks, CoverTheGridOnceWithSizesWithinOne) {
    for (int total = 1; total <= 60; ++total) {
        const ProbeGrid grid = testGrid({total, 1, 1});
        for (uint32_t count = 1; count <= uint32_t(total); ++count) {
            uint32_t next = 0, smallest = UINT32_MAX, largest = 0;
            for (uint32_t index = 0; index < count; ++index) {
                const ProbeRange range = brickRange(grid, {index, count});
                ASSERT_EQ(range.begin, next) << total << " probes, brick " << index << "/" << count;
                ASSERT_GT(range.end, range.begin);
                smallest = std::min(smallest, range.end - range.begin);
                largest = std::max(largest, range.end - range.begin);
                next = range.end;
            }
            EXPECT_EQ(next, uint32_t(total));
            EXPECT_LE(largest - smallest, 1u);
        }
    }
    // The largest grid: the products stay exact.
    const ProbeGrid big = testGrid({256, 256, 256});
    EXPECT_EQ(brickRange(big, {6, 7}).end, big.probeCount());
    EXPECT_EQ(brickRange(big, {0, 7}).end, 2396745u); // floor(2^24 / 7)
}

TEST(Bricks, MoreBricksThanProbesAreRefused) {
    expectInputError(
        [] {
            brickRange(testGrid({2, 2, 1}), {0, 5});
        },
        "--brick 0/5: the grid has 4 probes, fewer than 5 bricks (4 at most)");
}

// ---- Volume files ------------------------------------------------------------------------------

// What is written reads back bit for bit, for every order and each set of quantities.
TEST(ProbeVolumeFile, RoundTripsBitForBit) {
    TempFolder folder;
    const std::string path = folder.file("volume.shpv");
    for (int order = 1; order <= kMaxOrder; ++order)
        for (auto [radiance, irradiance] : {std::pair{true, true}, {true, false}, {false, true}}) {
            const ProbeVolume volume = sampleVolume(testGrid({3, 2, 2}), order, radiance, irradiance);
            writeProbeVolume(path, volume);
            SCOPED_TRACE("order " + std::to_string(order) + (radiance ? " radiance" : "") +
                         (irradiance ? " irradiance" : ""));
            expectSameVolume(readProbeVolume(path), volume);
        }
    // Only the file itself: the temporary file was renamed into place.
    EXPECT_EQ(
        std::distance(std::filesystem::directory_iterator(std::filesystem::path(path).parent_path()), {}), 1);
}

// The layout of docs/probe-volume.md, checked from the bytes: magic, header length, a JSON header
// padded to a multiple of 16 bytes, then radiance, irradiance and validity, nothing after.
TEST(ProbeVolumeFile, LayoutIsTheDocumentedOne) {
    const ProbeVolume volume = sampleVolume(testGrid({3, 2, 2}), 3);
    const std::string bytes = volumeBytes(volume);
    EXPECT_EQ(bytes.substr(0, 8), "SHPROBEV");
    const uint64_t header = headerLength(bytes);
    EXPECT_EQ((16 + header) % 16, 0u);
    EXPECT_EQ(bytes[16 + header - 1], '\n');
    EXPECT_EQ(bytes.size(), 16 + header + 12 * (2 * 9 * 12 + 1));
    const ordered_json json = headerOf(bytes);
    EXPECT_EQ(json["format"], "shprobe.volume");
    EXPECT_EQ(json["version"], 1);
    EXPECT_EQ(json["convention"], "real-orthonormal-condon-shortley");
    EXPECT_EQ(json["order"], 3);
    EXPECT_EQ(json["coefficient_count"], 9);
    EXPECT_EQ(json["quantities"], ordered_json::array({"radiance", "irradiance"}));
    EXPECT_EQ(json["grid"]["counts"], ordered_json::array({3, 2, 2}));
    EXPECT_EQ(json["grid"]["bounds_min"], ordered_json::array({-2.0, 0.25, 1.0}));
    EXPECT_EQ(json["probes"]["begin"], 0);
    EXPECT_EQ(json["probes"]["end"], 12);
    EXPECT_EQ(json["bounces"], 2);
    EXPECT_EQ(json["settings"]["face_size"], 32);
    // Probe 1's first radiance coefficient, and the validity bytes, where the layout puts them.
    float red;
    std::memcpy(&red, bytes.data() + 16 + header + 9 * 12, sizeof(red));
    EXPECT_EQ(red, volume.radiance[9].r);
    EXPECT_EQ(bytes.substr(bytes.size() - 12), std::string(volume.valid.begin(), volume.valid.end()));
}

// The optional capture offsets: announced by "capture_offsets": true, 12 bytes a probe between the
// visibility maps (none here) and the validity bytes, read back bit for bit; a volume without them
// reads as no offsets (each zero); bricks with them merge to the whole volume byte for byte, and not
// with bricks without them; a non-finite offset and a key that is not a boolean are refused.
// The volume cut into three bricks, given to merge in `order`: the merged file is the whole file,
// byte for byte. Returns the bricks in that order.
std::vector<ProbeVolume> expectBricksMergeToTheWhole(const TempFolder& folder, const ProbeVolume& volume,
                                                     std::array<uint32_t, 3> order) {
    writeProbeVolume(folder.file("whole.shpv"), volume);
    std::vector<ProbeVolume> bricks;
    for (uint32_t index : order)
        bricks.push_back(sliceOf(volume, brickRange(volume.grid, {index, 3})));
    writeProbeVolume(folder.file("merged.shpv"), mergeProbeVolumes(bricks));
    EXPECT_EQ(fileBytes(folder.file("merged.shpv")), fileBytes(folder.file("whole.shpv")));
    return bricks;
}

TEST(ProbeVolumeFile, CaptureOffsetsAreAnOptionalSection) {
    TempFolder folder;
    ProbeVolume volume = sampleVolume(testGrid({3, 2, 2}), 3);
    const std::string without = volumeBytes(volume);
    EXPECT_FALSE(headerOf(without).contains("capture_offsets"));
    EXPECT_TRUE(parseProbeVolume(without, "v").offsets.empty());
    for (uint32_t p = 0; p < volume.probeCount(); ++p)
        volume.offsets.push_back(p % 3 == 0 ? glm::vec3(0.1f * float(p), -0.25f, 1.0f / 3.0f)
                                            : glm::vec3(0.0f));
    const std::string bytes = volumeBytes(volume);
    const uint64_t header = headerLength(bytes);
    EXPECT_EQ(headerOf(bytes)["capture_offsets"], true);
    EXPECT_EQ(bytes.size(), 16 + header + 12 * (2 * 9 * 12 + 12 + 1));
    float y;
    std::memcpy(&y, bytes.data() + 16 + header + 12 * 2 * 9 * 12 + 3 * 12 + 4, sizeof(y));
    EXPECT_EQ(y, -0.25f); // probe 3's offset.y
    expectSameVolume(parseProbeVolume(bytes, "v"), volume);

    std::vector<ProbeVolume> bricks = expectBricksMergeToTheWhole(folder, volume, {2u, 0u, 1u});
    bricks[1].offsets.clear();
    expectInputError([&] { mergeProbeVolumes(bricks); },
                     "capture offsets present in brick 1, absent in brick 2");

    ProbeVolume broken = volume;
    broken.offsets[4].z = NAN;
    expectInputError([&] { writeProbeVolume(folder.file("broken.shpv"), broken); },
                     "the capture offset of probe 4 is not finite");
    std::string edited = bytes;
    const size_t key = edited.find("\"capture_offsets\": true");
    edited.replace(key, 23, "\"capture_offsets\": 1   ");
    expectInputError([&] { parseProbeVolume(edited, "v"); },
                     "field \"capture_offsets\" must be true or false");
}

// The transfer (static radiance, then order^4 values a probe) follows the capture offsets; bricks
// with it merge to the whole file, and a brick without it is not of the same bake.
TEST(ProbeVolumeFile, TransferIsAnOptionalSection) {
    TempFolder folder;
    ProbeVolume volume = sampleVolume(testGrid({3, 2, 2}), 2);
    EXPECT_FALSE(headerOf(volumeBytes(volume)).contains("transfer"));
    volume.staticRadiance = volume.radiance;
    for (size_t i = 0; i < volume.radiance.size() * 4; ++i) {
        const bool valid = volume.valid[i / 16];
        volume.transfer.push_back(valid ? glm::vec3(0.01f * float(i), 1.0f / 7.0f, -float(i))
                                        : glm::vec3(0.0f));
    }
    const std::string bytes = volumeBytes(volume);
    const uint64_t header = headerLength(bytes);
    EXPECT_EQ(headerOf(bytes)["transfer"], true);
    EXPECT_EQ(bytes.size(), 16 + header + 12 * (2 * 4 * 12 + 4 * 12 + 16 * 12 + 1));
    float red;
    std::memcpy(&red, bytes.data() + 16 + header + 12 * (3 * 4 * 12) + (16 * 2 + 5) * 12, sizeof(red));
    EXPECT_EQ(red, 0.01f * float(16 * 2 + 5)); // probe 2's T_11 (row 1, column 1)
    expectSameVolume(parseProbeVolume(bytes, "v"), volume);

    std::vector<ProbeVolume> bricks = expectBricksMergeToTheWhole(folder, volume, {1u, 2u, 0u});
    bricks[2].transfer.clear();
    bricks[2].staticRadiance.clear();
    expectInputError([&] { mergeProbeVolumes(bricks); }, "transfer present in brick 1, absent in brick 3");

    ProbeVolume broken = volume;
    broken.transfer[17].g = INFINITY;
    expectInputError([&] { writeProbeVolume(folder.file("broken.shpv"), broken); },
                     "the transfer of probe 1 is not finite");
    broken = volume;
    broken.staticRadiance.clear();
    expectInputError([&] { writeProbeVolume(folder.file("broken.shpv"), broken); },
                     "holds a transfer without its static radiance");
    std::string truncated = bytes;
    truncated.resize(bytes.size() - 13);
    expectInputError([&] { parseProbeVolume(truncated, "v"); }, "truncated");
    std::string edited = bytes;
    edited.replace(edited.find("\"transfer\": true"), 16, "\"transfer\": 1   ");
    expectInputError([&] { parseProbeVolume(edited, "v"); }, "field \"transfer\" must be true or false");
}

// An invalid probe's coefficients are written as zeros (a NaN there is the bake's business, not
// the file's); a valid probe's NaN is refused before anything is written.
TEST(ProbeVolumeFile, InvalidProbesAreWrittenAsZerosAndNaNIsRefused) {
    ProbeVolume volume = sampleVolume(testGrid({2, 2, 2}), 2);
    volume.valid[1] = 0;
    volume.irradiance[5] = glm::vec3(std::numeric_limits<float>::quiet_NaN());
    const ProbeVolume read = parseProbeVolume(volumeBytes(volume), "volume.shpv");
    for (int c = 4; c < 8; ++c)
        EXPECT_EQ(read.irradiance[size_t(c)], glm::vec3(0.0f));

    volume.valid[1] = 1;
    TempFolder folder;
    expectInputError([&] { writeProbeVolume(folder.file("bad.shpv"), volume); },
                     "bad.shpv: the irradiance of probe 1 is not finite");
    EXPECT_FALSE(std::filesystem::exists(folder.file("bad.shpv")));
}

TEST(ProbeVolumeFile, InconsistentVolumesAreNotWritten) {
    TempFolder folder;
    const std::string path = folder.file("volume.shpv");
    const ProbeVolume good = sampleVolume(testGrid({2, 2, 1}), 2);
    const std::pair<std::function<void(ProbeVolume&)>, const char*> cases[] = {
        {[](ProbeVolume& v) { v.radiance.pop_back(); }, "radiance holds 15 coefficients, not 16"},
        {[](ProbeVolume& v) { v.valid.pop_back(); }, "holds 3 validity bytes for 4 probes"},
        {[](ProbeVolume& v) { v.valid[2] = 7; }, "probe 2 has validity 7, neither 0 nor 1"},
        {[](ProbeVolume& v) { v.end = 5; }, "the probe range [0, 5) is not a non-empty range"},
        {[](ProbeVolume& v) { v.order = 9; }, "order 9 is outside 1..8"},
        {[](ProbeVolume& v) { v.radiance.clear(), v.irradiance.clear(); }, "holds neither radiance nor"},
        {[](ProbeVolume& v) { v.settings = "[1]"; }, "the settings are not a JSON object"},
        {[](ProbeVolume& v) { v.bounces = -1; }, "a negative bounce count"},
        {[](ProbeVolume& v) { v.grid.counts.z = 0; }, "the grid's count along z must be at least 1"},
    };
    for (const auto& [spoil, message] : cases) {
        ProbeVolume volume = good;
        spoil(volume);
        expectInputError([&] { writeProbeVolume(path, volume); }, "cannot write " + path + ": " + message);
    }
}

// Whatever the writer accepts, the reader reads: the most deeply nested settings it takes (one
// level more is refused on writing, not left for the reader to refuse), and a source that is not
// UTF-8 (a file name's bytes), written with U+FFFD in place of the stray byte.
TEST(ProbeVolumeFile, WhatIsWrittenIsReadable) {
    TempFolder folder;
    const std::string path = folder.file("volume.shpv");
    ProbeVolume volume = sampleVolume(testGrid({2, 1, 1}), 1);
    auto nested = [](int levels) {
        std::string text;
        for (int n = 0; n < levels; ++n)
            text += "{\"a\":";
        return text + "1" + std::string(size_t(levels), '}');
    };
    int levels = 1;
    for (;; ++levels) {
        volume.settings = nested(levels);
        try {
            writeProbeVolume(path, volume);
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("the settings are not a JSON object"),
                      std::string::npos);
            break;
        }
        ASSERT_LT(levels, 100);
    }
    EXPECT_GT(levels, 8);
    volume.settings = nested(levels - 1);
    volume.source = "caf\xe9.glb";
    writeProbeVolume(path, volume);
    const ProbeVolume read = readProbeVolume(path);
    EXPECT_EQ(read.settings, nested(levels - 1));
    EXPECT_EQ(read.source, "caf\xef\xbf\xbd.glb");
}

// A file cut at any byte is refused with a message naming it; the cut never reaches an
// allocation or a read past the end (the test runs under the sanitizers too).
TEST(ProbeVolumeFile, TruncatedAtEveryByteIsRefused) {
    const std::string bytes = volumeBytes(sampleVolume(testGrid({2, 1, 1}), 1, false, true));
    for (size_t size = 0; size < bytes.size(); ++size) {
        SCOPED_TRACE("cut at byte " + std::to_string(size));
        expectInputError([&] { parseProbeVolume(std::string_view(bytes).substr(0, size), "cut.shpv"); },
                         size < 16 + headerLength(bytes) ? "cut.shpv: truncated"
                                                         : "cut.shpv: truncated: the header describes");
    }
    expectInputError([&] { parseProbeVolume(bytes + std::string(1, '\0'), "long.shpv"); },
                     "long.shpv: " + std::to_string(bytes.size() + 1) + " bytes, more than the " +
                         std::to_string(bytes.size()) + " its header describes");
}

TEST(ProbeVolumeFile, APreambleThatLiesIsRefused) {
    const std::string bytes = volumeBytes(sampleVolume(testGrid({2, 1, 1}), 1));
    auto withLength = [&](uint64_t length) {
        std::string out = bytes;
        for (int i = 0; i < 8; ++i)
            out[size_t(8 + i)] = char((length >> (8 * i)) & 0xffu);
        return out;
    };
    std::string wrongMagic = bytes;
    wrongMagic[3] = 'X';
    expectInputError([&] { parseProbeVolume(wrongMagic, "v"); }, "v: not a probe volume");
    expectInputError([&] { parseProbeVolume(withLength(0), "v"); }, "the header length 0 is outside");
    expectInputError([&] { parseProbeVolume(withLength(uint64_t(1) << 63), "v"); }, "is outside 16..1048576");
    expectInputError([&] { parseProbeVolume(withLength(headerLength(bytes) + 1), "v"); },
                     "is not a multiple of 16");
    expectInputError([&] { parseProbeVolume(withLength(1u << 20), "v"); },
                     "truncated: the header ends at byte");
    std::string nul = bytes;
    nul[40] = '\0';
    expectInputError([&] { parseProbeVolume(nul, "v"); }, "not valid JSON (a NUL byte at offset 40)");
}

// Counts that would ask for gigabytes are held against the file's size before anything is
// allocated: were the 2^24 probes of order 8 allocated (25 GB), this test would run out of memory.
TEST(ProbeVolumeFile, HugeCountsAreRefusedBeforeAllocating) {
    const std::string bytes = volumeBytes(sampleVolume(testGrid({2, 1, 1}), 1));
    expectInputError(
        [&] {
            parseProbeVolume(withHeader(bytes,
                                        [](ordered_json& h) {
                                            h["order"] = 8;
                                            h["coefficient_count"] = 64;
                                            h["grid"]["counts"] = {256, 256, 256};
                                            h["probes"]["end"] = 1 << 24;
                                        }),
                             "huge.shpv");
        },
        "huge.shpv: truncated: the header describes 257865"); // 2^24 (2 x 64 x 12 + 1) bytes and the header
    expectInputError(
        [&] {
            parseProbeVolume(withHeader(bytes,
                                        [](ordered_json& h) {
                                            h["grid"]["counts"] = {1 << 20, 1 << 20, 1};
                                        }),
                             "v");
        },
        "v: the grid 1048576x1048576x1 has more than 16777216 probes");
}

// Every field of the header is checked, each with its own message.
TEST(ProbeVolumeFile, EveryHeaderFieldIsChecked) {
    const std::string bytes = volumeBytes(sampleVolume(testGrid({2, 2, 1}), 2));
    using Edit = std::function<void(ordered_json&)>;
    const std::pair<Edit, const char*> cases[] = {
        {[](ordered_json& h) { h.erase("format"); }, "missing field \"format\""},
        {[](ordered_json& h) { h["format"] = "shprobe.sh"; }, "field \"format\" must be \"shprobe.volume\""},
        {[](ordered_json& h) { h["version"] = 2; }, "field \"version\" must be 1"},
        {[](ordered_json& h) { h["convention"] = "unity"; }, "field \"convention\" must be"},
        {[](ordered_json& h) { h["order"] = 9; }, "field \"order\" must be an integer from 1 to 8"},
        {[](ordered_json& h) { h["order"] = 2.0; }, "field \"order\" must be an integer"},
        {[](ordered_json& h) { h["coefficient_count"] = 9; }, "field \"coefficient_count\" must be 4"},
        {[](ordered_json& h) {
             h["quantities"] = {"irradiance", "radiance"};
         },
         "field \"quantities\" must be"},
        {[](ordered_json& h) {
             h["quantities"] = {"irradiance", "irradiance"};
         },
         "field \"quantities\" must be"},
        {[](ordered_json& h) { h["quantities"] = ordered_json::array(); }, "field \"quantities\" must be"},
        {[](ordered_json& h) { h["grid"] = 4; }, "field \"grid\" must be an object"},
        {[](ordered_json& h) {
             h["grid"]["counts"] = {2, 2};
         },
         "field \"grid.counts\" must be an array of 3"},
        {[](ordered_json& h) {
             h["grid"]["counts"] = {2, 0, 1};
         },
         "field \"grid.counts[y]\" must be an integer from 1"},
        {[](ordered_json& h) {
             h["grid"]["bounds_max"] = {4, 0, 5.5};
         },
         "the grid's bounds are inverted along y"},
        {[](ordered_json& h) {
             h["grid"]["bounds_max"] = {4, 0.25, 5.5};
         },
         "the grid's bounds are flat along y"},
        {[](ordered_json& h) {
             h["grid"]["bounds_min"] = {"a", 0, 0};
         },
         "field \"grid.bounds_min\" must be an array of 3 numbers"},
        {[](ordered_json& h) {
             h["grid"]["bounds_min"] = {-1e308, 0, 0};
             h["grid"]["bounds_max"] = {1e308, 3, 5.5};
         },
         "the grid's extent along x is not finite"},
        {[](ordered_json& h) { h["probes"]["begin"] = 4; },
         "field \"probes.begin\" must be an integer from 0 to 3"},
        {[](ordered_json& h) { h["probes"]["end"] = 5; },
         "field \"probes.end\" must be an integer from 1 to 4"},
        {[](ordered_json& h) { h["probes"]["end"] = 18446744073709551615u; },
         "field \"probes.end\" must be an integer"},
        {[](ordered_json& h) { h["bounces"] = -1; }, "field \"bounces\" must be an integer from 0"},
        {[](ordered_json& h) { h.erase("source"); }, "missing field \"source\""},
        {[](ordered_json& h) { h["source_hash"] = 12; }, "field \"source_hash\" must be a string"},
        {[](ordered_json& h) { h["sky_source"] = true; }, "field \"sky_source\" must be a string"},
        {[](ordered_json& h) { h["settings"] = "face_size=32"; }, "field \"settings\" must be an object"},
    };
    for (const auto& [edit, message] : cases)
        expectInputError([&, edit = edit] { parseProbeVolume(withHeader(bytes, edit), "v.shpv"); },
                         std::string("v.shpv: ") + message);
    // Fields a reader does not know are ignored, and the test's own writer makes a readable file.
    const ProbeVolume read =
        parseProbeVolume(withHeader(bytes, [](ordered_json& h) { h["baked_on"] = "gpu"; }), "v");
    EXPECT_EQ(read.end, 4u);
    // A volume written before volumes held a source hash reads with none.
    const ProbeVolume old =
        parseProbeVolume(withHeader(bytes, [](ordered_json& h) { h.erase("source_hash"); }), "v");
    EXPECT_EQ(old.sourceHash, "");
    EXPECT_EQ(old.source, "room.glb (12 triangles, 1 material, 1 sun)");
    const ProbeVolume unnamedSky =
        parseProbeVolume(withHeader(bytes, [](ordered_json& h) { h.erase("sky_source"); }), "v");
    EXPECT_EQ(unnamedSky.skySource, "");
}

TEST(ProbeVolumeFile, DamagedPayloadsAreRefused) {
    const std::string bytes = volumeBytes(sampleVolume(testGrid({2, 2, 1}), 1, true, false));
    std::string validity = bytes;
    validity[bytes.size() - 2] = 2;
    expectInputError([&] { parseProbeVolume(validity, "v"); }, "v: probe 2 has validity 2, neither 0 nor 1");
    std::string nan = bytes;
    const float quietNaN = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(nan.data() + 16 + headerLength(bytes) + 12 * 3 + 4, &quietNaN, sizeof(quietNaN));
    expectInputError([&] { parseProbeVolume(nan, "v"); }, "v: the radiance of probe 3 is not finite");
}

// The same checks on disk, and the project's words for what is not a file.
TEST(ProbeVolumeFile, ReadsFilesAndRefusesWhatIsNotOne) {
    TempFolder folder;
    const std::string bytes = volumeBytes(sampleVolume(testGrid({2, 1, 1}), 1));
    const std::string cut = folder.file("cut.shpv");
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 1);
    expectInputError([&] { readProbeVolume(cut); }, cut + ": truncated: the header describes");
    expectInputError([&] { readProbeVolume(folder.file("missing.shpv")); }, "missing.shpv: no such file");
    expectInputError([&] { readProbeVolume(folder.file("")); }, "is a folder, not a probe volume");
    std::ofstream(folder.file("empty.shpv")).close();
    expectInputError([&] { readProbeVolume(folder.file("empty.shpv")); }, "the file is empty");
}

// ---- Merge -------------------------------------------------------------------------------------

// Bricks cut as brickRange cuts them, merged in a shuffled order, give the whole volume, in memory
// and as files (the whole bake's file, byte for byte).
TEST(Merge, ShuffledBricksMergeToTheWholeVolume) {
    TempFolder folder;
    const ProbeVolume whole = sampleVolume(testGrid({5, 3, 2}), 3);
    const std::string wholeFile = folder.file("whole.shpv");
    writeProbeVolume(wholeFile, whole);
    std::mt19937 random(7);
    for (uint32_t count : {1u, 2u, 3u, 7u, 30u}) {
        SCOPED_TRACE(std::to_string(count) + " bricks");
        std::vector<ProbeVolume> bricks;
        for (uint32_t index = 0; index < count; ++index)
            bricks.push_back(sliceOf(whole, brickRange(whole.grid, {index, count})));
        std::shuffle(bricks.begin(), bricks.end(), random);
        expectSameVolume(mergeProbeVolumes(bricks), whole);

        std::vector<ProbeVolume> read;
        for (size_t n = 0; n < bricks.size(); ++n) {
            const std::string path = folder.file("brick" + std::to_string(n) + ".shpv");
            writeProbeVolume(path, bricks[n]);
            read.push_back(readProbeVolume(path));
        }
        writeProbeVolume(folder.file("merged.shpv"), mergeProbeVolumes(read));
        EXPECT_EQ(fileBytes(folder.file("merged.shpv")), fileBytes(wholeFile));
    }
}

TEST(Merge, RefusesOverlapsGapsAndMissingBricks) {
    const ProbeVolume whole = sampleVolume(testGrid({5, 2, 1}), 2);
    auto brick = [&](uint32_t index) {
        return sliceOf(whole, brickRange(whole.grid, {index, 3}));
    }; // 0-2, 3-5, 6-9
    const std::vector<std::string> names = {"a.shpv", "b.shpv", "c.shpv", "d.shpv"};
    expectInputError(
        [&] {
            mergeProbeVolumes(std::vector{brick(0), brick(1), brick(1), brick(2)}, names);
        },
        "merge: b.shpv (probes 3 to 5) and c.shpv (probes 3 to 5) overlap");
    expectInputError(
        [&] {
            mergeProbeVolumes(std::vector{brick(2), brick(0)});
        },
        "merge: probes 3 to 5 are in no brick");
    expectInputError(
        [&] {
            mergeProbeVolumes(std::vector{brick(0), brick(1)});
        },
        "merge: probes 6 to 9 are in no brick");
    expectInputError(
        [&] {
            mergeProbeVolumes(std::vector{sliceOf(whole, {1, 10})});
        },
        "merge: probe 0 is in no brick");
    expectInputError([&] { mergeProbeVolumes(std::vector<ProbeVolume>()); }, "merge: no bricks to merge");
}

// Bricks of different bakes are refused, naming what differs.
TEST(Merge, RefusesBricksOfDifferentBakes) {
    const ProbeVolume whole = sampleVolume(testGrid({4, 1, 1}), 2);
    const ProbeVolume first = sliceOf(whole, {0, 2});
    const std::vector<std::string> names = {"a.shpv", "b.shpv"};
    const std::pair<std::function<void(ProbeVolume&)>, const char*> cases[] = {
        {[](ProbeVolume& v) { v.settings = R"({"sky":"uniform 1,1,1","face_size":64})"; },
         "a.shpv and b.shpv are not bricks of one bake: setting \"face_size\" is 32 in a.shpv, 64 in b.shpv"},
        {[](ProbeVolume& v) { v.settings = R"({"face_size":32})"; },
         "sky \"sky.exr (equirect 64x32)\" (uniform 1,1,1) in a.shpv, \"sky.exr (equirect 64x32)\" (no sky "
         "setting) in b.shpv"},
        {[](ProbeVolume& v) { v.settings = R"({"face_size":32,"sky":"fnv1a64:00000000000000ff"})"; },
         "sky \"sky.exr (equirect 64x32)\" (uniform 1,1,1) in a.shpv, \"sky.exr (equirect 64x32)\" "
         "(fnv1a64:00000000000000ff) in b.shpv"},
        {[](ProbeVolume& v) { v.bounces = 1; }, "bounces 2 in a.shpv, 1 in b.shpv"},
        {[](ProbeVolume& v) { v.sourceHash = "fnv1a64:00000000000000ff"; },
         "source \"room.glb (12 triangles, 1 material, 1 sun)\" (fnv1a64:0123456789abcdef) in a.shpv, "
         "\"room.glb (12 triangles, 1 material, 1 sun)\" (fnv1a64:00000000000000ff) in b.shpv"},
        {[](ProbeVolume& v) { v.sourceHash.clear(); }, "(no source hash) in b.shpv"},
        {[](ProbeVolume& v) { v.grid.boundsMax.x = 5.0; }, "bounds [-2.0,0.25,1.0]..[4.0,3.0,5.5] in a.shpv"},
        {[](ProbeVolume& v) { v.grid.counts.y = 2; }, "grid 4x1x1 in a.shpv, 4x2x1 in b.shpv"},
        {[](ProbeVolume& v) { v.radiance.clear(); },
         "radiance and irradiance in a.shpv, irradiance in b.shpv"},
    };
    for (const auto& [change, message] : cases) {
        ProbeVolume second = sliceOf(whole, {2, 4});
        change(second);
        expectInputError([&] { mergeProbeVolumes(std::vector{first, second}, names); }, message);
    }
    ProbeVolume order = sampleVolume(testGrid({4, 1, 1}), 3);
    expectInputError(
        [&] {
            mergeProbeVolumes(std::vector{first, sliceOf(order, {2, 4})}, names);
        },
        "order 2 in a.shpv, 3 in b.shpv");
    // Settings equal as JSON merge, whatever their key order.
    ProbeVolume reordered = sliceOf(whole, {2, 4});
    reordered.settings = R"({ "sky": "uniform 1,1,1", "face_size": 32 })";
    EXPECT_EQ(mergeProbeVolumes(std::vector{first, reordered}).end, 4u);
}

// Bricks of one scene and sky baked under two paths (on two machines) have one source hash, one
// sky in their settings and two descriptions of each: they merge, the brick of probe 0 naming the
// source and the sky whatever the order given.
// Without hashes (volumes written before them) the descriptions must agree.
TEST(Merge, OneSceneUnderTwoPathsMerges) {
    const ProbeVolume whole = sampleVolume(testGrid({4, 1, 1}), 2);
    ProbeVolume first = sliceOf(whole, {0, 2}), second = sliceOf(whole, {2, 4});
    second.source = "/farm/7/room.glb (12 triangles, 1 material, 1 sun)";
    second.skySource = "/farm/7/sky.exr (equirect 64x32)";
    const ProbeVolume merged = mergeProbeVolumes(std::vector{second, first});
    EXPECT_EQ(merged.source, whole.source);
    EXPECT_EQ(merged.skySource, whole.skySource);
    EXPECT_EQ(merged.sourceHash, whole.sourceHash);
    first.sourceHash.clear();
    second.sourceHash.clear();
    expectInputError(
        [&] {
            mergeProbeVolumes(std::vector{first, second}, std::vector<std::string>{"a", "b"});
        },
        "source \"room.glb (12 triangles, 1 material, 1 sun)\" in a, \"/farm/7/room.glb");
}

// FNV-1a 64's published test vectors (draft-eastlake-fnv, the test suite): "", "a", "foobar".
TEST(ContentHash, MatchesFnv1a64) {
    auto of = [](std::string_view bytes) {
        Fnv1a64 hash;
        hash.add(bytes);
        return hash.text();
    };
    EXPECT_EQ(of(""), "fnv1a64:cbf29ce484222325");
    EXPECT_EQ(of("a"), "fnv1a64:af63dc4c8601ec8c");
    EXPECT_EQ(of("foobar"), "fnv1a64:85944171f73967e8");
}

// A volume is of a scene when the hashes agree, whatever the description; without a hash, when
// the descriptions agree.
TEST(ProbeVolumeFile, SceneMismatchComparesHashesElseDescriptions) {
    ProbeVolume volume = sampleVolume(testGrid({2, 1, 1}), 2);
    EXPECT_EQ(sceneMismatch(volume, volume.sourceHash, "./room.glb (12 triangles, 1 material, 1 sun)"), "");
    EXPECT_NE(sceneMismatch(volume, "fnv1a64:00000000000000ff", volume.source)
                  .find("(fnv1a64:0123456789abcdef), not in room.glb (12 triangles, 1 material, 1 sun) "
                        "(fnv1a64:00000000000000ff)"),
              std::string::npos);
    volume.sourceHash.clear();
    EXPECT_EQ(sceneMismatch(volume, "fnv1a64:00000000000000ff", volume.source), "");
    EXPECT_NE(sceneMismatch(volume, "fnv1a64:00000000000000ff", "./room.glb").find("holds no source hash"),
              std::string::npos);
}

// ---- Sampling ----------------------------------------------------------------------------------

const double kY00 = 0.5 / std::sqrt(std::numbers::pi);        // y_00
const double kY1 = std::sqrt(3.0 / (4.0 * std::numbers::pi)); // |y_1m| = kY1 |n_axis|

// The irradiance E(p, n) = f(p) + g(p) . n with f and g linear in p, per channel scaled by
// (1, 2, -0.5): E_00 = f / y00, E_1-1 = -g_y / k1, E_10 = g_z / k1, E_11 = -g_x / k1
// (y_1-1 = -k1 y, y_10 = k1 z, y_11 = -k1 x).
double fieldF(const glm::dvec3& p) {
    return 2.0 + 0.3 * p.x - 0.2 * p.y + 0.1 * p.z;
}
glm::dvec3 fieldG(const glm::dvec3& p) {
    return {0.1 + 0.05 * p.y, -0.2 + 0.03 * p.z, 0.15 * p.x - 0.02 * p.z};
}
const glm::dvec3 kChannels(1.0, 2.0, -0.5);

glm::dvec3 fieldAt(const glm::dvec3& p, const glm::dvec3& n) {
    return (fieldF(p) + glm::dot(fieldG(p), n)) * kChannels;
}

ProbeVolume linearFieldVolume(const ProbeGrid& grid, int order) {
    ProbeVolume volume;
    volume.grid = grid;
    volume.order = order;
    volume.end = grid.probeCount();
    volume.valid.assign(volume.end, 1);
    const size_t perProbe = size_t(coefficientCount(order));
    volume.irradiance.assign(volume.end * perProbe, glm::vec3(0.0f));
    for (uint32_t index = 0; index < volume.end; ++index) {
        const glm::dvec3 p = probePosition(grid, probeCell(grid, index));
        const glm::dvec3 g = fieldG(p);
        glm::vec3* e = &volume.irradiance[index * perProbe];
        e[0] = glm::vec3(fieldF(p) / kY00 * kChannels);
        if (order < 2) continue;
        e[shIndex(1, -1)] = glm::vec3(-g.y / kY1 * kChannels);
        e[shIndex(1, 0)] = glm::vec3(g.z / kY1 * kChannels);
        e[shIndex(1, 1)] = glm::vec3(-g.x / kY1 * kChannels);
    }
    return volume;
}

// The coefficients are stored as float: each carries a relative rounding of 6e-8, on values below
// 30, so a sample is within 1e-5 of the field's value; a wrong weight or probe errs by 1e-2 or more.
constexpr double kFloatStorageError = 1e-5;

// Trilinear interpolation reproduces any function linear in position exactly (to the float
// storage): at random points inside the grid, on its faces and, clamped, outside it.
TEST(Sampling, ReproducesALinearFieldExactly) {
    const ProbeGrid grid{{4, 3, 5}, {-2.0, 0.5, 1.0}, {4.0, 3.0, 9.0}};
    const ProbeVolume volume = linearFieldVolume(grid, 3);
    std::mt19937 random(11);
    std::uniform_real_distribution<double> unit(0.0, 1.0), wide(-0.5, 1.5), normal(-1.0, 1.0);
    for (int sample = 0; sample < 2000; ++sample) {
        const bool inside = sample % 2 == 0;
        glm::dvec3 t;
        for (int a = 0; a < 3; ++a)
            t[a] = inside ? unit(random) : wide(random);
        if (sample % 10 == 4) t.y = 1.0; // on the top face
        const glm::dvec3 position = grid.boundsMin + t * (grid.boundsMax - grid.boundsMin);
        const glm::dvec3 clamped = glm::clamp(position, grid.boundsMin, grid.boundsMax);
        const glm::dvec3 n = glm::normalize(glm::dvec3(normal(random), normal(random), normal(random)));
        const glm::dvec3 expected = fieldAt(clamped, n);
        const glm::dvec3 got = sampleVolumeIrradiance(volume, position, 3.0 * n); // normalized inside
        for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(got[c], expected[c], kFloatStorageError) << "sample " << sample << " channel " << c;
    }
    // At a probe, the sample is that probe's value alone.
    const glm::dvec3 probe = probePosition(grid, {2, 1, 3});
    const ProbeWeights at = volumeProbeWeights(volume, probe);
    EXPECT_NEAR(*std::max_element(at.weights.begin(), at.weights.end()), 1.0, 1e-12);
}

// An axis of one probe has no variation to interpolate: every point samples the field on the
// probes' plane (y at the middle of the bounds).
TEST(Sampling, ASingleProbeAxisHoldsItsValueEverywhere) {
    const ProbeGrid grid{{3, 1, 2}, {0.0, 0.0, 0.0}, {2.0, 4.0, 1.0}};
    const ProbeVolume volume = linearFieldVolume(grid, 2);
    const glm::dvec3 n = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
    for (double y : {-10.0, 0.0, 1.0, 2.0, 3.5, 10.0}) {
        const glm::dvec3 got = sampleVolumeIrradiance(volume, {1.3, y, 0.4}, n);
        const glm::dvec3 expected = fieldAt({1.3, 2.0, 0.4}, n);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(got[c], expected[c], kFloatStorageError) << "y " << y;
    }
}

// An invalid probe holding NaN changes nothing: the valid probes around it, holding a constant,
// still give that constant (weights renormalized to 1) at every point of the 8 cells it touches.
TEST(Sampling, InvalidProbesHaveNoEffect) {
    const ProbeGrid grid{{3, 3, 3}, {0.0, 0.0, 0.0}, {2.0, 2.0, 2.0}};
    ProbeVolume volume = linearFieldVolume(grid, 2);
    const glm::vec3 constant(1.5f, 0.25f, 3.0f);
    for (size_t i = 0; i < volume.irradiance.size(); ++i)
        volume.irradiance[i] = i % 4 == 0 ? constant / float(kY00) : glm::vec3(0.0f);
    const uint32_t centre = probeIndex(grid, {1, 1, 1});
    volume.valid[centre] = 0;
    for (int c = 0; c < 4; ++c)
        volume.irradiance[centre * 4 + size_t(c)] = glm::vec3(std::numeric_limits<float>::quiet_NaN());
    std::mt19937 random(3);
    std::uniform_real_distribution<double> inside(0.0, 2.0);
    for (int sample = 0; sample < 500; ++sample) {
        const glm::dvec3 position(inside(random), inside(random), inside(random));
        const ProbeWeights probes = volumeProbeWeights(volume, position);
        double sum = 0.0;
        for (int n = 0; n < 8; ++n) {
            sum += probes.weights[n];
            if (probes.probes[n] == centre) {
                EXPECT_EQ(probes.weights[n], 0.0);
            }
        }
        EXPECT_NEAR(sum, 1.0, 1e-12);
        const glm::dvec3 got = sampleVolumeIrradiance(volume, position, {0.0, 0.0, 1.0});
        for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(got[c], constant[c], kFloatStorageError) << "sample " << sample;
    }
}

// Where no probe of non-zero weight is valid there is nothing to interpolate: 0, never NaN. Also
// exactly at an invalid probe, whose neighbours' weights are all 0 there.
TEST(Sampling, NoValidProbeAroundGivesZero) {
    const ProbeGrid grid{{3, 2, 2}, {0.0, 0.0, 0.0}, {2.0, 1.0, 1.0}};
    ProbeVolume volume = linearFieldVolume(grid, 1);
    for (glm::ivec3 cell :
         {glm::ivec3(0, 0, 0), {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}}) {
        volume.valid[probeIndex(grid, cell)] = 0;
        volume.irradiance[probeIndex(grid, cell)] = glm::vec3(std::numeric_limits<float>::infinity());
    }
    EXPECT_EQ(sampleVolumeIrradiance(volume, {0.5, 0.5, 0.5}, {0.0, 1.0, 0.0}), glm::dvec3(0.0));
    EXPECT_EQ(sampleVolumeIrradiance(volume, {1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}), glm::dvec3(0.0));
    // Half a cell on, the valid probes at x = 2 carry the sample.
    EXPECT_GT(sampleVolumeIrradiance(volume, {1.5, 0.5, 0.5}, {0.0, 1.0, 0.0}).r, 0.0);
}

TEST(Sampling, RefusesWhatCannotBeSampled) {
    const ProbeGrid grid{{2, 2, 2}, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};
    const ProbeVolume volume = linearFieldVolume(grid, 2);
    expectInputError(
        [&] {
            sampleVolumeIrradiance(sliceOf(volume, {0, 4}), {0.5, 0.5, 0.5}, {0, 0, 1});
        },
        "probe volume sampling: the volume holds probes 0 to 3 of 8, not the whole grid");
    ProbeVolume radianceOnly = volume;
    radianceOnly.radiance = radianceOnly.irradiance;
    radianceOnly.irradiance.clear();
    expectInputError(
        [&] {
            sampleVolumeIrradiance(radianceOnly, {0.5, 0.5, 0.5}, {0, 0, 1});
        },
        "holds no irradiance");
    expectInputError(
        [&] {
            sampleVolumeIrradiance(volume, {0.5, 0.5, 0.5}, {0, 0, 0});
        },
        "the normal has no length");
    expectInputError(
        [&] {
            sampleVolumeIrradiance(volume, {0.5, std::nan(""), 0.5}, {0, 0, 1});
        },
        "the position is not finite");
}

} // namespace
} // namespace shprobe
