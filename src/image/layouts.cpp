// Image layouts of environment maps (equirect, crosses) turned into cube maps, and cube-map
// resizing. Face order, orientation and the cross layouts are those of docs/conventions.md.
// Resampling runs on all cores, a row of texels at a time; each texel is computed alone, so the
// result is bit-identical for every thread count.
#include "image/environment.h"

#include "common/error.h"
#include "common/parallel.h"
#include "common/quoted.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <glm/vec4.hpp>
#include <vector>

namespace shprobe {
namespace {

struct NamedLayout {
    Layout layout;
    const char* name;
};
constexpr std::array<NamedLayout, 5> kLayoutNames{{
    {Layout::Auto, "auto"},
    {Layout::Equirect, "equirect"},
    {Layout::HorizontalCross, "hcross"},
    {Layout::VerticalCross, "vcross"},
    {Layout::Faces, "faces"},
}};

// Where a face sits in a cross, in face-size units, and whether it is stored rotated 180 degrees.
struct CrossSlot {
    int column;
    int row;
    bool rotated;
};
// Indexed by Face (+X, -X, +Y, -Y, +Z, -Z). Rows [ . +Y . . ] [ -X +Z +X -Z ] [ . -Y . . ].
constexpr std::array<CrossSlot, kFaceCount> kHorizontalCross{
    {{2, 1, false}, {0, 1, false}, {1, 0, false}, {1, 2, false}, {1, 1, false}, {3, 1, false}}};
// Rows [ . +Y . ] [ -X +Z +X ] [ . -Y . ] [ . -Z . ]. -Z hangs below -Y turned 180 degrees: its
// own bottom edge (b = 1, where y = -1) goes to the top of its slot, against -Y's bottom edge.
constexpr std::array<CrossSlot, kFaceCount> kVerticalCross{
    {{2, 1, false}, {0, 1, false}, {1, 0, false}, {1, 2, false}, {1, 1, false}, {1, 3, true}}};
// crossFaceRows turns the one turned face back into a buffer of its own.
static_assert(std::count_if(kVerticalCross.begin(), kVerticalCross.end(),
                            [](CrossSlot s) { return s.rotated; }) == 1);

std::string sizeText(int width, int height) {
    return std::to_string(width) + "x" + std::to_string(height);
}

void copyCrossFace(const Image& cross, CrossSlot slot, int face, Cubemap& cubemap) {
    int n = cubemap.faceSize;
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            int x = slot.rotated ? n - 1 - i : i;
            int y = slot.rotated ? n - 1 - j : j;
            cubemap.at(face, i, j) = cross.at(slot.column * n + x, slot.row * n + y);
        }
    }
}

// One output texel of a 1-D resampling: the source texels it reads and their weights.
struct Tap {
    int source;
    double weight;
};
using Taps = std::vector<std::vector<Tap>>; // indexed by output texel

// Shrinking: output texel i covers the source interval [i s, (i + 1) s), s = from / to, and
// averages the source texels under it, each weighted by its overlap (s need not be an integer).
Taps areaTaps(int from, int to) {
    double scale = double(from) / to;
    Taps taps(static_cast<size_t>(to));
    for (int i = 0; i < to; ++i) {
        double begin = i * scale;
        double end = std::min((i + 1) * scale, double(from));
        for (int s = int(std::floor(begin)); s < from && s < end; ++s) {
            double overlap = std::min(end, s + 1.0) - std::max(begin, double(s));
            if (overlap > 0.0) taps[size_t(i)].push_back({s, overlap / (end - begin)});
        }
    }
    return taps;
}

// Growing: output texel centers map to source coordinate (i + 0.5) s - 0.5 and interpolate the
// two nearest source texels, clamped at the face's edges.
Taps bilinearTaps(int from, int to) {
    double scale = double(from) / to;
    Taps taps(static_cast<size_t>(to));
    for (int i = 0; i < to; ++i) {
        double x = std::clamp((i + 0.5) * scale - 0.5, 0.0, double(from - 1));
        int x0 = int(std::floor(x));
        int x1 = std::min(x0 + 1, from - 1);
        double t = x - x0;
        taps[size_t(i)] = {{x0, 1.0 - t}, {x1, t}};
    }
    return taps;
}

// The first pass of resizeFace: source row j resampled along the row into row j of `rows`.
void resizeRow(const Cubemap& source, int face, const Taps& taps, int j, std::vector<glm::dvec4>& rows) {
    int to = int(taps.size());
    for (int i = 0; i < to; ++i) {
        glm::dvec4 sum(0.0);
        for (Tap tap : taps[size_t(i)])
            sum += tap.weight * glm::dvec4(source.at(face, tap.source, j));
        rows[size_t(j) * to + i] = sum;
    }
}

// The second pass: output row j, each texel resampled along its column of `rows`.
void resizeColumns(const std::vector<glm::dvec4>& rows, int face, const Taps& taps, int j, Cubemap& result) {
    int to = result.faceSize;
    for (int i = 0; i < to; ++i) {
        glm::dvec4 sum(0.0);
        for (Tap tap : taps[size_t(j)])
            sum += tap.weight * rows[size_t(tap.source) * to + i];
        result.at(face, i, j) = glm::vec4(sum);
    }
}

// Work worth a thread (threadCount): a quarter to half a millisecond of resampling taps, far more
// than starting and joining the thread costs.
constexpr size_t kTapsPerThread = size_t(1) << 16;

// Taps read by one row of either pass: every output texel's taps.
size_t tapsPerRow(const Taps& taps) {
    size_t count = 0;
    for (const std::vector<Tap>& texel : taps)
        count += texel.size();
    return count;
}

// Separable resampling of one face: rows first, then columns. The threads split each pass by
// rows, a pass on as many threads as its own work is worth (shrinking a lot leaves the second
// pass little). A face at a time, so that only one face's intermediate rows are held.
void resizeFace(const Cubemap& source, int face, const Taps& taps, Cubemap& result) {
    int from = source.faceSize;
    int to = result.faceSize;
    size_t rowTaps = tapsPerRow(taps);
    std::vector<glm::dvec4> rows(size_t(to) * from); // `to` columns, `from` rows
    forEachItem(from, threadCount(size_t(from) * rowTaps, kTapsPerThread),
                [&](int j) { resizeRow(source, face, taps, j, rows); });
    forEachItem(to, threadCount(size_t(to) * rowTaps, kTapsPerThread),
                [&](int j) { resizeColumns(rows, face, taps, j, result); });
}

} // namespace

Layout parseLayout(const std::string& name) {
    for (const NamedLayout& entry : kLayoutNames)
        if (name == entry.name) return entry.layout;
    throw Error(ErrorKind::Input,
                "unknown layout " + quotedInput(name) + "; expected auto, equirect, hcross, vcross or faces");
}

const char* layoutName(Layout layout) {
    for (const NamedLayout& entry : kLayoutNames)
        if (layout == entry.layout) return entry.name;
    return "unknown";
}

Layout detectLayout(int width, int height) {
    const int64_t w = width, h = height; // 64-bit: no overflow for any int size
    if (w > 0 && h > 0) {
        if (w == 2 * h) return Layout::Equirect;
        if (3 * w == 4 * h) return Layout::HorizontalCross;
        if (4 * w == 3 * h) return Layout::VerticalCross;
    }
    throw Error(ErrorKind::Input, "image is " + sizeText(width, height) +
                                      ", which matches no layout: expected 2:1 (equirect), 4:3 "
                                      "(hcross) or 3:4 (vcross)");
}

int crossFaceSize(int width, int height, Layout layout) {
    bool horizontal = layout == Layout::HorizontalCross;
    if (!horizontal && layout != Layout::VerticalCross)
        throw Error(ErrorKind::Input, std::string("layout ") + layoutName(layout) + " is not a cross");
    int columns = horizontal ? 4 : 3;
    int rows = horizontal ? 3 : 4;
    if (width < 1 || int64_t(width) * rows != int64_t(height) * columns)
        throw Error(ErrorKind::Input, "image is " + sizeText(width, height) + ", but a " +
                                          layoutName(layout) + " image must be " + std::to_string(columns) +
                                          ":" + std::to_string(rows));
    return width / columns;
}

Cubemap crossToCubemap(const Image& cross, Layout layout) {
    int faceSize = crossFaceSize(cross.width, cross.height, layout);
    const auto& slots = layout == Layout::HorizontalCross ? kHorizontalCross : kVerticalCross;
    Cubemap cubemap = makeCubemap(faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        copyCrossFace(cross, slots[size_t(face)], face, cubemap);
    return cubemap;
}

FaceRows crossFaceRows(const Image& cross, Layout layout, std::vector<glm::vec4>& turned) {
    const int n = crossFaceSize(cross.width, cross.height, layout);
    if (cross.texels.size() != size_t(cross.width) * size_t(cross.height))
        throw Error(ErrorKind::Input, "the cross image holds " + std::to_string(cross.texels.size()) +
                                          " texels, not " + sizeText(cross.width, cross.height));
    const auto& slots = layout == Layout::HorizontalCross ? kHorizontalCross : kVerticalCross;
    FaceRows faces;
    for (int face = 0; face < kFaceCount; ++face) {
        const CrossSlot slot = slots[size_t(face)];
        faces.faces[size_t(face)] = &cross.at(slot.column * n, slot.row * n);
        faces.rowStrides[size_t(face)] = size_t(cross.width);
        if (!slot.rotated) continue;
        // Turned 180 degrees, its rows run right to left: they are read in a copy turned back.
        Cubemap one{n, std::vector<glm::vec4>(size_t(n) * size_t(n))};
        copyCrossFace(cross, slot, 0, one);
        turned = std::move(one.texels);
        faces.faces[size_t(face)] = turned.data();
        faces.rowStrides[size_t(face)] = size_t(n);
    }
    return faces;
}

void copyCrossToCubemap(Environment& environment) {
    if (!environment.keptCross()) return;
    environment.cubemap = crossToCubemap(environment.cross, environment.layout);
    environment.cross = Image{};
}

int Environment::faceSize() const {
    return keptCross() ? crossFaceSize(cross.width, cross.height, layout) : cubemap.faceSize;
}

size_t Environment::texelCount() const {
    if (keptEquirect()) return equirect.texels.size();
    const size_t n = size_t(faceSize());
    return keptCross() ? size_t(kFaceCount) * n * n : cubemap.texels.size();
}

void checkEquirectShape(int width, int height) {
    if (width != 2 * height)
        throw Error(ErrorKind::Input,
                    "image is " + sizeText(width, height) + ", but an equirect image must be 2:1");
}

namespace {

// One axis of averageCubemap: the edges of a face's `from` texels and of its `to` texels merged,
// each piece between two edges with the texel of either grid it lies in. Edges are compared as the
// integers i to and j from (multiples of 1 / (from to) of the face), so that shared edges are one.
struct AxisPiece {
    double end; // face-local coordinate in [-1, 1]; the piece begins where the one before ends
    int source;
    int target;
};
std::vector<AxisPiece> mergedEdges(int from, int to) {
    std::vector<AxisPiece> pieces;
    const int64_t span = int64_t(from) * to;
    for (int source = 0, target = 0; source < from && target < to;) {
        const int64_t sourceEnd = int64_t(source + 1) * to, targetEnd = int64_t(target + 1) * from;
        const int64_t end = std::min(sourceEnd, targetEnd);
        pieces.push_back({2.0 * double(end) / double(span) - 1.0, source, target});
        source += sourceEnd == end ? 1 : 0;
        target += targetEnd == end ? 1 : 0;
    }
    return pieces;
}

} // namespace

// Each piece where a source texel and a target texel overlap adds the source's value times the
// piece's exact solid angle (cube-map corner formula) to the target; the target's value is that sum
// over its solid angle (the sum of its pieces'). A row of corner terms serves all six faces.
Cubemap averageCubemap(const Cubemap& cubemap, int faceSize) {
    const int n = cubemap.faceSize;
    if (faceSize >= n) return cubemap;
    Cubemap result = makeCubemap(faceSize); // throws for a face size below 1
    std::vector<double> weights(result.texels.size(), 0.0);
    std::vector<glm::dvec3> sums(result.texels.size(), glm::dvec3(0.0));
    const std::vector<AxisPiece> pieces = mergedEdges(n, faceSize);
    auto cornerRow = [&](double b) {
        std::vector<double> row{cornerSolidAngle(-1.0, b)};
        for (const AxisPiece& piece : pieces)
            row.push_back(cornerSolidAngle(piece.end, b));
        return row;
    };
    std::vector<double> top = cornerRow(-1.0);
    for (const AxisPiece& rowPiece : pieces) {
        const std::vector<double> bottom = cornerRow(rowPiece.end);
        for (int face = 0; face < kFaceCount; ++face) {
            const size_t targetRow = (size_t(face) * faceSize + size_t(rowPiece.target)) * faceSize;
            for (size_t k = 0; k < pieces.size(); ++k) {
                const double solidAngle = top[k] - bottom[k] - top[k + 1] + bottom[k + 1];
                const size_t to = targetRow + size_t(pieces[k].target);
                sums[to] += solidAngle * glm::dvec3(cubemap.at(face, pieces[k].source, rowPiece.source));
                weights[to] += solidAngle;
            }
        }
        top = bottom;
    }
    for (size_t t = 0; t < result.texels.size(); ++t)
        result.texels[t] = glm::vec4(glm::vec3(sums[t] / weights[t]), 1.0f);
    return result;
}

Cubemap resizeCubemap(const Cubemap& cubemap, int faceSize) {
    if (faceSize == cubemap.faceSize) return cubemap;
    Cubemap result = makeCubemap(faceSize); // throws for a face size below 1
    Taps taps = faceSize < cubemap.faceSize ? areaTaps(cubemap.faceSize, faceSize)
                                            : bilinearTaps(cubemap.faceSize, faceSize);
    for (int face = 0; face < kFaceCount; ++face)
        resizeFace(cubemap, face, taps, result);
    return result;
}

} // namespace shprobe
