// Mesh-file loaders: OBJ + MTL (tinyobjloader) and PLY (ASCII and binary).
// Each can append a file's geometry to a scene (for JSON "mesh" shapes and
// Mitsuba XML obj/ply shapes) or load a file alone as a whole scene (with a
// default camera and light, see load.h).
#pragma once
#include <string>
#include <vector>
#include "../scene_desc.h"

namespace caustica {

// PLY: vertex positions, optional normals (nx ny nz) and UVs (u v / s t /
// texture_u texture_v), faces (triangles and quads; larger polygons fanned).
// Errors throw InputError "<path>: line N (header) / element ...: what".
MeshDesc load_ply_mesh(const std::string& path);

// OBJ: appends one MeshDesc + ShapeDesc per (group or object, material) to
// `desc`, with `to_world`. material_override >= 0 uses that material for every
// shape (XML/JSON given a material); -1 converts the MTL materials (documented
// in docs/scene-format.md) and adds them to desc (names prefixed with the file
// stem to stay unique). Emissive MTL materials (Ke) make area lights. Returns
// the indices of the shapes added.
std::vector<int> append_obj(SceneDesc& desc, const std::string& path, const Affine& to_world,
                            int material_override, const std::string& referrer);

}  // namespace caustica
