// Double-precision texel geometry of cube maps and equirect maps (docs/conventions.md, "Cube-map
// faces", "Texel weight" and "Equirectangular maps"). The float twin used by the shaders is
// src/glsl/texel_geometry.h.
#include "sh/cubemap.h"

#include "common/error.h"

#include <glm/geometric.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <new>
#include <numbers>
#include <string>
#include <sys/mman.h>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;

void requirePositiveSize(int size, const char* what) {
    if (size <= 0) {
        throw Error(ErrorKind::Input, std::string(what) + " must be positive, got " + std::to_string(size));
    }
}

} // namespace

// The table of docs/conventions.md, in Vulkan's face order.
glm::dvec3 unnormalizedFaceDirection(int face, double a, double b) {
    switch (Face(face)) {
    case Face::PositiveX:
        return {1.0, -b, -a};
    case Face::NegativeX:
        return {-1.0, -b, a};
    case Face::PositiveY:
        return {a, 1.0, b};
    case Face::NegativeY:
        return {a, -1.0, -b};
    case Face::PositiveZ:
        return {a, -b, 1.0};
    case Face::NegativeZ:
        return {-a, -b, -1.0};
    }
    throw Error(ErrorKind::Input, "cube-map face index out of range: " + std::to_string(face));
}

namespace {

// Face-local coordinate of the left (or top) edge of texel i: 2i/N - 1.
double texelEdgeCoord(int i, int faceSize) {
    return 2.0 * i / faceSize - 1.0;
}

// The face whose axis is the direction's major axis (Vulkan "Cube Map Face Selection");
// ties go to x, then y.
Face majorAxisFace(const glm::dvec3& d) {
    const glm::dvec3 m = glm::abs(d);
    if (m.x >= m.y && m.x >= m.z) return d.x >= 0.0 ? Face::PositiveX : Face::NegativeX;
    if (m.y >= m.z) return d.y >= 0.0 ? Face::PositiveY : Face::NegativeY;
    return d.z >= 0.0 ? Face::PositiveZ : Face::NegativeZ;
}

std::atomic<bool> texelHugePages{false}; // adviseTexelHugePages

// Asks the kernel to back [start, start + bytes) with transparent huge pages. Filling a cube map of
// 6 x 1024^2 texels (96 MiB) took 24,576 faults of 4 KiB, about 250 ms on one thread. Advice only:
// where it is refused, the pages come as before.
void adviseHugePages(void* start, size_t bytes) {
#ifdef MADV_HUGEPAGE
    constexpr uintptr_t kHugePage = uintptr_t(2) << 20;
    const uintptr_t first = (uintptr_t(start) + kHugePage - 1) & ~(kHugePage - 1);
    const uintptr_t end = (uintptr_t(start) + bytes) & ~(kHugePage - 1);
    if (end > first) madvise(reinterpret_cast<void*>(first), end - first, MADV_HUGEPAGE);
#else
    (void)start;
    (void)bytes;
#endif
}

// `rows` rows of `rowTexels`, each `fill`; where the machine cannot allocate them, one line saying
// what and how much, not a bare std::bad_alloc. The count is checked before it is multiplied out:
// 6 N^2 passes size_t for N near 2^31.
std::vector<glm::vec4> allocateTexels(size_t rows, size_t rowTexels, glm::vec4 fill,
                                      const std::string& what) {
    auto outOfMemory = [&] { // the message only where it is needed
        char size[32];
        std::snprintf(size, sizeof(size), "%.1f GiB",
                      double(rows) * double(rowTexels) * sizeof(glm::vec4) / double(1u << 30));
        return Error(ErrorKind::Memory, "out of memory: " + what + " needs " + size);
    };
    if (rows > std::vector<glm::vec4>().max_size() / rowTexels) throw outOfMemory();
    try {
        std::vector<glm::vec4> texels;
        texels.reserve(rows * rowTexels); // allocated, not yet touched
        if (texelHugePages) adviseHugePages(texels.data(), rows * rowTexels * sizeof(glm::vec4));
        texels.resize(rows * rowTexels, fill);
        return texels;
    } catch (const std::bad_alloc&) {
        throw outOfMemory();
    }
}

} // namespace

// F(a, b): the solid angle of the face region between the face center and corner (a, b), signed
// (docs/conventions.md, "Texel weight").
double cornerSolidAngle(double a, double b) {
    return std::atan2(a * b, std::sqrt(a * a + b * b + 1.0));
}

void requireFaceSize(int faceSize) {
    requirePositiveSize(faceSize, "cube-map face size");
}

Cubemap makeCubemap(int faceSize, glm::vec4 fill) {
    requireFaceSize(faceSize);
    const std::string size = std::to_string(faceSize);
    return Cubemap{faceSize, allocateTexels(size_t(kFaceCount) * size_t(faceSize), size_t(faceSize), fill,
                                            "a cube map of 6 x " + size + "^2 texels")};
}

Image makeImage(int width, int height, glm::vec4 fill) {
    requirePositiveSize(width, "image width");
    requirePositiveSize(height, "image height");
    return Image{
        width, height,
        allocateTexels(size_t(height), size_t(width), fill,
                       "an image of " + std::to_string(width) + " x " + std::to_string(height) + " texels")};
}

void adviseTexelHugePages(bool advise) {
    texelHugePages = advise;
}

glm::dvec3 faceDirection(int face, double a, double b) {
    return glm::normalize(unnormalizedFaceDirection(face, a, b));
}

glm::dvec3 texelDirection(int face, int i, int j, int faceSize) {
    return faceDirection(face, texelCenterCoord(i, faceSize), texelCenterCoord(j, faceSize));
}

// Inverts the face table: divide by the major-axis magnitude, then read (a, b) off the other two.
FacePoint directionToFace(const glm::dvec3& d) {
    const Face face = majorAxisFace(d);
    const glm::dvec3 p = d / glm::max(glm::max(std::abs(d.x), std::abs(d.y)), std::abs(d.z));
    switch (face) {
    case Face::PositiveX:
        return {int(face), -p.z, -p.y};
    case Face::NegativeX:
        return {int(face), p.z, -p.y};
    case Face::PositiveY:
        return {int(face), p.x, p.z};
    case Face::NegativeY:
        return {int(face), p.x, -p.z};
    case Face::PositiveZ:
        return {int(face), p.x, -p.y};
    case Face::NegativeZ:
        return {int(face), -p.x, -p.y};
    }
    return {}; // unreachable: majorAxisFace returns one of the six faces
}

// Omega = F(a0, b0) - F(a0, b1) - F(a1, b0) + F(a1, b1) (docs/conventions.md). In double the
// cancellation costs about 1e-16 / (4/N^2) relative: below 1e-9 at N = 4096.
double texelSolidAngle(int i, int j, int faceSize) {
    const double a0 = texelEdgeCoord(i, faceSize);
    const double a1 = texelEdgeCoord(i + 1, faceSize);
    const double b0 = texelEdgeCoord(j, faceSize);
    const double b1 = texelEdgeCoord(j + 1, faceSize);
    return cornerSolidAngle(a0, b0) - cornerSolidAngle(a0, b1) - cornerSolidAngle(a1, b0) +
           cornerSolidAngle(a1, b1);
}

// docs/conventions.md, "Equirectangular maps": theta = pi v, phi = 2 pi u - pi,
// d = (sin theta sin phi, cos theta, -sin theta cos phi).
glm::dvec3 equirectDirection(int i, int j, int width, int height) {
    const double theta = kPi * (j + 0.5) / height;
    const double phi = 2.0 * kPi * (i + 0.5) / width - kPi;
    const double sinTheta = std::sin(theta);
    return {sinTheta * std::sin(phi), std::cos(theta), -sinTheta * std::cos(phi)};
}

// theta = acos(y), phi = atan2(x, -z) in [-pi, pi]; x = u W wraps W to 0, y = v H reaches H only
// at the -Y pole.
PixelPoint directionToEquirect(const glm::dvec3& d, int width, int height) {
    return unitDirectionToEquirect(glm::normalize(d), width, height);
}

PixelPoint unitDirectionToEquirect(const glm::dvec3& n, int width, int height) {
    const double theta = std::acos(glm::clamp(n.y, -1.0, 1.0));
    const double phi = std::atan2(n.x, -n.z);
    double x = (phi + kPi) / (2.0 * kPi) * width;
    if (x >= width) x -= width;
    return {x, theta / kPi * height};
}

// (2 pi / W)(cos theta0 - cos theta1), written as 2 sin((theta0 + theta1)/2) sin((theta1 - theta0)/2)
// so that thin polar rows do not lose digits to cancellation.
double equirectRowSolidAngle(int j, int width, int height) {
    const double theta0 = kPi * j / height;
    const double theta1 = kPi * (j + 1) / height;
    const double cosDifference = 2.0 * std::sin(0.5 * (theta0 + theta1)) * std::sin(0.5 * (theta1 - theta0));
    return 2.0 * kPi / width * cosDifference;
}

} // namespace shprobe
