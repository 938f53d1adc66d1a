#include "mesh_loaders.h"
#include "../../base/error.h"
namespace caustica {
MeshDesc load_ply_mesh(const std::string& path) { throw InputError(path + ": PLY loading is not implemented yet"); }
}  // namespace caustica
