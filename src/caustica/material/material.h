// A material is a small tagged struct; bsdf.h dispatches on its type with a
// switch (no virtual calls), so the same code runs on the CPU and the GPU.
// All BSDF routines work in the local shading frame, normal = +z, and take
// wo (towards the viewer or the previous vertex) and wi (towards the light).
#pragma once
#include <array>
#include <cstdint>
#include "../base/math.h"

namespace caustica {

enum class MaterialType : uint32_t {
  kDiffuse = 0,
  kConductor,            // smooth: a tinted perfect mirror, or complex IOR (eta + i k)
  kRoughConductor,       // GGX
  kDielectric,           // smooth glass
  kRoughDielectric,      // GGX glass
  kThinDielectric,       // a thin pane: reflection and straight transmission
  kPlastic,              // smooth dielectric coat over a diffuse base
  kDiffuseTransmission,  // Lambertian reflection r/pi and transmission t/pi
  kPhong,                // SmallVCM's Lambert + modified Phong lobe
  kMetallicRoughness,    // glTF 2.0 PBR: GGX conductor / dielectric-over-diffuse / rough glass blend
  kPrincipled,           // Mitsuba 3's principled (the Disney BSDF): diffuse, retro-reflection, sheen, GGX, clearcoat
  kRoughPlastic,         // a rough dielectric coat over Lambert (Mitsuba's roughplastic): material/rough_plastic.h
  // No surface: a boundary between participating media that rays cross unchanged (Mitsuba 3's `null` BSDF,
  // pbrt-v4's "interface" material). Its BSDF is zero; the path tracer continues straight through it.
  kNull,
  kCount
};

enum MaterialFlags : uint32_t {
  kTwoSided = 1u,       // reflective materials: the same from both sides
  kConductorTint = 2u,  // conductor: Fresnel ignored, reflectance = specular
  // Normal map: its y axis is n x dp/du whatever the UVs' handedness (Mitsuba 3's normalmap, pbrt-v4), rather
  // than turned to dp/dv's side (MikkTSpace and glTF, caustica's default; scene/shading.h).
  kNormalMapCross = 4u,
  kOpacityLuminance = 8u,  // the opacity texture's luminance is the opacity, rather than its alpha channel
  kAlphaTested = 16u,      // set by Scene::build where opacity < 1 or an opacity texture makes cut-outs
  // Metallic-roughness: the dielectric's diffuse base is plastic's (refraction into the coat, 1/eta^2, and
  // internal reflections; Mitsuba's roughplastic) instead of glTF's (1 - F) base (material/metallic_roughness.h).
  kPlasticBase = 32u,
  // The main colour (as tex_color's) times the triangle's interpolated vertex colour (SceneView::colors; glTF's
  // COLOR_0, Mitsuba's mesh_attribute "vertex_color"); white on spheres and meshes without colours.
  kVertexColor = 64u,
  // Rough conductor and rough dielectric: the Beckmann distribution instead of GGX (material/microfacet.h;
  // Mitsuba's default `distribution`).
  kBeckmann = 128u,
  // A pair of sides (Mitsuba 3's twosided of two BSDFs): with mix_a and mix_b, mix_a seen from the front (the
  // side the geometric normal faces) and mix_b from behind (resolve_material, scene/interaction.h).
  kSides = 256u,
};

// Entries of a material's table of a function of a cosine (Material::table, material_table).
constexpr int kMaterialTable = 32;

// Radiance flows from lights to the camera; importance flows the other way.
// Refraction scales radiance by 1/eta^2 but not importance (Veach 1997, Sec. 5.2).
enum class TransportMode : uint32_t { kRadiance = 0, kImportance = 1 };

struct Material {
  MaterialType type = MaterialType::kDiffuse;
  uint32_t flags = 0;
  RGB diffuse{0.5f};        // Lambert / plastic base / Phong kd / diffuse reflectance r
  RGB specular{1.f};        // specular tint / Phong ks
  // Dielectric transmission tint / diffuse transmittance t; metallic-roughness: the colour of its diffuse
  // transmission (KHR_materials_diffuse_transmission's diffuseTransmissionColorFactor).
  RGB transmission{1.f};
  RGB eta_c{0.f}, k_c{0.f}; // conductor complex index of refraction
  float eta = 1.5f;         // dielectric / plastic: interior IOR over exterior IOR
  float alpha_x = 0.1f, alpha_y = 0.1f;  // GGX roughness (alpha_x along the anisotropy direction, scene/shading.h)
  float aniso_rotation = 0.f;  // anisotropy direction: radians from dp/du towards dp/dv (glTF anisotropyRotation)
  float exponent = 90.f;    // Phong exponent
  float fdr_int = 0.f;      // plastic: internal diffuse Fresnel reflectance (precomputed); rough plastic: its coat's (prepare_rough_plastic)
  float metallic = 0.f;     // metallic-roughness: metal weight
  float transmission_weight = 0.f;  // metallic-roughness: KHR_materials_transmission; principled: spec_trans
  // Metallic-roughness: KHR_materials_specular's specularFactor (the dielectric's specular weight); `specular`
  // holds its specularColorFactor (material/metallic_roughness.h, mr_dielectric_fresnel).
  float specular_weight = 1.f;
  // Principled (material/principled.h): the Disney BSDF's other weights, each in [0, 1]. `clearcoat` is also
  // metallic-roughness's coat weight (KHR_materials_clearcoat's clearcoatFactor), whose GGX alpha is
  // clearcoat_alpha (clearcoatRoughness^2; material/metallic_roughness.h).
  float spec_tint = 0.f, sheen = 0.f, sheen_tint = 0.f, flatness = 0.f, clearcoat = 0.f, clearcoat_gloss = 0.f;
  float clearcoat_alpha = 0.f;
  // Metallic-roughness: the coat's normal in the shading frame (z along the shading normal), set per hit by
  // surface_material (scene/shading.h): the surface's normal before the base's normal or bump map, turned by
  // tex_clearcoat_normal (KHR_materials_clearcoat's clearcoatNormalTexture, scaled by clearcoat_normal_scale).
  Vec3f coat_normal{0.f, 0.f, 1.f};
  float clearcoat_normal_scale = 1.f;
  // Metallic-roughness: KHR_materials_sheen's sheenColorFactor (black: no sheen) and sheenRoughnessFactor
  // (perceptual; the Charlie distribution's alpha is its square).
  RGB sheen_color{0.f};
  float sheen_roughness = 0.f;
  // Metallic-roughness: KHR_materials_iridescence, a thin film over the specular layers (material/thin_film.h):
  // its weight iridescenceFactor (0: none), IOR, and thickness in nm, iridescence_thickness, or with
  // tex_iridescence_thickness, from iridescence_thickness_min (texel 0) to iridescence_thickness (texel 1).
  float iridescence = 0.f, iridescence_eta = 1.3f, iridescence_thickness = 400.f, iridescence_thickness_min = 0.f;
  // Metallic-roughness: KHR_materials_diffuse_transmission's diffuseTransmissionFactor, the share of the
  // dielectric's diffuse base that is Lambertian transmission (colour `transmission`) instead of reflection
  // (material/metallic_roughness.h).
  float diffuse_transmission = 0.f;
  // Textures (indices into SceneView::textures, -1 = none), applied at the hit:
  //   tex_color multiplies the main colour (diffuse/base colour; a tinted
  //     mirror's or conductor's `specular`; a dielectric's `transmission`);
  //   tex_roughness: metallic-roughness reads roughness from G (alpha =
  //     (G * roughness)^2) and metallic from B; principled reads roughness from G
  //     (both alphas times G^2); other rough types read alpha from R;
  //   tex_normal: a tangent-space normal map (RGB in [0,1] -> [-1,1]);
  //   tex_bump: a height map (its luminance times bump_scale, in scene units per unit of height), used when
  //     there is no normal map (scene/shading.h, apply_bump_map).
  //   tex_aniso: KHR_materials_anisotropy's anisotropyTexture: RG (2 rg - 1) a direction in the tangent
  //     frame that turns the anisotropy direction further, B scales the anisotropy strength.
  //   tex_clearcoat: metallic-roughness's coat weight times R (KHR_materials_clearcoat's clearcoatTexture);
  //   tex_clearcoat_roughness: the coat's roughness times G (alpha = (G sqrt(alpha))^2; clearcoatRoughnessTexture);
  //   tex_specular: metallic-roughness's specular_weight times R (the glTF loader moves KHR_materials_specular's
  //     specularTexture alpha there, so that the JSON export's RGB images keep it);
  //   tex_specular_color: its specular colour times RGB (specularColorTexture);
  //   tex_transmission: metallic-roughness's transmission_weight times R (KHR_materials_transmission's
  //     transmissionTexture);
  //   tex_sheen_color: its sheen colour times RGB (KHR_materials_sheen's sheenColorTexture);
  //   tex_sheen_roughness: its sheen roughness times R (sheenRoughnessTexture's alpha, moved to red by the glTF
  //     loader); its albedo table (Material::table) is then the texel's roughness's (mr_sheen_table_at).
  //   tex_iridescence: its iridescence weight times R (KHR_materials_iridescence's iridescenceTexture);
  //   tex_iridescence_thickness: its film thickness from the minimum to iridescence_thickness by R (the glTF
  //     loader moves iridescenceThicknessTexture's green channel there).
  //   tex_clearcoat_normal: a tangent-space normal map for the coat alone (clearcoatNormalTexture; as tex_normal,
  //     on the surface's normal: the base's normal map does not move the coat).
  //   tex_diffuse_transmission: its diffuse transmission weight times R (diffuseTransmissionTexture's alpha,
  //     moved to red by the glTF loader); tex_diffuse_transmission_color: that transmission's colour times RGB
  //     (diffuseTransmissionColorTexture), and a diffuse transmission material's transmittance times RGB.
  //   Principled: tex_clearcoat and tex_transmission as above (clearcoat, spec_trans times R), and
  //     tex_metallic, tex_spec_tint, tex_sheen, tex_sheen_tint, tex_flatness, tex_clearcoat_gloss: those weights
  //     times R (the Mitsuba loader gives them grey copies of its images: Mitsuba reads a float texture's
  //     luminance). The metallic-roughness layer slots are read for metallic-roughness only, these for
  //     principled only (scene/shading.h).
  int32_t tex_color = -1, tex_roughness = -1, tex_normal = -1, tex_bump = -1, tex_aniso = -1;
  int32_t tex_clearcoat = -1, tex_clearcoat_roughness = -1, tex_specular = -1, tex_specular_color = -1,
          tex_transmission = -1, tex_sheen_color = -1, tex_sheen_roughness = -1, tex_iridescence = -1,
          tex_iridescence_thickness = -1, tex_clearcoat_normal = -1, tex_diffuse_transmission = -1,
          tex_diffuse_transmission_color = -1;
  int32_t tex_metallic = -1, tex_spec_tint = -1, tex_sheen = -1, tex_sheen_tint = -1, tex_flatness = -1,
          tex_clearcoat_gloss = -1;
  float normal_scale = 1.f, bump_scale = 1.f;
  // Dielectrics: absorption coefficient inside (per unit length, Beer-Lambert),
  // applied to path segments that end on the back side of this material
  // (closed, non-nested glass; glTF KHR_materials_volume: -ln(colour)/distance).
  RGB absorption{0.f};
  // Opacity, for cut-outs (leaves, fences: glTF alphaMode MASK and BLEND, Mitsuba 3's mask, OBJ map_d):
  // `opacity` times tex_opacity's alpha channel (or its luminance with kOpacityLuminance). With
  // opacity_cutoff >= 0 the surface is there where that is >= the cutoff and absent elsewhere (an alpha test,
  // glTF MASK); with a negative cutoff a ray passes through with probability 1 - opacity (stochastic
  // transparency, glTF BLEND, Mitsuba's mask). Rays pass through inside the intersection queries
  // (scene/opacity.h), so every integrator, shadow rays and photons see the same surface.
  float opacity = 1.f;
  int32_t tex_opacity = -1;
  float opacity_cutoff = -1.f;
  // Blend (Mitsuba 3's blendbsdf, pbrt-v4's mix): when mix_b >= 0 this entry stands for materials mix_a and
  // mix_b (indices into the scene's materials), mix_b at a share mix_weight of the surface (times tex_mix's
  // luminance), or with kSides mix_a on the front and mix_b behind. resolve_material (scene/interaction.h)
  // picks one at each hit. Of the entry's other fields only the opacity is used (cut-outs of the blend as a
  // whole).
  int32_t mix_a = -1, mix_b = -1, tex_mix = -1;
  float mix_weight = 0.5f;
  // A function of a cosine mu in [0, 1], at mu = i / (kMaterialTable - 1), in 65535ths (material_table):
  // rough plastic: t(mu), the light its coat lets through (fdr_int holds the coat's internal reflectance;
  // prepare_rough_plastic); metallic-roughness with sheen: the sheen's directional albedo E(mu) for a white
  // sheen colour (prepare_sheen). Filled by Scene::build.
  uint16_t table[kMaterialTable] = {};
};

// Every texture slot of a material (-1 where empty), for host code that visits them all (validation, the
// writers' lists of used images); without `opacity` the opacity slot reads as empty.
inline std::array<int32_t, 25> material_textures(const Material& m, bool opacity = true) {
  return {m.tex_color, m.tex_roughness, m.tex_normal, m.tex_bump, m.tex_aniso, m.tex_clearcoat,
          m.tex_clearcoat_roughness, m.tex_specular, m.tex_specular_color, m.tex_transmission,
          m.tex_sheen_color, m.tex_sheen_roughness, m.tex_iridescence, m.tex_iridescence_thickness, m.tex_clearcoat_normal,
          m.tex_diffuse_transmission, m.tex_diffuse_transmission_color,
          m.tex_metallic, m.tex_spec_tint, m.tex_sheen,
          m.tex_sheen_tint, m.tex_flatness, m.tex_clearcoat_gloss, opacity ? m.tex_opacity : -1, m.tex_mix};
}

// The principled weights in [0, 1] that take a texture (its red channel times the weight; scene/shading.h), by
// their names in JSON and Mitsuba XML: the loaders and the JSON writer read and write them from this list.
struct PrincipledWeight {
  const char* name;
  float Material::*value;
  int32_t Material::*texture;
};
inline constexpr PrincipledWeight kPrincipledWeights[] = {
    {"metallic", &Material::metallic, &Material::tex_metallic},
    {"spec_trans", &Material::transmission_weight, &Material::tex_transmission},
    {"spec_tint", &Material::spec_tint, &Material::tex_spec_tint},
    {"sheen", &Material::sheen, &Material::tex_sheen},
    {"sheen_tint", &Material::sheen_tint, &Material::tex_sheen_tint},
    {"flatness", &Material::flatness, &Material::tex_flatness},
    {"clearcoat", &Material::clearcoat, &Material::tex_clearcoat},
    {"clearcoat_gloss", &Material::clearcoat_gloss, &Material::tex_clearcoat_gloss}};

// Material::table at cosine mu, linearly interpolated.
CHD float material_table(const Material& m, float mu) {
  const float x = clampf(mu, 0.f, 1.f) * float(kMaterialTable - 1);
  const int i = x >= float(kMaterialTable - 2) ? kMaterialTable - 2 : int(x);
  const float f = x - float(i);
  return (float(m.table[i]) * (1.f - f) + float(m.table[i + 1]) * f) * (1.f / 65535.f);
}

// How many blends inside blends resolve_material resolves (the loaders refuse cycles).
constexpr uint32_t kMaxMixDepth = 8;

// Metallic-roughness with diffuse transmission (KHR_materials_diffuse_transmission): a thin translucent
// sheet, whose opaque parts are seen the same from both sides (material/metallic_roughness.h). With a weight
// texture it is one wherever the texture lets light through, so the whole surface is.
CHD bool mr_translucent(const Material& m) {
  return m.type == MaterialType::kMetallicRoughness && (m.diffuse_transmission > 0.f || m.tex_diffuse_transmission >= 0);
}
CHD bool material_is_transmissive(const Material& m) {
  return m.type == MaterialType::kDielectric || m.type == MaterialType::kRoughDielectric ||
         m.type == MaterialType::kThinDielectric || m.type == MaterialType::kDiffuseTransmission ||
         ((m.type == MaterialType::kMetallicRoughness || m.type == MaterialType::kPrincipled) &&
          m.transmission_weight > 0.f && (m.metallic < 1.f || m.tex_metallic >= 0)) ||  // a texture may lower it
         mr_translucent(m);
}
// True when every lobe is a Dirac delta (NEE is pointless there).
CHD bool material_is_delta(const Material& m) {
  return m.type == MaterialType::kConductor || m.type == MaterialType::kDielectric ||
         m.type == MaterialType::kThinDielectric ||
         (m.type == MaterialType::kMetallicRoughness && m.alpha_x < 1e-3f && m.alpha_y < 1e-3f &&
          (m.metallic >= 1.f || m.transmission_weight >= 1.f) && (!(m.clearcoat > 0.f) || m.clearcoat_alpha < 1e-3f) &&
          !(max_component(m.sheen_color) > 0.f));
}

struct BSDFSample {
  Vec3f wi;
  RGB weight{0.f};  // f * |cos(wi)| / pdf
  float pdf = 0.f;  // solid-angle density; for a delta lobe, its discrete probability
  bool delta = false;
  float eta = 1.f;  // relative IOR crossed (for Russian roulette on radiance)
};

}  // namespace caustica
