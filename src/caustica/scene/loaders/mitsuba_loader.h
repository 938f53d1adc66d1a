// Mitsuba 3 XML scenes (the subset documented in docs/formats-mitsuba.md) through pugixml.
#pragma once
#include <map>
#include <string>
#include "../scene_desc.h"

namespace caustica {

// `params` overrides <default name=... value=...> for $name substitution.
SceneDesc load_mitsuba_scene(const std::string& path, const std::map<std::string, std::string>& params = {});

}  // namespace caustica
