// Writes tests/data/media/plume.vdb, the OpenVDB test asset of tests/python/test_media_vdb.py: a float grid
// "density" (a lumpy plume, 20 x 24 x 20 voxels with an empty corner, 0 to about 3) and a vec3 grid "Cd"
// (a colour per voxel) on voxels of size 0.1, moved by (-1, 0, -1). Build and run (Debian's libopenvdb-dev
// and libboost-dev; OpenVDB needs its templates at default visibility):
//   g++ -O2 -std=c++17 make_plume_vdb.cpp -o /tmp/make_plume_vdb -lopenvdb -ltbb -lImath-3_1
//   /tmp/make_plume_vdb tests/data/media/plume.vdb
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cmath>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  openvdb::initialize();
  auto density = openvdb::FloatGrid::create(0.f);
  density->setName("density");
  density->setGridClass(openvdb::GRID_FOG_VOLUME);
  auto colour = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
  colour->setName("Cd");
  auto da = density->getAccessor();
  auto ca = colour->getAccessor();
  for (int z = 0; z < 20; ++z)
    for (int y = 0; y < 24; ++y)
      for (int x = 0; x < 20; ++x) {
        if (x < 5 && z < 5) continue;  // an empty corner: inactive voxels
        const double u = (x + 0.5) / 20 - 0.5, v = (y + 0.5) / 24, w = (z + 0.5) / 20 - 0.5;
        const double d = 3.0 * std::exp(-(u * u + (v - 0.35) * (v - 0.35) + w * w) / 0.06) *
                         (1.0 + 0.3 * std::sin(17 * u) * std::cos(13 * w));
        if (d < 1e-3) continue;
        da.setValue(openvdb::Coord(x, y, z), float(d));
        ca.setValue(openvdb::Coord(x, y, z), openvdb::Vec3s(float(0.5 + 0.5 * v), 0.6f, float(1.0 - 0.5 * v)));
      }
  auto xf = openvdb::math::Transform::createLinearTransform(0.1);
  xf->postTranslate(openvdb::Vec3d(-1.0, 0.0, -1.0));
  density->setTransform(xf);
  colour->setTransform(xf->copy());
  openvdb::io::File f(argv[1]);
  f.setCompression(openvdb::io::COMPRESS_BLOSC);
  f.write({density, colour});
  f.close();
  return 0;
}
