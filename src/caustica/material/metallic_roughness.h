// glTF 2.0 metallic-roughness material (glTF 2.0 specification, Appendix B
// "BRDF Implementation"; KHR_materials_transmission and KHR_materials_ior) as
// a blend of three BSDFs with weights that sum to one:
//   metal        w_m = metallic:
//                GGX reflection (Walter et al. 2007 Eq. 20) with Schlick's
//                Fresnel, F0 = base colour (Schlick 1994, Eq. 24);
//   glass        w_t = (1 - metallic) * transmission:
//                the rough dielectric of rough_dielectric.h (Walter et al. 2007
//                Eqs. 20-21) with relative IOR `eta`, transmission tinted by
//                the base colour (KHR_materials_transmission);
//   dielectric   w_d = (1 - metallic) * (1 - transmission):
//                GGX reflection with the exact dielectric Fresnel F(eta) over
//                a diffuse base. glTF's base (Appendix B: fresnel_mix leaves
//                1 - F of the light to base/pi) with the Fresnel factor on
//                both sides, base/pi (1-F(cos_o))(1-F(cos_i)): reciprocal,
//                albedo <= 1, and within a few percent of the specification's
//                (1-F(v.h)) base/pi where that one is bounded. With
//                kPlasticBase, the plastic base of plastic.h instead:
//                base/pi (1-F(cos_o))(1-F(cos_i)) / (eta^2 (1 - base Fdr_int)),
//                the light refracted into a coat and reflected inside it
//                (Mitsuba's roughplastic; ~0.6 x as bright at base 0.5, eta 1.5).
//                KHR_materials_specular scales and tints F (mr_dielectric_fresnel below)
//                and the base takes 1 - max(F) on each side.
// KHR_materials_diffuse_transmission (m.diffuse_transmission dt, m.transmission its colour t): the dielectric's
// diffuse base becomes the extension's mix of a Lambertian BRDF and BTDF, (1 - dt) base/pi on the side of wo and
// dt t/pi on the other, under the same specular layer: (1 - F(cos_o)) (1 - F(|cos_i|)) dt t/pi through the surface
// (the glTF form; with kPlasticBase too), which is symmetric, and the albedo stays <= 1. The specular lobe,
// the metal and the glass are unchanged (the extension: KHR_materials_transmission's glass takes its share
// first). Such a surface is a thin translucent sheet (leaves, paper, lamp shades; with KHR_materials_volume the
// boundary of a translucent solid): light must leave it on either side, so seen from behind (wo.z < 0) its
// metal and dielectric are those seen from the front with both directions mirrored (mr_mirror_side), whether
// or not the material is two-sided; the coat and the sheen lie on the front side only (as for the glass seen
// from inside, a direction below the surface passes neither), which keeps the whole reciprocal. Sampling
// splits the diffuse base's probability between its two sides by luminance, (1 - dt) lum(base) : dt lum(t).
// GGX alpha = roughness^2 (the glTF convention); with kBeckmann (Mitsuba's roughplastic) the Beckmann
// distribution instead (material/microfacet.h). Roughness alpha below
// kSmoothAlpha makes the specular lobes Dirac deltas (a GGX lobe that narrow
// is a mirror to float precision, and sampling it as a delta avoids the
// numerical trouble of D at tiny alpha).
// Sampling picks a component with probability equal to its weight (then, in
// the dielectric, specular with probability Fo / (Fo + (1-Fo) lum(base)));
// continuous samples are weighted by the full mixture f / pdf, delta samples
// by their own lobe.
//
// KHR_materials_clearcoat (m.clearcoat = clearcoatFactor c, m.clearcoat_alpha = clearcoatRoughness^2): a GGX
// coat of IOR 1.5 over all of the above. The extension's fresnel_coat mixes base and coat by c Fc(n.v), the coat
// being the specular BRDF D V; here the coat lobe is c Fc(|wo.h|) D G / (4 cos_o cos_i) (the exact dielectric
// Fresnel at the microfacet, as the dielectric's specular lobe above), and, as for the dielectric's base, the
// base is attenuated on both sides, (1 - c Fc(cos_o)) (1 - c Fc(cos_i)), a direction below the surface (glass
// seen from inside) passing no coat: reciprocal, and the albedo stays <= 1 (the coat reflects at most
// c Fc(cos_o) of the light, the base gets the rest). Sampling picks the coat with probability c Fc(cos_o), its
// reflectance, and the base mixture otherwise; a coat with alpha below kSmoothAlpha is a mirror (a delta lobe).
// The coat has its own normal n_c (m.coat_normal): as the extension says, the surface's normal without the
// base's normal map, or its clearcoatNormalTexture's. The coat's cosines, D and G are taken about n_c, and the
// lobe is the microfacet BRDF about n_c put in the shading frame's measure: c Fc D G / (4 |wo.n_c| |wi.z|),
// whose projected-solid-angle integral is the coat's own albedo about n_c (<= c Fc(wo.n_c), so the albedo stays
// <= 1 and the VNDF sample's weight is Fc(wo.h) G / (Fc(wo.n_c) G1(wo))). Like a shading normal (Veach 1997,
// Sec. 5.3.2) a tilted n_c makes the lobe asymmetric: importance transport (mode kImportance) evaluates the
// adjoint f(wi, wo), c Fc D G / (4 |wi.n_c| |wo.z|). The base's side factors 1 - c Fc(w.n_c) are symmetric.
// With n_c the shading normal all of this is the lobe above.
//
// KHR_materials_iridescence (m.iridescence k, m.iridescence_eta, m.iridescence_thickness): a thin film over the
// metal and the dielectric's specular layer (material/thin_film.h, Belcour & Barla 2017). As the extension
// says, each layer's Fresnel term F becomes (1 - k) F + k F_film, F_film the film's reflectance over a base of
// the dielectric's IOR, or, for the metal, per channel over a dielectric whose F0 is the base colour
// (film_ior_from_f0). The film's colour then plays the part of the specular colour: the dielectric's base
// takes 1 - max(F) on each side and its lobe is picked by max(F), as with KHR_materials_specular. The glass keeps
// its own Fresnel.
//
// KHR_materials_sheen (m.sheen_color, m.sheen_roughness; alpha = roughness^2, at least 1e-3), under the coat and
// over the rest: the extension's sheen lobe, sheen_color D V with the Charlie distribution and the visibility of
// Estevez & Kulla 2017, divided by max(1, E(cos_o)) max(1, E(cos_i)) (E the white lobe's directional albedo,
// tabulated per material for the factor's roughness: Material::table, prepare_sheen), which changes it only
// at grazing angles of smooth sheens, where the model's albedo exceeds 1; and the layers under it scaled by
// the extension's min(1 - max(col) E(cos_o), 1 - max(col) E(cos_i)), with E capped at 1. Symmetric, so
// reciprocal, and the albedo stays <= 1. Sampling picks the sheen with probability max(col) min(E(cos_o), 1)
// and then a cosine-distributed direction.
#pragma once
#include "dielectric.h"
#include "microfacet.h"
#include "plastic.h"
#include "rough_dielectric.h"
#include "thin_film.h"

namespace caustica {

constexpr float kSmoothAlpha = 1e-3f;

CHD RGB schlick_fresnel(RGB f0, float cos_i) { return f0 + (RGB(1.f) - f0) * schlick_weight(cos_i); }
CHD bool mr_iridescent(const Material& m) { return m.iridescence > 0.f; }
// F mixed with the film's reflectance over a base of IOR eta3 (KHR_materials_iridescence; top of this file). Out
// of line, as the layers below, so that materials without a film do not carry its code inlined.
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline RGB mr_film_mix(const Material& m, RGB F, float c, RGB eta3) {
  return F * (1.f - m.iridescence) + thin_film_reflectance(c, m.iridescence_eta, eta3, m.iridescence_thickness) * m.iridescence;
}
// The metal's Fresnel: Schlick's with F0 the base colour, under the film where there is one.
CHD RGB mr_metal_fresnel(const Material& m, float c) {
  const RGB F = schlick_fresnel(m.diffuse, c);
  if (!mr_iridescent(m)) return F;
  return mr_film_mix(m, F, c, RGB(film_ior_from_f0(m.diffuse.x), film_ior_from_f0(m.diffuse.y), film_ior_from_f0(m.diffuse.z)));
}

struct MRWeights {
  float metal, glass, dielectric;
};
CHD MRWeights mr_weights(const Material& m) {
  float metal = clampf(m.metallic, 0.f, 1.f);
  float tw = clampf(m.transmission_weight, 0.f, 1.f);
  return {metal, (1.f - metal) * tw, (1.f - metal) * (1.f - tw)};
}
CHD bool mr_smooth(const Material& m) { return m.alpha_x < kSmoothAlpha && m.alpha_y < kSmoothAlpha; }
// The glass lobe: m's IOR, an untinted reflection and the base colour as the transmission tint, with m's
// microfacets when rough.
CHD DielectricParams mr_glass(const Material& m) { return {m.eta, RGB(1.f), m.diffuse}; }
// KHR_materials_specular (m.specular_weight = specularFactor w, m.specular = specularColorFactor s): the
// dielectric's specular reflectance at cosine c. With F the exact Fresnel of eta and F0 = F(1), the colour
// scales the reflectance at normal incidence (capped at 1) and the weight scales the whole,
// w (F0s + (1 - F0s) (F - F0) / (1 - F0)), F0s = min(s F0, 1): F's angular shape, and F itself at w = 1,
// s = 1 (the extension's fresnel_mix does the same to Schlick's approximation). Above F0 = 0.25 (eta 3) that
// rise (F - F0) / (1 - F0) stops being monotone (from eta 3.5 it dips below zero on its way to 1, down to
// -124 at the IOR of 1000 that gltf-transform's metalRough writes so that the colour alone sets F0); there the
// layer takes Schlick's rise (1 - c)^5, the extension's own. The glass keeps its own Fresnel (the extension's
// effect on transmission is not modelled).
constexpr float kExactRiseMaxF0 = 0.25f;
// A film (KHR_materials_iridescence) mixes its reflectance into that.
CHD bool mr_plain_specular(const Material& m) {
  return m.specular_weight == 1.f && m.specular.x == 1.f && m.specular.y == 1.f && m.specular.z == 1.f &&
         !mr_iridescent(m);
}
CHD RGB mr_dielectric_fresnel(const Material& m, float c) {
  const float F = fresnel_dielectric(c, m.eta);
  if (mr_plain_specular(m)) return RGB(F);
  const float F0 = fresnel_dielectric(1.f, m.eta);
  const float t = F0 <= kExactRiseMaxF0 ? clampf((F - F0) / (1.f - F0), 0.f, 1.f) : schlick_weight(c);
  const RGB f0s(minf(F0 * m.specular.x, 1.f), minf(F0 * m.specular.y, 1.f), minf(F0 * m.specular.z, 1.f));
  const RGB Fs = (f0s + (RGB(1.f) - f0s) * t) * m.specular_weight;
  return mr_iridescent(m) ? mr_film_mix(m, Fs, c, RGB(m.eta)) : Fs;
}
// The share of the light the specular layer takes from the diffuse base at cosine c: the largest channel of
// its reflectance (the extension's max_value(fr)).
CHD float mr_dielectric_reflectance(const Material& m, float c) {
  return mr_plain_specular(m) ? fresnel_dielectric(c, m.eta) : max_component(mr_dielectric_fresnel(m, c));
}
// The diffuse base's luminance: reflection (1 - dt) base and transmission dt t (KHR_materials_diffuse_transmission).
CHD float mr_diffuse_reflected(const Material& m) { return (1.f - m.diffuse_transmission) * luminance(m.diffuse); }
CHD float mr_diffuse_transmitted(const Material& m) { return m.diffuse_transmission * luminance(m.transmission); }
CHD float mr_specular_prob(const Material& m, float Fo) {
  const float d = m.diffuse_transmission > 0.f ? mr_diffuse_reflected(m) + mr_diffuse_transmitted(m) : luminance(m.diffuse);
  float ws = Fo, wd = (1.f - Fo) * d;
  return ws + wd > 0.f ? ws / (ws + wd) : 1.f;
}
// Of the diffuse base's samples, the share reflected (the rest are transmitted), by luminance.
CHD float mr_diffuse_reflect_prob(const Material& m) {
  if (!(m.diffuse_transmission > 0.f)) return 1.f;
  const float r = mr_diffuse_reflected(m), t = mr_diffuse_transmitted(m);
  return t > 0.f ? r / (r + t) : 1.f;
}
// A translucent sheet seen from behind (mr_translucent, material.h): its opaque parts are evaluated and sampled
// as if seen from the front, both directions mirrored; the glass keeps its sides. Returns the sign applied.
CHD float mr_mirror_side(const Material& m, Vec3f& wo, Vec3f& wi) {
  if (!(wo.z < 0.f) || !mr_translucent(m)) return 1.f;
  wo.z = -wo.z;
  wi.z = -wi.z;
  return -1.f;
}

// The base mixture (metal, glass, dielectric) without the coat. Continuous parts of f (delta lobes evaluate to
// zero), without the cosine.
CHD RGB mr_base_eval(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode) {
  MRWeights w = mr_weights(m);
  RGB f(0.f);
  if (w.glass > 0.f && !mr_smooth(m))
    f += rough_dielectric_eval(mr_glass(m), material_microfacet(m), wo, wi, mode) * w.glass;
  mr_mirror_side(m, wo, wi);
  if (wo.z <= 0.f) return f;
  if (wi.z <= 0.f) {  // through the surface: the diffuse transmission
    if (w.dielectric > 0.f && m.diffuse_transmission > 0.f && wi.z < 0.f) {
      float Fo = mr_dielectric_reflectance(m, wo.z), Fi = mr_dielectric_reflectance(m, -wi.z);
      f += m.transmission * (m.diffuse_transmission * (1.f - Fo) * (1.f - Fi) * kInvPi * w.dielectric);
    }
    return f;
  }
  if (!mr_smooth(m)) {
    Vec3f wm = normalize(wo + wi);
    Microfacet g = material_microfacet(m);
    float dg = g.D(wm) * g.G(wo, wi) / (4.f * wo.z * wi.z);
    float c = absdot(wo, wm);
    if (w.metal > 0.f) f += mr_metal_fresnel(m, c) * (dg * w.metal);
    if (w.dielectric > 0.f) f += mr_dielectric_fresnel(m, c) * (dg * w.dielectric);
  }
  if (w.dielectric > 0.f) {
    float Fo = mr_dielectric_reflectance(m, wo.z), Fi = mr_dielectric_reflectance(m, wi.z);
    RGB base = (m.flags & kPlasticBase) ? plastic_diffuse_albedo(m) / (m.eta * m.eta) : m.diffuse;
    f += base * ((1.f - m.diffuse_transmission) * (1.f - Fo) * (1.f - Fi) * kInvPi * w.dielectric);
  }
  return f;
}

// Density of the continuous parts of the base's sampling mixture.
CHD float mr_base_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  MRWeights w = mr_weights(m);
  float pdf = 0.f;
  // Seen from behind only the glass is sampled (selection probability 1), unless the surface is translucent.
  float sel_glass = wo.z <= 0.f && !mr_translucent(m) ? 1.f : w.glass;
  if (w.glass > 0.f && !mr_smooth(m))
    pdf += sel_glass * rough_dielectric_pdf(mr_glass(m), material_microfacet(m), wo, wi);
  mr_mirror_side(m, wo, wi);
  if (wo.z <= 0.f || wi.z == 0.f) return pdf;
  float ps = mr_specular_prob(m, mr_dielectric_reflectance(m, wo.z));
  if (wi.z < 0.f) {  // the diffuse transmission
    if (w.dielectric > 0.f && m.diffuse_transmission > 0.f)
      pdf += w.dielectric * (1.f - ps) * (1.f - mr_diffuse_reflect_prob(m)) * cosine_hemisphere_pdf(Vec3f(wi.x, wi.y, -wi.z));
    return pdf;
  }
  if (!mr_smooth(m)) {
    Vec3f wm = normalize(wo + wi);
    Microfacet g = material_microfacet(m);
    float p_refl = g.pdf_wm(wo, wm) / (4.f * absdot(wo, wm));
    pdf += (w.metal + w.dielectric * ps) * p_refl;
  }
  if (w.dielectric > 0.f) pdf += w.dielectric * (1.f - ps) * mr_diffuse_reflect_prob(m) * cosine_hemisphere_pdf(wi);
  return pdf;
}

// Samples the base mixture: a delta lobe's sample complete (its own weight and discrete probability), a
// continuous one only its direction (s.wi, s.eta; s.delta false), weighted by the caller.
CHD bool mr_base_sample(const Material& m, Vec3f wo, float uc, Vec2f u, TransportMode mode, BSDFSample& s) {
  MRWeights w = mr_weights(m);
  bool smooth = mr_smooth(m);
  s.eta = 1.f;
  // Component choice; uc is rescaled so the chosen lobe can reuse it.
  const bool only_glass = wo.z <= 0.f && !mr_translucent(m);  // seen from behind only the glass transmits
  if (uc < w.glass || only_glass) {
    if (w.glass == 0.f) return false;
    float sel = only_glass ? 1.f : w.glass;
    float uc2 = only_glass ? uc : uc / w.glass;
    const DielectricParams g = mr_glass(m);
    if (smooth) {
      if (!dielectric_sample(g, wo, minf(uc2, 0.99999994f), mode, s)) return false;
      s.pdf *= sel;
      s.weight = s.weight * (w.glass / sel);
      return true;
    }
    if (!rough_dielectric_sample(g, material_microfacet(m), wo, minf(uc2, 0.99999994f), u, mode, s)) return false;
  } else {
    Vec3f o = wo, unused;
    const float side = mr_mirror_side(m, o, unused);  // a translucent surface seen from behind
    if (o.z <= 0.f) return false;
    uc = (uc - w.glass) / (1.f - w.glass);
    float Fo = mr_dielectric_reflectance(m, o.z);
    float ps = mr_specular_prob(m, Fo);
    float p_metal = w.metal / (w.metal + w.dielectric);
    bool metal = uc < p_metal;
    const float ud = metal ? 0.f : (uc - p_metal) / (1.f - p_metal);
    bool spec = metal || ud < ps;
    if (spec && smooth) {
      s.wi = Vec3f(-wo.x, -wo.y, wo.z);
      s.delta = true;
      if (metal) {
        s.pdf = w.metal;
        s.weight = mr_metal_fresnel(m, o.z);
      } else {
        s.pdf = w.dielectric * ps;
        s.weight = mr_plain_specular(m) ? RGB(Fo / ps) : mr_dielectric_fresnel(m, o.z) / ps;
      }
      return true;
    }
    if (spec) {
      Microfacet g = material_microfacet(m);
      s.wi = reflect(o, g.sample_wm(o, u));
      if (s.wi.z <= 0.f) return false;
    } else {
      s.wi = square_to_cosine_hemisphere(u);
      if (s.wi.z <= 0.f) return false;
      // The diffuse transmission (KHR_materials_diffuse_transmission): the same cosine lobe on the other side.
      if (m.diffuse_transmission > 0.f && (ud - ps) / (1.f - ps) >= mr_diffuse_reflect_prob(m)) s.wi.z = -s.wi.z;
    }
    s.wi.z *= side;
    s.eta = 1.f;
  }
  s.delta = false;
  return true;
}

// The sheen (KHR_materials_sheen; see the top of this file).
constexpr float kMinSheenAlpha = 1e-3f;
CHD bool mr_has_sheen(const Material& m) { return max_component(m.sheen_color) > 0.f; }
CHD float mr_sheen_alpha(const Material& m) { return maxf(m.sheen_roughness * m.sheen_roughness, kMinSheenAlpha); }
// Estevez & Kulla 2017's fit of the Charlie distribution's masking, Lambda(cos) = exp(l(cos)) below cos 0.5
// and exp(2 l(0.5) - l(1 - cos)) above, l(x) = a / (1 + b x^c) + d x + e with the paper's coefficients for
// alpha 0 and 1 blended by (1 - alpha)^2.
CHD float charlie_l(float x, float alpha) {
  const float t = (1.f - alpha) * (1.f - alpha);
  const float a = 21.5473f + (25.3245f - 21.5473f) * t, b = 3.82987f + (3.32435f - 3.82987f) * t,
              c = 0.19823f + (0.16801f - 0.19823f) * t, d = -1.97760f + (-1.27393f + 1.97760f) * t,
              e = -4.32054f + (-4.85967f + 4.32054f) * t;
  return a / (1.f + b * std::pow(x, c)) + d * x + e;
}
CHD float charlie_lambda(float cos_theta, float alpha) {
  return cos_theta < 0.5f ? std::exp(charlie_l(cos_theta, alpha))
                          : std::exp(2.f * charlie_l(0.5f, alpha) - charlie_l(1.f - cos_theta, alpha));
}
// The sheen lobe of a white sheen colour as the extension defines it: the Charlie distribution
// D(h) = (2 + 1/a) sin(theta_h)^(1/a) / (2 pi) (Estevez & Kulla 2017, Eq. 2) and their visibility
// 1 / ((1 + Lambda(cos_o) + Lambda(cos_i)) 4 cos_o cos_i); symmetric in wo and wi.
CHD float mr_sheen_lobe(float alpha, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
  const Vec3f wm = normalize(wo + wi);
  const float sin2 = maxf(0.f, 1.f - wm.z * wm.z);
  const float d = (2.f + 1.f / alpha) * std::pow(sin2, 0.5f / alpha) * (0.5f * kInvPi);
  return d / ((1.f + charlie_lambda(wo.z, alpha) + charlie_lambda(wi.z, alpha)) * 4.f * wo.z * wi.z);
}
// That lobe's directional albedo E(mu), tabulated (Material::table holds E / kSheenTableScale: at grazing
// incidence and small alpha E exceeds 1, up to ~1.6 at alpha 1e-3).
constexpr float kSheenTableScale = 4.f;
CHD float mr_sheen_E(const Material& m, float mu) { return kSheenTableScale * material_table(m, mu); }
// A sheen roughness texture's tables: kSheenRows tables of E like Material::table's, row k for the alpha
// kMinSheenAlpha^(1 - k / (kSheenRows - 1)), from kMinSheenAlpha to 1 in equal ratios (E changes fastest at small
// alpha) (SceneView::sheen_table, which Scene::build makes where a material has such a texture);
// mr_sheen_table_at fills m.table for m's alpha at the hit, linearly in log alpha between the two rows around it.
constexpr int kSheenRows = 32;
CHD float mr_sheen_row_alpha(int k) {
  return std::exp(std::log(kMinSheenAlpha) * (1.f - float(k) / float(kSheenRows - 1)));
}
CHD void mr_sheen_table_at(const uint16_t* rows, Material& m) {
  const float x = clampf(1.f - std::log(minf(mr_sheen_alpha(m), 1.f)) / std::log(kMinSheenAlpha), 0.f, 1.f) *
                  float(kSheenRows - 1);
  const int k = x >= float(kSheenRows - 2) ? kSheenRows - 2 : int(x);
  const float f = x - float(k);
  const uint16_t* a = rows + k * kMaterialTable;
  const uint16_t* b = a + kMaterialTable;
  for (int i = 0; i < kMaterialTable; ++i)
    m.table[i] = uint16_t(float(a[i]) * (1.f - f) + float(b[i]) * f + 0.5f);
}
// The sheen caustica renders: the lobe over max(1, E(cos_o)) max(1, E(cos_i)), which leaves it alone where E <= 1
// and keeps its albedo at most 1 where the model would create light (symmetric still).
CHD float mr_sheen_eval(const Material& m, Vec3f wo, Vec3f wi) {
  if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
  return mr_sheen_lobe(mr_sheen_alpha(m), wo, wi) / (maxf(1.f, mr_sheen_E(m, wo.z)) * maxf(1.f, mr_sheen_E(m, wi.z)));
}
// A bound on that sheen's directional albedo towards w for its colour's largest channel, max(col) min(E, 1):
// the share of the light it takes from the layers under it (0 below the surface).
CHD float mr_sheen_albedo(const Material& m, Vec3f w) {
  return w.z > 0.f ? max_component(m.sheen_color) * minf(mr_sheen_E(m, w.z), 1.f) : 0.f;
}
// The extension's albedo scaling of the layers under the sheen, min(1 - E(cos_o), 1 - E(cos_i)).
CHD float mr_sheen_scaling(const Material& m, Vec3f wo, Vec3f wi) {
  return minf(1.f - mr_sheen_albedo(m, wo), 1.f - mr_sheen_albedo(m, wi));
}

// The clear coat (KHR_materials_clearcoat; see the top of this file).
constexpr float kCoatEta = 1.5f;
CHD bool mr_coat_smooth(const Material& m) { return m.clearcoat_alpha < kSmoothAlpha; }
CHD Microfacet mr_coat_microfacet(const Material& m) { return Microfacet{m.clearcoat_alpha, m.clearcoat_alpha, false}; }
// Whether the coat's normal is not the shading normal. Most coats' is, and the layered functions below are
// templates on it (kTilted), chosen once per call, so that those coats never build the coat's frame. Measured
// on bench/scenes/mr_coated.json (every material coated, none tilted): 2-3 % more instructions than before
// coats had normals of their own, most of it GCC inlining less of the microfacet code into the larger
// functions (callgrind); none on scenes without coats (bench/RESULTS.md).
// On the GPU only the general (tilted) code is instantiated: it is exact for an untilted coat too (the frame of
// (0, 0, 1) is the identity), and with both copies of the layered code the CUDA backend (then one file,
// cuda_render.cu) took 32 min of CPU to compile for sm_80 against 19.5 without the templates (nvcc 13.0 from PyPI, one run each, on this 2-core machine).
#if defined(__CUDA_ARCH__)
CHD bool mr_coat_tilted(const Material&) { return true; }
#else
CHD bool mr_coat_tilted(const Material& m) { return m.coat_normal.z < 1.f; }
#endif
// The coat's cosine of w.
template <bool kTilted>
CHD float mr_coat_cos(const Material& m, Vec3f w) { return kTilted ? dot(w, m.coat_normal) : w.z; }
// wo and wi put in a tilted coat's frame (any tangent: the coat is isotropic).
CHD void mr_coat_to_local(const Material& m, Vec3f& wo, Vec3f& wi) {
  const Frame f(m.coat_normal);
  wo = f.to_local(wo);
  wi = f.to_local(wi);
}
// The share of the light the coat lets through towards w: 1 - c Fc(w.n_c), and 1 below the surface or the coat.
template <bool kTilted>
CHD float mr_coat_through(const Material& m, Vec3f w) {
  const float c = mr_coat_cos<kTilted>(m, w);
  return w.z > 0.f && c > 0.f ? 1.f - m.clearcoat * fresnel_dielectric(c, kCoatEta) : 1.f;
}
// The coat's reflectance seen from wo, c Fc(wo.n_c): its lobe's selection probability.
template <bool kTilted>
CHD float mr_coat_prob(const Material& m, Vec3f wo) {
  const float c = mr_coat_cos<kTilted>(m, wo);
  return wo.z > 0.f && c > 0.f && m.clearcoat > 0.f ? m.clearcoat * fresnel_dielectric(c, kCoatEta) : 0.f;
}
// The rough coat's lobe (without the cosine), and its sampling density times pc, the coat's probability; zero
// unless wo and wi are above both the surface and the coat.
template <bool kTilted>
CHD RGB mr_coat_eval(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode) {
  Vec3f o = wo, i = wi;
  if (kTilted) mr_coat_to_local(m, o, i);
  if (wo.z <= 0.f || wi.z <= 0.f || o.z <= 0.f || i.z <= 0.f) return RGB(0.f);
  const Vec3f wm = normalize(o + i);
  const Microfacet g = mr_coat_microfacet(m);
  const float cos_in_frame = mode == TransportMode::kRadiance ? o.z * wi.z : i.z * wo.z;
  return RGB(m.clearcoat * fresnel_dielectric(absdot(o, wm), kCoatEta) * g.D(wm) * g.G(o, i) /
             (4.f * cos_in_frame));
}
template <bool kTilted>
CHD float mr_coat_pdf(const Material& m, float pc, Vec3f wo, Vec3f wi) {
  Vec3f o = wo, i = wi;
  if (kTilted) mr_coat_to_local(m, o, i);
  if (wi.z <= 0.f || i.z <= 0.f) return 0.f;
  const Vec3f wm = normalize(o + i);
  return pc * mr_coat_microfacet(m).pdf_wm(o, wm) / (4.f * absdot(o, wm));
}

// A coat or a sheen over the base. Without one, eval, pdf and sample are the base's alone, and the layers'
// code below is kept out of line so that plain metallic-roughness materials run the base's code as before the
// layers (measured: inlined, the layers made plain materials 15-20% slower; bench/RESULTS.md).
CHD bool mr_layered(const Material& m) { return m.clearcoat > 0.f || mr_has_sheen(m); }

// Continuous parts of f (delta lobes evaluate to zero), without the cosine, with the layers.
template <bool kTilted>
CHD RGB mr_layered_eval_t(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode) {
  RGB f = mr_base_eval(m, wo, wi, mode);
  if (mr_has_sheen(m))
    f = f * mr_sheen_scaling(m, wo, wi) + m.sheen_color * mr_sheen_eval(m, wo, wi);
  if (!(m.clearcoat > 0.f)) return f;
  f = f * (mr_coat_through<kTilted>(m, wo) * mr_coat_through<kTilted>(m, wi));
  return mr_coat_smooth(m) ? f : f + mr_coat_eval<kTilted>(m, wo, wi, mode);
}
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline RGB mr_layered_eval(const Material& m, Vec3f wo, Vec3f wi,
                                                                   TransportMode mode) {
  return mr_coat_tilted(m) ? mr_layered_eval_t<true>(m, wo, wi, mode) : mr_layered_eval_t<false>(m, wo, wi, mode);
}

// Density of the continuous parts of the sampling mixture, with the layers.
template <bool kTilted>
CHD float mr_layered_pdf_t(const Material& m, Vec3f wo, Vec3f wi) {
  float pdf = mr_base_pdf(m, wo, wi);
  const float psh = mr_sheen_albedo(m, wo);  // the sheen is sampled with probability its albedo
  if (psh > 0.f) pdf = pdf * (1.f - psh) + (wi.z > 0.f ? psh * cosine_hemisphere_pdf(wi) : 0.f);
  float pc = mr_coat_prob<kTilted>(m, wo);
  if (!(pc > 0.f)) return pdf;
  pdf *= 1.f - pc;
  return mr_coat_smooth(m) ? pdf : pdf + mr_coat_pdf<kTilted>(m, pc, wo, wi);
}
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline float mr_layered_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  return mr_coat_tilted(m) ? mr_layered_pdf_t<true>(m, wo, wi) : mr_layered_pdf_t<false>(m, wo, wi);
}

CHD RGB metallic_roughness_eval(const Material& m, Vec3f wo, Vec3f wi, TransportMode mode) {
  return mr_layered(m) ? mr_layered_eval(m, wo, wi, mode) : mr_base_eval(m, wo, wi, mode);
}
CHD float metallic_roughness_pdf(const Material& m, Vec3f wo, Vec3f wi) {
  return mr_layered(m) ? mr_layered_pdf(m, wo, wi) : mr_base_pdf(m, wo, wi);
}

// Sampling with the layers: the coat with probability c Fc(cos_o), else the sheen with probability its albedo,
// else the base.
template <bool kTilted>
CHD bool mr_layered_sample_t(const Material& m, Vec3f wo, float uc, Vec2f u, TransportMode mode, BSDFSample& s) {
  const float pc = mr_coat_prob<kTilted>(m, wo);
  if (uc < pc) {  // the coat
    s.eta = 1.f;
    const Vec3f nc = m.coat_normal;
    if (mr_coat_smooth(m)) {
      s.wi = kTilted ? reflect(wo, nc) : Vec3f(-wo.x, -wo.y, wo.z);
      if (s.wi.z <= 0.f) return false;
      s.delta = true;
      s.pdf = pc;
      // The mirror's mass c Fc(wo.n_c) over its probability; the adjoint's carries |wi.z| / |wo.z| (see above).
      s.weight = RGB(kTilted && mode == TransportMode::kImportance ? s.wi.z / wo.z : 1.f);
      return true;
    }
    if (kTilted) {
      const Frame f(nc);
      s.wi = reflect(wo, f.to_world(mr_coat_microfacet(m).sample_wm(f.to_local(wo), u)));
    } else {
      s.wi = reflect(wo, mr_coat_microfacet(m).sample_wm(wo, u));
    }
    if (s.wi.z <= 0.f || mr_coat_cos<kTilted>(m, s.wi) <= 0.f) return false;
  } else {
    if (pc > 0.f) uc = minf((uc - pc) / (1.f - pc), 0.99999994f);
    const float psh = mr_sheen_albedo(m, wo);
    if (uc < psh) {  // the sheen, by its cosine
      s.wi = square_to_cosine_hemisphere(u);
      s.eta = 1.f;
      if (s.wi.z <= 0.f) return false;
    } else {
      if (psh > 0.f) uc = minf((uc - psh) / (1.f - psh), 0.99999994f);
      if (!mr_base_sample(m, wo, uc, u, mode, s)) return false;
      if (s.delta) {
        // The layers above pass the base's delta lobe the share they leave it.
        float share = 1.f, prob = 1.f;
        if (m.clearcoat > 0.f) share *= mr_coat_through<kTilted>(m, wo) * mr_coat_through<kTilted>(m, s.wi), prob *= 1.f - pc;
        if (psh > 0.f) share *= mr_sheen_scaling(m, wo, s.wi), prob *= 1.f - psh;
        s.pdf *= prob;
        s.weight = s.weight * (share / prob);
        return true;
      }
    }
  }
  s.delta = false;
  s.pdf = mr_layered_pdf_t<kTilted>(m, wo, s.wi);
  if (!(s.pdf > 0.f)) return false;
  s.weight = mr_layered_eval_t<kTilted>(m, wo, s.wi, mode) * (abs_cos_theta(s.wi) / s.pdf);
  return isfinite3(s.weight);
}
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline bool mr_layered_sample(const Material& m, Vec3f wo, float uc, Vec2f u,
                                                                      TransportMode mode, BSDFSample& s) {
  return mr_coat_tilted(m) ? mr_layered_sample_t<true>(m, wo, uc, u, mode, s)
                           : mr_layered_sample_t<false>(m, wo, uc, u, mode, s);
}

CHD bool metallic_roughness_sample(const Material& m, Vec3f wo, float uc, Vec2f u, TransportMode mode,
                                   BSDFSample& s) {
  if (mr_layered(m)) return mr_layered_sample(m, wo, uc, u, mode, s);
  if (!mr_base_sample(m, wo, uc, u, mode, s)) return false;
  if (s.delta) return true;
  s.pdf = mr_base_pdf(m, wo, s.wi);
  if (!(s.pdf > 0.f)) return false;
  s.weight = mr_base_eval(m, wo, s.wi, mode) * (abs_cos_theta(s.wi) / s.pdf);
  return isfinite3(s.weight);
}

}  // namespace caustica
