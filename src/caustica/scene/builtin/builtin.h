// Built-in scenes, by name.
#pragma once
#include <string>
#include <utility>
#include <vector>
#include "../scene_desc.h"

namespace caustica {

// (name, one-line description) of every built-in scene, default first.
const std::vector<std::pair<std::string, std::string>>& builtin_scenes();
const std::string& default_scene_name();
bool is_builtin_scene(const std::string& name);
// Throws InputError for an unknown name (listing the known ones).
SceneDesc builtin_scene(const std::string& name);

SceneDesc make_cornell_mitsuba();
enum class SmallVCMLight { kSun, kArea, kPoint, kBackground };
SceneDesc make_smallvcm_cornell(bool large_mirror_sphere, bool small_spheres, SmallVCMLight light);
// SmallVCM's box with a point light inside a glass sphere: all light reaches the room
// through glass (L S+ D ... E), which path tracing cannot sample.
SceneDesc make_point_in_glass();
// SmallVCM's box (area light, mirror and glass spheres) filled with a homogeneous haze.
SceneDesc make_smallvcm_fog();
SceneDesc make_smallvcm_smoke();
SceneDesc make_fog_lens();

}  // namespace caustica
