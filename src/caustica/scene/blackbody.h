// Blackbody emission as linear sRGB, for emission grids given as temperatures (pbrt-v4's `temperature` grids
// of its grid and NanoVDB media; EmberGen and Houdini write them): a temperature grid becomes a colour emission
// grid when a scene is loaded (scene/loaders/json_loader.cpp).
//
// The colour of temperature T: Planck's law B(lambda, T) = 2 h c^2 / lambda^5 / (exp(h c / (lambda k T)) - 1),
// normalized to 1 at its peak (Wien's displacement law, lambda_max = b / T), as pbrt-v4's BlackbodySpectrum
// is; integrated against the CIE 1931 2-degree colour matching functions (the multi-lobe Gaussian fit of
// Wyman, Sloan & Shirley 2013, "Simple Analytic Approximations to the CIE XYZ Color Matching Functions",
// JCGT 2(2), Sec. 2) over 360-830 nm and divided by the integral of y-bar, so that a flat spectrum of 1 has
// Y = 1; then XYZ to linear sRGB (Rec. 709 primaries, D65 white), negative components set to 0.
#pragma once
#include "../base/math.h"

namespace caustica {

// The CIE 1931 colour matching functions at wavelength `nm` (the fit above).
Vec3f cie_xyz_fit(double nm);

// The linear sRGB of the peak-normalized blackbody at temperature `kelvin`, by quadrature (1 nm steps).
// 0 at or below 100 K (no visible emission to speak of).
RGB blackbody_rgb_exact(double kelvin);

// The same from a table (log-spaced temperatures 100 K to 100000 K, linear interpolation; held beyond):
// relative error below 1e-3 (tests/cpp/test_blackbody.cpp). What the loaders use for every voxel.
RGB blackbody_rgb(double kelvin);

}  // namespace caustica
