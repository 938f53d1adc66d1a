// The moving camera (motion blur): quaternion conversions, the pose
// interpolation (end poses, orthonormal frames, constant angular speed, mirrored
// cameras) and the shutter interval of make_camera.
#include <gtest/gtest.h>

#include <cmath>

#include "caustica/base/rng.h"
#include "caustica/base/sampling.h"
#include "caustica/camera/camera.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {
Vec3f random_unit(PCG32& rng) { return square_to_uniform_sphere(Vec2f(rng.next_float(), rng.next_float())); }

// A random right-handed frame: (right, up, -forward) with det +1, like make_camera's.
CameraPose random_pose(PCG32& rng) {
  CameraPose p;
  p.forward = random_unit(rng);
  Vec3f u = random_unit(rng);
  p.right = normalize(cross(p.forward, u));
  p.up = cross(p.right, p.forward);
  p.position = Vec3f(rng.next_float() * 10.f - 5.f, rng.next_float() * 10.f - 5.f, rng.next_float() * 10.f - 5.f);
  return p;
}

void expect_near(Vec3f a, Vec3f b, float tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

// Rotation angle between two frames: cos = (trace(Ra^T Rb) - 1) / 2.
double angle_between(const CameraPose& a, const CameraPose& b) {
  double tr = double(dot(a.right, b.right)) + dot(a.up, b.up) + dot(a.forward, b.forward);
  return std::acos(std::fmax(-1.0, std::fmin(1.0, (tr - 1.0) / 2.0)));
}
}  // namespace

TEST(Camera, QuaternionRoundTripsEveryRotation) {
  PCG32 rng(7, 1);
  for (int i = 0; i < 2000; ++i) {
    CameraPose p = random_pose(rng);
    Vec3f c0, c1, c2;
    quat_to_columns(quat_from_columns(p.right, p.up, -p.forward), c0, c1, c2);
    // float rounding of unit vectors: a few ulps of 1, times the conversions' handful of operations
    expect_near(c0, p.right, 2e-5f);
    expect_near(c1, p.up, 2e-5f);
    expect_near(c2, -p.forward, 2e-5f);
  }
  // The four branches of Shepperd's method: the identity and half-turns about x, y and z.
  const Vec3f X(1, 0, 0), Y(0, 1, 0), Z(0, 0, 1);
  const Vec3f frames[4][3] = {{X, Y, Z}, {X, -Y, -Z}, {-X, Y, -Z}, {-X, -Y, Z}};
  for (const auto& f : frames) {
    Vec3f c0, c1, c2;
    quat_to_columns(quat_from_columns(f[0], f[1], f[2]), c0, c1, c2);
    expect_near(c0, f[0], 1e-6f);
    expect_near(c1, f[1], 1e-6f);
    expect_near(c2, f[2], 1e-6f);
  }
}

TEST(Camera, PoseInterpolationIsASlerpWithLinearPosition) {
  PCG32 rng(11, 1);
  for (int i = 0; i < 500; ++i) {
    CameraPose a = random_pose(rng), b = random_pose(rng);
    double total = angle_between(a, b);
    if (total > 3.1) continue;  // near a half-turn the shorter arc is ill-defined
    CameraPose p0 = interpolate_pose(a, b, 0.f), p1 = interpolate_pose(a, b, 1.f);
    expect_near(p0.right, a.right, 3e-5f);
    expect_near(p0.forward, a.forward, 3e-5f);
    expect_near(p1.right, b.right, 3e-5f);
    expect_near(p1.forward, b.forward, 3e-5f);
    expect_near(p1.position, b.position, 1e-5f);
    for (float u : {0.1f, 0.25f, 0.5f, 0.8f}) {
      CameraPose p = interpolate_pose(a, b, u);
      // Orthonormal and right-handed like the ends.
      EXPECT_NEAR(length(p.right), 1.f, 1e-5f);
      EXPECT_NEAR(length(p.up), 1.f, 1e-5f);
      EXPECT_NEAR(length(p.forward), 1.f, 1e-5f);
      EXPECT_NEAR(dot(p.right, p.up), 0.f, 1e-5f);
      EXPECT_NEAR(dot(p.up, p.forward), 0.f, 1e-5f);
      expect_near(cross(p.right, p.up), -p.forward, 3e-5f);
      // Constant angular speed along one arc: u of the angle from a, 1 - u of it to b
      // (float frames: 1e-3 rad covers acos's sensitivity near small angles).
      EXPECT_NEAR(angle_between(a, p), u * total, 1e-3) << i << " u=" << u;
      EXPECT_NEAR(angle_between(p, b), (1.0 - u) * total, 1e-3) << i << " u=" << u;
      expect_near(p.position, a.position * (1.f - u) + b.position * u, 1e-5f);
    }
  }
}

TEST(Camera, MirroredCameraStaysMirrored) {
  PCG32 rng(3, 1);
  for (int i = 0; i < 200; ++i) {
    CameraPose a = random_pose(rng), b = random_pose(rng);
    a.right = -a.right;  // CameraDesc::flip_x
    b.right = -b.right;
    CameraPose p1 = interpolate_pose(a, b, 1.f);
    expect_near(p1.right, b.right, 3e-5f);
    CameraPose p = interpolate_pose(a, b, 0.5f);
    expect_near(cross(p.right, p.up), p.forward, 3e-5f);
  }
}

TEST(Camera, ShutterIntervalSelectsThePosesBetweenTheKeyframes) {
  CameraDesc d;
  d.position = Vec3f(0, 0, 5);
  d.target = Vec3f(0, 0, 0);
  d.up = Vec3f(0, 1, 0);
  d.moving = true;
  d.position1 = Vec3f(4, 0, 5);
  d.target1 = Vec3f(4, 0, 0);  // a pure translation along x
  d.up1 = d.up;
  d.shutter_open = 0.25f;
  d.shutter_close = 0.75f;
  Camera c = make_camera(d);
  ASSERT_TRUE(c.moving);
  expect_near(c.at(0.f).position, Vec3f(1, 0, 5), 1e-6f);
  expect_near(c.at(0.5f).position, Vec3f(2, 0, 5), 1e-6f);
  expect_near(c.at(1.f).position, Vec3f(3, 0, 5), 1e-6f);
  expect_near(c.at(0.5f).forward, Vec3f(0, 0, -1), 1e-6f);
  // The centre ray at time u hits the plane z = 0 at x = 1 + 2u.
  Ray r = c.at(0.3f).generate_ray(Vec2f(0.5f * float(c.width), 0.5f * float(c.height)), Vec2f(0.5f, 0.5f));
  expect_near(r.o + r.d * 5.f, Vec3f(1.6f, 0, 0), 1e-5f);

  // A rotation of 90 degrees about y over [0, 1]: half of it at mid-shutter of [0, 1].
  d.position1 = d.position;
  d.target1 = Vec3f(-5, 0, 5);
  d.shutter_open = 0.f;
  d.shutter_close = 1.f;
  c = make_camera(d);
  float h = std::sqrt(0.5f);
  expect_near(c.at(0.5f).forward, Vec3f(-h, 0, -h), 1e-6f);
  expect_near(c.at(1.f).forward, Vec3f(-1, 0, 0), 1e-6f);

  // A closed shutter (open == close) or equal keyframes: a static camera at that time.
  d.shutter_open = d.shutter_close = 0.5f;
  c = make_camera(d);
  EXPECT_FALSE(c.moving);
  expect_near(c.forward, Vec3f(-h, 0, -h), 1e-6f);
  d.shutter_open = 0.f;
  d.shutter_close = 1.f;
  d.target1 = d.target;
  EXPECT_FALSE(make_camera(d).moving);
}

TEST(Camera, StaticCameraIsTheSameAtEveryTime) {
  CameraDesc d;
  d.position = Vec3f(1, 2, 3);
  d.target = Vec3f(0, 0, 0);
  Camera c = make_camera(d);
  ASSERT_FALSE(c.moving);
  Ray a = c.generate_ray(Vec2f(10.3f, 20.7f), Vec2f(0.5f, 0.5f));
  Ray b = c.at(0.77f).generate_ray(Vec2f(10.3f, 20.7f), Vec2f(0.5f, 0.5f));
  EXPECT_EQ(a.o.x, b.o.x);
  EXPECT_EQ(a.d.x, b.d.x);
  EXPECT_EQ(a.d.y, b.d.y);
  EXPECT_EQ(a.d.z, b.d.z);
}

// ---------------------------------------------------------------------------
// Crop windows and clipping planes.

#include "caustica/base/error.h"
#include "caustica/integrator/vcm.h"

namespace {
CameraDesc crop_test_desc(int kind) {
  CameraDesc d;
  d.position = Vec3f(0.5f, 1.f, 4.f);
  d.target = Vec3f(-0.2f, 0.3f, 0.f);
  d.width = 96;
  d.height = 64;
  if (kind == 1) {  // thin lens
    d.aperture_radius = 0.2f;
    d.focus_distance = 3.f;
  } else if (kind == 2) {
    d.orthographic = true;
    d.view_size = 3.f;
  }
  return d;
}
}  // namespace

// A cropped camera's pixel (x, y) is the whole film's pixel (crop_x + x, crop_y + y): the same ray for the
// same film and lens sample, and light vertices project to the shifted raster position.
TEST(Camera, CropWindowIsThatPartOfTheFilm) {
  for (int kind = 0; kind < 3; ++kind) {
    SCOPED_TRACE(kind);
    CameraDesc d = crop_test_desc(kind);
    Camera full = make_camera(d);
    d.crop_x = 13;
    d.crop_y = 40;
    d.crop_width = 50;
    d.crop_height = 21;
    Camera crop = make_camera(d);
    EXPECT_EQ(crop.width, 50);
    EXPECT_EQ(crop.height, 21);
    EXPECT_NEAR(camera_pixel_area(crop), camera_pixel_area(full), 1e-6f * camera_pixel_area(full));
    PCG32 rng(7, 2);
    for (int i = 0; i < 200; ++i) {
      Vec2f f(rng.next_float() * 50.f, rng.next_float() * 21.f), lens(rng.next_float(), rng.next_float());
      Ray a = crop.generate_ray(f, lens), b = full.generate_ray(Vec2f(f.x + 13.f, f.y + 40.f), lens);
      expect_near(a.o, b.o, 1e-5f);
      expect_near(a.d, b.d, 1e-5f);
      // A point along the ray projects back to the cropped raster position.
      Vec3f p = a.o + a.d * (1.f + 3.f * rng.next_float());
      Vec3f pl = camera_eye_point(crop, p, lens);
      Vec2f r;
      float ct;
      ASSERT_TRUE(camera_project(crop, pl, p, r, ct));
      EXPECT_NEAR(r.x, f.x, 2e-3f);
      EXPECT_NEAR(r.y, f.y, 2e-3f);
    }
  }
}

TEST(Camera, CropWindowMustFitTheFilm) {
  CameraDesc d = crop_test_desc(0);
  d.crop_x = 50;
  d.crop_y = 0;
  d.crop_width = 47;  // 50 + 47 > 96
  d.crop_height = 10;
  EXPECT_THROW(make_camera(d), InputError);
  EXPECT_NE(crop_problem(d).find("does not fit the 96x64 film"), std::string::npos) << crop_problem(d);
  d.crop_width = 46;
  EXPECT_EQ(crop_problem(d), "");
  d.crop_y = -1;
  EXPECT_NE(crop_problem(d), "");
  d = crop_test_desc(0);  // all zero: no crop
  EXPECT_EQ(crop_problem(d), "");
  EXPECT_EQ(make_camera(d).width, 96);
}

// Camera rays start on the near plane and end on the far plane (depths along the view axis from the lens
// plane); a point is seen only between them.
TEST(Camera, ClippingPlanesBoundTheRaysAndTheProjection) {
  for (int kind = 0; kind < 3; ++kind) {
    SCOPED_TRACE(kind);
    CameraDesc d = crop_test_desc(kind);
    Camera open = make_camera(d);
    d.near_clip = 1.5f;
    d.far_clip = 6.f;
    Camera c = make_camera(d);
    PCG32 rng(3, 2);
    for (int i = 0; i < 100; ++i) {
      Vec2f f(rng.next_float() * 96.f, rng.next_float() * 64.f), lens(rng.next_float(), rng.next_float());
      Ray a = c.generate_ray(f, lens), u = open.generate_ray(f, lens);
      expect_near(a.d, u.d, 1e-6f);
      // The unclipped ray's origin is on the lens plane; the clipped one starts at depth 1.5 along it.
      EXPECT_NEAR(dot(a.o - u.o, c.forward), 1.5f, 1e-4f);
      EXPECT_NEAR(length(cross(a.o - u.o, u.d)), 0.f, 1e-4f);
      EXPECT_NEAR(c.near_distance(a.d), kind == 2 ? 1.5f : 1.5f / dot(a.d, c.forward), 1e-5f);
      EXPECT_NEAR(dot(a.o + a.d * a.tmax - u.o, c.forward), 6.f, 1e-3f);
      EXPECT_EQ(u.tmax, kInf);
      // Points on the ray at depths 1, 3 and 7: only the middle one projects.
      for (float depth : {1.f, 3.f, 7.f}) {
        Vec3f p = u.o + u.d * (depth / dot(u.d, c.forward));
        Vec3f pl = camera_eye_point(c, p, lens);
        Vec2f r;
        float ct;
        EXPECT_EQ(camera_project(c, pl, p, r, ct), depth == 3.f) << depth;
        EXPECT_TRUE(camera_project(open, pl, p, r, ct));
      }
    }
  }
  CameraDesc d = crop_test_desc(0);
  d.near_clip = 2.f;
  d.far_clip = 2.f;
  EXPECT_THROW(make_camera(d), InputError);
}

// A principal point offset (x, y) shows what the centred camera sees (x W, y H) pixels right and down, with or
// without a crop window.
TEST(Camera, PrincipalPointShiftsTheWindow) {
  for (int kind = 0; kind < 3; ++kind) {
    SCOPED_TRACE(kind);
    CameraDesc d = crop_test_desc(kind);
    Camera centred = make_camera(d);
    d.principal_point = Vec2f(0.125f, -0.25f);  // 12 pixels right, 16 up
    Camera shifted = make_camera(d);
    d.crop_x = 5;
    d.crop_y = 9;
    d.crop_width = 30;
    d.crop_height = 20;
    Camera both = make_camera(d);
    PCG32 rng(5, 2);
    for (int i = 0; i < 100; ++i) {
      Vec2f f(rng.next_float() * 30.f, rng.next_float() * 20.f), lens(rng.next_float(), rng.next_float());
      Ray a = shifted.generate_ray(f, lens), b = centred.generate_ray(Vec2f(f.x + 12.f, f.y - 16.f), lens);
      expect_near(a.o, b.o, 1e-5f);
      expect_near(a.d, b.d, 1e-5f);
      Ray c = both.generate_ray(f, lens), e = centred.generate_ray(Vec2f(f.x + 5.f + 12.f, f.y + 9.f - 16.f), lens);
      expect_near(c.o, e.o, 1e-5f);
      expect_near(c.d, e.d, 1e-5f);
    }
  }
}
