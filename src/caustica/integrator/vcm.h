// Bidirectional light transport as stage functions: light tracing (`light`),
// bidirectional path tracing (`bdpt`), bidirectional photon mapping (`bpm`) and
// vertex connection and merging (`vcm`), one implementation with four modes.
//
// Papers:
//   Veach 1997, "Robust Monte Carlo Methods for Light Transport Simulation",
//     Ch. 10 (bidirectional path tracing; the power heuristic, Eq. 9.13, over the
//     strategies (s, t)); camera importance W_e as in pbrt-v4 Sec. 5.4.
//   Georgiev, Krivanek, Davidovic, Slusallek 2012, "Light Transport Simulation
//     with Vertex Connection and Merging" (SIGGRAPH Asia): vertex merging as a
//     path sampling technique whose pdf is the connection's times the
//     acceptance probability ~ pi r^2 p(x) of the merged vertex, combined with
//     the connections by MIS; the radius schedule r_i = r_1 i^((alpha - 1) / 2).
//   Georgiev 2012, "Implementing Vertex Connection and Merging" (technical
//     report): the MIS weights computed from three running quantities per
//     subpath vertex, dVCM, dVC and dVM, so a weight needs only the pdfs at the
//     two vertices being joined. Equation numbers below refer to it:
//       eta_VCM = N_VM pi r^2 with n_VC = 1, n_VM = N_light      (20)
//       full weight w = 1 / (w_light + 1 + w_camera)             (37)
//       subpath start                                            (31)-(33)
//       after a segment / a non-delta BSDF sample                (34)-(36)
//       after a delta (specular) BSDF sample                     (53)-(55)
//       merging: w_light, w_camera                               (38), (39)
//       light vertex to camera vertex                            (40), (41)
//       camera hits a light (s = 0): w_light = 0, w_camera       (42), (43)
//       next-event estimation (s = 1)                            (44), (45)
//       light vertex to the camera (t = 1): w_light, w_camera = 0 (46), (47)
//     mis(x) = x^beta: beta = 2 (power heuristic, default) or 1 (balance).
//
// Conventions. Depth counts segments (Mitsuba's convention, as path.h): a light
// subpath vertex after L segments and a camera vertex after T segments joined
// by a connection make a path of L + T + 1 segments, by a merge L + T. Densities
// carry the light selection probability where the report's do. Russian roulette
// (on throughput) is not part of the MIS densities: the weights still sum to one
// over the strategies (they use the same densities for every strategy), and
// each strategy divides by its true sampling density.
//
// Pixel filters. A camera sample of pixel j lands at raster offset d from the
// pixel centre with density p(d) (filter importance sampling, film/filter.h)
// and measures h(d), the normalised filter. Camera strategies weight a sample
// by h/p; light-tracing splats go to every pixel whose filter covers the raster
// point, each with h(d) and its own MIS weight using p(d) as the camera's
// raster density (box and tent: p = h; gaussian: p is the untruncated shape;
// mitchell and lanczos: p is tabulated |h|, and h/p < 0 in their negative lobes,
// so a camera subpath's throughput may be negative: Russian roulette uses
// magnitudes, max_abs_component).
//
// Participating media (`light`, `bdpt`, `bpm`, `vcm`, `upg`; upg's gathers in media: upg.h). Both subpaths
// sample free-flight distances in the medium their ray is in with the path tracer's estimator (medium/medium.h:
// a hero channel per subpath, spectral MIS over the subpath; delta tracking in grid media), so a subpath's
// throughput is unbiased per channel however its hero was drawn, and a connection of two independent
// subpaths is too. A scattering event is a vertex like a surface's with the Henyey-Greenstein phase function
// in the place of the BSDF and no cosine: in the MIS quantities its |cos| is 1 (the geometry term has a
// cosine at surface points only; pbrt-v3's BDPT, Sec. 16.3, converts a medium vertex's density to area by
// 1/d^2 alone). Like that BDPT, the MIS densities leave out the free-flight and transmittance factors of the
// segments: every strategy's weight for a path is computed from the same densities, so the weights still sum
// to one and each strategy's estimate stays unbiased; only the weights' quality suffers where transmittance
// varies strongly.
// Volumetric merging (`bpm`, `vcm`): a camera vertex in a medium merges with the light vertices in the same
// medium within the ball of radius r around it, the point-point estimator of Krivanek, Georgiev, Hachisuka,
// Vevoda, Sik, Nowrouzezahrai, Jarosz 2014, "Unifying Points, Beams, and Paths in Volumetric Light Transport
// Simulation" (UPBP; Jensen & Christensen 1998's volume radiance estimate): the light vertices carry their
// sigma_s (their throughput includes the event's), the camera's weight leaves out its own, and the kernel is
// 1 / (4/3 pi r_v^3 N_VM) (vcm_camera_merge_medium). The ball's radius r_v is the surface merges' r unless
// given (--volume-radius; then it shrinks as pass^((alpha - 1) / 3), the 3D kernel's schedule, and the
// volume merges use a grid of their own). A merge's acceptance probability is the ball's volume times the
// light subpath's density of the vertex per volume; as the MIS densities leave out free-flight factors, that
// density is taken as sigma_t(x) (the mean over channels at the vertex: a function of the point, the same
// from either subpath) times the density per area, so a medium vertex's merge term is eta_VCM times
// rel = mis(4/3 r_v^3 sigma_t(x) / r^2) (vcm_medium_vm_rel; a surface vertex's rel is 1). With rel varying per vertex the
// running quantities keep the report's form: dVC gains vm_factor rel and dVM gains rel at each vertex
// (vcm_after_scatter), the merge and connection terms of a vertex are vm_factor rel (vcm_cam_vm, vcm_lt_vm), and
// a merge at a medium vertex divides its w_light and w_camera by rel (vcm_weight_merge); dVM stays dVC vc_factor
// as in the report, so the weights sum to one (tests/cpp/test_vcm_mis.cpp).
// Connections, next-event estimation and light-tracing splats carry the transmittance of their segment
// (ratio tracking in grid media, medium_scene.h's shadow_transmittance), through null surfaces, which
// subpaths also cross without a vertex (the segment's length for the 1/d^2 conversion runs from the last
// vertex). Russian roulette at a medium vertex continues with the event's albedo. Camera subpaths score an
// emissive medium's emission at their events with MIS weight 1 (no light subpath starts in a medium).
//
// Modes (as SmallVCM's algorithms): kLight uses only t = 1 (light tracing, no
// MIS) plus camera rays through specular chains for L S* E; kBpt all
// connections; kBpm all merges (plus emission on purely specular camera
// chains); kVcm both.
#pragma once
#include "../base/sampler.h"
#include "../light/light_emit.h"
#include "../light/light_sample.h"
#include "../material/bsdf.h"
#include "../medium/medium_scene.h"
#include "../photon/hash_grid.h"
#include "../scene/shading.h"

namespace caustica {

// kUpg: BDPT's strategies weighed against unbiased photon gathering (upg.h):
// the MIS of vcm with each merge replaced by the gather that samples the same
// path (see vcm_after_scatter), no merging.
enum class VcmMode : uint32_t { kLight = 0, kBpt, kBpm, kVcm, kUpg };

struct VcmParams {
  VcmMode mode = VcmMode::kVcm;
  uint32_t max_depth = 0xffffffffu;  // segments
  uint32_t rr_depth = 5;
  uint64_t seed = 0;
  uint32_t pass = 0;
  SamplerType sampler = SamplerType::kSobol;
  bool balance = false;     // balance heuristic instead of the power heuristic
  float n_light = 1.f;      // light subpaths per pass (N_VM in the paper)
  float radius = 0.f;       // merge radius of this pass
  float vm_factor = 0.f;    // mis(eta_VCM), 0 without merging   (report Sec. 5.1)
  float vc_factor = 0.f;    // mis(1 / eta_VCM), 0 without connections
  float vm_norm = 0.f;      // 1 / (pi r^2 N_VM)
  float radius_v = 0.f;     // volumetric merging's radius of this pass (header comment; r unless given)
  float vm_norm_v = 0.f;    // 1 / (4/3 pi r_v^3 N_VM)
  // The medium of the region outside every medium boundary, where a light subpath starts when its first ray
  // meets no boundary: the camera's medium when the camera is in that region (an unbounded fog), else vacuum
  // (vcm_outer_medium in vcm_render.cpp).
  int32_t outer_medium = -1;
  // Next-event estimation (s = 1) chooses its light by the light BVH from the camera vertex (light/light_bvh.h)
  // instead of by power; light subpaths still start in proportion to power. See vcm_nee_pick.
  bool light_bvh = false;
  // Emitters seen directly from the camera add nothing (PathParams::hide_emitters): vcm_camera_emission_weight.
  bool hide_emitters = false;
  CHD bool use_vc() const { return mode == VcmMode::kBpt || mode == VcmMode::kVcm || mode == VcmMode::kUpg; }
  // Merge-like strategies in the MIS sums (merges, or upg's gathers).
  CHD bool use_vm() const { return mode == VcmMode::kBpm || mode == VcmMode::kVcm || mode == VcmMode::kUpg; }
  // Vertex merging proper (density estimation at camera vertices).
  CHD bool merges() const { return mode == VcmMode::kBpm || mode == VcmMode::kVcm; }
  CHD bool use_lt() const { return mode != VcmMode::kBpm; }  // t = 1 strategies
};

CHD float vcm_mis(const VcmParams& p, float x) { return p.balance ? x : x * x; }

// The probability that next-event estimation from surface point x chooses `light` (power_pick: its probability
// by power). With the light BVH the s = 1 strategy's density of a path's light vertex differs from the light
// subpath's (which chose the light by power): every MIS ratio between the two uses each one's own pick. The
// BVH's reference point is the vertex's surface point itself, the same whichever subpath reached it.
CHD float vcm_nee_pick(const SceneView& s, const VcmParams& p, Vec3f x, uint32_t light, float power_pick) {
  return p.light_bvh ? light_bvh_pmf(s.light_bvh, x, light) : power_pick;
}

// Fills the factors for a pass with radius r (eta_VCM = N pi r^2, report Eq. 20) and volumetric merging's
// radius rv (0: r).
CHD void vcm_set_radius(VcmParams& p, float r, float rv = 0.f) {
  p.radius = r;
  float eta = kPi * r * r * p.n_light;
  p.vm_factor = p.use_vm() ? vcm_mis(p, eta) : 0.f;
  p.vc_factor = p.use_vc() ? vcm_mis(p, 1.f / eta) : 0.f;
  p.vm_norm = p.use_vm() ? 1.f / eta : 0.f;
  p.radius_v = rv > 0.f ? rv : r;
  p.vm_norm_v = p.use_vm() ? 1.f / ((4.f / 3.f) * kPi * p.radius_v * p.radius_v * p.radius_v * p.n_light) : 0.f;
}

// ---------------------------------------------------------------------------
// The running MIS quantities and their updates (report Eqs. 31-36, 53-55).
struct VcmMis {
  float dVCM = 0.f, dVC = 0.f, dVM = 0.f;
  // upg's light subpaths only: the merge-like term of the vertex just left,
  // not yet in dVC (as vm_factor pend) and dVM (as pend), because a gather can
  // sample the path there only if the *next* vertex scatters through a non-delta
  // lobe (the gathered photon is joined to it). vcm_after_scatter adds it or
  // drops it; vcm_mis_commit adds it where the subpath ends in a connection.
  float pend = 0.f;
};

// A medium vertex's merge term relative to a surface vertex's (header comment: rel = mis(4/3 r_v^3 sigma_t(x) /
// r^2), the ball's volume over the disc's area times sigma_t(x), the mean over channels at x); 0 where no merge
// runs (light, bdpt, and upg, which gathers at surface vertices only: upg.h).
CHD float vcm_medium_vm_rel_of(const VcmParams& p, float sigma_t) {
  return p.merges() ? vcm_mis(p, (4.f / 3.f) * p.radius_v * p.radius_v * p.radius_v * sigma_t /
                                     (p.radius * p.radius))
                    : 0.f;
}
CHD float vcm_medium_vm_rel(const SceneView& s, const VcmParams& p, int32_t medium, Vec3f x) {
  if (!p.merges()) return 0.f;
  const Medium& md = s.media[medium];
  const RGB st = md.grid >= 0 ? grid_coefficients(md, s.medium_grids, s.grid_values, x).sigma_t : medium_sigma_t(md);
  return vcm_medium_vm_rel_of(p, (st.x + st.y + st.z) * (1.f / 3.f));
}

// upg at a medium vertex: a gather joins its photon to the photon's neighbour on the camera side only where
// that is a non-delta surface vertex (upg.h), so the pending term of the light vertex before a medium vertex is
// dropped, as before a delta vertex (vcm_after_scatter). Only light subpaths defer that term, so only their medium
// vertices need it, once, where vcm_light_hit reaches them (before they are stored or scattered from).
CHD void vcm_upg_medium_vertex(const VcmParams& p, VcmMis& m) {
  if (p.mode == VcmMode::kUpg) m.pend = 0.f;
}

CHD VcmMis vcm_mis_commit(const VcmParams& p, VcmMis m) {
  m.dVC += p.vm_factor * m.pend;
  m.dVM += m.pend;
  m.pend = 0.f;
  return m;
}

// After tracing a segment of length `dist` that arrives with |cos| = cos_in at
// the new vertex (Eqs. 34-36): densities of the previous vertex's direction
// become area densities at this one. `area` is false for the first segment from
// an infinite light, whose densities stay per solid angle (report Sec. 5.1).
CHD void vcm_after_segment(const VcmParams& p, VcmMis& m, float dist, float cos_in, bool area) {
  if (area) m.dVCM *= vcm_mis(p, dist * dist);
  float ic = 1.f / vcm_mis(p, maxf(cos_in, 1e-8f));
  m.dVCM *= ic;
  m.dVC *= ic;
  m.dVM *= ic;
  m.pend *= ic;
}

// After sampling the next direction with |cos| = cos_out at the vertex, forward
// density pdf_dir and reverse density pdf_rev (both per solid angle).
//
// The merge term of this vertex (the "+ 1" of dVM, "+ vm_factor" of dVC) is the
// strategy that merges here; vm is its size relative to a surface vertex's (0: none, 1: a surface vertex, rel
// of vcm_medium_vm_rel at a medium vertex). For vcm and bpm it exists at every non-delta vertex.
// For upg it is the gather whose photon lies here, joined to the neighbour on
// the camera side, which must be a non-delta surface scattering (not the camera):
//   camera subpaths pass vm = 1 where the previous camera vertex was such a
//   vertex (VcmPathState::vm_ok), else 0;
//   light subpaths pass defer = true: the term waits in m.pend until the next
//   vertex's scattering is known (added if non-delta, dropped if delta).
CHD void vcm_after_scatter(const VcmParams& p, VcmMis& m, float cos_out, float pdf_dir, float pdf_rev, bool delta,
                           float vm = 1.f, bool defer = false) {
  if (delta) {
    // A delta vertex cannot end a subpath: no connection or merge there.
    m.dVCM = 0.f;
    m.dVC *= vcm_mis(p, cos_out);
    m.dVM *= vcm_mis(p, cos_out);
    m.pend = 0.f;  // upg: the previous vertex's gather would join a photon to this delta vertex
    return;
  }
  m = vcm_mis_commit(p, m);
  float g = vcm_mis(p, cos_out / pdf_dir);
  const float vm_now = defer ? 0.f : vm;
  float dVC = g * (m.dVC * vcm_mis(p, pdf_rev) + m.dVCM + p.vm_factor * vm_now);
  float dVM = g * (m.dVM * vcm_mis(p, pdf_rev) + m.dVCM * p.vc_factor + vm_now);
  m.dVC = dVC;
  m.dVM = dVM;
  m.pend = defer ? g * vm : 0.f;
  m.dVCM = vcm_mis(p, 1.f / pdf_dir);
}

// Light subpath start (Eqs. 31-33). emission_pdf_w and direct_pdf_a include the
// light selection probability; cos_light is 1 for infinite lights.
CHD VcmMis vcm_light_start_mis(const VcmParams& p, float direct_pdf_a, float emission_pdf_w, float cos_light,
                               bool delta) {
  VcmMis m;
  m.dVCM = vcm_mis(p, direct_pdf_a / emission_pdf_w);
  m.dVC = delta ? 0.f : vcm_mis(p, cos_light / emission_pdf_w);
  m.dVM = m.dVC * p.vc_factor;
  return m;
}

// Camera subpath start: camera_pdf_w is the solid-angle density of the camera
// ray; dVCM = mis(N_light / p_camera) (the t = 1 strategies splat N_light paths).
CHD VcmMis vcm_camera_start_mis(const VcmParams& p, float camera_pdf_w) {
  VcmMis m;
  m.dVCM = vcm_mis(p, p.n_light / camera_pdf_w);
  return m;
}

// Camera subpath hits an emitter (s = 0, Eqs. 42-43, 37); densities include the light
// selection probability. Returns the weight for camera path length >= 2.
CHD float vcm_weight_hit(const VcmParams& p, const VcmMis& cam, float direct_pdf_a, float emission_pdf_w) {
  float w_camera = vcm_mis(p, direct_pdf_a) * cam.dVCM + vcm_mis(p, emission_pdf_w) * cam.dVC;
  return 1.f / (1.f + w_camera);
}

// Next-event estimation (s = 1, Eqs. 44-45). direct_pdf_w: density of choosing
// the light point per solid angle at the camera vertex without the selection
// probability (d^2 for point lights, 1 for directional ones); emission_pdf_w
// without it too; bsdf_dir_pdf_w: camera BSDF towards the light (0 for delta
// lights); bsdf_rev_pdf_w: the reverse.
// cam_vm: the merge term at the camera vertex (p.vm_factor, or for upg 0 where
// vcm_cam_vm says no gather can sample the path there).
CHD float vcm_weight_nee(const VcmParams& p, const VcmMis& cam, float pick, float direct_pdf_w, float emission_pdf_w,
                         float cos_at_light, float cos_to_light, float bsdf_dir_pdf_w, float bsdf_rev_pdf_w,
                         float cam_vm) {
  float w_light = vcm_mis(p, bsdf_dir_pdf_w / (pick * direct_pdf_w));
  float w_camera = vcm_mis(p, emission_pdf_w * cos_to_light / (direct_pdf_w * cos_at_light)) *
                   (cam_vm + cam.dVCM + cam.dVC * vcm_mis(p, bsdf_rev_pdf_w));
  return 1.f / (w_light + 1.f + w_camera);
}

// The merge term at a light vertex joined to the camera (t = 1), vm_rel its size relative to a surface
// vertex's (vcm_medium_vm_rel): for upg none (a gathered photon is never joined to the camera itself).
CHD float vcm_lt_vm(const VcmParams& p, float vm_rel) {
  return p.mode == VcmMode::kUpg ? 0.f : p.vm_factor * vm_rel;
}

// Light vertex to camera (t = 1, Eqs. 46-47): camera_pdf_a is the camera's
// density of the light vertex (raster density -> area at the vertex); vm_rel as for vcm_lt_vm.
// (vcm_light_to_camera computes the same per pixel: VcmSplat::Q.)
CHD float vcm_weight_camera(const VcmParams& p, const VcmMis& light, float camera_pdf_a, float bsdf_rev_pdf_w,
                            float vm_rel = 1.f) {
  float w_light = vcm_mis(p, camera_pdf_a / p.n_light) *
                  (vcm_lt_vm(p, vm_rel) + light.dVCM + light.dVC * vcm_mis(p, bsdf_rev_pdf_w));
  return 1.f / (w_light + 1.f);
}

// The light side's merge term of a connection of light vertex v (its vm_rel) to a camera vertex: the merge
// of v, or upg's gather of v joined to the camera vertex, which needs that vertex to be a surface (upg.h).
CHD float vcm_connect_light_vm(const VcmParams& p, float light_vm_rel, bool camera_in_medium) {
  return p.mode == VcmMode::kUpg && camera_in_medium ? 0.f : p.vm_factor * light_vm_rel;
}

// Light vertex to camera vertex (Eqs. 40-41). *_dir_pdf_a: each side's BSDF
// density of the other vertex (area); *_rev_pdf_w: each side's reverse density.
// cam_vm as for vcm_weight_nee; light_vm the light side's merge term (the merge, or
// upg's gather, of the light vertex joined to this camera vertex): p.vm_factor times the vertex's rel
// (vcm_medium_vm_rel; 1 at a surface).
CHD float vcm_weight_connect(const VcmParams& p, const VcmMis& light, const VcmMis& cam, float cam_dir_pdf_a,
                             float cam_rev_pdf_w, float light_dir_pdf_a, float light_rev_pdf_w, float cam_vm,
                             float light_vm) {
  float w_light = vcm_mis(p, cam_dir_pdf_a) * (light_vm + light.dVCM + light.dVC * vcm_mis(p, light_rev_pdf_w));
  float w_camera = vcm_mis(p, light_dir_pdf_a) * (cam_vm + cam.dVCM + cam.dVC * vcm_mis(p, cam_rev_pdf_w));
  return 1.f / (w_light + 1.f + w_camera);
}

// Merging at a camera vertex (Eqs. 38-39): cam_dir_pdf_w is the camera BSDF's
// density of the light vertex's incoming direction, cam_rev_pdf_w the reverse; vm_rel the merging vertex's
// rel (1 at a surface; a medium vertex's merge is rel times a surface's, header comment).
CHD float vcm_weight_merge(const VcmParams& p, const VcmMis& light, const VcmMis& cam, float cam_dir_pdf_w,
                           float cam_rev_pdf_w, float vm_rel = 1.f) {
  float w_light = (light.dVCM * p.vc_factor + light.dVM * vcm_mis(p, cam_dir_pdf_w)) / vm_rel;
  float w_camera = (cam.dVCM * p.vc_factor + cam.dVM * vcm_mis(p, cam_rev_pdf_w)) / vm_rel;
  return 1.f / (w_light + 1.f + w_camera);
}

// ---------------------------------------------------------------------------
// Camera importance (pbrt-v4 Sec. 5.4; Veach 1997 Ch. 10). A camera ray at
// angle theta to the view axis through raster point x: d omega = A_pix cos^3
// theta dx, with A_pix the area of a pixel on the image plane at distance 1
// (the same for the thin lens, whose rays pass the focus plane at distance
// focus_distance). So a raster density p(x) is p / (A_pix cos^3 theta) per solid
// angle, and a light vertex y seen from lens point c contributes to pixel j
//   beta f |cos_y| h_j(x) / (|y - c|^2 A_pix cos^3 theta N_light).
// Orthographic: a camera ray starts at a film point with area density p / A_pix
// (A_pix now a pixel's area in scene units) and runs along the view axis, so a
// light vertex y is seen from the film point straight "below" it, and the film
// area dA = |cos_y| dA(y): its contribution is beta f |cos_y| h_j(x) / (A_pix
// N_light), and the camera subpath's first segment, like one from a directional
// light, keeps its density per area (no 1/d^2; vcm_camera_hit).
CHD float camera_pixel_area(const Camera& c) {
  return 4.f * c.tan_half_x * c.tan_half_y / (float(c.width) * float(c.height));
}
CHD Vec3f camera_lens_point(const Camera& c, Vec2f u) {
  if (c.aperture_radius <= 0.f) return c.position;
  Vec2f pl = square_to_concentric_disk(u) * c.aperture_radius;
  return c.position + c.right * pl.x + c.up * pl.y;
}
// The lens (film, for the orthographic camera) point that sees p: a sample of the
// lens, the pinhole, or p's projection onto the orthographic camera's plane.
CHD Vec3f camera_eye_point(const Camera& c, Vec3f p, Vec2f u) {
  if (c.orthographic) return p - c.forward * dot(p - c.position, c.forward);
  return camera_lens_point(c, u);
}
// Raster position of the camera ray from lens point `pl` towards `p`, and the
// cosine of that ray with the view axis; false behind the camera or outside its
// clipping planes (the depth along the view axis from the lens plane, as the
// camera rays' clipping in Camera::clip).
CHD bool camera_project(const Camera& c, Vec3f pl, Vec3f p, Vec2f& raster, float& cos_theta) {
  Vec3f d = p - pl;
  float dz = dot(d, c.forward);
  if (!(dz > 0.f) || dz < c.near_clip || dz > c.far_clip) return false;
  float dx = dot(d, c.right), dy = dot(d, c.up);
  float sx, sy;
  if (c.orthographic) {
    Vec3f o = pl - c.position;
    sx = dot(o, c.right);
    sy = dot(o, c.up);
  } else if (c.aperture_radius > 0.f) {
    Vec3f o = pl - c.position;
    float t = c.focus_distance / dz;
    sx = (dot(o, c.right) + dx * t) / c.focus_distance;
    sy = (dot(o, c.up) + dy * t) / c.focus_distance;
  } else {
    sx = dx / dz;
    sy = dy / dz;
  }
  sx -= c.shift_x;  // a crop window's centre
  sy -= c.shift_y;
  raster = Vec2f((sx / c.tan_half_x + 1.f) * 0.5f * float(c.width), (1.f - sy / c.tan_half_y) * 0.5f * float(c.height));
  cos_theta = c.orthographic ? 1.f : dz / length(d);
  return std::isfinite(raster.x) && std::isfinite(raster.y);
}

// ---------------------------------------------------------------------------
// Light densities (report Sec. 5.1's Emit / Illuminate / GetRadiance).
struct VcmEmission {
  Ray ray;
  RGB Le_cos{0.f};          // emitted radiance x cos (intensity, irradiance for delta and distant lights)
  float emission_pdf_w = 0.f;  // position x direction density, without the light selection probability
  float direct_pdf_a = 0.f;    // NEE density of the point (area; per solid angle for the environment); < 0:
                               // depends on the receiver (area lights), computed at the first hit
  float cos_light = 1.f;
  Vec3f p, n;                  // emission point and normal (area lights)
  bool delta = false, infinite = false;
};

CHD float vcm_area_light_area(const SceneView& s, const Light& l) {
  if (l.type == LightType::kTriangle) {
    Vec3f p0, p1, p2;
    triangle_vertices(s, l.prim, p0, p1, p2);
    return triangle_area(p0, p1, p2);
  }
  const Sphere& sp = s.spheres[l.prim - s.num_triangles];
  return 4.f * kPi * sp.radius * sp.radius;
}

// Emission density (position x direction) of a light leaving towards w (world),
// from point p_l with normal n_l for area lights; without the selection probability.
CHD float vcm_emission_pdf(const SceneView& s, const Light& l, Vec3f n_l, Vec3f w) {
  const float R = s.bsphere_radius;
  switch (l.type) {
    case LightType::kTriangle:
    case LightType::kSphere: {
      float c = dot(n_l, w);
      if (!l.two_sided && c <= 0.f) return 0.f;
      return std::fabs(c) * kInvPi / (vcm_area_light_area(s, l) * (l.two_sided ? 2.f : 1.f));
    }
    case LightType::kPoint: return uniform_sphere_pdf();
    case LightType::kSpot: return uniform_cone_pdf(l.cos_total);
    case LightType::kDirectional: return 1.f / (kPi * R * R);
    case LightType::kEnvironment: return environment_pdf(s, l, -w) / (kPi * R * R);
  }
  return 0.f;
}

CHD bool vcm_sample_emission(const SceneView& s, const Light& l, Vec2f u_pos, Vec2f u_dir, float u_side,
                             VcmEmission& e) {
  const float R = s.bsphere_radius;
  e = VcmEmission();
  switch (l.type) {
    case LightType::kTriangle:
    case LightType::kSphere: {
      Vec2f uv;
      if (l.type == LightType::kTriangle) {
        Vec3f p0, p1, p2;
        triangle_vertices(s, l.prim, p0, p1, p2);
        Vec2f b = square_to_uniform_triangle(u_pos);
        e.p = p0 * (1.f - b.x - b.y) + p1 * b.x + p2 * b.y;
        e.n = normalize(cross(p1 - p0, p2 - p0));
        uv = triangle_uv(s, l.prim, b.x, b.y);
      } else {
        const Sphere& sp = s.spheres[l.prim - s.num_triangles];
        e.n = square_to_uniform_sphere(u_pos);
        e.p = sp.center + e.n * sp.radius;
        uv = sphere_uv_at(s, l.prim - s.num_triangles, e.n);
      }
      Vec3f n_side = e.n;
      if (l.two_sided && u_side < 0.5f) n_side = -n_side;
      Vec3f wl = square_to_cosine_hemisphere(u_dir);
      Vec3f d = Frame(n_side).to_world(wl);
      e.ray = Ray{offset_ray_origin(e.p, e.n, d), d, kInf};
      e.cos_light = wl.z;
      e.emission_pdf_w = vcm_emission_pdf(s, l, e.n, d);
      e.direct_pdf_a = -1.f;
      RGB Le = l.L * area_coverage(s, l.prim, uv);
      if (l.texture >= 0) Le = Le * texture_lookup(s.textures[l.texture], uv).rgb();
      e.Le_cos = Le * wl.z;
      return e.emission_pdf_w > 0.f && !is_black(e.Le_cos);
    }
    case LightType::kPoint:
    case LightType::kSpot: {
      Vec3f d;
      float falloff = 1.f;
      if (l.type == LightType::kPoint) d = square_to_uniform_sphere(u_dir);
      else {
        Vec3f w = square_to_uniform_cone(u_dir, l.cos_total);
        falloff = spot_falloff(l, w.z);
        d = Frame(l.dir).to_world(w);
      }
      e.ray = Ray{l.p, d, kInf};
      e.emission_pdf_w = vcm_emission_pdf(s, l, Vec3f(0.f), d);
      e.direct_pdf_a = 1.f;
      e.Le_cos = l.L * falloff;
      e.delta = true;
      return !is_black(e.Le_cos);
    }
    case LightType::kDirectional:
    case LightType::kEnvironment: {
      float dir_pdf;
      if (!sample_infinite_emission(s, l, u_pos, u_dir, e.ray, dir_pdf)) return false;
      Vec3f dir = e.ray.d;
      e.emission_pdf_w = dir_pdf / (kPi * R * R);
      e.direct_pdf_a = dir_pdf;
      e.infinite = true;
      e.delta = l.type == LightType::kDirectional;
      e.Le_cos = l.type == LightType::kDirectional ? l.L : environment_radiance(s, l, -dir);
      return !is_black(e.Le_cos);
    }
  }
  return false;
}

// NEE density of an area light point p_l (normal n_l) seen from ref, per unit
// area, without the selection probability.
CHD float vcm_direct_pdf_a(const SceneView& s, const Light& l, Vec3f ref, Vec3f p_l, Vec3f n_l) {
  Vec3f d = p_l - ref;
  float d2 = length_sq(d);
  if (!(d2 > 0.f)) return 0.f;
  return light_pdf(s, l, ref, p_l, n_l) * absdot(n_l, d) / (std::sqrt(d2) * d2);
}

// ---------------------------------------------------------------------------
// Per-path state and light vertices.
struct VcmLightVertex {
  SurfaceHit sh;  // before surface_material (the material is rebuilt at use); a medium vertex: only sh.p
  Vec3f wi;       // world direction towards the previous vertex
  RGB beta{0.f};  // throughput arriving at the vertex
  uint32_t length = 0;  // segments from the light
  VcmMis mis;
  int32_t medium = -1;  // a scattering event in a medium (no surface): its medium; -1: a surface vertex
  float vm_rel = 1.f;   // its merge term relative to a surface vertex's (vcm_medium_vm_rel)
  CHD bool in_medium() const { return medium >= 0; }
};

// What a merge reads of a light vertex (36 bytes against VcmLightVertex's 108):
// the merging stage keeps these in the photon grid's order, so that the records
// found by one query lie close together in memory.
struct VcmMergeVertex {
  Vec3f wi;
  RGB beta{0.f};
  float dVCM = 0.f, dVM = 0.f;
  uint16_t length = 0;  // segments from the light (at most 65535: no subpath gets near)
  int16_t medium = -1;  // a medium vertex's medium (merged at camera vertices in it), -1: a surface vertex
};

CHD VcmMergeVertex vcm_merge_vertex(const VcmLightVertex& v) {
  VcmMergeVertex m;
  m.wi = v.wi;
  m.beta = v.beta;
  m.dVCM = v.mis.dVCM;
  m.dVM = v.mis.dVM;
  m.length = uint16_t(v.length < 65535u ? v.length : 65535u);
  m.medium = int16_t(v.medium);
  return m;
}

struct VcmPathState {
  Ray ray;
  RGB beta{1.f};
  RGB L{0.f};            // camera: radiance gathered (already weighted by h/p)
  VcmMis mis;
  uint32_t length = 0;   // segments traced before `ray`
  bool specular = true;  // every scattering so far was a delta lobe
  bool vm_ok = false;    // camera: the previous vertex is a surface that scattered through a non-delta lobe
  bool active = true;
  Vec3f prev_p;
  Vec3f prev_x;          // the previous vertex's surface point (the BVH's NEE reference there; vcm_nee_pick)
  // light subpaths
  int32_t light = -1;
  float pick = 1.f, emission_pdf_w = 0.f;
  Vec3f light_p, light_n;
  bool infinite = false, receiver_pdf = false;
  uint32_t pixel = 0;
  Sampler sampler;       // camera: the pixel sampler; light: an independent stream
  // The vertex just hit (set by the *_hit stages).
  SurfaceHit sh;
  Material m;
  Frame frame;
  Vec3f wo_world, wo;    // towards the previous vertex
  Vec3f p_front;
  bool vertex_valid = false;
  // Participating media (header comment): the medium `ray` travels in (-1: vacuum), the subpath's hero channel
  // (-1: none drawn yet) and distance densities per channel scaled to average 1 (medium/medium.h), the null
  // surfaces crossed since the last vertex and the distance travelled through them (seg_t), whether the vertex
  // just reached is a scattering event in the medium (then sh.p is its point) and the throughput before that
  // event (its Russian roulette), and whether the last hit stage only crossed a null surface (`ray` goes on).
  int32_t medium = -1;
  int32_t hero = -1;
  RGB r_medium{1.f};
  uint32_t null_crossings = 0;
  float seg_t = 0.f;
  bool in_medium = false;
  bool crossing = false;
  RGB beta_in{0.f};
  // At a medium vertex: sigma_s there (what a merge divides the camera's throughput by) and the vertex's merge
  // term relative to a surface vertex's (vcm_medium_vm_rel); 1 at a surface vertex.
  RGB sigma_s{0.f};
  float vm_rel = 1.f;
};

// ---------------------------------------------------------------------------
// Vertices in media (header comment).

// A vertex's scattering towards w: f (with the shading-normal adjoint for importance), its |cos| (1 in a
// medium), and the forward (wo -> w) and reverse densities per solid angle, each only where asked for (fwd,
// rev; else 0: a BSDF's density costs about what its value does).
struct VcmVertexEval {
  RGB f{0.f};
  float cos = 1.f, pdf_fwd = 0.f, pdf_rev = 0.f;
};

CHD VcmVertexEval vcm_eval_surface(const Material& m, const Frame& fr, const SurfaceHit& sh, Vec3f wo_world, Vec3f wo,
                                   Vec3f w, TransportMode mode, bool fwd = true, bool rev = true) {
  VcmVertexEval e;
  const Vec3f wl = fr.to_local(w);
  e.f = bsdf_eval(m, wo, wl, mode);
  if (is_black(e.f)) return e;
  if (mode == TransportMode::kImportance) e.f *= shading_normal_adjoint(sh, wo_world, w);
  e.cos = std::fabs(wl.z);
  if (fwd) e.pdf_fwd = bsdf_pdf(m, wo, wl);
  if (rev) e.pdf_rev = bsdf_pdf(m, wl, wo);
  return e;
}

// The forward and reverse densities of vcm_eval_surface alone, into e.
CHD void vcm_surface_pdfs(const Material& m, const Frame& fr, Vec3f wo, Vec3f w, VcmVertexEval& e) {
  const Vec3f wl = fr.to_local(w);
  e.pdf_fwd = bsdf_pdf(m, wo, wl);
  e.pdf_rev = bsdf_pdf(m, wl, wo);
}

// The Henyey-Greenstein phase function is symmetric: both densities are its value.
CHD VcmVertexEval vcm_eval_medium(float g, Vec3f wo_world, Vec3f w) {
  VcmVertexEval e;
  const float ph = hg_phase(dot(wo_world, w), g);
  e.f = RGB(ph);
  e.pdf_fwd = e.pdf_rev = ph;
  return e;
}

// The vertex st just reached, seen towards w (mode: the subpath's transport mode).
CHD VcmVertexEval vcm_eval_state(const SceneView& s, const VcmPathState& st, Vec3f w, TransportMode mode,
                                 bool fwd = true, bool rev = true) {
  if (st.in_medium) return vcm_eval_medium(s.media[st.medium].g, st.wo_world, w);
  return vcm_eval_surface(st.m, st.frame, st.sh, st.wo_world, st.wo, w, mode, fwd, rev);
}

// The point a ray from st's vertex towards w starts at, and the medium it starts in (a surface with a medium
// interface: the medium of the side it leaves on).
CHD Vec3f vcm_origin_towards(const VcmPathState& st, Vec3f w) {
  if (st.in_medium) return st.sh.p;
  return dot(w, st.sh.ng) * dot(st.wo_world, st.sh.ng) > 0.f ? st.p_front : offset_ray_origin(st.sh.p, st.sh.ng, w);
}
CHD int32_t vcm_medium_towards(const SceneView& s, const VcmPathState& st, Vec3f w) {
  if (st.in_medium || !s.prim_medium) return st.medium;
  return medium_after_crossing(prim_medium_interface(s, st.sh.prim), w, st.sh.ng, st.medium);
}

// The medium a light subpath starts in (medium_scene.h's locate_medium, p.outer_medium where its ray meets no
// boundary; vacuum in scenes without media).
template <typename Intersect>
CHD void vcm_light_locate(const SceneView& s, const VcmParams& p, VcmPathState& st, Intersect&& intersect) {
  if (st.active && scene_has_media(s)) st.medium = locate_medium(s, intersect, st.ray, p.outer_medium);
}

// Free-flight sampling on the segment st.ray traced to `hit` through st.medium (medium/medium.h, delta tracking
// in a grid medium from a stream of its own): true for a scattering event, which st becomes as a medium vertex
// (sh.p, wo_world, in_medium; the segment's length from the last vertex in *dist); false when the segment
// reaches the surface (st.beta then holds its transmittance factor) or the path ends (st.active false).
// `camera`: a camera subpath, which scores an emissive medium's emission at the event.
// (Out of line, as vcm_cross_null and vcm_scatter_medium: the hit and scatter stages of scenes without media
// stay as compact as before.)
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline bool vcm_medium_segment(const SceneView& s, VcmPathState& st,
                                                                     const Hit& hit, float& dist, bool camera) {
  const Medium& md = s.media[st.medium];
  const float dlen = length(st.ray.d);
  const Vec3f d = st.ray.d / dlen;
  const uint64_t track_seed = md.grid >= 0 ? st.sampler.stream_seed() : 0;
  const Vec2f u = st.sampler.next_2d();
  if (st.hero < 0) st.hero = medium_hero_channel(u.x);
  const MediumSample ms = medium_sample(s, md, st.ray.o, d, hit.valid() ? hit.t * dlen : kInf, st.hero, u.y,
                                        track_seed);
  const RGB before = st.beta;
  // An emissive medium's emission at a camera subpath's event (medium/medium.h's collision estimator, with the
  // throughput before the event): no other strategy samples such a path (light subpaths start at lights), so
  // its MIS weight is 1.
  if (camera) st.L += medium_event_emission(ms, st.beta, st.r_medium);
  if (!medium_update_throughput(ms, st.beta, st.r_medium) || is_black(st.beta) || !isfinite3(st.beta)) {
    st.active = false;
    return false;
  }
  if (!ms.scattered) return false;
  st.in_medium = true;
  st.beta_in = before;
  st.sigma_s = ms.sigma_s;
  st.sh = SurfaceHit();
  st.sh.p = st.ray.o + d * ms.t;
  st.wo_world = -d;
  st.p_front = st.sh.p;
  dist = st.seg_t + ms.t;
  return true;
}

// A null surface at st.sh: the subpath goes on through it without a vertex (st.crossing).
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline void vcm_cross_null(const SceneView& s, VcmPathState& st, float t) {
  st.crossing = true;
  st.seg_t += t * length(st.ray.d);
  if (!cross_null_surface(s, st.sh, st.ray, st.medium, st.null_crossings)) st.active = false;
}

// The light subpath of index `index` in pass p.pass: its random stream is independent of the camera's.
CHD void vcm_light_start(const SceneView& s, const VcmParams& p, uint32_t index, VcmPathState& st) {
  st = VcmPathState();
  st.active = false;
  st.sampler.start(SamplerType::kIndependent, hash3(p.seed, 0x6c69676874ull, p.pass), index, p.pass);
  if (s.num_lights == 0) return;
  float pick;
  uint32_t li = s.light_sampler.sample(st.sampler.next_1d(), pick);
  const Light& l = s.lights[li];
  Vec2f up = st.sampler.next_2d(), ud = st.sampler.next_2d();
  float us = st.sampler.next_1d();
  VcmEmission e;
  if (!vcm_sample_emission(s, l, up, ud, us, e)) return;
  st.light = int32_t(li);
  st.pick = pick;
  st.emission_pdf_w = e.emission_pdf_w * pick;
  st.beta = e.Le_cos / st.emission_pdf_w;
  st.ray = e.ray;
  st.prev_p = e.ray.o;
  st.light_p = e.p;
  st.light_n = e.n;
  st.infinite = e.infinite;
  // The NEE density of the light vertex depends on the receiver for area lights (cone sampling of spheres),
  // and with the light BVH for every finite light (its pick): then it is computed at the first hit.
  st.receiver_pdf = e.direct_pdf_a < 0.f || (p.light_bvh && !e.infinite);
  const float nee_pick = e.infinite ? vcm_nee_pick(s, p, e.p, li, pick) : pick;  // BVH: infinite ones' is constant
  st.mis = vcm_light_start_mis(p, st.receiver_pdf ? 1.f : e.direct_pdf_a * nee_pick, st.emission_pdf_w,
                               e.infinite ? 1.f : e.cos_light, e.delta);
  st.active = isfinite3(st.beta) && !is_black(st.beta);
}

// The light subpath reached `hit`: MIS update, the vertex (if not delta).
CHD bool vcm_light_hit(const SceneView& s, const VcmParams& p, VcmPathState& st, const Hit& hit, VcmLightVertex& v) {
  st.vertex_valid = false;
  st.crossing = false;
  st.in_medium = false;
  float dist = 0.f;
  if (st.medium >= 0 && vcm_medium_segment(s, st, hit, dist, false)) {
    // A scattering event in the medium: a vertex with the phase function (|cos| 1).
  } else {
    if (!st.active || !hit.valid()) {
      st.active = false;
      return false;
    }
    st.sh = make_surface_hit(s, st.ray, hit);
    if (is_null_surface(s, st.sh)) {
      vcm_cross_null(s, st, hit.t);
      return false;
    }
    dist = st.seg_t + hit.t;
    st.beta *= segment_transmittance(s, st.ray.d, hit.t, st.sh);
    st.wo_world = -st.ray.d;
    st.m = surface_material(s, st.sh);
    st.frame = shading_frame(s, st.sh, st.m);
    st.wo = st.frame.to_local(st.wo_world);
  }
  st.length += 1;
  st.seg_t = 0.f;
  st.null_crossings = 0;
  float cos_in = st.in_medium ? 1.f : std::fabs(st.wo.z);
  st.vm_rel = st.in_medium ? vcm_medium_vm_rel(s, p, st.medium, st.sh.p) : 1.f;
  if (st.length == 1 && st.receiver_pdf) {
    // The NEE density of the emission point seen from this receiver (area lights: per area; point and spot
    // lights: 1, the light itself; times the NEE pick); dVCM = mis(p_direct / p_emit).
    const Light& l = s.lights[st.light];
    const bool area = l.type == LightType::kTriangle || l.type == LightType::kSphere;
    float pa = (area ? vcm_direct_pdf_a(s, l, st.sh.p, st.light_p, st.light_n) : 1.f) *
               vcm_nee_pick(s, p, st.sh.p, uint32_t(st.light), st.pick);
    st.mis.dVCM = vcm_mis(p, pa / st.emission_pdf_w);
  }
  vcm_after_segment(p, st.mis, dist, cos_in, st.length > 1 || !st.infinite);
  if (!st.in_medium) {
    st.p_front = offset_ray_origin(st.sh.p, st.sh.ng, st.wo_world);
    if (material_is_delta(st.m)) return false;
  }
  st.vertex_valid = true;
  v.sh = st.sh;
  v.wi = st.wo_world;
  v.beta = st.beta;
  v.length = st.length;
  if (st.in_medium) vcm_upg_medium_vertex(p, st.mis);
  v.mis = vcm_mis_commit(p, st.mis);  // the vertex ends subpaths here: upg's pending term holds (at a surface)
  v.medium = st.in_medium ? st.medium : -1;
  v.vm_rel = st.vm_rel;
  return true;
}

// A light-tracing splat (t = 1): the contribution to pixel j is
// C h_j(x) / (1 + w_light_j) with w_light_j = mis(p_j(x) K / N) Q (Eq. 46).
struct VcmSplat {
  Ray ray;       // visibility
  Vec2f raster;
  RGB C{0.f};    // beta f K / N_light, K = |cos_y| / (d^2 A_pix cos^3 theta)
  float K = 0.f; // camera area density per unit raster density
  float Q = 0.f; // vm_factor + dVCM + dVC mis(p_rev)
  uint32_t length = 0;  // segments of the light subpath (the strategy s = length + 1, t = 1)
  int32_t medium = -1;  // the medium the visibility ray starts in (vcm_visibility)
  bool active = false;
};

CHD void vcm_light_to_camera(const SceneView& s, const VcmParams& p, VcmPathState& st, VcmSplat& sp) {
  sp.active = false;
  if (!st.vertex_valid || !p.use_lt() || st.length + 1 > p.max_depth) return;
  // A moving camera: each connection takes its own time (the scene is static, so the light
  // subpath is the same at every time and only the lens moves).
  // (A static camera is used in place: this runs per light vertex, so it is not copied.)
  Camera moved;
  const Camera& c = s.camera.moving ? (moved = s.camera.at(st.sampler.next_1d())) : s.camera;
  Vec3f pl = camera_eye_point(c, st.sh.p, st.sampler.next_2d());
  Vec2f raster;
  float cos_theta;
  if (!camera_project(c, pl, st.sh.p, raster, cos_theta)) return;
  const float fr = s.filter.radius;
  if (raster.x < -fr || raster.y < -fr || raster.x > float(c.width) + fr || raster.y > float(c.height) + fr) return;
  Vec3f d = pl - st.sh.p;
  float d2 = length_sq(d);
  Vec3f w = d / std::sqrt(d2);
  // The splat's MIS weight needs the reverse density only (light tracing alone, none).
  const VcmVertexEval e = vcm_eval_state(s, st, w, TransportMode::kImportance, false, p.mode != VcmMode::kLight);
  if (is_black(e.f)) return;
  float cos_y = e.cos;
  float K = c.orthographic ? cos_y / camera_pixel_area(c)
                           : cos_y / (d2 * camera_pixel_area(c) * cos_theta * cos_theta * cos_theta);
  sp.C = st.beta * e.f * (K / p.n_light);
  sp.K = K;
  VcmMis lm = vcm_mis_commit(p, st.mis);
  sp.Q = p.mode == VcmMode::kLight ? 0.f : vcm_lt_vm(p, st.vm_rel) + lm.dVCM + lm.dVC * vcm_mis(p, e.pdf_rev);
  sp.raster = raster;
  sp.length = st.length;
  // A near clipping plane: what lies between it and the lens does not occlude (camera rays start there).
  const Vec3f eye = c.near_clip > 0.f ? pl + (st.sh.p - pl) * (c.near_clip / dot(st.sh.p - pl, c.forward)) : pl;
  sp.ray = spawn_ray_to(vcm_origin_towards(st, w), eye, Vec3f(0.f));
  sp.medium = vcm_medium_towards(s, st, w);
  sp.active = isfinite3(sp.C) && !is_black(sp.C);
}

// Calls add(pixel, RGB) for every pixel the splat reaches, with its MIS weight.
template <typename Add>
CHD void vcm_splat_pixels(const SceneView& s, const VcmParams& p, const VcmSplat& sp, Add&& add) {
  const Camera& c = s.camera;
  const Filter& f = s.filter;
  const float r = f.radius;
  int x0 = int(std::ceil(sp.raster.x - 0.5f - r)), x1 = int(std::floor(sp.raster.x - 0.5f + r));
  int y0 = int(std::ceil(sp.raster.y - 0.5f - r)), y1 = int(std::floor(sp.raster.y - 0.5f + r));
  const bool pixel_box = f.type == FilterType::kBox && r == 0.5f;
  if (pixel_box) {  // the pixel containing the point (half-open)
    x0 = x1 = int(std::floor(sp.raster.x));
    y0 = y1 = int(std::floor(sp.raster.y));
  }
  for (int y = y0 > 0 ? y0 : 0; y <= y1 && y < c.height; ++y)
    for (int x = x0 > 0 ? x0 : 0; x <= x1 && x < c.width; ++x) {
      float dx = sp.raster.x - (float(x) + 0.5f), dy = sp.raster.y - (float(y) + 0.5f);
      float h, pr;
      if (pixel_box) h = pr = 1.f;
      else {
        h = filter_h1(f, dx) * filter_h1(f, dy);  // negative in a negative lobe (mitchell, lanczos)
        pr = filter_p1(f, dx) * filter_p1(f, dy);
      }
      if (h == 0.f) continue;
      float w = p.mode == VcmMode::kLight ? 1.f : 1.f / (1.f + vcm_mis(p, pr * sp.K / p.n_light) * sp.Q);
      add(uint32_t(y) * uint32_t(c.width) + uint32_t(x), sp.C * (h * w));
    }
}

// Russian roulette continues with the scattering's albedo, the throughput ratio
// without the 1/eta^2 that refraction gives radiance (else a camera path entering
// glass would be killed with probability 1 - 1/eta^2 and its survivors doubled on
// the way out; pbrt-v4 and Mitsuba 3 keep the same factor, "eta scale").
CHD float vcm_rr_eta2(const BSDFSample& bs, TransportMode mode) {
  return mode == TransportMode::kRadiance ? bs.eta * bs.eta : 1.f;
}

// The next direction from a medium vertex by the phase function (weight 1), Russian roulette with the event's
// albedo (the throughput over the one before the event).
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline bool vcm_scatter_medium(const SceneView& s, const VcmParams& p,
                                                                     VcmPathState& st) {
  st.sampler.next_1d();  // the BSDF's lobe number, unused: both kinds of vertex take the same count
  const Vec2f u = st.sampler.next_2d();
  const float u_rr = st.sampler.next_1d();
  float pdf;
  const Vec3f wi = hg_sample(st.wo_world, s.media[st.medium].g, u, &pdf);
  vcm_after_scatter(p, st.mis, 1.f, pdf, pdf, false, st.vm_rel);
  st.vm_ok = false;
  st.specular = false;
  if (st.length >= p.rr_depth) {
    const float q = minf(1.f, max_abs_component(st.beta) / maxf(max_abs_component(st.beta_in), 1e-30f));
    if (!(u_rr < q)) return st.active = false;
    st.beta /= q;
  }
  st.ray = Ray{st.sh.p, wi, kInf};
  st.prev_p = st.sh.p;
  st.prev_x = st.sh.p;
  return true;
}

// Samples the next direction (both subpaths); false ends the path.
CHD bool vcm_scatter(const SceneView& s, const VcmParams& p, VcmPathState& st, TransportMode mode) {
  if (st.in_medium) return vcm_scatter_medium(s, p, st);
  float uc = st.sampler.next_1d();
  Vec2f u = st.sampler.next_2d();
  float u_rr = st.sampler.next_1d();
  BSDFSample bs;
  if (!bsdf_sample(st.m, st.wo, uc, u, bs, mode)) return st.active = false;
  Vec3f wi_world = st.frame.to_world(bs.wi);
  if (dot(wi_world, st.sh.ng) * bs.wi.z * dot(st.sh.ns, st.sh.ng) < 0.f) return st.active = false;
  float pdf_rev = bs.delta ? bs.pdf : bsdf_pdf(st.m, bs.wi, st.wo);
  const bool upg = p.mode == VcmMode::kUpg, light = mode == TransportMode::kImportance;
  vcm_after_scatter(p, st.mis, std::fabs(bs.wi.z), bs.pdf, pdf_rev, bs.delta,
                    !upg || light || st.vm_ok ? 1.f : 0.f, upg && light);
  st.vm_ok = !bs.delta;
  st.specular = st.specular && bs.delta;
  RGB prev = st.beta;
  st.beta *= bs.weight;
  if (light) st.beta *= shading_normal_adjoint(st.sh, st.wo_world, wi_world);
  if (is_black(st.beta) || !isfinite3(st.beta)) return st.active = false;
  if (st.length >= p.rr_depth) {
    float q = minf(1.f, max_abs_component(st.beta) * vcm_rr_eta2(bs, mode) / maxf(max_abs_component(prev), 1e-30f));
    if (!(u_rr < q)) return st.active = false;
    st.beta /= q;
  }
  st.ray.o = dot(wi_world, st.sh.ng) * dot(st.wo_world, st.sh.ng) > 0.f ? st.p_front
                                                                        : offset_ray_origin(st.sh.p, st.sh.ng, wi_world);
  st.ray.d = wi_world;
  st.ray.tmax = kInf;
  st.prev_p = st.ray.o;
  st.prev_x = st.sh.p;
  st.medium = vcm_medium_towards(s, st, wi_world);
  return true;
}

CHD void vcm_light_continue(const SceneView& s, const VcmParams& p, VcmPathState& st) {
  if (!st.active || st.crossing) return;  // after a null surface the ray goes on as it was
  // A vertex after L segments is used by paths of at least L + 1 segments; the next one by L + 2.
  if (p.max_depth != 0xffffffffu && st.length + 2 > p.max_depth) {
    st.active = false;
    return;
  }
  vcm_scatter(s, p, st, TransportMode::kImportance);
}

// ---------------------------------------------------------------------------
// Camera subpaths.

// Starts pixel (px, py)'s camera path of pass p.pass.
CHD void vcm_camera_start(const SceneView& s, const VcmParams& p, uint32_t px, uint32_t py, VcmPathState& st) {
  st = VcmPathState();
  st.pixel = py * uint32_t(s.camera.width) + px;
  st.sampler.start(p.sampler, p.seed, s.camera.film_pixel(px, py), p.pass);
  FilterSample fs = filter_sample(s.filter, st.sampler.next_2d());
  Vec2f lens = st.sampler.next_2d();
  // A moving camera: the pose at this path's time (its importance and pdf are the same at every time).
  Camera moved;
  const Camera& c = s.camera.moving ? (moved = s.camera.at(st.sampler.next_1d())) : s.camera;
  st.ray = c.generate_ray(Vec2f(float(px) + 0.5f + fs.offset.x, float(py) + 0.5f + fs.offset.y), lens);
  st.seg_t = c.near_distance(st.ray.d);  // a near clipping plane: the first segment starts at the lens
  st.prev_p = st.ray.o - st.ray.d * st.seg_t;
  st.medium = s.camera_medium;
  // The sample's weight h / p (negative in a filter's negative lobe: Russian roulette compares magnitudes).
  const float pr = fs.pdf;
  if (!(pr > 0.f) || fs.weight == 0.f) {
    st.active = false;
    return;
  }
  st.beta = RGB(fs.weight);
  float ct = dot(st.ray.d, c.forward);
  float camera_pdf_w = pr / (camera_pixel_area(c) * ct * ct * ct);
  st.mis = vcm_camera_start_mis(p, camera_pdf_w);
}

// Emission weight of a camera path reaching a light (s = 0).
CHD float vcm_camera_emission_weight(const VcmParams& p, const VcmPathState& st, float direct_pdf_a,
                                     float emission_pdf_w) {
  if (st.length == 1) return p.hide_emitters ? 0.f : 1.f;  // the light seen directly: no other strategy
  if (!p.use_vc()) return st.specular ? 1.f : 0.f;  // light tracing / merging cover every other path
  return vcm_weight_hit(p, st.mis, direct_pdf_a, emission_pdf_w);
}

// The camera path reached `hit` (or escaped): MIS update, emission; sets
// st.vertex_valid when the vertex can be connected/merged.
CHD void vcm_camera_hit(const SceneView& s, const VcmParams& p, VcmPathState& st, const Hit& hit) {
  st.vertex_valid = false;
  st.crossing = false;
  st.in_medium = false;
  float dist = 0.f;
  if (st.medium >= 0 && vcm_medium_segment(s, st, hit, dist, true)) {
    // A scattering event in the medium: a vertex with the phase function (|cos| 1).
    st.length += 1;
    st.seg_t = 0.f;
    st.null_crossings = 0;
    vcm_after_segment(p, st.mis, dist, 1.f, st.length > 1 || !s.camera.orthographic);
    if (st.length >= p.max_depth) {
      st.active = false;
      return;
    }
    st.vm_rel = vcm_medium_vm_rel(s, p, st.medium, st.sh.p);
    st.vertex_valid = true;
    return;
  }
  if (!st.active) return;
  st.length += 1;
  if (!hit.valid()) {
    if (s.environment_light >= 0) {
      const Light& env = s.lights[s.environment_light];
      RGB Le = environment_radiance(s, env, st.ray.d);
      if (!is_black(Le)) {
        const uint32_t li = uint32_t(s.environment_light);
        float pick = s.light_sampler.pmf[li];
        float env_pdf = environment_pdf(s, env, st.ray.d);
        float dp = env_pdf * vcm_nee_pick(s, p, st.prev_x, li, pick);
        float ep = env_pdf * pick / (kPi * s.bsphere_radius * s.bsphere_radius);
        st.L += st.beta * Le * vcm_camera_emission_weight(p, st, dp, ep);
      }
    }
    st.active = false;
    return;
  }
  st.sh = make_surface_hit(s, st.ray, hit);
  if (is_null_surface(s, st.sh)) {
    st.length -= 1;
    vcm_cross_null(s, st, hit.t);
    return;
  }
  dist = st.seg_t + hit.t;
  st.seg_t = 0.f;
  st.null_crossings = 0;
  st.beta *= segment_transmittance(s, st.ray.d, hit.t, st.sh);
  st.wo_world = -st.ray.d;
  Vec3f ns = st.sh.ns;
  // The orthographic camera's first segment: its density stays per area (camera_pixel_area's comment).
  vcm_after_segment(p, st.mis, dist, absdot(ns, st.wo_world), st.length > 1 || !s.camera.orthographic);
  if (st.sh.light >= 0) {
    const Light& l = s.lights[st.sh.light];
    RGB Le = area_radiance(s, l, st.sh.ng, st.wo_world, st.sh.uv);
    if (!is_black(Le)) {
      float pick = s.light_sampler.pmf[st.sh.light];
      float dp = vcm_direct_pdf_a(s, l, st.prev_p, st.sh.p, st.sh.ng) *
                 vcm_nee_pick(s, p, st.prev_x, uint32_t(st.sh.light), pick);
      float ep = vcm_emission_pdf(s, l, st.sh.ng, st.wo_world) * pick;
      st.L += st.beta * Le * vcm_camera_emission_weight(p, st, dp, ep);
    }
  }
  if (st.length >= p.max_depth) {
    st.active = false;
    return;
  }
  st.m = surface_material(s, st.sh);
  st.frame = shading_frame(s, st.sh, st.m);
  st.wo = st.frame.to_local(st.wo_world);
  st.p_front = offset_ray_origin(st.sh.p, st.sh.ng, st.wo_world);
  st.vm_rel = 1.f;
  st.vertex_valid = !material_is_delta(st.m);
}

struct VcmShadow {
  Ray ray;
  RGB contrib{0.f};
  float weight = 0.f;  // the MIS weight in contrib
  int32_t medium = -1;  // the medium the ray starts in (vcm_visibility)
  bool active = false;
};

// The merge term at camera vertex st (see vcm_weight_nee).
CHD float vcm_cam_vm(const VcmParams& p, const VcmPathState& st) {
  return p.mode == VcmMode::kUpg && !st.vm_ok ? 0.f : p.vm_factor * st.vm_rel;
}

// Next-event estimation from the camera vertex (s = 1).
CHD void vcm_camera_nee(const SceneView& s, const VcmParams& p, VcmPathState& st, VcmShadow& sr) {
  sr.active = false;
  float ul = st.sampler.next_1d();
  Vec2f u2 = st.sampler.next_2d();
  if (!st.vertex_valid || !p.use_vc() || s.num_lights == 0 || st.length + 1 > p.max_depth) return;
  float pick = 0.f;  // the NEE pick
  Vec2f u_choice(ul, 0.f);
  const int32_t chosen = choose_light(s, p.light_bvh, st.sh.p, u_choice, pick);
  if (chosen < 0) return;
  const uint32_t li = uint32_t(chosen);
  const Light& l = s.lights[li];
  LightSample ls;
  if (!sample_light(s, l, st.p_front, u2, ls)) return;
  const VcmVertexEval e = vcm_eval_state(s, st, ls.wi, TransportMode::kRadiance, !ls.delta);
  const RGB f = e.f;
  if (is_black(f)) return;
  float cos_to_light = e.cos;
  // Report Sec. 5.1's conventions: point lights have direct_pdf_w = d^2 (area
  // density 1 converted), their "radiance" the intensity.
  float direct_pdf_w = ls.pdf, cos_at_light = 1.f;
  if (l.type == LightType::kPoint || l.type == LightType::kSpot) direct_pdf_w = ls.dist * ls.dist;
  else if (l.type == LightType::kTriangle || l.type == LightType::kSphere) cos_at_light = absdot(ls.n_l, ls.wi);
  // The light subpath's density of this light vertex relative to NEE's: its power pick over NEE's pick (1 by
  // power; vcm_weight_nee divides emission by direct density without the picks).
  float emission_pdf_w = vcm_emission_pdf(s, l, ls.n_l, -ls.wi) * (s.light_sampler.pmf[li] / pick);
  float dir_pdf = ls.delta ? 0.f : e.pdf_fwd;
  float rev_pdf = e.pdf_rev;
  float w = vcm_weight_nee(p, st.mis, pick, direct_pdf_w, emission_pdf_w, cos_at_light, cos_to_light, dir_pdf, rev_pdf,
                           vcm_cam_vm(p, st));
  sr.contrib = st.beta * f * ls.Li * (cos_to_light * w / (pick * ls.pdf));
  Vec3f o = vcm_origin_towards(st, ls.wi);
  if (std::isfinite(ls.dist)) sr.ray = spawn_ray_to(o, ls.p_l, ls.n_l);
  else sr.ray = Ray{o, ls.wi, kInf};
  sr.medium = vcm_medium_towards(s, st, ls.wi);
  sr.active = isfinite3(sr.contrib) && !is_black(sr.contrib);
}

// Connection of the camera vertex to a light vertex.
CHD void vcm_camera_connect(const SceneView& s, const VcmParams& p, const VcmPathState& st, const VcmLightVertex& v,
                            VcmShadow& sr) {
  sr.active = false;
  if (!st.vertex_valid || !p.use_vc() || v.length + st.length + 1 > p.max_depth) return;
  Vec3f d = v.sh.p - st.sh.p;
  float d2 = length_sq(d);
  if (!(d2 > 0.f)) return;
  float dist = std::sqrt(d2);
  Vec3f w = d / dist;
  // Both sides' values first, their densities only where both are non-zero (a light vertex often faces away).
  VcmVertexEval ec = vcm_eval_state(s, st, w, TransportMode::kRadiance, false, false);
  if (is_black(ec.f)) return;
  VcmVertexEval el;
  SurfaceHit vsh = v.sh;  // surface_material may bend its shading normal
  Material vm;
  Frame vf;
  if (v.in_medium()) {
    el = vcm_eval_medium(s.media[v.medium].g, v.wi, -w);
  } else {
    vm = surface_material(s, vsh);
    vf = shading_frame(s, vsh, vm);
    el = vcm_eval_surface(vm, vf, vsh, v.wi, vf.to_local(v.wi), -w, TransportMode::kImportance, false, false);
  }
  if (is_black(el.f)) return;
  if (!st.in_medium) vcm_surface_pdfs(st.m, st.frame, st.wo, w, ec);
  if (!v.in_medium()) vcm_surface_pdfs(vm, vf, vf.to_local(v.wi), -w, el);
  float cos_c = ec.cos, cos_l = el.cos;
  float G = cos_c * cos_l / d2;
  float cam_dir_a = ec.pdf_fwd * cos_l / d2;
  float light_dir_a = el.pdf_fwd * cos_c / d2;
  float mw = vcm_weight_connect(p, v.mis, st.mis, cam_dir_a, ec.pdf_rev, light_dir_a, el.pdf_rev, vcm_cam_vm(p, st),
                                vcm_connect_light_vm(p, v.vm_rel, st.in_medium));
  sr.contrib = st.beta * ec.f * el.f * v.beta * (G * mw);
  sr.weight = mw;
  Vec3f o = vcm_origin_towards(st, w);
  if (v.in_medium()) {
    sr.ray = Ray{o, v.sh.p - o, 1.f};
  } else {
    Vec3f target = offset_ray_origin(v.sh.p, v.sh.ng, -w);
    sr.ray = Ray{o, target - o, 1.f - 1e-4f};
  }
  sr.medium = vcm_medium_towards(s, st, w);
  sr.active = isfinite3(sr.contrib) && !is_black(sr.contrib);
}

// Volumetric merging at a camera vertex in a medium (header comment: UPBP's point-point estimator): the light
// vertices in the same medium within the ball of radius r_v (`grid` and `vertices` hold the medium vertices),
// each p(wo, wi_j) beta_j (sigma_s(x_j) in beta_j) over 4/3 pi r_v^3 N_VM, times the camera's throughput
// without its own sigma_s (a channel with sigma_s = 0 there has none either).
CAUSTICA_HOST_DEVICE CAUSTICA_NOINLINE inline void vcm_camera_merge_medium(const SceneView& s, const VcmParams& p,
                                                                          VcmPathState& st,
                                                                          const PhotonGridView& grid,
                                                                          const VcmMergeVertex* vertices) {
  if (!(st.vm_rel > 0.f)) return;  // no merge term (rel underflows only for r sigma_t below 1e-19)
  const float g = s.media[st.medium].g;
  RGB sum(0.f);
  grid.query_indexed(st.sh.p, p.radius_v, [&](uint32_t id, const Photon&) {
    const VcmMergeVertex& v = vertices[id];
    if (v.medium != st.medium || uint32_t(v.length) + st.length > p.max_depth) return;
    VcmMis lm;
    lm.dVCM = v.dVCM;
    lm.dVM = v.dVM;
    const float ph = hg_phase(dot(st.wo_world, v.wi), g);
    sum += v.beta * (ph * vcm_weight_merge(p, lm, st.mis, ph, ph, st.vm_rel));
  }, vertices, uint32_t(sizeof(VcmMergeVertex)));
  RGB cam;
  for (int c = 0; c < 3; ++c) cam[c] = st.sigma_s[c] > 0.f ? st.beta[c] / st.sigma_s[c] : 0.f;
  st.L += cam * sum * p.vm_norm_v;
}

// Merging at the camera vertex with the light vertices within the radius
// (report Eqs. 38-39; the constant-kernel density estimate 1 / (pi r^2 N_light) of the paper's vertex merging;
// in a medium vcm_camera_merge_medium). `grid` and `vertices` hold the light vertices on surfaces, `grid_v` and
// `vertices_v` those in media (cells of 2 r_v), each indexed as its grid reports (the grid's order when its
// view has no ids).
CHD void vcm_camera_merge(const SceneView& s, const VcmParams& p, VcmPathState& st, const PhotonGridView& grid,
                          const VcmMergeVertex* vertices, const PhotonGridView& grid_v,
                          const VcmMergeVertex* vertices_v) {
  if (!st.vertex_valid || !p.merges()) return;
  if (st.in_medium) return vcm_camera_merge_medium(s, p, st, grid_v, vertices_v);
  RGB sum(0.f);
  grid.query_indexed(st.sh.p, p.radius, [&](uint32_t id, const Photon&) {
    const VcmMergeVertex& v = vertices[id];
    if (uint32_t(v.length) + st.length > p.max_depth) return;  // too long
    Vec3f wl = st.frame.to_local(v.wi);
    RGB f = bsdf_eval(st.m, st.wo, wl) * photon_gather_cosines(st.sh.ns, st.sh.ng, v.wi);
    if (is_black(f)) return;
    VcmMis lm;
    lm.dVCM = v.dVCM;
    lm.dVM = v.dVM;
    float w = vcm_weight_merge(p, lm, st.mis, bsdf_pdf(st.m, st.wo, wl), bsdf_pdf(st.m, wl, st.wo));
    sum += f * v.beta * w;
  }, vertices, uint32_t(sizeof(VcmMergeVertex)));
  st.L += st.beta * sum * p.vm_norm;
}

CHD void vcm_camera_continue(const SceneView& s, const VcmParams& p, VcmPathState& st) {
  if (!st.active || st.crossing) return;  // after a null surface the ray goes on as it was
  if (p.mode == VcmMode::kLight && st.vertex_valid) {  // light tracing covers the rest
    st.active = false;
    return;
  }
  vcm_scatter(s, p, st, TransportMode::kRadiance);
}

// The fraction of a connection's, a next-event estimate's or a splat's contribution that arrives: 0 or 1 from
// one occlusion query in scenes without media, else the transmittance through media and null surfaces.
template <typename Tracer>
CHD RGB vcm_visibility(const SceneView& s, const Tracer& tracer, const Ray& ray, int32_t medium) {
  return shadow_transmittance(s, tracer, ray, medium);
}

// Adds a shadow ray's contribution times the visibility Tr (vcm_visibility).
CHD void vcm_shadow(VcmPathState& st, const VcmShadow& sr, const RGB& Tr) {
  if (sr.active && !is_black(Tr)) st.L += sr.contrib * Tr;
}

}  // namespace caustica
