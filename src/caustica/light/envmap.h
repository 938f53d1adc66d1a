// Equirectangular environment map with importance sampling.
// Mapping (Mitsuba 3's `envmap` convention, in the light's local frame, y up):
//   direction d = (sin(theta) sin(phi), cos(theta), -sin(theta) cos(phi)),
//   u = phi / (2 pi) (image column from the left), theta = pi * (image row from the top),
// so the texture's v (bottom = 0) is 1 - theta / pi.
// Lookups are bilinear (repeating in u, clamped at the poles).
// Sampling: a piecewise-constant 2D distribution over the image's texels with
// weights M * sin(theta), where M is the largest luminance the bilinear lookup
// takes inside the texel (the maximum over its centre, edge midpoints and
// corners), so radiance / density stays bounded even next to a one-texel sun
// (pbrt-v4 Sec. A.5.6 "Piecewise-Constant 2D Distributions"; pbrt-v4
// Sec. 12.5.2 "ImageInfiniteLight" builds its distribution from the filtered
// image for the same reason): the marginal
// density picks a row, the conditional a column, both inverted through their
// CDFs. The solid-angle density is p(u, v) / (2 pi^2 sin(theta)) (the Jacobian
// of the mapping, pbrt-v4 Eq. 12.13 with Mitsuba's axes).
#pragma once
#include "../base/math.h"
#include "../texture/texture.h"

namespace caustica {

struct EnvMapView {
  TextureView tex;
  const float* func = nullptr;      // height x width sampling weights (row 0 = top)
  const float* cond_cdf = nullptr;  // height x (width + 1)
  const float* marg_cdf = nullptr;  // height + 1
  const float* marg_func = nullptr; // height: each row's integral over u
  float integral = 0.f;             // integral of func over [0,1]^2
  int32_t width = 0, height = 0;
  Affine to_world, to_local;        // rotations (linear parts only)
};

// Index i with cdf[i] <= u < cdf[i+1] among n bins (cdf has n + 1 entries, cdf[n] = 1).
CHD int find_interval(const float* cdf, int n, float u) {
  int lo = 0, hi = n;  // invariant: cdf[lo] <= u, answer < hi
  while (hi - lo > 1) {
    int mid = (lo + hi) / 2;
    if (cdf[mid] <= u) lo = mid;
    else hi = mid;
  }
  return lo;
}

CHD Vec3f envmap_direction_local(Vec2f uv_img) {  // uv_img: (column fraction, row fraction from the top)
  float phi = 2.f * kPi * uv_img.x, theta = kPi * uv_img.y;
  float st = std::sin(theta);
  return Vec3f(st * std::sin(phi), std::cos(theta), -st * std::cos(phi));
}
CHD Vec2f envmap_image_uv(Vec3f d_local) {
  float u = std::atan2(d_local.x, -d_local.z) * (0.5f * kInvPi);
  if (u < 0.f) u += 1.f;
  float v = std::acos(clampf(d_local.y, -1.f, 1.f)) * kInvPi;
  return Vec2f(u, v);
}

// Bilinear lookup at image coordinates (u from the left, v from the top), wrapping
// around in u and clamping at the poles in v.
CHD RGB envmap_texel(const EnvMapView& e, int x, int y) {
  x = texel_wrap(x, e.width, TexWrap::kRepeat);
  y = texel_wrap(y, e.height, TexWrap::kClamp);
  const float* p = e.tex.rgba + (size_t(y) * size_t(e.width) + size_t(x)) * 4;
  return RGB(p[0], p[1], p[2]);
}
CHD RGB envmap_lookup(const EnvMapView& e, Vec2f uv_img) {
  float x = uv_img.x * float(e.width) - 0.5f, y = uv_img.y * float(e.height) - 0.5f;
  float fx = std::floor(x), fy = std::floor(y);
  int x0 = int(fx), y0 = int(fy);
  float dx = x - fx, dy = y - fy;
  return envmap_texel(e, x0, y0) * ((1.f - dx) * (1.f - dy)) + envmap_texel(e, x0 + 1, y0) * (dx * (1.f - dy)) +
         envmap_texel(e, x0, y0 + 1) * ((1.f - dx) * dy) + envmap_texel(e, x0 + 1, y0 + 1) * (dx * dy);
}

// Radiance of the map (before the light's scale) arriving from world direction -w, i.e. seen along w.
CHD RGB envmap_eval(const EnvMapView& e, Vec3f w_world) {
  return envmap_lookup(e, envmap_image_uv(normalize(e.to_local.vector(w_world))));
}

CHD float envmap_pdf(const EnvMapView& e, Vec3f w_world) {
  if (e.integral <= 0.f) return 0.f;
  Vec3f d = normalize(e.to_local.vector(w_world));
  Vec2f uv = envmap_image_uv(d);
  float st = safe_sqrt(1.f - d.y * d.y);
  if (st <= 0.f) return 0.f;
  int x = minf(int(uv.x * float(e.width)), e.width - 1);
  int y = minf(int(uv.y * float(e.height)), e.height - 1);
  float p_uv = e.func[size_t(y) * size_t(e.width) + size_t(x)] / e.integral;
  return p_uv / (2.f * kPi * kPi * st);
}

// Samples a world direction towards the map; returns false for a black map.
CHD bool envmap_sample(const EnvMapView& e, Vec2f u, Vec3f& w_world, float& pdf) {
  if (e.integral <= 0.f) return false;
  int y = find_interval(e.marg_cdf, e.height, u.y);
  float dy = e.marg_cdf[y + 1] - e.marg_cdf[y];
  float fy = dy > 0.f ? (u.y - e.marg_cdf[y]) / dy : 0.5f;
  const float* cdf = e.cond_cdf + size_t(y) * size_t(e.width + 1);
  int x = find_interval(cdf, e.width, u.x);
  float dx = cdf[x + 1] - cdf[x];
  float fx = dx > 0.f ? (u.x - cdf[x]) / dx : 0.5f;
  Vec2f uv((float(x) + clampf(fx, 0.f, 1.f)) / float(e.width), (float(y) + clampf(fy, 0.f, 1.f)) / float(e.height));
  Vec3f d = envmap_direction_local(uv);
  float st = std::sin(kPi * uv.y);
  if (st <= 0.f) return false;
  float p_uv = e.func[size_t(y) * size_t(e.width) + size_t(x)] / e.integral;
  pdf = p_uv / (2.f * kPi * kPi * st);
  w_world = normalize(e.to_world.vector(d));
  return pdf > 0.f;
}

}  // namespace caustica
