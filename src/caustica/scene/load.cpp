#include "load.h"

#include <algorithm>
#include <filesystem>

#include "../base/error.h"
#include "builtin/builtin.h"
#include "loaders/json_loader.h"

namespace caustica {

SceneDesc load_scene_desc(const std::string& name_or_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (is_builtin_scene(name_or_path) && !fs::exists(name_or_path, ec)) return builtin_scene(name_or_path);
  fs::path p(name_or_path);
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (fs::exists(p, ec)) {
    if (fs::is_directory(p, ec)) throw InputError(name_or_path + ": is a directory, not a scene file");
    if (ext == ".json") return load_json_scene_file(name_or_path);
    throw InputError(name_or_path + ": unsupported scene format '" + ext + "' (supported: .json)");
  }
  if (!ext.empty() || name_or_path.find('/') != std::string::npos)
    throw InputError(name_or_path + ": no such file");
  return builtin_scene(name_or_path);  // throws with the list of names
}

}  // namespace caustica
