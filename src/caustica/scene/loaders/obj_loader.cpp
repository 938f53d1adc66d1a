#include "mesh_loaders.h"
#include "../../base/error.h"
namespace caustica {
std::vector<int> append_obj(SceneDesc&, const std::string& path, const Affine&, int, const std::string&) {
  throw InputError(path + ": OBJ loading is not implemented yet");
}
}  // namespace caustica
