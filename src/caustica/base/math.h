// Small vector algebra shared by the CPU and the GPU: Vec2f, Vec3f (also used as
// linear RGB), orthonormal frames, and the scalar helpers the BSDFs need.
#pragma once
#include <cmath>
#include <cstdint>
#include "host_device.h"

namespace caustica {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInvPi = 0.31830988618379067154f;
constexpr float kInv2Pi = 0.15915494309189533577f;
constexpr float kInv4Pi = 0.07957747154594766788f;
constexpr float kInf = INFINITY;
// Largest float strictly below 1: the upper end of every [0,1) sample.
constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

CHD float clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }
CHD float minf(float a, float b) { return a < b ? a : b; }
CHD float maxf(float a, float b) { return a > b ? a : b; }
CHD float sqr(float x) { return x * x; }
CHD float safe_sqrt(float x) { return std::sqrt(maxf(x, 0.f)); }
CHD float lerpf(float t, float a, float b) { return (1.f - t) * a + t * b; }
// sin x and cos x for |x| <= pi/4 (the range the concentric disk mapping needs):
// Taylor polynomials through x^9 and x^10 in Horner form. The truncation error
// is below x^11/11! = 1.7e-9 and x^12/12! = 1.1e-10 at pi/4, under float's
// rounding. It replaces a library call with general range reduction (sincosf
// was a third of the cosine-hemisphere warp's time in a profile of `cornell`),
// and runs alike on CPU and GPU. tests/cpp/test_warps.cpp compares with
// std::sin/std::cos. Written once for float and the CPU's eight-lane vectors (base/lanes.h).
template <typename F>
CHD void sincos_quarter_pi_of(F x, F& s, F& c) {
  F x2 = x * x;
  s = x * (1.f + x2 * (-1.f / 6.f + x2 * (1.f / 120.f + x2 * (-1.f / 5040.f + x2 * (1.f / 362880.f)))));
  c = 1.f + x2 * (-0.5f + x2 * (1.f / 24.f + x2 * (-1.f / 720.f + x2 * (1.f / 40320.f + x2 * (-1.f / 3628800.f)))));
}
CHD void sincos_quarter_pi(float x, float& s, float& c) { sincos_quarter_pi_of(x, s, c); }

struct Vec2f {
  float x = 0, y = 0;
  Vec2f() = default;
  CHD Vec2f(float x_, float y_) : x(x_), y(y_) {}
};
CHD Vec2f operator+(Vec2f a, Vec2f b) { return {a.x + b.x, a.y + b.y}; }
CHD Vec2f operator-(Vec2f a, Vec2f b) { return {a.x - b.x, a.y - b.y}; }
CHD Vec2f operator*(Vec2f a, float s) { return {a.x * s, a.y * s}; }

struct Vec3f {
  float x = 0, y = 0, z = 0;
  Vec3f() = default;
  CHD explicit Vec3f(float v) : x(v), y(v), z(v) {}
  CHD Vec3f(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  CHD float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  CHD float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  CHD Vec3f& operator+=(Vec3f b) { x += b.x; y += b.y; z += b.z; return *this; }
  CHD Vec3f& operator-=(Vec3f b) { x -= b.x; y -= b.y; z -= b.z; return *this; }
  CHD Vec3f& operator*=(Vec3f b) { x *= b.x; y *= b.y; z *= b.z; return *this; }
  CHD Vec3f& operator*=(float s) { x *= s; y *= s; z *= s; return *this; }
  CHD Vec3f& operator/=(float s) { float r = 1.f / s; x *= r; y *= r; z *= r; return *this; }
};
// Linear RGB radiance, reflectance and power share the vector type.
using RGB = Vec3f;

CHD Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
CHD Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
CHD Vec3f operator-(Vec3f a) { return {-a.x, -a.y, -a.z}; }
CHD Vec3f operator*(Vec3f a, Vec3f b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
CHD Vec3f operator/(Vec3f a, Vec3f b) { return {a.x / b.x, a.y / b.y, a.z / b.z}; }
CHD Vec3f operator*(Vec3f a, float s) { return {a.x * s, a.y * s, a.z * s}; }
CHD Vec3f operator*(float s, Vec3f a) { return {a.x * s, a.y * s, a.z * s}; }
CHD Vec3f operator/(Vec3f a, float s) { float r = 1.f / s; return {a.x * r, a.y * r, a.z * r}; }
CHD float dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
CHD float absdot(Vec3f a, Vec3f b) { return std::fabs(dot(a, b)); }
CHD Vec3f cross(Vec3f a, Vec3f b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
CHD float length_sq(Vec3f a) { return dot(a, a); }
CHD float length(Vec3f a) { return std::sqrt(dot(a, a)); }
CHD Vec3f normalize(Vec3f a) { return a / length(a); }
CHD Vec3f vmin(Vec3f a, Vec3f b) { return {minf(a.x, b.x), minf(a.y, b.y), minf(a.z, b.z)}; }
CHD Vec3f vmax(Vec3f a, Vec3f b) { return {maxf(a.x, b.x), maxf(a.y, b.y), maxf(a.z, b.z)}; }
CHD Vec3f vabs(Vec3f a) { return {std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)}; }
CHD float max_component(Vec3f a) { return maxf(a.x, maxf(a.y, a.z)); }
CHD float min_component(Vec3f a) { return minf(a.x, minf(a.y, a.z)); }
CHD float average(Vec3f a) { return (a.x + a.y + a.z) * (1.f / 3.f); }
CHD bool is_black(Vec3f a) { return a.x == 0.f && a.y == 0.f && a.z == 0.f; }
// The largest magnitude of a component (Russian roulette on throughputs that a pixel filter's negative lobe
// made negative: film/filter.h).
CHD float max_abs_component(Vec3f a) { return maxf(std::fabs(a.x), maxf(std::fabs(a.y), std::fabs(a.z))); }
// Each component at least 0 (rounding below 0 set to 0).
CHD Vec3f max0(Vec3f a) { return {a.x > 0.f ? a.x : 0.f, a.y > 0.f ? a.y : 0.f, a.z > 0.f ? a.z : 0.f}; }
CHD Vec3f vsqrt(Vec3f a) { return {safe_sqrt(a.x), safe_sqrt(a.y), safe_sqrt(a.z)}; }
CHD Vec3f vexp(Vec3f a) { return {std::exp(a.x), std::exp(a.y), std::exp(a.z)}; }
// Rec. 709 luminance (the weights SmallVCM and pbrt use).
CHD float luminance(RGB c) { return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z; }
CHD Vec3f face_forward(Vec3f n, Vec3f v) { return dot(n, v) < 0.f ? -n : n; }
CHD Vec3f reflect(Vec3f wo, Vec3f n) { return -wo + 2.f * dot(wo, n) * n; }
CHD bool isfinite3(Vec3f a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

// Orthonormal basis around a unit normal (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited", Listing 3): no branch on a near-zero component.
struct Frame {
  Vec3f s, t, n;
  CHD Frame() : s(1, 0, 0), t(0, 1, 0), n(0, 0, 1) {}
  CHD explicit Frame(Vec3f nn) : n(nn) {
    float sign = std::copysign(1.f, nn.z);
    float a = -1.f / (sign + nn.z);
    float b = nn.x * nn.y * a;
    s = Vec3f(1.f + sign * nn.x * nn.x * a, sign * b, -sign * nn.x);
    t = Vec3f(b, sign + nn.y * nn.y * a, -nn.y);
  }
  CHD Vec3f to_local(Vec3f v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
  CHD Vec3f to_world(Vec3f v) const { return s * v.x + t * v.y + n * v.z; }
};

// Spherical coordinates in a local frame whose normal is +z.
CHD float cos_theta(Vec3f w) { return w.z; }
CHD float abs_cos_theta(Vec3f w) { return std::fabs(w.z); }
CHD float cos2_theta(Vec3f w) { return w.z * w.z; }
CHD float sin2_theta(Vec3f w) { return maxf(0.f, 1.f - w.z * w.z); }
CHD float tan2_theta(Vec3f w) { return sin2_theta(w) / cos2_theta(w); }
CHD bool same_hemisphere(Vec3f a, Vec3f b) { return a.z * b.z > 0.f; }

// Row-major 3x4 affine transform, p' = M p + t.
struct Affine {
  float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  CHD Vec3f point(Vec3f p) const {
    return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
  }
  CHD Vec3f vector(Vec3f v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
};

}  // namespace caustica
