// Density grids in Mitsuba's binary volume format (.vol, the file Mitsuba 3's `gridvolume` reads and
// mi.VolumeGrid.write writes): the bytes 'V' 'O' 'L' 3, then little-endian int32 encoding (1: float32),
// xres, yres, zres, channels, six float32 (a bounding box, which Mitsuba 3 ignores unless asked), and
// xres * yres * zres * channels float32 samples, x fastest, then y, then z, channels innermost.
#pragma once
#include <string>
#include "scene_desc.h"

namespace caustica {

// Reads a grid of one or three channels (resolution and samples; to_world left as the identity). `bbox_lo`/`bbox_hi`
// receive the file's bounding box when not null. Throws InputError naming `referrer` (the scene file and
// where in it) and the file for a file that cannot be read or is not such a grid.
MediumGridDesc read_vol_grid(const std::string& path, const std::string& referrer, Vec3f* bbox_lo = nullptr,
                             Vec3f* bbox_hi = nullptr);

// Writes g's samples (its channels) as a .vol file (bounding box: the unit cube), atomically (a temporary
// file renamed into place); InputError when it cannot.
void write_vol_grid(const MediumGridDesc& g, const std::string& path);

}  // namespace caustica
