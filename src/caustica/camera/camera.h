// Perspective camera (pinhole or thin lens) or orthographic camera. The field
// of view spans the smaller image axis, as in Mitsuba's default. Raster (0,0) is
// the top-left corner; image right is the camera's `right` axis and image up its
// `up` axis.
// Thin lens: Kolb et al. 1995 / pbrt-v4 Sec. 5.2.3 - rays from a point on the
// lens disk of radius aperture_radius through the point of the pinhole ray at
// distance focus_distance along the view axis.
// Orthographic (pbrt-v4 Sec. 5.2.1, Mitsuba 3's `orthographic`): parallel rays
// along `forward` from the plane through `position` spanned by `right` and `up`,
// over [-tan_half_x, tan_half_x] x [-tan_half_y, tan_half_y] in scene units.
//
// Crop window (Mitsuba 3's crop_offset/crop_size, pbrt-v4's pixel bounds): a
// camera that renders pixels [crop_x, crop_x + w) x [crop_y, crop_y + h) of a
// W x H film is a w x h camera whose image-plane window is that part of the
// film's: tan_half scaled by w / W and h / H and the window's centre shifted by
// (shift_x, shift_y) (make_camera). Pixels keep their size, so every pixel's
// rays, importance and footprint are those of the uncropped film's pixel, and its
// samples are seeded by its index in the uncropped film (film_pixel).
//
// Clipping planes (Mitsuba 3's near_clip / far_clip, glTF's znear / zfar):
// camera rays start where they cross the plane at depth near_clip along the
// view axis and end at depth far_clip; a light vertex is seen only between
// them (camera_project), and nothing nearer than near_clip occludes it.
// Measured from the lens plane (the pinhole, or the orthographic camera's
// plane), as in Mitsuba, so a thin-lens ray from lens point o along unit d
// starts at o + d near_clip / d_z.
//
// Motion blur (camera motion): a moving camera holds its pose at shutter open
// and at shutter close; a ray's time u in [0, 1) picks the pose in between, the
// position interpolated linearly and the orientation by spherical linear
// interpolation of unit quaternions (Shoemake 1985, "Animating rotation with
// quaternion curves"; pbrt-v4 Sec. 3.9's AnimatedTransform does the same for
// the rotation part), so the camera turns at a constant angular speed about one
// axis. The scene itself is static, so only camera rays (and light tracing's
// connections to the lens) carry a time; everything after the first vertex is
// the same for every time.
#pragma once
#include <cmath>
#include "../base/math.h"
#include "../base/sampling.h"
#include "../geometry/ray.h"

namespace caustica {

// Unit quaternion (w, v) of a rotation.
struct Quat {
  float w = 1.f;
  Vec3f v{0.f, 0.f, 0.f};
};

// The rotation whose matrix has columns c0, c1, c2 (orthonormal, determinant +1);
// Shepperd's method: the largest of the four squared components is taken
// from the trace or a diagonal entry, so the division is well conditioned.
CHD Quat quat_from_columns(Vec3f c0, Vec3f c1, Vec3f c2) {
  float m00 = c0.x, m11 = c1.y, m22 = c2.z, tr = m00 + m11 + m22;
  Quat q;
  if (tr > 0.f) {
    float s = 2.f * std::sqrt(tr + 1.f);  // 4 w
    q.w = 0.25f * s;
    q.v = Vec3f(c1.z - c2.y, c2.x - c0.z, c0.y - c1.x) / s;
  } else if (m00 >= m11 && m00 >= m22) {
    float s = 2.f * std::sqrt(1.f + m00 - m11 - m22);  // 4 x
    q.w = (c1.z - c2.y) / s;
    q.v = Vec3f(0.25f * s, (c1.x + c0.y) / s, (c2.x + c0.z) / s);
  } else if (m11 >= m22) {
    float s = 2.f * std::sqrt(1.f + m11 - m00 - m22);  // 4 y
    q.w = (c2.x - c0.z) / s;
    q.v = Vec3f((c1.x + c0.y) / s, 0.25f * s, (c2.y + c1.z) / s);
  } else {
    float s = 2.f * std::sqrt(1.f + m22 - m00 - m11);  // 4 z
    q.w = (c0.y - c1.x) / s;
    q.v = Vec3f((c2.x + c0.z) / s, (c2.y + c1.z) / s, 0.25f * s);
  }
  return q;
}

// Columns of the rotation matrix of unit quaternion q.
CHD void quat_to_columns(Quat q, Vec3f& c0, Vec3f& c1, Vec3f& c2) {
  float w = q.w, x = q.v.x, y = q.v.y, z = q.v.z;
  c0 = Vec3f(1.f - 2.f * (y * y + z * z), 2.f * (x * y + w * z), 2.f * (x * z - w * y));
  c1 = Vec3f(2.f * (x * y - w * z), 1.f - 2.f * (x * x + z * z), 2.f * (y * z + w * x));
  c2 = Vec3f(2.f * (x * z + w * y), 2.f * (y * z - w * x), 1.f - 2.f * (x * x + y * y));
}

// Spherical linear interpolation along the shorter arc (q and -q are the same
// rotation); nearly equal rotations fall back to normalised linear interpolation.
CHD Quat quat_slerp(Quat a, Quat b, float u) {
  float c = a.w * b.w + dot(a.v, b.v);
  if (c < 0.f) {
    c = -c;
    b.w = -b.w;
    b.v = -b.v;
  }
  float ka, kb;
  if (c > 0.9995f) {
    ka = 1.f - u;
    kb = u;
  } else {
    float theta = std::acos(c), s = std::sin(theta);
    ka = std::sin((1.f - u) * theta) / s;
    kb = std::sin(u * theta) / s;
  }
  Quat q;
  q.w = ka * a.w + kb * b.w;
  q.v = a.v * ka + b.v * kb;
  float n = std::sqrt(q.w * q.w + dot(q.v, q.v));
  q.w /= n;
  q.v = q.v / n;
  return q;
}

// Where the camera is and which way it looks: `right`, `up`, `forward` orthonormal.
// (right, up, -forward) is a right-handed frame, or a left-handed one for a
// mirrored camera (right negated, CameraDesc::flip_x).
struct CameraPose {
  Vec3f position{0, 0, 0};
  Vec3f right{1, 0, 0}, up{0, 1, 0}, forward{0, 0, -1};
};

CHD CameraPose interpolate_pose(const CameraPose& a, const CameraPose& b, float u) {
  // Rotate the right-handed frames; a mirrored camera's right is negated before and after.
  float ha = dot(cross(a.right, a.up), a.forward) < 0.f ? 1.f : -1.f;
  float hb = dot(cross(b.right, b.up), b.forward) < 0.f ? 1.f : -1.f;
  Quat qa = quat_from_columns(a.right * ha, a.up, -a.forward);
  Quat qb = quat_from_columns(b.right * hb, b.up, -b.forward);
  CameraPose p;
  Vec3f c0, c1, c2;
  quat_to_columns(quat_slerp(qa, qb, u), c0, c1, c2);
  p.right = c0 * ha;
  p.up = c1;
  p.forward = -c2;
  p.position = a.position * (1.f - u) + b.position * u;
  return p;
}

struct Camera {
  // The pose (at shutter open for a moving camera).
  Vec3f position{0, 0, 0};
  Vec3f right{1, 0, 0}, up{0, 1, 0}, forward{0, 0, -1};  // orthonormal
  // Half the image plane's extent at distance 1 (orthographic: half the view's extent in scene units).
  float tan_half_x = 0.4f, tan_half_y = 0.4f;
  bool orthographic = false;
  float aperture_radius = 0.f;  // (perspective only)
  float focus_distance = 1.f;
  int width = 256, height = 256;
  // A crop window's place in the uncropped film (its first pixel, and the film's width; 0: this camera's own
  // width, no crop): film_pixel numbers a pixel as the whole film does, which seeds its samples.
  uint32_t crop_x = 0, crop_y = 0, film_width = 0;
  // The image plane window's centre (a crop window, a principal point offset; 0 for a whole, centred
  // film), in the units of tan_half.
  float shift_x = 0.f, shift_y = 0.f;
  // Clipping planes: depths along `forward` from the lens plane (0 and infinity: none).
  float near_clip = 0.f, far_clip = kInf;
  // Motion blur: the pose at shutter close; time u in [0, 1) spans the shutter.
  bool moving = false;
  CameraPose close_pose;

  // The index of pixel (px, py) of this camera in the uncropped film: the samplers are seeded by it, so that a
  // crop draws each of its pixels' samples as the whole film's render does.
  CHD uint32_t film_pixel(uint32_t px, uint32_t py) const {
    return (py + crop_y) * (film_width ? film_width : uint32_t(width)) + px + crop_x;
  }

  CHD CameraPose pose() const {
    CameraPose p;
    p.position = position;
    p.right = right;
    p.up = up;
    p.forward = forward;
    return p;
  }
  // The camera at time u of the shutter interval (itself when it does not move).
  CHD Camera at(float u) const {
    Camera c = *this;
    if (!moving) return c;
    CameraPose p = interpolate_pose(pose(), close_pose, u);
    c.position = p.position;
    c.right = p.right;
    c.up = p.up;
    c.forward = p.forward;
    c.moving = false;
    return c;
  }

  // film: raster position in pixels; lens: a sample of [0,1)^2. The pose is
  // this camera's own (the shutter-open one of a moving camera: use at(u)).
  CHD Ray generate_ray(Vec2f film, Vec2f lens) const {
    float sx = (2.f * film.x / float(width) - 1.f) * tan_half_x + shift_x;
    float sy = (1.f - 2.f * film.y / float(height)) * tan_half_y + shift_y;
    Ray r;
    r.tmax = kInf;
    if (orthographic) {
      r.o = position + right * sx + up * sy;
      r.d = forward;
      clip(r);
      return r;
    }
    Vec3f d_cam(sx, sy, 1.f);
    Vec3f o_cam(0.f, 0.f, 0.f);
    if (aperture_radius > 0.f) {
      Vec2f pl = square_to_concentric_disk(lens) * aperture_radius;
      Vec3f focus = d_cam * focus_distance;
      o_cam = Vec3f(pl.x, pl.y, 0.f);
      d_cam = focus - o_cam;
    }
    r.o = position + right * o_cam.x + up * o_cam.y;
    r.d = normalize(right * d_cam.x + up * d_cam.y + forward * d_cam.z);
    clip(r);
    return r;
  }
  // The distance along a camera ray (unit d) from the lens plane to the near plane.
  CHD float near_distance(Vec3f d) const {
    return near_clip > 0.f ? near_clip / dot(d, forward) : 0.f;
  }
  // Moves a camera ray's origin (on the lens plane) to the near plane and ends it at the far plane.
  CHD void clip(Ray& r) const {
    const float dz = dot(r.d, forward);
    if (far_clip < kInf) r.tmax = (far_clip - near_clip) / dz;
    if (near_clip > 0.f) r.o = r.o + r.d * (near_clip / dz);
  }
};

}  // namespace caustica
