// caustica's native JSON scene format (docs/scene-format.md, docs/scene.schema.json).
#pragma once
#include <string>
#include "../scene_desc.h"

namespace caustica {

// Parses JSON text; `source` names the file (or "<dict>") in error messages.
// Relative file names in the scene (meshes, textures, environment maps) are
// resolved against `base_dir` ("" = the current directory).
// Errors throw InputError: "<source>: <json path or line>: <what was expected>".
SceneDesc load_json_scene_text(const std::string& text, const std::string& source, const std::string& base_dir = "");
// Reads a file; relative names in it are resolved against its directory.
SceneDesc load_json_scene_file(const std::string& path);
// A pixel filter as the scene format's "filter" (a name, or an object with its parameters), in JSON text;
// errors name `source` and the key.
Filter parse_filter_json(const std::string& text, const std::string& source);

}  // namespace caustica
