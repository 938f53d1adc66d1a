// The material at a surface hit with its textures applied, and the
// attenuation of a path segment inside absorbing glass.
//   tex_color:     multiplies the main colour (see material.h);
//   tex_roughness: metallic-roughness reads roughness from G and metallic
//                  from B (glTF 2.0 Sec. 3.9.2), other rough types alpha from R;
//   tex_normal:    tangent-space normal map (glTF 2.0 Sec. 3.9.3): n =
//                  normalize(T x s + B y s + N z) with (x, y, z) = 2 rgb - 1,
//                  s = normal_scale, T = dp/du and B = dp/dv (surface_uv_axes: vertex
//                  tangents where the mesh has them) made orthogonal to the shading
//                  normal N (v up, so green points towards +v);
//   tex_bump:      a height map, when there is no normal map (apply_bump_map).
#pragma once
#include "opacity.h"

namespace caustica {

// dp/du and dp/dv of a triangle from its texture coordinates (pbrt-v4 Eq. 6.7);
// false without UVs or for a degenerate mapping.
CHD bool triangle_dpduv(const SceneView& s, uint32_t tri, Vec3f& dpdu, Vec3f& dpdv) {
  if (!s.uvs || tri >= s.num_triangles) return false;
  const uint32_t* ix = s.indices + 3 * tri;
  Vec3f p0 = s.positions[ix[0]], p1 = s.positions[ix[1]], p2 = s.positions[ix[2]];
  Vec2f t0 = s.uvs[ix[0]], t1 = s.uvs[ix[1]], t2 = s.uvs[ix[2]];
  float du1 = t1.x - t0.x, dv1 = t1.y - t0.y, du2 = t2.x - t0.x, dv2 = t2.y - t0.y;
  float det = du1 * dv2 - dv1 * du2;
  if (std::fabs(det) < 1e-12f) return false;
  float inv = 1.f / det;
  Vec3f e1 = p1 - p0, e2 = p2 - p0;
  dpdu = (e1 * dv2 - e2 * dv1) * inv;
  dpdv = (e2 * du1 - e1 * du2) * inv;
  return isfinite3(dpdu) && isfinite3(dpdv);
}

// dp/du and dp/dv of sphere i at outward normal n (world space), in scene units per unit of u and v:
// u = phi / 2pi about the sphere's own +z, v = 1 - theta / pi (sphere_uv_at), so with n = (sin theta cos phi,
// sin theta sin phi, cos theta) in its frame dp/du = 2 pi r (-n.y, n.x, 0) and dp/dv = pi r (-cos theta cos phi,
// -cos theta sin phi, sin theta). False at the poles, where phi has no direction.
CHD bool sphere_dpduv(const SceneView& s, uint32_t i, Vec3f n_world, Vec3f& dpdu, Vec3f& dpdv) {
  const Vec3f n = sphere_local(s, i, n_world);
  const float r = s.spheres[i].radius, sin_theta = std::sqrt(n.x * n.x + n.y * n.y);
  if (!(sin_theta > 0.f)) return false;
  dpdu = Vec3f(-n.y, n.x, 0.f) * (2.f * kPi * r);
  dpdv = Vec3f(-n.z * n.x / sin_theta, -n.z * n.y / sin_theta, sin_theta) * (kPi * r);
  if (s.sphere_frames) {
    dpdu = s.sphere_frames[i].to_world(dpdu);
    dpdv = s.sphere_frames[i].to_world(dpdv);
  }
  return true;
}

// The directions of increasing u and v at a hit (unnormalised, not yet orthogonal to the shading normal):
//   triangles of a mesh with vertex tangents (Tangent: glTF's TANGENT, or generate_tangents): the
//     tangents interpolated at the hit and w * cross(vertex normal, tangent), as pbrt-v4 does with a mesh's
//     s and glTF 2.0 with TANGENT; smooth across triangles, as the normals are;
//   other triangles: their own dp/du and dp/dv (triangle_dpduv; Mitsuba 3 and pbrt-v4 without
//     tangents), constant over each triangle;
//   spheres: sphere_dpduv (u = phi / 2pi about their own +z, v growing towards their +z pole).
// False where there are none: a mesh without UVs, a degenerate mapping, a sphere's pole.
CHD bool surface_uv_axes(const SceneView& s, const SurfaceHit& sh, Vec3f& dpdu, Vec3f& dpdv) {
  if (sh.prim >= s.num_triangles) return sphere_dpduv(s, sh.prim - s.num_triangles, sh.ng, dpdu, dpdv);
  if (s.tangents) {
    const uint32_t* ix = s.indices + 3 * sh.prim;
    const Tangent t0 = s.tangents[ix[0]], t1 = s.tangents[ix[1]], t2 = s.tangents[ix[2]];
    if (t0.w != 0.f && t0.w == t1.w && t0.w == t2.w) {  // one handedness over the triangle
      Vec3f p0, p1, p2;
      triangle_vertices(s, sh.prim, p0, p1, p2);
      Vec3f e1 = p1 - p0, e2 = p2 - p0, d = sh.p - p0, nt = cross(e1, e2);
      float inv = 1.f / length_sq(nt);
      float b1 = dot(cross(d, e2), nt) * inv, b2 = dot(cross(e1, d), nt) * inv, b0 = 1.f - b1 - b2;
      Vec3f t = t0.t * b0 + t1.t * b1 + t2.t * b2;
      Vec3f nv = sh.ng;
      if (s.normals) {
        Vec3f n = s.normals[ix[0]] * b0 + s.normals[ix[1]] * b1 + s.normals[ix[2]] * b2;
        if (length_sq(n) > 0.f) nv = n;  // the vertex normals' side, which w refers to
      }
      Vec3f b = cross(nv, t) * t0.w;
      if (length_sq(t) > 0.f && length_sq(b) > 0.f && isfinite3(t) && isfinite3(b)) {
        dpdu = t;
        dpdv = b;
        return true;
      }
    }
  }
  return triangle_dpduv(s, sh.prim, dpdu, dpdv);
}

// The direction anisotropic roughness is measured along (alpha_x along it, alpha_y across it): dp/du of
// the surface's texture parameterisation (surface_uv_axes), as in pbrt-v4 (uroughness along dpdu) and
// Mitsuba 3 (alpha_u along dp_du). Zero where there is none and for isotropic materials, whose frame
// about the normal is arbitrary.
// A material's aniso_rotation (KHR_materials_anisotropy's anisotropyRotation) turns that direction about
// the shading normal, counter-clockwise from dp/du towards dp/dv.
CHD Vec3f shading_tangent(const SceneView& s, const SurfaceHit& sh, const Material& m) {
  if (m.alpha_x == m.alpha_y) return Vec3f(0.f);
  Vec3f dpdu, dpdv;
  if (!surface_uv_axes(s, sh, dpdu, dpdv)) return Vec3f(0.f);
  if (m.aniso_rotation == 0.f) return dpdu;
  const Vec3f n = sh.ns;
  Vec3f t = dpdu - n * dot(n, dpdu);
  if (!(length_sq(t) > 0.f)) return Vec3f(0.f);
  t = normalize(t);
  Vec3f b = cross(n, t);
  if (dot(b, dpdv) < 0.f) b = -b;  // mirrored UVs
  return t * std::cos(m.aniso_rotation) + b * std::sin(m.aniso_rotation);
}

// The shading frame about unit normal n whose first axis is tangent t made orthogonal to n (Gram-Schmidt),
// the second cross(n, s); without a usable tangent (zero, or along n) the branchless frame of Frame(n).
CHD Frame tangent_frame(Vec3f n, Vec3f t) {
  Vec3f sv = t - n * dot(n, t);
  float l2 = length_sq(sv);
  if (!(l2 > 1e-10f * length_sq(t)) || !std::isfinite(l2)) return Frame(n);
  Frame f;
  f.n = n;
  f.s = sv / std::sqrt(l2);
  f.t = cross(n, f.s);
  return f;
}

// The frame a BSDF is evaluated in at a hit, with the material's textures (and normal map) applied.
CHD Frame shading_frame(const SceneView& s, const SurfaceHit& sh, const Material& m) {
  return tangent_frame(sh.ns, shading_tangent(s, sh, m));
}

// The normal that normal map `tex` (scaled by `scale`) gives at a hit: from the shading normal sh.ns in the
// frame of the surface's u and v axes; false where there is no such frame or the normal would cross the
// geometric surface.
CHD bool normal_map_normal(const SceneView& s, const Material& m, const SurfaceHit& sh, int32_t tex, float scale,
                           Vec3f& out) {
  Vec3f dpdu, dpdv;
  if (!surface_uv_axes(s, sh, dpdu, dpdv)) return false;
  Vec3f n = sh.ns;
  Vec3f t = dpdu - n * dot(n, dpdu);
  if (length_sq(t) == 0.f) return false;
  t = normalize(t);
  Vec3f b = cross(n, t);
  if (!(m.flags & kNormalMapCross) && dot(b, dpdv) < 0.f) b = -b;  // mirrored UVs
  RGB c = texture_lookup(s.textures[tex], sh.uv).rgb();
  Vec3f ts((2.f * c.x - 1.f) * scale, (2.f * c.y - 1.f) * scale, 2.f * c.z - 1.f);
  Vec3f nn = t * ts.x + b * ts.y + n * ts.z;
  if (!(length_sq(nn) > 0.f)) return false;
  nn = normalize(nn);
  if (dot(nn, sh.ng) * dot(n, sh.ng) <= 0.f) return false;  // would cross the geometric surface
  out = nn;
  return true;
}

CHD void apply_normal_map(const SceneView& s, const Material& m, SurfaceHit& sh) {
  Vec3f n;
  if (normal_map_normal(s, m, sh, m.tex_normal, m.normal_scale, n)) sh.ns = n;
}

// Bump mapping with height h = bump_scale x (the texture's luminance) along the shading normal n, as
// Mitsuba 3's bumpmap does it (pbrt-v4 Sec. 10.5.1 with the dn/du term dropped): dp/du' = dp/du - n (n . dp/du)
// + n dh/du (and for v, with dh/du and dh/dv from texture_luminance_gradient), n' = dp/du' x dp/dv' normalised
// and put on n's side. The derivatives are the geometry's own (triangle_dpduv, sphere_dpduv; vertex
// tangents have no lengths), so dh/du is in scene units per unit of u. As with a normal map, a normal that
// would cross the geometric surface is not used.
CHD void apply_bump_map(const SceneView& s, const Material& m, SurfaceHit& sh) {
  Vec3f dpdu, dpdv;
  bool ok = sh.prim < s.num_triangles ? triangle_dpduv(s, sh.prim, dpdu, dpdv)
                                      : sphere_dpduv(s, sh.prim - s.num_triangles, sh.ng, dpdu, dpdv);
  if (!ok) return;
  Vec2f g = texture_luminance_gradient(s.textures[m.tex_bump], sh.uv) * m.bump_scale;
  const Vec3f n = sh.ns;
  Vec3f du = dpdu + n * (g.x - dot(n, dpdu)), dv = dpdv + n * (g.y - dot(n, dpdv));
  Vec3f nn = cross(du, dv);
  float l2 = length_sq(nn);
  if (!(l2 > 0.f) || !std::isfinite(l2)) return;
  nn = nn / std::sqrt(l2);
  if (dot(nn, n) < 0.f) nn = -nn;
  if (dot(nn, sh.ng) * dot(n, sh.ng) <= 0.f) return;  // would cross the geometric surface
  sh.ns = nn;
}

// The main colour, the one colour textures and vertex colours tint: the specular tint of conductors, the
// transmission of dielectrics, else the diffuse or base colour.
CHD RGB& main_colour(Material& m) {
  switch (m.type) {
    case MaterialType::kConductor:
    case MaterialType::kRoughConductor: return m.specular;
    case MaterialType::kDielectric:
    case MaterialType::kRoughDielectric:
    case MaterialType::kThinDielectric: return m.transmission;
    default: return m.diffuse;
  }
}

CHD Material surface_material(const SceneView& s, SurfaceHit& sh) {
  Material m = s.materials[sh.material];  // blends already resolved (make_surface_hit, resolve_material)
  if (m.tex_color >= 0) main_colour(m) *= texture_lookup(s.textures[m.tex_color], sh.uv).rgb();
  if ((m.flags & kVertexColor) && s.colors && sh.prim < s.num_triangles) main_colour(m) *= triangle_color(s, sh.prim, sh.p);
  if (m.tex_roughness >= 0) {
    RGBA r = texture_lookup(s.textures[m.tex_roughness], sh.uv);
    if (m.type == MaterialType::kMetallicRoughness) {
      if (m.alpha_x == m.alpha_y) {
        float rough = std::sqrt(maxf(m.alpha_x, 0.f)) * r.g;
        m.alpha_x = m.alpha_y = rough * rough;
      } else {
        // Anisotropic (KHR_materials_anisotropy): the texture scales the roughness across the direction,
        // alpha_y = (sqrt(alpha) G)^2, and alpha_x keeps its share s^2 of the way to 1 (alpha_x = mix(alpha_y,
        // 1, s^2), s the anisotropy strength).
        float s2 = m.alpha_y < 1.f ? (m.alpha_x - m.alpha_y) / (1.f - m.alpha_y) : 0.f;
        float rough = std::sqrt(maxf(m.alpha_y, 0.f)) * r.g;
        m.alpha_y = maxf(rough * rough, 1e-4f);
        m.alpha_x = maxf(m.alpha_y + (1.f - m.alpha_y) * s2, 1e-4f);
      }
      m.metallic *= r.b;
    } else if (m.type == MaterialType::kPrincipled) {
      // The roughness times G: both alphas (roughness^2 over and times the anisotropic aspect) times G^2.
      m.alpha_x *= r.g * r.g;
      m.alpha_y *= r.g * r.g;
    } else if (m.type == MaterialType::kRoughConductor || m.type == MaterialType::kRoughDielectric) {
      m.alpha_x = m.alpha_y = maxf(r.r, 1e-4f);
    }
  }
  // A weight in [0, 1] times its texture's red channel (unchanged without one).
  auto weight = [&](float& w, int32_t t) {
    if (t >= 0) w *= clampf(texture_lookup(s.textures[t], sh.uv).r, 0.f, 1.f);
  };
  if (m.type == MaterialType::kMetallicRoughness) {  // the glTF layers
    if (m.tex_sheen_color >= 0) m.sheen_color *= texture_lookup(s.textures[m.tex_sheen_color], sh.uv).rgb();
    if (m.tex_sheen_roughness >= 0) {
      weight(m.sheen_roughness, m.tex_sheen_roughness);
      if (s.sheen_table) mr_sheen_table_at(s.sheen_table, m);  // the texel's roughness's albedo table
    }
    weight(m.transmission_weight, m.tex_transmission);
    weight(m.diffuse_transmission, m.tex_diffuse_transmission);
    if (m.tex_diffuse_transmission_color >= 0)
      m.transmission *= texture_lookup(s.textures[m.tex_diffuse_transmission_color], sh.uv).rgb();
    weight(m.specular_weight, m.tex_specular);
    if (m.tex_specular_color >= 0) m.specular *= texture_lookup(s.textures[m.tex_specular_color], sh.uv).rgb();
    weight(m.clearcoat, m.tex_clearcoat);
    weight(m.iridescence, m.tex_iridescence);
    if (m.tex_iridescence_thickness >= 0) {  // from the minimum (texel 0) to the thickness (texel 1)
      const float t = clampf(texture_lookup(s.textures[m.tex_iridescence_thickness], sh.uv).r, 0.f, 1.f);
      m.iridescence_thickness = m.iridescence_thickness_min + (m.iridescence_thickness - m.iridescence_thickness_min) * t;
    }
    if (m.tex_clearcoat_roughness >= 0) {
      float rough = std::sqrt(maxf(m.clearcoat_alpha, 0.f)) *
                    clampf(texture_lookup(s.textures[m.tex_clearcoat_roughness], sh.uv).g, 0.f, 1.f);
      m.clearcoat_alpha = rough * rough;
    }
  } else if (m.type == MaterialType::kDiffuseTransmission && m.tex_diffuse_transmission_color >= 0) {
    m.transmission *= texture_lookup(s.textures[m.tex_diffuse_transmission_color], sh.uv).rgb();  // its transmittance
  } else if (m.type == MaterialType::kPrincipled) {  // the Disney BSDF's weights
    weight(m.metallic, m.tex_metallic);
    weight(m.transmission_weight, m.tex_transmission);
    weight(m.spec_tint, m.tex_spec_tint);
    weight(m.sheen, m.tex_sheen);
    weight(m.sheen_tint, m.tex_sheen_tint);
    weight(m.flatness, m.tex_flatness);
    weight(m.clearcoat, m.tex_clearcoat);
    weight(m.clearcoat_gloss, m.tex_clearcoat_gloss);
  }
  if (m.tex_aniso >= 0 && m.alpha_x != m.alpha_y) {
    // KHR_materials_anisotropy's texture: the strength s (alpha_x = mix(alpha_y, 1, s^2)) times B, the
    // direction turned by the angle of (2R - 1, 2G - 1) from the tangent towards the bitangent.
    RGBA a = texture_lookup(s.textures[m.tex_aniso], sh.uv);
    float s2 = m.alpha_y < 1.f ? (m.alpha_x - m.alpha_y) / (1.f - m.alpha_y) : 0.f;
    float st = std::sqrt(maxf(s2, 0.f)) * clampf(a.b, 0.f, 1.f);
    m.alpha_x = maxf(m.alpha_y + (1.f - m.alpha_y) * st * st, 1e-4f);
    float dx = 2.f * a.r - 1.f, dy = 2.f * a.g - 1.f;
    if (dx != 0.f || dy != 0.f) m.aniso_rotation += std::atan2(dy, dx);
  }
  // The coat's normal (KHR_materials_clearcoat): the surface's before the base's maps, or its own map's.
  Vec3f coat_n = sh.ns;
  const bool coat_own = m.type == MaterialType::kMetallicRoughness && m.clearcoat > 0.f &&
                        (m.tex_clearcoat_normal >= 0 || m.tex_normal >= 0 || m.tex_bump >= 0);
  if (coat_own && m.tex_clearcoat_normal >= 0)
    normal_map_normal(s, m, sh, m.tex_clearcoat_normal, m.clearcoat_normal_scale, coat_n);
  if (m.tex_normal >= 0) apply_normal_map(s, m, sh);
  else if (m.tex_bump >= 0) apply_bump_map(s, m, sh);
  if (coat_own) {
    // In the shading frame, on its upper side (a map may tilt either normal past the other's horizon).
    const Vec3f c = shading_frame(s, sh, m).to_local(coat_n);
    m.coat_normal = c.z > 1e-4f ? c : Vec3f(0.f, 0.f, 1.f);
  }
  return m;
}

// Shading normals make scattering asymmetric (Veach 1997, Sec. 5.3.2, Eq. 5.19): particles carrying
// importance-weighted power (light subpaths, photons) scatter with the adjoint f*(wo -> wi) =
// f(wi -> wo) |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|) (wo towards the previous vertex, wi the new direction), so
// this factor multiplies their BSDF weights (bs.weight, which holds |wi.ns|); it is 1 where ns = ng.
// pbrt-v3/v4's BDPT apply the same (CorrectShadingNormal). 0 when a direction grazes the geometric surface.
CHD float shading_normal_adjoint(const SurfaceHit& sh, Vec3f wo, Vec3f wi) {
  float den = absdot(wo, sh.ng) * absdot(wi, sh.ns);
  return den > 0.f ? absdot(wo, sh.ns) * absdot(wi, sh.ng) / den : 0.f;
}
// A density estimate counts photons per unit of geometric area, where they arrive with |wi.ng| (wi towards
// where the photon came from), while the radiance the BSDF reflects weighs them with |wi.ns|: each photon's
// f(wo, wi) beta is multiplied by |wi.ns| / |wi.ng| (1 where ns = ng), so that merging, photon mapping and
// path tracing agree on smooth-shaded and normal-mapped surfaces.
CHD float photon_gather_cosines(Vec3f ns, Vec3f ng, Vec3f wi) {
  float den = absdot(wi, ng);
  return den > 0.f ? absdot(wi, ns) / den : 0.f;
}

// Beer-Lambert transmittance of the segment that ended at `sh` after distance t
// when it ran inside absorbing glass (the hit is on the glass's back side).
CHD RGB segment_transmittance(const SceneView& s, Vec3f dir, float t, const SurfaceHit& sh) {
  const Material& m = s.materials[sh.material];
  if (is_black(m.absorption) || dot(dir, sh.ng) <= 0.f) return RGB(1.f);
  return vexp(m.absorption * (-t));
}

}  // namespace caustica
