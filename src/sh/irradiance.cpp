// Lambertian convolution E_lm = A_l L_lm (Ramamoorthi & Hanrahan, "An Efficient Representation for
// Irradiance Environment Maps"; Brown, "Spherical Harmonic Basis Functions", for A_l) and evaluation
// of a probe, E(n) = sum E_lm y_lm(n) (docs/conventions.md, "Radiance, irradiance").
#include "sh/irradiance.h"

#include "common/error.h"
#include "sh/basis.h"

#include <array>
#include <numbers>
#include <string>

namespace shprobe {

namespace {

constexpr double kPi = std::numbers::pi;

// l! / (2^l ((l/2)!)^2) for even l, as the product prod_{k=1}^{l/2} (2k-1)/(2k), which never overflows.
double centralBinomialOverPowerOfTwo(int l) {
    double product = 1.0;
    for (int k = 1; k <= l / 2; ++k)
        product *= (2.0 * k - 1.0) / (2.0 * k);
    return product;
}

} // namespace

// A_0 = pi, A_1 = 2 pi / 3, A_l = 0 for odd l > 1, and for even l (docs/conventions.md; Brown,
// "Spherical Harmonic Basis Functions")
// A_l = 2 pi (-1)^(l/2 - 1) / ((l+2)(l-1)) * l! / (2^l ((l/2)!)^2), which also gives A_0 = pi.
double irradianceBandFactor(int l) {
    if (l < 0) throw Error(ErrorKind::Input, "no SH band l = " + std::to_string(l));
    if (l == 1) return 2.0 * kPi / 3.0;
    if (l % 2 == 1) return 0.0;
    const double sign = (l / 2) % 2 == 1 ? 1.0 : -1.0; // (-1)^(l/2 - 1)
    return 2.0 * kPi * sign / ((l + 2.0) * (l - 1.0)) * centralBinomialOverPowerOfTwo(l);
}

ShCoefficients convolveIrradiance(const ShCoefficients& radiance) {
    if (radiance.quantity != Quantity::Radiance) {
        throw Error(ErrorKind::Input, "irradiance convolution needs radiance coefficients, got irradiance");
    }
    requireCoefficients(radiance);
    ShCoefficients irradiance = radiance;
    irradiance.quantity = Quantity::Irradiance;
    for (size_t i = 0; i < irradiance.rgb.size(); ++i)
        irradiance.rgb[i] *= irradianceBandFactor(shBand(int(i)));
    return irradiance;
}

glm::dvec3 evaluate(const ShCoefficients& coefficients, const glm::dvec3& direction) {
    requireCoefficients(coefficients);
    std::array<double, coefficientCount(kMaxOrder)> basis{};
    evalBasis(coefficients.order, direction, basis);
    glm::dvec3 sum(0.0);
    for (size_t i = 0; i < coefficients.rgb.size(); ++i)
        sum += coefficients.rgb[i] * basis[i];
    return sum;
}

} // namespace shprobe
