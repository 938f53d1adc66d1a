// glTF 2.0 (.gltf with external or data-URI buffers, and binary .glb) through tinygltf.
#pragma once
#include <string>
#include "../scene_desc.h"

namespace caustica {

SceneDesc load_gltf_scene(const std::string& path);

}  // namespace caustica
