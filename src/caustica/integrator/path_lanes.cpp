// The lane-parallel `path` driver (see path_lanes.h). The scalar code it mirrors is cited beside each
// step: path.h (path_start, path_shade, path_shadow), light_sample.h (sample_light, kTriangle),
// material/bsdf.h and diffuse.h (bsdf_eval, bsdf_pdf, bsdf_sample, bsdf_side), sampling.h and ray.h.
#include "path_lanes.h"

#include "../backend/cpu/cpu_accel.h"
#include "../base/avx2.h"

namespace caustica {
namespace {
// Materials whose vertices the lanes shade; a vertex on any other runs the scalar path_shade in its lane.
bool lane_material(const Material& m) {
  return m.type == MaterialType::kDiffuse && m.mix_b < 0 && m.tex_color < 0 && m.tex_roughness < 0 && m.tex_normal < 0 && m.tex_bump < 0 && m.tex_aniso < 0 &&
         !(m.flags & kVertexColor) && is_black(m.absorption);
}
}  // namespace

bool path_lanes_supported(const SceneView& s, const PathParams& pp, std::string* why) {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (scene_has_media(s)) return fail("participating media or null surfaces");
  if (pp.aov != Aov::kNone) return fail("an output variable (--aov)");
  for (uint32_t i = 0; i < s.num_lights; ++i) {
    const Light& l = s.lights[i];
    if (l.type != LightType::kTriangle) return fail("a light other than a triangle area light");
    if (l.texture >= 0) return fail("a textured area light");
    // Its light samples would need the coverage (area_coverage, scene/opacity.h) that the lanes leave out.
    if (s.materials[s.prim_material[l.prim]].flags & kAlphaTested) return fail("an area light with opacity");
  }
  uint32_t prims = s.num_triangles + s.num_spheres;
  for (uint32_t p = 0; p < prims; ++p)
    if (lane_material(s.materials[s.prim_material[p]])) return true;
  return fail("no untextured `diffuse` surface");
}

#if CAUSTICA_AVX2_BUILD

bool path_lanes_available() { return cpu_has_avx2(); }

}  // namespace caustica

// Everything from here to CAUSTICA_AVX2_END is compiled for AVX2 (and only called after
// path_lanes_available()). The scalar headers were included above, so their functions keep the baseline
// instruction set.
CAUSTICA_AVX2_BEGIN
#include "../base/lanes.h"

namespace caustica {
namespace {

using namespace lanes;

inline void store_lanes(RayLanes& r, const V3& o, const V3& d, F tmax) {
  *reinterpret_cast<F*>(r.ox) = o.x;
  *reinterpret_cast<F*>(r.oy) = o.y;
  *reinterpret_cast<F*>(r.oz) = o.z;
  *reinterpret_cast<F*>(r.dx) = d.x;
  *reinterpret_cast<F*>(r.dy) = d.y;
  *reinterpret_cast<F*>(r.dz) = d.z;
  *reinterpret_cast<F*>(r.tmax) = tmax;
}

template <typename SamplerLanes, typename Accel>
void trace_avx2(const SceneView& s, const Accel& accel, const PathParams& pp, uint32_t x0, uint32_t y0, int w,
                int h, uint32_t sample_index, LaneResult* out, LaneCounts& counts) {
  const int count = w * h;
  SamplerLanes sampler;
  sampler.init(sample_index);
  V3 o{}, d{}, prev_p{}, beta{}, L{};
  F tmax = splat(kInf), prev_pdf = splat(1.f), eta_scale = splat(1.f);
  M active = none(), prev_delta = none();
  U depth = U{};       // the lane's path's segments so far (PathState::depth; raised as each ray is traced)
  int slot[kWidth];    // the lane's path: its index into out, or -1
  int next = 0;        // the next pixel to start
  // A lane whose path has ended hands its result to `out` and starts the next pixel's path (path_start:
  // camera ray, filter sample, the sampler's first dimensions), so lanes stay busy until pixels run out.
  auto refill = [&](int i) {
    if (slot[i] >= 0) out[slot[i]].L = get(L, i);
    slot[i] = -1;
    if (next >= count) return;
    int k = next++;
    PathState st;
    path_start(s, pp, x0 + uint32_t(k % w), y0 + uint32_t(k / w), sample_index, st);
    set(o, i, st.ray.o);
    set(d, i, st.ray.d);
    tmax[i] = st.ray.tmax;
    set(prev_p, i, st.prev_p);
    set(beta, i, st.beta);
    set(L, i, st.L);
    prev_pdf[i] = st.prev_pdf;
    prev_delta[i] = st.prev_delta ? -1 : 0;
    eta_scale[i] = st.eta_scale;
    depth[i] = st.depth;
    sampler.load_lane(i, st.sampler);
    active[i] = -1;
    slot[i] = k;
    out[k].weight = st.weight;
    out[k].pixel = st.pixel;
  };
  for (int i = 0; i < kWidth; ++i) {
    slot[i] = -1;
    refill(i);
  }

  // Per-vertex values, gathered lane by lane into arrays (lanes.h, Staged*) and read as vectors. They are
  // zeroed once here, not per vertex (zeroing them every vertex took a quarter of this function's time);
  // a lane that is not active keeps the values of its last vertex, masked out of every result.
  Staged3 sphere_p, sphere_ng, sphere_ns, albedo_s, v0_s, v1_s, v2_s, n0_s, n1_s, n2_s, q0_s, q1_s, q2_s, Le_s;
  Staged b1_s, b2_s, ulx_s, pmf_s;
  StagedMask two_sided_s, triangle_s, lane_s, light_two_sided_s;
  while (any(active)) {
    depth += 1u;  // the segment traced now (idle lanes count too; refill resets them)
    // Closest hits, the active lanes' rays in one call; then lane by lane: the hit's point and normals
    // (make_surface_hit) for triangles in lanes, for spheres per lane; emission reached by the ray
    // (path_shade), per lane (rare).
    // A vertex on any other material is shaded by the scalar path_shade right here (see below).
    int32_t light[kWidth];
    RayLanes rays;  // the active lanes' rays, queried together (the rays' set-up runs in lanes)
    store_lanes(rays, o, d, tmax);
    Hit hits[kWidth];
    const int asked = __builtin_ia32_movmskps256((F)active);
    accel.intersect8(rays, asked, hits);
    counts.rays += uint64_t(__builtin_popcount(asked));
    for (int i = 0; i < kWidth; ++i) {
      light[i] = -1;
      lane_s.v[i] = 0;
      triangle_s.v[i] = 0;
      if (!active[i]) continue;
      const Ray r = rays.ray(i);
      const Hit& h = hits[i];
      if (!h.valid()) {  // no environment light in the scenes the lanes cover
        active[i] = 0;
        continue;
      }
      const Material& m = s.materials[s.prim_material[h.prim]];
      if (!lane_material(m)) {
        // The scalar stages for this lane's vertex, with the lane's own sampler dimension.
        PathState st;
        st.ray = r;
        st.beta = get(beta, i);
        st.L = get(L, i);
        st.prev_pdf = prev_pdf[i];
        st.prev_delta = prev_delta[i] != 0;
        st.depth = depth[i] - 1;
        st.eta_scale = eta_scale[i];
        st.prev_p = get(prev_p, i);
        sampler.store_lane(i, st.sampler);
        path_vertex(s, pp, accel, st, h, counts.shadow_rays);
        set(o, i, st.ray.o);
        set(d, i, st.ray.d);
        tmax[i] = st.ray.tmax;
        set(beta, i, st.beta);
        set(L, i, st.L);
        prev_pdf[i] = st.prev_pdf;
        prev_delta[i] = st.prev_delta ? -1 : 0;
        eta_scale[i] = st.eta_scale;
        set(prev_p, i, st.prev_p);
        sampler.after_scalar_vertex(i, st.sampler);
        active[i] = st.active ? -1 : 0;
        continue;
      }
      lane_s.v[i] = -1;
      albedo_s.set(i, m.diffuse);
      two_sided_s.v[i] = (m.flags & kTwoSided) ? -1 : 0;
      light[i] = s.prim_light[h.prim];
      if (h.prim < s.num_triangles) {
        triangle_s.v[i] = -1;
        b1_s.v[i] = h.b1;
        b2_s.v[i] = h.b2;
        const uint32_t* ix = s.indices + 3 * h.prim;
        v0_s.set(i, s.positions[ix[0]]);
        v1_s.set(i, s.positions[ix[1]]);
        v2_s.set(i, s.positions[ix[2]]);
        if (s.normals) {
          n0_s.set(i, s.normals[ix[0]]);
          n1_s.set(i, s.normals[ix[1]]);
          n2_s.set(i, s.normals[ix[2]]);
        }
      } else {
        SurfaceHit sh = make_surface_hit(s, r, h);
        sphere_p.set(i, sh.p);
        sphere_ng.set(i, sh.ng);
        sphere_ns.set(i, sh.ns);
      }
      if (light[i] >= 0 && pp.shows_emission(depth[i])) {
        SurfaceHit sh = make_surface_hit(s, r, h);
        RGB Li = get(L, i);
        path_add_emission(s, pp, sh, -r.d, get(prev_p, i), prev_pdf[i], prev_delta[i] != 0, get(beta, i), Li);
        set(L, i, Li);
      }
    }
    M lane = lane_s.load(), triangle = triangle_s.load(), two_sided = two_sided_s.load();
    const V3 albedo = albedo_s.load();
    // A path at its maximum depth ends after the emission it reached.
    M at_max = (M)(depth >= pp.max_depth);
    active &= ~(lane & at_max);
    lane &= ~at_max;
    if (!any(lane)) {
      for (int i = 0; i < kWidth; ++i)
        if (!active[i]) refill(i);
      continue;
    }
    const typename SamplerLanes::Saved sampler_before = sampler.save();
    V3 p = sphere_p.load(), ng = sphere_ng.load(), ns = sphere_ns.load();
    if (any(triangle)) {  // make_surface_hit for triangles
      const F b1 = b1_s.load(), b2 = b2_s.load();
      const V3 v0 = v0_s.load(), v1 = v1_s.load(), v2 = v2_s.load();
      F b0 = 1.f - b1 - b2;
      V3 tp = v0 * b0 + v1 * b1 + v2 * b2;
      V3 tng = normalize(cross(v1 - v0, v2 - v0));
      V3 tns = tng;
      if (s.normals) {
        V3 nn = n0_s.load() * b0 + n1_s.load() * b1 + n2_s.load() * b2;
        V3 nu = normalize(nn);
        tns = sel(dot(nn, nn) > 0.f, sel(dot(nu, tng) < 0.f, -nu, nu), tng);  // face_forward
      }
      p = sel(triangle, tp, p);
      ng = sel(triangle, tng, ng);
      ns = sel(triangle, tns, ns);
    }

    Frame3 frame(ns);
    V3 wo_world = -d;
    V3 wo = frame.to_local(wo_world);
    // bsdf_side: a two-sided surface seen from behind is evaluated as if from the front.
    M flip = two_sided & (wo.z < 0.f);
    F side = sel(flip, splat(-1.f), splat(1.f));
    F wo_z = sel(flip, -wo.z, wo.z);
    V3 p_front = offset_ray_origin(p, ng, wo_world);

    // Next-event estimation (path_shade; sample_light, kTriangle).
    F ulx, uly;
    sampler.next_2d(ulx, uly);
    if (s.num_lights > 0) {
      *reinterpret_cast<F*>(ulx_s.v) = ulx;
      for (int i = 0; i < kWidth; ++i) {
        if (!lane_s.v[i]) continue;
        Vec2f u(ulx_s.v[i], uly[i]);
        float pm = 0.f;
        // The same choice as path_shade's: by power, or by the light BVH's importance from p_front.
        const int32_t li = choose_light(s, pp.light_bvh, get(p_front, i), u, pm);
        ulx_s.v[i] = u.x;
        if (li < 0) {  // no light can reach p_front: pmf 0 masks the lane out below
          pmf_s.v[i] = 0.f;
          continue;
        }
        pmf_s.v[i] = pm;
        const Light& l = s.lights[li];
        Vec3f a, b, c;
        triangle_vertices(s, l.prim, a, b, c);
        q0_s.set(i, a);
        q1_s.set(i, b);
        q2_s.set(i, c);
        Le_s.set(i, l.L);
        light_two_sided_s.v[i] = l.two_sided ? -1 : 0;
      }
      ulx = ulx_s.load();
      // Lanes without a vertex here keep stale (finite) values, masked out below.
      const F pmf = pmf_s.load();
      const M light_two_sided = light_two_sided_s.load();
      const V3 q0 = q0_s.load(), q1 = q1_s.load(), q2 = q2_s.load(), Le = Le_s.load();
      F su = vsqrt(ulx);  // square_to_uniform_triangle
      F bx = 1.f - su, by = uly * su;
      V3 pl = q0 * (1.f - bx - by) + q1 * bx + q2 * by;
      V3 e = cross(q1 - q0, q2 - q0);
      V3 nl = normalize(e);
      V3 dl = pl - p_front;
      F d2 = dot(dl, dl);
      F dist = vsqrt(d2);
      V3 wi_world = dl / dist;
      F c = vfabs(dot(nl, wi_world));
      F light_pdf = d2 / (c * (0.5f * length(e)));  // triangle_area
      F c_emit = dot(nl, -wi_world);                // area_le
      M emits = (c_emit > 0.f) | (light_two_sided & (c_emit < 0.f));
      M ok = lane & (pmf > 0.f) & (d2 != 0.f) & (c != 0.f) & (light_pdf > 0.f) & emits & ~is_black(Le);
      // bsdf_eval / bsdf_pdf of `diffuse` (with bsdf_side's flip of wi).
      V3 wi = frame.to_local(wi_world);
      F wi_z = wi.z * side;
      ok &= (wo_z > 0.f) & (wi_z > 0.f);
      V3 f = albedo * splat(kInvPi);
      ok &= ~is_black(f);
      F w = power_heuristic(pmf * light_pdf, wi_z * kInvPi);
      V3 contrib = beta * f * Le * (vfabs(wi.z) * w / (pmf * light_pdf));
      M shadow = ok & ~is_black(contrib) & finite3(contrib);
      if (any(shadow)) {
        V3 so = sel(dot(wi_world, ng) * dot(wo_world, ng) > 0.f, p_front, offset_ray_origin(p, ng, wi_world));
        M n_zero = (nl.x == 0.f) & (nl.y == 0.f) & (nl.z == 0.f);  // spawn_ray_to
        V3 target = sel(n_zero, pl, offset_ray_origin(pl, nl, so - pl));
        V3 sd = target - so;
        M dist_finite = finite(dist);
        // spawn_ray_to's segment, or the direction to a light at infinity.
        RayLanes srays;
        store_lanes(srays, so, sel(dist_finite, sd, wi_world), sel(dist_finite, splat(1.f - 1e-4f), splat(kInf)));
        const int asked_shadow = __builtin_ia32_movmskps256((F)shadow);
        counts.shadow_rays += uint64_t(__builtin_popcount(asked_shadow));
        const int occluded = accel.occluded8(srays, asked_shadow);
        L = sel(shadow & ~mask_of_bits(occluded), L + contrib, L);  // path_shadow
      }
    }

    // BSDF sampling (path_shade; bsdf_sample, diffuse_sample, square_to_cosine_hemisphere).
    F u_lobe, u_rr;
    sampler.next_2d(u_lobe, u_rr);
    (void)u_lobe;  // `diffuse` has one lobe
    F ubx, uby;
    sampler.next_2d(ubx, uby);
    V3 wl = square_to_cosine_hemisphere(ubx, uby);
    F pdf = sel(wl.z > 0.f, wl.z * kInvPi, splat(0.f));
    M ok = lane & (wo_z > 0.f) & (pdf > 0.f) & finite3(albedo);
    wl.z = wl.z * side;
    V3 wi_world = frame.to_world(wl);
    ok &= ~(dot(wi_world, ng) * wl.z * dot(ns, ng) < 0.f);
    beta = sel(ok, beta * albedo, beta);
    prev_pdf = sel(lane, pdf, prev_pdf);
    prev_delta = prev_delta & ~lane;
    V3 no = sel(dot(wi_world, ng) * dot(wo_world, ng) > 0.f, p_front, offset_ray_origin(p, ng, wi_world));
    o = sel(ok, no, o);
    d = sel(ok, wi_world, d);
    tmax = sel(lane, splat(kInf), tmax);
    prev_p = sel(lane, o, prev_p);
    ok &= ~is_black(beta);
    M roulette = (M)(depth >= pp.rr_depth);
    if (any(roulette & ok)) {
      // `diffuse` leaves eta_scale as it is (its eta is 1).
      F q = vminf(max_component(beta) * eta_scale, splat(0.95f));
      ok &= ~roulette | (u_rr < q);
      beta = sel(ok & roulette, beta * (1.f / q), beta);
    }
    active = ok | (active & ~lane);
    // The lanes' three draws advanced every lane's dimension; the scalar lanes had advanced their own.
    sampler.keep(lane, sampler_before);
    for (int i = 0; i < kWidth; ++i)
      if (!active[i]) refill(i);
  }
}

}  // namespace
}  // namespace caustica

CAUSTICA_AVX2_END

namespace caustica {

template <typename Accel>
void path_lanes_trace(const SceneView& s, const Accel& accel, const PathParams& pp, uint32_t x0, uint32_t y0, int w,
                      int h, uint32_t sample_index, LaneResult* out, LaneCounts& counts) {
  if (w <= 0 || h <= 0) return;
  if (pp.sampler == SamplerType::kIndependent)
    trace_avx2<IndependentLanes>(s, accel, pp, x0, y0, w, h, sample_index, out, counts);
  else
    trace_avx2<SobolLanes>(s, accel, pp, x0, y0, w, h, sample_index, out, counts);
}

#else  // no lanes on this target

bool path_lanes_available() { return false; }

template <typename Accel>
void path_lanes_trace(const SceneView&, const Accel&, const PathParams&, uint32_t, uint32_t, int, int, uint32_t,
                      LaneResult*, LaneCounts&) {}

#endif

template void path_lanes_trace<CpuAccel>(const SceneView&, const CpuAccel&, const PathParams&, uint32_t,
                                            uint32_t, int, int, uint32_t, LaneResult*, LaneCounts&);
template void path_lanes_trace<BVHAccel>(const SceneView&, const BVHAccel&, const PathParams&, uint32_t, uint32_t,
                                         int, int, uint32_t, LaneResult*, LaneCounts&);

}  // namespace caustica
