// Thin-film interference (KHR_materials_iridescence): the reflectance, as a linear sRGB colour, of a
// dielectric film of IOR eta2 and thickness d (nm) between the outside (IOR 1) and a base of IOR eta3, after
// Belcour & Barla 2017, "A Practical Extension to Microfacet Theory for the Modeling of Varying Iridescence"
// (ACM TOG 36(4), 65): the film's reflections summed as Airy does and the spectrum integrated against the
// colour matching functions in closed form, the functions being Gaussians in wavenumber whose cosine transforms
// are known (the fits of their supplemental material, whose constants are used below). Their equation numbers
// could not be checked here (the paper was not reachable), so the derivation caustica uses is written out in
// full below instead; it is its own (a Fourier series in the phase of the exact amplitude sum).
//
// Per polarization, with real amplitude coefficients a = r12 and b = r23 (no total internal reflection; the
// amplitude form carries the pi phase shifts in their signs) and the phase delta = 2 pi x / lambda of the
// optical path difference x = 2 eta2 d cos(theta2), the film's reflectance is
//   R(delta) = |a + b e^{i delta}|^2 / |1 + a b e^{i delta}|^2
//            = 1 - K (1 + 2 sum_{m>=1} (-a b)^m cos(m delta)),   K = (1 - a^2)(1 - b^2) / (1 - a^2 b^2)
// (the Fourier series of 1 / (1 + rho^2 + 2 rho cos delta), rho = a b). Integrating over the spectrum with a
// channel's sensitivity s_c (normalized to integrate to 1) turns each cos(m delta) into S_c(m x), the cosine
// transform of s_c at path difference m x, and the constant terms stay as they are:
//   R_c = 1 - K (1 + 2 sum_m (-a b)^m S_c(m x)).
// caustica sums m = 1..3 exactly and the rest at S_c(4 x) (the envelope of S_c is a Gaussian in m x, so
// those terms are small wherever x is not), which keeps the sum exact at x = 0: a film of thickness 0, of the
// base's IOR (b = 0) or of the outside's (a = 0) reflects exactly the base's Fresnel reflectance.
// S_c: the CIE 1931 functions as Belcour & Barla's Gaussian lobes in wavenumber nu (1/m), a lobe of weight V,
// centre mu and variance parameter v transforming to V sqrt(2 pi v) cos(mu p) exp(-v p^2), p = 2 pi x 1e-9;
// XYZ to linear sRGB (Rec. 709, D65) and each channel divided by its value at x = 0, so that a spectrally flat
// reflectance keeps its value in every channel (caustica's white is the equal-energy spectrum).
#pragma once
#include "../base/math.h"

namespace caustica {

// The lobes of the colour matching functions' fits (x has two): a lobe's cosine transform at
// p = 2 pi x 1e-9 (x the path difference in nm) is w cos(mu p) e^(-v p^2).
struct FilmLobes {
  float w[4], mu[4], v[4];
};
CHD FilmLobes film_lobes() {
  // x (two lobes), y, z: V, mu, v of the fits; w = V sqrt(2 pi v).
  FilmLobes l{{5.4856e-13f, 9.7470e-14f, 4.4201e-13f, 5.2481e-13f},
              {1.6810e+06f, 2.2399e+06f, 1.7953e+06f, 2.2084e+06f},
              {4.3278e+09f, 4.5282e+09f, 9.3046e+09f, 6.6121e+09f}};
  for (int i = 0; i < 4; ++i) l.w[i] *= std::sqrt(2.f * kPi * l.v[i]) * 1e7f;  // 1e7: keeps values near 1
  return l;
}
CHD RGB film_xyz_to_rgb(float X, float Y, float Z) {
  return RGB(3.2404542f * X - 1.5371385f * Y - 0.4985314f * Z, -0.9692660f * X + 1.8760108f * Y + 0.0415560f * Z,
             0.0556434f * X - 0.2040259f * Y + 1.0572252f * Z);
}
// S_c(x) for x = m x1, m = 1..4 (s[m - 1]), each channel normalized to S_c(0) = 1.
CHD void thin_film_sensitivities(float x1, RGB s[4]) {
  const FilmLobes l = film_lobes();
  const float p = 2.f * kPi * 1e-9f * x1;
  // cos(m mu p) by cos((m + 1) t) = 2 cos(t) cos(m t) - cos((m - 1) t); e^(-v (m p)^2) = e1^(m^2), stepping
  // by e1^(2 m + 1).
  float c1[4], cprev[4], ccur[4], e2[4], em[4], step[4];
  for (int i = 0; i < 4; ++i) {
    c1[i] = std::cos(l.mu[i] * p);
    cprev[i] = 1.f, ccur[i] = c1[i];
    em[i] = std::exp(-l.v[i] * p * p);
    e2[i] = em[i] * em[i];
    step[i] = em[i] * e2[i];
  }
  const RGB norm = film_xyz_to_rgb(l.w[0] + l.w[1], l.w[2], l.w[3]);
  for (int m = 1; m <= 4; ++m) {
    float t[4];
    for (int i = 0; i < 4; ++i) t[i] = l.w[i] * ccur[i] * em[i];
    const RGB rgb = film_xyz_to_rgb(t[0] + t[1], t[2], t[3]);
    s[m - 1] = RGB(rgb.x / norm.x, rgb.y / norm.y, rgb.z / norm.z);
    for (int i = 0; i < 4; ++i) {
      const float cn = 2.f * c1[i] * ccur[i] - cprev[i];
      cprev[i] = ccur[i], ccur[i] = cn;
      em[i] *= step[i], step[i] *= e2[i];
    }
  }
}

// One polarization's spectrally integrated film reflectance in channel c's sensitivities s[]: a, b its
// amplitude coefficients at the two interfaces (see the top of this file).
CHD float thin_film_channel(float a, float b, const float s[4]) {
  const float ab = a * b, den = 1.f - ab * ab;
  if (!(den > 1e-7f)) return 1.f;  // |a b| = 1: grazing, everything reflected
  const float K = (1.f - a * a) * (1.f - b * b) / den;
  const float r = -ab;
  float sum = 0.f, rm = 1.f;
  for (int m = 1; m <= 3; ++m) rm *= r, sum += rm * s[m - 1];
  sum += rm * r / (1.f - r) * s[3];  // the rest, sum_{m>3} r^m = r^4 / (1 - r), at S(4 x)
  return 1.f - K * (1.f + 2.f * sum);
}

// The film's reflectance at cosine cos1 (outside, to the film's normal), linear sRGB in [0, 1]: film IOR eta2
// and thickness d_nm, the base's IOR eta3 per channel (a dielectric's the same in all three).
CHD RGB thin_film_reflectance(float cos1, float eta2, RGB eta3, float d_nm) {
  const float c1 = clampf(std::fabs(cos1), 0.f, 1.f), sin2_1 = 1.f - c1 * c1;
  const float sin2_2 = sin2_1 / (eta2 * eta2);
  if (!(sin2_2 < 1.f)) return RGB(1.f);  // total internal reflection into the film: all is reflected
  const float c2 = std::sqrt(1.f - sin2_2);
  RGB s[4];
  thin_film_sensitivities(2.f * eta2 * maxf(d_nm, 0.f) * c2, s);
  const float as = (c1 - eta2 * c2) / (c1 + eta2 * c2), ap = (eta2 * c1 - c2) / (eta2 * c1 + c2);
  float out[3];
  for (int ch = 0; ch < 3; ++ch) {
    const float e3 = eta3[ch];
    const float sin2_3 = sin2_1 / (e3 * e3);
    if (!(sin2_3 < 1.f)) {  // total internal reflection at the base: a lossless film returns everything
      out[ch] = 1.f;
      continue;
    }
    const float c3 = std::sqrt(1.f - sin2_3);
    const float bs = (eta2 * c2 - e3 * c3) / (eta2 * c2 + e3 * c3), bp = (e3 * c2 - eta2 * c3) / (e3 * c2 + eta2 * c3);
    const float sc[4] = {s[0][ch], s[1][ch], s[2][ch], s[3][ch]};
    out[ch] = clampf(0.5f * (thin_film_channel(as, bs, sc) + thin_film_channel(ap, bp, sc)), 0.f, 1.f);
  }
  return RGB(out[0], out[1], out[2]);
}

// The IOR of a dielectric whose reflectance at normal incidence is F0 (the extension's stand-in for a metal's
// base under the film: its base colour per channel), F0 capped below 1.
CHD float film_ior_from_f0(float F0) {
  const float r = std::sqrt(clampf(F0, 0.f, 0.9999f));
  return (1.f + r) / (1.f - r);
}

}  // namespace caustica
