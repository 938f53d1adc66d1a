// Image textures on the device side: linear RGBA floats, row 0 = the top row
// of the image; uv (0,0) is the bottom-left corner (v up), the convention of
// OBJ, Mitsuba and pbrt. Bilinear filtering between texel centres (or the
// nearest texel), with repeat / clamp / mirror wrapping, after the uv
// transform uv' = R(rotation) (scale * uv) + offset (KHR_texture_transform).
#pragma once
#include <cstdint>
#include "../base/math.h"

namespace caustica {

enum class TexWrap : uint32_t { kRepeat = 0, kClamp, kMirror };

struct TextureView {
  const float* rgba = nullptr;
  int32_t width = 0, height = 0;
  TexWrap wrap_u = TexWrap::kRepeat, wrap_v = TexWrap::kRepeat;  // along u (glTF's wrapS) and v (wrapT)
  uint32_t nearest = 0;
  Vec2f uv_offset{0.f, 0.f}, uv_scale{1.f, 1.f};
  float cos_rot = 1.f, sin_rot = 0.f;
};

struct RGBA {
  float r = 0.f, g = 0.f, b = 0.f, a = 0.f;
  CHD RGB rgb() const { return RGB(r, g, b); }
};

CHD int texel_wrap(int i, int n, TexWrap w) {
  switch (w) {
    case TexWrap::kClamp: return i < 0 ? 0 : (i >= n ? n - 1 : i);
    case TexWrap::kMirror: {
      int p = 2 * n;
      int m = i % p;
      if (m < 0) m += p;
      return m < n ? m : p - 1 - m;
    }
    default: {
      int m = i % n;
      return m < 0 ? m + n : m;
    }
  }
}

CHD RGBA texel(const TextureView& t, int x, int y) {
  x = texel_wrap(x, t.width, t.wrap_u);
  y = texel_wrap(y, t.height, t.wrap_v);
  const float* p = t.rgba + (size_t(y) * size_t(t.width) + size_t(x)) * 4;
  return {p[0], p[1], p[2], p[3]};
}

CHD Vec2f texture_uv(const TextureView& t, Vec2f uv) {
  Vec2f s(uv.x * t.uv_scale.x, uv.y * t.uv_scale.y);
  return Vec2f(t.cos_rot * s.x - t.sin_rot * s.y + t.uv_offset.x, t.sin_rot * s.x + t.cos_rot * s.y + t.uv_offset.y);
}

CHD RGBA texture_lookup(const TextureView& t, Vec2f uv_in) {
  Vec2f uv = texture_uv(t, uv_in);
  // Continuous texel coordinates: x right, y down from the top row.
  float x = uv.x * float(t.width), y = (1.f - uv.y) * float(t.height);
  if (!(std::isfinite(x) && std::isfinite(y))) return {};
  if (t.nearest) return texel(t, int(std::floor(x)), int(std::floor(y)));
  x -= 0.5f;
  y -= 0.5f;
  float fx = std::floor(x), fy = std::floor(y);
  int x0 = int(fx), y0 = int(fy);
  float dx = x - fx, dy = y - fy;
  RGBA a = texel(t, x0, y0), b = texel(t, x0 + 1, y0), c = texel(t, x0, y0 + 1), d = texel(t, x0 + 1, y0 + 1);
  float wa = (1.f - dx) * (1.f - dy), wb = dx * (1.f - dy), wc = (1.f - dx) * dy, wd = dx * dy;
  return {wa * a.r + wb * b.r + wc * c.r + wd * d.r, wa * a.g + wb * b.g + wc * c.g + wd * d.g,
          wa * a.b + wb * b.b + wc * c.b + wd * d.b, wa * a.a + wb * b.a + wc * c.a + wd * d.a};
}

// The gradient (d/du, d/dv, v up) of the texture's luminance (Rec. 709 weights, what Mitsuba 3's eval_1 reads
// from an RGB bitmap) at uv_in: the slope of the bilinear interpolant over the texel cell that holds uv (also
// for nearest lookups, whose piecewise-constant height would have none), through the uv transform
// (uv' = R S uv + o, so d/duv = S R^T d/duv').
CHD Vec2f texture_luminance_gradient(const TextureView& t, Vec2f uv_in) {
  Vec2f uv = texture_uv(t, uv_in);
  float x = uv.x * float(t.width) - 0.5f, y = (1.f - uv.y) * float(t.height) - 0.5f;
  if (!(std::isfinite(x) && std::isfinite(y))) return Vec2f(0.f, 0.f);
  float fx = std::floor(x), fy = std::floor(y);
  int x0 = int(fx), y0 = int(fy);
  float dx = x - fx, dy = y - fy;
  auto lum = [&](int xi, int yi) {
    RGBA c = texel(t, xi, yi);
    return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b;
  };
  float a = lum(x0, y0), b = lum(x0 + 1, y0), c = lum(x0, y0 + 1), d = lum(x0 + 1, y0 + 1);
  float ddx = (1.f - dy) * (b - a) + dy * (d - c), ddy = (1.f - dx) * (c - a) + dx * (d - b);
  Vec2f g(ddx * float(t.width), -ddy * float(t.height));  // x grows with u, y against v
  Vec2f gs(t.cos_rot * g.x + t.sin_rot * g.y, -t.sin_rot * g.x + t.cos_rot * g.y);
  return Vec2f(gs.x * t.uv_scale.x, gs.y * t.uv_scale.y);
}

}  // namespace caustica
