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
  uint32_t flags = 0;
};

}  // namespace caustica
