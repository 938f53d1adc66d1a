// Mitsuba 3's principled BSDF (material/principled.h): f |cos| at fixed directions against the values Mitsuba 3.9.1
// itself returns (`mi.load_dict({"type": "principled", ...}).eval(BSDFContext(), si, wo)` in scalar_rgb, si.wi
// the view direction; the script is in the comment below). Sampling, pdf and albedo are checked with every other
// BSDF in test_bsdf.cpp (chi-square, weight = f |cos| / pdf, and the mean weight against the integral of f).
//
//   d(theta, phi) = (sin theta cos phi, sin theta sin phi, cos theta), degrees
//   P1 base (0.8, 0.3, 0.2), roughness 0.4
//   P2 base (0.3, 0.6, 0.9), metallic 0.7, roughness 0.3, anisotropic 0.5, spec_tint 0.4
//   P3 base (0.9, 0.8, 0.2), roughness 0.6, sheen 0.6, sheen_tint 0.5, clearcoat 0.7, clearcoat_gloss 0.3,
//      flatness 0.4
//   P4 base (0.7, 0.9, 0.5), spec_trans 0.6, roughness 0.3, eta 1.45, metallic 0.1 (views from below too)
//   P5 base 0.5, specular 0.8 (eta from it), roughness 0.15
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "caustica/material/bsdf.h"
#include "caustica/scene/scene_desc.h"

using namespace caustica;

namespace {

Vec3f dir(float theta_deg, float phi_deg) {
  const float t = theta_deg * kPi / 180.f, p = phi_deg * kPi / 180.f;
  return Vec3f(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
}

enum Params { P1, P2, P3, P4, P5 };

Material params(Params p) {
  switch (p) {
    case P1: return make_principled(RGB(0.8f, 0.3f, 0.2f), 0.f, 0.4f);
    case P2: {
      Material m = make_principled(RGB(0.3f, 0.6f, 0.9f), 0.7f, 0.3f, 0.5f);
      m.spec_tint = 0.4f;
      return m;
    }
    case P3: {
      Material m = make_principled(RGB(0.9f, 0.8f, 0.2f), 0.f, 0.6f);
      m.sheen = 0.6f;
      m.sheen_tint = 0.5f;
      m.clearcoat = 0.7f;
      m.clearcoat_gloss = 0.3f;
      m.flatness = 0.4f;
      return m;
    }
    case P4: return make_principled(RGB(0.7f, 0.9f, 0.5f), 0.1f, 0.3f, 0.f, 0.6f, 1.45f);
    case P5: return make_principled(RGB(0.5f), 0.f, 0.15f, 0.f, 0.f, 2.f / (1.f - std::sqrt(0.08f * 0.8f)) - 1.f);
  }
  return Material();
}

struct Row {
  Params p;
  float view_theta, view_phi, light_theta, light_phi;
  float mitsuba[3];  // f |cos(light)|
};

const Row kRows[] = {
    {P1, 30, 0, 30, 180, {0.3689414, 0.231108, 0.2035414}},
    {P1, 30, 0, 50, 160, {0.1833136, 0.08102357, 0.06056556}},
    {P1, 70, 20, 40, 200, {0.2372014, 0.1188619, 0.09519405}},
    {P1, 85, 0, 60, 170, {0.2551322, 0.1976307, 0.1861303}},
    {P1, 10, 0, 80, 90, {0.04409391, 0.01679342, 0.01133332}},
    {P1, 60, 45, 60, 225, {0.6590989, 0.5810065, 0.565388}},
    {P1, 45, 0, 20, 40, {0.2408199, 0.09118579, 0.06125898}},
    {P2, 30, 0, 30, 180, {2.515354, 4.945728, 7.376101}},
    {P2, 30, 0, 50, 160, {0.05088883, 0.1005081, 0.1501273}},
    {P2, 70, 20, 40, 200, {0.1663184, 0.3176557, 0.468993}},
    {P2, 85, 0, 60, 170, {0.1013628, 0.1594329, 0.217503}},
    {P2, 10, 0, 80, 90, {0.004928994, 0.009848439, 0.01476788}},
    {P2, 60, 45, 60, 225, {4.810612, 8.813866, 12.81712}},
    {P2, 45, 0, 20, 40, {0.03388427, 0.06753993, 0.1011956}},
    {P3, 30, 0, 30, 180, {0.3218173, 0.2973177, 0.1503203}},
    {P3, 30, 0, 50, 160, {0.1940375, 0.1749566, 0.0604713}},
    {P3, 70, 20, 40, 200, {0.2853292, 0.2599585, 0.1077342}},
    {P3, 85, 0, 60, 170, {0.3473299, 0.3294804, 0.2223829}},
    {P3, 10, 0, 80, 90, {0.05276144, 0.04704656, 0.01275724}},
    {P3, 60, 45, 60, 225, {0.3247547, 0.3069727, 0.2002806}},
    {P3, 45, 0, 20, 40, {0.2491906, 0.2221401, 0.05983693}},
    {P4, 30, 0, 30, 180, {1.220829, 1.467245, 0.9744123}},
    {P4, 30, 0, 50, 160, {0.07580197, 0.09515261, 0.05645132}},
    {P4, 70, 20, 40, 200, {0.1012325, 0.1247089, 0.07775607}},
    {P4, 85, 0, 60, 170, {0.1330034, 0.1484146, 0.1175923}},
    {P4, 10, 0, 80, 90, {0.01347927, 0.01729712, 0.00966142}},
    {P4, 60, 45, 60, 225, {2.827099, 3.214448, 2.439751}},
    {P4, 45, 0, 20, 40, {0.07661244, 0.09839544, 0.05482943}},
    {P4, 30, 0, 150, 180, {0.09774578, 0.1108333, 0.08261026}},
    {P4, 60, 10, 140, 200, {0.3853562, 0.4369529, 0.3256854}},
    {P4, 150, 0, 30, 180, {0.2055106, 0.2330271, 0.1736881}},
    {P4, 140, 30, 120, 200, {0.1977634, 0.1977634, 0.1977634}},
    {P4, 150, 0, 160, 190, {0.05126425, 0.05126425, 0.05126425}},
    {P5, 30, 0, 30, 180, {12.07793, 12.07793, 12.07793}},
    {P5, 30, 0, 50, 160, {0.1034489, 0.1034489, 0.1034489}},
    {P5, 70, 20, 40, 200, {0.1183517, 0.1183517, 0.1183517}},
    {P5, 85, 0, 60, 170, {0.06320043, 0.06320043, 0.06320043}},
    {P5, 10, 0, 80, 90, {0.02419869, 0.02419869, 0.02419869}},
    {P5, 60, 45, 60, 225, {36.82717, 36.82717, 36.82717}},
    {P5, 45, 0, 20, 40, {0.1495361, 0.1495361, 0.1495361}},
};

}  // namespace

TEST(Principled, MatchesMitsubasEval) {
  // Mitsuba evaluates in single precision and prints 7 digits: 1e-4 of the largest channel is a few dozen
  // float ulps of each lobe (D's steep slope near the mirror direction amplifies their rounding).
  for (const Row& r : kRows) {
    const Material m = params(r.p);
    const Vec3f v = dir(r.view_theta, r.view_phi), l = dir(r.light_theta, r.light_phi);
    const RGB f = bsdf_eval(m, v, l, TransportMode::kRadiance) * std::fabs(l.z);
    const float scale = std::max({r.mitsuba[0], r.mitsuba[1], r.mitsuba[2]});
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(f[c], r.mitsuba[c], 1e-4f * scale)
          << "P" << int(r.p) + 1 << " view (" << r.view_theta << ", " << r.view_phi << ") light (" << r.light_theta
          << ", " << r.light_phi << ") channel " << c;
  }
}

TEST(Principled, ImportanceTransportIsTheAdjoint) {
  // Transmission carries eta^2 more importance than radiance; reflection is the same in both modes.
  const Material m = params(P4);
  const Vec3f v = dir(30.f, 0.f), through = dir(150.f, 180.f), back = dir(40.f, 170.f);
  const RGB rad = bsdf_eval(m, v, through, TransportMode::kRadiance);
  const RGB imp = bsdf_eval(m, v, through, TransportMode::kImportance);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(imp[c], rad[c] * 1.45f * 1.45f, 1e-5f * imp[c]);
  const RGB r1 = bsdf_eval(m, v, back, TransportMode::kRadiance), r2 = bsdf_eval(m, v, back, TransportMode::kImportance);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(r1[c], r2[c]);
}
