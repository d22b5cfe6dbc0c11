// Real orthonormal SH basis in GLSL, Condon-Shortley phase, flat index l(l+1)+m (CONVENTIONS.md).
// The includer declares `const uint SH_ORDER` (usually a specialization constant) first; then
// SH_COEFFICIENTS = SH_ORDER^2 and shEvalBasis(d, y) fills y[0..SH_COEFFICIENTS).
#ifndef SHPROBE_SH_BASIS_GLSL
#define SHPROBE_SH_BASIS_GLSL

const uint SH_COEFFICIENTS = SH_ORDER * SH_ORDER;

// Polynomial in x, y, z, no trigonometry (Lisle & Huang 2007, seed 002 section 2.1):
// (x + iy)^m = sin^m(theta) (cos m phi + i sin m phi) by complex multiplication, times the
// normalized associated Legendre factor Pbar_l^m(z) = K_l^m P_l^m(z) / sin^m(theta), which follows
// the normalized recurrences
//   Pbar_0^0 = 1/sqrt(4 pi),  Pbar_m^m = -sqrt((2m+1)/(2m)) Pbar_{m-1}^{m-1},
//   Pbar_{m+1}^m = sqrt(2m+3) z Pbar_m^m,
//   Pbar_l^m = a (z Pbar_{l-1}^m - b Pbar_{l-2}^m), a = sqrt((4l^2-1)/(l^2-m^2)),
//   b = sqrt(((l-1)^2-m^2)/(4(l-1)^2-1)).
// Normalized factors stay near 1, unlike the factorials of K_l^m, so fp32 keeps its digits.
void shEvalBasis(vec3 d, out float y[SH_COEFFICIENTS]) {
    const float sqrt2 = 1.41421356237f;
    float cosTerm = 1.0f; // sin^m(theta) cos(m phi)
    float sinTerm = 0.0f; // sin^m(theta) sin(m phi)
    float diagonal = 0.282094791774f; // Pbar_m^m, starting at 1/sqrt(4 pi)
    for (uint m = 0u; m < SH_ORDER; ++m) {
        float previous = 0.0f;
        float current = diagonal;
        for (uint l = m; l < SH_ORDER; ++l) {
            if (l == m + 1u) {
                previous = current;
                current = sqrt(float(2u * m + 3u)) * d.z * current;
            } else if (l > m + 1u) {
                float l2 = float(l * l), m2 = float(m * m), k = float((l - 1u) * (l - 1u));
                float a = sqrt((4.0f * l2 - 1.0f) / (l2 - m2));
                float b = sqrt((k - m2) / (4.0f * k - 1.0f));
                float next = a * (d.z * current - b * previous);
                previous = current;
                current = next;
            }
            uint center = l * (l + 1u);
            if (m == 0u) {
                y[center] = current;
            } else {
                y[center + m] = sqrt2 * current * cosTerm;
                y[center - m] = sqrt2 * current * sinTerm;
            }
        }
        diagonal *= -sqrt(float(2u * m + 3u) / float(2u * m + 2u));
        float nextCos = cosTerm * d.x - sinTerm * d.y;
        sinTerm = cosTerm * d.y + sinTerm * d.x;
        cosTerm = nextCos;
    }
}

#endif
