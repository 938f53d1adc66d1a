// Blackbody colours (scene/blackbody.h): the colour matching functions' fit integrates as the CIE 1931 table
// does (y-bar's integral 106.86 over 360-830 nm); the table that loaders use agrees with the quadrature within
// 1e-3 of the brightest channel from 500 K to 50000 K; a 6504 K blackbody is close to white (D65 lies near the
// Planckian locus there); low temperatures are red and high ones blue.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "caustica/base/rng.h"
#include "caustica/scene/blackbody.h"

using namespace caustica;

TEST(Blackbody, ColourMatchingFitIntegratesLikeTheTable) {
  double y = 0.0;
  for (int nm = 360; nm <= 830; ++nm) y += (nm == 360 || nm == 830 ? 0.5 : 1.0) * cie_xyz_fit(nm).y;
  EXPECT_NEAR(y, 106.86, 0.01 * 106.86);  // the CIE 1931 table's sum at 1 nm steps; the fit is within 1%
  // y-bar peaks at 555 nm (1.0 in the table; the fit within 2%).
  EXPECT_NEAR(cie_xyz_fit(555.0).y, 1.0, 0.02);
}

TEST(Blackbody, TableMatchesTheQuadrature) {
  PCG32 rng(1, 2);
  double worst = 0.0;
  for (int i = 0; i < 300; ++i) {
    const double t = 500.0 * std::pow(100.0, double(rng.next_float()));  // 500 K to 50000 K
    const RGB a = blackbody_rgb(t), b = blackbody_rgb_exact(t);
    const double m = std::max({b.x, b.y, b.z});
    ASSERT_GT(m, 0.0) << t;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(double(a[c]) - b[c]) / m);
  }
  EXPECT_LT(worst, 1e-3);
  EXPECT_EQ(blackbody_rgb(50.0).x, 0.f);
}

TEST(Blackbody, ColoursFollowTheTemperature) {
  const RGB w = blackbody_rgb_exact(6504.0);
  const float m = std::max({w.x, w.y, w.z});
  for (int c = 0; c < 3; ++c) EXPECT_GT(w[c], 0.9f * m) << c;  // near white
  const RGB red = blackbody_rgb_exact(1500.0), blue = blackbody_rgb_exact(20000.0);
  EXPECT_GT(red.x, red.y);
  EXPECT_GT(red.y, red.z);
  EXPECT_GT(blue.z, blue.y);
  EXPECT_GT(blue.y, blue.x);
}
