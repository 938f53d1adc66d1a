// The thin film of KHR_materials_iridescence (material/thin_film.h): its limits are the base's Fresnel
// reflectance, its closed-form spectral integral agrees with quadrature of the exact Airy reflectance over the
// colour matching functions, and a quarter-wave film is an anti-reflection coating.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "caustica/material/fresnel.h"
#include "caustica/material/thin_film.h"

namespace caustica {
namespace {

// A film of thickness 0, of the base's IOR, or of the outside's IOR (1) is not there: the reflectance is the
// base's Fresnel reflectance in every channel. The sum is exact in all three (thin_film.h), so the tolerance is
// float rounding: ~30 operations on values <= 1, 2e-6 absolute.
TEST(ThinFilm, AbsentFilmsReflectTheBaseFresnel) {
  for (float c : {1.f, 0.8f, 0.5f, 0.2f, 0.05f})
    for (float eta3 : {1.2f, 1.5f, 3.f})
      for (float eta2 : {1.1f, 1.8f, 2.5f}) {
        const float F = fresnel_dielectric(c, eta3);
        const RGB zero = thin_film_reflectance(c, eta2, RGB(eta3), 0.f);
        const RGB same = thin_film_reflectance(c, eta3, RGB(eta3), 400.f);
        const RGB air = thin_film_reflectance(c, 1.f, RGB(eta3), 400.f);
        for (int ch = 0; ch < 3; ++ch) {
          EXPECT_NEAR(zero[ch], F, 2e-6f) << c << " " << eta2 << " " << eta3;
          EXPECT_NEAR(same[ch], F, 2e-6f) << c << " " << eta3;
          EXPECT_NEAR(air[ch], F, 2e-6f) << c << " " << eta3;
        }
      }
  // The metal's stand-in base: a dielectric whose F0 is the base colour.
  for (float f0 : {0.02f, 0.3f, 0.9f}) EXPECT_NEAR(fresnel_dielectric(1.f, film_ior_from_f0(f0)), f0, 1e-5f);
}

// The lobes of thin_film.h as densities in wavenumber nu: V exp(-(nu - mu)^2 / (4 v)) / sqrt(2), whose cosine
// transform is V sqrt(2 pi v) cos(2 pi nu x) exp(-v (2 pi x)^2) (x in m).
struct Lobe {
  double V, mu, v;
};
constexpr Lobe kLobes[4] = {{5.4856e-13, 1.6810e+06, 4.3278e+09}, {9.7470e-14, 2.2399e+06, 4.5282e+09},
                            {4.4201e-13, 1.7953e+06, 9.3046e+09}, {5.2481e-13, 2.2084e+06, 6.6121e+09}};
// Channel ch's sensitivity at nu (unnormalized): the XYZ to linear sRGB row times the lobes (x: 0 and 1).
double channel_density(int ch, double nu) {
  static const double M[3][3] = {{3.2404542, -1.5371385, -0.4985314},
                                 {-0.9692660, 1.8760108, 0.0415560},
                                 {0.0556434, -0.2040259, 1.0572252}};
  double g[4];
  for (int i = 0; i < 4; ++i) g[i] = kLobes[i].V / std::sqrt(2.0) * std::exp(-std::pow(nu - kLobes[i].mu, 2) / (4 * kLobes[i].v));
  return M[ch][0] * (g[0] + g[1]) + M[ch][1] * g[2] + M[ch][2] * g[3];
}
// The exact Airy reflectance, unpolarized, at wavenumber nu (1/m): the film's amplitudes summed in closed form.
double airy(double c1, double eta2, double eta3, double d_nm, double nu) {
  const double s1 = 1 - c1 * c1, c2 = std::sqrt(1 - s1 / (eta2 * eta2)), c3 = std::sqrt(1 - s1 / (eta3 * eta3));
  const std::complex<double> e = std::polar(1.0, 2 * M_PI * nu * 2 * eta2 * d_nm * 1e-9 * c2);
  const double as = (c1 - eta2 * c2) / (c1 + eta2 * c2), ap = (eta2 * c1 - c2) / (eta2 * c1 + c2);
  const double bs = (eta2 * c2 - eta3 * c3) / (eta2 * c2 + eta3 * c3), bp = (eta3 * c2 - eta2 * c3) / (eta3 * c2 + eta2 * c3);
  const double Rs = std::norm((as + bs * e) / (1.0 + as * bs * e)), Rp = std::norm((ap + bp * e) / (1.0 + ap * bp * e));
  return 0.5 * (Rs + Rp);
}

// The closed form against the quadrature of Airy's reflectance times each channel's sensitivity (midpoint rule,
// 60000 steps from 0.2e6 to 3.8e6 per m, beyond 10 standard deviations of every lobe). The closed form
// sums the series' terms beyond the third at S(4 x) rather than at S(m x); with rho = |a b| per polarization
// that moves the result by at most K 2 rho^4 / (1 - rho) 2 Smax, Smax = the largest |S_c| (bounded by the sum of
// the absolute lobe weights over the value at 0), and float evaluation adds 2e-5 (cos of phases up to ~100 rad).
TEST(ThinFilm, ClosedFormMatchesSpectralQuadrature) {
  double worst = 0.0;
  for (double c : {1.0, 0.7, 0.4, 0.15})
    for (double eta2 : {1.3, 1.8})
      for (double eta3 : {1.5, 2.5})
        for (double d : {100.0, 250.0, 400.0, 800.0, 1500.0}) {
          const RGB got = thin_film_reflectance(float(c), float(eta2), RGB(float(eta3)), float(d));
          // The truncation bound.
          const double s1 = 1 - c * c, c2 = std::sqrt(1 - s1 / (eta2 * eta2)), c3 = std::sqrt(1 - s1 / (eta3 * eta3));
          const double ab[2] = {(c - eta2 * c2) / (c + eta2 * c2) * (eta2 * c2 - eta3 * c3) / (eta2 * c2 + eta3 * c3),
                                (eta2 * c - c2) / (eta2 * c + c2) * (eta3 * c2 - eta2 * c3) / (eta3 * c2 + eta2 * c3)};
          for (int ch = 0; ch < 3; ++ch) {
            const double lo = 0.2e6, hi = 3.8e6;
            const int n = 60000;
            double num = 0, den = 0, abs_den = 0;
            for (int k = 0; k < n; ++k) {
              const double nu = lo + (k + 0.5) * (hi - lo) / n, g = channel_density(ch, nu);
              num += g * airy(c, eta2, eta3, d, nu);
              den += g;
              abs_den += std::fabs(g);
            }
            const double want = std::min(std::max(num / den, 0.0), 1.0);
            const double smax = abs_den / std::fabs(den);
            double bound = 2e-5;
            for (double p : ab) {  // each polarization at half weight, K <= 1
              const double rho = std::fabs(p);
              bound += 0.5 * 2 * std::pow(rho, 4) / (1 - rho) * 2 * smax;
            }
            EXPECT_NEAR(got[ch], want, bound) << "c " << c << " eta2 " << eta2 << " eta3 " << eta3 << " d " << d << " ch " << ch;
            worst = std::max(worst, std::fabs(got[ch] - want));
          }
        }
  // Measured: 2.3e-3 at cosine 0.15 and 100 nm (bound 4e-2 there), ~1e-5 at cosines >= 0.7.
  std::printf("thin film: largest difference from quadrature %.2e\n", worst);
}

// A quarter-wave film of IOR 1.38 (MgF2) on glass of IOR 1.52 at normal incidence is an anti-reflection
// coating: green (the sensitivity's centre ~557 nm) is least reflected at d = 557 / (4 1.38) ~ 101 nm, where
// the monochromatic value is ((1.52 - 1.38^2) / (1.52 + 1.38^2))^2 = 0.0126 against the bare glass's 0.0426.
// The integral over the band raises it a little (the other wavelengths are not at their quarter wave): below
// 0.016, and the minimum within 3 nm (the step) of the band's centre's quarter wave, 95-107 nm.
TEST(ThinFilm, QuarterWaveFilmIsAnAntiReflectionCoating) {
  float best = 1.f, best_d = 0.f;
  for (float d = 40.f; d <= 200.f; d += 1.f) {
    const float g = thin_film_reflectance(1.f, 1.38f, RGB(1.52f), d).y;
    if (g < best) best = g, best_d = d;
  }
  EXPECT_LT(best, 0.016f);
  EXPECT_GE(best_d, 95.f);
  EXPECT_LE(best_d, 107.f);
  EXPECT_NEAR(fresnel_dielectric(1.f, 1.52f), 0.0426f, 1e-4f);
  // A half-wave film (~202 nm) is absent at that wavelength: green near the bare glass's.
  EXPECT_NEAR(thin_film_reflectance(1.f, 1.38f, RGB(1.52f), 202.f).y, 0.0426f, 0.004f);
}

}  // namespace
}  // namespace caustica
