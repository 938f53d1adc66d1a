#include "builtin.h"

#include "../../base/error.h"

namespace caustica {

const std::vector<std::pair<std::string, std::string>>& builtin_scenes() {
  static const std::vector<std::pair<std::string, std::string>> s = {
      {"smallvcm-spheres", "SmallVCM Cornell box: glossy floor, mirror and glass spheres, ceiling area light (default)"},
      {"cornell", "Mitsuba 3's cornell_box(): two boxes, rectangular ceiling light"},
      {"smallvcm-sun", "SmallVCM scene 0: glossy floor, mirror and glass spheres, sun (directional light)"},
      {"smallvcm-mirror-ball", "SmallVCM scene 1: glossy floor, large mirror sphere, ceiling area light"},
      {"smallvcm-point", "SmallVCM scene 2: glossy floor, mirror and glass spheres, point light"},
      {"smallvcm-env", "SmallVCM scene 3: glossy floor, mirror and glass spheres, constant environment"},
      {"point-in-glass", "SDS: SmallVCM's box lit only by a point light inside a glass sphere (path tracing renders it black)"},
      {"smallvcm-fog", "SmallVCM's spheres and area light in a box filled with haze (participating media: every integrator)"},
      {"smallvcm-smoke",
       "SmallVCM's box and area light with a plume of smoke (a heterogeneous medium, a density grid: every integrator)"},
      {"fog-lens", "a point light focused by a glass ball into fog: a volumetric caustic (the photon mappers and the bidirectional integrators; path tracing cannot render it)"},
  };
  return s;
}

const std::string& default_scene_name() { return builtin_scenes().front().first; }

bool is_builtin_scene(const std::string& name) {
  for (const auto& s : builtin_scenes())
    if (s.first == name) return true;
  return false;
}

SceneDesc builtin_scene(const std::string& name) {
  SceneDesc d;
  if (name == "cornell") d = make_cornell_mitsuba();
  else if (name == "smallvcm-spheres") d = make_smallvcm_cornell(false, true, SmallVCMLight::kArea);
  else if (name == "smallvcm-sun") d = make_smallvcm_cornell(false, true, SmallVCMLight::kSun);
  else if (name == "smallvcm-mirror-ball") d = make_smallvcm_cornell(true, false, SmallVCMLight::kArea);
  else if (name == "smallvcm-point") d = make_smallvcm_cornell(false, true, SmallVCMLight::kPoint);
  else if (name == "point-in-glass") d = make_point_in_glass();
  else if (name == "smallvcm-fog") d = make_smallvcm_fog();
  else if (name == "smallvcm-smoke") d = make_smallvcm_smoke();
  else if (name == "fog-lens") d = make_fog_lens();
  else if (name == "smallvcm-env") d = make_smallvcm_cornell(false, true, SmallVCMLight::kBackground);
  else {
    std::string list;
    for (const auto& s : builtin_scenes()) list += (list.empty() ? "" : ", ") + s.first;
    throw InputError("unknown scene '" + name + "' (not a file; built-in scenes: " + list + ")");
  }
  d.name = name;
  return d;
}

}  // namespace caustica
