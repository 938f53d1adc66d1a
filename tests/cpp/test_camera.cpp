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
