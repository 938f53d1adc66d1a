// One entry point for scenes: a built-in name or a scene file.
#pragma once
#include <string>
#include "scene_desc.h"

namespace caustica {

// A path to an existing file is loaded by its extension (.json); anything
// else must be a built-in scene name. Throws InputError otherwise.
SceneDesc load_scene_desc(const std::string& name_or_path);

}  // namespace caustica
