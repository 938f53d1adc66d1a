// OpenVDB files as dense medium grids (vdb_io.h).
#include "vdb_io.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <mutex>

#include "../base/error.h"

namespace caustica {

namespace {

// Copies the grid's values over `box` (index space) into out, x fastest, channels innermost; false at the
// first negative or non-finite value (its index in *bad).
template <typename GridT, typename Store>
bool densify(const GridT& grid, const openvdb::CoordBBox& box, Store&& store, size_t* bad) {
  auto acc = grid.getConstAccessor();
  const openvdb::Coord lo = box.min(), dim = box.dim();
  size_t i = 0;
  for (int z = 0; z < dim.z(); ++z)
    for (int y = 0; y < dim.y(); ++y)
      for (int x = 0; x < dim.x(); ++x, ++i)
        if (!store(i, acc.getValue(lo + openvdb::Coord(x, y, z)))) {
          *bad = i;
          return false;
        }
  return true;
}

}  // namespace

MediumGridDesc read_vdb_grid(const std::string& path, const std::string& referrer, const std::string& grid_name) {
  auto fail = [&](const std::string& what) -> void {
    throw InputError(referrer + ": OpenVDB file '" + path + "': " + what);
  };
  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
  openvdb::GridBase::Ptr base;
  std::string names;
  try {
    openvdb::io::File file(path);
    file.open(false);  // no delayed loading: the file is read now and closed
    for (auto it = file.beginName(); it != file.endName(); ++it)
      names += (names.empty() ? "" : ", ") + it.gridName();
    if (file.hasGrid(grid_name)) base = file.readGrid(grid_name);
    file.close();
  } catch (const openvdb::Exception& e) {
    fail(std::string("cannot read it (") + e.what() + ")");
  } catch (const std::exception& e) {
    fail(std::string("cannot read it (") + e.what() + ")");
  }
  if (!base)
    fail("no grid named '" + grid_name + "' (the file has: " + (names.empty() ? std::string("none") : names) + ")");
  const std::string gname = "grid '" + grid_name + "'";
  if (base->getGridClass() == openvdb::GRID_LEVEL_SET)
    fail(gname + " is a level set (a signed distance to a surface), not a density; convert it to a fog volume");
  const bool scalar = base->isType<openvdb::FloatGrid>() || base->isType<openvdb::DoubleGrid>();
  const bool vector = base->isType<openvdb::Vec3SGrid>() || base->isType<openvdb::Vec3DGrid>();
  if (!scalar && !vector)
    fail(gname + " holds " + base->valueType() + " values (expected float or vec3s: a density, a colour)");
  if (!base->transform().isLinear()) fail(gname + " has a non-affine (frustum) transform");
  const openvdb::CoordBBox active = base->evalActiveVoxelBoundingBox();
  if (active.empty()) fail(gname + " has no active voxels");
  // One voxel of background around the active box (vdb_io.h).
  openvdb::CoordBBox box = active;
  box.expand(1);
  const openvdb::Coord dim = box.dim();
  const int channels = scalar ? 1 : 3;
  const uint64_t n = uint64_t(dim.x()) * uint64_t(dim.y()) * uint64_t(dim.z());
  if (n * uint64_t(channels) > kMaxDenseGridSamples)
    fail(gname + ": " + std::to_string(dim.x()) + " x " + std::to_string(dim.y()) + " x " + std::to_string(dim.z()) +
         " voxels once dense (its active box and a border), more than " + std::to_string(kMaxDenseGridSamples) +
         " samples; resample it to a coarser voxel size");
  MediumGridDesc g;
  g.name = path + ":" + grid_name;
  g.nx = dim.x();
  g.ny = dim.y();
  g.nz = dim.z();
  g.channels = channels;
  g.values.resize(size_t(n) * size_t(channels));
  size_t bad = 0;
  auto ok = [](double v) { return v >= 0.0 && std::isfinite(v); };
  bool good = true;
  if (base->isType<openvdb::FloatGrid>())
    good = densify(*openvdb::gridConstPtrCast<openvdb::FloatGrid>(base), box,
                   [&](size_t i, float v) { return ok(v) && (g.values[i] = v, true); }, &bad);
  else if (base->isType<openvdb::DoubleGrid>())
    good = densify(*openvdb::gridConstPtrCast<openvdb::DoubleGrid>(base), box,
                   [&](size_t i, double v) { return ok(v) && (g.values[i] = float(v), true); }, &bad);
  else {
    auto store3 = [&](size_t i, const auto& v) {
      for (int c = 0; c < 3; ++c) {
        if (!ok(double(v[c]))) return false;
        g.values[i * 3 + c] = float(v[c]);
      }
      return true;
    };
    if (base->isType<openvdb::Vec3SGrid>())
      good = densify(*openvdb::gridConstPtrCast<openvdb::Vec3SGrid>(base), box, store3, &bad);
    else
      good = densify(*openvdb::gridConstPtrCast<openvdb::Vec3DGrid>(base), box, store3, &bad);
  }
  if (!good) {
    const openvdb::Coord at = box.min() + openvdb::Coord(int(bad % size_t(dim.x())),
                                                         int(bad / size_t(dim.x()) % size_t(dim.y())),
                                                         int(bad / (size_t(dim.x()) * size_t(dim.y()))));
    fail(gname + ": the voxel at index (" + std::to_string(at.x()) + ", " + std::to_string(at.y()) + ", " +
         std::to_string(at.z()) + ") is negative or not finite (expected values >= 0)");
  }
  // The unit cube onto the index box [min - 1/2, max + 1/2] (voxel centres at integers), then the file's
  // affine index-to-world map: four points give the affine map.
  const openvdb::math::Transform& xf = base->transform();
  const openvdb::Vec3d c0(box.min().x() - 0.5, box.min().y() - 0.5, box.min().z() - 0.5);
  const openvdb::Vec3d w0 = xf.indexToWorld(c0);
  const double ext[3] = {double(dim.x()), double(dim.y()), double(dim.z())};
  for (int a = 0; a < 3; ++a) {
    openvdb::Vec3d c = c0;
    c[a] += ext[a];
    const openvdb::Vec3d axis = xf.indexToWorld(c) - w0;
    for (int r = 0; r < 3; ++r) g.to_world.m[r][a] = float(axis[r]);
  }
  for (int r = 0; r < 3; ++r) g.to_world.m[r][3] = float(w0[r]);
  return g;
}

}  // namespace caustica
