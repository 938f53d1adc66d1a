// OpenVDB grids as medium grids (scene/vdb_io.h) through the JSON loader: the densified grid, looked up the
// way the renderer does (medium/medium_grid.h: cell-centred, trilinear, zero outside), equals OpenVDB's own
// trilinear box sampler in world space at random points in and around the active voxels, for a scaled,
// turned and moved voxel-to-world transform, a float grid and a vec3 grid (three channels), alone and
// placed in the scene by the medium's transform (composed with the file's) or bounds (the box onto them);
// and the errors (a missing grid naming those the file has, a level set, negative values, another value type,
// not a VDB file).
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "caustica/base/error.h"
#include "caustica/base/rng.h"
#include "caustica/medium/medium_grid.h"
#include "caustica/scene/loaders/json_loader.h"
#include "caustica/scene/scene.h"

using namespace caustica;
namespace fs = std::filesystem;

namespace {

struct VdbDir {
  fs::path path;
  VdbDir() {
    openvdb::initialize();
    path = fs::temp_directory_path() / ("caustica-vdb-" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~VdbDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& n) const { return (path / n).string(); }
};

// A lumpy float density and a vec3 colour over a sparse set of voxels (index x in [-3, 5], y in [2, 7], z in
// [-1, 3], some voxels left inactive), voxel size 0.25 turned 30 degrees about z and moved by (1, -0.5, 2).
openvdb::math::Transform::Ptr turned_transform() {
  openvdb::math::Transform::Ptr xf = openvdb::math::Transform::createLinearTransform(0.25);
  xf->postRotate(0.5236, openvdb::math::Z_AXIS);
  xf->postTranslate(openvdb::Vec3d(1.0, -0.5, 2.0));
  return xf;
}
void write_grids(const std::string& path) {
  auto density = openvdb::FloatGrid::create(0.f);
  density->setName("density");
  density->setGridClass(openvdb::GRID_FOG_VOLUME);
  auto colour = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
  colour->setName("Cd");
  PCG32 rng(3, 4);
  auto da = density->getAccessor();
  auto ca = colour->getAccessor();
  for (int z = -1; z <= 3; ++z)
    for (int y = 2; y <= 7; ++y)
      for (int x = -3; x <= 5; ++x) {
        if ((x + 2 * y + z) % 5 == 0) continue;  // inactive: the background
        da.setValue(openvdb::Coord(x, y, z), 2.f * rng.next_float());
        ca.setValue(openvdb::Coord(x, y, z), openvdb::Vec3s(rng.next_float(), rng.next_float(), rng.next_float()));
      }
  density->setTransform(turned_transform());
  colour->setTransform(turned_transform());
  openvdb::io::File f(path);
  f.write({density, colour});
  f.close();
}

// write_grids' file in dir as smoke.vdb, and its grid `name` read back with OpenVDB.
template <typename GridT>
typename GridT::Ptr written_grid(const VdbDir& dir, const std::string& name) {
  write_grids(dir.file("smoke.vdb"));
  openvdb::io::File f(dir.file("smoke.vdb"));
  f.open();
  auto grid = openvdb::gridPtrCast<GridT>(f.readGrid(name));
  f.close();
  return grid;
}

// The medium's density grid from a JSON medium whose "density" is `grid` (and the medium's extra keys).
struct Loaded {
  MediumGrid g;
  std::vector<float> values;
};
Loaded load(const VdbDir& dir, const std::string& density, const std::string& extra = "") {
  const std::string text = R"({"camera": {}, "media": {"m": {"type": "heterogeneous", "sigma_t": 1, "density": )" +
                           density + extra + R"(}}, "shapes": [{"type": "cube"}]})";
  SceneDesc d = load_json_scene_text(text, "scene.json", dir.path.string());
  Loaded l;
  std::vector<MediumGrid> gs;
  build_medium_grids(d, gs, l.values);
  l.g = gs.at(size_t(d.media.at(0).grid));
  return l;
}

// OpenVDB's trilinear sample of `grid` at world point p.
template <typename GridT>
typename GridT::ValueType vdb_sample(const GridT& grid, Vec3f p) {
  openvdb::tools::GridSampler<GridT, openvdb::tools::BoxSampler> s(grid);
  return s.wsSample(openvdb::Vec3d(p.x, p.y, p.z));
}

// Random world points around the grid: its active box in index space grown by 2 voxels, mapped to the world
// by `xf` and then by `scene` (the medium's placement).
template <typename F>
void for_points(const openvdb::math::Transform& xf, F&& f, int n = 4000) {
  PCG32 rng(11, 12);
  for (int i = 0; i < n; ++i) {
    const openvdb::Vec3d ijk(-5.0 + 12.0 * rng.next_float(), 0.0 + 10.0 * rng.next_float(),
                             -3.0 + 8.0 * rng.next_float());
    const openvdb::Vec3d w = xf.indexToWorld(ijk);
    f(Vec3f(float(w.x()), float(w.y()), float(w.z())));
  }
}

}  // namespace

TEST(Vdb, FloatGridMatchesOpenVdbsBoxSampler) {
  VdbDir dir;
  auto grid = written_grid<openvdb::FloatGrid>(dir, "density");
  Loaded l = load(dir, R"({"file": "smoke.vdb"})");
  EXPECT_EQ(l.g.channels, 1u);
  EXPECT_EQ(l.g.nx, 9u + 2u);  // the active box and one voxel of background on each side
  double worst = 0.0;
  for_points(*turned_transform(), [&](Vec3f p) {
    const float want = vdb_sample(*grid, p);
    const float got = grid_value(l.g, l.values.data(), p).x;
    worst = std::max(worst, double(std::fabs(got - want)));
  });
  EXPECT_LT(worst, 2e-5) << "largest difference from OpenVDB's sampler";
}

TEST(Vdb, Vec3GridIsAColourGrid) {
  VdbDir dir;
  auto grid = written_grid<openvdb::Vec3SGrid>(dir, "Cd");
  Loaded l = load(dir, R"({"file": "smoke.vdb", "grid": "Cd"})");
  EXPECT_EQ(l.g.channels, 3u);
  double worst = 0.0;
  for_points(*turned_transform(), [&](Vec3f p) {
    const openvdb::Vec3s want = vdb_sample(*grid, p);
    const RGB got = grid_value(l.g, l.values.data(), p);
    for (int c = 0; c < 3; ++c) worst = std::max(worst, double(std::fabs(got[c] - want[c])));
  });
  EXPECT_LT(worst, 2e-5);
}

TEST(Vdb, TheMediumsTransformMovesTheFilesWorldAndBoundsPlaceTheBox) {
  VdbDir dir;
  auto grid = written_grid<openvdb::FloatGrid>(dir, "density");
  // "transform" composes: scene point = 2 * file point + (0, 3, 0); so the file's point q is at 2 q + (0, 3, 0).
  Loaded l = load(dir, R"({"file": "smoke.vdb"})", R"(, "transform": {"scale": 2, "translate": [0, 3, 0]})");
  double worst = 0.0;
  for_points(*turned_transform(), [&](Vec3f q) {
    const float want = vdb_sample(*grid, q);
    worst = std::max(worst, double(std::fabs(grid_value(l.g, l.values.data(), q * 2.f + Vec3f(0, 3, 0)).x - want)));
  });
  EXPECT_LT(worst, 5e-5);
  // "bounds": the dense box (active voxels and the border) fills them, whatever the file's transform.
  Loaded b = load(dir, R"({"file": "smoke.vdb", "bounds": [[0, 0, 0], [11, 8, 7]]})");
  // Index (x, y, z) of the file sits at ((x + 4) + 0.5, (y - 1) + 0.5, (z + 2) + 0.5) there (unit voxels).
  const openvdb::Coord c(2, 4, 1);
  EXPECT_NEAR(grid_value(b.g, b.values.data(), Vec3f(6.5f, 3.5f, 3.5f)).x, grid->tree().getValue(c), 1e-6f);
}

TEST(Vdb, ErrorsNameTheFileAndTheGrid) {
  VdbDir dir;
  write_grids(dir.file("smoke.vdb"));
  auto message = [&](const std::string& density) {
    try {
      load(dir, density);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string m = message(R"({"file": "smoke.vdb", "grid": "heat"})");
  EXPECT_NE(m.find("scene.json: /media/m/density/file: OpenVDB file '"), std::string::npos) << m;
  EXPECT_TRUE(m.find("no grid named 'heat' (the file has: Cd, density)") != std::string::npos ||
              m.find("no grid named 'heat' (the file has: density, Cd)") != std::string::npos)
      << m;
  // A level set, negative values, an integer grid.
  auto ls = openvdb::FloatGrid::create(3.f);
  ls->setName("density");
  ls->setGridClass(openvdb::GRID_LEVEL_SET);
  ls->getAccessor().setValue(openvdb::Coord(0, 0, 0), -1.f);
  auto neg = openvdb::FloatGrid::create(0.f);
  neg->setName("density");
  neg->getAccessor().setValue(openvdb::Coord(1, 2, 3), -0.5f);
  auto ints = openvdb::Int32Grid::create(0);
  ints->setName("density");
  ints->getAccessor().setValue(openvdb::Coord(0, 0, 0), 4);
  const std::pair<openvdb::GridBase::Ptr, std::string> cases[] = {
      {ls, "grid 'density' is a level set"},
      {neg, "the voxel at index (1, 2, 3) is negative or not finite"},
      {ints, "grid 'density' holds int32 values (expected float or vec3s"}};
  for (const auto& [g, want] : cases) {
    openvdb::io::File f(dir.file("bad.vdb"));
    f.write({g});
    f.close();
    m = message(R"({"file": "bad.vdb"})");
    EXPECT_NE(m.find(want), std::string::npos) << m;
  }
  std::ofstream(dir.file("junk.vdb")) << "not a vdb";
  m = message(R"({"file": "junk.vdb"})");
  EXPECT_NE(m.find("OpenVDB file '"), std::string::npos) << m;
  EXPECT_NE(m.find("cannot read it"), std::string::npos) << m;
  m = message(R"({"file": "grid.vol", "grid": "density"})");
  EXPECT_NE(m.find("/media/m/density/grid: applies to an OpenVDB file (.vdb)"), std::string::npos) << m;
}
