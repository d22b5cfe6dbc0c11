// Specular radiance cube maps prefiltered for GGX roughness, as glTF's EXT_lights_image_based holds
// them: mip i of a chain from `size` down to 16 x 16 faces is the radiance seen in the mirror
// direction R by a surface of roughness r_i = i / (N - 1) (GGX alpha = r_i^2), under the split-sum
// assumption n = v = R (Karis, "Real Shading in Unreal Engine 4", 2013):
//
//   P(R) = integral L(l) D(h) max(0, R.l) dl / integral D(h) max(0, R.l) dl,   h = normalize(R + l),
//
// a kernel that depends on R.l alone. Mip 0 (roughness 0) is the environment itself, area-resized;
// the other mips are that integral as a direct sum over a solid-angle mip pyramid of mip 0, each
// texel's radiance times its solid angle weighted by the kernel at its centre: texels near R come
// from levels fine enough to resolve the lobe, far ones from coarse levels, refined wherever a
// texel is seen from R under more than 1/8 of its distance (the kernel's tails are smooth there).
// Deterministic, and within 0.5% of a quadrature of the integral (test_specular_export).
#pragma once
#include "sh/coefficients.h"
#include "sh/cubemap.h"
#include "sh/lights.h"

#include <glm/vec3.hpp>
#include <vector>

namespace shprobe {

constexpr int kSmallestSpecularMip = 16; // the extension's example size for roughness 1
constexpr int kDefaultSpecularSize = 128;
// At least two mips: one mip cannot span roughness 0 to 1 (r_i = i / (N - 1) needs N >= 2; a
// reader such as Babylon, whose LOD scale is (N - 1) / log2(size), would read it at every
// roughness). At most 512: the sums grow about 5 times a doubling of the size (docs/benchmark.md).
constexpr int kMinSpecularSize = 2 * kSmallestSpecularMip;
constexpr int kMaxSpecularSize = 512;

// A power of two from kMinSpecularSize to kMaxSpecularSize.
bool isSpecularSize(int size);
// log2(size / 16) + 1: the mips from size down to 16.
int specularMipCount(int size);
// i / (mipCount - 1).
double specularMipRoughness(int mip, int mipCount);

// The chain of specularMipCount(size) mips, mips[i] of face size size >> i. mips[0] is
// resizeCubemap(environment, size): an area average when shrinking. Every mip's texels are >= 0
// where the environment's are. Throws Error(Input) unless isSpecularSize(size).
std::vector<Cubemap> prefilterSpecular(const Cubemap& environment, int size);

// The GGX kernel of the formula above, D(h) max(0, R.l), as a function of c = R.l (with n = v = R,
// cos^2 theta_h = (1 + c) / 2): alpha^2 c / (pi ((1 + c) / 2 (alpha^2 - 1) + 1)^2) for c > 0.
double specularKernel(double cosine, double alpha);

// Sources of the chain beside an environment map.
// The radiance of SH coefficients (radiance ones) at each texel's centre, clamped to >= 0: the
// band-limited radiance a probe file holds.
Cubemap radianceCubemap(const ShCoefficients& radiance, int faceSize);
// Adds a uniform radiance to every texel.
void addUniformRadiance(Cubemap& cubemap, const glm::dvec3& radiance);
// Adds a spherical light's cap: each texel gets the light's radiance times the share of its solid
// angle inside the cap (a grid of samples per texel, at least 8 across the cap's radius), so that
// a cap smaller than a texel keeps its power.
void drawSphericalLight(Cubemap& cubemap, const SphericalLight& light);

} // namespace shprobe
