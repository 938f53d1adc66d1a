// Statistical tests of the BSDFs (material/*.h through the bsdf.h dispatch):
//
//  (a) bsdf_sample draws directions with density bsdf_pdf (chi-square, chi2.h;
//      delta and rejected samples form one extra bin);
//  (b) every non-delta sample's weight is bsdf_eval |cos| / pdf and its pdf is
//      bsdf_pdf;
//  (c) reciprocity: f(wo, wi) = f(wi, wo), and for rough glass the generalised
//      form f(wo, wi) / eta_o^2 = f(wi, wo) / eta_i^2 (radiance mode) and the
//      adjoint relation between the two transport modes;
//  (d) white furnace: the albedo (mean sample weight) is <= 1, equals the
//      quadrature integral of bsdf_eval |cos|, and equals its known value where
//      there is one (lossless mirror, smooth and thin glass in importance mode,
//      layered plastic, diffuse transmission, Phong at normal incidence);
//  plus formulas against independent references: the microfacet BSDFs against
//  double-precision Cook-Torrance / Walter et al. 2007, Fresnel (dielectric,
//  complex, the thin slab's series), Snell's law and total internal reflection.
//
// Directions are in the local frame (normal +z); wo = (sin t cos p, sin t sin p,
// cos t) with an azimuth p != 0 so that anisotropic roughness is exercised.
// Set CHI2_VERBOSE=1 to print every chi-square summary and albedo comparison.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "caustica/base/rng.h"
#include "caustica/base/sampling.h"
#include "caustica/material/bsdf.h"
#include "caustica/scene/scene.h"
#include "caustica/scene/scene_desc.h"
#include "caustica/scene/shading.h"
#include "chi2.h"

using namespace caustica;

namespace {

const RGB kGoldEta(0.143f, 0.374f, 1.442f), kGoldK(3.983f, 2.385f, 1.603f);

Material rough_gold(float ax, float ay) {
  Material m = make_conductor(kGoldEta, kGoldK, RGB(1.f), ax);
  m.alpha_y = ay;
  return m;
}
// A rough mirror whose reflectance is a tint (Fresnel ignored), as the JSON
// loader builds a "conductor" with only a specular colour and a roughness.
// Its red channel is white, so its albedo is the microfacet model's alone.
Material rough_tinted(float alpha) {
  Material m = make_mirror(RGB(1.f, 0.75f, 0.4f));
  m.type = MaterialType::kRoughConductor;
  m.alpha_x = m.alpha_y = alpha;
  return m;
}

// A metallic-roughness material under a KHR_materials_clearcoat coat of weight c and perceptual roughness r.
Material coated(Material m, float c, float r) {
  m.clearcoat = c;
  m.clearcoat_alpha = r * r;
  return m;
}

// Its coat's normal turned to n (normalised; KHR_materials_clearcoat's clearcoatNormalTexture, or a base normal
// map the coat does not follow).
Material coat_tilted(Material m, Vec3f n) {
  m.coat_normal = normalize(n);
  return m;
}

// A metallic-roughness material under a KHR_materials_sheen sheen of colour col and perceptual roughness r
// (its albedo table filled, as Scene::build does).
Material sheened(Material m, RGB col, float r) {
  m.sheen_color = col;
  m.sheen_roughness = r;
  prepare_sheen(m);
  return m;
}

// A metallic-roughness material with KHR_materials_specular's weight w and colour s.
Material specular(Material m, float w, RGB s) {
  m.specular_weight = w;
  m.specular = s;
  return m;
}

// A metallic-roughness material under a KHR_materials_iridescence film of weight k, IOR eta and thickness d nm.
Material iridescent(Material m, float k, float eta, float d) {
  m.iridescence = k;
  m.iridescence_eta = eta;
  m.iridescence_thickness = d;
  return m;
}

// A metallic-roughness material with KHR_materials_diffuse_transmission's weight dt and colour t.
Material translucent(Material m, float dt, RGB t) {
  m.diffuse_transmission = dt;
  m.transmission = t;
  return m;
}

Vec3f dir(float cos_theta, float phi) {
  float s = safe_sqrt(1.f - cos_theta * cos_theta);
  return Vec3f(s * std::cos(phi), s * std::sin(phi), cos_theta);
}

struct Case {
  std::string name;
  Material m;
  float cos_o;
  float phi_o = 0.6f;
  // A model that is not energy conserving (Mitsuba's principled with sheen, retro-reflection and clearcoat):
  // instead of albedo <= 1, the albedo must be the reference's, here Mitsuba 3.9.1's own (the mean of its
  // sample weights over 4M samples, with its standard error).
  bool reference_albedo = false;
  // A BSDF that is asymmetric (a coat normal tilted from the shading normal): its albedo <= 1 holds for radiance,
  // not for the adjoint that importance evaluates (as with shading normals, Veach 1997 Sec. 5.3.2), so the furnace
  // test runs in radiance mode (no case of this kind refracts).
  bool radiance_furnace = false;
  double ref[3] = {0, 0, 0}, ref_se[3] = {0, 0, 0};
  bool transmissive() const { return material_is_transmissive(m); }
  Vec3f wo() const { return dir(cos_o, phi_o); }
};

std::string angle_name(float c) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%s%03d", c < 0.f ? "below" : "above", int(std::lround(std::fabs(c) * 100.f)));
  return buf;
}

// The cases of (a), (b) and (d): every BSDF with a non-delta lobe, at several
// incident angles (below the surface too for transmissive and two-sided ones).
std::vector<Case> make_cases() {
  std::vector<Case> cs;
  auto add = [&](const std::string& name, const Material& m, std::initializer_list<float> cos_os) {
    for (float c : cos_os) cs.push_back(Case{name + "_" + angle_name(c), m, c});
  };
  const auto above = {0.9f, 0.5f, 0.1f};
  const auto both = {0.9f, 0.5f, 0.1f, -0.9f, -0.5f, -0.1f};
  add("diffuse", make_diffuse(RGB(0.8f, 0.5f, 0.2f)), above);
  add("diffuse_two_sided", make_diffuse(RGB(0.8f, 0.5f, 0.2f), true), {-0.5f});
  add("gold_a005", rough_gold(0.05f, 0.05f), above);
  add("gold_a030", rough_gold(0.3f, 0.3f), above);
  add("gold_a080", rough_gold(0.8f, 0.8f), above);
  add("gold_aniso_a010_040", rough_gold(0.1f, 0.4f), above);
  add("tinted_a030", rough_tinted(0.3f), above);
  Material bk = rough_gold(0.3f, 0.3f);
  bk.flags |= kBeckmann;
  add("gold_beckmann_a030", bk, above);
  bk = rough_gold(0.1f, 0.4f);
  bk.flags |= kBeckmann;
  add("gold_beckmann_aniso_a010_040", bk, above);
  bk = make_dielectric(1.5f, 0.2f);
  bk.flags |= kBeckmann;
  add("glass_beckmann_eta150_a020", bk, both);
  bk = make_dielectric(1.f / 1.5f, 0.5f);
  bk.flags |= kBeckmann;
  add("glass_beckmann_eta067_a050", bk, both);
  add("glass_eta150_a010", make_dielectric(1.5f, 0.1f), both);
  add("glass_eta150_a050", make_dielectric(1.5f, 0.5f), both);
  add("glass_eta067_a010", make_dielectric(1.f / 1.5f, 0.1f), both);
  add("glass_eta067_a050", make_dielectric(1.f / 1.5f, 0.5f), both);
  add("plastic", make_plastic(RGB(0.8f, 0.5f, 0.2f), 1.5f), above);
  add("rough_plastic_a010", make_rough_plastic(RGB(0.8f, 0.5f, 0.2f), 1.5f, 0.1f), above);
  add("rough_plastic_a040", make_rough_plastic(RGB(0.8f, 0.5f, 0.2f), 1.5f, 0.4f, false, RGB(0.6f, 0.7f, 0.8f)), above);
  add("rough_plastic_beckmann_a030", make_rough_plastic(RGB(0.3f, 0.6f, 0.9f), 1.33f, 0.3f, true), above);
  add("difftrans", make_diffuse_transmission(RGB(0.5f, 0.3f, 0.2f), RGB(0.3f, 0.5f, 0.6f)),
      {0.9f, 0.5f, 0.1f, -0.5f, -0.9f});
  add("phong_n10", make_phong(RGB(0.3f, 0.2f, 0.1f), RGB(0.6f, 0.7f, 0.8f), 10.f), above);
  add("phong_n90", make_phong(RGB(0.3f, 0.2f, 0.1f), RGB(0.6f, 0.7f, 0.8f), 90.f), above);
  const RGB base(0.9f, 0.6f, 0.3f);
  add("mr_metal_r050", make_metallic_roughness(base, 1.f, 0.5f), above);
  add("mr_dielectric_r030", make_metallic_roughness(base, 0.f, 0.3f), above);
  add("mr_mix_r040", make_metallic_roughness(base, 0.5f, 0.4f), above);
  add("mr_smooth_mix", make_metallic_roughness(base, 0.3f, 0.f), above);
  add("mr_glass_r040", make_metallic_roughness(base, 0.f, 0.4f, 1.f), both);
  add("mr_all_r060", make_metallic_roughness(base, 0.3f, 0.6f, 0.5f, 1.33f), both);
  Material mrb = make_metallic_roughness(base, 0.f, 0.5f, 0.f, 1.5f);  // Mitsuba's roughplastic, Beckmann
  mrb.flags |= kPlasticBase | kBeckmann;
  add("mr_plastic_beckmann_r050", mrb, above);
  mrb = make_metallic_roughness(base, 0.4f, 0.4f, 0.5f, 1.33f);
  mrb.flags |= kBeckmann;
  add("mr_all_beckmann_r040", mrb, both);
  // KHR_materials_clearcoat: smooth and rough coats over rough and smooth bases, glass too.
  add("mr_coat_smooth_over_r030", coated(make_metallic_roughness(base, 0.f, 0.3f), 1.f, 0.f), above);
  add("mr_coat_r020_over_metal_r050", coated(make_metallic_roughness(base, 1.f, 0.5f), 0.8f, 0.2f), above);
  add("mr_coat_r030_over_smooth_glass", coated(make_metallic_roughness(base, 0.f, 0.f, 1.f), 1.f, 0.3f), above);
  add("mr_coat_r045_over_all_r060", coated(make_metallic_roughness(base, 0.3f, 0.6f, 0.5f, 1.33f), 0.7f, 0.45f), both);
  // Coats whose normal is tilted from the shading normal (rough over a rough mixture, smooth over a rough metal).
  for (const Case& k : {Case{"mr_coat_tilted_r030_over_r040",
                             coat_tilted(coated(make_metallic_roughness(base, 0.2f, 0.4f), 0.9f, 0.3f), Vec3f(0.35f, -0.2f, 0.9f))},
                        Case{"mr_coat_tilted_smooth_over_metal_r050",
                             coat_tilted(coated(make_metallic_roughness(base, 1.f, 0.5f), 1.f, 0.f), Vec3f(-0.3f, 0.25f, 0.92f))}})
    for (float c : above) {
      Case t = k;
      t.name += "_" + angle_name(c);
      t.cos_o = c;
      t.radiance_furnace = true;
      cs.push_back(t);
    }
  // KHR_materials_specular: a tinted, weighted specular layer (colour above 1 too), rough and smooth, none.
  add("mr_spec_tinted_r030", specular(make_metallic_roughness(base, 0.f, 0.3f), 0.6f, RGB(1.f, 0.5f, 0.2f)), above);
  add("mr_spec_bright_smooth", specular(make_metallic_roughness(base, 0.2f, 0.f), 0.8f, RGB(30.f, 1.f, 0.5f)), above);
  add("mr_spec_none_r040", specular(make_metallic_roughness(base, 0.f, 0.4f), 0.f, RGB(1.f)), above);
  // IOR 1000 (gltf-transform's metalRough): Schlick's rise (mr_dielectric_fresnel).
  add("mr_spec_ior1000_r030", specular(make_metallic_roughness(base, 0.f, 0.3f, 0.f, 1000.f), 0.9f, RGB(0.05f, 0.1f, 0.2f)),
      above);
  // KHR_materials_iridescence: films over a rough dielectric, a rough metal, a smooth metal over a little dielectric, a mixture with glass,
  // under a coat, and a film of the base's IOR over a dielectric with a specular colour.
  add("mr_irid_r030", iridescent(make_metallic_roughness(base, 0.f, 0.3f), 1.f, 1.3f, 400.f), above);
  add("mr_irid_metal_r040", iridescent(make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 1.f, 0.4f), 0.7f, 1.8f, 550.f), above);
  add("mr_irid_smooth_mostly_metal", iridescent(make_metallic_roughness(base, 0.8f, 0.f), 1.f, 1.5f, 300.f), above);
  add("mr_irid_all_r050", iridescent(make_metallic_roughness(base, 0.3f, 0.5f, 0.5f, 1.33f), 0.5f, 2.f, 800.f), both);
  add("mr_irid_coat_smooth_mix", coated(iridescent(make_metallic_roughness(base, 0.4f, 0.f), 1.f, 1.4f, 250.f), 0.6f, 0.2f), above);
  add("mr_irid_spec_r030", iridescent(specular(make_metallic_roughness(base, 0.f, 0.3f), 0.8f, RGB(1.f, 0.6f, 0.3f)), 0.8f, 1.5f, 0.f),
      above);
  // KHR_materials_sheen: over a rough dielectric, with a coat over metal, over smooth glass, over all, and a
  // white sheen over a white Lambertian base (the albedo bound is tight there).
  add("mr_sheen_r050_over_r060", sheened(make_metallic_roughness(base, 0.f, 0.6f), RGB(0.9f, 0.7f, 0.5f), 0.5f), above);
  add("mr_sheen_r030_coat_over_metal",
      coated(sheened(make_metallic_roughness(base, 1.f, 0.4f), RGB(1.f), 0.3f), 0.5f, 0.2f), above);
  add("mr_sheen_r080_over_smooth_glass", sheened(make_metallic_roughness(base, 0.f, 0.f, 1.f), RGB(0.5f), 0.8f), above);
  add("mr_sheen_coat_over_all_r060",
      coated(sheened(make_metallic_roughness(base, 0.3f, 0.6f, 0.5f, 1.33f), RGB(0.3f, 0.6f, 0.9f), 0.6f), 0.7f, 0.45f), both);
  add("mr_sheen_white_over_lambert",
      sheened(specular(make_metallic_roughness(RGB(1.f), 0.f, 0.5f), 0.f, RGB(1.f)), RGB(1.f), 0.4f), above);
  // A smooth sheen (roughness 0.1): its model albedo exceeds 1 near grazing, which the eval divides out.
  add("mr_sheen_r010_white_over_lambert",
      sheened(specular(make_metallic_roughness(RGB(1.f), 0.f, 0.5f), 0.f, RGB(1.f)), RGB(1.f), 0.1f), {0.9f, 0.3f, 0.1f, 0.03f});
  // KHR_materials_diffuse_transmission: seen from both sides (a translucent sheet), rough and smooth, all of the
  // base transmitted, mixed with metal and glass, under a sheen and a coat, with the plastic base.
  const RGB tcol(0.3f, 0.8f, 0.5f);
  add("mr_dt_r040", translucent(make_metallic_roughness(base, 0.f, 0.4f), 0.5f, tcol), both);
  add("mr_dt_smooth", translucent(make_metallic_roughness(base, 0.f, 0.f), 0.3f, tcol), both);
  add("mr_dt_full_r060", translucent(make_metallic_roughness(base, 0.f, 0.6f), 1.f, tcol), both);
  add("mr_dt_all_r050", translucent(make_metallic_roughness(base, 0.3f, 0.5f, 0.4f, 1.33f), 0.6f, tcol), both);
  add("mr_dt_sheen_coat_r040",
      coated(sheened(translucent(make_metallic_roughness(base, 0.2f, 0.4f), 0.7f, tcol), RGB(0.8f, 0.6f, 0.9f), 0.5f), 0.6f, 0.3f),
      both);
  mrb = translucent(make_metallic_roughness(base, 0.f, 0.5f, 0.f, 1.5f), 0.4f, tcol);
  mrb.flags |= kPlasticBase;
  add("mr_dt_plastic_base_r050", mrb, both);
  add("pr_diffuse_r040", make_principled(RGB(0.8f, 0.3f, 0.2f), 0.f, 0.4f), above);
  Material pr = make_principled(RGB(0.3f, 0.6f, 0.9f), 0.7f, 0.3f, 0.5f);
  pr.spec_tint = 0.4f;
  add("pr_metal_aniso", pr, above);
  pr = make_principled(RGB(0.9f, 0.8f, 0.2f), 0.f, 0.6f);
  pr.sheen = 0.6f;
  pr.sheen_tint = 0.5f;
  pr.clearcoat = 0.7f;
  pr.clearcoat_gloss = 0.3f;
  pr.flatness = 0.4f;
  struct Ref {
    float c;
    double a[3], se[3];
  };
  for (const Ref& r : {Ref{0.9f, {0.88723624, 0.79434764, 0.23701578}, {1.90e-4, 1.69e-4, 4.0e-5}},
                       Ref{0.5f, {1.0132875, 0.9082936, 0.2783301}, {2.80e-4, 2.47e-4, 5.3e-5}},
                       Ref{0.1f, {1.2263224, 1.1054507, 0.3802208}, {3.05e-4, 2.66e-4, 6.2e-5}}}) {
    Case k{"pr_sheen_clearcoat_" + angle_name(r.c), pr, r.c};
    k.reference_albedo = true;
    for (int c = 0; c < 3; ++c) {
      k.ref[c] = r.a[c];
      k.ref_se[c] = r.se[c];
    }
    cs.push_back(k);
  }
  add("pr_glass_r030", make_principled(RGB(0.7f, 0.9f, 0.5f), 0.1f, 0.3f, 0.f, 0.6f, 1.45f), both);
  pr = make_principled(RGB(0.6f, 0.5f, 0.4f), 0.f, 0.3f, 0.f, 1.f, 1.5f);
  pr.clearcoat = 1.f;
  pr.clearcoat_gloss = 0.5f;
  add("pr_clear_glass_r030", pr, both);
  return cs;
}

const std::vector<Case>& cases() {
  static const std::vector<Case> cs = make_cases();
  return cs;
}

// One chi-square test per case: the Sidak correction is over all of them.
int num_chi2_tests() { return int(cases().size()); }

struct Draw {
  bool ok;
  BSDFSample s;
};
struct BsdfSampler {
  const Material& m;
  Vec3f wo;
  TransportMode mode;
  PCG32 rng;
  Draw operator()() {
    float uc = rng.next_float();
    float u1 = rng.next_float();
    float u2 = rng.next_float();
    Draw d;
    d.ok = bsdf_sample(m, wo, uc, Vec2f(u1, u2), d.s, mode);
    return d;
  }
};

// Relative difference, with 0 for two zeros.
double rel_diff(double a, double b) {
  double s = std::max(std::fabs(a), std::fabs(b));
  return s > 0.0 ? std::fabs(a - b) / s : 0.0;
}
double rel_diff(RGB a, RGB b) {
  return std::max({rel_diff(a.x, b.x), rel_diff(a.y, b.y), rel_diff(a.z, b.z)});
}

// Per-channel mean and its standard error.
struct Mean3 {
  double n = 0, s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
  void add(RGB v) {
    n += 1;
    for (int c = 0; c < 3; ++c) {
      s[c] += v[c];
      s2[c] += double(v[c]) * v[c];
    }
  }
  double mean(int c) const { return s[c] / n; }
  double se(int c) const {
    double m = mean(c), var = std::max(0.0, s2[c] / n - m * m);
    return std::sqrt(var / (n - 1));
  }
};

// Albedo estimate: the mean weight over n samples (a rejected sample weighs 0).
Mean3 albedo(const Material& m, Vec3f wo, TransportMode mode, long n, uint64_t seed) {
  BsdfSampler draw{m, wo, mode, PCG32(seed, 0x5eed)};
  Mean3 a;
  for (long i = 0; i < n; ++i) {
    Draw d = draw();
    a.add(d.ok ? d.s.weight : RGB(0.f));
  }
  return a;
}

// Float rounding allowance for means of weights that are exactly 1 or a
// constant: a single-precision weight is within 2^-24 of its value.
constexpr double kFloatSlack = 1e-6;

class BsdfCase : public ::testing::TestWithParam<int> {
 protected:
  const Case& c() const { return cases()[size_t(GetParam())]; }
};

std::string case_name(const ::testing::TestParamInfo<int>& info) { return cases()[size_t(info.param)].name; }

}  // namespace

// (a) -----------------------------------------------------------------------

TEST_P(BsdfCase, SamplesFollowPdf) {
  const Case& k = c();
  const Vec3f wo = k.wo();
  BsdfSampler draw{k.m, wo, TransportMode::kRadiance, PCG32(1000 + GetParam(), 0x5eed)};
  auto sample = [&]() {
    Draw d = draw();
    return chi2::SampleDir{d.ok, d.s.wi, d.s.delta};
  };
  auto pdf = [&](Vec3f wi) { return bsdf_pdf(k.m, wo, wi); };
  chi2::Options o;
  o.samples = 1000000;
  o.alpha = 0.01;
  o.n_tests = num_chi2_tests();
  chi2::Result r = chi2::test_sphere(16, sample, pdf, o);
  // The pdf of the non-delta part integrates to at most 1 (the rest is the
  // delta lobe or rejected samples); 4 x quadrature error estimate + float slack.
  EXPECT_LE(r.pdf_integral, 1.0 + 4.0 * r.quad_error + kFloatSlack) << r.report;
  EXPECT_TRUE(r.passed) << k.name << ": " << r.report;  // p >= 0.01 Sidak-corrected over all cases
}

// (b) -----------------------------------------------------------------------

TEST_P(BsdfCase, SampleWeightAndPdfMatchEvalAndPdf) {
  // Relative tolerance 1e-3: the sampling routines compute the same quantities
  // in another order (e.g. the rough conductor's F G2 / G1 from the sampled
  // microfacet normal, bsdf_pdf from the re-derived half vector), so they agree
  // to a few single-precision ulps amplified by the slopes of D and F.
  const Case& k = c();
  const Vec3f wo = k.wo();
  for (TransportMode mode : {TransportMode::kRadiance, TransportMode::kImportance}) {
    BsdfSampler draw{k.m, wo, mode, PCG32(2000 + GetParam(), 0x5eed)};
    long checked = 0, bad_weight = 0, bad_pdf = 0, not_unit = 0;
    double worst_w = 0.0, worst_p = 0.0;
    Vec3f worst_wi(0.f);
    for (int i = 0; i < 100000; ++i) {
      Draw d = draw();
      if (!d.ok) continue;
      if (std::fabs(length(d.s.wi) - 1.f) > 1e-4f) ++not_unit;  // a few float ulps of a unit vector
      if (d.s.delta) continue;
      ++checked;
      float pdf = bsdf_pdf(k.m, wo, d.s.wi);
      RGB expect = bsdf_eval(k.m, wo, d.s.wi, mode) * (std::fabs(d.s.wi.z) / d.s.pdf);
      double ew = rel_diff(d.s.weight, expect), ep = rel_diff(d.s.pdf, pdf);
      if (ew > 1e-3) ++bad_weight;
      if (ep > 1e-3) ++bad_pdf;
      if (ew > worst_w) {
        worst_w = ew;
        worst_wi = d.s.wi;
      }
      worst_p = std::max(worst_p, ep);
    }
    EXPECT_GT(checked, 1000) << k.name;  // every case has a non-delta lobe
    EXPECT_EQ(not_unit, 0) << k.name;
    EXPECT_EQ(bad_weight, 0) << k.name << " mode " << int(mode) << ": worst relative error " << worst_w
                             << " at wi = (" << worst_wi.x << ", " << worst_wi.y << ", " << worst_wi.z << ")";
    EXPECT_EQ(bad_pdf, 0) << k.name << " mode " << int(mode) << ": worst relative error " << worst_p;
  }
}

// (d) -----------------------------------------------------------------------

TEST_P(BsdfCase, WhiteFurnaceAlbedoAtMostOneAndMatchesIntegralOfEval) {
  // Importance mode: there refraction does not scale the weight by 1/eta^2,
  // so no BSDF may create energy (in radiance mode a ray leaving glass carries
  // eta^2 times the radiance, a legitimate albedo above 1). Mean weight
  // <= 1 + 4 standard errors (+ float slack), per channel; for a reference model
  // that does create energy (Case::reference_albedo), the reference's albedo.
  // The same samples' mean non-delta weight must equal the integral of
  // f |cos| over the sphere (adaptive quadrature of bsdf_eval): this catches
  // directions where f > 0 that the sampler never produces, which neither the
  // chi-square test nor the weight check can see.
  const Case& k = c();
  const Vec3f wo = k.wo();
  const TransportMode mode = k.radiance_furnace ? TransportMode::kRadiance : TransportMode::kImportance;
  BsdfSampler draw{k.m, wo, mode, PCG32(3000 + GetParam(), 0x5eed)};
  Mean3 all, cont;  // all samples; only the non-delta ones (delta samples weigh 0)
  for (int i = 0; i < 200000; ++i) {
    Draw d = draw();
    RGB w = d.ok ? d.s.weight : RGB(0.f);
    all.add(w);
    cont.add(d.ok && !d.s.delta ? w : RGB(0.f));
  }
  for (int ch = 0; ch < 3; ++ch) {
    if (k.reference_albedo)  // 4 standard errors of the difference
      EXPECT_NEAR(all.mean(ch), k.ref[ch], 4.0 * std::hypot(all.se(ch), k.ref_se[ch])) << k.name << " channel " << ch;
    else
      EXPECT_LE(all.mean(ch), 1.0 + 4.0 * all.se(ch) + kFloatSlack) << k.name << " channel " << ch;  // 4 SE
  }
  chi2::QuadOptions q;
  chi2::Integration in = chi2::integrate(
      chi2::sphere_grid(8),
      [&](double phi, double z) {
        Vec3f wi = chi2::sphere_dir(phi, z);
        return double(average(bsdf_eval(k.m, wo, wi, mode))) * std::fabs(z);
      },
      q);
  double mean = (cont.mean(0) + cont.mean(1) + cont.mean(2)) / 3.0;
  double se = (cont.se(0) + cont.se(1) + cont.se(2)) / 3.0;  // >= the SE of the channel average
  EXPECT_EQ(in.non_finite, 0) << k.name;
  if (std::getenv("CHI2_VERBOSE"))
    std::fprintf(stderr, "[albedo] %s: estimate %.5f integral %.5f (quadrature error %.1e), |diff| / SE = %.2f\n",
                 k.name.c_str(), mean, in.total, in.error, std::fabs(mean - in.total) / se);
  // 4 SE of the estimate + 4 x the quadrature's error estimate + float slack.
  EXPECT_NEAR(mean, in.total, 4.0 * se + 4.0 * in.error + kFloatSlack) << k.name;
}

INSTANTIATE_TEST_SUITE_P(All, BsdfCase, ::testing::Range(0, int(cases().size())), case_name);

// (c) -----------------------------------------------------------------------

namespace {
struct Recip {
  std::string name;
  Material m;
};
std::vector<Recip> recip_materials() {
  return {
      {"diffuse", make_diffuse(RGB(0.8f, 0.5f, 0.2f))},
      {"diffuse_two_sided", make_diffuse(RGB(0.8f, 0.5f, 0.2f), true)},
      {"gold_a005", rough_gold(0.05f, 0.05f)},
      {"gold_a030", rough_gold(0.3f, 0.3f)},
      {"gold_a080", rough_gold(0.8f, 0.8f)},
      {"gold_aniso", rough_gold(0.1f, 0.4f)},
      {"tinted_a030", rough_tinted(0.3f)},
      {"plastic", make_plastic(RGB(0.8f, 0.5f, 0.2f), 1.5f)},
      {"difftrans", make_diffuse_transmission(RGB(0.5f, 0.3f, 0.2f), RGB(0.3f, 0.5f, 0.6f))},
      {"phong_n10", make_phong(RGB(0.3f, 0.2f, 0.1f), RGB(0.6f, 0.7f, 0.8f), 10.f)},
      {"phong_n90", make_phong(RGB(0.3f, 0.2f, 0.1f), RGB(0.6f, 0.7f, 0.8f), 90.f)},
      {"mr_metal_r050", make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 1.f, 0.5f)},
      {"mr_mix_r040", make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.5f, 0.4f)},
      {"mr_coat_r030_over_mix_r040", coated(make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.5f, 0.4f), 0.9f, 0.3f)},
      {"mr_spec_tinted_r030", specular(make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.f, 0.3f), 0.6f, RGB(1.f, 0.5f, 0.2f))},
      {"mr_sheen_coat_r040", coated(sheened(make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.5f, 0.4f), RGB(0.8f, 0.9f, 1.f), 0.4f), 0.6f, 0.3f)},
      {"mr_dt_r040", translucent(make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.2f, 0.4f), 0.6f, RGB(0.3f, 0.8f, 0.5f))},
      {"mr_dt_sheen_coat_r040", coated(sheened(translucent(make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.2f, 0.4f), 0.6f,
                                                           RGB(0.3f, 0.8f, 0.5f)), RGB(0.8f, 0.9f, 1.f), 0.4f), 0.6f, 0.3f)},
  };
}
// Random direction pairs: uniform on the sphere, so below-surface pairs and
// mixed pairs are covered as well.
constexpr int kRecipPairs = 200000;
}  // namespace

TEST(BsdfReciprocity, SymmetricBsdfs) {
  // f(wo, wi) = f(wi, wo). Relative tolerance 1e-4: the two evaluations round
  // differently (e.g. 1 + L(wo) + L(wi) summed in another order, cos^90 of a
  // dot product), a few ulps times the exponent at most.
  for (const Recip& r : recip_materials()) {
    PCG32 rng(7, 0x5eed);
    long bad = 0, nonzero = 0;
    double worst = 0.0;
    for (int i = 0; i < kRecipPairs; ++i) {
      float a = rng.next_float(), b = rng.next_float(), c = rng.next_float(), d = rng.next_float();
      Vec3f wo = square_to_uniform_sphere(Vec2f(a, b)), wi = square_to_uniform_sphere(Vec2f(c, d));
      RGB f1 = bsdf_eval(r.m, wo, wi), f2 = bsdf_eval(r.m, wi, wo);
      if (!is_black(f1) || !is_black(f2)) ++nonzero;
      double e = rel_diff(f1, f2);
      worst = std::max(worst, e);
      if (e > 1e-4) ++bad;
    }
    EXPECT_GT(nonzero, kRecipPairs / 10) << r.name;  // the test exercised the BSDF
    EXPECT_EQ(bad, 0) << r.name << ": worst relative difference " << worst;
  }
}

namespace {
// IOR on w's side of a rough dielectric: 1 above, m.eta below.
double side_eta(const Material& m, Vec3f w) { return w.z > 0.f ? 1.0 : double(m.eta); }

// Relative tolerance for comparing rough-dielectric values of a pair in
// single precision: 1e-3, plus, for a refraction pair, the float error near
// the critical angle. There the cosine on the denser side is cos_c + delta with
// delta = cos_less^2 / (2 eta^2 cos_c) (cos_less: the microfacet cosine on the
// less dense side), and 1 - F ~ cos_less ~ sqrt(delta), so a rounding error e
// of that cosine changes f by the relative amount eta^2 cos_c e / cos_less^2;
// e = 6e-7 (ten float ulps of a cosine) is allowed. Such pairs are ones where
// the light grazes the microfacet on the less dense side (f -> 0 there).
double dielectric_tolerance(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z * wi.z >= 0.f) return 1e-3;
  const double eo = side_eta(m, wo), ei = side_eta(m, wi);
  double hx = eo * wo.x + ei * wi.x, hy = eo * wo.y + ei * wi.y, hz = eo * wo.z + ei * wi.z;
  const double len = std::sqrt(hx * hx + hy * hy + hz * hz);
  if (len == 0.0) return 1e-3;
  const Vec3f& less = eo < ei ? wo : wi;
  const double cos_less = std::fabs(hx * less.x + hy * less.y + hz * less.z) / len;
  const double eta = std::max(eo, ei) / std::min(eo, ei), cos_c = std::sqrt(1.0 - 1.0 / (eta * eta));
  return 1e-3 + 6e-7 * eta * eta * cos_c / (cos_less * cos_less);
}
}  // namespace

TEST(BsdfReciprocity, RoughDielectricGeneralised) {
  // With eta(w) the index of refraction on w's side (1 above, m.eta below):
  //   radiance mode:   f(wo, wi) / eta(wo)^2 = f(wi, wo) / eta(wi)^2
  //     (Veach 1997, Eq. 5.14: radiance is scaled by eta^2 across the surface);
  //   importance mode: f(wo, wi) / eta(wi)^2 = f(wi, wo) / eta(wo)^2, which is
  //     the adjoint relation f*(wo, wi) = f(wi, wo) (Veach 1997, Sec. 5.2);
  // neither is symmetric for refraction (asserted too). Tolerance: see
  // dielectric_tolerance (the two evaluations derive the Fresnel cosine on
  // different sides of the interface).
  struct G {
    const char* name;
    Material m;
  };
  for (const G& g : {G{"eta150_a010", make_dielectric(1.5f, 0.1f)}, G{"eta150_a050", make_dielectric(1.5f, 0.5f)},
                     G{"eta067_a010", make_dielectric(1.f / 1.5f, 0.1f)},
                     G{"eta067_a050", make_dielectric(1.f / 1.5f, 0.5f)},
                     // glTF glass under a clear coat (the coat's (1 - c Fc) factors are symmetric)
                     G{"mr_coat_glass_r040", coated(make_metallic_roughness(RGB(1.f), 0.f, 0.4f, 1.f, 1.5f), 1.f, 0.3f)}}) {
    PCG32 rng(8, 0x5eed);
    long bad_rad = 0, bad_imp = 0, bad_adj = 0, refractions = 0, asym = 0;
    double worst_rad = 0.0, worst_imp = 0.0, worst_adj = 0.0;
    for (int i = 0; i < kRecipPairs; ++i) {
      float a = rng.next_float(), b = rng.next_float(), c = rng.next_float(), d = rng.next_float();
      Vec3f wo = square_to_uniform_sphere(Vec2f(a, b)), wi = square_to_uniform_sphere(Vec2f(c, d));
      RGB r1 = bsdf_eval(g.m, wo, wi, TransportMode::kRadiance), r2 = bsdf_eval(g.m, wi, wo, TransportMode::kRadiance);
      RGB i1 = bsdf_eval(g.m, wo, wi, TransportMode::kImportance),
          i2 = bsdf_eval(g.m, wi, wo, TransportMode::kImportance);
      const double eo2 = side_eta(g.m, wo) * side_eta(g.m, wo), ei2 = side_eta(g.m, wi) * side_eta(g.m, wi);
      const double tol = dielectric_tolerance(g.m, wo, wi);
      if (wo.z * wi.z < 0.f && !is_black(r1)) ++refractions;
      double er = rel_diff(r1.x / eo2, r2.x / ei2), ei = rel_diff(i1.x / ei2, i2.x / eo2);
      double ea = rel_diff(i1, r2);
      if (rel_diff(r1.x, r2.x) > 0.1) ++asym;
      worst_rad = std::max(worst_rad, er / tol);
      worst_imp = std::max(worst_imp, ei / tol);
      worst_adj = std::max(worst_adj, ea / tol);
      bad_rad += er > tol;
      bad_imp += ei > tol;
      bad_adj += ea > tol;
    }
    EXPECT_GT(refractions, kRecipPairs / 100) << g.name;  // the refraction lobe was exercised
    EXPECT_GT(asym, 0) << g.name;                         // refraction is not symmetric in radiance mode
    EXPECT_EQ(bad_rad, 0) << g.name << ": radiance mode, worst error / tolerance " << worst_rad;
    EXPECT_EQ(bad_imp, 0) << g.name << ": importance mode, worst error / tolerance " << worst_imp;
    EXPECT_EQ(bad_adj, 0) << g.name << ": adjoint, worst error / tolerance " << worst_adj;
  }
}

// Microfacet BSDFs against independent double-precision implementations ------

namespace ref {
constexpr double kPiD = 3.14159265358979323846;
double sqr(double x) { return x * x; }
struct V {
  double x, y, z;
};
V v(Vec3f a) { return {a.x, a.y, a.z}; }
double dot(V a, V b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V normalize(V a) {
  double l = std::sqrt(dot(a, a));
  return {a.x / l, a.y / l, a.z / l};
}
// GGX (Walter et al. 2007 Eq. 33, anisotropic: Heitz 2014 Eq. 85) and Smith's
// Lambda (Heitz 2014 Eq. 86), height-correlated G2 (Heitz 2014 Eq. 99).
// Microfacet normals within 1e-4 of the horizon: there GGX::D (like pbrt-v4's
// TrowbridgeReitzDistribution::D) returns 0 when cos^4 < 1e-16 to keep tan^2
// finite, although D tends to alpha^2 / pi; a set of pairs of measure ~1e-4
// where f is 0 in both pdf and eval, so sampling stays consistent. The
// comparisons skip such pairs (with a factor-2 margin for float rounding).
bool near_horizontal(V h) { return std::pow(h.z, 4) < 2e-16; }
double D(V h, double ax, double ay) {
  if (h.z <= 0.0) return 0.0;
  double e = (h.x * h.x / (ax * ax) + h.y * h.y / (ay * ay)) / (h.z * h.z);
  return 1.0 / (kPiD * ax * ay * std::pow(h.z, 4) * sqr(1.0 + e));
}
double lambda(V w, double ax, double ay) {
  return 0.5 * (std::sqrt(1.0 + (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z)) - 1.0);
}
double G2(V o, V i, double ax, double ay) { return 1.0 / (1.0 + lambda(o, ax, ay) + lambda(i, ax, ay)); }
// Unpolarised Fresnel with a complex relative index (std::complex).
double fresnel_complex(double c, double n, double k) {
  std::complex<double> e(n, k), ci(c, 0.0);
  std::complex<double> ct = std::sqrt(1.0 - (1.0 - c * c) / (e * e));
  std::complex<double> rp = (e * ci - ct) / (e * ci + ct), rs = (ci - e * ct) / (ci + e * ct);
  return 0.5 * (std::norm(rp) + std::norm(rs));
}
// Cook-Torrance: F D G2 / (4 cos_o cos_i), Walter et al. 2007 Eq. 20.
double rough_conductor(const Material& m, int ch, V o, V i) {
  if (o.z <= 0.0 || i.z <= 0.0) return 0.0;
  V h = normalize({o.x + i.x, o.y + i.y, o.z + i.z});
  if (near_horizontal(h)) return -1.0;  // skipped
  double F = (m.flags & kConductorTint) ? m.specular[ch]
                                        : m.specular[ch] * fresnel_complex(dot(o, h), m.eta_c[ch], m.k_c[ch]);
  return F * D(h, m.alpha_x, m.alpha_y) * G2(o, i, m.alpha_x, m.alpha_y) / (4.0 * o.z * i.z);
}
// Walter et al. 2007: reflection Eq. 20; transmission Eq. 21 written for
// radiance, with i the light direction and o the viewing direction:
//   f_t = |i.h||o.h| / (|i.n||o.n|) eta_o^2 (1 - F) D G / (eta_i (i.h) + eta_o (o.h))^2,
// h = -(eta_i i + eta_o o) normalised (Eq. 16), and the sidedness factors chi+.
// Importance is the adjoint: f*(o, i) = f(i, o).
double rough_dielectric(const Material& m, V o, V i, TransportMode mode) {
  if (mode == TransportMode::kImportance) std::swap(o, i);
  if (o.z == 0.0 || i.z == 0.0) return 0.0;
  const double ax = m.alpha_x, ay = m.alpha_y;
  const double eo = o.z > 0.0 ? 1.0 : m.eta, ei = i.z > 0.0 ? 1.0 : m.eta;
  const bool refl = o.z * i.z > 0.0;
  V h = refl ? normalize({o.x + i.x, o.y + i.y, o.z + i.z})
             : normalize({eo * o.x + ei * i.x, eo * o.y + ei * i.y, eo * o.z + ei * i.z});
  if (h.z < 0.0) h = {-h.x, -h.y, -h.z};
  if (near_horizontal(h)) return -1.0;  // skipped
  const double oh = dot(o, h), ih = dot(i, h);
  if (oh * o.z <= 0.0 || ih * i.z <= 0.0) return 0.0;  // chi+
  // Fresnel seen from o's side of the interface: relative index (other side) / (o's side).
  const double c = std::fabs(oh), eta_rel = o.z > 0.0 ? m.eta : 1.0 / m.eta;
  const double s2 = (1.0 - c * c) / (eta_rel * eta_rel);
  double F = 1.0;  // total internal reflection
  if (s2 < 1.0) {
    double ct = std::sqrt(1.0 - s2);
    double rs = (c - eta_rel * ct) / (c + eta_rel * ct), rp = (eta_rel * c - ct) / (eta_rel * c + ct);
    F = 0.5 * (rs * rs + rp * rp);
  }
  const double d = D(h, ax, ay), g = G2(o, i, ax, ay);
  if (refl) return F * d * g / std::fabs(4.0 * o.z * i.z);
  return std::fabs(ih * oh / (i.z * o.z)) * eo * eo * (1.0 - F) * d * g / sqr(ei * ih + eo * oh);
}
}  // namespace ref

namespace {
// Pairs for the reference comparisons: half with wi uniform on the sphere,
// half with wi drawn by bsdf_sample (so the lobes' peaks are covered).
template <class Check>
void for_pairs(const Material& m, uint64_t seed, int n, Check&& check) {
  PCG32 rng(seed, 0x5eed);
  for (int k = 0; k < n; ++k) {
    float a = rng.next_float(), b = rng.next_float(), c = rng.next_float(), d = rng.next_float();
    float e = rng.next_float();
    Vec3f wo = square_to_uniform_sphere(Vec2f(a, b)), wi = square_to_uniform_sphere(Vec2f(c, d));
    if (k % 2) {
      BSDFSample s;
      if (!bsdf_sample(m, wo, e, Vec2f(c, d), s) || s.delta) continue;
      wi = s.wi;
    }
    check(wo, wi);
  }
}
}  // namespace

TEST(MicrofacetReference, BeckmannIsNormalizedAndItsMaskingMatches) {
  // int D(m) cos theta_m dm = 1, and the projected-area identity int G1(wo) max(0, wo.m) D(m) dm = wo.z
  // (Heitz 2014, Sec. 2), which holds only when Lambda is D's own: checks D and the erf form of Lambda.
  // Tolerance: 4 x the quadrature's error estimate + 1e-5 (single-precision D).
  for (Vec2f a : {Vec2f(0.2f, 0.2f), Vec2f(0.5f, 0.5f), Vec2f(0.15f, 0.6f)}) {
    const Microfacet g{a.x, a.y, true};
    chi2::QuadOptions q;
    chi2::Integration n = chi2::integrate(
        chi2::sphere_grid(16),
        [&](double phi, double z) { return z > 0.0 ? double(g.D(chi2::sphere_dir(phi, z))) * z : 0.0; }, q);
    EXPECT_NEAR(n.total, 1.0, 4.0 * n.error + 1e-5) << a.x << " " << a.y;
    for (float c : {0.9f, 0.5f, 0.15f}) {
      const Vec3f wo = dir(c, 0.7f);
      chi2::Integration p = chi2::integrate(
          chi2::sphere_grid(16),
          [&](double phi, double z) {
            const Vec3f m = chi2::sphere_dir(phi, z);
            return z > 0.0 ? double(g.G1(wo)) * std::max(0.0, double(dot(wo, m))) * double(g.D(m)) : 0.0;
          },
          q);
      EXPECT_NEAR(p.total, c, 4.0 * p.error + 1e-5) << a.x << " " << a.y << " cos " << c;
    }
  }
}

TEST(MicrofacetReference, RoughConductorMatchesCookTorrance) {
  // Relative tolerance 1e-3: single- against double-precision evaluation of
  // the same formulas (D's relative slope is at most ~4 / alpha per radian of
  // the half vector, whose float error is ~1e-7 rad).
  for (const Material& m : {rough_gold(0.05f, 0.05f), rough_gold(0.3f, 0.3f), rough_gold(0.8f, 0.8f),
                            rough_gold(0.1f, 0.4f), rough_tinted(0.3f)}) {
    long bad = 0, nonzero = 0, skipped = 0;
    double worst = 0.0;
    for_pairs(m, 60, 100000, [&](Vec3f wo, Vec3f wi) {
      RGB f = bsdf_eval(m, wo, wi);
      if (ref::rough_conductor(m, 0, ref::v(wo), ref::v(wi)) < 0.0) {
        ++skipped;
        return;
      }
      for (int ch = 0; ch < 3; ++ch) {
        double r = ref::rough_conductor(m, ch, ref::v(wo), ref::v(wi));
        double e = rel_diff(f[ch], r);
        nonzero += r > 0.0;
        worst = std::max(worst, e);
        bad += e > 1e-3;
      }
    });
    EXPECT_GT(nonzero, 10000);
    EXPECT_LE(skipped, 100);  // near-horizontal half vectors are rare (~1e-4 of pairs)
    EXPECT_EQ(bad, 0) << "alpha " << m.alpha_x << ", " << m.alpha_y << ": worst relative error " << worst;
  }
}

TEST(MicrofacetReference, RoughDielectricMatchesWalter2007) {
  // Tolerance: dielectric_tolerance (1e-3, more for refraction pairs that
  // graze a microfacet on the less dense side, where 1 - F is ill-conditioned).
  for (const Material& m : {make_dielectric(1.5f, 0.1f), make_dielectric(1.5f, 0.5f),
                            make_dielectric(1.f / 1.5f, 0.1f), make_dielectric(1.f / 1.5f, 0.5f)}) {
    for (TransportMode mode : {TransportMode::kRadiance, TransportMode::kImportance}) {
      long bad = 0, refr = 0, skipped = 0;
      double worst = 0.0;
      for_pairs(m, 61, 100000, [&](Vec3f wo, Vec3f wi) {
        double f = bsdf_eval(m, wo, wi, mode).x, r = ref::rough_dielectric(m, ref::v(wo), ref::v(wi), mode);
        if (r < 0.0) {
          ++skipped;
          return;
        }
        double e = rel_diff(f, r) / dielectric_tolerance(m, wo, wi);
        refr += r > 0.0 && wo.z * wi.z < 0.f;
        worst = std::max(worst, e);
        bad += e > 1.0;
      });
      EXPECT_GT(refr, 10000);
      EXPECT_LE(skipped, 100);  // near-horizontal half vectors are rare (~1e-4 of pairs)
      EXPECT_EQ(bad, 0) << "eta " << m.eta << " alpha " << m.alpha_x << " mode " << int(mode)
                        << ": worst error / tolerance " << worst;
    }
  }
}

// (d) with known albedos ----------------------------------------------------

namespace {
const std::vector<float> kAngles = {0.9f, 0.5f, 0.1f, -0.1f, -0.5f, -0.9f};

// Unpolarised Fresnel reflectance in double (Born & Wolf), eta = eta_t / eta_i,
// cos_i > 0 on the incident side.
double fresnel_ref(double cos_i, double eta) {
  double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0) return 1.0;
  double cos_t = std::sqrt(1.0 - sin2_t);
  double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}
}  // namespace

TEST(WhiteFurnace, LosslessMirrorIsOne) {
  const Material m = make_mirror(RGB(1.f));
  for (float c : {0.9f, 0.5f, 0.1f}) {
    Mean3 a = albedo(m, dir(c, 0.6f), TransportMode::kRadiance, 100000, 40);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(a.mean(ch), 1.0, 4.0 * a.se(ch) + kFloatSlack) << c;  // 4 SE
  }
}

TEST(WhiteFurnace, SmoothDielectricImportanceIsOneAndRadianceScales) {
  // Importance: F + (1 - F) = 1. Radiance: F + (1 - F) / eta_t^2 with eta_t the
  // relative index crossed, since refracted radiance is divided by it squared.
  for (float eta : {1.5f, 1.f / 1.5f}) {
    const Material m = make_dielectric(eta);
    for (float c : kAngles) {
      Vec3f wo = dir(c, 0.6f);
      Mean3 imp = albedo(m, wo, TransportMode::kImportance, 100000, 41);
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(imp.mean(ch), 1.0, 4.0 * imp.se(ch) + kFloatSlack) << eta << " " << c;
      double et = c > 0.f ? eta : 1.0 / eta;
      double F = fresnel_ref(std::fabs(c), et);
      Mean3 rad = albedo(m, wo, TransportMode::kRadiance, 100000, 42);
      EXPECT_NEAR(rad.mean(0), F + (1.0 - F) / (et * et), 4.0 * rad.se(0) + kFloatSlack) << eta << " " << c;  // 4 SE
    }
  }
}

TEST(WhiteFurnace, ThinDielectricIsOne) {
  const Material m = make_thin_dielectric(1.5f);
  for (float c : kAngles) {
    Mean3 a = albedo(m, dir(c, 0.6f), TransportMode::kImportance, 100000, 43);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(a.mean(ch), 1.0, 4.0 * a.se(ch) + kFloatSlack) << c;  // 4 SE
  }
}

TEST(ThinDielectric, ReflectsWithSlabReflectanceAndTransmitsStraight) {
  // Every weight is 1, so the furnace above cannot see the split: the
  // reflection probability must be the slab's R' = R + T^2 R / (1 - R^2)
  // (a geometric series of internal bounces, T = 1 - R), the same from both
  // sides, and transmission must continue along -wo.
  const Material m = make_thin_dielectric(1.5f);
  for (float c : kAngles) {
    const Vec3f wo = dir(c, 0.6f);
    const double R = fresnel_ref(std::fabs(c), 1.5), T = 1.0 - R;
    const double Rp = R + T * T * R / (1.0 - R * R);
    BsdfSampler draw{m, wo, TransportMode::kRadiance, PCG32(52, 0x5eed)};
    const int n = 100000;
    int refl = 0;
    for (int i = 0; i < n; ++i) {
      Draw d = draw();
      ASSERT_TRUE(d.ok && d.s.delta);
      if (d.s.wi.z * wo.z > 0.f) {
        ++refl;
        EXPECT_NEAR(d.s.pdf, Rp, 1e-6);  // float evaluation
      } else {
        EXPECT_NEAR(length(d.s.wi + wo), 0.f, 1e-6f);  // undeviated
      }
    }
    // Binomial: 4 standard errors sqrt(R' (1 - R') / n).
    EXPECT_NEAR(double(refl) / n, Rp, 4.0 * std::sqrt(Rp * (1.0 - Rp) / n)) << "cos_o " << c;
  }
}

TEST(WhiteFurnace, DiffuseAndDiffuseTransmissionMatchTheirReflectances) {
  // Lambert: every weight is exactly R. Diffuse transmission: R + T.
  const RGB R(0.8f, 0.5f, 0.2f);
  const Material d = make_diffuse(R);
  const RGB Rt(0.5f, 0.3f, 0.2f), Tt(0.3f, 0.5f, 0.6f);
  const Material dt = make_diffuse_transmission(Rt, Tt);
  for (float c : kAngles) {
    Vec3f wo = dir(c, 0.6f);
    if (c > 0.f) {
      Mean3 a = albedo(d, wo, TransportMode::kRadiance, 100000, 44);
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(a.mean(ch), R[ch], kFloatSlack) << c;  // constant weight
    }
    Mean3 b = albedo(dt, wo, TransportMode::kRadiance, 100000, 45);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(b.mean(ch), Rt[ch] + Tt[ch], 4.0 * b.se(ch) + kFloatSlack) << c;  // 4 SE
  }
}

TEST(WhiteFurnace, PlasticMatchesItsLayeredAlbedo) {
  // Internal diffuse reflectance Fdr_int = 2 int_0^1 F(mu, 1/eta) mu dmu,
  // reference by 2*10^5-step midpoint in double with the critical angle at a
  // step edge (error ~1e-10); the scene code's 4096-step float-valued midpoint
  // is within 1e-5 (its error near the kink of F at the critical angle is
  // O(h^1.5) ~ 4e-6).
  const double eta = 1.5;
  auto fdr = [](double e) {
    const double mu_c = e < 1.0 ? std::sqrt(1.0 - e * e) : 0.0;  // TIR below mu_c
    const int n = 200000;
    double s = mu_c * mu_c;                                        // F = 1 on [0, mu_c]: 2 int mu = mu_c^2
    for (int i = 0; i < n; ++i) {
      double mu = mu_c + (1.0 - mu_c) * (i + 0.5) / n;
      s += 2.0 * fresnel_ref(mu, e) * mu * (1.0 - mu_c) / n;
    }
    return s;
  };
  const double fdr_int = fdr(1.0 / eta), fdr_ext = fdr(eta);
  // Reciprocity of Fresnel transmission: 1 - Fdr_int = (1 - Fdr_ext) / eta^2.
  EXPECT_NEAR(1.0 - fdr_int, (1.0 - fdr_ext) / (eta * eta), 1e-8);  // two 1e-10-accurate integrals
  for (RGB kd : {RGB(1.f), RGB(0.8f, 0.5f, 0.2f)}) {
    const Material m = make_plastic(kd, float(eta));
    EXPECT_NEAR(m.fdr_int, fdr_int, 1e-5);
    // Albedo = F(cos_o) + (1 - F(cos_o)) Kd (1 - Fdr_int) / (1 - Kd Fdr_int):
    // specular F, plus the transmitted part bounced between base and coat (a
    // geometric series) and let out with probability 1 - Fdr_int. Kd = 1 is
    // lossless: exactly 1.
    for (float c : {0.9f, 0.5f, 0.1f}) {
      Mean3 a = albedo(m, dir(c, 0.6f), TransportMode::kRadiance, 200000, 46);
      double F = fresnel_ref(c, eta);
      for (int ch = 0; ch < 3; ++ch) {
        double expect = F + (1.0 - F) * kd[ch] * (1.0 - fdr_int) / (1.0 - kd[ch] * fdr_int);
        // 4 SE, plus the 1e-5 error of m.fdr_int times d(albedo)/d(Fdr) <= 1 / (1 - Fdr)^2 ~ 1.7
        EXPECT_NEAR(a.mean(ch), expect, 4.0 * a.se(ch) + 2e-5) << "kd " << kd[ch] << " cos " << c;
      }
    }
  }
}

TEST(WhiteFurnace, PhongAtNormalIncidenceIsKdPlusKs) {
  // Modified Phong (Lafortune & Willems 1994): at normal incidence the lobe
  // (n + 2) / (2 pi) cos^n(alpha), alpha = theta_i, lies wholly above the
  // horizon and int (n + 2) / (2 pi) cos^(n+1) d(omega) = 1, so the albedo is
  // exactly Kd + Ks; elsewhere the horizon clips the lobe: below Kd + Ks.
  const RGB kd(0.3f, 0.2f, 0.1f), ks(0.6f, 0.7f, 0.8f);
  for (float n : {10.f, 90.f}) {
    const Material m = make_phong(kd, ks, n);
    Mean3 a = albedo(m, Vec3f(0.f, 0.f, 1.f), TransportMode::kRadiance, 200000, 49);
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(a.mean(ch), kd[ch] + ks[ch], 4.0 * a.se(ch) + kFloatSlack) << "n " << n << " channel " << ch;  // 4 SE
    for (float c : {0.5f, 0.1f}) {
      Mean3 b = albedo(m, dir(c, 0.6f), TransportMode::kRadiance, 200000, 50);
      for (int ch = 0; ch < 3; ++ch) EXPECT_LT(b.mean(ch), kd[ch] + ks[ch] + 4.0 * b.se(ch)) << "n " << n;  // 4 SE
    }
  }
}

TEST(WhiteFurnace, RoughDielectricImportanceNearOneForLowRoughness) {
  // In importance mode every sample weighs G2(wo, wi) / G1(wo) <= 1 (Heitz
  // 2018, Sec. 2), so the albedo is <= 1. It falls short of 1 by the energy
  // that a single-scattering microfacet model drops, which grows with
  // roughness (Heitz et al. 2016, "Multiple-scattering microfacet BSDFs with
  // the Smith model"; Kulla & Conty 2017):
  //  - scattered directions on the wrong side of the surface (rejected): under
  //    GGX the visible normals tilted beyond theta_h have weight
  //    ~alpha^2 / (alpha^2 + tan^2 theta_h); at alpha = 0.1, tilting normally
  //    incident light to the horizon (theta_h = 45 deg) takes ~1 %;
  //  - shadowing of wi, G2 / G1(wo) >= G1(wi).
  // An independent double-precision integration of the GGX model (the white
  // conductor, F = 1) gives E = 0.987, 0.969, 0.883 at cos_o = 0.9, 0.5, 0.1
  // for alpha = 0.1, and 0.68 - 0.86 for alpha = 0.5; glass behaves alike (on
  // its dense side total internal reflection makes it nearly that conductor).
  // Asserted, each within 4 standard errors:
  //   alpha = 0.1: albedo >= 0.95 for |cos_o| >= 0.5, >= 0.85 for |cos_o| = 0.1;
  //   alpha = 0.5: albedo >= 0.6, and below the alpha = 0.1 albedo (the loss
  //                grows with roughness);
  //   all: albedo <= 1.
  struct B {
    float cos_abs;
    double lower_01, lower_05;
  };
  for (float eta : {1.5f, 1.f / 1.5f})
    for (B b : {B{0.9f, 0.95, 0.6}, B{0.5f, 0.95, 0.6}, B{0.1f, 0.85, 0.6}})
      for (float sign : {1.f, -1.f}) {
        const Vec3f wo = dir(sign * b.cos_abs, 0.6f);
        Mean3 a1 = albedo(make_dielectric(eta, 0.1f), wo, TransportMode::kImportance, 200000, 47);
        Mean3 a5 = albedo(make_dielectric(eta, 0.5f), wo, TransportMode::kImportance, 200000, 48);
        const std::string where = "eta " + std::to_string(eta) + " cos_o " + std::to_string(sign * b.cos_abs);
        EXPECT_LE(a1.mean(0), 1.0 + 4.0 * a1.se(0) + kFloatSlack) << where;  // 4 SE
        EXPECT_LE(a5.mean(0), 1.0 + 4.0 * a5.se(0) + kFloatSlack) << where;  // 4 SE
        EXPECT_GE(a1.mean(0), b.lower_01 - 4.0 * a1.se(0)) << where;         // 4 SE
        EXPECT_GE(a5.mean(0), b.lower_05 - 4.0 * a5.se(0)) << where;         // 4 SE
        // 4 SE of the difference of two independent estimates.
        EXPECT_GT(a1.mean(0) - a5.mean(0), -4.0 * std::hypot(a1.se(0), a5.se(0))) << where;
        if (std::getenv("CHI2_VERBOSE"))
          std::fprintf(stderr, "[furnace] rough glass %s: alpha 0.1 %.4f +- %.4f, alpha 0.5 %.4f +- %.4f\n",
                       where.c_str(), a1.mean(0), a1.se(0), a5.mean(0), a5.se(0));
      }
}

// Smooth dielectric: Fresnel, Snell, total internal reflection ----------------

TEST(SmoothDielectric, ReflectionProbabilityIsFresnelAndSnellHolds) {
  const float eta = 1.5f;
  const Material m = make_dielectric(eta);
  for (float c : kAngles) {
    const Vec3f wo = dir(c, 0.6f);
    const double et = c > 0.f ? eta : 1.0 / eta;  // eta_t / eta_i
    const double F = fresnel_ref(std::fabs(c), et);
    EXPECT_NEAR(fresnel_dielectric(c, eta), F, 1e-6) << c;  // float evaluation of the same formula
    BsdfSampler draw{m, wo, TransportMode::kRadiance, PCG32(50, 0x5eed)};
    const int n = 100000;
    int refl = 0, fails = 0;
    for (int i = 0; i < n; ++i) {
      Draw d = draw();
      if (!d.ok) {
        ++fails;
        continue;
      }
      ASSERT_TRUE(d.s.delta);
      EXPECT_EQ(bsdf_pdf(m, wo, d.s.wi), 0.f);  // no continuous density
      EXPECT_TRUE(is_black(bsdf_eval(m, wo, d.s.wi)));
      if (d.s.wi.z * wo.z > 0.f) {
        ++refl;
        EXPECT_NEAR(d.s.wi.x, -wo.x, 1e-6f);  // mirror direction
        EXPECT_NEAR(d.s.wi.y, -wo.y, 1e-6f);
        EXPECT_NEAR(d.s.wi.z, wo.z, 1e-6f);
        EXPECT_NEAR(d.s.pdf, F, 1e-6);  // discrete probability of the lobe
      } else {
        // Snell: eta_i sin(theta_i) = eta_t sin(theta_t), in the plane of wo.
        double sin_o = std::sqrt(1.0 - double(c) * c), sin_t = std::sqrt(std::max(0.0, 1.0 - double(d.s.wi.z) * d.s.wi.z));
        EXPECT_NEAR(sin_t * et, sin_o, 1e-5);  // float directions
        EXPECT_NEAR(d.s.wi.x * wo.y - d.s.wi.y * wo.x, 0.f, 1e-6f);  // coplanar with the normal
        EXPECT_LT(d.s.wi.x * wo.x + d.s.wi.y * wo.y, 0.f);           // on the far side of the normal
        EXPECT_NEAR(d.s.weight.x, 1.0 / (et * et), 1e-6);            // radiance scaled by 1/eta_t^2
        EXPECT_NEAR(d.s.eta, et, 1e-6);
      }
    }
    EXPECT_EQ(fails, 0) << c;
    // Binomial: standard error sqrt(F (1 - F) / n); 4 SE (+1/n when F is 0 or 1).
    EXPECT_NEAR(double(refl) / n, F, 4.0 * std::sqrt(F * (1.0 - F) / n) + 1.0 / n) << "cos_o " << c;
  }
  // Normal incidence: ((eta - 1) / (eta + 1))^2 = 0.04.
  EXPECT_NEAR(fresnel_dielectric(1.f, 1.5f), 0.04f, 1e-6f);
}

TEST(SmoothDielectric, TotalInternalReflectionBeyondCriticalAngle) {
  // From the denser side, beyond the critical angle sin(theta_c) = 1 / 1.5
  // (cos(theta_c) = 0.745), every sample reflects; just inside it some refract.
  // Also for eta = 1/1.5 seen from above (the outside is the dense side).
  const double cos_c = std::sqrt(1.0 - 1.0 / (1.5 * 1.5));
  struct T {
    float eta, sign;
  };
  for (T t : {T{1.5f, -1.f}, T{1.f / 1.5f, 1.f}}) {
    const Material m = make_dielectric(t.eta);
    for (double c : {0.05, 0.3, 0.6, cos_c - 1e-3, cos_c + 1e-3, 0.9}) {
      const Vec3f wo = dir(float(t.sign * c), 0.3f);
      BsdfSampler draw{m, wo, TransportMode::kRadiance, PCG32(51, 0x5eed)};
      int refl = 0, n = 20000;
      for (int i = 0; i < n; ++i) {
        Draw d = draw();
        ASSERT_TRUE(d.ok);
        refl += d.s.wi.z * wo.z > 0.f;
      }
      if (c < cos_c) {
        EXPECT_EQ(refl, n) << "eta " << t.eta << " cos " << c;  // total internal reflection
        EXPECT_EQ(fresnel_dielectric(float(t.sign * c), t.eta), 1.f);
      } else {
        EXPECT_LT(refl, n) << "eta " << t.eta << " cos " << c;  // F < 1 just inside the critical angle
      }
    }
  }
}

TEST(ConductorFresnel, MatchesComplexFresnel) {
  // fresnel_conductor against the unpolarised Fresnel equations with a complex
  // index in double (std::complex); at normal incidence the closed form
  // ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2). Gold's three channels, plus indices
  // with n > k and n < 1 (e.g. n = 0.5, k = 0.05), for which 1 - sin^2 / (n + ik)^2
  // has a negative real part near grazing (the other branch of the complex
  // square root). Tolerance 1e-5: float arithmetic.
  std::vector<std::pair<double, double>> indices;
  for (int ch = 0; ch < 3; ++ch) indices.push_back({kGoldEta[ch], kGoldK[ch]});
  for (auto nk : {std::pair<double, double>{0.5, 0.05}, {0.8, 0.2}, {1.2, 0.5}, {2.5, 0.1}}) indices.push_back(nk);
  for (auto [n, k] : indices) {
    EXPECT_NEAR(fresnel_complex(1.f, float(n), float(k)), ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k),
                1e-5);
    for (double c : {1.0, 0.9, 0.7, 0.5, 0.3, 0.2, 0.05, 0.01}) {
      double ref = ref::fresnel_complex(c, n, k);
      EXPECT_NEAR(fresnel_complex(float(c), float(n), float(k)), ref, 1e-5) << "n " << n << " k " << k << " cos " << c;
    }
  }
}

// KHR_materials_clearcoat (material/metallic_roughness.h) ------------------------

namespace {
// Two evaluations of (f, pdf) that must agree on 1000 random direction pairs (seeded), to relative tolerance tol
// (0: bit for bit).
template <class A, class B>
void expect_same_on_random_pairs(uint64_t seed, A&& a, B&& b, double tol) {
  PCG32 rng(seed, 0x5eed);
  for (int k = 0; k < 1000; ++k) {
    const Vec3f wo = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
    const Vec3f wi = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
    const std::pair<RGB, float> x = a(wo, wi), y = b(wo, wi);
    ASSERT_LE(rel_diff(x.first, y.first), tol) << "pair " << k;
    ASSERT_LE(rel_diff(x.second, y.second), tol) << "pair " << k;
  }
}
}  // namespace

TEST(Clearcoat, MatchesTheLayerFormula) {
  // f = (1 - c Fc(cos_o)) (1 - c Fc(cos_i)) f_base + c Fc(|o.h|) D G2 / (4 cos_o cos_i), Fc the dielectric
  // Fresnel of IOR 1.5 (a direction below the surface passes no coat), against double-precision D, G2 and
  // Fresnel and the uncoated material's own eval. Relative tolerance 1e-3, as the microfacet references.
  const RGB base(0.9f, 0.6f, 0.3f);
  for (const Material& plain : {make_metallic_roughness(base, 0.f, 0.3f), make_metallic_roughness(base, 0.5f, 0.6f, 0.5f, 1.33f)}) {
    for (float r : {0.2f, 0.6f}) {
      const Material m = coated(plain, 0.7f, r);
      const double a = double(r) * r;
      long bad = 0, nonzero = 0, skipped = 0;
      double worst = 0.0;
      for_pairs(m, 62, 100000, [&](Vec3f wo, Vec3f wi) {
        const ref::V o = ref::v(wo), i = ref::v(wi);
        auto through = [&](ref::V w) { return w.z > 0.0 ? 1.0 - 0.7 * fresnel_ref(w.z, 1.5) : 1.0; };
        double coat = 0.0;
        if (o.z > 0.0 && i.z > 0.0) {
          const ref::V h = ref::normalize({o.x + i.x, o.y + i.y, o.z + i.z});
          if (ref::near_horizontal(h)) {
            ++skipped;
            return;
          }
          coat = 0.7 * fresnel_ref(ref::dot(o, h), 1.5) * ref::D(h, a, a) * ref::G2(o, i, a, a) / (4.0 * o.z * i.z);
        }
        const RGB fb = bsdf_eval(plain, wo, wi), f = bsdf_eval(m, wo, wi);
        for (int ch = 0; ch < 3; ++ch) {
          const double want = through(o) * through(i) * fb[ch] + coat;
          const double e = rel_diff(f[ch], want);
          nonzero += want > 0.0;
          worst = std::max(worst, e);
          bad += e > 1e-3;
        }
      });
      EXPECT_GT(nonzero, 10000);
      EXPECT_LE(skipped, 100);  // near-horizontal half vectors are rare (~1e-4 of pairs)
      EXPECT_EQ(bad, 0) << "coat roughness " << r << ": worst relative error " << worst;
    }
  }
}

TEST(Clearcoat, SmoothCoatMirrorsItsFresnelShare) {
  // A smooth coat is a mirror of mass c Fc(cos_o): the mean of the delta samples' weights in the mirror
  // direction is that, within 4 standard errors (a rough base has no other delta lobe). A coat of weight 0 is
  // the plain material, value for value.
  const Material plain = make_metallic_roughness(RGB(0.8f, 0.5f, 0.2f), 0.2f, 0.5f);
  const Material m = coated(plain, 0.6f, 0.f);
  for (float c : {0.9f, 0.5f, 0.1f}) {
    const Vec3f wo = dir(c, 0.3f);
    BsdfSampler draw{m, wo, TransportMode::kRadiance, PCG32(77, 0x5eed)};
    Mean3 mirror;
    long other_delta = 0;
    for (int i = 0; i < 200000; ++i) {
      Draw d = draw();
      const bool hit = d.ok && d.s.delta;
      if (hit && std::fabs(d.s.wi.x + wo.x) + std::fabs(d.s.wi.y + wo.y) + std::fabs(d.s.wi.z - wo.z) > 1e-6f) ++other_delta;
      mirror.add(hit ? d.s.weight : RGB(0.f));
    }
    const double want = 0.6 * fresnel_ref(c, 1.5);
    EXPECT_EQ(other_delta, 0);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(mirror.mean(ch), want, 4.0 * mirror.se(ch) + 1e-6) << "cos " << c;  // 4 SE
  }
  EXPECT_TRUE(material_is_delta(coated(make_metallic_roughness(RGB(1.f), 1.f, 0.f), 1.f, 0.f)));
  EXPECT_FALSE(material_is_delta(coated(make_metallic_roughness(RGB(1.f), 1.f, 0.f), 1.f, 0.3f)));
  Material sheen_mirror = make_metallic_roughness(RGB(1.f), 1.f, 0.f);
  sheen_mirror.sheen_color = RGB(0.5f);  // a sheen is a continuous lobe over the mirror
  EXPECT_FALSE(material_is_delta(sheen_mirror));
  const Material zero = coated(plain, 0.f, 0.3f);
  auto as = [](const Material& mat) {
    return [&mat](Vec3f wo, Vec3f wi) { return std::make_pair(bsdf_eval(mat, wo, wi), bsdf_pdf(mat, wo, wi)); };
  };
  expect_same_on_random_pairs(9, as(zero), as(plain), 0.0);
}

TEST(Clearcoat, TiltedNormalIsTheLayerAboutItAndImportanceIsItsAdjoint) {
  // A coat normal n_c tilted from the shading normal: in radiance mode
  //   f = (1 - c Fc(o.n_c)) (1 - c Fc(i.n_c)) f_base + c Fc(o.h) D(h.n_c) G2 / (4 (o.n_c) i.z),
  // each side factor 1 where the direction is below the surface or the coat, the lobe where both are above
  // both, D and G2 about n_c; against double precision (relative 1e-3, as the microfacet references). In
  // importance mode f(wo, wi) is radiance's f(wi, wo) (relative 1e-4: the same values, summed in another
  // order), and radiance is asymmetric (where the tilt matters, by more than 10 %).
  const Material plain = make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.3f, 0.5f);
  const double c = 0.8, r = 0.35, a = r * r;
  const Material m = coat_tilted(coated(plain, float(c), float(r)), Vec3f(0.4f, 0.3f, 0.85f));
  const ref::V n = ref::normalize({0.4, 0.3, 0.85});
  // An orthonormal frame about n, in double: D and G2 are isotropic, so any tangent will do.
  const ref::V t0 = ref::normalize({n.z, 0.0, -n.x});
  const ref::V t1 = {n.y * t0.z - n.z * t0.y, n.z * t0.x - n.x * t0.z, n.x * t0.y - n.y * t0.x};
  auto local = [&](ref::V w) { return ref::V{ref::dot(w, t0), ref::dot(w, t1), ref::dot(w, n)}; };
  long bad = 0, bad_adj = 0, nonzero = 0, lobe = 0, asym = 0, skipped = 0;
  double worst = 0.0, worst_adj = 0.0;
  for_pairs(m, 63, 100000, [&](Vec3f wo, Vec3f wi) {
    const ref::V o = ref::v(wo), i = ref::v(wi), oc = local(o), ic = local(i);
    auto through = [&](ref::V w, ref::V wc) { return w.z > 0.0 && wc.z > 0.0 ? 1.0 - c * fresnel_ref(wc.z, 1.5) : 1.0; };
    double coat = 0.0;
    if (o.z > 0.0 && i.z > 0.0 && oc.z > 0.0 && ic.z > 0.0) {
      const ref::V h = ref::normalize({oc.x + ic.x, oc.y + ic.y, oc.z + ic.z});
      if (ref::near_horizontal(h)) {
        ++skipped;
        return;
      }
      coat = c * fresnel_ref(ref::dot(oc, h), 1.5) * ref::D(h, a, a) * ref::G2(oc, ic, a, a) / (4.0 * oc.z * i.z);
      lobe += coat > 0.0;
    }
    const RGB fb = bsdf_eval(plain, wo, wi), f = bsdf_eval(m, wo, wi, TransportMode::kRadiance);
    const RGB fi = bsdf_eval(m, wo, wi, TransportMode::kImportance), fr = bsdf_eval(m, wi, wo, TransportMode::kRadiance);
    for (int ch = 0; ch < 3; ++ch) {
      const double want = through(o, oc) * through(i, ic) * fb[ch] + coat;
      const double e = rel_diff(f[ch], want);
      nonzero += want > 0.0;
      worst = std::max(worst, e);
      bad += e > 1e-3;
    }
    const double ea = rel_diff(fi, fr);
    worst_adj = std::max(worst_adj, ea);
    bad_adj += ea > 1e-4;
    asym += rel_diff(f, fr) > 0.1;
  });
  EXPECT_GT(nonzero, 10000);
  EXPECT_GT(lobe, 10000);  // the coat's lobe was exercised
  EXPECT_GT(asym, 1000);   // the tilt makes it asymmetric
  EXPECT_LE(skipped, 100);  // near-horizontal half vectors are rare (~1e-4 of pairs)
  EXPECT_EQ(bad, 0) << "worst relative error " << worst;
  EXPECT_EQ(bad_adj, 0) << "importance against the adjoint: worst relative difference " << worst_adj;
  // The tilted code (mr_layered_*_t<true>) with the normal straight up is the untilted code, in both modes
  // (relative 1e-6: the coat's frame is then the identity, so a few ulps at most).
  const Material flat = coated(plain, float(c), float(r));
  for (TransportMode mode : {TransportMode::kRadiance, TransportMode::kImportance}) {
    auto with = [&](auto tilted) {
      return [&, tilted](Vec3f wo, Vec3f wi) {
        constexpr bool kT = decltype(tilted)::value;
        return std::make_pair(mr_layered_eval_t<kT>(flat, wo, wi, mode), mr_layered_pdf_t<kT>(flat, wo, wi));
      };
    };
    expect_same_on_random_pairs(10, with(std::true_type{}), with(std::false_type{}), 1e-6);
    // And so is its sampling, rough and smooth coats alike: the same direction, weight and density.
    for (const Material& mat : {flat, coated(plain, float(c), 0.f)}) {
      PCG32 rng(11, 0x5eed);
      for (int k = 0; k < 1000; ++k) {
        const Vec3f wo = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
        const float uc = rng.next_float();
        const Vec2f u(rng.next_float(), rng.next_float());
        BSDFSample st, su;
        const bool ok_t = mr_layered_sample_t<true>(mat, wo, uc, u, mode, st);
        ASSERT_EQ(ok_t, mr_layered_sample_t<false>(mat, wo, uc, u, mode, su)) << "sample " << k;
        if (!ok_t) continue;
        ASSERT_EQ(st.delta, su.delta);
        ASSERT_LE(length(st.wi - su.wi), 1e-6f) << "sample " << k;
        ASSERT_LE(rel_diff(st.weight, su.weight), 1e-6) << "sample " << k;
        ASSERT_LE(rel_diff(st.pdf, su.pdf), 1e-6) << "sample " << k;
      }
    }
  }
}

TEST(Clearcoat, TiltedSmoothCoatMirrorsAboutItsNormal) {
  // A smooth coat with normal n_c reflects wo about n_c with mass c Fc(wo.n_c) (radiance; the adjoint's carries
  // wi.z / wo.z): the mean delta weight, to 4 standard errors.
  const Material plain = make_metallic_roughness(RGB(0.8f, 0.5f, 0.2f), 0.2f, 0.5f);
  const Vec3f nc = normalize(Vec3f(-0.2f, 0.3f, 0.9f));
  const Material m = coat_tilted(coated(plain, 0.6f, 0.f), nc);
  for (float cz : {0.9f, 0.5f, 0.3f}) {
    const Vec3f wo = dir(cz, 1.8f);
    const Vec3f want_wi = reflect(wo, nc);
    ASSERT_GT(dot(wo, nc), 0.f);
    ASSERT_GT(want_wi.z, 0.f);
    for (TransportMode mode : {TransportMode::kRadiance, TransportMode::kImportance}) {
      BsdfSampler draw{m, wo, mode, PCG32(78, 0x5eed)};
      Mean3 mirror;
      long other_delta = 0;
      for (int i = 0; i < 200000; ++i) {
        Draw d = draw();
        const bool hit = d.ok && d.s.delta;
        if (hit && length(d.s.wi - want_wi) > 1e-5f) ++other_delta;
        mirror.add(hit ? d.s.weight : RGB(0.f));
      }
      const double mass = 0.6 * fresnel_ref(dot(wo, nc), 1.5);
      const double want = mode == TransportMode::kRadiance ? mass : mass * want_wi.z / wo.z;
      EXPECT_EQ(other_delta, 0);
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(mirror.mean(ch), want, 4.0 * mirror.se(ch) + 1e-6) << "cos " << cz << " mode " << int(mode);  // 4 SE
    }
  }
}

// KHR_materials_specular (material/metallic_roughness.h, mr_dielectric_fresnel) -------------

TEST(KhrSpecular, WeightZeroLeavesLambertAndTheColourScalesTheNormalReflectance) {
  // Weight 0: no specular layer, the base alone, f = base / pi everywhere above (to float rounding, 1e-6
  // relative), so the albedo is the base colour. A smooth dielectric's mirror mass is w (F0s + (1 - F0s)
  // (F - F0) / (1 - F0)), F0s = min(s F0, 1): at normal incidence w min(s F0, 1), at grazing incidence
  // towards w; checked against double-precision Fresnel through the mean delta weight (4 standard errors).
  const RGB base(0.8f, 0.5f, 0.2f);
  const Material none = specular(make_metallic_roughness(base, 0.f, 0.4f), 0.f, RGB(1.f));
  PCG32 rng(11, 0x5eed);
  for (int k = 0; k < 10000; ++k) {
    const Vec3f wo = square_to_cosine_hemisphere(Vec2f(rng.next_float(), rng.next_float()));
    const Vec3f wi = square_to_cosine_hemisphere(Vec2f(rng.next_float(), rng.next_float()));
    const RGB f = bsdf_eval(none, wo, wi);
    for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(f[ch], base[ch] * kInvPi, 1e-6 * base[ch]) << wo.z << " " << wi.z;
  }
  const RGB tint(3.f, 1.f, 0.25f);
  const Material m = specular(make_metallic_roughness(base, 0.f, 0.f), 0.7f, tint);
  const double F0 = fresnel_ref(1.0, 1.5);
  for (float c : {1.f, 0.5f, 0.05f}) {
    BsdfSampler draw{m, dir(c, 0.2f), TransportMode::kRadiance, PCG32(12, 0x5eed)};
    Mean3 mirror;
    for (int i = 0; i < 200000; ++i) {
      Draw d = draw();
      mirror.add(d.ok && d.s.delta ? d.s.weight : RGB(0.f));
    }
    const double t = (fresnel_ref(c, 1.5) - F0) / (1.0 - F0);
    for (int ch = 0; ch < 3; ++ch) {
      const double f0s = std::min(double(tint[ch]) * F0, 1.0), want = 0.7 * (f0s + (1.0 - f0s) * t);
      EXPECT_NEAR(mirror.mean(ch), want, 4.0 * mirror.se(ch) + 1e-6) << "cos " << c << " channel " << ch;  // 4 SE
    }
  }
}

TEST(KhrSpecular, AboveF0QuarterTheLayerRisesAsSchlick) {
  // At the IOR of 1000 that gltf-transform's metalRough writes (F0 0.996, so the colour alone sets the layer's
  // F0), the exact Fresnel's normalized rise is negative at every cosine below 1 (-0.25 at 0.5); the layer
  // takes Schlick's (1 - c)^5 there, from F0 = 0.25 (eta 3) up. The mirror mass of a smooth plate (weight 1,
  // colour 0.04 / F0 and 0.5 / F0): F0s + (1 - F0s) (1 - c)^5, checked as above (4 standard errors); at eta 3
  // still the exact rise.
  const RGB base(0.f);
  for (float eta : {1000.f, 3.f}) {
    Material m = make_metallic_roughness(base, 0.f, 0.f);
    m.eta = eta;
    const double F0 = fresnel_ref(1.0, eta);
    m = specular(m, 1.f, RGB(float(0.04 / F0), float(0.5 / F0), 1.f));
    for (float c : {1.f, 0.5f, 0.2f, 0.05f}) {
      BsdfSampler draw{m, dir(c, 0.7f), TransportMode::kRadiance, PCG32(13, 0x5eed)};
      Mean3 mirror;
      for (int i = 0; i < 20000; ++i) {
        Draw d = draw();
        mirror.add(d.ok && d.s.delta ? d.s.weight : RGB(0.f));
      }
      const double t = eta > 3.f ? std::pow(1.0 - c, 5.0) : (fresnel_ref(c, eta) - F0) / (1.0 - F0);
      for (int ch = 0; ch < 3; ++ch) {
        const double f0s = std::min(double(m.specular[ch]) * F0, 1.0), want = f0s + (1.0 - f0s) * t;
        EXPECT_NEAR(mirror.mean(ch), want, 4.0 * mirror.se(ch) + 1e-5) << "eta " << eta << " cos " << c << " channel " << ch;
      }
    }
  }
}

// KHR_materials_sheen (material/metallic_roughness.h) -------------------------------

namespace {
// The white sheen lobe in double, as KHR_materials_sheen defines it: the Charlie distribution and the
// visibility of Estevez & Kulla 2017 (their Lambda fit, coefficients for alpha 0 and 1 blended by (1 - alpha)^2).
double charlie_lambda_ref(double x, double a) {
  auto l = [a](double y) {
    const double t = (1.0 - a) * (1.0 - a);
    const double A = 21.5473 + (25.3245 - 21.5473) * t, B = 3.82987 + (3.32435 - 3.82987) * t,
                 C = 0.19823 + (0.16801 - 0.19823) * t, D = -1.97760 + (-1.27393 + 1.97760) * t,
                 E = -4.32054 + (-4.85967 + 4.32054) * t;
    return A / (1.0 + B * std::pow(y, C)) + D * y + E;
  };
  return x < 0.5 ? std::exp(l(x)) : std::exp(2.0 * l(0.5) - l(1.0 - x));
}
double sheen_ref(double alpha, ref::V o, ref::V i) {
  if (o.z <= 0.0 || i.z <= 0.0) return 0.0;
  const ref::V h = ref::normalize({o.x + i.x, o.y + i.y, o.z + i.z});
  const double sin2 = std::max(0.0, 1.0 - h.z * h.z);
  const double d = (2.0 + 1.0 / alpha) * std::pow(sin2, 0.5 / alpha) / (2.0 * ref::kPiD);
  return d / ((1.0 + charlie_lambda_ref(o.z, alpha) + charlie_lambda_ref(i.z, alpha)) * 4.0 * o.z * i.z);
}
}  // namespace

TEST(Sheen, AlbedoTableIsTheLobesIntegral) {
  // The table (prepare_sheen) at its own cosines against an adaptive quadrature over the sphere of the
  // double-precision lobe: within 4 x the quadrature's error estimate + 1e-3 relative + 2e-4 (the table's
  // 4/65535 steps and its own midpoint rule). alpha = roughness^2, at least 1e-3; the smoothest sheen's albedo
  // exceeds 1 at grazing incidence (which mr_sheen_eval divides out).
  for (float r : {0.1f, 0.4f, 1.f}) {
    const Material m = sheened(make_metallic_roughness(RGB(0.5f), 0.f, 0.5f), RGB(1.f), r);
    const double alpha = std::max(double(r) * r, 1e-3);
    for (int k : {1, 8, 16, 31}) {
      const double mu = double(k) / (kMaterialTable - 1);
      const ref::V o{std::sqrt(1.0 - mu * mu), 0.0, mu};
      chi2::QuadOptions q;
      chi2::Integration in = chi2::integrate(
          chi2::sphere_grid(16),
          [&](double phi, double z) { return z > 0.0 ? sheen_ref(alpha, o, ref::v(chi2::sphere_dir(phi, z))) * z : 0.0; }, q);
      EXPECT_NEAR(kSheenTableScale * material_table(m, float(mu)), in.total, 4.0 * in.error + 1e-3 * in.total + 2e-4)
          << "roughness " << r << " mu " << mu;
      EXPECT_GT(in.total, 0.0);
    }
  }
}

TEST(Sheen, RoughnessTextureGivesTheTexelsAlbedoTable) {
  // A sheen roughness texture: surface_material's table is the texel's roughness's (interpolated between the
  // scene's kSheenRows tables, in log alpha), not the factor's. Measured here, halfway between two rows: the
  // interpolation is within 0.007 in E at cosines 1/31 to 1 (near roughness 1), and at cosine 0 within 2.5% of E
  // (E near 4 there for alpha near 0.002, where it changes fastest); the factor's (roughness 1) table is more
  // than 0.05 away below roughness 0.7. Bounds: 0.01 and 3% halfway, one step of the 16-bit table at a row.
  SceneDesc d;
  d.camera.width = d.camera.height = 4;
  Material m = sheened(make_metallic_roughness(RGB(0.5f), 0.f, 0.5f), RGB(1.f), 1.f);
  m.tex_sheen_roughness = 0;
  d.materials.push_back(m);
  TextureDesc t;
  t.name = "grey";
  t.width = t.height = 1;
  d.textures.push_back(t);
  MeshDesc mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}};
  mesh.uvs = {{0, 0}, {1, 0}, {1, 1}};
  mesh.indices = {0, 1, 2};
  d.meshes.push_back(mesh);
  ShapeDesc shape;
  shape.mesh = 0;
  d.shapes.push_back(shape);
  d.lights.push_back(Light{});
  for (int k = 0; k < 2 * (kSheenRows - 1) + 1; ++k) {
    // The rows' roughnesses (k even) and those halfway between them in log alpha.
    const float r = std::sqrt(std::exp(std::log(kMinSheenAlpha) * (1.f - float(k) / float(2 * (kSheenRows - 1)))));
    d.textures[0].rgba = {r, r, r, 1.f};
    std::shared_ptr<Scene> sc = Scene::build(d);
    ASSERT_NE(sc->view().sheen_table, nullptr);
    SurfaceHit sh;
    sh.material = 0;
    sh.uv = Vec2f(0.5f, 0.5f);
    const Material got = surface_material(sc->view(), sh);
    Material want = m;
    want.sheen_roughness = r;
    prepare_sheen(want);
    double err = 0.0, off = 0.0;
    const double grazing = std::fabs(double(got.table[0]) - double(want.table[0])) / std::max(1.0, double(want.table[0]));
    for (int i = 0; i < kMaterialTable; ++i) {
      if (i > 0)
        err = std::max(err, std::fabs(double(got.table[i]) - double(want.table[i])) * kSheenTableScale / 65535.0);
      off = std::max(off, std::fabs(double(sc->view().materials[0].table[i]) - double(want.table[i])) *
                              kSheenTableScale / 65535.0);
    }
    EXPECT_LE(err, k % 2 == 0 ? 4.0 / 65535.0 : 0.01) << "roughness " << r;
    EXPECT_LE(grazing, k % 2 == 0 ? 4.0 / 65535.0 : 0.03) << "roughness " << r;
    if (r < 0.7f) EXPECT_GT(off, 0.05) << "roughness " << r;  // the factor's (roughness 1) table is far off
  }
  // Without a sheen roughness texture there are no tables.
  d.materials[0].tex_sheen_roughness = -1;
  EXPECT_EQ(Scene::build(d)->view().sheen_table, nullptr);
}

TEST(Sheen, MatchesTheLayerFormula) {
  // f = S f_under + col D V / (max(1, E(cos_o)) max(1, E(cos_i))), S = min(1 - max(col) min(E(cos_o), 1),
  // 1 - max(col) min(E(cos_i), 1)), E the table, against the double-precision lobe and the unsheened
  // material's eval; relative 1e-3 (as the microfacet references, plus the single-precision pow of a 1/alpha
  // exponent). Roughness 0.1 has E > 1 near grazing.
  const RGB col(0.9f, 0.7f, 0.5f);
  for (float r : {0.1f, 0.3f, 0.8f}) {
    const Material plain = make_metallic_roughness(RGB(0.9f, 0.6f, 0.3f), 0.2f, 0.5f, 0.3f);
    const Material m = sheened(plain, col, r);
    const double alpha = double(r) * r;
    long bad = 0, nonzero = 0;
    double worst = 0.0;
    for_pairs(m, 63, 100000, [&](Vec3f wo, Vec3f wi) {
      auto E = [&](Vec3f w) { return w.z > 0.f ? double(kSheenTableScale) * material_table(m, w.z) : 0.0; };
      const double S = std::min(1.0 - 0.9 * std::min(E(wo), 1.0), 1.0 - 0.9 * std::min(E(wi), 1.0));
      const double lobe = sheen_ref(alpha, ref::v(wo), ref::v(wi)) / (std::max(1.0, E(wo)) * std::max(1.0, E(wi)));
      const RGB fu = bsdf_eval(plain, wo, wi), f = bsdf_eval(m, wo, wi);
      for (int ch = 0; ch < 3; ++ch) {
        const double want = S * fu[ch] + col[ch] * lobe;
        const double e = rel_diff(f[ch], want);
        nonzero += want > 0.0;
        worst = std::max(worst, e);
        bad += e > 1e-3;
      }
    });
    EXPECT_GT(nonzero, 10000);
    EXPECT_EQ(bad, 0) << "sheen roughness " << r << ": worst relative error " << worst;
  }
}

TEST(DiffuseTransmission, MatchesTheLayerFormula) {
  // KHR_materials_diffuse_transmission over a rough mixture (metal 0.2, roughness 0.4): through the surface
  // f = (1 - metallic) dt t (1 - F(|cos_o|)) (1 - F(|cos_i|)) / pi, F the exact Fresnel of eta in double
  // precision, from either side; on one side (1 - dt) of the plain material's diffuse base plus its unchanged
  // specular lobes, i.e. f(dt) = f(0) - dt (1 - metallic) base (1 - F(cos_o)) (1 - F(cos_i)) / pi; seen from
  // behind, the same as from the front with both directions mirrored. Relative 1e-4 (single-precision Fresnel),
  // absolute 1e-6 where the difference cancels.
  const RGB base(0.9f, 0.6f, 0.3f), t(0.3f, 0.8f, 0.5f);
  const float metal = 0.2f, dt = 0.6f;
  const Material plain = make_metallic_roughness(base, metal, 0.4f);
  const Material m = translucent(plain, dt, t);
  long bad = 0, through = 0, same = 0;
  double worst = 0.0;
  for_pairs(m, 71, 100000, [&](Vec3f wo, Vec3f wi) {
    const double k = (1.0 - metal) * (1.0 - fresnel_ref(std::fabs(wo.z), 1.5)) * (1.0 - fresnel_ref(std::fabs(wi.z), 1.5)) / ref::kPiD;
    const Vec3f mo(wo.x, wo.y, std::fabs(wo.z)), mi(wi.x, wi.y, wo.z < 0.f ? -wi.z : wi.z);  // mirrored to the front
    const RGB f = bsdf_eval(m, wo, wi), fp = bsdf_eval(plain, mo, mi);
    for (int ch = 0; ch < 3; ++ch) {
      double want;
      if (wo.z * wi.z < 0.f) {
        want = dt * t[ch] * k;
        ++through;
      } else {
        want = fp[ch] - dt * base[ch] * k;
        ++same;
      }
      const double e = std::fabs(f[ch] - want) / std::max(std::fabs(want), 1e-2);
      worst = std::max(worst, e);
      bad += e > 1e-4;
    }
  });
  EXPECT_GT(through, 30000);
  EXPECT_GT(same, 30000);
  EXPECT_EQ(bad, 0) << "worst relative error " << worst;
}

TEST(WhiteFurnace, DiffuseTransmissionAtIorOneIsItsTwoColours) {
  // IOR 1 has no specular layer (F = 0): the albedo is (1 - dt) base + dt t from either side, the transmitted
  // part dt t; 4 standard errors.
  const RGB base(0.9f, 0.6f, 0.3f), t(0.3f, 0.8f, 0.5f);
  for (float dt : {0.25f, 1.f}) {
    const Material m = translucent(make_metallic_roughness(base, 0.f, 0.5f, 0.f, 1.f), dt, t);
    for (float c : kAngles) {
      const Vec3f wo = dir(c, 0.6f);
      BsdfSampler draw{m, wo, TransportMode::kRadiance, PCG32(77, 0x5eed)};
      Mean3 all, through;
      for (int i = 0; i < 100000; ++i) {
        Draw d = draw();
        const RGB w = d.ok ? d.s.weight : RGB(0.f);
        all.add(w);
        through.add(d.ok && d.s.wi.z * wo.z < 0.f ? w : RGB(0.f));
      }
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(all.mean(ch), (1.f - dt) * base[ch] + dt * t[ch], 4.0 * all.se(ch) + kFloatSlack) << dt << " " << c;
        EXPECT_NEAR(through.mean(ch), dt * t[ch], 4.0 * through.se(ch) + kFloatSlack) << dt << " " << c;
      }
    }
  }
}

TEST(DiffuseTransmission, MakesTheMaterialTransmissiveAndTheGlassKeepsItsSides) {
  // A translucent surface transmits (pairs of sides refuse it; bsdf_side leaves it to the material), and its
  // glass share (KHR_materials_transmission) still refracts from inside: seen from below, a rough glass mixture
  // with diffuse transmission evaluates the glass unmirrored plus the opaque parts mirrored.
  const RGB base(0.9f, 0.6f, 0.3f), t(0.3f, 0.8f, 0.5f);
  EXPECT_FALSE(material_is_transmissive(make_metallic_roughness(base, 0.f, 0.4f)));
  EXPECT_TRUE(material_is_transmissive(translucent(make_metallic_roughness(base, 0.f, 0.4f), 0.5f, t)));
  const Material glass_only = make_metallic_roughness(base, 0.f, 0.4f, 0.5f);
  const Material both = translucent(glass_only, 0.5f, t);
  const Material opaque = translucent(make_metallic_roughness(base, 0.f, 0.4f, 0.f), 0.5f, t);
  PCG32 rng(5, 0x5eed);
  long bad = 0;
  for (int i = 0; i < 20000; ++i) {
    Vec3f wo = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
    Vec3f wi = square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float()));
    if (wo.z > 0.f) wo.z = -wo.z;
    const RGB f = bsdf_eval(both, wo, wi), g = bsdf_eval(glass_only, wo, wi);
    const RGB o = bsdf_eval(opaque, wo, wi) * 0.5f;  // the opaque share is 1 - transmission = 0.5
    for (int ch = 0; ch < 3; ++ch) bad += std::fabs(f[ch] - (g[ch] + o[ch])) > 1e-4 * std::max(1.0, double(f[ch]));
  }
  EXPECT_EQ(bad, 0);
}
