// ppm's measurement points in participating media (integrator/sppm.h: trace_measurement_points). A camera
// outside a null box of fog looks through it at a diffuse back wall and a glass sphere (vacuum inside) that
// splits rays into reflected and refracted branches. The same geometry three times: the box empty (a null
// boundary, no medium), filled with a homogeneous medium, and filled with a grid medium of constant density 1
// and the same coefficients. Checked per point:
//   - the points are the same in all three scenes and for every salt (positions depend on geometry alone);
//   - homogeneous: the weight is the empty box's (the Fresnel weights) times the exact transmittance, which for
//     a ray straight to the wall is exp(-sigma_t d) over the part d of the ray inside the box;
//   - grid: the weights are ratio-tracking estimates drawn from the salt; over S salts their mean x (the
//     weight divided by the empty box's) is the homogeneous transmittance T. Every estimate lies in [0, 1]
//     (medium_grid.h), so Var x <= T (1 - T): the bound |mean - T| <= 5 sqrt(T (1 - T) / S) needs no estimated
//     variance. And the estimates do vary with the salt (ppm draws a new one every pass).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/integrator/sppm.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {

enum class Fill { kNone, kHomogeneous, kGrid };

const RGB kSigmaA(0.1f, 0.1f, 0.1f), kSigmaS(0.3f, 0.45f, 0.6f);
const Vec3f kCamera(0.f, 0.f, 3.5f);

bool same(const Vec3f& a, const Vec3f& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

std::shared_ptr<Scene> box_scene(Fill fill) {
  SceneDesc d;
  d.name = "ppm-media";
  d.camera.position = kCamera;
  d.camera.target = {0, 0, 0};
  if (fill != Fill::kNone) {
    Medium m;
    m.sigma_a = kSigmaA;
    m.sigma_s = kSigmaS;
    m.g = 0.3f;
    if (fill == Fill::kGrid) {
      MediumGridDesc gd;
      gd.nx = gd.ny = gd.nz = 2;
      gd.values.assign(8, 1.f);
      gd.clamp = true;
      for (int i = 0; i < 3; ++i) {
        gd.to_world.m[i][i] = 4.f;  // the unit cube to [-2, 2]^3
        gd.to_world.m[i][3] = -2.f;
      }
      d.grids.push_back(gd);
      m.grid = 0;
    }
    d.media.push_back(m);
    d.medium_names.push_back("fog");
  }
  const int null_material = d.add_material("boundary", Material());
  d.materials[size_t(null_material)].type = MaterialType::kNull;
  const int wall = d.add_material("wall", make_diffuse(RGB(0.5f)));
  const int glass = d.add_material("glass", make_dielectric(1.5f));
  ShapeDesc box;
  box.type = ShapeType::kCube;
  box.material = null_material;
  for (int i = 0; i < 3; ++i) box.to_world.m[i][i] = 2.f;  // [-2, 2]^3
  if (fill != Fill::kNone) {
    box.medium_interface = true;
    box.interior = 0;
  }
  d.shapes.push_back(box);
  ShapeDesc back;
  back.type = ShapeType::kRectangle;
  back.material = wall;
  for (int i = 0; i < 3; ++i) back.to_world.m[i][i] = 1.9f;
  back.to_world.m[2][3] = -1.9f;  // facing +z, inside the box
  d.shapes.push_back(back);
  ShapeDesc ball;
  ball.type = ShapeType::kSphere;
  ball.center = {0.3f, 0.2f, 0.f};
  ball.radius = 0.6f;
  ball.material = glass;
  if (fill != Fill::kNone) {
    ball.medium_interface = true;
    ball.exterior = 0;  // vacuum inside the glass
  }
  d.shapes.push_back(ball);
  return Scene::build(d);
}

struct RayPoints {
  int n = 0;
  VisiblePoint p[kPpmPointsPerPixel];
};

RayPoints measure(const Scene& sc, const Ray& r, uint64_t salt) {
  RayPoints out;
  out.n = trace_measurement_points(sc.view(), sc.accel(), r, 0xffffffffu, out.p, kPpmPointsPerPixel, salt);
  return out;
}

}  // namespace

TEST(PpmMedia, MeasurementPointsCarryTheTransmittanceAndGridWeightsAverageToIt) {
  auto empty = box_scene(Fill::kNone), homogeneous = box_scene(Fill::kHomogeneous), grid = box_scene(Fill::kGrid);
  ASSERT_TRUE(scene_has_media(empty->view()));  // the null boundary alone
  ASSERT_FALSE(scene_has_grid_media(homogeneous->view()));
  ASSERT_TRUE(scene_has_grid_media(grid->view()));
  const RGB sigma_t = kSigmaA + kSigmaS;
  constexpr int kSalts = 256;
  int points = 0, split = 0, direct = 0, compared = 0, varied = 0;
  for (int iy = 0; iy < 12; ++iy)
    for (int ix = 0; ix < 12; ++ix) {
      const Vec3f target(-1.6f + 3.2f * (ix + 0.5f) / 12.f, -1.6f + 3.2f * (iy + 0.5f) / 12.f, -1.9f);
      const Ray ray{kCamera, normalize(target - kCamera), kInf};
      const RayPoints e = measure(*empty, ray, 0), h = measure(*homogeneous, ray, 7);
      ASSERT_EQ(e.n, h.n);
      points += e.n;
      split += e.n > 1;
      std::vector<RayPoints> g(kSalts);
      for (int s = 0; s < kSalts; ++s) {
        g[s] = measure(*grid, ray, uint64_t(s) + 1);
        ASSERT_EQ(g[s].n, e.n);
      }
      for (int k = 0; k < e.n; ++k) {
        const Vec3f p = e.p[k].p;
        ASSERT_TRUE(e.p[k].valid && h.p[k].valid);
        EXPECT_TRUE(same(h.p[k].p, p));
        EXPECT_EQ(h.p[k].medium, 0);  // every point here is inside the box, outside the glass
        EXPECT_EQ(e.p[k].medium, -1);
        if (same(e.p[k].beta, RGB(1.f))) {
          // Straight to the wall (no glass on the way): the ray enters the box at z = 2.
          ++direct;
          const float inside = length(p - kCamera) * (2.f - p.z) / (kCamera.z - p.z);
          for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(h.p[k].beta[c], std::exp(-sigma_t[c] * inside), 2e-5f) << c;
        }
        for (int c = 0; c < 3; ++c) {
          const double w = e.p[k].beta[c];
          if (!(w > 1e-6)) continue;
          const double T = h.p[k].beta[c] / w;
          ASSERT_GT(T, 0.0);
          ASSERT_LT(T, 1.0);
          double sum = 0.0, sum2 = 0.0;
          for (int s = 0; s < kSalts; ++s) {
            const VisiblePoint& q = g[s].p[k];
            ASSERT_TRUE(same(q.p, p));
            const double x = q.beta[c] / w;
            ASSERT_GE(x, 0.0);
            ASSERT_LE(x, 1.0 + 1e-5);
            sum += x;
            sum2 += x * x;
          }
          const double mean = sum / kSalts, var = sum2 / kSalts - mean * mean;
          // Rounding of the float weights: 1e-5.
          EXPECT_LE(std::abs(mean - T), 5.0 * std::sqrt(T * (1.0 - T) / kSalts) + 1e-5) << "point " << k << " c " << c;
          ++compared;
          varied += var > 1e-6;
        }
      }
    }
  // The scene exercises what it should: rays straight to the wall, rays split by the glass, and grid weights
  // that differ from salt to salt.
  EXPECT_GT(direct, 40);
  EXPECT_GT(split, 10);
  // Points behind the glass are compared too (measured 73 from 38 split rays; the deeper internal
  // reflections' weights fall below 1e-6 and are left out, reflected branches that leave the box find none).
  EXPECT_GT(compared - 3 * direct, 3 * split) << points << " points, " << split << " split, " << direct << " direct";
  EXPECT_EQ(varied, compared);
}

// Without a salt (0) a grid medium's estimate is the one medium_segment_transmittance always gave for the
// segment: shadow rays and the other integrators draw nothing new.
TEST(PpmMedia, GridTransmittanceDependsOnTheSalt) {
  auto grid = box_scene(Fill::kGrid);
  const SceneView& v = grid->view();
  const Vec3f o(0.1f, -0.3f, 1.9f), d = normalize(Vec3f(0.2f, 0.1f, -1.f));
  const RGB a = medium_segment_transmittance(v, v.media[0], o, d, 3.f);
  EXPECT_TRUE(same(a, medium_segment_transmittance(v, v.media[0], o, d, 3.f, 0)));
  int differ = 0;
  for (uint64_t s = 1; s <= 16; ++s) {
    const RGB b = medium_segment_transmittance(v, v.media[0], o, d, 3.f, s);
    EXPECT_TRUE(same(b, medium_segment_transmittance(v, v.media[0], o, d, 3.f, s)));  // a function of the salt
    differ += !same(b, a);
  }
  EXPECT_GT(differ, 8);
}
