// An equirect map resampled into a cube map by area: each texel holds the mean of the equirect's
// pixels over the texel's footprint on the sphere, each pixel weighed by the solid angle it shares
// with the texel, so that the map's power (radiance times solid angle) is kept however small a
// bright source is and however the two grids fall on each other.
//
// In the plane (x, z), x the equirect's column coordinate and z = cos(theta) = d.y, solid angle is
// (2 pi / W) dx dz (Archimedes' hat-box theorem), and the pixels are rectangles: row j spans z from
// cos(pi (j + 1) / H) to cos(pi j / H). The integral of the piecewise-constant image over a texel
// is, by Green's theorem, the loop integral of Q dz around the texel's footprint, Q(x, z) the
// integral of its row from a fixed x_ref to x. Each edge of the texel is a great-circle arc, cut
// where it crosses a column (a meridian plane) or a row boundary (a cone about the axis); on each
// piece Q is linear in x, and the integral of x dz along it follows by parts from that of z dphi
// along a great circle, which has a closed form (below), so the result is exact up to rounding. A texel is
// that integral divided by its footprint's area, found the same way, so a constant map stays constant.
//
// The geometry (the pieces and their integrals) does not depend on the pixels, and faces related by
// a symmetry of the equirect grid share it: where W is a multiple of 4, the four side faces are
// one another turned a quarter turn about the axis (W / 4 columns) and each cap is a quarter of it
// turned four times; -Y is +Y mirrored (x -> W / 2 - x, z -> -z, which keeps the loops'
// orientation). Each edge's pieces are found once, on the face they were worked out on, and summed
// against each related face's pixels (PixelView).
#include "image/environment.h"

#include "common/error.h"
#include "common/parallel.h"
#include "sh/cubemap.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>
#include <initializer_list>
#include <numbers>
#include <tuple>
#include <utility>
#include <vector>

namespace shprobe {
namespace {

constexpr double kPi = std::numbers::pi;

// A texel corner. `direction` is the face's unnormalized direction (linear in a and b, so that
// points of an edge are direction(t) = p + t (q - p)); x in [0, W) is the equirect's column
// coordinate, undefined at a pole (atPole), where a meridian edge keeps the x of its other end.
struct Corner {
    glm::dvec3 direction;
    glm::dvec3 unit; // direction normalized
    double x;
    double z;
    int row;
    bool atPole;
};

// A point where an edge crosses a boundary, or one of its ends, at parameter t along the edge.
struct ArcPoint {
    double t;
    double x; // unwrapped along the loop
    double z;
    double u; // e'(phi) . n, and
    double c; // sqrt(n_y^2 + (e(phi) . n)^2): the angle atan2(u, c) of the closed form below
};

// A piece of a loop inside one pixel (addPiece), all that its integral needs but the pixel values.
struct Piece {
    double xa; // unwrapped x of its ends
    double xb;
    double dz;
    double i;   // the integral of (x - xa) dz along it
    int column; // the pixel's
    int row;
    bool carried; // goes on in the row where the piece before ended: Q carries on from there
};

// One texel's footprint (or one edge of it), gathered piece by piece around its edges: the area
// at once, the integral of radiance (loopIntegral) once per face that shares the geometry.
struct FootprintLoop {
    double area = 0.0;  // in pixel x dz units
    double xRef = 0.0;  // x_ref, the loop's first x: keeps Q small against rounding
    double xLast = 0.0; // unwrapped x of the last point reached
    bool started = false;
    std::vector<ArcPoint> points;                 // scratch for one edge
    std::vector<Piece> pieces;                    // in order along the loop
    std::vector<std::pair<int, double>> rowSteps; // dz by row along the loop, for sharedEdge
    // Where the last piece ended, for the next piece's `carried`.
    int carriedRow = -1;
    double carriedX = 0.0;

    void restart() {
        area = 0.0;
        started = false;
        pieces.clear();
        rowSteps.clear();
        carriedRow = -1;
    }
};

// Which pixels a face reads where its geometry is another face's: column c of row r there is
// column (c + shift) mod W of row r here, or, mirrored, column (shift - c) mod W of row H - 1 - r.
struct PixelView {
    int shift = 0; // in [0, W)
    bool mirrored = false;
};

// A texel's integrals, gathered from its four edges.
struct TexelSums {
    glm::dvec3 integral{0.0};
    double area = 0.0;
};

class EquirectFootprints {
  public:
    EquirectFootprints(const Image& equirect, int faceSize)
        : bulge(0.5 / (double(faceSize) * faceSize)), image(equirect), width(equirect.width),
          height(equirect.height), rowTop(size_t(height) + 1), columnPlane(size_t(width)) {
        // cos(pi j / H) written as sin(pi (H - 2j) / 2H): exactly 0 at the equator and exactly
        // opposite in the two hemispheres.
        for (int j = 0; j <= height; ++j)
            rowTop[size_t(j)] = std::sin(kPi * double(height - 2 * j) / (2.0 * height));
        // Column c's left boundary lies in the plane of normal (cos phi, 0, sin phi), phi = 2 pi c / W - pi.
        for (int c = 0; c < width; ++c) {
            const double phi = 2.0 * kPi * c / width - kPi;
            columnPlane[size_t(c)] = glm::dvec3(std::cos(phi), 0.0, std::sin(phi));
        }
    }

    Corner corner(int face, double a, double b) const {
        const glm::dvec3 direction = unnormalizedFaceDirection(face, a, b);
        const glm::dvec3 d = glm::normalize(direction);
        const bool atPole = d.x == 0.0 && d.z == 0.0;
        return {direction, d, atPole ? 0.0 : xOf(d), d.y, rowOf(d.y), atPole};
    }

    // A texel whose corners lie in one pixel, far enough from its rows' boundaries that no edge
    // bulges across them, lies in that pixel: a column is a wedge between two meridian planes, which
    // an arc between points inside does not leave, and off the poles z has no extremum inside a
    // texel, only along its edges.
    bool inOnePixel(std::initializer_list<const Corner*> corners) const {
        const Corner& first = **corners.begin();
        for (const Corner* p : corners)
            if (p->atPole || p->row != first.row || column(p->x) != column(first.x) || !clearOfRowEdges(*p))
                return false;
        return true;
    }

    glm::vec4 pixelAt(const Corner& p, PixelView view) const {
        return glm::vec4(glm::vec3(pixel(view, column(p.x), p.row)), 1.0f);
    }

    // An edge's pieces and area, with Q to be taken from its own first x, x0 (loopIntegral);
    // sharedEdge moves them to a texel's. The loop keeps them with the dz the edge spends in each row.
    double edgeIntegrals(const Corner& p, const Corner& q, FootprintLoop& loop) const {
        const double x0 = p.atPole ? q.x : p.x;
        loop.restart();
        loop.xRef = loop.xLast = x0;
        loop.started = true;
        edge(p, q, loop);
        return x0;
    }

    // The integral of Q dz around a loop's pieces, Q(x) that of its row from the loop's xRef to x:
    // with Q = Q(a) + L (x - x_a) on a piece, Q(a) dz plus L times the piece's i.
    glm::dvec3 loopIntegral(const FootprintLoop& loop, PixelView view) const {
        glm::dvec3 integral(0.0), q(0.0);
        for (const Piece& piece : loop.pieces) {
            const glm::dvec3 value = pixel(view, piece.column, piece.row);
            if (!piece.carried) q = rowIntegral(view, piece.row, loop.xRef, piece.xa);
            integral += q * piece.dz + value * piece.i;
            q += (piece.xb - piece.xa) * value;
        }
        return integral;
    }

    // Adds an edge (edgeIntegrals) to a texel whose loop runs along it (sign 1) or against it (-1),
    // with Q from the texel's xRef: Q(x) - Q(xRef) = (Q(x) - Q(x0)) + (Q(x0) - Q(xRef)) row by row,
    // the edge unwrapped to lie by the texel (a texel off the poles spans less than half a turn).
    void sharedEdge(const FootprintLoop& edgeLoop, const glm::dvec3& edgeIntegral, double x0, double sign,
                    double xRef, PixelView view, TexelSums& texel) const {
        const double x = unwrapped(x0, xRef);
        glm::dvec3 integral = edgeIntegral;
        double dz = 0.0;
        if (x != xRef) { // else the edge starts at the texel's reference corner: nothing to move
            for (const auto& [row, rowDz] : edgeLoop.rowSteps) {
                integral += rowDz * rowIntegral(view, row, xRef, x);
                dz += rowDz;
            }
        }
        texel.integral += sign * integral;
        texel.area += sign * (edgeLoop.area + (x - xRef) * dz);
    }

    // The texel around a pole (odd face sizes) winds a whole turn, so it is integrated on its own,
    // around its loop and closed along the pole.
    glm::vec4 poleTexel(int face, const Corner& p00, const Corner& p10, const Corner& p11, const Corner& p01,
                        PixelView view, FootprintLoop& loop) const {
        loop.restart();
        edge(p00, p10, loop);
        edge(p10, p11, loop);
        edge(p11, p01, loop);
        edge(p01, p00, loop);
        closeAroundPole(face, p00, loop);
        return glm::vec4(glm::vec3(loopIntegral(loop, view) / loop.area), 1.0f);
    }

  private:
    // phi = atan2(x, -z) in [-pi, pi] mapped to x in [0, W), as unitDirectionToEquirect does.
    double xOf(const glm::dvec3& d) const {
        const double x = (std::atan2(d.x, -d.z) + kPi) / (2.0 * kPi) * width;
        return x >= width ? x - width : x;
    }

    int rowOf(double z) const { return rowOf(z, 0, height - 1); }

    // The row of z among rows [firstRow, lastRow], those an arc spans (rowCrossings).
    int rowOf(double z, int firstRow, int lastRow) const {
        // Row j holds z in (rowTop[j + 1], rowTop[j]]: the count of inner boundaries at or above z.
        const auto first = rowTop.begin() + firstRow + 1, last = rowTop.begin() + lastRow + 1;
        return firstRow +
               int(std::partition_point(first, last, [z](double top) { return top >= z; }) - first);
    }

    // The pixel column of an x within a turn of [0, W), as unwrapped x are.
    int column(double x) const {
        const int c = int(std::floor(x));
        return c < 0 ? c + width : c >= width ? c - width : c;
    }

    // The image's column that a view reads for column c in [0, W).
    int imageColumn(PixelView view, int c) const {
        c = view.mirrored ? view.shift - c : c + view.shift;
        return c < 0 ? c + width : c >= width ? c - width : c;
    }

    glm::dvec3 pixel(PixelView view, int columnIndex, int row) const {
        return glm::dvec3(
            glm::vec3(image.at(imageColumn(view, columnIndex), view.mirrored ? height - 1 - row : row)));
    }

    bool clearOfRowEdges(const Corner& p) const {
        return rowTop[size_t(p.row)] - p.z >= bulge && p.z - rowTop[size_t(p.row) + 1] >= bulge;
    }

    // x seen from `near`, moved by whole turns to lie within half a turn of it. A loop strays at
    // most a turn from [0, W) (the one around a pole), so this takes a turn or two at most.
    double unwrapped(double x, double near) const {
        const double half = 0.5 * width;
        while (x - near > half)
            x -= width;
        while (near - x > half)
            x += width;
        return x;
    }

    void edge(const Corner& p, const Corner& q, FootprintLoop& loop) const {
        double xp = p.atPole ? q.x : p.x;
        if (!loop.started) {
            loop.started = true;
            loop.xRef = xp;
            loop.xLast = xp;
        }
        xp = unwrapped(xp, loop.xLast);
        const double xq = q.atPole ? xp : unwrapped(q.x, xp);
        const glm::dvec3 normal = glm::cross(p.direction, q.direction);
        // A meridian (an edge through a pole, or between two points of one meridian, as the side
        // faces' columns are) keeps its x: a vertical segment of the plane.
        if (normal.y == 0.0)
            meridian(xp, p.z, p.row, q.z, q.row, loop);
        else if (normal.x != 0.0 || normal.z != 0.0) // the equator (z = 0 throughout) adds nothing
            arc(p, q, xp, xq, glm::normalize(normal), loop);
        loop.xLast = xq;
    }

    // The one texel around a pole (odd face sizes) ends its loop a whole turn from where it began:
    // it is closed up to the pole and back along the two ends' meridians.
    void closeAroundPole(int face, const Corner& start, FootprintLoop& loop) const {
        if (std::abs(loop.xLast - loop.xRef) < 0.5 * width) return;
        const bool north = face == int(Face::PositiveY);
        const double zPole = north ? 1.0 : -1.0;
        const int poleRow = north ? 0 : height - 1;
        meridian(loop.xLast, start.z, start.row, zPole, poleRow, loop);
        meridian(loop.xRef, zPole, poleRow, start.z, start.row, loop);
    }

    // A piece from a to b inside one pixel, kept for loopIntegral, and its area term. I, the integral
    // of (x - x_a) dz along it, is by parts (x_b - x_a) z_b minus the integral of z dx. `zdx` is that
    // last integral (0 along a meridian).
    void addPiece(const ArcPoint& a, const ArcPoint& b, int row, double zdx, FootprintLoop& loop) const {
        const double dz = b.z - a.z;
        const double i = (b.x - a.x) * b.z - zdx;
        const bool carried = row == loop.carriedRow && a.x == loop.carriedX;
        loop.carriedRow = row;
        loop.carriedX = b.x;
        loop.pieces.push_back({a.x, b.x, dz, i, column(0.5 * (a.x + b.x)), row, carried});
        loop.area += (a.x - loop.xRef) * dz + i;
        if (!loop.rowSteps.empty() && loop.rowSteps.back().first == row)
            loop.rowSteps.back().second += dz;
        else
            loop.rowSteps.emplace_back(row, dz);
    }

    // A vertical segment at x from z0 to z1, cut at the row boundaries between.
    void meridian(double x, double z0, int row0, double z1, int row1, FootprintLoop& loop) const {
        if (z0 == z1) return;
        const int step = row1 > row0 ? 1 : -1;
        ArcPoint a{0.0, x, z0, 0.0, 0.0};
        for (int row = row0; row != row1; row += step) {
            const ArcPoint b{0.0, x, rowTop[size_t(step > 0 ? row + 1 : row)], 0.0, 0.0};
            addPiece(a, b, row, 0.0, loop);
            a = b;
        }
        addPiece(a, {0.0, x, z1, 0.0, 0.0}, row1, 0.0, loop);
    }

    // Along a great circle of unit normal n, the integral of z dphi is sign(n_y) asin(e'(phi) . n),
    // e'(phi) = (cos phi, 0, sin phi): its derivative in phi is z (tan(latitude) = -(e . n) / n_y on
    // the circle, e = (sin phi, 0, -cos phi)). Written as atan2(u, c), c = sqrt(1 - u^2) from the
    // other components, and differenced as one atan2, it keeps its digits where the arc runs nearly
    // along a meridian and where two points are close.
    ArcPoint arcPoint(double t, const glm::dvec3& d, double x, double z, const glm::dvec3& n) const {
        const double s = std::sqrt(d.x * d.x + d.z * d.z);
        const double u = (n.z * d.x - n.x * d.z) / s;
        const double w = (n.x * d.x + n.z * d.z) / s;
        return {t, x, z, u, std::sqrt(n.y * n.y + w * w)};
    }

    double zdxBetween(const ArcPoint& a, const ArcPoint& b, const glm::dvec3& n) const {
        const double angle = std::atan2(b.u * a.c - a.u * b.c, a.c * b.c + a.u * b.u);
        return (n.y > 0.0 ? angle : -angle) * width / (2.0 * kPi);
    }

    void arc(const Corner& p, const Corner& q, double xp, double xq, const glm::dvec3& n,
             FootprintLoop& loop) const {
        const glm::dvec3 origin = p.direction, step = q.direction - p.direction;
        std::vector<ArcPoint>& points = loop.points;
        points.clear();
        points.push_back(arcPoint(0.0, p.unit, xp, p.z, n));
        // Azimuth runs one way along an arc off the poles: it meets each column boundary once, where
        // the direction lies in that meridian's plane. They are taken in order along the arc.
        const double xStep = xq > xp ? 1.0 : -1.0;
        const double firstBoundary = xq > xp ? std::floor(xp) + 1.0 : std::ceil(xp) - 1.0;
        for (double c = firstBoundary; (c - xq) * xStep < 0.0; c += xStep) {
            const glm::dvec3& plane = columnPlane[size_t(column(c))];
            const double t = std::clamp(-glm::dot(origin, plane) / glm::dot(step, plane), 0.0, 1.0);
            const glm::dvec3 d = glm::normalize(origin + t * step);
            points.push_back(arcPoint(t, d, c, d.y, n));
        }
        points.push_back(arcPoint(1.0, q.unit, xq, q.z, n));
        // Ends in one row and clear of its edges by more than the arc can rise: no row crossed, and
        // the points are in order.
        const bool oneRow = p.row == q.row && clearOfRowEdges(p) && clearOfRowEdges(q);
        std::pair<int, int> rows{p.row, p.row};
        if (!oneRow) {
            rows = rowCrossings(p, q, xp, n, points);
            std::sort(points.begin(), points.end(),
                      [](const ArcPoint& a, const ArcPoint& b) { return a.t < b.t; });
        }
        for (size_t k = 0; k + 1 < points.size(); ++k) {
            const ArcPoint& a = points[k];
            const ArcPoint& b = points[k + 1];
            if (a.t == b.t) continue;
            const int row =
                oneRow ? p.row
                       : rowOf(glm::normalize(origin + 0.5 * (a.t + b.t) * step).y, rows.first, rows.second);
            addPiece(a, b, row, zdxBetween(a, b, n), loop);
        }
    }

    // z along an arc may rise past both ends (towards the pole), so the rows between its lowest and
    // highest points are tried: where z(t) = z_j, (d_y)^2 (1 - z_j^2) = z_j^2 (d_x^2 + d_z^2) with
    // d_y of z_j's sign, a quadratic in t. Returns the rows the arc spans, top to bottom.
    std::pair<int, int> rowCrossings(const Corner& p, const Corner& q, double xp, const glm::dvec3& n,
                                     std::vector<ArcPoint>& points) const {
        const glm::dvec3 origin = p.direction, step = q.direction - p.direction;
        const glm::dvec3 top =
            glm::normalize(glm::dvec3(0.0, 1.0, 0.0) - n.y * n); // highest point of the circle
        auto onArc = [&](const glm::dvec3& v) {
            return glm::dot(glm::cross(p.unit, v), n) > 0.0 && glm::dot(glm::cross(v, q.unit), n) > 0.0;
        };
        const double zHigh = std::max({p.z, q.z, onArc(top) ? top.y : -1.0});
        const double zLow = std::min({p.z, q.z, onArc(-top) ? -top.y : 1.0});
        const std::pair<int, int> rows{rowOf(zHigh), rowOf(zLow)};
        for (int j = rows.first + 1; j <= rows.second; ++j) {
            const double zj = rowTop[size_t(j)];
            const Crossings crossings = boundaryCrossings(origin, step, zj);
            for (int k = 0; k < crossings.count; ++k) {
                const double t = crossings.t[size_t(k)];
                if (!(t > 0.0 && t < 1.0)) continue; // NaN too
                const glm::dvec3 d = glm::normalize(origin + t * step);
                points.push_back(arcPoint(t, d, unwrapped(xOf(d), xp), zj, n));
            }
        }
        return rows;
    }

    // Parameters t where the direction origin + t step has height zj (up to two).
    struct Crossings {
        std::array<double, 2> t;
        int count;
    };
    static Crossings boundaryCrossings(const glm::dvec3& origin, const glm::dvec3& step, double zj) {
        if (zj == 0.0) return {{-origin.y / step.y, 0.0}, 1};
        const double k = 1.0 - zj * zj, h = zj * zj;
        const double a = k * step.y * step.y - h * (step.x * step.x + step.z * step.z);
        const double b = 2.0 * (k * origin.y * step.y - h * (origin.x * step.x + origin.z * step.z));
        const double c = k * origin.y * origin.y - h * (origin.x * origin.x + origin.z * origin.z);
        const double discriminant = b * b - 4.0 * a * c;
        Crossings crossings{{0.0, 0.0}, 0};
        if (discriminant < 0.0) return crossings;
        const double root = -0.5 * (b + std::copysign(std::sqrt(discriminant), b));
        for (double t : {root / a, c / root})
            if (std::isfinite(t) && (origin.y + t * step.y > 0.0) == (zj > 0.0))
                crossings.t[size_t(crossings.count++)] = t;
        return crossings;
    }

    // The integral of row `row` over x from `from` to `to` (unwrapped; negative when to < from).
    glm::dvec3 rowIntegral(PixelView view, int row, double from, double to) const {
        if (to == from) return glm::dvec3(0.0);
        if (to < from) return -rowIntegral(view, row, to, from);
        const double first = std::floor(from), last = std::floor(to);
        if (first == last) return (to - from) * pixel(view, column(first), row);
        glm::dvec3 sum = (first + 1.0 - from) * pixel(view, column(first), row);
        // The whole pixels between, walked along the image's row as the view reads it.
        const glm::vec4* line = &image.at(0, view.mirrored ? height - 1 - row : row);
        const int step = view.mirrored ? -1 : 1;
        int c = imageColumn(view, column(first + 1.0));
        for (int k = int(last - first) - 1; k > 0; --k) {
            sum += glm::dvec3(glm::vec3(line[c]));
            c += step;
            c = c < 0 ? c + width : c >= width ? c - width : c;
        }
        return sum + (to - last) * pixel(view, column(last), row);
    }

    // The most an edge rises above its ends in z: an arc of angle l, at most l^2 / 8 (z'' = -z along
    // a great circle, |z| <= 1), and a texel's edge spans at most 2 / N radians.
    const double bulge;
    const Image& image;
    const int width;
    const int height;
    std::vector<double> rowTop;          // z of each row's upper boundary, rowTop[H] = -1
    std::vector<glm::dvec3> columnPlane; // of each column's left boundary
};

// Work worth a thread (threadCount): about a millisecond of texels.
constexpr size_t kTexelsPerThread = size_t(1) << 11;
// A task takes this many rows of a group's geometry: the edges inside them are worked out once
// for the two texels on either side, those along the task's first and last rows once per task.
constexpr int kRowsPerTask = 8;

// A face that takes its texels from a group's geometry: texel (i, j) there is texel (i, j) turned
// a number of quarter turns here (turned), its pixels read through `view`.
struct GroupFace {
    int face;
    int quarterTurns;
    PixelView view;
};

// Faces whose texels are those of face `geometry`, or, fourFold, of a quarter of it (inQuarter).
struct FaceGroup {
    int geometry;
    bool fourFold;
    std::vector<GroupFace> faces;
};

// Turning a direction a quarter turn about the axis, (x, z) -> (z, -x), moves its x back W / 4
// columns: it takes +Z to +X, +X to -Z, -Z to -X, and +Y's texel (i, j) to its texel turned (i, j, 1).
// Mirroring (x, y, z) -> (x, -y, -z) takes +Y to -Y, x to W / 2 - x, row r to H - 1 - r.
std::vector<FaceGroup> faceGroups(int width) {
    const int px = int(Face::PositiveX), nx = int(Face::NegativeX), pz = int(Face::PositiveZ),
              nz = int(Face::NegativeZ), py = int(Face::PositiveY), ny = int(Face::NegativeY);
    auto wrap = [width](int c) { return (c % width + width) % width; };
    const int mirrorShift = width / 2 - 1; // column c mirrored: W / 2 - 1 - c
    std::vector<FaceGroup> groups;
    if (width % 4 == 0) {
        const int quarter = width / 4;
        groups.push_back({pz, false, {}});
        for (int k = 0; k < 4; ++k) // +Z, +X, -Z, -X
            groups.back().faces.push_back(
                {std::array{pz, px, nz, nx}[size_t(k)], 0, {wrap(-k * quarter), false}});
        groups.push_back({py, true, {}});
        for (int k = 0; k < 4; ++k) {
            groups.back().faces.push_back({py, k, {wrap(-k * quarter), false}});
            groups.back().faces.push_back({ny, k, {wrap(mirrorShift + k * quarter), true}});
        }
    } else {
        for (int face : {px, nx, pz, nz})
            groups.push_back({face, false, {{face, 0, {0, false}}}});
        groups.push_back({py, false, {{py, 0, {0, false}}, {ny, 0, {mirrorShift, true}}}});
    }
    return groups;
}

// Texel (i, j) of an N x N cap turned k quarter turns about the axis: (i, j) -> (j, N - 1 - i).
std::pair<int, int> turned(int i, int j, int k, int n) {
    for (; k > 0; --k)
        std::tie(i, j) = std::pair{j, n - 1 - i};
    return {i, j};
}

// A quarter of a cap that turned four times covers it once: the texels (i, j) with i <= m, j < m
// of an N = 2 m + 1 face, with the texel (m, m) around the pole, and i, j < m of N = 2 m.
bool inQuarter(int i, int j, int n) {
    const int m = n / 2;
    return n % 2 == 1 ? (i <= m && j < m) || (i == m && j == m) : i < m && j < m;
}

// The rows of a group's geometry that its tasks work out.
int groupRows(const FaceGroup& group, int n) {
    return group.fourFold ? (n + 1) / 2 : n;
}

std::vector<Corner> cornerRow(const EquirectFootprints& footprints, int face, int j, int faceSize) {
    std::vector<Corner> corners;
    corners.reserve(size_t(faceSize) + 1);
    const double b = 2.0 * j / faceSize - 1.0;
    for (int i = 0; i <= faceSize; ++i)
        corners.push_back(footprints.corner(face, 2.0 * i / faceSize - 1.0, b));
    return corners;
}

// Rows [firstRow, firstRow + rows) of a group's geometry, for each of its faces: each texel in one
// pixel takes it; the one around a pole is integrated alone; every other gathers its four edges,
// each worked out once and summed against each face's pixels.
void resampleRows(const EquirectFootprints& footprints, const FaceGroup& group, int firstRow, int rows,
                  Cubemap& cubemap) {
    const int n = cubemap.faceSize, face = group.geometry;
    std::vector<std::vector<Corner>> corners;
    for (int j = 0; j <= rows; ++j)
        corners.push_back(cornerRow(footprints, face, firstRow + j, n));
    auto texelCorners = [&](int i, int j) {
        return std::array<const Corner*, 4>{
            &corners[size_t(j)][size_t(i)], &corners[size_t(j)][size_t(i) + 1],
            &corners[size_t(j) + 1][size_t(i) + 1], &corners[size_t(j) + 1][size_t(i)]};
    };
    const bool cap = face == int(Face::PositiveY) || face == int(Face::NegativeY);
    auto aroundPole = [&](int i, int j) { return cap && n % 2 == 1 && i == n / 2 && firstRow + j == n / 2; };
    auto wanted = [&](int i, int j) { return !group.fourFold || inQuarter(i, firstRow + j, n); };

    const size_t texels = size_t(rows) * size_t(n);
    std::vector<char> gathered(texels); // whether a texel gathers its edges
    std::vector<double> xRefs(texels);
    for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < n; ++i) {
            const auto c = texelCorners(i, j);
            const size_t t = size_t(j) * n + size_t(i);
            gathered[t] =
                wanted(i, j) && !aroundPole(i, j) && !footprints.inOnePixel({c[0], c[1], c[2], c[3]});
            xRefs[t] = c[0]->atPole ? c[2]->x : c[0]->x; // a texel has at most one corner at a pole
        }
    }
    const size_t faceCount = group.faces.size();
    std::vector<TexelSums> sums(faceCount * texels); // face by face
    FootprintLoop loop;
    // The edge from corner p to corner q, to texel (i, j) along its loop (p00 p10 p11 p01) with sign.
    auto shareEdge = [&](const Corner& p, const Corner& q,
                         std::initializer_list<std::tuple<int, int, double>> edgeTexels) {
        bool needed = false;
        for (const auto& [i, j, sign] : edgeTexels)
            needed = needed || (j >= 0 && j < rows && i >= 0 && i < n && gathered[size_t(j) * n + size_t(i)]);
        if (!needed) return;
        const double x0 = footprints.edgeIntegrals(p, q, loop);
        for (size_t f = 0; f < faceCount; ++f) {
            const PixelView view = group.faces[f].view;
            const glm::dvec3 integral = footprints.loopIntegral(loop, view);
            for (const auto& [i, j, sign] : edgeTexels) {
                if (j < 0 || j >= rows || i < 0 || i >= n) continue;
                const size_t t = size_t(j) * n + size_t(i);
                if (gathered[t])
                    footprints.sharedEdge(loop, integral, x0, sign, xRefs[t], view, sums[f * texels + t]);
            }
        }
    };
    // Row by row, the sides of a row of texels after its top, so that the pixels they read are
    // still in the cache for each face.
    for (int j = 0; j <= rows; ++j) {
        for (int i = 0; i < n; ++i) // left to right: the top of texel (i, j), the bottom of (i, j - 1)
            shareEdge(corners[size_t(j)][size_t(i)], corners[size_t(j)][size_t(i) + 1],
                      {{i, j, 1.0}, {i, j - 1, -1.0}});
        if (j == rows) break;
        for (int i = 0; i <= n; ++i) // downwards: the right side of texel (i - 1, j), the left of (i, j)
            shareEdge(corners[size_t(j)][size_t(i)], corners[size_t(j) + 1][size_t(i)],
                      {{i - 1, j, 1.0}, {i, j, -1.0}});
    }

    for (size_t f = 0; f < faceCount; ++f) {
        const auto [target, quarterTurns, view] = group.faces[f];
        for (int j = 0; j < rows; ++j) {
            for (int i = 0; i < n; ++i) {
                if (!wanted(i, j) || (aroundPole(i, j) && quarterTurns != 0)) continue;
                const auto c = texelCorners(i, j);
                const size_t t = size_t(j) * n + size_t(i);
                const auto [ti, tj] = turned(i, firstRow + j, quarterTurns, n);
                glm::vec4& texel = cubemap.at(target, ti, tj);
                const TexelSums& sum = sums[f * texels + t];
                if (aroundPole(i, j))
                    texel = footprints.poleTexel(face, *c[0], *c[1], *c[2], *c[3], view, loop);
                else if (!gathered[t])
                    texel = footprints.pixelAt(*c[0], view);
                else
                    texel = glm::vec4(glm::vec3(sum.integral / sum.area), 1.0f);
            }
        }
    }
}

} // namespace

Cubemap equirectToCubemap(const Image& equirect, int faceSize, WorkCounter* progress) {
    if (equirect.texels.empty()) throw Error(ErrorKind::Input, "the equirect image is empty");
    checkEquirectShape(equirect.width, equirect.height);
    Cubemap cubemap = makeCubemap(faceSize); // throws for a face size below 1
    const EquirectFootprints footprints(equirect, faceSize);
    const std::vector<FaceGroup> groups = faceGroups(equirect.width);
    const int n = faceSize;
    startWork(progress, "resampling, rows", uint64_t(kFaceCount) * uint64_t(n), uint64_t(n));
    // Tasks group by group, each a few rows of the group's geometry.
    std::vector<std::pair<size_t, int>> tasks; // group, first row
    for (size_t g = 0; g < groups.size(); ++g)
        for (int row = 0; row < groupRows(groups[g], n); row += kRowsPerTask)
            tasks.emplace_back(g, row);
    forEachItem(int(tasks.size()), threadCount(cubemap.texels.size(), kTexelsPerThread), [&](int task) {
        const auto [g, firstRow] = tasks[size_t(task)];
        const FaceGroup& group = groups[g];
        const int groupRowCount = groupRows(group, n),
                  rows = std::min(kRowsPerTask, groupRowCount - firstRow);
        resampleRows(footprints, group, firstRow, rows, cubemap);
        // The group's faces' rows, n each, shared out over its tasks.
        const uint64_t faceRows = uint64_t(n) * (group.faces.size() / (group.fourFold ? 4 : 1));
        countWork(progress, faceRows * uint64_t(firstRow + rows) / uint64_t(groupRowCount) -
                                faceRows * uint64_t(firstRow) / uint64_t(groupRowCount));
    });
    return cubemap;
}

} // namespace shprobe
