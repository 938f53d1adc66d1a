// Rough plastic (material/rough_plastic.h) against Mitsuba 3.9.1's roughplastic: f |cos| at fixed directions,
// the diffuse part (specular_reflectance 0) and the coat's lobe (diffuse_reflectance 0) apart, for GGX and
// Beckmann (alpha 0.3, int_ior 1.5, ext_ior 1, nonlinear, diffuse (0.8, 0.5, 0.2)); values Mitsuba's `eval`
// returned (si.wi the view direction). The models are the same but for the coat lobe's masking term, the
// height-correlated Smith G2 here and Mitsuba's separable G1 G1 (docs/formats-mitsuba.md: up to 12% at 80
// degrees on both sides), which the comparison converts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "caustica/material/bsdf.h"
#include "caustica/scene/scene_desc.h"

using namespace caustica;

namespace {

Vec3f dir(float theta_deg, float phi_deg) {
  const float t = theta_deg * kPi / 180.f, p = phi_deg * kPi / 180.f;
  return Vec3f(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
}

struct Row {
  bool beckmann, diffuse;
  float view_theta, view_phi, light_theta, light_phi;
  float mitsuba[3];
};

const Row kRows[] = {
    {false, true, 0, 0, 0, 0, {0.1539005, 0.08108328, 0.02803148}},
    {false, true, 30, 0, 30, 180, {0.1310884, 0.0690646, 0.02387648}},
    {false, true, 30, 0, 50, 160, {0.09445783, 0.04976561, 0.01720458}},
    {false, true, 70, 20, 40, 200, {0.1013433, 0.05339323, 0.01845869}},
    {false, true, 85, 0, 60, 170, {0.05300718, 0.02792711, 0.009654745}},
    {false, true, 10, 0, 80, 90, {0.02122344, 0.01118168, 0.003865643}},
    {false, true, 60, 45, 60, 225, {0.06655565, 0.03506519, 0.01212247}},
    {false, true, 45, 0, 20, 40, {0.1403711, 0.07395525, 0.02556724}},
    {false, true, 80, 0, 80, 180, {0.01687462, 0.008890482, 0.003073548}},
    {false, false, 0, 0, 0, 0, {0.03536776, 0.03536776, 0.03536776}},
    {false, false, 30, 0, 30, 180, {0.04176952, 0.04176952, 0.04176952}},
    {false, false, 30, 0, 50, 160, {0.01993878, 0.01993878, 0.01993878}},
    {false, false, 70, 20, 40, 200, {0.05495563, 0.05495563, 0.05495563}},
    {false, false, 85, 0, 60, 170, {0.1820043, 0.1820043, 0.1820043}},
    {false, false, 10, 0, 80, 90, {0.0009772793, 0.0009772793, 0.0009772793}},
    {false, false, 60, 45, 60, 225, {0.1394525, 0.1394525, 0.1394525}},
    {false, false, 45, 0, 20, 40, {0.003575417, 0.003575417, 0.003575417}},
    {false, false, 80, 0, 80, 180, {0.8931034, 0.8931034, 0.8931034}},
    {true, true, 0, 0, 0, 0, {0.1809896, 0.08864977, 0.02915367}},
    {true, true, 30, 0, 30, 180, {0.1555046, 0.07616707, 0.02504856}},
    {true, true, 30, 0, 50, 160, {0.1127148, 0.05520837, 0.01815601}},
    {true, true, 70, 20, 40, 200, {0.1209167, 0.05922573, 0.01947718}},
    {true, true, 85, 0, 60, 170, {0.06417308, 0.03143236, 0.01033695}},
    {true, true, 10, 0, 80, 90, {0.02519369, 0.01234002, 0.004058181}},
    {true, true, 60, 45, 60, 225, {0.07981382, 0.03909329, 0.01285635}},
    {true, true, 45, 0, 20, 40, {0.1668939, 0.08174562, 0.02688315}},
    {true, true, 80, 0, 80, 180, {0.02020471, 0.009896387, 0.00325456}},
    {true, false, 0, 0, 0, 0, {0.03536776, 0.03536776, 0.03536776}},
    {true, false, 30, 0, 30, 180, {0.04239375, 0.04239375, 0.04239375}},
    {true, false, 30, 0, 50, 160, {0.02887617, 0.02887617, 0.02887617}},
    {true, false, 70, 20, 40, 200, {0.09256792, 0.09256792, 0.09256792}},
    {true, false, 85, 0, 60, 170, {0.4066063, 0.4066063, 0.4066063}},
    {true, false, 10, 0, 80, 90, {2.78573e-05, 2.78573e-05, 2.78573e-05}},
    {true, false, 60, 45, 60, 225, {0.1577167, 0.1577167, 0.1577167}},
    {true, false, 45, 0, 20, 40, {0.001632439, 0.001632439, 0.001632439}},
    {true, false, 80, 0, 80, 180, {1.518611, 1.518611, 1.518611}},
};

}  // namespace

TEST(RoughPlastic, MatchesMitsubasRoughplastic) {
  double worst_diffuse = 0.0;
  for (const Row& r : kRows) {
    const RGB kd = r.diffuse ? RGB(0.8f, 0.5f, 0.2f) : RGB(0.f), ks = r.diffuse ? RGB(0.f) : RGB(1.f);
    const Material m = make_rough_plastic(kd, 1.5f, 0.3f, r.beckmann, ks);
    const Vec3f v = dir(r.view_theta, r.view_phi), l = dir(r.light_theta, r.light_phi);
    RGB f = bsdf_eval(m, v, l) * l.z;
    // The coat's lobe with Mitsuba's masking term (G1 G1 for caustica's G2): then the same D, F and
    // normalization, to float precision for GGX (1e-4); Mitsuba's Beckmann G1 is Walter et al. 2007's rational
    // approximation (within ~0.35% of the exact erf form caustica uses), so 1% for the product of two. The
    // diffuse part: Mitsuba's 64-entry tables against these 32 entries (both interpolated linearly) and its
    // quadrature against this one, within 1% (0.66% at worst here).
    float tol = r.diffuse ? 0.01f : (r.beckmann ? 0.01f : 1e-4f);
    if (!r.diffuse) {
      const Microfacet g = material_microfacet(m);
      f = f * (g.G1(v) * g.G1(l) / g.G(v, l));
    }
    for (int c = 0; c < 3; ++c) {
      if (r.mitsuba[c] == 0.f) {
        EXPECT_EQ(f[c], 0.f);
        continue;
      }
      if (r.diffuse) worst_diffuse = std::max(worst_diffuse, std::fabs(double(f[c]) / r.mitsuba[c] - 1.0));
      EXPECT_NEAR(f[c], r.mitsuba[c], tol * r.mitsuba[c])
          << (r.beckmann ? "beckmann" : "ggx") << (r.diffuse ? " diffuse" : " specular") << " view (" << r.view_theta
          << ", " << r.view_phi << ") light (" << r.light_theta << ", " << r.light_phi << ") channel " << c;
    }
  }
  std::printf("[rough plastic] worst relative difference of the diffuse part: %.2e\n", worst_diffuse);
}
