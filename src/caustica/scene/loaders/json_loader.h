// caustica's native JSON scene format (docs/scene-format.md).
#pragma once
#include <string>
#include "../scene_desc.h"

namespace caustica {

// Parses JSON text; `source` names the file (or "<dict>") in error messages.
// Errors throw InputError: "<source>: <json path or line>: <what was expected>".
SceneDesc load_json_scene_text(const std::string& text, const std::string& source);
SceneDesc load_json_scene_file(const std::string& path);

}  // namespace caustica
