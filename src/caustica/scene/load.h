// One entry point for scenes: a built-in name or a scene file.
#pragma once
#include <map>
#include <string>
#include "scene_desc.h"

namespace caustica {

struct LoadOptions {
  std::string camera;                         // glTF / XML: the camera to use by name ("" = the first)
  std::map<std::string, std::string> params;  // Mitsuba XML $name substitutions
  std::string variant;                        // glTF: a KHR_materials_variants variant by name ("" = none)
};

// A path to an existing file is loaded by its extension (.json, .obj, .ply,
// .gltf, .glb, .xml); anything else must be a built-in scene name. Throws
// InputError otherwise.
SceneDesc load_scene_desc(const std::string& name_or_path, const LoadOptions& opts = {});

// For files that carry geometry only (OBJ, PLY; glTF without a camera or
// lights): a camera looking at the bounds' centre along -z from far enough
// to see them (fov 40 degrees, 512 x 512), and, if the scene emits no light,
// a constant white environment (radiance 1). Each default added is reported
// in desc.warnings.
void add_default_camera_and_light(SceneDesc& desc, bool need_camera);

// Counts and world-space bounds of a scene description.
SceneStats scene_stats(const SceneDesc& desc);

}  // namespace caustica
