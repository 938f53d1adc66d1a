// The photon record shared by photon tracing and the photon maps.
#pragma once
#include <cstdint>
#include "../base/math.h"

namespace caustica {

enum PhotonFlags : uint32_t {
  kPhotonCaustic = 1u,  // the light path was L S+ D: at least one specular bounce, no diffuse one, before this hit
  kPhotonDirect = 2u,   // first hit after leaving the light (L D), or first scattering event in a medium
  // Stored at a scattering event in a participating medium (photon/trace.h): p is the event, wi points
  // back along the photon's way there, power already holds the medium's sigma_s (volume photons).
  kPhotonVolume = 4u,
};

// Working record written by photon tracing (photon/trace.h) at non-specular hits.
struct Photon {
  Vec3f p;          // position on the surface (in the medium: kPhotonVolume)
  Vec3f wi;         // unit direction towards where the photon came from (away from the surface)
  RGB power{0.f};   // flux carried; density estimates divide by the number of emitted photon paths
  uint32_t flags = 0;  // bits 0-2: PhotonFlags; bits 16-31: the photon's segments (photon_segments)
};

// The photon path's segments from the light to the photon (the first hit or scattering event is 1), kept in
// bits 16-31 of Photon::flags (saturating at 65535; the 16-byte maps keep 11 bits, compact_photon.h).
// Estimates keep only the photons that close a path of at most max_depth segments, as Mitsuba's photon
// mappers do: a visible point d segments from the camera takes photons of at most max_depth - d segments
// (photon_budget), so that `pm`, `ppm`, `sppm` and `pppm` render the same paths as `path` at any max depth,
// also behind glass, where the visible point is more than one segment from the camera.
constexpr uint32_t kPhotonSegmentsShift = 16;
constexpr uint32_t kPhotonFlagBits = (1u << kPhotonSegmentsShift) - 1u;
CHD uint32_t photon_segment_bits(uint32_t segments) {
  return (segments < 0xffffu ? segments : 0xffffu) << kPhotonSegmentsShift;
}
CHD uint32_t photon_segments(const Photon& ph) { return ph.flags >> kPhotonSegmentsShift; }

// The most segments a photon may have at a visible point `vp_depth` segments from the camera (the camera
// segment is 1) under max_depth (0xffffffff: unlimited, and so is the budget); 0 when no photon fits.
CHD uint32_t photon_budget(uint32_t max_depth, uint32_t vp_depth) {
  if (max_depth == 0xffffffffu) return max_depth;
  return vp_depth < max_depth ? max_depth - vp_depth : 0u;
}

}  // namespace caustica
