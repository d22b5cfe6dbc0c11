// Reference projection L_lm = sum_texels L(w) y_lm(w) Omega (Sloan, "Stupid Spherical Harmonics (SH)
// Tricks", projection from cube maps), each texel weighted by its exact solid angle; accumulated in double.
// Alpha is ignored.
#include "sh/projection.h"

#include "common/error.h"
#include "common/parallel.h"
#include "sh/basis.h"
#include "sh/irradiance.h"

#include <array>
#include <string>

namespace shprobe {

namespace {

using BasisValues = std::array<double, coefficientCount(kMaxOrder)>;

ShCoefficients makeRadianceCoefficients(int order) {
    requireOrder(order);
    return makeCoefficients(order, Quantity::Radiance);
}

// Adds one sample's contribution L(w) y_i(w) Omega to every coefficient.
void accumulateSample(ShCoefficients& sum, const glm::vec4& texel, const glm::dvec3& direction,
                      double solidAngle, BasisValues& basis) {
    evalBasis(sum.order, direction, basis);
    const glm::dvec3 weighted = glm::dvec3(texel.r, texel.g, texel.b) * solidAngle;
    for (size_t i = 0; i < sum.rgb.size(); ++i)
        sum.rgb[i] += weighted * basis[i];
}

// Solid angles of the texels of one face, row after row; all six faces share them.
std::vector<double> faceSolidAngles(int faceSize) {
    std::vector<double> solidAngles(size_t(faceSize) * size_t(faceSize));
    for (int j = 0; j < faceSize; ++j) {
        for (int i = 0; i < faceSize; ++i)
            solidAngles[size_t(j) * faceSize + i] = texelSolidAngle(i, j, faceSize);
    }
    return solidAngles;
}

void requireTexelCount(size_t actual, size_t expected, const char* what) {
    if (actual != expected) {
        throw Error(ErrorKind::Input, std::string(what) + " holds " + std::to_string(actual) +
                                          " texels, expected " + std::to_string(expected));
    }
}

} // namespace

ShCoefficients projectCubemap(const Cubemap& cubemap, int order, WorkCounter* progress) {
    const int n = cubemap.faceSize;
    requireTexelCount(cubemap.texels.size(), size_t(kFaceCount) * size_t(n) * size_t(n), "cube map");
    ShCoefficients sum = makeRadianceCoefficients(order);
    const std::vector<double> solidAngles = faceSolidAngles(n);
    startWork(progress, "projecting, rows", uint64_t(kFaceCount) * uint64_t(n), uint64_t(n));
    BasisValues basis{};
    for (int face = 0; face < kFaceCount; ++face) {
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i) {
                accumulateSample(sum, cubemap.at(face, i, j), texelDirection(face, i, j, n),
                                 solidAngles[size_t(j) * n + i], basis);
            }
            countWork(progress, 1);
        }
    }
    return sum;
}

ShCoefficients projectEquirect(const Image& equirect, int order, WorkCounter* progress) {
    const int w = equirect.width;
    const int h = equirect.height;
    requireTexelCount(equirect.texels.size(), size_t(w) * size_t(h), "equirect image");
    ShCoefficients sum = makeRadianceCoefficients(order);
    startWork(progress, "projecting, rows", uint64_t(h), uint64_t(w));
    BasisValues basis{};
    for (int j = 0; j < h; ++j) {
        const double rowSolidAngle = equirectRowSolidAngle(j, w, h);
        for (int i = 0; i < w; ++i) {
            accumulateSample(sum, equirect.at(i, j), equirectDirection(i, j, w, h), rowSolidAngle, basis);
        }
        countWork(progress, 1);
    }
    return sum;
}

Cubemap evaluateCubemap(const ShCoefficients& coefficients, int faceSize) {
    Cubemap cubemap = makeCubemap(faceSize);
    forEachItem(kFaceCount * faceSize, threadCount(cubemap.texels.size(), 4096), [&](int row) {
        const int face = row / faceSize, j = row % faceSize;
        for (int i = 0; i < faceSize; ++i)
            cubemap.at(face, i, j) =
                glm::vec4(glm::vec3(evaluate(coefficients, texelDirection(face, i, j, faceSize))), 1.0f);
    });
    return cubemap;
}

} // namespace shprobe
