// Fast float projection of cube maps and equirect maps onto SH (fast_projection.h). The sums are the
// reference's (projection.cpp), L_lm = sum L(w) y_lm(w) Omega, rearranged so that little more than
// the multiply-adds remains per texel. Cube maps:
//
// 1. One grid for six faces. Face f's unit direction at face-local (a, b) is P_f v, with
//    v = (a, b, 1) / sqrt(a^2 + b^2 + 1) and P_f the signed permutation of orientToFace
//    (texel_geometry.h); the solid angle Omega depends on (a, b) alone. Each face is projected in its
//    own frame, T_f = sum L_f(a, b) Omega(a, b) y(v), from one table of Omega y(v) that serves all
//    six faces. Every P_f is a reflection (det -1): P_f = -Q_f with Q_f a rotation, and
//    y_lm(-w) = (-1)^l y_lm(w), so the world coefficients are sum_f D(Q_f) (-1)^l T_f, D being the
//    band rotation matrices of rotation.h (a face's frame turned into the world's).
// 2. Mirror symmetry within a face. y_lm(x, y, z) is even or odd in x and in y: for m >= 0 it is
//    cos(m phi) times a function of z and |sin theta|, odd in x for odd m and even in y; for m < 0 it
//    is sin(|m| phi) times such a function, odd in x for even |m| and odd in y. The texels at
//    (a, b), (-a, b), (a, -b), (-a, -b) share Omega and |y_lm(v)|, so their radiances are first
//    combined into four sums, one per parity (a 2 x 2 Hadamard transform), and each coefficient takes
//    the sum of its parity: order^2 multiply-adds per four texels. On odd faces the middle column
//    and row are their own mirror images: their weight is halved and they are counted twice.
// 3. Lanes. Eight float lanes hold two texels' RGBA, and one multiply-add by Omega y_k, spread
//    over each texel's four channels, serves both.
// 4. Memory. The texels are asked for (prefetched) in memory order one face ahead, because the
//    mirror images are read from both ends of two rows at once (see NextRows).
// 5. Precision. Sums run in float along a row of positions in short runs (a stage of 64 pairs for
//    a cube map, chunks of 16 pairs for an equirect map, whose products repeat: see
//    accumulateCoefficients), each added to the row's sums, then in double across rows and faces.
// 6. Threads. The rows are split into blocks fixed by the input's size alone; each block's double sums
//    are kept apart and the blocks are added in index order, so the result does not depend on the
//    number of threads nor on which thread ran which block.
//
// Equirect maps (W x H, docs/conventions.md) go through the same rows, lanes, stages, blocks and
// threads, as one face of W x H texels whose table serves every row:
//
// 7. Frame. The direction of pixel (i, j) is P v with v = (sin theta cos phi, sin theta sin phi,
//    cos theta), theta = pi (j + 0.5) / H, phi = 2 pi (i + 0.5) / W - pi, and P a fixed reflection
//    (kEquirectOrientation), turned into the world as a face's frame is (1.).
// 8. Separation (the azimuthal Fourier transform first, then the Legendre transform, as in Driscoll
//    and Healy, "Computing Fourier Transforms and Convolutions on the 2-Sphere", 1994). In the frame,
//    y_l,m(v) = y_l,|m|(theta, 0) cos(m phi) for m >= 0 and y_l,|m|(theta, 0) sin(|m| phi) for m < 0,
//    and every pixel of row j has the exact solid angle Omega_j = (2 pi / W)(cos theta_j -
//    cos theta_j+1). So a row needs only its Fourier sums C_m = sum_i L cos(m phi_i) and
//    S_m = sum_i L sin(m phi_i), m < n (2n - 1 of them), in float along the row; then, in double,
//    T_l,m += Omega_j y_l,m(theta_j, 0) C_m and T_l,-m += Omega_j y_l,m(theta_j, 0) S_m. The table
//    holds cos(m phi_i) and sin(m phi_i), the same for every row.
// 9. Mirror symmetry. Column W-1-i has phi -> -phi (cosines even, sines odd), row H-1-j has
//    theta -> pi - theta, under which y_l,m(theta, 0) takes the sign (-1)^(l+m) (P_l^m(-z) =
//    (-1)^(l+m) P_l^m(z)). The four parity sums of a position serve as for a face: each Fourier sum
//    is taken twice, with the radiance even and odd under the row mirror, 2 (2n - 1) multiply-adds per
//    four texels (30 at order 8, against 64 for a face's position).
#include "sh/fast_projection.h"

#include "common/error.h"
#include "glsl/texel_geometry.h"
#include "sh/basis.h"
#include "sh/rotation.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <glm/gtc/packing.hpp>
#include <memory>
#include <new>
#include <numbers>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

// The kernels are compiled for x86-64-v4 (AVX-512), x86-64-v3 (AVX2, FMA, F16C) and the baseline,
// and the best one the processor runs is chosen at the first projection (x86-64 with GCC);
// elsewhere they are compiled for the target alone. flatten inlines the lane functions into each
// copy, so that they too are compiled for its instruction set. GCC's target_clones would choose at
// load time instead, by resolvers that run libgcc's processor detection as every process starts
// (cpuid traps to the hypervisor on a VM: there, a tenth of `shprobe --help`).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define SHPROBE_X86_LEVELS 1
#else
#define SHPROBE_X86_LEVELS 0
#endif

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if SHPROBE_X86_LEVELS
#include <cpuid.h>
#include <immintrin.h>
#endif

// The lane functions below return 32-byte vectors by value (and take them by reference, as GCC notes
// even a suppressed ABI warning for such arguments). They are internal and inlined into the kernels,
// so the x86-64 ABI difference for such values with and without AVX never meets code compiled
// elsewhere.
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

namespace shprobe {

namespace {

// ------------------------------------------------------------------------------------------------
// Lanes: GCC and Clang vector extensions, lowered to the widest SIMD of the clone being compiled
// (two SSE registers on the x86-64 baseline).

using Lanes = float __attribute__((vector_size(32))); // two texels' RGBA, or eight positions
using LaneBits = uint32_t __attribute__((vector_size(32)));
using HalfLanes = uint16_t __attribute__((vector_size(16))); // two texels' RGBA in half floats
constexpr int kLaneCount = 8;
constexpr int kChannels = 4; // RGBA; alpha is carried along and dropped at the end
constexpr int kParities = 4; // even/odd in x times even/odd in y

// Heap arrays of Lanes, 32-byte aligned. The AVX clones load and store Lanes as 32-byte aligned, but
// the baseline x86-64 build (without AVX) aligns a 32-byte vector type to 16 bytes only, and standard
// containers ignore alignment attributes on their element type: allocations are aligned by hand.
constexpr std::align_val_t kLaneAlignment{32};

struct AlignedDelete {
    void operator()(Lanes* lanes) const { ::operator delete(lanes, kLaneAlignment); }
};
using LaneArray = std::unique_ptr<Lanes[], AlignedDelete>;

LaneArray makeLaneArray(size_t count) {
    void* memory = ::operator new(count * sizeof(Lanes), kLaneAlignment);
    std::memset(memory, 0, count * sizeof(Lanes));
    return LaneArray(static_cast<Lanes*>(memory));
}

// Lane-wise square root. The vector extensions have none, and std::sqrt in a loop is not vectorized
// because it may set errno; SSE2, part of x86-64, has one (correctly rounded, like std::sqrt).
Lanes laneSqrt(const Lanes& x) {
#if defined(__SSE2__)
    const __m128 low = _mm_sqrt_ps(__builtin_shufflevector(x, x, 0, 1, 2, 3));
    const __m128 high = _mm_sqrt_ps(__builtin_shufflevector(x, x, 4, 5, 6, 7));
    return __builtin_shufflevector(low, high, 0, 1, 2, 3, 4, 5, 6, 7);
#else
    Lanes root;
    for (int lane = 0; lane < kLaneCount; ++lane)
        root[lane] = std::sqrt(x[lane]);
    return root;
#endif
}

// [v_q x4, v_4+q x4]: from the values of four coefficients at two positions (the first four lanes
// for one position, the last four for the other), coefficient q over the four channels of each
// position's texel. One shuffle within 128-bit halves.
template <int Q> Lanes spreadCoefficient(const Lanes& v) {
    return __builtin_shufflevector(v, v, Q, Q, Q, Q, 4 + Q, 4 + Q, 4 + Q, 4 + Q);
}

Lanes splat(float value) {
    return Lanes{value, value, value, value, value, value, value, value};
}

// Exchanges the two texels held in the lanes.
Lanes swapTexels(const Lanes& v) {
    return __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
}

// IEEE half to float, exact for every value (F. Giesen, "Half to float done quick", 2012): a half's
// exponent and mantissa, moved to the mantissa position of a float, make a float 2^112 times too
// small, for normal and subnormal halves alike (the float is then normal or subnormal in the same
// way), so one multiplication by 2^112 rescales them exactly. The all-ones exponent (infinity, NaN)
// is mapped apart. Needs subnormal floats (no flush-to-zero), the default in C++.
Lanes halfToFloat(HalfLanes half) {
    const LaneBits bits = __builtin_convertvector(half, LaneBits);
    const LaneBits magnitude = (bits & 0x7fffu) << 13;
    const LaneBits sign = (bits & 0x8000u) << 16;
    const LaneBits infinityOrNan = std::bit_cast<LaneBits>((bits & 0x7c00u) == 0x7c00u);
    const LaneBits finite = std::bit_cast<LaneBits>(std::bit_cast<Lanes>(magnitude) * 0x1p112f);
    const LaneBits special = magnitude | 0x7f800000u;
    return std::bit_cast<Lanes>(((finite & ~infinityOrNan) | (special & infinityOrNan)) | sign);
}

// Loads one or two adjacent texels into lanes; with one, the second texel's lanes are 0.
struct Rgba32FTexels {
    static constexpr size_t kTexelBytes = kChannels * sizeof(float);
    static Lanes loadTwo(const std::byte* texel) {
        Lanes v;
        std::memcpy(&v, texel, sizeof v);
        return v;
    }
    static Lanes loadOne(const std::byte* texel) {
        Lanes v{};
        std::memcpy(&v, texel, kTexelBytes);
        return v;
    }
};

struct Rgba16FTexels {
    static constexpr size_t kTexelBytes = kChannels * sizeof(uint16_t);
    static Lanes loadTwo(const std::byte* texel) {
        HalfLanes h;
        std::memcpy(&h, texel, sizeof h);
        return halfToFloat(h);
    }
    static Lanes loadOne(const std::byte* texel) {
        HalfLanes h{};
        std::memcpy(&h, texel, kTexelBytes);
        return halfToFloat(h);
    }
};

#if SHPROBE_X86_LEVELS
// Eight halves to floats by F16C's one instruction (exact, like halfToFloat). Compiled for F16C
// alone, and inlined into the kernels that have it (x86-64-v3 and v4); the baseline ones convert
// without it. The floats go through memory, untyped, as Lanes are aligned differently there.
[[gnu::target("f16c")]] void convertHalvesF16c(const std::byte* halves, void* floats) {
    __m128i bits;
    std::memcpy(&bits, halves, sizeof bits);
    const __m256 converted = _mm256_cvtph_ps(bits);
    std::memcpy(floats, &converted, sizeof converted);
}

// Texels' RGB to halves by F16C, one texel an instruction, rounded to nearest even; alpha 0.
[[gnu::target("f16c")]] void packHalvesF16c(std::span<const glm::vec4> texels, uint64_t* halves) {
    const __m128 rgb = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
    for (size_t t = 0; t < texels.size(); ++t) {
        const __m128 texel = _mm_and_ps(_mm_loadu_ps(&texels[t].x), rgb);
        _mm_storel_epi64(reinterpret_cast<__m128i*>(halves + t),
                         _mm_cvtps_ph(texel, _MM_FROUND_TO_NEAREST_INT));
    }
}

// RGBA16F texels where the processor has F16C.
struct Rgba16FTexelsF16c {
    static constexpr size_t kTexelBytes = Rgba16FTexels::kTexelBytes;
    static Lanes loadTwo(const std::byte* texel) {
        Lanes floats;
        convertHalvesF16c(texel, &floats);
        return floats;
    }
    static Lanes loadOne(const std::byte* texel) {
        std::byte halves[2 * kTexelBytes] = {};
        std::memcpy(halves, texel, kTexelBytes);
        return loadTwo(halves);
    }
};

// The widest of the kernels' instruction sets the processor runs, by the x86-64 psABI's levels:
// each level's features in cpuid, and the AVX (and AVX-512) registers saved by the operating
// system (xgetbv, read only where OSXSAVE says it may be), without which the instructions fault.
uint64_t savedRegisterState() {
    unsigned low = 0, high = 0;
    asm("xgetbv" : "=a"(low), "=d"(high) : "c"(0));
    return uint64_t(high) << 32 | low;
}

KernelLevel detectWidestKernelLevel() {
    unsigned a = 0, b = 0, c = 0, d = 0;
    if (!__get_cpuid(1, &a, &b, &c, &d)) return KernelLevel::Baseline;
    const unsigned v2 = bit_SSE3 | bit_SSSE3 | bit_SSE4_1 | bit_SSE4_2 | bit_POPCNT | bit_CMPXCHG16B;
    const unsigned v3 = bit_FMA | bit_MOVBE | bit_AVX | bit_F16C | bit_OSXSAVE;
    if ((c & (v2 | v3)) != (v2 | v3) || __get_cpuid_max(0, nullptr) < 7) return KernelLevel::Baseline;
    const uint64_t saved = savedRegisterState();
    if ((saved & 0x6u) != 0x6u) return KernelLevel::Baseline; // SSE and AVX state
    unsigned extended = 0;
    if (!__get_cpuid(0x80000001, &a, &b, &extended, &d)) return KernelLevel::Baseline;
    if (!(extended & bit_LAHF_LM) || !(extended & bit_LZCNT)) return KernelLevel::Baseline;
    __cpuid_count(7, 0, a, b, c, d);
    const unsigned v3Leaf7 = bit_AVX2 | bit_BMI | bit_BMI2;
    if ((b & v3Leaf7) != v3Leaf7) return KernelLevel::Baseline;
    const unsigned v4Leaf7 = bit_AVX512F | bit_AVX512BW | bit_AVX512CD | bit_AVX512DQ | bit_AVX512VL;
    const bool v4 = (b & v4Leaf7) == v4Leaf7 && (saved & 0xe0u) == 0xe0u; // opmask and ZMM state
    return v4 ? KernelLevel::X86_64_V4 : KernelLevel::X86_64_V3;
}

#endif

// ------------------------------------------------------------------------------------------------
// The plan: everything fixed by the input, its size and the order, read by all threads.
//
// A position (i, j) stands for the four texels (i, j), (W-1-i, j), (i, H-1-j), (W-1-i, H-1-j) of a
// W x H face (a cube map's N x N; face-local a, b <= 0) or equirect map, for i < (W+1)/2 and
// j < (H+1)/2. Two positions share lanes as a "pair".

// Table lanes per pair: four coefficients at the pair's two positions per lanes.
constexpr int tableLanesPerPair(int coefficients) {
    return (coefficients + 3) / 4;
}

// Blocks of rows, the unit of work of a thread: enough to keep many cores busy, few enough that a
// block holds several rows (see projectBlock), and they bound the memory of the block sums.
constexpr int kMaxBlocks = 64;

struct Plan {
    FaceRows faceRows; // an equirect map: its one "face" as faces[0]
    size_t texelBytes;
    int width;  // texels per row: N for cube maps, whose faces are square
    int height; // rows per face
    int faces;  // kFaceCount, or 1 for an equirect map
    int order;
    int coefficients; // order^2
    int positions;    // positions per row: (W + 1) / 2
    int rows;         // rows of positions: (H + 1) / 2
    int pairs;        // pairs per row: ceil(positions / 2)
    int tablePairs;   // pairs rounded up to a multiple of 4 (the table is built 8 positions at a time)
    int rowSums;      // lanes of float sums per face along a row (CubeTerms, EquirectTerms)
    int blockRows;    // rows of positions per block (the last block may hold fewer)
    int blocks;
    std::array<float, coefficientCount(kMaxOrder)> normalization; // of the recurrence's Y_lm
    const Lanes* sharedTable = nullptr; // equirect maps: the table, the same for every row

    const std::byte* rowTexels(int face, int row) const {
        return static_cast<const std::byte*>(faceRows.faces[size_t(face)]) +
               size_t(row) * faceRows.rowStrides[size_t(face)] * texelBytes;
    }

    // Weight factor of column i of the positions: 1/2 where it is its own mirror image (the middle
    // column of an odd width), 0 beyond the positions (lanes past the end of a row).
    float columnFactor(int i) const {
        if (i >= positions) return 0.0f;
        return i == width - 1 - i ? 0.5f : 1.0f;
    }
    // The same for row j of the positions (the middle row of an odd height).
    float rowFactor(int j) const { return j == height - 1 - j ? 0.5f : 1.0f; }
};

// y_lm = recurrence Y_lm times recurrenceNormalization(l, m) (basis.h), in float.
std::array<float, coefficientCount(kMaxOrder)> floatRecurrenceNormalization(int order) {
    std::array<float, coefficientCount(kMaxOrder)> normalization{};
    for (int l = 0; l < order; ++l) {
        for (int m = -l; m <= l; ++m)
            normalization[size_t(shIndex(l, m))] = float(recurrenceNormalization(l, m));
    }
    return normalization;
}

// Pairs per stage. Where the coefficients take several groups (accumulateStage), the stage's parity
// sums (4 lanes each, 8 KiB) stay in the L1 cache for the groups after the first.
constexpr int kStagePairs = 64;

// rowSums: lanes of float sums per face along a row (the Terms' kCount for this order).
Plan makePlan(const FaceRows& faceRows, TexelFormat format, int width, int height, int faces, int order,
              int rowSums) {
    Plan plan{};
    plan.faceRows = faceRows;
    plan.texelBytes =
        format == TexelFormat::Rgba32F ? Rgba32FTexels::kTexelBytes : Rgba16FTexels::kTexelBytes;
    plan.width = width;
    plan.height = height;
    plan.faces = faces;
    plan.order = order;
    plan.coefficients = coefficientCount(order);
    plan.positions = (width + 1) / 2;
    plan.rows = (height + 1) / 2;
    plan.pairs = (plan.positions + 1) / 2;
    plan.tablePairs = (plan.pairs + 3) / 4 * 4;
    plan.rowSums = rowSums;
    plan.blockRows = (plan.rows + kMaxBlocks - 1) / kMaxBlocks;
    plan.blocks = (plan.rows + plan.blockRows - 1) / plan.blockRows;
    plan.normalization = floatRecurrenceNormalization(order);
    return plan;
}

// ------------------------------------------------------------------------------------------------
// Geometry of eight positions of a row: solid angles and basis, on lanes.

// From this face size on, the solid angles come from their expansion about the texel center; below
// it the expansion is not accurate enough, and the faces are small enough for the exact formula.
constexpr int kMinExpandedFaceSize = 128;

// The solid angle of a texel is the integral of (1 + s^2 + t^2)^(-3/2) over it (the plane z = 1 seen
// from the origin). Expanded about the center (a, b), r^2 = 1 + a^2 + b^2, h = 1/N half the texel's
// width: Omega = 4 h^2 (f + h^2/6 (f_aa + f_bb) + O(h^4)) with f = r^-3, which simplifies to
// 4 h^2 r^-3 (1 + h^2 r^-2 (1.5 - 2.5 r^-2)). Against the exact formula in double, the relative error
// is 4.3e-9 at most for N = 128 and falls as N^-4: far below float rounding. It needs only 1/r,
// which the direction needs too, instead of four corner lengths and two arctangents.
Lanes expandedSolidAngles(const Lanes& inverseLength, int faceSize) {
    const float h = 1.0f / float(faceSize);
    const Lanes u = inverseLength * inverseLength;
    return (4.0f * h * h) * (u * inverseLength) * (1.0f + (h * h) * u * (1.5f - 2.5f * u));
}

// Solid angles of the texels of columns i0 .. i0+7 in a row. Below kMinExpandedFaceSize, the
// shaders' formula (texelSolidAngleFp32 of texel_geometry.h) texel by texel: a few thousand calls at most.
Lanes texelSolidAngles(const Plan& plan, int firstColumn, int row, const Lanes& inverseLength) {
    if (plan.width >= kMinExpandedFaceSize) return expandedSolidAngles(inverseLength, plan.width);
    Lanes solidAngles;
    for (int lane = 0; lane < kLaneCount; ++lane) {
        solidAngles[lane] = glsl::texelSolidAngleFp32(glsl::uint(firstColumn + lane), glsl::uint(row),
                                                      glsl::uint(plan.width));
    }
    return solidAngles;
}

// y_k, k < Order^2, at eight unit directions (x, y, z): the recurrence of basis.h on float lanes,
// then the normalization. Order is a constant in each kernel, and so are the recurrence's loop bounds.
template <int Order>
void evalBasisLanes(const Lanes& x, const Lanes& y, const Lanes& z, const float* normalization, Lanes* out) {
    evalBasisRecurrence<float>(Order, x, y, z, out);
    // Y_00 = 1: assigned rather than multiplied, as GCC 12 warns (wrongly) that it may be uninitialized.
    out[0] = splat(normalization[0]);
    for (int k = 1; k < Order * Order; ++k)
        out[k] *= normalization[k];
}

// Face-local coordinates 2(i + 0.5)/N - 1 of columns i0 .. i0+7, as texelCenterCoord computes them.
Lanes centerCoords(int firstColumn, int faceSize) {
    const Lanes column = Lanes{0, 1, 2, 3, 4, 5, 6, 7} + float(firstColumn);
    return 2.0f * (column + 0.5f) / float(faceSize) - 1.0f;
}

// Mirror factors of columns i0 .. i0+7: all 1 but near the end of a row.
Lanes columnFactors(const Plan& plan, int firstColumn) {
    const int lastColumn = firstColumn + kLaneCount - 1;
    if (lastColumn < plan.positions && lastColumn < plan.width - 1 - lastColumn) return splat(1.0f);
    Lanes factors;
    for (int lane = 0; lane < kLaneCount; ++lane)
        factors[lane] = plan.columnFactor(firstColumn + lane);
    return factors;
}

// Four coefficients at eight positions (one lanes per coefficient) into the table's layout: for each
// pair q of positions 2q, 2q+1, the four coefficients at 2q, then at 2q+1. A 4 x 8 transpose by
// shuffles (interleave coefficient pairs, then quadruples, then exchange 128-bit halves).
void writeTableEntries(const Lanes& w0, const Lanes& w1, const Lanes& w2, const Lanes& w3, Lanes* out,
                       int stride) {
    const Lanes w01Low = __builtin_shufflevector(w0, w1, 0, 8, 1, 9, 4, 12, 5, 13);
    const Lanes w01High = __builtin_shufflevector(w0, w1, 2, 10, 3, 11, 6, 14, 7, 15);
    const Lanes w23Low = __builtin_shufflevector(w2, w3, 0, 8, 1, 9, 4, 12, 5, 13);
    const Lanes w23High = __builtin_shufflevector(w2, w3, 2, 10, 3, 11, 6, 14, 7, 15);
    const Lanes positions04 = __builtin_shufflevector(w01Low, w23Low, 0, 1, 8, 9, 4, 5, 12, 13);
    const Lanes positions15 = __builtin_shufflevector(w01Low, w23Low, 2, 3, 10, 11, 6, 7, 14, 15);
    const Lanes positions26 = __builtin_shufflevector(w01High, w23High, 0, 1, 8, 9, 4, 5, 12, 13);
    const Lanes positions37 = __builtin_shufflevector(w01High, w23High, 2, 3, 10, 11, 6, 7, 14, 15);
    out[0] = __builtin_shufflevector(positions04, positions15, 0, 1, 2, 3, 8, 9, 10, 11);
    out[stride] = __builtin_shufflevector(positions26, positions37, 0, 1, 2, 3, 8, 9, 10, 11);
    out[2 * stride] = __builtin_shufflevector(positions04, positions15, 4, 5, 6, 7, 12, 13, 14, 15);
    out[3 * stride] = __builtin_shufflevector(positions26, positions37, 4, 5, 6, 7, 12, 13, 14, 15);
}

// The table of a row: Omega y_k(v) of the row's pairs, including the mirror factors of the
// positions; lanes p * tableLanesPerPair + k/4 hold coefficient k of pair p's first position in lane
// k%4 and of its second position in lane 4 + k%4, for spreadCoefficient. (Holding each value four
// times instead, ready to multiply, makes a table four times as large, out of the L1 cache.)
template <int Order> void fillBasisTable(const Plan& plan, int row, Lanes* table) {
    constexpr int count = Order * Order;
    const float b = glsl::texelCenterCoord(glsl::uint(row), glsl::uint(plan.width));
    const float rowFactor = plan.rowFactor(row);
    for (int group = 0; group < plan.pairs; group += kLaneCount / 2) {
        const int firstColumn = 2 * group;
        const Lanes a = centerCoords(firstColumn, plan.width);
        const Lanes inverseLength = 1.0f / laneSqrt(a * a + (b * b + 1.0f));
        const Lanes weight = texelSolidAngles(plan, firstColumn, row, inverseLength) *
                             columnFactors(plan, firstColumn) * rowFactor;
        Lanes basis[tableLanesPerPair(count) * 4] = {};
        evalBasisLanes<Order>(a * inverseLength, b * inverseLength, inverseLength, plan.normalization.data(),
                              basis);
        Lanes* out = table + size_t(group) * tableLanesPerPair(count);
        for (int k = 0; k < count; k += 4) {
            writeTableEntries(basis[k] * weight, basis[k + 1] * weight, basis[k + 2] * weight,
                              basis[k + 3] * weight, out + k / 4, tableLanesPerPair(count));
        }
    }
}

// ------------------------------------------------------------------------------------------------
// Texels: parity sums and their multiply-adds.

// Parity class of y_k (see the top of the file): bit 0 set if odd in x, bit 1 if odd in y.
constexpr int parityClass(int index) {
    int l = 0;
    while ((l + 1) * (l + 1) <= index)
        ++l;
    const int m = index - l * (l + 1);
    const bool oddInX = m >= 0 ? m % 2 != 0 : m % 2 == 0;
    const bool oddInY = m < 0;
    return int(oddInX) | int(oddInY) << 1;
}

// The four parity sums of a texel at (a, b) and its mirror images at (-a, b), (a, -b), (-a, -b).
void writeParitySums(const Lanes& texel, const Lanes& mirroredA, const Lanes& mirroredB,
                     const Lanes& mirroredBoth, Lanes* sums) {
    const Lanes evenInX = texel + mirroredA;
    const Lanes oddInX = texel - mirroredA;
    const Lanes evenInXMirroredB = mirroredB + mirroredBoth;
    const Lanes oddInXMirroredB = mirroredB - mirroredBoth;
    sums[0] = evenInX + evenInXMirroredB;
    sums[1] = oddInX + oddInXMirroredB;
    sums[2] = evenInX - evenInXMirroredB;
    sums[3] = oddInX - oddInXMirroredB;
}

// The texels of one face at a row of positions: row j ("near") and its mirror row H-1-j ("far").
struct RowPair {
    const std::byte* near;
    const std::byte* far;
    int width;
    int completePairs; // pairs holding two positions; with an odd number of positions the last holds one
};

RowPair rowPair(const Plan& plan, int face, int row) {
    return {plan.rowTexels(face, row), plan.rowTexels(face, plan.height - 1 - row), plan.width,
            plan.positions / 2};
}

// The rows read after the current ones (the next face's, or the first face's at the next row of
// positions), asked for from memory while the current ones are multiplied. They are asked for in
// memory order, the near row forwards and the far row backwards: from visit to visit a face's near
// rows ascend and its far rows descend, so each face is read as two continuous streams, which the
// hardware prefetchers follow better than the mirror pairs' order (four streams meeting in the
// middle of each row; docs/benchmark.md).
struct NextRows {
    const std::byte* near = nullptr; // none: nothing to ask for
    const std::byte* far = nullptr;
    size_t rowBytes = 0;
    int pairs = 1; // the asking is spread over the current rows' pairs
};

NextRows nextRows(const Plan& plan, int face, int row, int lastRow) {
    const int nextFace = (face + 1) % plan.faces;
    const int nextRow = nextFace == 0 ? row + 1 : row;
    if (nextRow >= lastRow) return {};
    const RowPair rows = rowPair(plan, nextFace, nextRow);
    return {rows.near, rows.far, size_t(plan.width) * plan.texelBytes, plan.pairs};
}

// Asks for the share of the next rows that goes with pair p: at most 64 bytes (one cache line) of
// each, as a pair covers four texels of a row.
void prefetchShare(const NextRows& next, int pair) {
    const size_t offset = size_t(pair) * next.rowBytes / size_t(next.pairs);
    __builtin_prefetch(next.near + offset, 0, 2);
    __builtin_prefetch(next.far + (next.rowBytes - 1 - offset), 0, 2);
}

// The parity sums of a pair of positions (i, i+1). Their mirror columns W-1-i, W-2-i are adjacent
// too, loaded together and swapped into the pair's order.
template <class Texels> void loadParitySums(const RowPair& rows, int pair, Lanes* sums) {
    const size_t column = size_t(2 * pair) * Texels::kTexelBytes;
    if (pair < rows.completePairs) {
        const size_t mirror = size_t(rows.width - 2 - 2 * pair) * Texels::kTexelBytes;
        writeParitySums(Texels::loadTwo(rows.near + column), swapTexels(Texels::loadTwo(rows.near + mirror)),
                        Texels::loadTwo(rows.far + column), swapTexels(Texels::loadTwo(rows.far + mirror)),
                        sums);
    } else {
        const size_t mirror = size_t(rows.width - 1 - 2 * pair) * Texels::kTexelBytes;
        writeParitySums(Texels::loadOne(rows.near + column), Texels::loadOne(rows.near + mirror),
                        Texels::loadOne(rows.far + column), Texels::loadOne(rows.far + mirror), sums);
    }
}

// What the float sums along a row are, per face: kCount sums, sum q the multiply-adds of table entry
// entry(q) with the parity sums of class parity(q); the table holds kTableEntries values per
// position. Cube maps: the frame sums T_k of the coefficients themselves, from Omega y_k.
template <int Order> struct CubeTerms {
    static constexpr int kChunkPairs = kStagePairs; // see accumulateCoefficients
    static constexpr int kTableEntries = Order * Order;
    static constexpr int kCount = Order * Order;
    static constexpr int entry(int q) { return q; }
    static constexpr int parity(int q) { return parityClass(q); }
};

// Equirect maps (top of the file): the table holds cos(m phi), m = 0 .. Order-1, then sin(m phi),
// m = 1 .. Order-1; cosines are even under the column mirror (phi -> -phi), sines odd. Each entry
// takes two sums, q = 2e for the radiance even under the row mirror (theta -> pi - theta) and
// q = 2e + 1 for the odd one, side by side so that a group spreads each entry once.
template <int Order> struct EquirectTerms {
    static constexpr int kChunkPairs = 16; // see accumulateCoefficients
    static constexpr int kTableEntries = 2 * Order - 1;
    static constexpr int kCount = 2 * kTableEntries;
    static constexpr int entry(int q) { return q / 2; }
    static constexpr int parity(int q) { return int(q / 2 >= Order) | (q % 2) << 1; }
};

// sums[q] += parity sum of term q's class * its table entry, over `pairCount` pairs, for the terms
// First .. First+Count-1; paritySumsOf(p, local) points to pair p's four parity sums (in `local` or
// elsewhere). Unrolled at compile time, so that each term's parity class and table entry are
// constants and the accumulators stay in registers.
// The accumulators start from zero every Terms::kChunkPairs pairs and are added to `sums` (the
// stage's, then the row's: accumulateRow), so that no float sum runs long. A cube map's products
// vary with Omega y_k, so their roundings mostly cancel and a chunk is a whole stage. An equirect
// row's cos(0 phi) entries are all 1: along a row of even radiance every product is the same, each
// rounding of the growing sum goes the same way, and over W/4 terms they add up: chunks of 16
// pairs, stages of 4 chunks and the stages' compensated sum (accumulateRow) keep them from it
// (test_fast_projection, FastEquirectProjection.EvenRowsWithinTarget).
template <class Terms, int First, int Count, class ParitySums>
void accumulateCoefficients(const ParitySums& paritySumsOf, const Lanes* table, int pairCount, Lanes* sums) {
    [&]<int... q>(std::integer_sequence<int, q...>) {
        for (int start = 0; start < pairCount; start += Terms::kChunkPairs) {
            Lanes accumulators[Count] = {};
            const int end = std::min(pairCount, start + Terms::kChunkPairs);
            for (int p = start; p < end; ++p) {
                Lanes local[kParities];
                const Lanes* parity = paritySumsOf(p, local);
                const Lanes* weights = table + size_t(p) * tableLanesPerPair(Terms::kTableEntries);
                ((accumulators[q] +=
                  parity[Terms::parity(First + q)] *
                  spreadCoefficient<Terms::entry(First + q) % 4>(weights[Terms::entry(First + q) / 4])),
                 ...);
            }
            ((sums[First + q] += accumulators[q]), ...);
        }
    }
    (std::make_integer_sequence<int, Count>{});
}

// Terms per group: as many as fit the 16 vector registers of AVX2 next to the four parity sums and a
// table entry and its spread value (at most 10), in groups of nearly equal size.
constexpr int groupSize(int terms) {
    const int groups = (terms + 9) / 10;
    return (terms + groups - 1) / groups;
}

// All terms of a stage of pairs of one face, group after group. The first group reads the texels, so
// that its arithmetic overlaps the loads from memory, and keeps their parity sums for the other
// groups.
template <class Terms, class Texels>
void accumulateStage(const RowPair& rows, const NextRows& next, int firstPair, int pairCount,
                     const Lanes* table, Lanes* kept, Lanes* sums) {
    constexpr int count = Terms::kCount;
    constexpr int group = groupSize(count);
    constexpr int groups = (count + group - 1) / group;
    const auto fromTexels = [&](int p, Lanes* local) {
        if (next.near != nullptr) prefetchShare(next, firstPair + p);
        Lanes* parity = groups > 1 ? kept + kParities * p : local;
        loadParitySums<Texels>(rows, firstPair + p, parity);
        return parity;
    };
    const auto fromKept = [&](int p, Lanes*) { return kept + kParities * p; };
    accumulateCoefficients<Terms, 0, group>(fromTexels, table, pairCount, sums);
    [&]<int... g>(std::integer_sequence<int, g...>) {
        (accumulateCoefficients<Terms, (g + 1) * group, std::min(group, count - (g + 1) * group)>(
             fromKept, table, pairCount, sums),
         ...);
    }
    (std::make_integer_sequence<int, groups - 1>{});
}

// ------------------------------------------------------------------------------------------------
// Rows, blocks and threads.

// Per-thread working memory, allocated before the threads start.
struct Scratch {
    LaneArray table;      // cube maps: tablePairs x tableLanesPerPair(order^2), refilled per row
    LaneArray paritySums; // kStagePairs x 4
    LaneArray rowSums;    // faces x rowSums, the float sums of the current row
};

Scratch makeScratch(const Plan& plan) {
    const size_t tableLanes = plan.sharedTable != nullptr
                                  ? 0
                                  : size_t(plan.tablePairs) * size_t(tableLanesPerPair(plan.coefficients));
    return Scratch{makeLaneArray(tableLanes), makeLaneArray(kStagePairs * kParities),
                   makeLaneArray(size_t(plan.faces) * size_t(plan.rowSums))};
}

// Double sums, per face, coefficient and RGB channel, of one block of rows.
size_t blockSumsSize(const Plan& plan) {
    return size_t(plan.faces) * size_t(plan.coefficients) * 3;
}

// The float sums of one face along a row of positions, stage by stage; table: the row's.
template <class Terms, class Texels>
void accumulateRow(const Plan& plan, int face, int row, int lastRow, const Lanes* table, Scratch& scratch,
                   Lanes* sums) {
    const RowPair rows = rowPair(plan, face, row);
    const NextRows next = nextRows(plan, face, row, lastRow);
    // The stage sums reach the row's with Kahan's compensation (the low bits each addition lost,
    // carried into the next), so that their roundings do not add up along a long row either.
    Lanes lost[Terms::kCount] = {};
    for (int stage = 0; stage < plan.pairs; stage += kStagePairs) {
        Lanes stageSums[Terms::kCount] = {}; // short sums (accumulateCoefficients)
        accumulateStage<Terms, Texels>(rows, next, stage, std::min(kStagePairs, plan.pairs - stage),
                                       table + size_t(stage) * tableLanesPerPair(Terms::kTableEntries),
                                       scratch.paritySums.get(), stageSums);
        for (int q = 0; q < Terms::kCount; ++q) {
            const Lanes added = stageSums[q] - lost[q];
            const Lanes sum = sums[q] + added;
            lost[q] = (sum - sums[q]) - added;
            sums[q] = sum;
        }
    }
}

// Adds a row's float sums (two texels' RGBA per entry) to the block's double sums.
void addRowSums(const Plan& plan, const Lanes* rowSums, double* blockSums) {
    for (size_t i = 0; i < size_t(kFaceCount) * size_t(plan.coefficients); ++i) {
        for (int c = 0; c < 3; ++c)
            blockSums[3 * i + size_t(c)] += double(rowSums[i][c]) + double(rowSums[i][kChannels + c]);
    }
}

// Cube maps: one row of positions, its table, then the six faces along it.
struct CubeRows {
    template <int Order, class Texels>
    static void project(const Plan& plan, int row, int lastRow, Scratch& scratch, double* blockSums) {
        using Terms = CubeTerms<Order>;
        std::fill_n(scratch.rowSums.get(), kFaceCount * Terms::kCount, Lanes{});
        fillBasisTable<Order>(plan, row, scratch.table.get());
        for (int face = 0; face < kFaceCount; ++face) {
            accumulateRow<Terms, Texels>(plan, face, row, lastRow, scratch.table.get(), scratch,
                                         scratch.rowSums.get() + face * Terms::kCount);
        }
        addRowSums(plan, scratch.rowSums.get(), blockSums);
    }
};

// Adds an equirect row's Fourier sums (EquirectTerms) to the block's frame sums (top of the file):
// T_l,m += Omega_j y_l,m(theta_j, 0) C_m and T_l,-m += Omega_j y_l,m(theta_j, 0) S_m, with the row
// mirror's even sums where l + m is even and its odd sums where it is odd.
void addEquirectRowSums(const Plan& plan, int row, const Lanes* rowSums, double* blockSums) {
    const double theta = std::numbers::pi * (row + 0.5) / plan.height;
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    evalBasis(plan.order, {std::sin(theta), 0.0, std::cos(theta)}, basis);
    const double weight = equirectRowSolidAngle(row, plan.width, plan.height) * plan.rowFactor(row);
    for (int l = 0; l < plan.order; ++l) {
        for (int m = 0; m <= l; ++m) {
            const double factor = weight * basis[size_t(shIndex(l, m))];
            const Lanes& cosine = rowSums[2 * m + (l + m) % 2];
            const Lanes& sine = rowSums[2 * (plan.order - 1 + m) + (l + m) % 2];
            for (int c = 0; c < 3; ++c) {
                blockSums[3 * size_t(shIndex(l, m)) + size_t(c)] +=
                    factor * (double(cosine[c]) + double(cosine[kChannels + c]));
                if (m > 0)
                    blockSums[3 * size_t(shIndex(l, -m)) + size_t(c)] +=
                        factor * (double(sine[c]) + double(sine[kChannels + c]));
            }
        }
    }
}

// Equirect maps: one row of positions along the shared table.
struct EquirectRows {
    template <int Order, class Texels>
    static void project(const Plan& plan, int row, int lastRow, Scratch& scratch, double* blockSums) {
        using Terms = EquirectTerms<Order>;
        std::fill_n(scratch.rowSums.get(), Terms::kCount, Lanes{});
        accumulateRow<Terms, Texels>(plan, 0, row, lastRow, plan.sharedTable, scratch, scratch.rowSums.get());
        addEquirectRowSums(plan, row, scratch.rowSums.get(), blockSums);
    }
};

// The rows of a block, in order (the texels of each row are asked for while the one before is
// multiplied).
template <class Rows, int Order, class Texels>
[[gnu::flatten]] void projectBlock(const Plan& plan, int block, Scratch& scratch, double* blockSums) {
    const int lastRow = std::min(plan.rows, (block + 1) * plan.blockRows);
    for (int row = block * plan.blockRows; row < lastRow; ++row)
        Rows::template project<Order, Texels>(plan, row, lastRow, scratch, blockSums);
}

using BlockKernel = void (*)(const Plan&, int, Scratch&, double*);

#if SHPROBE_X86_LEVELS
// The same kernel for x86-64-v3 and v4: flatten inlines projectBlock and all it calls, compiled
// anew for the level.
template <class Rows, int Order, class Texels>
[[gnu::target("arch=x86-64-v3"), gnu::flatten]] void projectBlockV3(const Plan& plan, int block,
                                                                    Scratch& scratch, double* blockSums) {
    projectBlock<Rows, Order, Texels>(plan, block, scratch, blockSums);
}
template <class Rows, int Order, class Texels>
[[gnu::target("arch=x86-64-v4"), gnu::flatten]] void projectBlockV4(const Plan& plan, int block,
                                                                    Scratch& scratch, double* blockSums) {
    projectBlock<Rows, Order, Texels>(plan, block, scratch, blockSums);
}
#endif

template <class Rows, class Texels, int... orderMinusOne>
BlockKernel blockKernelOf(int order, KernelLevel level, std::integer_sequence<int, orderMinusOne...>) {
#if SHPROBE_X86_LEVELS
    if (level == KernelLevel::X86_64_V4) {
        const BlockKernel kernels[] = {&projectBlockV4<Rows, orderMinusOne + 1, Texels>...};
        return kernels[order - 1];
    }
    if (level == KernelLevel::X86_64_V3) {
        const BlockKernel kernels[] = {&projectBlockV3<Rows, orderMinusOne + 1, Texels>...};
        return kernels[order - 1];
    }
#endif
    const BlockKernel kernels[] = {&projectBlock<Rows, orderMinusOne + 1, Texels>...};
    return kernels[order - 1];
}

// The kernel for the format and order, of the widest level both the processor and the options allow.
template <class Rows>
BlockKernel blockKernel(TexelFormat format, int order, const FastProjectionOptions& options) {
    const auto orders = std::make_integer_sequence<int, kMaxOrder>{};
    const KernelLevel level = std::max(widestKernelLevel(), options.widest); // the enum runs widest first
    if (format == TexelFormat::Rgba32F) return blockKernelOf<Rows, Rgba32FTexels>(order, level, orders);
#if SHPROBE_X86_LEVELS
    if (level != KernelLevel::Baseline) return blockKernelOf<Rows, Rgba16FTexelsF16c>(order, level, orders);
#endif
    return blockKernelOf<Rows, Rgba16FTexels>(order, level, orders);
}

// Runs every block on `threads` threads, the caller's among them; each takes the next block not yet
// taken, and block b writes only its own sums.
std::vector<double> projectBlocks(const Plan& plan, BlockKernel kernel, unsigned threads) {
    std::vector<double> blockSums(size_t(plan.blocks) * blockSumsSize(plan), 0.0);
    std::vector<Scratch> scratches;
    for (unsigned t = 0; t < threads; ++t)
        scratches.push_back(makeScratch(plan));
    std::atomic<int> nextBlock{0};
    const auto work = [&](Scratch& scratch) {
        for (int block = nextBlock++; block < plan.blocks; block = nextBlock++)
            kernel(plan, block, scratch, blockSums.data() + size_t(block) * blockSumsSize(plan));
    };
    std::vector<std::jthread> workers;
    for (unsigned t = 1; t < threads; ++t)
        workers.emplace_back(work, std::ref(scratches[t]));
    work(scratches[0]);
    workers.clear(); // joins
    return blockSums;
}

// ------------------------------------------------------------------------------------------------
// The equirect map's table, and from the frames to the world.

// The table of an equirect map, the same for every row: for each pair of positions, cos(m phi) for
// m < order, then sin(m phi) for 1 <= m < order, at its two columns (phi = 2 pi (i + 0.5) / W - pi),
// times their column factors, in fillBasisTable's layout. Evaluated in double and rounded once.
LaneArray makeEquirectTable(const Plan& plan) {
    const int entries = 2 * plan.order - 1;
    const int lanesPerPair = tableLanesPerPair(entries);
    LaneArray table = makeLaneArray(size_t(plan.pairs) * size_t(lanesPerPair));
    for (int i = 0; i < 2 * plan.pairs; ++i) {
        const double phi = 2.0 * std::numbers::pi * (i + 0.5) / plan.width - std::numbers::pi;
        const double factor = plan.columnFactor(i);
        Lanes* pair = table.get() + size_t(i / 2) * size_t(lanesPerPair);
        for (int e = 0; e < entries; ++e) {
            const double value = e < plan.order ? std::cos(e * phi) : std::sin((e - plan.order + 1) * phi);
            pair[e / 4][kChannels * (i % 2) + e % 4] = float(factor * value);
        }
    }
    return table;
}

// P_f, the signed permutation taking face f's frame (a, b, 1) to the world (orientToFace).
glm::dmat3 faceOrientation(int face) {
    const auto column = [face](glm::vec3 axis) {
        return glm::dvec3(glsl::orientToFace(glsl::uint(face), axis));
    };
    return glm::dmat3(column({1.0f, 0.0f, 0.0f}), column({0.0f, 1.0f, 0.0f}), column({0.0f, 0.0f, 1.0f}));
}

// The equirect map's frame (top of the file): v = (sin theta cos phi, sin theta sin phi, cos theta)
// is the world's (v_y, v_z, -v_x) (docs/conventions.md), a reflection like every P_f.
const glm::dmat3 kEquirectOrientation(glm::dvec3(0.0, 0.0, -1.0), glm::dvec3(1.0, 0.0, 0.0),
                                      glm::dvec3(0.0, 1.0, 0.0));

// World coefficients of frame sums T in the frame P (a reflection, det P = -1): D(Q) (-1)^l T with
// Q = -P (top of the file).
ShCoefficients frameToWorld(const glm::dmat3& orientation, ShCoefficients frameSums) {
    for (int l = 1; l < frameSums.order; l += 2) {
        for (int m = -l; m <= l; ++m)
            frameSums.rgb[size_t(shIndex(l, m))] *= -1.0;
    }
    return rotate(makeShRotation(-orientation, frameSums.order), frameSums);
}

// The blocks' sums added in block order, per face, then turned into the world and added; face f's
// frame is orientations[f].
ShCoefficients combineBlocks(const Plan& plan, const std::vector<double>& blockSums,
                             std::span<const glm::dmat3> orientations) {
    ShCoefficients world = makeCoefficients(plan.order, Quantity::Radiance);
    for (int face = 0; face < plan.faces; ++face) {
        ShCoefficients frameSums = makeCoefficients(plan.order, Quantity::Radiance);
        for (int block = 0; block < plan.blocks; ++block) {
            const double* sums = blockSums.data() + size_t(block) * blockSumsSize(plan) +
                                 size_t(face) * size_t(plan.coefficients) * 3;
            for (int k = 0; k < plan.coefficients; ++k)
                frameSums.rgb[size_t(k)] += glm::dvec3(sums[3 * k], sums[3 * k + 1], sums[3 * k + 2]);
        }
        const ShCoefficients faceWorld = frameToWorld(orientations[size_t(face)], frameSums);
        for (int k = 0; k < plan.coefficients; ++k)
            world.rgb[size_t(k)] += faceWorld.rgb[size_t(k)];
    }
    return world;
}

void requireProjectable(std::span<const void* const> faces, int order) {
    requireOrder(order);
    if (std::find(faces.begin(), faces.end(), nullptr) != faces.end())
        throw Error(ErrorKind::Input, "no texels to project");
}

// Texels worth a thread: more work than starting the thread costs (docs/benchmark.md).
constexpr size_t kTexelsPerThread = size_t(1) << 17;

// The threads asked for, or all cores but no more than the work is worth; never more than blocks.
unsigned threadCount(const FastProjectionOptions& options, const Plan& plan) {
    const size_t texels = size_t(plan.faces) * size_t(plan.width) * size_t(plan.height);
    const size_t worth = std::max<size_t>(1, texels / kTexelsPerThread);
    const size_t wanted =
        options.threads != 0 ? options.threads : std::min<size_t>(std::thread::hardware_concurrency(), worth);
    return unsigned(std::clamp<size_t>(wanted, 1, size_t(plan.blocks)));
}

// Term counts by order, for the plan (the kernels know theirs at compile time).
template <template <int> class Terms, int... orderMinusOne>
int termCount(int order, std::integer_sequence<int, orderMinusOne...>) {
    const int counts[] = {Terms<orderMinusOne + 1>::kCount...};
    return counts[order - 1];
}

void requireTexelCount(size_t actual, size_t expected, const char* what) {
    if (actual != expected) {
        throw Error(ErrorKind::Input, std::string(what) + " holds " + std::to_string(actual) +
                                          " texels, expected " + std::to_string(expected));
    }
}

} // namespace

KernelLevel widestKernelLevel() {
#if SHPROBE_X86_LEVELS
    static const KernelLevel widest = detectWidestKernelLevel();
    return widest;
#else
    return KernelLevel::Baseline;
#endif
}

void packHalves(std::span<const glm::vec4> texels, uint64_t* halves, KernelLevel widest) {
#if SHPROBE_X86_LEVELS
    if (widest != KernelLevel::Baseline && widestKernelLevel() != KernelLevel::Baseline)
        return packHalvesF16c(texels, halves);
#endif
    for (size_t t = 0; t < texels.size(); ++t)
        halves[t] = glm::packHalf4x16(glm::vec4(glm::vec3(texels[t]), 0.0f));
}

ShCoefficients projectFacesFast(const FaceRows& faces, TexelFormat format, int faceSize, int order,
                                const FastProjectionOptions& options) {
    if (faceSize < 1)
        throw Error(ErrorKind::Input, "cube-map face size must be positive, got " + std::to_string(faceSize));
    requireProjectable(faces.faces, order);
    for (size_t stride : faces.rowStrides)
        if (stride < size_t(faceSize))
            throw Error(ErrorKind::Input, "a face's rows are " + std::to_string(stride) +
                                              " texels apart, fewer than its " + std::to_string(faceSize));
    const Plan plan = makePlan(faces, format, faceSize, faceSize, kFaceCount, order,
                               termCount<CubeTerms>(order, std::make_integer_sequence<int, kMaxOrder>{}));
    std::array<glm::dmat3, kFaceCount> orientations;
    for (int face = 0; face < kFaceCount; ++face)
        orientations[size_t(face)] = faceOrientation(face);
    return combineBlocks(
        plan, projectBlocks(plan, blockKernel<CubeRows>(format, order, options), threadCount(options, plan)),
        orientations);
}

ShCoefficients projectFacesFast(const void* texels, TexelFormat format, int faceSize, int order,
                                const FastProjectionOptions& options) {
    const size_t side = size_t(std::max(faceSize, 0));
    FaceRows faces;
    for (int face = 0; face < kFaceCount; ++face) {
        faces.faces[size_t(face)] =
            texels ? static_cast<const std::byte*>(texels) + size_t(face) * side * side * texelBytes(format)
                   : nullptr;
        faces.rowStrides[size_t(face)] = side;
    }
    return projectFacesFast(faces, format, faceSize, order, options);
}

ShCoefficients projectCubemapFast(const Cubemap& cubemap, int order, const FastProjectionOptions& options) {
    static_assert(sizeof(glm::vec4) == Rgba32FTexels::kTexelBytes,
                  "Cubemap texels are tightly packed RGBA32F");
    const size_t side = size_t(std::max(cubemap.faceSize, 0));
    requireTexelCount(cubemap.texels.size(), size_t(kFaceCount) * side * side, "cube map");
    return projectFacesFast(cubemap.texels.data(), TexelFormat::Rgba32F, cubemap.faceSize, order, options);
}

ShCoefficients projectEquirectFast(const void* texels, TexelFormat format, int width, int height, int order,
                                   const FastProjectionOptions& options) {
    if (width < 1 || height < 1) {
        throw Error(ErrorKind::Input, "equirect map size must be positive, got " + std::to_string(width) +
                                          "x" + std::to_string(height));
    }
    requireProjectable(std::span(&texels, 1), order);
    FaceRows rows;
    rows.faces[0] = texels;
    rows.rowStrides[0] = size_t(width);
    Plan plan = makePlan(rows, format, width, height, 1, order,
                         termCount<EquirectTerms>(order, std::make_integer_sequence<int, kMaxOrder>{}));
    const LaneArray table = makeEquirectTable(plan);
    plan.sharedTable = table.get();
    return combineBlocks(
        plan,
        projectBlocks(plan, blockKernel<EquirectRows>(format, order, options), threadCount(options, plan)),
        std::span(&kEquirectOrientation, 1));
}

ShCoefficients projectEquirectFast(const Image& equirect, int order, const FastProjectionOptions& options) {
    requireTexelCount(equirect.texels.size(),
                      size_t(std::max(equirect.width, 0)) * size_t(std::max(equirect.height, 0)),
                      "equirect map");
    return projectEquirectFast(equirect.texels.data(), TexelFormat::Rgba32F, equirect.width, equirect.height,
                               order, options);
}

} // namespace shprobe
