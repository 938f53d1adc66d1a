// Lane-parallel path tracing on the CPU: the `path` integrator (path.h) for eight camera paths in
// lockstep, its per-vertex arithmetic (the sampler's draws, the shading frame, light sampling,
// the BSDF's evaluation and sampling, MIS weights, Russian roulette) done as eight-lane AVX2 operations
// (base/lanes.h). Ray queries go to the CPU accelerator eight at a time (CpuAccel::intersect8 and
// occluded8: the small-scene test sets the eight rays up in lanes, then tests each ray against its
// triangles; Embree answers them one by one with rtcIntersect1/rtcOccluded1, bench/RESULTS.md, 2026-12-01,
// having found its packet queries no faster on incoherent rays). One lane at a time stay the camera ray,
// the setup of sphere hits (make_surface_hit), emission at light hits and the light's choice from the
// alias table. A lane whose path ends starts the next pixel's, so the lanes stay busy.
//
// Each lane computes bit for bit what path_start / path_shade / path_shadow compute for the same pixel
// and sample index (the same IEEE operations in the same order; tests/cpp/test_path_lanes.cpp compares
// whole images), so images do not depend on whether lanes were used, nor on how pixels were grouped.
//
// Coverage grows with the lane-parallel core (docs/architecture.md, "CPU throughput"); for now the lanes
// shade vertices on untextured Lambertian surfaces (`diffuse`, one- or two-sided) lit by untextured
// triangle area lights, with either sampler (Sobol, or eight PCG32 streams); a vertex on any other material
// runs the scalar path_shade in its lane. Scenes with other lights run the scalar stages throughout.
#pragma once
#include <cstdint>
#include <string>

#include "path.h"

namespace caustica {

constexpr int kPathLanes = 8;

// Whether this build and this CPU run the lanes (x86-64 with AVX2, GCC or Clang).
bool path_lanes_available();
// Whether the lanes cover this scene and these parameters; if not, `why` (when given) says what they lack.
bool path_lanes_supported(const SceneView& s, const PathParams& pp, std::string* why = nullptr);

struct LaneResult {
  RGB L{0.f};          // the path's radiance estimate (before the filter weight), as PathState::L
  float weight = 0.f;  // pixel filter weight, as PathState::weight
  uint32_t pixel = 0;  // y * width + x
};
struct LaneCounts {
  uint64_t rays = 0;         // closest-hit queries
  uint64_t shadow_rays = 0;  // occlusion queries
};

// Traces one camera path, at sample index sample_index, for each pixel of the w x h rectangle at (x0, y0),
// into out[0 .. w*h-1] in row-major order; a lane whose path ends starts the next pixel's. Needs
// path_lanes_available() and path_lanes_supported(s, pp).
template <typename Accel>
void path_lanes_trace(const SceneView& s, const Accel& accel, const PathParams& pp, uint32_t x0, uint32_t y0, int w,
                      int h, uint32_t sample_index, LaneResult* out, LaneCounts& counts);

}  // namespace caustica
