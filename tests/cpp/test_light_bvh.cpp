// The light BVH (light/light_bvh.h): from any reference point its probabilities over the lights sum to one; the
// lights it samples follow them (Pearson's chi-square test); the probability it returns with a sample is the one
// light_bvh_pmf recomputes from the light's bit trail (what MIS uses when a BSDF sample hits the light); the
// remapped random number is uniform again; lights that cannot reach the point (a spot light's back, a one-sided
// area light's back) are never chosen.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "caustica/base/rng.h"
#include "caustica/light/light_bvh.h"
#include "caustica/scene/interaction.h"
#include "caustica/scene/loaders/json_loader.h"
#include "caustica/scene/scene.h"
#include "chi2.h"

using namespace caustica;

namespace {

// 24 small one-sided area lights facing down, up and sideways, a two-sided sphere light, a point light, a spot
// light, and two infinite lights.
std::string scene_text() {
  std::string shapes =
      R"({"type": "rectangle", "transform": {"scale": 3, "rotate": {"axis": [1, 0, 0], "angle": -90}}},
         {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.25, "emission": [4, 4, 10],
          "emission_two_sided": true})";
  for (int i = 0; i < 24; ++i) {
    const float x = -2.f + 4.f * float(i % 6) / 5.f, z = -1.5f + float(i / 6);
    const int angle = i % 3 == 0 ? 90 : (i % 3 == 1 ? -90 : 0);  // facing down, up, or +z
    shapes += R"(, {"type": "rectangle", "emission": [)" + std::to_string(1 + i % 4) + R"(, 2, 3],
                   "transform": {"scale": 0.1, "rotate": {"axis": [1, 0, 0], "angle": )" +
              std::to_string(angle) + R"(}, "translate": [)" + std::to_string(x) + ", 1.5, " + std::to_string(z) +
              "]}}";
  }
  return R"({"camera": {"position": [0, 2, 5], "target": [0, 0, 0], "width": 8, "height": 8},
             "shapes": [)" + shapes + R"(],
             "lights": [
               {"type": "point", "position": [1, 1.5, 1], "intensity": [2, 1, 1]},
               {"type": "spot", "position": [-1, 2, 1], "target": [-1, 0, 1], "intensity": 6, "cutoff_angle": 40},
               {"type": "directional", "direction": [0.3, -1, -0.2], "irradiance": [0.3, 0.3, 0.2]},
               {"type": "environment", "radiance": [0.2, 0.3, 0.5]}]})";
}

struct LightBvhTest : ::testing::Test {
  std::shared_ptr<Scene> scene = Scene::build(load_json_scene_text(scene_text(), "light-bvh-test.json"));
  const SceneView& s = scene->view();

  Vec3f random_point(PCG32& rng) const {
    const Vec3f lo = s.bounds.lo - Vec3f(0.5f), hi = s.bounds.hi + Vec3f(0.5f);
    return Vec3f(lo.x + (hi.x - lo.x) * rng.next_float(), lo.y + (hi.y - lo.y) * rng.next_float(),
                 lo.z + (hi.z - lo.z) * rng.next_float());
  }
  int light_of_type(LightType t) const {
    for (uint32_t i = 0; i < s.num_lights; ++i)
      if (s.lights[i].type == t) return int(i);
    return -1;
  }
};

TEST_F(LightBvhTest, BuildsOverTheFiniteLights) {
  ASSERT_EQ(s.light_bvh.num_infinite, 2u);                     // environment and directional
  ASSERT_EQ(s.light_bvh.num_nodes, 2u * (s.num_lights - 2) - 1);  // a binary tree over the 51 others
  EXPECT_FLOAT_EQ(s.light_bvh.p_infinite(), 2.f / 3.f);
}

TEST_F(LightBvhTest, ProbabilitiesAreConservativeAndSumToAtMostOne) {
  // Every light that can light p has a positive probability (so next-event estimation stays unbiased); the
  // probabilities sum to at most one: the rest is the chance that the walk meets a node whose children both
  // have zero importance (then no light is sampled; SamplesFollowTheProbabilities counts those too).
  PCG32 rng(1, 2);
  double mean_sum = 0.0;
  for (int k = 0; k < 300; ++k) {
    const Vec3f p = random_point(rng);
    double sum = 0.0;
    for (uint32_t i = 0; i < s.num_lights; ++i) {
      const float pmf = light_bvh_pmf(s.light_bvh, p, i);
      ASSERT_TRUE(pmf >= 0.f && pmf <= 1.f) << pmf;
      sum += pmf;
      const Light& l = s.lights[i];
      bool can_light = true;
      if (l.type == LightType::kTriangle) {
        Vec3f p0, p1, p2;
        triangle_vertices(s, l.prim, p0, p1, p2);
        const Vec3f n = normalize(cross(p1 - p0, p2 - p0));
        can_light = l.two_sided || dot(n, p - p0) > 0.f;  // the plane's front side
      } else if (l.type == LightType::kSpot) {
        can_light = dot(normalize(p - l.p), l.dir) > l.cos_total;
      }
      if (can_light) EXPECT_GT(pmf, 0.f) << "light " << i << " at " << p.x << " " << p.y << " " << p.z;
    }
    EXPECT_LE(sum, 1.0 + 1e-5);  // float products along paths of about 10 levels: 1e-5 covers their rounding
    EXPECT_GE(sum, double(s.light_bvh.p_infinite()) - 1e-6);
    mean_sum += sum / 300.0;
  }
  std::printf("[ measured ] mean of the probabilities' sum over 300 points: %.4f\n", mean_sum);
  EXPECT_GT(mean_sum, 0.9);  // walks that end at no light are the exception
}

TEST_F(LightBvhTest, SamplesFollowTheProbabilities) {
  PCG32 pts(3, 4);
  const int kPoints = 4;
  const double alpha = chi2::sidak_alpha(0.01, kPoints);
  for (int k = 0; k < kPoints; ++k) {
    const Vec3f p = random_point(pts);
    PCG32 rng(5, uint64_t(k));
    const long n = 400000;
    std::vector<double> observed(s.num_lights + 1, 0.0), expected(s.num_lights + 1, 0.0);
    long mismatched = 0;
    for (long j = 0; j < n; ++j) {
      Vec2f u(rng.next_float(), rng.next_float());
      float pmf = 0.f;
      const int32_t li = light_bvh_sample(s.light_bvh, p, u, pmf);
      if (li < 0) {
        observed[s.num_lights] += 1;  // none: expected only where no finite light reaches p
        continue;
      }
      observed[size_t(li)] += 1;
      const float again = light_bvh_pmf(s.light_bvh, p, uint32_t(li));
      if (!(std::fabs(again - pmf) <= 1e-5f * pmf)) ++mismatched;
    }
    double total = 0.0;
    for (uint32_t i = 0; i < s.num_lights; ++i) {
      expected[i] = double(n) * light_bvh_pmf(s.light_bvh, p, i);
      total += expected[i];
    }
    expected[s.num_lights] = std::max(0.0, double(n) - total);
    EXPECT_EQ(mismatched, 0);
    chi2::Result r;
    chi2::pearson(observed, expected, 5.0, alpha, 10, [](size_t i) { return "light " + std::to_string(i); }, r);
    EXPECT_GE(r.p_value, alpha) << r.report;
  }
}

TEST_F(LightBvhTest, RemappedNumberIsUniform) {
  // Given the light chosen, u.x comes back uniform on [0, 1): 20 bins for the most likely light from one point.
  const Vec3f p(0.2f, 1.f, 0.3f);
  uint32_t best = 0;
  for (uint32_t i = 1; i < s.num_lights; ++i)
    if (light_bvh_pmf(s.light_bvh, p, i) > light_bvh_pmf(s.light_bvh, p, best)) best = i;
  PCG32 rng(7, 8);
  std::vector<double> observed(20, 0.0);
  long hits = 0;
  for (long j = 0; j < 1000000; ++j) {
    Vec2f u(rng.next_float(), 0.5f);
    float pmf;
    if (light_bvh_sample(s.light_bvh, p, u, pmf) != int32_t(best)) continue;
    ASSERT_TRUE(u.x >= 0.f && u.x < 1.f);
    observed[std::min(19, int(u.x * 20.f))] += 1;
    ++hits;
  }
  ASSERT_GT(hits, 20000);
  std::vector<double> expected(20, double(hits) / 20.0);
  chi2::Result r;
  chi2::pearson(observed, expected, 5.0, 0.01, 10, [](size_t i) { return "bin " + std::to_string(i); }, r);
  EXPECT_GE(r.p_value, 0.01) << r.report;
}

TEST_F(LightBvhTest, LightsThatCannotReachAPointAreNeverChosen) {
  // Above the spot light, which points down with a 40-degree cone: outside its cone and its falloff.
  const int spot = light_of_type(LightType::kSpot);
  ASSERT_GE(spot, 0);
  EXPECT_EQ(light_bvh_pmf(s.light_bvh, Vec3f(-1.f, 3.f, 1.f), uint32_t(spot)), 0.f);
  EXPECT_GT(light_bvh_pmf(s.light_bvh, Vec3f(-1.f, 0.5f, 1.f), uint32_t(spot)), 0.f);
  // Above the down-facing rectangles (one-sided, y = 1.5): their triangles are never chosen; below, they are.
  for (uint32_t i = 0; i < s.num_lights; ++i) {
    const Light& l = s.lights[i];
    if (l.type != LightType::kTriangle) continue;
    Vec3f p0, p1, p2;
    triangle_vertices(s, l.prim, p0, p1, p2);
    const Vec3f n = normalize(cross(p1 - p0, p2 - p0));
    if (n.y > -0.99f) continue;  // only the ones facing straight down
    const Vec3f c = (p0 + p1 + p2) / 3.f;
    EXPECT_EQ(light_bvh_pmf(s.light_bvh, c + Vec3f(0.f, 1.f, 0.f), i), 0.f) << "light " << i;
    EXPECT_GT(light_bvh_pmf(s.light_bvh, c - Vec3f(0.f, 1.f, 0.f), i), 0.f) << "light " << i;
  }
}

}  // namespace
