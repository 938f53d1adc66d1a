#include "gltf_loader.h"
#include "../../base/error.h"
namespace caustica {
SceneDesc load_gltf_scene(const std::string& path) { throw InputError(path + ": glTF loading is not implemented yet"); }
}  // namespace caustica
