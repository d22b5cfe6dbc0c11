// SH irradiance and radiance for a normal, from folded RGB coefficients, in the polynomial form of
// Sloan's irradiance shader ("Stupid Spherical Harmonics (SH) Tricks", appendix A10, with the
// convolution of Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance Environment
// Maps"), extended to order 5; and the non-linear L1 irradiance model of Geomerics' notes on SH
// irradiance.
//
// USAGE (any renderer; needs nothing but this file):
//   #include "sh_irradiance.glsl"
//   uniform block: vec4 coefficients[SH_FOLDED_COUNT];   // folded on the CPU, rgb used
//   vec3 outgoing = albedo * shIrradianceOverPi(coefficients, n, 3u); // or 5u
//
// Folding (CPU, src/render/probe_shading.cpp): with y_i = k_i p_i(x, y, z) the real orthonormal
// basis with the Condon-Shortley phase (docs/conventions.md) written as a constant k_i times the
// polynomial p_i evaluated below, and s_l a per-band scale, the CPU stores c_i = s_l k_i f_i, so
// sum_i c_i p_i(n) = sum_i s_l f_i y_i(n) costs one multiply-add per coefficient:
//   - irradiance / pi: s_l = A_l / pi (A_0 = pi, A_1 = 2pi/3, A_2 = pi/4, A_3 = 0, A_4 = -pi/24),
//     so shIrradianceOverPi returns E(n) / pi, the radiance a white Lambertian surface reflects;
//   - radiance reconstruction: s_l = 1, so shRadiance returns L(d).
// As in Sloan's shader, y_20 = k_6 (3 z^2 - 1) is split: p_6 = z^2 with c_6 = 3 s_2 k_6 f_6, and
// the constant -s_2 k_6 f_6 is added to c_0. The signs of the odd-m terms (y_1-1 = -k y, ...) live
// in k_i, hence in the folded coefficients; the polynomials carry none.
// Index i = l(l+1) + m. Orders 3, 4 and 5: bands 0..2 are always evaluated (the split of y_20
// puts band 2 into c_0), bands 3 and 4 only when the order includes them, so one set of folded
// coefficients serves orders 3 and 5. Order 5 irradiance skips band 3: A_3 = 0.
#ifndef SHPROBE_SH_IRRADIANCE_GLSL
#define SHPROBE_SH_IRRADIANCE_GLSL

#define SH_FOLDED_COUNT 25

// Bands 0..2: the 9 terms of Sloan's order-3 shader.
vec3 shFoldedBands012(vec4 c[SH_FOLDED_COUNT], vec3 n) {
    return c[0].rgb + c[1].rgb * n.y + c[2].rgb * n.z + c[3].rgb * n.x +
           c[4].rgb * (n.x * n.y) + c[5].rgb * (n.y * n.z) + c[6].rgb * (n.z * n.z) +
           c[7].rgb * (n.x * n.z) + c[8].rgb * (n.x * n.x - n.y * n.y);
}

// Band 3 (radiance reconstruction only: its irradiance scale A_3 is 0).
vec3 shFoldedBand3(vec4 c[SH_FOLDED_COUNT], vec3 n) {
    float x2 = n.x * n.x, y2 = n.y * n.y, z2 = n.z * n.z;
    return c[9].rgb * (n.y * (3.0 * x2 - y2)) + c[10].rgb * (n.x * n.y * n.z) +
           c[11].rgb * (n.y * (5.0 * z2 - 1.0)) + c[12].rgb * (n.z * (5.0 * z2 - 3.0)) +
           c[13].rgb * (n.x * (5.0 * z2 - 1.0)) + c[14].rgb * (n.z * (x2 - y2)) +
           c[15].rgb * (n.x * (x2 - 3.0 * y2));
}

// Band 4.
vec3 shFoldedBand4(vec4 c[SH_FOLDED_COUNT], vec3 n) {
    float x2 = n.x * n.x, y2 = n.y * n.y, z2 = n.z * n.z;
    float xy = n.x * n.y, yz = n.y * n.z, xz = n.x * n.z;
    float a = 7.0 * z2 - 1.0, b = 7.0 * z2 - 3.0;
    return c[16].rgb * (xy * (x2 - y2)) + c[17].rgb * (yz * (3.0 * x2 - y2)) + c[18].rgb * (xy * a) +
           c[19].rgb * (yz * b) + c[20].rgb * ((35.0 * z2 - 30.0) * z2 + 3.0) + c[21].rgb * (xz * b) +
           c[22].rgb * ((x2 - y2) * a) + c[23].rgb * (xz * (x2 - 3.0 * y2)) +
           c[24].rgb * (x2 * (x2 - 3.0 * y2) - y2 * (3.0 * x2 - y2));
}

// E(n) / pi from coefficients folded with s_l = A_l / pi; order 3..5 (band 3 skipped: A_3 = 0).
vec3 shIrradianceOverPi(vec4 c[SH_FOLDED_COUNT], vec3 n, uint order) {
    vec3 e = shFoldedBands012(c, n);
    if (order >= 5u) e += shFoldedBand4(c, n);
    return e;
}

// L(d) from coefficients folded with s_l = 1; order 3..5.
vec3 shRadiance(vec4 c[SH_FOLDED_COUNT], vec3 d, uint order) {
    vec3 l = shFoldedBands012(c, d);
    if (order >= 4u) l += shFoldedBand3(c, d);
    if (order >= 5u) l += shFoldedBand4(c, d);
    return l;
}

// Non-linear L1 irradiance of one channel (Geomerics' notes on L1 irradiance), as E(n) / pi:
//   I(n) = R0 (a + (1 - a)(p + 1) q^p),  q = (1 + R1^.n) / 2,  p = 1 + 2 r,  a = (1 - r) / (1 + r),
// r = |R1| / R0, with R0 = (1/4pi) int L and R1 = (1/4pi) int L w over the sphere (renormalized L0
// and L1). It is >= 0 for any normal, its mean over the sphere is R0 (the L0 energy of the linear
// E/pi), and its range max - min is 4 |R1|, that of the linear model R0 + 2 R1.n.
float shL1NonLinearChannel(float r0, vec3 r1, vec3 n) {
    if (r0 <= 0.0) return 0.0; // no light (non-negative radiance has R0 >= |R1|)
    float length1 = length(r1);
    float r = min(length1 / r0, 1.0);
    float q = length1 > 0.0 ? clamp(0.5 + 0.5 * dot(r1, n) / length1, 0.0, 1.0) : 0.5;
    float p = 1.0 + 2.0 * r;
    float a = (1.0 - r) / (1.0 + r);
    return r0 * (a + (1.0 - a) * (p + 1.0) * pow(q, p));
}

// l1[0].rgb = R0, l1[1..3].rgb = R1.x, R1.y, R1.z per channel (see RenderUniforms.l1).
vec3 shL1NonLinearOverPi(vec4 l1[4], vec3 n) {
    vec3 e;
    for (int channel = 0; channel < 3; ++channel)
        e[channel] =
            shL1NonLinearChannel(l1[0][channel], vec3(l1[1][channel], l1[2][channel], l1[3][channel]), n);
    return e;
}

#endif
