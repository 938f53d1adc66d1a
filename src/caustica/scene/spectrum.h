// Spectra reduced to linear sRGB, as Mitsuba 3's RGB variants reduce the spectra of a scene file (its
// `spectrum_list_to_srgb`), so that a Mitsuba XML scene with measured spectra renders here as it does there
// (scene/loaders/mitsuba_loader.cpp, docs/formats-mitsuba.md).
//
// The colour of a spectrum S(lambda) is the CIE 1931 XYZ of S, optionally lit by the D65 illuminant, converted
// to linear sRGB (Rec. 709 primaries, D65 white):
//   XYZ = (Delta / Y_n) sum_i S(l_i) [D65(l_i) / D65_n] (x-bar, y-bar, z-bar)(l_i),
// over the 1000 wavelengths l_i evenly spaced on [360, 830] nm (both ends included), Delta = 470 / 1000 nm.
// Y_n = 106.7502594 is this rule's integral of y-bar, so a flat spectrum of 1 has Y = 1; with D65 (how
// Mitsuba reads reflectances, which are seen under a white light) Mitsuba's D65_n = 98.9974 makes Y nearly equal
// to 1 for S = 1, so a flat reflectance of 1 becomes (0.99898, 0.99887, 0.99880), white to 0.12%.
// The colour-matching functions are the CIE 1931 2-degree standard observer at 5 nm steps (ISO/CIE 11664-1),
// interpolated linearly, as is D65 (its relative spectral power, 100 at 560 nm); both are zero outside
// 360-830 nm. These are the tables Mitsuba 3 holds, so the results agree with its own conversion to float
// precision (tests/cpp/test_spectrum.cpp holds values that Mitsuba 3.9.1 printed).
#pragma once
#include <vector>

namespace caustica {

struct SpectrumRgb {
  double r = 0, g = 0, b = 0;
};

// The CIE 1931 2-degree colour-matching functions (x-bar, y-bar, z-bar) at `nm`; 0 outside 360-830 nm.
SpectrumRgb cie1931_xyz(double nm);
// The CIE standard illuminant D65's relative spectral power at `nm` (100 at 560 nm); 0 outside 360-830 nm.
double cie_d65(double nm);
// XYZ to linear sRGB.
SpectrumRgb xyz_to_linear_srgb(SpectrumRgb xyz);

// Linear sRGB of S given by `eval(nm)` (the rule above), lit by D65 when `d65`. Unclamped.
template <class F>
SpectrumRgb spectrum_to_linear_srgb(F eval, bool d65);

// Linear sRGB of the piecewise-linear spectrum through (nm[i], value[i]) (nm strictly increasing, at least two
// points), zero outside [nm.front(), nm.back()] as Mitsuba's reduction has it. Unclamped.
SpectrumRgb piecewise_linear_srgb(const std::vector<double>& nm, const std::vector<double>& value, bool d65);

// Planck's law: the spectral radiance of a blackbody at `kelvin`, in W m^-2 sr^-1 per nanometre of wavelength
// `nm` (what Mitsuba 3's `blackbody` spectrum evaluates to).
double planck_radiance(double nm, double kelvin);

constexpr double kSpectrumMinNm = 360.0, kSpectrumMaxNm = 830.0;
constexpr int kSpectrumSteps = 1000;
constexpr double kCieYIntegral = 106.7502593994140625;  // the rule's integral of y-bar
constexpr double kD65YIntegral = 98.99741751876255;     // Mitsuba's D65_n (see above)

template <class F>
SpectrumRgb spectrum_to_linear_srgb(F eval, bool d65) {
  SpectrumRgb xyz;
  for (int i = 0; i < kSpectrumSteps; ++i) {
    const double nm = kSpectrumMinNm + (kSpectrumMaxNm - kSpectrumMinNm) * i / (kSpectrumSteps - 1);
    double s = eval(nm);
    if (s == 0.0) continue;
    if (d65) s *= cie_d65(nm) / kD65YIntegral;
    const SpectrumRgb c = cie1931_xyz(nm);
    xyz.r += s * c.r;
    xyz.g += s * c.g;
    xyz.b += s * c.b;
  }
  const double w = (kSpectrumMaxNm - kSpectrumMinNm) / kSpectrumSteps / kCieYIntegral;
  xyz.r *= w;
  xyz.g *= w;
  xyz.b *= w;
  return xyz_to_linear_srgb(xyz);
}

}  // namespace caustica
