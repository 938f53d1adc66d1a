// Blackbody colours (blackbody.h).
#include "blackbody.h"
#include "spectrum.h"

#include <array>
#include <cmath>

namespace caustica {

namespace {

// A piecewise Gaussian: sigma_lo left of the mean, sigma_hi right of it.
double lobe(double x, double mean, double sigma_lo, double sigma_hi) {
  const double t = (x - mean) / (x < mean ? sigma_lo : sigma_hi);
  return std::exp(-0.5 * t * t);
}

constexpr double kWienB = 2.897771955e6;  // nm K

constexpr double kMinKelvin = 100.0, kMaxKelvin = 100000.0;
constexpr int kTableSize = 8192;

}  // namespace

Vec3f cie_xyz_fit(double nm) {
  const double x = 1.056 * lobe(nm, 599.8, 37.9, 31.0) + 0.362 * lobe(nm, 442.0, 16.0, 26.7) -
                   0.065 * lobe(nm, 501.1, 20.4, 26.2);
  const double y = 0.821 * lobe(nm, 568.8, 46.9, 40.5) + 0.286 * lobe(nm, 530.9, 16.3, 31.1);
  const double z = 1.217 * lobe(nm, 437.0, 11.8, 36.0) + 0.681 * lobe(nm, 459.0, 26.0, 13.8);
  return Vec3f(float(x), float(y), float(z));
}

RGB blackbody_rgb_exact(double kelvin) {
  if (!(kelvin > kMinKelvin)) return RGB(0.f);
  const double peak = planck_radiance(kWienB / kelvin, kelvin);
  double X = 0.0, Y = 0.0, Z = 0.0, ybar = 0.0;
  for (int nm = 360; nm <= 830; ++nm) {
    const double w = (nm == 360 || nm == 830) ? 0.5 : 1.0;  // the trapezoid rule
    const double s = planck_radiance(nm, kelvin) / peak;
    const Vec3f c = cie_xyz_fit(nm);
    X += w * s * c.x;
    Y += w * s * c.y;
    Z += w * s * c.z;
    ybar += w * c.y;
  }
  X /= ybar;
  Y /= ybar;
  Z /= ybar;
  const SpectrumRgb c = xyz_to_linear_srgb({X, Y, Z});
  return RGB(float(std::max(c.r, 0.0)), float(std::max(c.g, 0.0)), float(std::max(c.b, 0.0)));
}

RGB blackbody_rgb(double kelvin) {
  static const std::array<RGB, kTableSize> table = [] {
    std::array<RGB, kTableSize> t;
    for (int i = 0; i < kTableSize; ++i)
      t[size_t(i)] = blackbody_rgb_exact(kMinKelvin * std::pow(kMaxKelvin / kMinKelvin, double(i) / (kTableSize - 1)) *
                                         (i == 0 ? 1.0 + 1e-12 : 1.0));
    return t;
  }();
  if (!(kelvin > kMinKelvin)) return RGB(0.f);
  const double u = std::log(std::min(kelvin, kMaxKelvin) / kMinKelvin) / std::log(kMaxKelvin / kMinKelvin) *
                   (kTableSize - 1);
  const int i = std::min(int(u), kTableSize - 2);
  const float f = float(u - i);
  return table[size_t(i)] * (1.f - f) + table[size_t(i) + 1] * f;
}

}  // namespace caustica
