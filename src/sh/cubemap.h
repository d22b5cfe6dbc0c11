// Environment images held in memory, and the double-precision geometry of their texels.
// Cube-map face order and orientation are Vulkan's; see src/glsl/texel_geometry.h for the
// diagram and the face direction table shared with the shaders.
#pragma once
#include <array>
#include <cstddef>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <vector>

namespace shprobe {

enum class Face { PositiveX, NegativeX, PositiveY, NegativeY, PositiveZ, NegativeZ };
constexpr int kFaceCount = 6;

// How texels are stored outside a Cubemap (which holds RGBA32F): 4 channels (RGBA, alpha ignored)
// of IEEE single or half floats.
enum class TexelFormat { Rgba32F, Rgba16F };
constexpr size_t texelBytes(TexelFormat format) {
    return format == TexelFormat::Rgba16F ? 8 : 16;
}
// The largest finite half float (IEEE 754 binary16): RGBA16F holds values within +-kHalfMax.
constexpr float kHalfMax = 65504.0f;

// Where six faces' texels lie when they are not one after another, as in a horizontal cross: face
// f's row j (top to bottom, as in a Cubemap) starts rowStrides[f] * j texels after faces[f], its
// faceSize texels consecutive.
struct FaceRows {
    std::array<const void*, kFaceCount> faces{};
    std::array<size_t, kFaceCount> rowStrides{}; // in texels, at least faceSize
};

// Six N x N faces, face after face in Face order, rows top to bottom, RGBA32F (alpha unused).
// This is also the layout the GPU projection reads.
struct Cubemap {
    int faceSize = 0;
    std::vector<glm::vec4> texels; // kFaceCount * faceSize * faceSize

    glm::vec4& at(int face, int i, int j) { return texels[(size_t(face) * faceSize + j) * faceSize + i]; }
    const glm::vec4& at(int face, int i, int j) const {
        return texels[(size_t(face) * faceSize + j) * faceSize + i];
    }
};
// Every texel `fill`; Error(Input) for a face size below 1, Error(Memory) where the machine cannot
// hold it.
Cubemap makeCubemap(int faceSize, glm::vec4 fill = glm::vec4(0.0f));
// Throws Error(Input) for a face size makeCubemap refuses (not positive), so that an option can be
// checked before any work.
void requireFaceSize(int faceSize);

// A W x H image, rows top to bottom, RGBA32F (alpha unused). Equirect maps use this type.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<glm::vec4> texels;

    glm::vec4& at(int x, int y) { return texels[size_t(y) * width + x]; }
    const glm::vec4& at(int x, int y) const { return texels[size_t(y) * width + x]; }
};
Image makeImage(int width, int height, glm::vec4 fill = glm::vec4(0.0f));

// Whether makeCubemap and makeImage ask the kernel to back their texels with transparent huge pages
// (madvise, where the system lends them on request): fresh memory then faults in 2 MiB at a time,
// not 4 KiB. Off unless asked, so that a program linking the library keeps its allocator's ways;
// shprobe's programs ask with their heap (app/heap.h).
void adviseTexelHugePages(bool advise);

// Face-local coordinate of the center of texel i on an N-wide face: 2(i + 0.5)/N - 1.
inline double texelCenterCoord(int i, int faceSize) {
    return 2.0 * (i + 0.5) / faceSize - 1.0;
}
// Direction of face-local point (a, b) by the face table of docs/conventions.md, not normalized:
// each component is 0, +-1, +-a or +-b, so it is linear in a and in b.
glm::dvec3 unnormalizedFaceDirection(int face, double a, double b);
// Unit direction through the center of texel (i, j) of a face (docs/conventions.md), in double.
glm::dvec3 texelDirection(int face, int i, int j, int faceSize);
// Unit direction of face-local point (a, b) in [-1, 1]^2.
glm::dvec3 faceDirection(int face, double a, double b);
// Inverse of faceDirection: the face a direction hits and its face-local (a, b) in [-1, 1].
struct FacePoint {
    int face;
    double a;
    double b;
};
FacePoint directionToFace(const glm::dvec3& d);

// Exact solid angle of texel (i, j) of an N x N face: the four-atan2 formula of docs/conventions.md
// ("Texel weight"), in double (relative error about 1e-9 at N = 4096).
double texelSolidAngle(int i, int j, int faceSize);
// F(a, b) = atan2(a b, sqrt(a^2 + b^2 + 1)), the solid angle between the face's centre and its
// point (a, b), signed: a face rectangle's is F(a0, b0) - F(a0, b1) - F(a1, b0) + F(a1, b1).
double cornerSolidAngle(double a, double b);

// Equirect (latitude-longitude) maps, docs/conventions.md: pixel (i, j) of W x H.
glm::dvec3 equirectDirection(int i, int j, int width, int height);
// Continuous pixel coordinates (x in [0, W), y in [0, H], H only at the -Y pole) of a direction;
// inverse of the above (pixel (i, j) maps back to (i + 0.5, j + 0.5)).
struct PixelPoint {
    double x;
    double y;
};
PixelPoint directionToEquirect(const glm::dvec3& d, int width, int height);
// The same for a direction already of unit length (faceDirection's), without normalizing it again.
PixelPoint unitDirectionToEquirect(const glm::dvec3& n, int width, int height);
// Exact solid angle of any pixel of row j: (2 pi / W)(cos theta0 - cos theta1).
double equirectRowSolidAngle(int j, int width, int height);

} // namespace shprobe
