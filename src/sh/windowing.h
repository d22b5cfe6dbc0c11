// Windowing of SH probes (band-wise scale factors that damp the high bands) and Sloan's de-ringing:
// the weakest window that makes the reconstructed function non-negative over the whole sphere.
//
// A window of width w (in bands, w > 0) scales band l by (Sloan, "Stupid SH Tricks", "Windowing"):
//   Hanning: h_l = (1 + cos(pi l / w)) / 2                       for l < w, 0 for l >= w
//   Lanczos: s_l = sin(pi l / w) / (pi l / w) (s_0 = 1)          for l < w, 0 for l >= w
// Band 0 is never changed. Its strength is 1/w: strength 0 (w = +infinity) is the identity, and
// strength 1 (w = 1) keeps band 0 alone, which is non-negative whenever the mean radiance is.
#pragma once
#include "sh/coefficients.h"

#include <glm/vec3.hpp>
#include <span>
#include <vector>

namespace shprobe {

enum class WindowKind { Hanning, Lanczos };

// Factors w_l for l = 0..order-1 of a window of the given width (> 0, +infinity allowed).
std::vector<double> windowFactors(WindowKind kind, double width, int order);

// c_lm * bandFactors[l]; bandFactors must hold at least coefficients.order values.
ShCoefficients applyWindow(const ShCoefficients& coefficients, std::span<const double> bandFactors);

// Smallest value, over directions and the three channels, of sum c_i y_i(w): the minimum over a
// Fibonacci sphere of sampleCount directions, refined by a local pattern search around the lowest
// samples (converges to the local minimum within about 1e-8 rad in direction).
struct SphereMinimum {
    double value = 0.0;
    glm::dvec3 direction{0.0, 0.0, 1.0};
    int channel = 0;
};
SphereMinimum minimumOnSphere(const ShCoefficients& coefficients, int sampleCount = 4096);

// Which function must be non-negative: the irradiance E = A_l L_lm (the usual case for diffuse
// lighting) or the radiance itself.
enum class DeringTarget { Irradiance, Radiance };

struct DeringOptions {
    WindowKind window = WindowKind::Hanning;
    DeringTarget target = DeringTarget::Irradiance;
    int sampleCount = 4096;          // Fibonacci-sphere directions for the minimum search
    int scanSteps = 64;              // strengths k / scanSteps tried in turn before bisecting
    double strengthTolerance = 1e-4; // bisection stops when the strength (1/width) is known to this
};

struct DeringResult {
    std::vector<double> bandFactors; // per band l = 0..order-1; apply to radiance with applyWindow
    double width = 0.0;              // +infinity when no window is needed
    double minimum = 0.0;            // minimumOnSphere of the windowed target (>= 0)
};

// Sloan's de-ringing ("Stupid SH Tricks", "Windowing"; Sloan, "Deringing Spherical Harmonics", SIGGRAPH Asia
// 2017): the weakest window whose target is non-negative on the sphere (minimumOnSphere >= 0).
// Non-negativity is not monotone in the strength 1/w (at order 5 a sky with a sun is non-negative
// for a band of weak windows and negative again for medium ones), so the strengths k/scanSteps are
// tried in turn and the first sign change is then bisected to strengthTolerance. A non-negative
// band narrower than 1/scanSteps in strength can be missed. Throws Error(Input) for irradiance
// coefficients (give the radiance) and when a channel's mean radiance L_00 is negative (no window
// can help).
DeringResult deringWindow(const ShCoefficients& radiance, const DeringOptions& options = {});

} // namespace shprobe
