// OpenVDB files (.vdb, the sparse volume format of film production: Houdini, Blender, EmberGen, Cycles) as
// the dense grids of heterogeneous media (scene_desc.h's MediumGridDesc, medium/medium_grid.h).
//
// A float grid reads as one channel, a vec3 grid (e.g. a colour "Cd" or an emission grid) as three. The grid's
// active voxels' bounding box, grown by one voxel on every side, becomes the dense grid: the extra border
// holds the background value (0 for a density), so that the grid's trilinear lookup between the outermost
// active voxel and the background matches OpenVDB's own box sampler (voxel centres at integer index
// coordinates) up to the box's faces, and the border samples held beyond them are the background. to_world
// maps the unit cube onto that box in the file's world space (its index-to-world transform, which must be
// affine: frustum transforms are refused).
#pragma once
#include <string>
#include "scene_desc.h"

namespace caustica {

// The most voxels (times channels) a grid may hold once dense: 2^28 floats, 1 GiB.
constexpr uint64_t kMaxDenseGridSamples = uint64_t(1) << 28;

// Reads grid `grid_name` of the OpenVDB file at `path` (file names and the world transform as above). Throws
// InputError naming `referrer` (the scene file and where in it) and the file for a file that cannot be read,
// a grid that is missing (naming the grids the file has), of another value type, a level set, empty, not
// affine, holding negative or non-finite values, or too large once dense.
MediumGridDesc read_vdb_grid(const std::string& path, const std::string& referrer, const std::string& grid_name);

}  // namespace caustica
