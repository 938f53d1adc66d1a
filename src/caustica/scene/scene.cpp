#include "scene.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <functional>
#include <cmath>
#include <numeric>
#include <tuple>
#include <mutex>
#include <map>

#include "../backend/cpu/cpu_accel.h"
#include "../base/error.h"
#include "../material/fresnel.h"
#include "../material/metallic_roughness.h"
#include "../material/microfacet.h"

namespace caustica {

Material make_diffuse(RGB reflectance, bool two_sided) {
  Material m;
  m.type = MaterialType::kDiffuse;
  m.diffuse = reflectance;
  m.flags = two_sided ? kTwoSided : 0u;
  return m;
}
Material make_mirror(RGB tint) {
  Material m;
  m.type = MaterialType::kConductor;
  m.flags = kConductorTint;
  m.specular = tint;
  return m;
}
Material make_conductor(RGB eta, RGB k, RGB tint, float alpha) {
  Material m;
  m.type = alpha > 0.f ? MaterialType::kRoughConductor : MaterialType::kConductor;
  m.eta_c = eta;
  m.k_c = k;
  m.specular = tint;
  m.alpha_x = m.alpha_y = alpha;
  return m;
}
Material make_dielectric(float eta, float alpha) {
  Material m;
  m.type = alpha > 0.f ? MaterialType::kRoughDielectric : MaterialType::kDielectric;
  m.eta = eta;
  m.alpha_x = m.alpha_y = alpha;
  return m;
}
Material make_thin_dielectric(float eta) {
  Material m;
  m.type = MaterialType::kThinDielectric;
  m.eta = eta;
  return m;
}
Material make_plastic(RGB diffuse, float eta, RGB specular) {
  Material m;
  m.type = MaterialType::kPlastic;
  m.diffuse = diffuse;
  m.eta = eta;
  m.specular = specular;
  m.fdr_int = diffuse_fresnel_reflectance(1.f / eta);
  return m;
}
Material make_diffuse_transmission(RGB reflectance, RGB transmittance) {
  Material m;
  m.type = MaterialType::kDiffuseTransmission;
  m.diffuse = reflectance;
  m.transmission = transmittance;
  return m;
}
Material make_phong(RGB kd, RGB ks, float exponent) {
  Material m;
  m.type = MaterialType::kPhong;
  m.diffuse = kd;
  m.specular = ks;
  m.exponent = exponent;
  return m;
}

Material make_metallic_roughness(RGB base_color, float metallic, float roughness, float transmission, float ior) {
  Material m;
  m.type = MaterialType::kMetallicRoughness;
  m.diffuse = base_color;
  m.metallic = metallic;
  float a = roughness * roughness;
  m.alpha_x = m.alpha_y = a;
  m.transmission_weight = transmission;
  m.eta = ior;
  m.fdr_int = diffuse_fresnel_reflectance(1.f / ior);
  return m;
}

Material make_principled(RGB base_color, float metallic, float roughness, float anisotropic, float spec_trans,
                         float eta) {
  Material m;
  m.type = MaterialType::kPrincipled;
  m.diffuse = base_color;
  m.metallic = metallic;
  m.transmission_weight = spec_trans;
  m.eta = eta;
  const float a = roughness * roughness, aspect = std::sqrt(1.f - 0.9f * anisotropic);
  m.alpha_x = a / aspect;
  m.alpha_y = a * aspect;
  return m;
}

namespace {
// Expectations over the normals visible from incidence cos mu (Heitz 2018 Eq. 2) of a rough dielectric
// interface (relative IOR eta), as Mitsuba 3's roughplastic precomputes them (its eval_transmittance and
// eval_reflectance): the light refracted through the normal and not masked on the way in, (1 - F) G1(w_t), or
// reflected and not masked, F G1(w_r). A 64 x 64 midpoint grid of the sampler's unit square, each normal weighted
// by D_visible / its sampling density (1 for GGX's visible normals); the integrands are smooth in it.
double coat_expectation(const Microfacet& g, float eta, float mu, bool transmitted) {
  const Vec3f wo(std::sqrt(std::max(0.f, 1.f - mu * mu)), 0.f, mu);
  const int n = 64;
  double sum = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Vec3f h = g.sample_wm(wo, Vec2f((i + 0.5f) / n, (j + 0.5f) / n));
      const float c = dot(wo, h);
      if (!(c > 0.f)) continue;
      const float pdf = g.pdf_wm(wo, h);
      if (!(pdf > 0.f)) continue;
      const double w = g.D_visible(wo, h) / pdf;
      const float F = fresnel_dielectric(c, eta);
      if (transmitted) {
        Vec3f wt;
        if (!refract(wo, h, eta, wt) || !(wt.z < 0.f)) continue;
        sum += w * (1.0 - F) * g.G1_facing(wt, h);
      } else {
        const Vec3f wr = reflect(wo, h);
        if (!(wr.z > 0.f)) continue;
        sum += w * F * g.G1_facing(wr, h);
      }
    }
  return sum / (double(n) * n);
}
}  // namespace

struct CoatTables {
  uint16_t t[kMaterialTable];
  float internal;
};

void prepare_rough_plastic(Material& m) {
  // Computed once per coat (alpha, eta, distribution) in a process: scenes share coats, and the Mitsuba loader
  // needs them before Scene::build does.
  static std::mutex mutex;
  static std::map<std::tuple<float, float, bool>, CoatTables> cache;
  const auto key = std::make_tuple(m.alpha_x, m.eta, (m.flags & kBeckmann) != 0u);
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) {
      std::copy(std::begin(it->second.t), std::end(it->second.t), std::begin(m.table));
      m.fdr_int = it->second.internal;
      return;
    }
  }
  const Microfacet g = material_microfacet(m);
  for (int i = 0; i < kMaterialTable; ++i) {
    const float mu = std::max(1e-4f, float(i) / float(kMaterialTable - 1));
    const double t = std::clamp(coat_expectation(g, m.eta, mu, true), 0.0, 1.0);
    m.table[i] = uint16_t(std::lround(t * 65535.0));
  }
  // The internal reflectance 2 int_0^1 R_inside(mu) mu dmu, by Mitsuba's rule: the mean over the 64 cosines
  // i / 63 (the first 1e-6).
  const int n = 64;
  double r = 0.0;
  for (int i = 0; i < n; ++i) {
    const float mu = std::max(1e-6f, float(i) / float(n - 1));
    r += coat_expectation(g, 1.f / m.eta, mu, false) * mu;
  }
  m.fdr_int = float(2.0 * r / n);
  CoatTables c;
  std::copy(std::begin(m.table), std::end(m.table), std::begin(c.t));
  c.internal = m.fdr_int;
  std::lock_guard<std::mutex> lock(mutex);
  cache.emplace(key, c);
}

std::array<uint16_t, kMaterialTable> sheen_albedo_table(float alpha) {
  // E(mu) = int f_sheen(wo, wi) cos_i dwi over the upper hemisphere (the white lobe of mr_sheen_lobe), wo at
  // cosine mu, by the midpoint rule on 256 polar angles x 64 azimuths over half the circle (the lobe is
  // symmetric about wo's plane; the smallest alpha's lobe is ~0.03 rad wide in theta_h, 5 steps), with the
  // masking terms of each row computed once and D's power in single precision (~10 ms per alpha). Stored as E / kSheenTableScale. Once per alpha in a process.
  static std::mutex mutex;
  static std::map<float, std::array<uint16_t, kMaterialTable>> cache;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(alpha);
    if (it != cache.end()) return it->second;
  }
  constexpr int nt = 256, np = 64;
  const double dt = 0.5 * double(kPi) / nt, dp = double(kPi) / np;
  double cos_t[nt], sin_t[nt], lambda_t[nt], cos_p[np], sin_p[np];
  for (int a = 0; a < nt; ++a) {
    cos_t[a] = std::cos((a + 0.5) * dt), sin_t[a] = std::sin((a + 0.5) * dt);
    lambda_t[a] = charlie_lambda(float(cos_t[a]), alpha);
  }
  for (int b = 0; b < np; ++b) cos_p[b] = std::cos((b + 0.5) * dp), sin_p[b] = std::sin((b + 0.5) * dp);
  const double norm = (2.0 + 1.0 / alpha) * 0.5 / double(kPi);
  const float expo = 0.5f / alpha;
  std::array<uint16_t, kMaterialTable> t{};
  for (int i = 0; i < kMaterialTable; ++i) {
    const double mu = std::max(1e-4, double(i) / (kMaterialTable - 1)), so = std::sqrt(1.0 - mu * mu);
    const double lambda_o = charlie_lambda(float(mu), alpha);
    double e = 0.0;
    for (int a = 0; a < nt; ++a) {
      double row = 0.0;
      for (int b = 0; b < np; ++b) {
        // h = (wo + wi) / |wo + wi|, wo = (so, 0, mu), wi = (sin_t cos_p, sin_t sin_p, cos_t): sin^2 theta_h
        const double hx = so + sin_t[a] * cos_p[b], hy = sin_t[a] * sin_p[b], hz = mu + cos_t[a];
        const double sin2 = (hx * hx + hy * hy) / (hx * hx + hy * hy + hz * hz);
        row += double(std::pow(float(sin2), expo));
      }
      // D V cos_i dw = D / ((1 + L_o + L_i) 4 mu cos_i) cos_i sin_t dtheta dphi
      e += row * sin_t[a] / (1.0 + lambda_o + lambda_t[a]);
    }
    e *= norm / (4.0 * mu) * dt * dp * 2.0;  // both halves of the circle
    t[size_t(i)] = uint16_t(std::lround(std::clamp(e / kSheenTableScale, 0.0, 1.0) * 65535.0));
  }
  std::lock_guard<std::mutex> lock(mutex);
  cache.emplace(alpha, t);
  return t;
}

void prepare_sheen(Material& m) {
  const std::array<uint16_t, kMaterialTable> t = sheen_albedo_table(mr_sheen_alpha(m));
  std::copy(t.begin(), t.end(), std::begin(m.table));
}

Material make_rough_plastic(RGB diffuse, float eta, float alpha, bool beckmann, RGB specular) {
  Material m;
  m.type = MaterialType::kRoughPlastic;
  m.diffuse = diffuse;
  m.eta = eta;
  m.specular = specular;
  m.alpha_x = m.alpha_y = std::max(alpha, 1e-4f);  // GGX's and Beckmann's D divide by alpha^2
  if (beckmann) m.flags |= kBeckmann;
  prepare_rough_plastic(m);
  return m;
}

void set_alpha(Material& m, float ax, float ay) {
  m.alpha_x = ax != ay ? maxf(ax, 1e-4f) : ax;
  m.alpha_y = ax != ay ? maxf(ay, 1e-4f) : ay;
}

float diffuse_fresnel_reflectance(float eta) {
  // Midpoint rule in mu; F is smooth except at the critical angle, and 4096
  // steps put the error far below float precision of its use.
  const int n = 4096;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    double mu = (i + 0.5) / n;
    sum += fresnel_dielectric(float(mu), eta) * mu;
  }
  return float(2.0 * sum / n);
}

Camera make_camera(const CameraDesc& c) {
  auto look_at = [&](Vec3f position, Vec3f target, Vec3f up) {
    CameraPose p;
    p.position = position;
    p.forward = normalize(target - position);
    p.right = normalize(cross(p.forward, up));
    p.up = cross(p.right, p.forward);
    if (c.flip_x) p.right = -p.right;
    return p;
  };
  CameraPose open = look_at(c.position, c.target, c.up), close = open;
  if (c.moving) {
    // The keyframes are times 0 and 1; the shutter's ends are poses between them.
    CameraPose p0 = open, p1 = look_at(c.position1, c.target1, c.up1);
    open = interpolate_pose(p0, p1, c.shutter_open);
    close = interpolate_pose(p0, p1, c.shutter_close);
  }
  Camera cam;
  cam.position = open.position;
  cam.forward = open.forward;
  cam.right = open.right;
  cam.up = open.up;
  cam.moving = c.moving && c.shutter_close > c.shutter_open &&
               (length_sq(close.position - open.position) > 0.f || length_sq(close.forward - open.forward) > 0.f ||
                length_sq(close.up - open.up) > 0.f);
  if (cam.moving) cam.close_pose = close;
  cam.width = c.width;
  cam.height = c.height;
  // Half the view across fov_axis: at distance 1 (perspective) or in scene units (orthographic).
  float t = c.orthographic ? 0.5f * c.view_size : std::tan(0.5f * c.fov_degrees * kPi / 180.f);
  cam.orthographic = c.orthographic;
  float aspect = float(c.width) / float(c.height);
  bool x_axis = c.fov_axis == CameraDesc::FovAxis::kX ||
                (c.fov_axis == CameraDesc::FovAxis::kSmaller && c.width < c.height);
  if (x_axis) {
    cam.tan_half_x = t;
    cam.tan_half_y = t / aspect;
  } else {
    cam.tan_half_y = t;
    cam.tan_half_x = t * aspect;
  }
  if (const std::string why = crop_problem(c); !why.empty()) throw InputError(why);
  // The principal point moves the whole film's window on the image plane (raster +x right, +y down).
  cam.shift_x = 2.f * c.principal_point.x * cam.tan_half_x;
  cam.shift_y = -2.f * c.principal_point.y * cam.tan_half_y;
  if (c.crop_width > 0) {
    // The crop's part of the image plane: its size and the offset of its centre from the film's.
    const float W = float(c.width), H = float(c.height);
    cam.shift_x += cam.tan_half_x * (2.f * (float(c.crop_x) + 0.5f * float(c.crop_width)) / W - 1.f);
    cam.shift_y += cam.tan_half_y * (1.f - 2.f * (float(c.crop_y) + 0.5f * float(c.crop_height)) / H);
    cam.tan_half_x *= float(c.crop_width) / W;
    cam.tan_half_y *= float(c.crop_height) / H;
    cam.width = c.crop_width;
    cam.height = c.crop_height;
    cam.crop_x = uint32_t(c.crop_x);
    cam.crop_y = uint32_t(c.crop_y);
    cam.film_width = uint32_t(c.width);
  }
  if (!(c.near_clip >= 0.f) || !(c.far_clip > c.near_clip)) {
    char msg[160];
    std::snprintf(msg, sizeof msg, "the camera's clipping planes need 0 <= near_clip < far_clip (got %g and %g)",
                  double(c.near_clip), double(c.far_clip));
    throw InputError(msg);
  }
  cam.near_clip = c.near_clip;
  cam.far_clip = c.far_clip;
  cam.aperture_radius = c.orthographic ? 0.f : c.aperture_radius;
  cam.focus_distance = c.focus_distance > 0.f ? c.focus_distance : length(c.target - c.position);
  return cam;
}

void generate_tangents(MeshDesc& m) {
  const size_t n = m.positions.size();
  if (m.normals.size() != n || m.uvs.size() != n) return;
  std::vector<Vec3f> tsum(n, Vec3f(0.f)), bsum(n, Vec3f(0.f));
  std::vector<uint8_t> hand(n, 0);  // bit 0: a triangle with +1 handedness met the vertex, bit 1: one with -1
  for (size_t k = 0; k + 2 < m.indices.size(); k += 3) {
    const uint32_t ix[3] = {m.indices[k], m.indices[k + 1], m.indices[k + 2]};
    if (ix[0] >= n || ix[1] >= n || ix[2] >= n) continue;
    Vec3f p0 = m.positions[ix[0]], p1 = m.positions[ix[1]], p2 = m.positions[ix[2]];
    Vec2f t0 = m.uvs[ix[0]], t1 = m.uvs[ix[1]], t2 = m.uvs[ix[2]];
    float du1 = t1.x - t0.x, dv1 = t1.y - t0.y, du2 = t2.x - t0.x, dv2 = t2.y - t0.y;
    float det = du1 * dv2 - dv1 * du2;
    if (!(std::fabs(det) > 1e-20f)) continue;
    Vec3f e1 = p1 - p0, e2 = p2 - p0;
    Vec3f dpdu = (e1 * dv2 - e2 * dv1) / det, dpdv = (e2 * du1 - e1 * du2) / det;
    if (!isfinite3(dpdu) || !isfinite3(dpdv)) continue;
    const Vec3f pts[3] = {p0, p1, p2};
    for (int c = 0; c < 3; ++c) {
      Vec3f a = pts[(c + 1) % 3] - pts[c], b = pts[(c + 2) % 3] - pts[c];
      float la = length(a), lb = length(b);
      if (!(la > 0.f) || !(lb > 0.f)) continue;
      float angle = std::acos(clampf(dot(a, b) / (la * lb), -1.f, 1.f));
      Vec3f nv = m.normals[ix[c]];
      Vec3f t = dpdu - nv * dot(nv, dpdu), bt = dpdv - nv * dot(nv, dpdv);
      if (!(length_sq(t) > 0.f) || !(length_sq(bt) > 0.f)) continue;
      tsum[ix[c]] += normalize(t) * angle;
      bsum[ix[c]] += normalize(bt) * angle;
      hand[ix[c]] |= dot(cross(nv, t), bt) >= 0.f ? 1 : 2;
    }
  }
  m.tangents.assign(n, Tangent{});
  for (size_t i = 0; i < n; ++i) {
    if (hand[i] != 1 && hand[i] != 2) continue;  // no triangle, or a mirrored seam: w = 0
    Vec3f nv = m.normals[i];
    Vec3f t = tsum[i] - nv * dot(nv, tsum[i]);
    float l2 = length_sq(t);
    if (!(l2 > 1e-12f * length_sq(tsum[i])) || !std::isfinite(l2)) continue;
    m.tangents[i] = Tangent{t / std::sqrt(l2), hand[i] == 1 ? 1.f : -1.f};
  }
}

namespace {
// Mean luminance of a texture's texels (textured area lights' power).
float texture_mean_luminance(const TextureView& t) {
  double sum = 0.0;
  size_t n = size_t(t.width) * size_t(t.height);
  for (size_t i = 0; i < n; ++i) sum += luminance(RGB(t.rgba[4 * i], t.rgba[4 * i + 1], t.rgba[4 * i + 2]));
  return n ? float(sum / double(n)) : 0.f;
}
}  // namespace

float light_power(const SceneView& s, const Light& l) {
  float lum = luminance(l.L);
  if (l.type == LightType::kEnvironment && l.texture >= 0) {
    // Mean radiance over the sphere: (1/4pi) int L dw = (1/4pi) 2 pi^2 int L sin(theta) du dv.
    lum *= 0.5f * kPi * s.envmap.integral;
  }
  // (Textured area lights: Scene::build multiplies by the texture's mean.)
  float R = s.bsphere_radius;
  switch (l.type) {
    case LightType::kTriangle: {
      const uint32_t* ix = s.indices + 3 * l.prim;
      float a = triangle_area(s.positions[ix[0]], s.positions[ix[1]], s.positions[ix[2]]);
      return kPi * a * lum * (l.two_sided ? 2.f : 1.f);
    }
    case LightType::kSphere: {
      float r = s.spheres[l.prim - s.num_triangles].radius;
      return kPi * 4.f * kPi * r * r * lum * (l.two_sided ? 2.f : 1.f);
    }
    case LightType::kPoint: return 4.f * kPi * lum;
    case LightType::kSpot: {
      // 2 pi lum times the integral of spot_falloff over cos(theta): the inner cone's 1 - cos(start), plus the
      // band's. Smoothstep in cos: half the band, (cos start - cos total) / 2. Linear in the angle from a = start
      // to b = total: the integral of (b - theta) / (b - a) sin(theta) over [a, b], cos a - (sin b - sin a) / (b - a).
      if (!l.spot_linear_angle || !(l.cos_falloff_start > l.cos_total))
        return 2.f * kPi * lum * (1.f - 0.5f * (l.cos_falloff_start + l.cos_total));
      const double a = std::acos(double(l.cos_falloff_start)), b = std::acos(double(l.cos_total));
      return float(2.0 * kPi * lum * (1.0 - (std::sin(b) - std::sin(a)) / (b - a)));
    }
    case LightType::kDirectional: return kPi * R * R * lum;
    case LightType::kEnvironment: return 4.f * kPi * kPi * R * R * lum;
  }
  return 0.f;
}

namespace {

struct Mat3 {
  double m[3][3];
};
Mat3 linear_part(const Affine& a) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j];
  return r;
}
double det3(const Mat3& a) {
  const auto& m = a.m;
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}
// Inverse transpose (cofactor matrix / det), for normals.
Mat3 inverse_transpose(const Mat3& a) {
  const auto& m = a.m;
  double d = det3(a);
  Mat3 c;
  c.m[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / d;
  c.m[0][1] = -(m[1][0] * m[2][2] - m[1][2] * m[2][0]) / d;
  c.m[0][2] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / d;
  c.m[1][0] = -(m[0][1] * m[2][2] - m[0][2] * m[2][1]) / d;
  c.m[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / d;
  c.m[1][2] = -(m[0][0] * m[2][1] - m[0][1] * m[2][0]) / d;
  c.m[2][0] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / d;
  c.m[2][1] = -(m[0][0] * m[1][2] - m[0][2] * m[1][0]) / d;
  c.m[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / d;
  return c;
}
Vec3f apply(const Mat3& a, Vec3f v) {
  return Vec3f(float(a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z),
               float(a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z),
               float(a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z));
}

// Local meshes of the parametric shapes.
MeshDesc rectangle_mesh() {
  MeshDesc m;
  m.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // upright seen from +z (the normal's side)
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}
MeshDesc cube_mesh() {
  MeshDesc m;
  const Vec3f axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int a = 0; a < 3; ++a) {
    for (int sgn = -1; sgn <= 1; sgn += 2) {
      Vec3f n = axes[a] * float(sgn);
      Vec3f u = axes[(a + 1) % 3], v = cross(n, u);  // u x v = n
      uint32_t base = uint32_t(m.positions.size());
      m.positions.push_back(n - u - v);
      m.positions.push_back(n + u - v);
      m.positions.push_back(n + u + v);
      m.positions.push_back(n - u + v);
      for (Vec2f t : {Vec2f(0, 0), Vec2f(1, 0), Vec2f(1, 1), Vec2f(0, 1)}) m.uvs.push_back(t);  // the face's (u, v)
      for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
    }
  }
  return m;
}
MeshDesc disk_mesh() {
  MeshDesc m;
  const int n = 128;
  m.positions.push_back({0, 0, 0});
  m.uvs.push_back({0.5f, 0.5f});
  for (int i = 0; i < n; ++i) {
    float phi = 2.f * kPi * i / n;
    m.positions.push_back({std::cos(phi), std::sin(phi), 0.f});
    m.uvs.push_back({0.5f + 0.5f * std::cos(phi), 0.5f + 0.5f * std::sin(phi)});  // planar: the image on the plate
  }
  for (int i = 0; i < n; ++i) {
    m.indices.push_back(0);
    m.indices.push_back(1 + i);
    m.indices.push_back(1 + (i + 1) % n);
  }
  return m;
}

// ---- The light BVH (light/light_bvh.h; pbrt-v4 Sec. 12.6.3): its nodes built on the host.
struct LightBoundsHost {
  Bounds3 b;
  Vec3f w{0, 0, 1};
  float cos_o = 1.f, cos_e = 0.f, phi = 0.f;
  bool two_sided = false;
};

// pbrt-v4's DirectionCone::Union: the smallest cone (from the two axes' plane) holding both cones.
void cone_union(Vec3f wa, float cos_a, Vec3f wb, float cos_b, Vec3f& w, float& cos_o) {
  auto angle = [](float c) { return std::acos(std::clamp(c, -1.f, 1.f)); };
  const float ta = angle(cos_a), tb = angle(cos_b), td = angle(dot(wa, wb));
  if (std::min(td + tb, kPi) <= ta) { w = wa; cos_o = cos_a; return; }
  if (std::min(td + ta, kPi) <= tb) { w = wb; cos_o = cos_b; return; }
  const float to = 0.5f * (ta + td + tb);
  Vec3f wr = cross(wa, wb);
  if (to >= kPi || length_sq(wr) == 0.f) { w = wa; cos_o = -1.f; return; }
  wr = normalize(wr);
  const float tr = to - ta;  // rotate wa towards wb by tr about wr (Rodrigues)
  w = normalize(wa * std::cos(tr) + cross(wr, wa) * std::sin(tr) + wr * (dot(wr, wa) * (1.f - std::cos(tr))));
  cos_o = std::cos(to);
}

LightBoundsHost merge_bounds(const LightBoundsHost& a, const LightBoundsHost& b) {
  if (!(a.phi > 0.f)) return b;
  if (!(b.phi > 0.f)) return a;
  LightBoundsHost m;
  m.b = a.b;
  m.b.extend(b.b);
  cone_union(a.w, a.cos_o, b.w, b.cos_o, m.w, m.cos_o);
  m.cos_e = std::min(a.cos_e, b.cos_e);
  m.phi = a.phi + b.phi;
  m.two_sided = a.two_sided || b.two_sided;
  return m;
}

// pbrt-v4's M_Omega: the solid-angle measure of the directions the cone (theta_o) and its spread (theta_e) cover.
float cone_measure(float cos_o, float cos_e) {
  const float to = std::acos(std::clamp(cos_o, -1.f, 1.f)), te = std::acos(std::clamp(cos_e, -1.f, 1.f));
  const float tw = std::min(to + te, kPi), so = std::sin(to);
  return 2.f * kPi * (1.f - cos_o) + 0.5f * kPi * (2.f * tw * so - std::cos(to - 2.f * tw) - 2.f * to * so + cos_o);
}

float surface_area(const Bounds3& b) {
  const Vec3f d = b.hi - b.lo;
  return 2.f * (d.x * d.y + d.y * d.z + d.z * d.x);
}

// Builds the subtree over items [begin, end) (light index, bounds); pbrt-v4's split: over the three axes, 12
// buckets of the centroids, the cost phi * M_Omega * surface area (times the box's aspect for the axis).
void build_light_bvh_node(std::vector<std::pair<uint32_t, LightBoundsHost>>& items, size_t begin, size_t end,
                          uint64_t trail, int depth, Scene& s) {
  LightBoundsHost all;
  Bounds3 cb;
  for (size_t i = begin; i < end; ++i) {
    all = merge_bounds(all, items[i].second);
    cb.extend(items[i].second.b.centroid());
  }
  const uint32_t index = uint32_t(s.light_bvh_nodes.size());
  LightBvhNode node;
  node.c = (all.b.lo + all.b.hi) * 0.5f;
  node.r = 0.5f * length(all.b.hi - all.b.lo);
  node.w = all.w;
  node.cos_o = all.cos_o;
  node.sin_o = std::sqrt(std::max(0.f, 1.f - all.cos_o * all.cos_o));
  node.cos_e = all.cos_e;
  node.phi = all.phi;
  node.flags = all.two_sided ? LightBvhNode::kTwoSided : 0u;
  if (end - begin == 1) {
    node.flags |= LightBvhNode::kLeaf;
    node.child = items[begin].first;
    s.light_bvh_nodes.push_back(node);
    s.light_bvh_trail[items[begin].first] = trail;
    return;
  }
  s.light_bvh_nodes.push_back(node);
  size_t mid = begin + (end - begin) / 2;
  constexpr int kBuckets = 12;
  const Vec3f ext = all.b.hi - all.b.lo, cext = cb.hi - cb.lo;
  const float max_ext = std::max(ext.x, std::max(ext.y, ext.z));
  float best = kInf;
  int best_dim = -1, best_split = -1;
  for (int dim = 0; dim < 3 && depth < 60; ++dim) {
    if (!(cext[dim] > 0.f)) continue;
    auto bucket_of = [&](const LightBoundsHost& lb) {
      int k = int(kBuckets * (lb.b.centroid()[dim] - cb.lo[dim]) / cext[dim]);
      return std::clamp(k, 0, kBuckets - 1);
    };
    LightBoundsHost buckets[kBuckets];
    for (size_t i = begin; i < end; ++i) {
      LightBoundsHost& bk = buckets[bucket_of(items[i].second)];
      bk = merge_bounds(bk, items[i].second);
    }
    const float kr = ext[dim] > 0.f ? max_ext / ext[dim] : 1.f;
    auto cost = [&](const LightBoundsHost& lb) {
      return lb.phi > 0.f ? lb.phi * cone_measure(lb.cos_o, lb.cos_e) * kr * surface_area(lb.b) : 0.f;
    };
    for (int split = 0; split < kBuckets - 1; ++split) {
      LightBoundsHost lo_b, hi_b;
      bool lo_any = false, hi_any = false;
      for (int k = 0; k <= split; ++k) lo_b = merge_bounds(lo_b, buckets[k]), lo_any |= buckets[k].phi > 0.f;
      for (int k = split + 1; k < kBuckets; ++k) hi_b = merge_bounds(hi_b, buckets[k]), hi_any |= buckets[k].phi > 0.f;
      if (!lo_any || !hi_any) continue;
      const float c = cost(lo_b) + cost(hi_b);
      if (c < best) {
        best = c;
        best_dim = dim;
        best_split = split;
      }
    }
    if (best_dim == dim) {
      auto it = std::partition(items.begin() + long(begin), items.begin() + long(end),
                               [&](const auto& x) { return bucket_of(x.second) <= best_split; });
      mid = size_t(it - items.begin());
    }
  }
  if (mid == begin || mid == end) mid = begin + (end - begin) / 2;
  build_light_bvh_node(items, begin, mid, trail, depth + 1, s);
  s.light_bvh_nodes[index].child = uint32_t(s.light_bvh_nodes.size());
  build_light_bvh_node(items, mid, end, trail | (uint64_t(1) << depth), depth + 1, s);
}

// Walker/Vose alias table over non-negative weights.
void build_alias(const std::vector<float>& w, std::vector<float>& prob, std::vector<uint32_t>& alias,
                 std::vector<float>& pmf) {
  size_t n = w.size();
  prob.assign(n, 1.f);
  alias.resize(n);
  pmf.resize(n);
  double total = 0.0;
  for (float x : w) total += x;
  std::vector<double> scaled(n);
  for (size_t i = 0; i < n; ++i) {
    pmf[i] = total > 0 ? float(w[i] / total) : 1.f / float(n);
    scaled[i] = total > 0 ? w[i] * n / total : 1.0;
    alias[i] = uint32_t(i);
  }
  std::vector<uint32_t> small, large;
  for (size_t i = 0; i < n; ++i) (scaled[i] < 1.0 ? small : large).push_back(uint32_t(i));
  while (!small.empty() && !large.empty()) {
    uint32_t s = small.back(), l = large.back();
    small.pop_back();
    large.pop_back();
    prob[s] = float(scaled[s]);
    alias[s] = l;
    scaled[l] = (scaled[l] + scaled[s]) - 1.0;
    (scaled[l] < 1.0 ? small : large).push_back(l);
  }
  for (uint32_t i : large) prob[i] = 1.f;
  for (uint32_t i : small) prob[i] = 1.f;
}

}  // namespace

Scene::~Scene() = default;

namespace {

// The inverse of an affine map; false when its linear part is singular.
bool invert_affine(const Affine& a, Affine& inv) {
  const float(*m)[4] = a.m;
  const double c00 = double(m[1][1]) * m[2][2] - double(m[1][2]) * m[2][1];
  const double c01 = double(m[1][2]) * m[2][0] - double(m[1][0]) * m[2][2];
  const double c02 = double(m[1][0]) * m[2][1] - double(m[1][1]) * m[2][0];
  const double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
  if (!(std::fabs(det) > 1e-30) || !std::isfinite(det)) return false;
  const double r = 1.0 / det;
  double b[3][3];
  b[0][0] = c00 * r;
  b[1][0] = c01 * r;
  b[2][0] = c02 * r;
  b[0][1] = (double(m[0][2]) * m[2][1] - double(m[0][1]) * m[2][2]) * r;
  b[1][1] = (double(m[0][0]) * m[2][2] - double(m[0][2]) * m[2][0]) * r;
  b[2][1] = (double(m[0][1]) * m[2][0] - double(m[0][0]) * m[2][1]) * r;
  b[0][2] = (double(m[0][1]) * m[1][2] - double(m[0][2]) * m[1][1]) * r;
  b[1][2] = (double(m[0][2]) * m[1][0] - double(m[0][0]) * m[1][2]) * r;
  b[2][2] = (double(m[0][0]) * m[1][1] - double(m[0][1]) * m[1][0]) * r;
  for (int i = 0; i < 3; ++i) {
    double t = 0.0;
    for (int j = 0; j < 3; ++j) {
      inv.m[i][j] = float(b[i][j]);
      t -= b[i][j] * m[j][3];
    }
    inv.m[i][3] = float(t);
  }
  return true;
}

}  // namespace

// The density grids of heterogeneous media (medium/medium_grid.h), checked: sizes, finite samples >= 0, an
// invertible placement.
void build_medium_grids(const SceneDesc& desc, std::vector<MediumGrid>& grids, std::vector<float>& values) {
  grids.clear();
  values.clear();
  for (size_t i = 0; i < desc.grids.size(); ++i) {
    const MediumGridDesc& gd = desc.grids[i];
    const std::string name = "density grid '" + (gd.name.empty() ? std::to_string(i) : gd.name) + "'";
    if (gd.nx <= 0 || gd.ny <= 0 || gd.nz <= 0)
      throw InputError(name + ": expected a resolution of at least 1 x 1 x 1");
    if (gd.channels != 1 && gd.channels != 3)
      throw InputError(name + ": " + std::to_string(gd.channels) + " channels (expected 1 or 3)");
    const size_t cells = size_t(gd.nx) * size_t(gd.ny) * size_t(gd.nz), n = cells * size_t(gd.channels);
    if (gd.values.size() != n)
      throw InputError(name + ": expected " + std::to_string(n) + " samples (" + std::to_string(gd.nx) + " x " +
                       std::to_string(gd.ny) + " x " + std::to_string(gd.nz) +
                       (gd.channels > 1 ? " x " + std::to_string(gd.channels) + " channels" : std::string()) +
                       "), got " + std::to_string(gd.values.size()));
    if (values.size() + n > size_t(UINT32_MAX)) throw InputError(name + ": the grids hold more than 2^32 samples");
    MediumGrid g;
    g.nx = uint32_t(gd.nx);
    g.ny = uint32_t(gd.ny);
    g.nz = uint32_t(gd.nz);
    g.channels = uint32_t(gd.channels);
    g.offset = uint32_t(values.size());
    g.nearest = gd.nearest ? 1u : 0u;
    g.clamp = gd.clamp ? 1u : 0u;
    if (!invert_affine(gd.to_world, g.world_to_grid)) throw InputError(name + ": its transform is singular");
    for (size_t k = 0; k < n; ++k) {
      const float v = gd.values[k];
      if (!(v >= 0.f) || !std::isfinite(v))
        throw InputError(name + ": sample " + std::to_string(k) + " is " + std::to_string(v) +
                         " (expected finite densities >= 0)");
      g.max_density = std::max(g.max_density, v);
    }
    values.insert(values.end(), gd.values.begin(), gd.values.end());
    // The majorant grid: per coarse cell, the largest sample (of any channel) that a lookup in it can read
    // (trilinear reads floor(q n - 1/2) and the next; one more on each side for the rounding of q near a
    // cell's faces).
    g.mx = majorant_res(g.nx);
    g.my = majorant_res(g.ny);
    g.mz = majorant_res(g.nz);
    g.maj_offset = uint32_t(values.size());
    auto range = [](uint32_t c, uint32_t m, int n, int& lo, int& hi) {
      lo = std::max(0, int(std::floor(double(c) / m * n - 0.5)) - 1);
      hi = std::min(n - 1, int(std::floor(double(c + 1) / m * n - 0.5)) + 2);
    };
    for (uint32_t k = 0; k < g.mz; ++k)
      for (uint32_t j = 0; j < g.my; ++j)
        for (uint32_t i = 0; i < g.mx; ++i) {
          int x0, x1, y0, y1, z0, z1;
          range(i, g.mx, gd.nx, x0, x1);
          range(j, g.my, gd.ny, y0, y1);
          range(k, g.mz, gd.nz, z0, z1);
          float mx = 0.f;
          for (int z = z0; z <= z1; ++z)
            for (int y = y0; y <= y1; ++y)
              for (int x = x0; x <= x1; ++x)
                for (int ch = 0; ch < gd.channels; ++ch) {
                  const size_t cell = (size_t(z) * gd.ny + size_t(y)) * gd.nx + size_t(x);
                  mx = std::max(mx, gd.values[cell * gd.channels + ch]);
                }
          values.push_back(mx);
        }
    if (values.size() > size_t(UINT32_MAX)) throw InputError(name + ": the grids hold more than 2^32 samples");
    grids.push_back(g);
  }
}

std::shared_ptr<Scene> Scene::build(const SceneDesc& desc) {
  std::shared_ptr<Scene> sc(new Scene());
  Scene& s = *sc;
  s.desc_ = desc;
  s.materials = desc.materials;
  if (s.materials.empty()) throw InputError("scene '" + desc.name + "' has no materials");
  for (Material& m : s.materials)
    if (m.type == MaterialType::kPlastic || m.type == MaterialType::kMetallicRoughness) m.fdr_int = diffuse_fresnel_reflectance(1.f / m.eta);
  for (Material& m : s.materials)
    if (m.type == MaterialType::kRoughPlastic) prepare_rough_plastic(m);  // its coat tables
    else if (m.type == MaterialType::kMetallicRoughness && mr_has_sheen(m)) prepare_sheen(m);  // its albedo table
  // A sheen roughness texture: the tables of kSheenRows alphas, between which the hit's is interpolated.
  if (std::any_of(s.materials.begin(), s.materials.end(), [](const Material& m) {
        return m.type == MaterialType::kMetallicRoughness && m.tex_sheen_roughness >= 0;
      }))
    for (int k = 0; k < kSheenRows; ++k) {
      const std::array<uint16_t, kMaterialTable> t = sheen_albedo_table(mr_sheen_row_alpha(k));
      s.sheen_table.insert(s.sheen_table.end(), t.begin(), t.end());
    }

  for (Material& m : s.materials) {
    for (int t : material_textures(m))
      if (t >= int(desc.textures.size())) throw InputError("scene '" + desc.name + "': texture index out of range");
    if (!(m.opacity >= 0.f && m.opacity <= 1.f) || !(m.opacity_cutoff <= 1.f))
      throw InputError("scene '" + desc.name + "': a material's opacity must be in [0, 1] and its cutoff at most 1");
    // Cut-outs are tested in the ray queries (scene/opacity.h) only where a material has them.
    if (m.mix_b >= 0 && (m.mix_a < 0 || size_t(m.mix_a) >= s.materials.size() || size_t(m.mix_b) >= s.materials.size() ||
                         !(m.mix_weight >= 0.f && m.mix_weight <= 1.f)))
      throw InputError("scene '" + desc.name + "': a blend's materials must exist and its weight be in [0, 1]");
    m.flags &= ~uint32_t(kAlphaTested);
    if (m.opacity < 1.f || m.tex_opacity >= 0) m.flags |= kAlphaTested;
  }
  {
    // Blends inside blends: no cycles, and at most kMaxMixDepth deep (what resolve_material resolves).
    std::vector<int> depth(s.materials.size(), -1);  // -2: being visited
    std::function<int(size_t)> visit = [&](size_t i) -> int {
      const Material& m = s.materials[i];
      if (m.mix_b < 0) return 0;
      if (depth[i] == -2) throw InputError("scene '" + desc.name + "': a blend contains itself");
      if (depth[i] >= 0) return depth[i];
      depth[i] = -2;
      depth[i] = 1 + std::max(visit(size_t(m.mix_a)), visit(size_t(m.mix_b)));
      return depth[i];
    };
    for (size_t i = 0; i < s.materials.size(); ++i)
      if (visit(i) > int(kMaxMixDepth))
        throw InputError("scene '" + desc.name + "': blends nest more than " + std::to_string(kMaxMixDepth) + " deep");
  }
  {
    // Pairs of sides: both sides' materials reflect only (a surface seen from both sides lets nothing
    // through), and the back's are evaluated as if seen from their front: resolve_material hands the back to
    // rays arriving from behind, so each back is replaced by a copy with kTwoSided (blends below it copied
    // the same way; the copies are appended, the description keeps its materials).
    std::function<void(int32_t)> check = [&](int32_t i) {
      const Material& m = s.materials[size_t(i)];
      if (m.mix_b >= 0) {
        check(m.mix_a);
        check(m.mix_b);
      } else if (material_is_transmissive(m) || m.type == MaterialType::kNull) {
        throw InputError("scene '" + desc.name + "': the materials of a pair of sides must reflect only (not " +
                         "transmit or be null surfaces)");
      }
    };
    std::map<int32_t, int32_t> copies;
    std::function<int32_t(int32_t)> two_sided = [&](int32_t i) -> int32_t {
      auto found = copies.find(i);
      if (found != copies.end()) return found->second;
      Material m = s.materials[size_t(i)];
      if (m.mix_b >= 0) {
        m.mix_a = two_sided(m.mix_a);
        m.mix_b = two_sided(m.mix_b);
      } else if (m.flags & kTwoSided) {
        return copies[i] = i;
      }
      m.flags |= kTwoSided;  // on a blend's entry it changes nothing
      s.materials.push_back(m);
      return copies[i] = int32_t(s.materials.size() - 1);
    };
    const size_t n = s.materials.size();
    for (size_t i = 0; i < n; ++i)
      if (s.materials[i].flags & kSides) {
        if (s.materials[i].mix_b < 0) throw InputError("scene '" + desc.name + "': a pair of sides needs two materials");
        check(int32_t(i));
        const int32_t back = two_sided(s.materials[i].mix_b);
        s.materials[i].mix_b = back;
      }
  }
  struct PendingArea {
    uint32_t prim;  // triangle index or sphere index (offset later)
    bool sphere;
    RGB L;
    bool two_sided;
    int texture;
  };
  std::vector<PendingArea> area;
  std::vector<uint32_t> sphere_material;
  std::vector<MediumInterface> sphere_medium;  // per sphere, appended to prim_medium after the triangles
  std::vector<int> sphere_shape;
  // Participating media (medium/medium.h).
  s.media = desc.media;
  for (size_t i = 0; i < s.media.size(); ++i) {
    const Medium& md = s.media[i];
    const std::string name = i < desc.medium_names.size() ? desc.medium_names[i] : std::to_string(i);
    auto ok = [](RGB c) { return isfinite3(c) && c.x >= 0.f && c.y >= 0.f && c.z >= 0.f; };
    if (!ok(md.sigma_a) || !ok(md.sigma_s))
      throw InputError("medium '" + name + "': sigma_a and sigma_s must be finite and >= 0");
    if (!(md.g > -1.f && md.g < 1.f)) throw InputError("medium '" + name + "': g must be in (-1, 1)");
    if (md.grid < -1 || md.grid >= int(desc.grids.size()))
      throw InputError("medium '" + name + "': density grid index out of range");
    if (md.albedo_grid < -1 || md.albedo_grid >= int(desc.grids.size()))
      throw InputError("medium '" + name + "': albedo grid index out of range");
    if (!ok(md.Le)) throw InputError("medium '" + name + "': its emission must be finite and >= 0");
    if (md.emission_grid < -1 || md.emission_grid >= int(desc.grids.size()))
      throw InputError("medium '" + name + "': emission grid index out of range");
    if (md.emission_grid >= 0 && md.grid < 0)
      throw InputError("medium '" + name + "': an emission grid needs a density grid");
    if (md.albedo_grid >= 0) {
      if (md.grid < 0) throw InputError("medium '" + name + "': an albedo grid needs a density grid");
      for (float v : desc.grids[md.albedo_grid].values)
        if (!(v <= 1.f)) throw InputError("medium '" + name + "': albedo grid sample " + std::to_string(v) +
                                          " (expected values in [0, 1])");
    }
  }
  build_medium_grids(desc, s.medium_grids, s.grid_values);
  auto medium_ok = [&](int m) { return m >= -1 && m < int(desc.media.size()); };
  if (!medium_ok(desc.camera.medium)) throw InputError("the camera's medium index is out of range");
  bool any_interface = false;
  for (const ShapeDesc& sh : desc.shapes) {
    if (!sh.medium_interface) continue;
    if (!medium_ok(sh.interior) || !medium_ok(sh.exterior))
      throw InputError("shape '" + sh.name + "': medium index out of range");
    any_interface = true;
  }
  const MeshDesc rect = rectangle_mesh(), cube = cube_mesh(), disk = disk_mesh();
  size_t skipped_index = 0, skipped_nonfinite = 0, skipped_degenerate = 0, skipped_spheres = 0;

  for (size_t si = 0; si < desc.shapes.size(); ++si) {
    const ShapeDesc& sh = desc.shapes[si];
    if (sh.emission_texture >= int(desc.textures.size()))
      throw InputError("shape '" + sh.name + "': emission texture index out of range");
    if (sh.material < 0 || size_t(sh.material) >= desc.materials.size())
      throw InputError("shape '" + sh.name + "': material index " + std::to_string(sh.material) + " out of range");
    bool emissive = max_component(sh.emission) > 0.f;
    if (sh.type == ShapeType::kSphere) {
      Mat3 l = linear_part(sh.to_world);
      Vec3f sx = apply(l, {1, 0, 0}), sy = apply(l, {0, 1, 0}), sz = apply(l, {0, 0, 1});
      float a = length(sx), b = length(sy), c = length(sz);
      if (std::fabs(a - b) > 1e-4f * a || std::fabs(a - c) > 1e-4f * a)
        throw InputError("shape '" + sh.name + "': a sphere's transform must scale uniformly");
      Sphere sp{sh.to_world.point(sh.center), sh.radius * a};
      if (!isfinite3(sp.center) || !(sp.radius > 0.f) || !std::isfinite(sp.radius)) {
        ++skipped_spheres;
        continue;
      }
      if (emissive)
        area.push_back({uint32_t(s.spheres.size()), true, sh.emission, sh.emission_two_sided, sh.emission_texture});
      s.spheres.push_back(sp);
      sphere_material.push_back(uint32_t(sh.material));
      // A flipped sphere's normal points inwards (Mitsuba's flip_normals): its interior is then outside.
      if (any_interface)
        sphere_medium.push_back(sh.flip_normals
                                    ? MediumInterface{sh.exterior, sh.interior, sh.medium_interface ? 1u : 0u}
                                    : MediumInterface{sh.interior, sh.exterior, sh.medium_interface ? 1u : 0u});
      // The sphere's axes (its transform's rotation or reflection, the scale divided out), kept only when
      // some sphere is turned: its UVs, textures and anisotropy turn with it.
      Frame axes;
      axes.s = sx / a;
      axes.t = sy / b;
      axes.n = sz / c;
      bool turned = false;
      const Vec3f id[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
      const Vec3f* ax[3] = {&axes.s, &axes.t, &axes.n};
      for (int k = 0; k < 3; ++k) turned |= length_sq(*ax[k] - id[k]) > 1e-12f;
      if (turned && s.sphere_frames.empty()) s.sphere_frames.assign(s.spheres.size() - 1, Frame());
      if (turned || !s.sphere_frames.empty()) s.sphere_frames.push_back(axes);
      continue;
    }
    const MeshDesc* mesh = nullptr;
    switch (sh.type) {
      case ShapeType::kRectangle: mesh = &rect; break;
      case ShapeType::kCube: mesh = &cube; break;
      case ShapeType::kDisk: mesh = &disk; break;
      default:
        if (sh.mesh < 0 || size_t(sh.mesh) >= desc.meshes.size())
          throw InputError("shape '" + sh.name + "': mesh index out of range");
        mesh = &desc.meshes[sh.mesh];
    }
    Mat3 lin = linear_part(sh.to_world);
    bool flip = (det3(lin) < 0.0) != sh.flip_normals;
    Mat3 nrm = inverse_transpose(lin);
    uint32_t base = uint32_t(s.positions.size());
    for (Vec3f p : mesh->positions) s.positions.push_back(sh.to_world.point(p));
    bool has_n = !mesh->normals.empty();
    bool has_uv = !mesh->uvs.empty();
    if (has_uv || !s.uvs.empty()) {
      // Meshes without UVs get zeros (a texture shows its corner texel there).
      s.uvs.resize(base, Vec2f(0.f, 0.f));
      for (size_t i = 0; i < mesh->positions.size(); ++i) s.uvs.push_back(has_uv ? mesh->uvs[i] : Vec2f(0.f, 0.f));
    }
    if (!mesh->colors.empty() || !s.colors.empty()) {
      // Meshes without vertex colours get white (a kVertexColor material keeps its own colour there).
      s.colors.resize(base, RGB(1.f));
      const bool has_c = mesh->colors.size() == mesh->positions.size();
      for (size_t i = 0; i < mesh->positions.size(); ++i) s.colors.push_back(has_c ? mesh->colors[i] : RGB(1.f));
    }
    if (!mesh->tangents.empty() || !s.tangents.empty()) {
      // A tangent moves with the surface (lin t); its handedness flips with a mirroring transform (the
      // normal goes by the inverse transpose: cross(M^-T n, M t) = det(M) M (n x t) for orthogonal M, and
      // the sign carries over to any M) and with flipped normals. Meshes without tangents get w = 0.
      s.tangents.resize(base, Tangent{});
      float wsign = ((det3(lin) < 0.0) != sh.flip_normals) ? -1.f : 1.f;
      for (size_t i = 0; i < mesh->positions.size(); ++i) {
        Tangent t = i < mesh->tangents.size() ? mesh->tangents[i] : Tangent{};
        Vec3f tw = apply(lin, t.t);
        if (t.w != 0.f && length_sq(tw) > 0.f && isfinite3(tw)) s.tangents.push_back(Tangent{normalize(tw), t.w * wsign});
        else s.tangents.push_back(Tangent{});
      }
    }
    if (has_n || !s.normals.empty()) {
      // Keep normals aligned with positions: meshes without them get zero
      // normals, which the interaction code treats as "use the geometric normal".
      s.normals.resize(base, Vec3f(0.f));
      for (size_t i = 0; i < mesh->positions.size(); ++i) {
        Vec3f n = has_n ? apply(nrm, mesh->normals[i]) : Vec3f(0.f);
        n = length_sq(n) > 0.f && isfinite3(n) ? normalize(n) : Vec3f(0.f);  // zero: use the geometric normal
        s.normals.push_back(sh.flip_normals ? -n : n);
      }
    }
    for (size_t t = 0; t + 2 < mesh->indices.size(); t += 3) {
      uint32_t i0 = mesh->indices[t], i1 = mesh->indices[t + 1], i2 = mesh->indices[t + 2];
      if (i0 >= mesh->positions.size() || i1 >= mesh->positions.size() || i2 >= mesh->positions.size()) {
        ++skipped_index;
        continue;
      }
      // Triangles that cannot be hit or sampled (non-finite after the transform, or
      // of zero area) are dropped here whatever the loader let through.
      Vec3f q0 = s.positions[base + i0], q1 = s.positions[base + i1], q2 = s.positions[base + i2];
      if (!isfinite3(q0) || !isfinite3(q1) || !isfinite3(q2)) {
        ++skipped_nonfinite;
        continue;
      }
      float tri_area = triangle_area(q0, q1, q2);
      if (!(tri_area > 0.f) || !std::isfinite(tri_area)) {
        ++skipped_degenerate;
        continue;
      }
      if (flip) std::swap(i1, i2);
      uint32_t tri = uint32_t(s.indices.size() / 3);
      s.indices.push_back(base + i0);
      s.indices.push_back(base + i1);
      s.indices.push_back(base + i2);
      s.prim_material.push_back(uint32_t(sh.material));
      if (any_interface)
        s.prim_medium.push_back(MediumInterface{sh.interior, sh.exterior, sh.medium_interface ? 1u : 0u});
      if (emissive) area.push_back({tri, false, sh.emission, sh.emission_two_sided, sh.emission_texture});
    }
  }
  if (!s.normals.empty()) s.normals.resize(s.positions.size(), Vec3f(0.f));
  auto skipped = [&](size_t n, const char* what) {
    if (n) s.desc_.warnings.push_back("scene '" + desc.name + "': skipped " + std::to_string(n) + " " + what);
  };
  skipped(skipped_index, "triangles with vertex indices out of range");
  skipped(skipped_nonfinite, "triangles with non-finite coordinates");
  skipped(skipped_degenerate, "degenerate (zero-area) triangles");
  skipped(skipped_spheres, "spheres with a non-finite centre or a radius that is not positive");
  if (!s.uvs.empty()) s.uvs.resize(s.positions.size(), Vec2f(0.f, 0.f));
  if (!s.colors.empty()) s.colors.resize(s.positions.size(), RGB(1.f));
  if (!s.tangents.empty()) s.tangents.resize(s.positions.size(), Tangent{});
  uint32_t num_tri = uint32_t(s.indices.size() / 3);
  for (uint32_t m : sphere_material) s.prim_material.push_back(m);
  for (const MediumInterface& mi : sphere_medium) s.prim_medium.push_back(mi);
  s.prim_light.assign(s.prim_material.size(), -1);

  for (const PendingArea& a : area) {
    Light l;
    l.type = a.sphere ? LightType::kSphere : LightType::kTriangle;
    l.prim = a.sphere ? num_tri + a.prim : a.prim;
    l.L = a.L;
    l.two_sided = a.two_sided ? 1u : 0u;
    l.texture = a.texture;
    s.prim_light[l.prim] = int32_t(s.lights.size());
    s.lights.push_back(l);
  }
  int env = -1;
  for (const Light& l : desc.lights) {
    if (l.type == LightType::kTriangle || l.type == LightType::kSphere)
      throw InputError("area lights are given as emissive shapes");
    if (l.type == LightType::kEnvironment) {
      if (env >= 0) throw InputError("scene '" + desc.name + "' has more than one environment light");
      env = int(s.lights.size());
    }
    Light c = l;
    if (c.type == LightType::kSpot || c.type == LightType::kDirectional) c.dir = normalize(c.dir);
    s.lights.push_back(c);
  }

  // Bounds and the bounding sphere.
  std::vector<Bounds3> pb;
  pb.reserve(s.prim_material.size());
  for (uint32_t t = 0; t < num_tri; ++t) {
    Bounds3 b;
    for (int k = 0; k < 3; ++k) b.extend(s.positions[s.indices[3 * t + k]]);
    pb.push_back(b);
  }
  for (const Sphere& sp : s.spheres) pb.push_back(sphere_bounds(sp));
  for (const Bounds3& b : pb) s.view_.bounds.extend(b);
  if (pb.empty()) throw InputError("scene '" + desc.name + "' has no shapes");
  s.bvh = build_bvh(pb);
  s.view_.camera = make_camera(desc.camera);
  s.view_.filter = desc.filter;
  s.view_.environment_light = env;
  for (const Light& l : s.lights)
    if (l.texture >= int(desc.textures.size())) throw InputError("scene '" + desc.name + "': light texture index out of range");
  for (const TextureDesc& t : s.desc_.textures) {
    if (t.width <= 0 || t.height <= 0 || t.rgba.size() != size_t(t.width) * size_t(t.height) * 4)
      throw InputError("texture '" + t.name + "': pixel data does not match its size");
    TextureView tv;
    tv.rgba = t.rgba.data();
    tv.width = t.width;
    tv.height = t.height;
    tv.wrap_u = t.wrap_u;
    tv.wrap_v = t.wrap_v;
    tv.nearest = t.nearest ? 1u : 0u;
    tv.uv_offset = t.uv_offset;
    tv.uv_scale = t.uv_scale;
    tv.cos_rot = std::cos(t.uv_rotation);
    tv.sin_rot = std::sin(t.uv_rotation);
    s.textures.push_back(tv);
  }
  if (env >= 0 && s.lights[env].texture >= 0) s.build_envmap(s.textures[s.lights[env].texture], desc.environment_to_world);
  s.update_view();

  std::vector<float> power;
  std::vector<float> tex_mean(s.textures.size(), -1.f);
  for (const Light& l : s.lights) {
    float p = light_power(s.view_, l);
    if (l.texture >= 0 && l.type != LightType::kEnvironment) {
      float& m = tex_mean[size_t(l.texture)];
      if (m < 0.f) m = texture_mean_luminance(s.textures[size_t(l.texture)]);
      p *= m;
    }
    power.push_back(p);
  }
  if (!s.lights.empty()) build_alias(power, s.alias_prob, s.alias_index, s.light_pmf);
  {
    const SceneView& v = s.view_;
    std::vector<std::pair<uint32_t, LightBoundsHost>> items;
    s.light_bvh_trail.assign(s.lights.size(), 0);
    s.light_bvh_where.assign(s.lights.size(), kLightNotSampled);
    for (uint32_t i = 0; i < s.lights.size(); ++i) {
      const Light& l = s.lights[i];
      if (light_is_infinite(l)) {
        s.light_bvh_where[i] = kLightInfinite;
        s.light_bvh_infinite.push_back(i);
        continue;
      }
      if (!(power[i] > 0.f)) continue;
      LightBoundsHost lb;
      lb.phi = power[i];
      lb.cos_e = 0.f;  // area lights emit over the hemisphere about a normal; points in every direction
      switch (l.type) {
        case LightType::kTriangle: {
          const Vec3f p0 = s.positions[s.indices[3 * l.prim]], p1 = s.positions[s.indices[3 * l.prim + 1]],
                      p2 = s.positions[s.indices[3 * l.prim + 2]];
          lb.b.extend(p0);
          lb.b.extend(p1);
          lb.b.extend(p2);
          lb.w = normalize(cross(p1 - p0, p2 - p0));
          lb.cos_o = 1.f;
          lb.two_sided = l.two_sided != 0;
          break;
        }
        case LightType::kSphere: {
          lb.b = sphere_bounds(s.spheres[l.prim - v.num_triangles]);
          lb.cos_o = -1.f;
          break;
        }
        case LightType::kSpot:
          lb.b.extend(l.p);
          lb.w = l.dir;
          lb.cos_o = l.cos_falloff_start;
          lb.cos_e = std::cos(std::acos(std::clamp(l.cos_total, -1.f, 1.f)) -
                              std::acos(std::clamp(l.cos_falloff_start, -1.f, 1.f)));
          break;
        default:  // point
          lb.b.extend(l.p);
          lb.cos_o = -1.f;
          break;
      }
      s.light_bvh_where[i] = kLightInBvh;
      items.emplace_back(i, lb);
    }
    if (!items.empty()) build_light_bvh_node(items, 0, items.size(), 0, 0, s);
  }
  s.update_view();
  s.accel_ = std::make_unique<CpuAccel>(s.view_);
  if (s.accel_->kind() != CpuAccel::Kind::kEmbree) s.embree_ = std::make_unique<CpuAccel>(s.view_, CpuAccel::Kind::kEmbree);
  return sc;
}

// The environment map's sampling distribution (envmap.h): weights luminance *
// sin(theta) at each texel's centre row, cumulated per row and over rows.
void Scene::build_envmap(const TextureView& tex, const Affine& to_world) {
  EnvMapView& e = view_.envmap;
  e.tex = tex;
  e.tex.wrap_u = e.tex.wrap_v = TexWrap::kRepeat;  // u wraps around; v never leaves [0, 1]
  int w = tex.width, h = tex.height;
  e.width = w;
  e.height = h;
  env_func.resize(size_t(w) * h);
  env_cond_cdf.resize(size_t(w + 1) * h);
  env_marg_cdf.resize(size_t(h) + 1);
  env_marg_func.resize(size_t(h));
  // Luminance per texel, then each texel's weight: the largest value the
  // bilinear lookup takes inside it (centre, edge midpoints, corners), with u
  // wrapping around and v clamped at the poles as in envmap_lookup.
  std::vector<float> lum(size_t(w) * h);
  for (size_t i = 0; i < lum.size(); ++i) {
    const float* p = tex.rgba + i * 4;
    float l = luminance(RGB(p[0], p[1], p[2]));
    lum[i] = std::isfinite(l) ? maxf(l, 0.f) : 0.f;
  }
  auto L = [&](int x, int y) {
    x = texel_wrap(x, w, TexWrap::kRepeat);
    y = texel_wrap(y, h, TexWrap::kClamp);
    return lum[size_t(y) * w + x];
  };
  for (int y = 0; y < h; ++y) {
    float st = std::sin(kPi * (y + 0.5f) / float(h));
    double row = 0.0;
    float* cdf = &env_cond_cdf[size_t(y) * (w + 1)];
    cdf[0] = 0.f;
    for (int x = 0; x < w; ++x) {
      float m = L(x, y);
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0) continue;
          float v = dx != 0 && dy != 0 ? 0.25f * (L(x, y) + L(x + dx, y) + L(x, y + dy) + L(x + dx, y + dy))
                                       : 0.5f * (L(x, y) + L(x + dx, y + dy));
          m = maxf(m, v);
        }
      float f = m * st;
      if (!std::isfinite(f)) f = 0.f;
      env_func[size_t(y) * w + x] = f;
      row += f;
      cdf[x + 1] = float(row);
    }
    for (int x = 1; x <= w; ++x) cdf[x] = row > 0.0 ? float(cdf[x] / row) : float(x) / float(w);
    cdf[w] = 1.f;
    env_marg_func[y] = float(row / w);
  }
  double total = 0.0;
  env_marg_cdf[0] = 0.f;
  for (int y = 0; y < h; ++y) {
    total += env_marg_func[y];
    env_marg_cdf[y + 1] = float(total);
  }
  for (int y = 1; y <= h; ++y) env_marg_cdf[y] = total > 0.0 ? float(env_marg_cdf[y] / total) : float(y) / float(h);
  env_marg_cdf[h] = 1.f;
  e.integral = float(total / h);
  // Rotation only: normalise the columns' lengths away and invert by transposing
  // after Gram-Schmidt, so a scaled to_world still maps directions sensibly.
  Vec3f c0 = to_world.vector(Vec3f(1, 0, 0)), c1 = to_world.vector(Vec3f(0, 1, 0));
  c0 = normalize(c0);
  c1 = normalize(c1 - c0 * dot(c1, c0));
  Vec3f c2 = cross(c0, c1);
  if (dot(c2, to_world.vector(Vec3f(0, 0, 1))) < 0.f) c2 = -c2;  // keep a mirrored frame mirrored
  Affine tw, tl;
  const Vec3f cols[3] = {c0, c1, c2};
  for (int j = 0; j < 3; ++j) {
    const float v[3] = {cols[j].x, cols[j].y, cols[j].z};
    for (int i = 0; i < 3; ++i) {
      tw.m[i][j] = v[i];
      tl.m[j][i] = v[i];
    }
  }
  e.to_world = tw;
  e.to_local = tl;
}

void Scene::update_view() {
  SceneView& v = view_;
  v.positions = positions.data();
  v.normals = normals.empty() ? nullptr : normals.data();
  v.uvs = uvs.empty() ? nullptr : uvs.data();
  v.colors = colors.empty() ? nullptr : colors.data();
  v.tangents = tangents.empty() ? nullptr : tangents.data();
  v.textures = textures.data();
  v.num_textures = uint32_t(textures.size());
  if (v.environment_light >= 0 && lights[v.environment_light].texture >= 0) {
    v.envmap.func = env_func.data();
    v.envmap.cond_cdf = env_cond_cdf.data();
    v.envmap.marg_cdf = env_marg_cdf.data();
    v.envmap.marg_func = env_marg_func.data();
  }
  v.indices = indices.data();
  v.num_triangles = uint32_t(indices.size() / 3);
  v.spheres = spheres.data();
  v.sphere_frames = sphere_frames.empty() ? nullptr : sphere_frames.data();
  v.num_spheres = uint32_t(spheres.size());
  v.prim_material = prim_material.data();
  v.prim_light = prim_light.data();
  v.materials = materials.data();
  v.sheen_table = sheen_table.empty() ? nullptr : sheen_table.data();
  v.alpha_tested = 0;
  for (const Material& m : materials) v.alpha_tested |= m.flags & kAlphaTested ? 1u : 0u;
  v.media = media.empty() ? nullptr : media.data();
  v.num_media = uint32_t(media.size());
  v.prim_medium = prim_medium.empty() ? nullptr : prim_medium.data();
  v.camera_medium = desc_.camera.medium;
  v.medium_grids = medium_grids.empty() ? nullptr : medium_grids.data();
  v.grid_values = grid_values.empty() ? nullptr : grid_values.data();
  v.has_null = 0;
  for (const Material& m : materials) v.has_null |= m.type == MaterialType::kNull ? 1u : 0u;
  v.lights = lights.data();
  v.num_lights = uint32_t(lights.size());
  v.num_point_lights = 0;
  for (const Light& l : lights) v.num_point_lights += l.type == LightType::kPoint || l.type == LightType::kSpot;
  v.light_sampler = {alias_prob.data(), alias_index.data(), light_pmf.data(), uint32_t(light_pmf.size())};
  v.light_bvh.nodes = light_bvh_nodes.data();
  v.light_bvh.num_nodes = uint32_t(light_bvh_nodes.size());
  v.light_bvh.trail = light_bvh_trail.data();
  v.light_bvh.where = light_bvh_where.data();
  v.light_bvh.infinite = light_bvh_infinite.data();
  v.light_bvh.num_infinite = uint32_t(light_bvh_infinite.size());
  v.bsphere_center = v.bounds.centroid();
  v.bsphere_radius = 0.5f * length(v.bounds.diagonal());
  v.bvh = bvh.view();
}

const CpuAccel& Scene::cpu_accel(const std::string& accel) const {
  if (accel == "embree") return embree();
  if (accel == "small" && accel_->kind() != CpuAccel::Kind::kSmall)
    throw InputError("--accel small takes scenes of at most " + std::to_string(SmallAccel::kMaxTriangles) +
                     " triangles and " + std::to_string(CpuAccel::kMaxSmallSpheres) +
                     " spheres without cut-outs (opacity) on a CPU with AVX2; " +
                     "this one has " + std::to_string(view_.num_triangles) + " triangles and " +
                     std::to_string(view_.num_spheres) + " spheres" + (view_.alpha_tested ? ", and cut-outs" : "") +
                     (SmallAccel::available() ? "" : ", and this CPU lacks AVX2"));
  return *accel_;
}

void Scene::set_resolution(int width, int height) {
  CameraDesc c = desc_.camera;
  c.width = width;
  c.height = height;
  view_.camera = make_camera(c);  // throws (and changes nothing) if the crop window no longer fits
  desc_.camera = c;
}

void Scene::set_crop(int x, int y, int width, int height) {
  CameraDesc c = desc_.camera;
  c.crop_x = x;
  c.crop_y = y;
  c.crop_width = width;
  c.crop_height = height;
  view_.camera = make_camera(c);
  desc_.camera = c;
}

std::string crop_problem(const CameraDesc& c) {
  if (c.crop_width == 0 && c.crop_height == 0 && c.crop_x == 0 && c.crop_y == 0) return "";
  auto str = [](int v) { return std::to_string(v); };
  if (c.crop_width <= 0 || c.crop_height <= 0 || c.crop_x < 0 || c.crop_y < 0 ||
      int64_t(c.crop_x) + c.crop_width > c.width || int64_t(c.crop_y) + c.crop_height > c.height)
    return "the crop window (x " + str(c.crop_x) + ", y " + str(c.crop_y) + ", width " + str(c.crop_width) +
           ", height " + str(c.crop_height) + ") does not fit the " + str(c.width) + "x" + str(c.height) +
           " film (expected x, y >= 0, width, height > 0, x + width <= " + str(c.width) + ", y + height <= " +
           str(c.height) + ")";
  return "";
}

}  // namespace caustica
