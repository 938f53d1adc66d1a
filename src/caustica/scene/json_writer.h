// Writes a SceneDesc as caustica's JSON scene format (docs/scene-format.md), so
// that any loaded scene (built-in, JSON, OBJ, glTF, Mitsuba XML) can be saved
// and read back: `caustica export`.
#pragma once
#include <string>
#include "scene_desc.h"

namespace caustica {

// The JSON text. Every float is written with the fewest digits that read back
// to the same float (at most max_digits10), so the description round-trips
// exactly; meshes are written inline (each once, in "meshes", and instanced by
// name). Textures are referenced as "<texture_stem>.tex<i>.exr" beside the file
// (write_scene_json writes them). Throws InputError for what JSON cannot hold
// (a non-finite number, an area light in `lights`, a dangling index).
std::string scene_desc_to_json(const SceneDesc& desc, const std::string& texture_stem = "scene");

// Writes `path` (atomically: a temporary file renamed into place) and, if the
// scene has textures, one float EXR per texture in use beside it, named after
// the JSON file's stem, and one .vol file per density grid a medium uses.
// Texture alpha channels are not kept; textures nothing refers to are dropped.
void write_scene_json(const SceneDesc& desc, const std::string& path);

// The texture file name scene_desc_to_json uses for texture `index`.
std::string exported_texture_name(const std::string& texture_stem, size_t index);
// The .vol file scene_desc_to_json names for density grid `index` (write_scene_json writes it).
std::string exported_grid_name(const std::string& texture_stem, size_t index);
// The grey image of texture `index`'s alpha channel (an opacity read from the alpha channel).
std::string exported_alpha_texture_name(const std::string& texture_stem, size_t index);

}  // namespace caustica
