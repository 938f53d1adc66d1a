#include "cpu_accel.h"

#include <cstring>
#include <stdexcept>
#include <string>

#include "../../scene/intersect.h"

namespace caustica {
namespace {

void sphere_bounds_fn(const RTCBoundsFunctionArguments* args) {
  const SceneView* v = static_cast<const SceneView*>(args->geometryUserPtr);
  Bounds3 b = sphere_bounds(v->spheres[args->primID]);
  args->bounds_o->lower_x = b.lo.x;
  args->bounds_o->lower_y = b.lo.y;
  args->bounds_o->lower_z = b.lo.z;
  args->bounds_o->upper_x = b.hi.x;
  args->bounds_o->upper_y = b.hi.y;
  args->bounds_o->upper_z = b.hi.z;
}

void sphere_intersect_fn(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const SceneView* v = static_cast<const SceneView*>(args->geometryUserPtr);
  RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  Ray r;
  r.o = Vec3f(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z);
  r.d = Vec3f(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z);
  r.tmax = rh->ray.tfar;
  float t;
  if (!intersect_sphere_kept(*v, args->primID, r, t)) return;
  rh->ray.tfar = t;
  rh->hit.geomID = args->geomID;
  rh->hit.primID = args->primID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rh->hit.u = rh->hit.v = 0.f;
  Vec3f n = (r.o + r.d * t) - v->spheres[args->primID].center;
  rh->hit.Ng_x = n.x;
  rh->hit.Ng_y = n.y;
  rh->hit.Ng_z = n.z;
}

void sphere_occluded_fn(const RTCOccludedFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const SceneView* v = static_cast<const SceneView*>(args->geometryUserPtr);
  RTCRay* ray = reinterpret_cast<RTCRay*>(args->ray);
  Ray r;
  r.o = Vec3f(ray->org_x, ray->org_y, ray->org_z);
  r.d = Vec3f(ray->dir_x, ray->dir_y, ray->dir_z);
  r.tmax = ray->tfar;
  float t;
  if (intersect_sphere_kept(*v, args->primID, r, t)) ray->tfar = -kInf;
}

// A triangle's candidate hit (closest-hit and any-hit queries alike): skipped where its material's opacity
// says so (scene/opacity.h, the portable BVH's test). Queries are single rays (N = 1).
void triangle_opacity_filter_fn(const RTCFilterFunctionNArguments* args) {
  const SceneView* v = static_cast<const SceneView*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    Ray r;
    r.o = Vec3f(RTCRayN_org_x(args->ray, args->N, i), RTCRayN_org_y(args->ray, args->N, i),
                RTCRayN_org_z(args->ray, args->N, i));
    r.d = Vec3f(RTCRayN_dir_x(args->ray, args->N, i), RTCRayN_dir_y(args->ray, args->N, i),
                RTCRayN_dir_z(args->ray, args->N, i));
    r.tmax = kInf;
    if (!triangle_hit_kept(*v, RTCHitN_primID(args->hit, args->N, i), RTCHitN_u(args->hit, args->N, i),
                           RTCHitN_v(args->hit, args->N, i), r))
      args->valid[i] = 0;
  }
}

// Embree reports errors through the device; checked after each setup step
// (a callback must not throw through Embree's C frames).
void check(RTCDevice device, const char* what) {
  RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE) throw std::runtime_error(std::string("Embree: ") + what + " failed (error " + std::to_string(int(e)) + ")");
}

inline void fill_ray(RTCRay& rr, const Ray& ray) {
  rr.org_x = ray.o.x;
  rr.org_y = ray.o.y;
  rr.org_z = ray.o.z;
  rr.dir_x = ray.d.x;
  rr.dir_y = ray.d.y;
  rr.dir_z = ray.d.z;
  rr.tnear = 0.f;
  rr.tfar = ray.tmax;
  rr.time = 0.f;
  rr.mask = 0xffffffffu;
  rr.id = 0;
  rr.flags = 0;
}

}  // namespace

bool CpuAccel::small_suits(const SceneView& v) {
  return SmallAccel::available() && v.num_triangles <= SmallAccel::kMaxTriangles &&
         v.num_spheres <= kMaxSmallSpheres && !v.alpha_tested;
}

CpuAccel::CpuAccel(const SceneView& v, Kind kind) : num_triangles_(v.num_triangles), view_(v) {
  if (kind == Kind::kSmall && !small_suits(v))
    throw std::invalid_argument("the small-scene accelerator takes at most " +
                                std::to_string(SmallAccel::kMaxTriangles) + " triangles and " +
                                std::to_string(kMaxSmallSpheres) + " spheres without cut-outs, on a CPU with AVX2");
  if (kind != Kind::kEmbree && small_suits(v)) {
    small_ = std::make_unique<SmallAccel>(v);
    return;
  }
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw std::runtime_error("Embree: could not create a device");
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  // Robust mode makes edges and vertices watertight: without it 3161 of the 20000 rays aimed at shared
  // edges and vertices of a closed box leaked (Triangle.EmbreeWatertightOnSharedEdgesAndVertices). It
  // costs about 12% of a cornell render (bench/RESULTS.md, 2026-12-01).
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
  if (v.num_triangles > 0) {
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Copies (Embree reads 16 bytes past the last vertex, so no shared buffer).
    uint32_t nv = 0;
    for (uint32_t i = 0; i < 3 * v.num_triangles; ++i) nv = v.indices[i] + 1 > nv ? v.indices[i] + 1 : nv;
    float* pos = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
    std::memcpy(pos, v.positions, sizeof(float) * 3 * nv);
    uint32_t* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(uint32_t), v.num_triangles));
    std::memcpy(idx, v.indices, sizeof(uint32_t) * 3 * v.num_triangles);
    if (v.alpha_tested) {
      rtcSetGeometryUserData(g, &view_);
      rtcSetGeometryIntersectFilterFunction(g, triangle_opacity_filter_fn);
      rtcSetGeometryOccludedFilterFunction(g, triangle_opacity_filter_fn);
    }
    rtcCommitGeometry(g);
    tri_geom_ = rtcAttachGeometry(scene_, g);
    rtcReleaseGeometry(g);
  }
  if (v.num_spheres > 0) {
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, v.num_spheres);
    rtcSetGeometryUserData(g, &view_);
    rtcSetGeometryBoundsFunction(g, sphere_bounds_fn, nullptr);
    rtcSetGeometryIntersectFunction(g, sphere_intersect_fn);
    rtcSetGeometryOccludedFunction(g, sphere_occluded_fn);
    rtcCommitGeometry(g);
    sphere_geom_ = rtcAttachGeometry(scene_, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(scene_);
  check(device_, "building the scene");
}

CpuAccel::~CpuAccel() {
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
}

bool CpuAccel::intersect(const Ray& ray, Hit& hit) const {
  if (small_) return small_->intersect(ray, hit);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  fill_ray(rh.ray, ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
    hit = Hit();
    return false;
  }
  hit.t = rh.ray.tfar;
  if (rh.hit.geomID == tri_geom_) {
    hit.prim = rh.hit.primID;
    hit.b1 = rh.hit.u;
    hit.b2 = rh.hit.v;
  } else {
    hit.prim = num_triangles_ + rh.hit.primID;
    hit.b1 = hit.b2 = 0.f;
  }
  return true;
}

bool CpuAccel::occluded(const Ray& ray) const {
  if (small_) return small_->occluded(ray);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  fill_ray(r, ray);
  rtcOccluded1(scene_, &ctx, &r);
  return r.tfar < 0.f;
}

namespace {
// intersect8 / occluded8 as single-ray queries, one lane after another (Embree, the portable BVH).
template <typename Accel>
void intersect_each(const Accel& a, const RayLanes& rays, int mask, Hit hits[8]) {
  for (int i = 0; i < 8; ++i)
    if (mask >> i & 1) a.intersect(rays.ray(i), hits[i]);
}
template <typename Accel>
int occluded_each(const Accel& a, const RayLanes& rays, int mask) {
  int occ = 0;
  for (int i = 0; i < 8; ++i)
    if ((mask >> i & 1) && a.occluded(rays.ray(i))) occ |= 1 << i;
  return occ;
}
}  // namespace

void CpuAccel::intersect8(const RayLanes& rays, int mask, Hit hits[8]) const {
  if (small_) return small_->intersect8(rays, mask, hits);
  intersect_each(*this, rays, mask, hits);
}
int CpuAccel::occluded8(const RayLanes& rays, int mask) const {
  return small_ ? small_->occluded8(rays, mask) : occluded_each(*this, rays, mask);
}
void BVHAccel::intersect8(const RayLanes& rays, int mask, Hit hits[8]) const {
  intersect_each(*this, rays, mask, hits);
}
int BVHAccel::occluded8(const RayLanes& rays, int mask) const { return occluded_each(*this, rays, mask); }

bool BVHAccel::intersect(const Ray& ray, Hit& hit) const {
  return scene_intersect(*view, ray, hit);
}
bool BVHAccel::occluded(const Ray& ray) const { return scene_occluded(*view, ray); }

}  // namespace caustica
