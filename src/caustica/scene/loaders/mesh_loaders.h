// Mesh-file loaders: OBJ + MTL (tinyobjloader), PLY (ASCII and binary) and Mitsuba's serialized meshes.
// Each can append a file's geometry to a scene (for JSON "mesh" shapes and
// Mitsuba XML obj/ply shapes) or load a file alone as a whole scene (with a
// default camera and light, see load.h). The conventions (normals, material
// mapping, what is skipped with a warning) are in docs/formats-obj-ply.md.
#pragma once
#include <cmath>
#include <string>
#include <vector>
#include "../scene_desc.h"

namespace caustica {

// PLY: vertex positions, optional normals (nx ny nz) and UVs (u v / s t /
// texture_u texture_v), faces (triangles and quads; larger polygons fanned).
// Errors throw InputError "<path>: line N (header) / element ...: what".
// This form drops the warnings (skipped degenerate or non-finite triangles);
// prefer the next one.
MeshDesc load_ply_mesh(const std::string& path);
// The same; what was skipped or repaired is appended to `warnings` (one line
// each, counting the cases, e.g. "bunny.ply: skipped 12 degenerate triangles").
// Vertex colours (red green blue) become MeshDesc::colors; so do face colours of a file whose vertices have none,
// constant over each face (vertices are copied where faces of different colours meet), and then *face_colors
// (when given) is set true: Mitsuba's face_color attribute, where vertex colours are its vertex_color.
MeshDesc load_ply_mesh(const std::string& path, std::vector<std::string>* warnings, bool* face_colors = nullptr);

// OBJ: appends one MeshDesc + ShapeDesc per (group or object, material) to
// `desc`, with `to_world`. material_override >= 0 uses that material for every
// shape (XML/JSON given a material); -1 converts the MTL materials (documented
// in docs/formats-obj-ply.md) and adds them to desc (names prefixed with the file
// stem to stay unique). Emissive MTL materials (Ke) make area lights. Returns
// the indices of the shapes added. Vertex colours (`v x y z r g b`, #MRGB; sRGB in the file) become linear
// MeshDesc::colors of the shapes whose vertices have them. Warnings go to desc.warnings.
std::vector<int> append_obj(SceneDesc& desc, const std::string& path, const Affine& to_world,
                            int material_override, const std::string& referrer);

// Angle-weighted smooth vertex normals (Thuermer & Wuethrich 1998, "Computing vertex normals from polygonal
// facets", JGT 3(1)): each triangle adds its unit normal (counter-clockwise winding) times its angle at the
// vertex, so the normal does not depend on how the surface around the vertex is cut into triangles (an area
// weighting leans towards the larger triangles). Mitsuba 3 and Blender compute missing normals this way.
// Vertices used by no (non-degenerate) triangle get (0, 0, 1).
std::vector<Vec3f> angle_weighted_normals(const std::vector<Vec3f>& positions, const std::vector<uint32_t>& indices);
// One triangle's terms of angle_weighted_normals: w[k] = unit normal of (p0, p1, p2) times the angle at p_k;
// false (and no terms) for a degenerate or non-finite triangle.
bool angle_weighted_terms(Vec3f p0, Vec3f p1, Vec3f p2, Vec3f w[3]);

// Mitsuba's serialized format (the `serialized` shape of Mitsuba 0.6 and 3): a file of zlib-compressed meshes,
// versions 3 and 4, single or double precision; `shape_index` picks one (0 = the first). Positions, optional
// normals and UVs (as in the file: Mitsuba's v points down), triangles; vertex colours are read past (as Mitsuba
// 3 does). Errors
// throw InputError "<path>: what"; what was skipped or repaired goes to `warnings` (as load_ply_mesh).
MeshDesc load_serialized_mesh(const std::string& path, size_t shape_index, std::vector<std::string>* warnings);

// A colour a mesh file may hold: non-negative and finite (the loaders make other colours white and count them).
inline bool usable_color(RGB c) {
  return c.x >= 0.f && c.y >= 0.f && c.z >= 0.f && std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z);
}

// What a mesh loader skipped or repaired, counted for its warnings.
struct MeshRepairs {
  size_t degenerate = 0;    // triangles of zero area or with a repeated vertex, skipped
  size_t nan = 0;           // triangles with non-finite vertex coordinates, skipped
  size_t bad_vertices = 0;  // vertices with non-finite coordinates
  size_t normals = 0;       // zero or non-finite normals replaced by computed ones
  size_t colors = 0;        // negative or non-finite vertex colours made white
};
// The last step of the PLY and serialized loaders: normals normalized (zero or non-finite ones, or all of them
// when the file has none, computed by angle_weighted_normals; counted in r.normals), non-finite UVs set to 0, and
// negative or non-finite vertex colours made white (r.colors).
void finish_mesh_attributes(MeshDesc& m, bool has_normals, MeshRepairs& r);
// One warning line per kind of repair, naming `path`.
void report_mesh_repairs(const std::string& path, const MeshRepairs& r, std::vector<std::string>& warnings);

}  // namespace caustica
