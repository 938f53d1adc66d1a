// glTF 2.0 (.gltf with external or data-URI buffers, and binary .glb) through tinygltf.
#pragma once
#include <string>
#include "../scene_desc.h"

namespace caustica {

// variant: a KHR_materials_variants variant by name, whose materials the primitives it maps take ("": none,
// each primitive its own material); a name the file does not have is an InputError listing its variants.
SceneDesc load_gltf_scene(const std::string& path, const std::string& variant = "");

}  // namespace caustica
