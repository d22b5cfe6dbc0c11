// Fast projection of cube maps and equirect maps onto SH on the CPU: the sums of projectCubemap and
// projectEquirect (projection.h), in float on SIMD lanes and on all cores, for when speed matters and
// the double reference is not asked for. Accuracy: within about 1e-6 of |L_00| of the reference at
// 6 x 2048^2 (float sums per row, double across rows), and so for equirect maps (measured in
// docs/gpu-path.md). The result is bit-identical for every thread count.
#pragma once
#include "sh/coefficients.h"
#include "sh/cubemap.h"

#include <cstdint>
#include <span>

namespace shprobe {

// The instruction sets the kernels may use, widest first. On x86-64 (GCC builds) the kernels are
// compiled for x86-64-v4 (AVX-512), x86-64-v3 (AVX2, FMA, F16C) and the baseline (halves converted
// without F16C), and run the widest the processor has, up to the one asked; elsewhere there is one
// kernel, for the target, whatever is asked.
enum class KernelLevel { X86_64_V4, X86_64_V3, Baseline };

struct FastProjectionOptions {
    unsigned threads = 0; // 0: all cores (fewer for small inputs, where starting threads costs more)
    KernelLevel widest = KernelLevel::X86_64_V4; // narrower: to check the narrower kernels
};

// The widest kernels this processor runs (Baseline where there are no others).
KernelLevel widestKernelLevel();

// The RGB of texels to RGBA16F, four halves a 64-bit word (TexelFormat::Rgba16F) with alpha 0 (the
// projection reads RGB), each value rounded to the nearest half, from +-65520 on to an infinity. By
// F16C where the processor has it and `widest` allows (x86-64-v3 and up), else by
// glm::packHalf4x16, which rounds ties away from zero where F16C rounds them to even.
void packHalves(std::span<const glm::vec4> texels, uint64_t* halves,
                KernelLevel widest = KernelLevel::X86_64_V4);

// Radiance coefficients of orders 1..kMaxOrder. texels: 6 faces of faceSize^2 texels, face-major in
// Vulkan layer order (Cubemap's layout), RGBA. Throws Error(Input) for a face size below 1, an
// order out of range or no texels.
ShCoefficients projectFacesFast(const void* texels, TexelFormat format, int faceSize, int order,
                                const FastProjectionOptions& options = {});

// The same for faces where they lie (FaceRows, cubemap.h): the same sums, in the same order, as for
// a copy of them into a Cubemap. Also throws Error(Input) for a row stride below the face size.
ShCoefficients projectFacesFast(const FaceRows& faces, TexelFormat format, int faceSize, int order,
                                const FastProjectionOptions& options = {});
// The same for a Cubemap; also throws Error(Input) if its texel count disagrees with its face size.
ShCoefficients projectCubemapFast(const Cubemap& cubemap, int order,
                                  const FastProjectionOptions& options = {});

// Radiance coefficients of an equirect map (docs/conventions.md, "Equirectangular maps"): texels are
// width x height, rows top to bottom, RGBA; each pixel weighted by the exact solid angle of its row,
// (2 pi / W)(cos theta_j - cos theta_j+1), as projectEquirect does. Throws Error(Input) for a size
// below 1, an order out of range or no texels.
ShCoefficients projectEquirectFast(const void* texels, TexelFormat format, int width, int height, int order,
                                   const FastProjectionOptions& options = {});
// The same for an Image; also throws Error(Input) if its texel count disagrees with its size.
ShCoefficients projectEquirectFast(const Image& equirect, int order,
                                   const FastProjectionOptions& options = {});

} // namespace shprobe
