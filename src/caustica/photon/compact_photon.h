// A 16-byte photon record for the photon maps, and its encoding and decoding.
//
//   position  3 x 16 bits, quantized inside the bounds of the photon map (PhotonQuantizer);
//   direction 2 x 16 bits, octahedral encoding (Cigolle, Donow, Evangelakos, Mara, McGuire and Meyer 2014,
//             "A Survey of Efficient Representations for Independent Unit Vectors", JCGT 3(2), Sec. 3.6
//             and the "precise" encoder of their supplement: of the four roundings of the octahedral
//             coordinates, the one that decodes closest to the input);
//   power     shared-exponent RGB: the encoding algorithm of the OpenGL EXT_texture_shared_exponent spec
//             (RGB9E5: three 9-bit mantissas, one shared exponent, round to nearest), with the exponent
//             field widened from 5 to 8 bits (bias 127). Plain RGB9E5 tops out at 65408, and photon powers
//             in caustica are a light's whole flux (and the stochastic hash grid multiplies them by a
//             photon count), so they exceed it; with 8 bits the range is [2^-137, 3.4e38], about float's;
//   flags     the two bits of PhotonFlags (kPhotonCaustic, kPhotonDirect); kPhotonVolume is dropped (volume
//             photons have maps of their own);
//   segments  the photon's segments from the light (photon.h's photon_segments) in 11 bits, the six of the
//             exponent word's top and the five above the mantissas, saturating at 2047: exact for every
//             photon of a render with max depth up to 2048 (its photon paths are shorter), and beyond that a
//             photon of more than 2047 segments reads 2047.
//
// Worst-case errors of a round trip (each is checked on random photons in tests/cpp/test_photon_map.cpp):
//
//   position  per axis at most half a quantization step, step = extent / 65535, plus float rounding:
//             |p' - p| <= (0.5 + 2^-6) * step + 2 ulp(max(|lo|, |hi|)) on each axis, for p inside the
//             bounds (outside they are clamped to the bounds). The 2^-6 step covers the float rounding of
//             (p - lo) * scale, whose relative error (a few 2^-24) times at most 65535 steps is < 0.01 step.
//             An axis of zero extent (photons on an axis-aligned plane) is stored exactly as lo.
//   direction angle(w', w) <= 3 / (32767 sqrt 2) = 6.47e-5 rad (0.0037 degrees). Derivation: the snorm16
//             grid has step h = 1/32767 in the octahedral square [-1,1]^2; rounding each coordinate to
//             nearest moves the point by |dp| <= h / sqrt 2 (the precise encoder picks among the four
//             roundings, nearest included, so does no worse). The square maps to the octahedron
//             |x|+|y|+|z| = 1 piecewise linearly and continuously (the fold of the lower half is an
//             isometry of the square), with n = (x, y, 1 - |x| - |y|) on the upper half:
//             |dn|^2 = dx^2 + dy^2 + (sx dx + sy dy)^2 <= 3 |dp|^2, so |dn| <= sqrt 3 |dp|. Normalizing
//             moves the angle by at most |dn| / |n|, and |n| >= 1/sqrt 3 (the face centres). So the angle
//             is at most sqrt 3 * sqrt 3 * h / sqrt 2 = 3h / sqrt 2; float rounding adds ~1e-7.
//             The test measures the largest error over random directions, the poles and the seams.
//   power     per channel |c' - c| <= maxc / 511.5 (about 2^-9 of the largest channel maxc): the shared
//             exponent puts maxc / denom in [256, 512), rounding to nearest errs by denom / 2, and when the
//             largest mantissa rounds up to 512 the exponent grows by one (denom doubles, maxc >= 511.5 of
//             the old denom). Below 2^-128 (the smallest exponent) the error is at most 2^-137 absolute.
//             Negative and NaN channels become 0, values above 511 * 2^119 are clamped to it.
//             Rounding to nearest is deterministic: photons of equal power all carry the same relative
//             error, so an image made from them is biased by up to that much (0.2%).
//
// Everything here is CHD: no std containers, callable from CUDA kernels.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>
#include "../base/host_device.h"
#include "../base/math.h"
#include "../geometry/ray.h"
#include "photon.h"

namespace caustica {

// Maps positions inside a box to 16-bit integers per axis and back.
struct PhotonQuantizer {
  Vec3f lo;            // the box's low corner
  Vec3f scale{0.f};    // 65535 / extent per axis (0 for an axis of zero extent)
  Vec3f step{0.f};     // extent / 65535 per axis: the quantization step
};

// The quantizer of a box (an empty box gives the zero quantizer at the origin).
CHD PhotonQuantizer make_photon_quantizer(const Bounds3& b) {
  PhotonQuantizer q;
  if (b.empty()) return q;
  q.lo = b.lo;
  for (int a = 0; a < 3; ++a) {
    float ext = b.hi[a] - b.lo[a];
    if (ext > 0.f) {
      q.scale[a] = 65535.f / ext;
      q.step[a] = ext / 65535.f;
    }
  }
  return q;
}

// The squared distance used by every photon-map query and by the tests' brute force, written once so that
// all of them round the same way.
CHD float photon_dist2(Vec3f a, Vec3f b) {
  float dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
  return dx * dx + dy * dy + dz * dz;
}

struct CompactPhoton {
  uint16_t q[3];       // quantized position
  uint16_t oct[2];     // octahedral direction, snorm16 stored as value + 32767 (0..65534)
  uint16_t exp_flags;  // bits 0-7: shared exponent of the power; bits 8-9: PhotonFlags; 10-15: segments' low 6
  uint32_t rgb;        // power mantissas: r bits 0-8, g bits 9-17, b bits 18-26; bits 27-31: segments' high 5
};
static_assert(sizeof(CompactPhoton) <= 16, "CompactPhoton must fit in 16 bytes");

// ---------------------------------------------------------------------------------------------------------
// Position

CHD uint16_t quantize_coord(float x, float lo, float scale) {
  float u = (x - lo) * scale + 0.5f;
  u = u > 0.f ? u : 0.f;  // also maps NaN to 0
  return u >= 65535.f ? uint16_t(65535) : uint16_t(u);
}

CHD float dequantize_coord(uint16_t q, float lo, float step) { return lo + float(q) * step; }

CHD void encode_position(Vec3f p, const PhotonQuantizer& qz, uint16_t out[3]) {
  out[0] = quantize_coord(p.x, qz.lo.x, qz.scale.x);
  out[1] = quantize_coord(p.y, qz.lo.y, qz.scale.y);
  out[2] = quantize_coord(p.z, qz.lo.z, qz.scale.z);
}

CHD Vec3f decode_position(const uint16_t q[3], const PhotonQuantizer& qz) {
  return {dequantize_coord(q[0], qz.lo.x, qz.step.x), dequantize_coord(q[1], qz.lo.y, qz.step.y),
          dequantize_coord(q[2], qz.lo.z, qz.step.z)};
}

// ---------------------------------------------------------------------------------------------------------
// Direction: octahedral encoding (Cigolle et al. 2014)

CHD float sign_not_zero(float v) { return v < 0.f ? -1.f : 1.f; }

// Decodes snorm16 octahedral coordinates (values in [-32767, 32767]) to a unit vector.
CHD Vec3f oct_decode_snorm(int32_t ix, int32_t iy) {
  float x = float(ix) * (1.f / 32767.f), y = float(iy) * (1.f / 32767.f);
  Vec3f v(x, y, 1.f - std::fabs(x) - std::fabs(y));
  if (v.z < 0.f) {
    float ox = (1.f - std::fabs(y)) * sign_not_zero(x);
    float oy = (1.f - std::fabs(x)) * sign_not_zero(y);
    v.x = ox;
    v.y = oy;
  }
  return normalize(v);
}

CHD int32_t clamp_snorm16(int32_t v) { return v < -32767 ? -32767 : (v > 32767 ? 32767 : v); }

// Encodes a unit vector (a zero or non-finite one becomes +z) to two uint16 (snorm16 + 32767).
CHD void oct_encode(Vec3f w, uint16_t out[2]) {
  float l1 = std::fabs(w.x) + std::fabs(w.y) + std::fabs(w.z);
  if (!(l1 > 0.f) || !(l1 < kInf)) {
    out[0] = out[1] = 32767;
    return;
  }
  float x = w.x / l1, y = w.y / l1;
  if (w.z < 0.f) {
    float ox = (1.f - std::fabs(y)) * sign_not_zero(x);
    float oy = (1.f - std::fabs(x)) * sign_not_zero(y);
    x = ox;
    y = oy;
  }
  float fx = clampf(x, -1.f, 1.f) * 32767.f, fy = clampf(y, -1.f, 1.f) * 32767.f;
  int32_t x0 = int32_t(std::floor(fx)), y0 = int32_t(std::floor(fy));
  // The "precise" encoder: of the four roundings (floor/ceil per axis) keep the one closest in angle,
  // measured by the squared chord |w' - w|^2 = 2 - 2 cos(angle) (monotonic in the angle). Not by the dot
  // product: near 1 its float rounding (6e-8) exceeds 1 - cos of the angles involved (~1e-9), which made
  // the choice random and the error worse than plain rounding.
  Vec3f wn = w / std::sqrt(dot(w, w));
  int32_t best_x = clamp_snorm16(x0), best_y = clamp_snorm16(y0);
  float best = kInf;
  for (int dy = 0; dy <= 1; ++dy) {
    for (int dx = 0; dx <= 1; ++dx) {
      int32_t cx = clamp_snorm16(x0 + dx), cy = clamp_snorm16(y0 + dy);
      float c = length_sq(oct_decode_snorm(cx, cy) - wn);
      if (c < best) {
        best = c;
        best_x = cx;
        best_y = cy;
      }
    }
  }
  out[0] = uint16_t(best_x + 32767);
  out[1] = uint16_t(best_y + 32767);
}

CHD Vec3f oct_decode(const uint16_t in[2]) { return oct_decode_snorm(int32_t(in[0]) - 32767, int32_t(in[1]) - 32767); }

// ---------------------------------------------------------------------------------------------------------
// Power: shared-exponent RGB (EXT_texture_shared_exponent's algorithm, N = 9 mantissa bits, exponent
// widened to 8 bits with bias B = 127; see the top of the file).

constexpr int kSharedExpMantissaBits = 9;
constexpr int kSharedExpBias = 127;
constexpr int kSharedExpMax = 255;
// (2^N - 1) / 2^N * 2^(Emax - B): the largest representable channel, 511 * 2^119.
constexpr float kSharedExpMaxValue = 511.f * 0x1p119f;

struct SharedExpRGB {
  uint32_t rgb;  // r | g << 9 | b << 18
  uint32_t exp;  // 0..255
};

CHD float shared_exp_clamp(float c) {
  // NaN and negative values become 0, as the spec's clamp does.
  return c > 0.f ? (c < kSharedExpMaxValue ? c : kSharedExpMaxValue) : 0.f;
}

CHD SharedExpRGB encode_shared_exp(RGB c) {
  float r = shared_exp_clamp(c.x), g = shared_exp_clamp(c.y), b = shared_exp_clamp(c.z);
  float maxc = maxf(r, maxf(g, b));
  // floor(log2(maxc)) exactly: frexp gives maxc = f 2^e with f in [0.5, 1). (The spec's log2 may round up
  // just below a power of two; the maxm == 2^N test below would catch that, frexp avoids it.)
  int e2 = 0;
  if (maxc > 0.f) {
    (void)std::frexp(maxc, &e2);
    e2 -= 1;
  } else {
    e2 = -kSharedExpBias - 1;
  }
  int exp_shared = (e2 < -kSharedExpBias - 1 ? -kSharedExpBias - 1 : e2) + 1 + kSharedExpBias;
  // c / denom with denom = 2^(exp_shared - B - N): a power-of-two scaling, exact.
  int shift = kSharedExpBias + kSharedExpMantissaBits - exp_shared;
  uint32_t maxm = uint32_t(std::floor(std::ldexp(maxc, shift) + 0.5f));
  if (maxm == (1u << kSharedExpMantissaBits)) {
    exp_shared += 1;
    shift -= 1;
  }
  uint32_t rm = uint32_t(std::floor(std::ldexp(r, shift) + 0.5f));
  uint32_t gm = uint32_t(std::floor(std::ldexp(g, shift) + 0.5f));
  uint32_t bm = uint32_t(std::floor(std::ldexp(b, shift) + 0.5f));
  // (exp_shared cannot pass Emax: maxc <= 511 2^119 gives e2 <= 127, exp_shared <= 255, and maxm rounds
  // up to 512 only above 511.5 2^119.)
  return {rm | (gm << 9) | (bm << 18), uint32_t(exp_shared)};
}

// 2^e as a float, for e in [-126, 127], built from its bits (ldexp is a library call on the CPU).
CHD float exp2_int(int e) {
  uint32_t bits = uint32_t(e + 127) << 23;
#if defined(__CUDA_ARCH__)
  return __uint_as_float(bits);
#else
  float f;
  std::memcpy(&f, &bits, sizeof(f));
  return f;
#endif
}

// The most segments a record keeps (header comment).
constexpr uint32_t kCompactMaxSegments = 2047;

CHD RGB decode_shared_exp(uint32_t rgb, uint32_t exp) {
  int shift = int(exp) - kSharedExpBias - kSharedExpMantissaBits;
  // m 2^shift is exact either way (m < 2^9, and the result is >= 2^-136 > float's smallest denormal).
  float s = shift >= -126 ? exp2_int(shift) : std::ldexp(1.f, shift);
  return {float(rgb & 511u) * s, float((rgb >> 9) & 511u) * s, float((rgb >> 18) & 511u) * s};
}

// ---------------------------------------------------------------------------------------------------------
// The whole record

CHD CompactPhoton encode_photon(const Photon& ph, const PhotonQuantizer& qz) {
  CompactPhoton c;
  encode_position(ph.p, qz, c.q);
  oct_encode(ph.wi, c.oct);
  SharedExpRGB s = encode_shared_exp(ph.power);
  const uint32_t seg = photon_segments(ph) < kCompactMaxSegments ? photon_segments(ph) : kCompactMaxSegments;
  c.rgb = s.rgb | (seg >> 6) << 27;
  c.exp_flags = uint16_t(s.exp | ((ph.flags & 3u) << 8) | (seg & 63u) << 10);
  return c;
}

// Photon::flags of a record: its PhotonFlags bits and its segments.
CHD uint32_t compact_flags(const CompactPhoton& c) {
  const uint32_t seg = (uint32_t(c.exp_flags) >> 10) | (c.rgb >> 27) << 6;
  return ((uint32_t(c.exp_flags) >> 8) & 3u) | photon_segment_bits(seg);
}
CHD RGB compact_power(const CompactPhoton& c) { return decode_shared_exp(c.rgb, c.exp_flags & 255u); }

CHD Photon decode_photon(const CompactPhoton& c, const PhotonQuantizer& qz) {
  Photon ph;
  ph.p = decode_position(c.q, qz);
  ph.wi = oct_decode(c.oct);
  ph.power = compact_power(c);
  ph.flags = compact_flags(c);
  return ph;
}

}  // namespace caustica
