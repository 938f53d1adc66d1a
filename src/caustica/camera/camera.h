// Perspective camera (pinhole or thin lens). The field of view spans the
// smaller image axis, as in Mitsuba's default. Raster (0,0) is the top-left
// corner; image right is the camera's `right` axis and image up its `up` axis.
// Thin lens: Kolb et al. 1995 / pbrt-v4 Sec. 5.2.3 - rays from a point on the
// lens disk of radius aperture_radius through the point of the pinhole ray at
// distance focus_distance along the view axis.
#pragma once
#include "../base/math.h"
#include "../base/sampling.h"
#include "../geometry/ray.h"

namespace caustica {

struct Camera {
  Vec3f position{0, 0, 0};
  Vec3f right{1, 0, 0}, up{0, 1, 0}, forward{0, 0, -1};  // orthonormal
  float tan_half_x = 0.4f, tan_half_y = 0.4f;            // image-plane extent at distance 1
  float aperture_radius = 0.f;
  float focus_distance = 1.f;
  int width = 256, height = 256;

  // film: raster position in pixels; lens: a sample of [0,1)^2.
  CHD Ray generate_ray(Vec2f film, Vec2f lens) const {
    float sx = (2.f * film.x / float(width) - 1.f) * tan_half_x;
    float sy = (1.f - 2.f * film.y / float(height)) * tan_half_y;
    Vec3f d_cam(sx, sy, 1.f);
    Vec3f o_cam(0.f, 0.f, 0.f);
    if (aperture_radius > 0.f) {
      Vec2f pl = square_to_concentric_disk(lens) * aperture_radius;
      Vec3f focus = d_cam * focus_distance;
      o_cam = Vec3f(pl.x, pl.y, 0.f);
      d_cam = focus - o_cam;
    }
    Ray r;
    r.o = position + right * o_cam.x + up * o_cam.y;
    r.d = normalize(right * d_cam.x + up * d_cam.y + forward * d_cam.z);
    r.tmax = kInf;
    return r;
  }
};

}  // namespace caustica
