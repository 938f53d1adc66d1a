// The MIS bookkeeping of integrator/vcm.h (Georgiev 2012, "Implementing Vertex
// Connection and Merging"): for a fixed path, the weights that the running
// quantities dVCM, dVC, dVM give to every strategy that can sample it must sum
// to one. Random paths x_0 (light) ... x_k (camera) with random diffuse or
// delta interior vertices; each strategy's weight is computed exactly as the
// integrator does, from the subpath states built by the integrator's own update
// functions (vcm_light_start_mis / vcm_camera_start_mis / vcm_after_segment /
// vcm_after_scatter) and the pdfs at the two joined vertices. Interior vertices
// may also be medium vertices (a Henyey-Greenstein phase function, no normal:
// |cos| 1; bpm and vcm merge there with the ball's term, rel = mis(4/3 r sigma_t)
// times a surface vertex's, vcm.h's header comment).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "caustica/base/rng.h"
#include "caustica/integrator/vcm.h"

using namespace caustica;

namespace {

struct V {
  Vec3f p, n;
  bool delta = false;
  bool medium = false;  // a scattering event in a medium (phase function kG)
  float sigma_t = 1.f;  // there: the medium's mean sigma_t
};

constexpr float kG = 0.6f;
// Sensitivity tests: 0 the integrator's rule; 1 no merge term at medium vertices in the running quantities and
// connections (while merges run there); 2 a surface vertex's term (rel 1) there.
int g_medium_rule = 0;

float g_rev_scale = 1.f;  // perturbation for the sensitivity test
bool g_upg_rules = true;  // false: upg's merge terms as vcm's (for the sensitivity test)
// false: upg's gathers still only where both vertices are surfaces, but the bookkeeping without the two rules
// that came with them (vcm_upg_medium_vertex, vcm_connect_light_vm), as before upg rendered media (for the
// sensitivity test)
bool g_upg_media_rules = true;
bool g_nee_ratio = true;  // false: NEE's emission density without pick / nee_pick (for the sensitivity test)

struct TestPath {
  std::vector<V> x;  // x[0] light, x[k] camera
  bool point_light = false;
  // pick: the light subpath's (power) selection probability; nee_pick: next-event estimation's from x_1 (the
  // light BVH's, vcm_nee_pick; equal to pick with the power sampler).
  float light_area = 0.7f, pick = 0.4f, nee_pick = 0.4f;
  Vec3f forward;
  float a_pix = 1e-3f;
};

Vec3f random_unit(PCG32& r) { return square_to_uniform_sphere(Vec2f(r.next_float(), r.next_float())); }

// Diffuse pdf (two-sided, |cos|/pi) of sampling the direction towards b at vertex i; at a medium vertex the
// phase function's density of the pair (b, the other path neighbour of x_i), symmetric as vcm_eval_medium's.
float pdf_w(const TestPath& P, int i, Vec3f b) {
  Vec3f d = normalize(b - P.x[i].p);
  if (P.x[i].medium) {
    const Vec3f n1 = P.x[i + 1].p;
    const Vec3f other = (b.x == n1.x && b.y == n1.y && b.z == n1.z) ? P.x[i - 1].p : n1;
    return hg_phase(dot(normalize(other - P.x[i].p), d), kG);
  }
  return absdot(P.x[i].n, d) * kInvPi;
}
float cosv(const TestPath& P, int i, Vec3f b) {
  return P.x[i].medium ? 1.f : absdot(P.x[i].n, normalize(b - P.x[i].p));
}
// The merge term of x_i relative to a surface vertex's (VcmPathState::vm_ok, vcm_medium_vm_rel).
float vm_rel(const VcmParams& p, const TestPath& P, int i) {
  if (!P.x[i].medium) return 1.f;
  return g_medium_rule == 1 ? 0.f : g_medium_rule == 2 ? 1.f : vcm_medium_vm_rel_of(p, P.x[i].sigma_t);
}
// The light side's merge term of a connection of light vertex x_a to camera vertex x_b (vcm_camera_connect).
float light_vm(const VcmParams& p, const TestPath& P, int a, int b) {
  return vcm_connect_light_vm(p, vm_rel(p, P, a), g_upg_media_rules && P.x[b].medium);
}
// upg: whether a gather samples the path by the connection of x_a and x_b (both non-delta): only where both
// are surface vertices (upg.h).
bool upg_gathers(const TestPath& P, int a, int b) { return !P.x[a].medium && !P.x[b].medium; }
float dist(const TestPath& P, int i, int j) { return length(P.x[i].p - P.x[j].p); }
float camera_pdf_w(const TestPath& P, Vec3f dir) {
  float c = dot(dir, P.forward);
  return 1.f / (P.a_pix * c * c * c);
}
float emission_pdf_w(const TestPath& P) {  // without the pick probability
  if (P.point_light) return uniform_sphere_pdf();
  return cosv(P, 0, P.x[1].p) * kInvPi / P.light_area;
}

// Light subpath state at vertex j (reached, not yet scattered), as stored for a
// connection or merge there (upg's pending term committed, as vcm_light_hit does).
VcmMis light_state(const VcmParams& p, const TestPath& P, int j) {
  const bool upg = p.mode == VcmMode::kUpg;
  float dpa = P.point_light ? 1.f : 1.f / P.light_area;
  VcmMis m = vcm_light_start_mis(p, dpa * P.nee_pick, emission_pdf_w(P) * P.pick,
                                 P.point_light ? 1.f : cosv(P, 0, P.x[1].p), P.point_light);
  for (int i = 1; i <= j; ++i) {
    vcm_after_segment(p, m, dist(P, i - 1, i), cosv(P, i, P.x[i - 1].p), true);
    if (P.x[i].medium && g_upg_media_rules) vcm_upg_medium_vertex(p, m);  // as vcm_light_hit
    if (i < j)
      vcm_after_scatter(p, m, cosv(P, i, P.x[i + 1].p), pdf_w(P, i, P.x[i + 1].p),
                        pdf_w(P, i, P.x[i - 1].p) * g_rev_scale, P.x[i].delta, vm_rel(p, P, i),
                        upg && g_upg_rules && !P.x[i].medium);
  }
  return vcm_mis_commit(p, m);
}

// Whether a merge-like strategy exists at camera vertex j for the integrator:
// always for vcm/bpm; for upg (a gathered photon at x_j joined to x_{j+1}) only if
// x_{j+1} is a non-delta surface vertex, not the camera (VcmPathState::vm_ok).
bool camera_vm_ok(const VcmParams& p, const TestPath& P, int j) {
  int k = int(P.x.size()) - 1;
  return p.mode != VcmMode::kUpg || !g_upg_rules ||
         (j + 1 < k && !P.x[j + 1].delta && !P.x[j + 1].medium);  // vcm_scatter_medium: vm_ok false
}
float cam_vm(const VcmParams& p, const TestPath& P, int j) {
  return camera_vm_ok(p, P, j) ? p.vm_factor * vm_rel(p, P, j) : 0.f;
}

// Camera subpath state at vertex j (reached from x_{j+1}).
VcmMis camera_state(const VcmParams& p, const TestPath& P, int j) {
  int k = int(P.x.size()) - 1;
  VcmMis m = vcm_camera_start_mis(p, camera_pdf_w(P, normalize(P.x[k - 1].p - P.x[k].p)));
  for (int i = k - 1; i >= j; --i) {
    vcm_after_segment(p, m, dist(P, i + 1, i), cosv(P, i, P.x[i + 1].p), true);
    if (i > j)
      vcm_after_scatter(p, m, cosv(P, i, P.x[i - 1].p), pdf_w(P, i, P.x[i - 1].p), pdf_w(P, i, P.x[i + 1].p),
                        P.x[i].delta, camera_vm_ok(p, P, i) ? vm_rel(p, P, i) : 0.f);
  }
  return m;
}

// Sum over all strategies of their weights (VC: s = 0 .. k light vertices; VM at
// x_1 .. x_{k-1}; upg: a gather for each connection of x_{s-1} (s >= 2) with a
// camera vertex x_s other than the camera, weighted as upg_gather does).
double weight_sum(const VcmParams& p, const TestPath& P, int* used = nullptr) {
  const int k = int(P.x.size()) - 1;
  double sum = 0.0;
  int n = 0;
  if (p.use_vc()) {
    // s = 0: the camera subpath hits the light.
    if (!P.point_light) {  // x_1 may be delta: a camera path through a mirror hits the light
      VcmMis c = camera_state(p, P, 0);
      sum += vcm_weight_hit(p, c, P.nee_pick / P.light_area, emission_pdf_w(P) * P.pick), ++n;
    }
    // s = 1: next-event estimation at x_1.
    if (!P.x[1].delta) {
      VcmMis c = camera_state(p, P, 1);
      float d = dist(P, 0, 1);
      float cos_l = P.point_light ? 1.f : cosv(P, 0, P.x[1].p);
      float direct_pdf_w = P.point_light ? d * d : d * d / (cos_l * P.light_area);
      float dir = P.point_light ? 0.f : pdf_w(P, 1, P.x[0].p);
      float ratio = g_nee_ratio ? P.pick / P.nee_pick : 1.f;  // as vcm_camera_nee passes it
      sum += vcm_weight_nee(p, c, P.nee_pick, direct_pdf_w, emission_pdf_w(P) * ratio, cos_l, cosv(P, 1, P.x[0].p),
                            dir, pdf_w(P, 1, P.x[2].p), cam_vm(p, P, 1));
      ++n;
    }
    // 2 <= s <= k - 1: light vertex x_{s-1} to camera vertex x_s.
    for (int s = 2; s <= k - 1; ++s) {
      int a = s - 1, b = s;
      if (P.x[a].delta || P.x[b].delta) continue;
      VcmMis l = light_state(p, P, a), c = camera_state(p, P, b);
      float d2 = dist(P, a, b) * dist(P, a, b);
      float cam_dir_a = pdf_w(P, b, P.x[a].p) * cosv(P, a, P.x[b].p) / d2;
      float light_dir_a = pdf_w(P, a, P.x[b].p) * cosv(P, b, P.x[a].p) / d2;
      float wc = vcm_weight_connect(p, l, c, cam_dir_a, pdf_w(P, b, P.x[b + 1].p), light_dir_a,
                                    pdf_w(P, a, P.x[a - 1].p), cam_vm(p, P, b), light_vm(p, P, a, b));
      sum += wc, ++n;
      if (p.mode == VcmMode::kUpg && upg_gathers(P, a, b))
        sum += wc * p.vm_factor * vcm_mis(p, cam_dir_a), ++n;  // the gather of x_a at x_b
    }
  }
  if (p.use_lt() && !P.x[k - 1].delta) {  // s = k: light vertex x_{k-1} to the camera
    VcmMis l = light_state(p, P, k - 1);
    float d = dist(P, k - 1, k);
    float cam_a = camera_pdf_w(P, normalize(P.x[k - 1].p - P.x[k].p)) * cosv(P, k - 1, P.x[k].p) / (d * d);
    sum += vcm_weight_camera(p, l, cam_a, pdf_w(P, k - 1, P.x[k - 2].p), vm_rel(p, P, k - 1));
    ++n;
  }
  if (p.merges())
    for (int i = 1; i <= k - 1; ++i) {
      if (P.x[i].delta) continue;
      VcmMis l = light_state(p, P, i), c = camera_state(p, P, i);
      // The merge weight of a medium vertex always divides by its true rel (vcm_camera_merge_medium).
      const float rel = P.x[i].medium ? vcm_medium_vm_rel_of(p, P.x[i].sigma_t) : 1.f;
      sum += vcm_weight_merge(p, l, c, pdf_w(P, i, P.x[i - 1].p), pdf_w(P, i, P.x[i + 1].p), rel);
      ++n;
    }
  if (used) *used = n;
  return sum;
}

TestPath random_path(PCG32& r, int k, bool point_light, bool allow_delta, bool media = false) {
  TestPath P;
  P.point_light = point_light;
  for (int i = 0; i <= k; ++i) {
    V v;
    v.p = Vec3f(2.f * r.next_float() - 1.f, 2.f * r.next_float() - 1.f, 2.f * r.next_float() - 1.f) * 2.f;
    v.n = random_unit(r);
    v.delta = allow_delta && i > 0 && i < k && r.next_float() < 0.3f;
    v.medium = media && !v.delta && i > 0 && i < k && r.next_float() < 0.5f;
    if (v.medium) v.sigma_t = std::pow(10.f, -2.f + 4.f * r.next_float());
    P.x.push_back(v);
  }
  // The camera looks roughly at x_{k-1}.
  Vec3f d = normalize(P.x[k - 1].p - P.x[k].p);
  P.forward = normalize(d + random_unit(r) * 0.3f);
  if (dot(P.forward, d) < 0.2f) P.forward = d;
  return P;
}

VcmParams params(VcmMode mode, bool balance, float radius, float volume_radius = 0.f) {
  VcmParams p;
  p.mode = mode;
  p.balance = balance;
  p.n_light = 4096.f;
  vcm_set_radius(p, radius, volume_radius);
  return p;
}

}  // namespace

// BDPT (connections only): Veach's strategies (s, t) partition the path, with
// delta vertices and point lights excluding the strategies they make impossible.
TEST(VcmMis, BdptWeightsSumToOne) {
  PCG32 r(7, 1);
  for (int trial = 0; trial < 3000; ++trial) {
    int k = 2 + int(r.next_u32() % 6);
    bool point = r.next_float() < 0.3f, balance = r.next_float() < 0.3f;
    TestPath P = random_path(r, k, point, true);
    int n = 0;
    double s = weight_sum(params(VcmMode::kBpt, balance, 0.01f), P, &n);
    if (n == 0) continue;  // e.g. x_{k-1} delta with a point light at a delta x_1: no strategy
    // float weights, each a ratio of sums of squared pdf ratios: 1e-4 relative.
    EXPECT_NEAR(s, 1.0, 1e-4) << "trial " << trial << " k " << k << " point " << point << " strategies " << n;
  }
}

// VCM: connections and merges (merging radius scanned over 5 decades so both
// kinds dominate somewhere).
TEST(VcmMis, VcmWeightsSumToOne) {
  PCG32 r(11, 2);
  for (int trial = 0; trial < 3000; ++trial) {
    int k = 2 + int(r.next_u32() % 6);
    bool point = r.next_float() < 0.3f, balance = r.next_float() < 0.3f;
    float radius = std::pow(10.f, -4.f + 4.f * r.next_float());
    TestPath P = random_path(r, k, point, true);
    int n = 0;
    double s = weight_sum(params(VcmMode::kVcm, balance, radius), P, &n);
    if (n == 0) continue;
    EXPECT_NEAR(s, 1.0, 1e-4) << "trial " << trial << " k " << k << " radius " << radius;
  }
}

// BPM (merges only): the merges at the non-delta interior vertices partition the path.
TEST(VcmMis, BpmWeightsSumToOne) {
  PCG32 r(13, 3);
  for (int trial = 0; trial < 2000; ++trial) {
    int k = 2 + int(r.next_u32() % 6);
    TestPath P = random_path(r, k, r.next_float() < 0.3f, true);
    int n = 0;
    double s = weight_sum(params(VcmMode::kBpm, false, 0.05f), P, &n);
    if (n == 0) continue;
    EXPECT_NEAR(s, 1.0, 1e-4) << "trial " << trial;
  }
}

// upg: BDPT's strategies and the gathers, weighted as VCM's merges where a gather
// can sample the path (the photon's camera-side neighbour a non-delta surface
// vertex); radius scanned over four decades so gathers dominate somewhere.
TEST(VcmMis, UpgWeightsSumToOne) {
  PCG32 r(17, 5);
  int with_gathers = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    int k = 2 + int(r.next_u32() % 6);
    bool point = r.next_float() < 0.3f, balance = r.next_float() < 0.3f;
    float radius = std::pow(10.f, -4.f + 4.f * r.next_float());
    TestPath P = random_path(r, k, point, true);
    int n = 0, n_bdpt = 0;
    VcmParams p = params(VcmMode::kUpg, balance, radius);
    double s = weight_sum(p, P, &n);
    weight_sum(params(VcmMode::kBpt, balance, radius), P, &n_bdpt);
    if (n == 0) continue;
    with_gathers += n > n_bdpt;
    EXPECT_NEAR(s, 1.0, 1e-4) << "trial " << trial << " k " << k << " radius " << radius;
  }
  EXPECT_GT(with_gathers, 1000);  // the test exercises gathers, not only BDPT's strategies
}

// Sensitivity: upg with vcm's rule (a merge term at every non-delta vertex)
// instead of its own breaks the sum on paths where a gather cannot run.
TEST(VcmMis, UpgWithVcmMergeRuleIsDetected) {
  PCG32 r(19, 6);
  int broken = 0, n = 0;
  for (int trial = 0; trial < 200; ++trial) {
    TestPath P = random_path(r, 6, false, true);
    VcmParams p = params(VcmMode::kUpg, false, 0.3f);
    EXPECT_NEAR(weight_sum(p, P), 1.0, 1e-4);
    g_upg_rules = false;
    broken += std::fabs(weight_sum(p, P) - 1.0) > 1e-3;
    g_upg_rules = true;
    ++n;
  }
  EXPECT_GT(broken, n / 2);
}

// The check is sensitive: a wrong update (here the light subpath's reverse
// densities scaled by 1.2, as a forgotten continuation probability would) breaks the sum.
TEST(VcmMis, WrongBookkeepingIsDetected) {
  PCG32 r(5, 4);
  TestPath P = random_path(r, 5, false, false);
  VcmParams p = params(VcmMode::kBpt, false, 0.01f);
  EXPECT_NEAR(weight_sum(p, P), 1.0, 1e-4);
  g_rev_scale = 1.2f;
  double bad = weight_sum(p, P);
  g_rev_scale = 1.f;
  EXPECT_GT(std::fabs(bad - 1.0), 1e-3);
}

// The light BVH (--light-sampler bvh): next-event estimation picks the light with another probability than the
// light subpath did (here anywhere from 0.01 to 1 against the subpath's 0.4). With each strategy's own pick
// in its densities, as vcm.h passes them, the weights of BDPT, VCM and upg still sum to one; without NEE's
// pick ratio they do not.
TEST(VcmMis, LightBvhPicksWeightsSumToOne) {
  PCG32 r(23, 7);
  int broken = 0, n_paths = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    int k = 2 + int(r.next_u32() % 6);
    bool point = r.next_float() < 0.3f, balance = r.next_float() < 0.3f;
    float radius = std::pow(10.f, -4.f + 4.f * r.next_float());
    TestPath P = random_path(r, k, point, true);
    P.nee_pick = 0.01f + 0.99f * r.next_float();
    const VcmMode modes[3] = {VcmMode::kBpt, VcmMode::kVcm, VcmMode::kUpg};
    VcmParams p = params(modes[trial % 3], balance, radius);
    int n = 0;
    double s = weight_sum(p, P, &n);
    if (n == 0) continue;
    EXPECT_NEAR(s, 1.0, 1e-4) << "trial " << trial << " k " << k << " nee_pick " << P.nee_pick;
    if (P.x[1].delta || std::fabs(P.nee_pick - P.pick) < 0.05f) continue;
    g_nee_ratio = false;
    broken += std::fabs(weight_sum(p, P) - 1.0) > 1e-3;
    g_nee_ratio = true;
    ++n_paths;
  }
  EXPECT_GT(broken, n_paths / 2) << broken << " of " << n_paths;
}

// Medium vertices (phase function, |cos| 1, merged by bpm and vcm with rel = mis(4/3 r_v^3 sigma_t / r^2)) among
// surface and delta vertices: bdpt's, bpm's, vcm's and upg's (gathers at surface pairs only) weights still sum
// to one (radius over four decades, the volume radius the same or within a decade of it, sigma_t over four
// decades).
TEST(VcmMis, WeightsSumToOneWithMediumVertices) {
  PCG32 r(23, 7);
  int with_media = 0;
  for (VcmMode mode : {VcmMode::kBpt, VcmMode::kBpm, VcmMode::kVcm, VcmMode::kUpg}) {
    for (int trial = 0; trial < 3000; ++trial) {
      int k = 2 + int(r.next_u32() % 6);
      bool point = r.next_float() < 0.3f, balance = r.next_float() < 0.3f;
      float radius = std::pow(10.f, -4.f + 4.f * r.next_float());
      float volume_radius = trial % 2 ? 0.f : radius * std::pow(10.f, -1.f + 2.f * r.next_float());
      TestPath P = random_path(r, k, point, true, true);
      for (const V& v : P.x) with_media += v.medium;
      int n = 0;
      double s = weight_sum(params(mode, balance, radius, volume_radius), P, &n);
      if (n == 0) continue;
      EXPECT_NEAR(s, 1.0, 1e-4) << "mode " << int(mode) << " trial " << trial << " k " << k << " radius " << radius;
    }
  }
  EXPECT_GT(with_media, 6000);
}

// Sensitivity: upg's gathers at surface pairs only, but the bookkeeping kept as before upg rendered media (a
// light vertex's pending term committed at a medium vertex after it, a connection to a camera vertex in a
// medium given the light side's term): the sum breaks on the paths where a surface vertex meets a medium
// vertex in a way that matters (measured: 130 of the 358 paths with medium vertices).
TEST(VcmMis, UpgMediumRulesAreDetected) {
  PCG32 r(31, 9);
  int broken = 0, n = 0;
  for (int trial = 0; trial < 400; ++trial) {
    TestPath P = random_path(r, 6, false, true, true);
    bool any = false;
    for (const V& v : P.x) any = any || v.medium;
    if (!any) continue;
    VcmParams p = params(VcmMode::kUpg, false, 0.3f);
    EXPECT_NEAR(weight_sum(p, P), 1.0, 1e-4);
    g_upg_media_rules = false;
    const double bad = weight_sum(p, P);
    g_upg_media_rules = true;
    broken += std::fabs(bad - 1.0) > 1e-3;
    ++n;
  }
  EXPECT_GT(n, 200);
  EXPECT_GT(broken, n / 4) << broken << " of " << n;
}

// Sensitivity: with merges at medium vertices, running quantities and connections that leave out their merge
// term (the rule before volumetric merging), or give it a surface vertex's size, break the sum.
TEST(VcmMis, MediumMergeTermIsDetected) {
  for (int rule : {1, 2}) {
    PCG32 r(29, 8);
    int broken = 0, n = 0;
    for (int trial = 0; trial < 300; ++trial) {
      TestPath P = random_path(r, 6, false, true, true);
      bool any = false;
      for (const V& v : P.x) any = any || v.medium;
      if (!any) continue;
      VcmParams p = params(trial % 2 ? VcmMode::kVcm : VcmMode::kBpm, false, 0.3f, trial % 3 ? 0.f : 0.6f);
      EXPECT_NEAR(weight_sum(p, P), 1.0, 1e-4);
      g_medium_rule = rule;
      broken += std::fabs(weight_sum(p, P) - 1.0) > 1e-3;
      g_medium_rule = 0;
      ++n;
    }
    EXPECT_GT(n, 100);
    EXPECT_GT(broken, n / 2) << "rule " << rule << ": " << broken << " of " << n;
  }
}
