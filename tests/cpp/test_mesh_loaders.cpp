// OBJ + MTL and PLY loaders: geometry (dedup, triangulation, normals, UVs),
// the MTL -> material mapping, and one-line errors and counted warnings for
// broken input. Test files are written into a fresh temporary folder.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unistd.h>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "caustica/base/error.h"
#include "caustica/scene/load.h"
#include "caustica/scene/loaders/mesh_loaders.h"
#include "caustica/scene/scene.h"

using namespace caustica;
namespace fs = std::filesystem;

namespace {

fs::path test_dir() {
  static fs::path d = [] {
    fs::path p = fs::path(testing::TempDir()) / ("caustica_mesh_" + std::to_string(::getpid()));
    fs::create_directories(p);
    return p;
  }();
  return d;
}

std::string write(const std::string& name, const std::string& bytes) {
  fs::path p = test_dir() / name;
  fs::create_directories(p.parent_path());
  std::ofstream f(p, std::ios::binary);
  f.write(bytes.data(), std::streamsize(bytes.size()));
  return p.string();
}

// The message of the InputError that f throws ("" if none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

template <class T>
void put(std::string& s, T v, bool big = false) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

SceneDesc load_obj(const std::string& path) {
  SceneDesc d;
  append_obj(d, path, Affine(), -1, path);
  return d;
}

size_t triangles(const SceneDesc& d) {
  size_t n = 0;
  for (const MeshDesc& m : d.meshes) n += m.indices.size() / 3;
  return n;
}

double area(const MeshDesc& m) {
  double a = 0;
  for (size_t t = 0; t < m.indices.size(); t += 3) {
    Vec3f p0 = m.positions[m.indices[t]], p1 = m.positions[m.indices[t + 1]], p2 = m.positions[m.indices[t + 2]];
    a += 0.5 * length(cross(p1 - p0, p2 - p0));
  }
  return a;
}

// A unit cube, outward counter-clockwise quads, 8 shared positions.
const char* kCubeObjNoNormals =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

// Checks every vertex normal has unit length and points away from the centre.
void expect_outward_unit_normals(const MeshDesc& m, Vec3f centre) {
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (size_t i = 0; i < m.normals.size(); ++i) {
    EXPECT_NEAR(length(m.normals[i]), 1.f, 1e-5f);
    EXPECT_GT(dot(m.normals[i], m.positions[i] - centre), 0.f) << i;
  }
}

// The corners of a unit cube whose faces are split into two triangles each: angle-weighted normals are the
// diagonals (p - centre) / |p - centre| whatever the split, because each face turns 90 degrees about every
// corner it has, split or not (an area weighting counts a face twice at the two corners its diagonal joins).
void expect_cube_corner_diagonals(const MeshDesc& m) {
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (size_t i = 0; i < m.normals.size(); ++i) {
    const Vec3f d = normalize(m.positions[i] - Vec3f(0.5f));
    EXPECT_NEAR(m.normals[i].x, d.x, 1e-6f) << i;
    EXPECT_NEAR(m.normals[i].y, d.y, 1e-6f) << i;
    EXPECT_NEAR(m.normals[i].z, d.z, 1e-6f) << i;
  }
}

}  // namespace

// ----------------------------------------------------------------------------- PLY

TEST(PlyLoader, MissingNormalsAreAngleWeightedAsMitsubas) {
  // Two triangles at a right angle: (0,0,0) (1,0,0) (0,1,0) in z = 0 (normal +z, area 0.5) and (0,0,0) (0,0,3)
  // (1,0,0) in y = 0 (normal +y, area 1.5). Mitsuba 3.9.1 gives these vertex normals for this file (its
  // `vertex_normals`): vertex 0 sees 90 degrees of each face, vertex 1 45 degrees of the first and
  // atan(3) = 71.57 degrees of the second. (Area weights would give (0, 0.949, 0.316) at vertex 0.)
  std::string p = write("hinge.ply",
                        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n0 0 3\n3 0 1 2\n3 0 3 1\n");
  MeshDesc m = load_ply_mesh(p, nullptr);
  const Vec3f mitsuba[4] = {{0.f, 0.70710677f, 0.70710677f}, {0.f, 0.84655f, 0.5323093f}, {0.f, 0.f, 1.f},
                            {0.f, 1.f, 0.f}};
  ASSERT_EQ(m.normals.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(m.normals[i].x, mitsuba[i].x, 1e-6f) << i;
    EXPECT_NEAR(m.normals[i].y, mitsuba[i].y, 1e-6f) << i;
    EXPECT_NEAR(m.normals[i].z, mitsuba[i].z, 1e-6f) << i;
  }
  // A cube of 12 triangles: every corner's normal is its diagonal.
  std::string c = write("cube_nonormals.ply",
                        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 6\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
                        "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n");
  expect_cube_corner_diagonals(load_ply_mesh(c, nullptr));
}

TEST(PlyLoader, AsciiQuadIsSplitAndReadsUVs) {
  std::string p = write("quad.ply",
                        "ply\nformat ascii 1.0\ncomment a unit quad\nelement vertex 4\n"
                        "property float x\nproperty float y\nproperty float z\nproperty float s\nproperty float t\n"
                        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n4 0 1 2 3\n");
  std::vector<std::string> w;
  MeshDesc m = load_ply_mesh(p, &w);
  EXPECT_TRUE(w.empty());
  ASSERT_EQ(m.positions.size(), 4u);
  ASSERT_EQ(m.indices.size(), 6u);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_NEAR(area(m), 1.0, 1e-6);
  ASSERT_EQ(m.uvs.size(), 4u);
  EXPECT_EQ(m.uvs[2].x, 1.f);
  EXPECT_EQ(m.uvs[2].y, 1.f);
  EXPECT_EQ(m.uvs[1].y, 0.f);
  // No normals in the file: computed, unit, along +z (counter-clockwise seen from +z).
  for (Vec3f n : m.normals) {
    EXPECT_NEAR(n.z, 1.f, 1e-6f);
    EXPECT_NEAR(length(n), 1.f, 1e-6f);
  }
}

TEST(PlyLoader, QuadSplitAlongTheShorterDiagonal) {
  // A quad whose 1-3 diagonal is shorter than 0-2.
  std::string p = write("kite.ply",
                        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 1\nproperty list uchar uint vertex_index\nend_header\n"
                        "0 0 0\n1 -0.2 0\n3 0 0\n1 0.2 0\n4 0 1 2 3\n");
  MeshDesc m = load_ply_mesh(p);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 3, 1, 2, 3}));
}

// The same mesh, a cube with per-vertex normals and an extra element, in the three encodings
// with assorted types: they must read identically.
std::string cube_ply(const std::string& format) {
  const float P[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const int F[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  std::string h = "ply\r\nformat " + format +
                  " 1.0\r\nelement vertex 8\r\nproperty double x\r\nproperty float32 y\r\nproperty float z\r\n"
                  "property uchar red\r\nproperty short nx\r\nproperty int8 ny\r\nproperty int nz\r\n"
                  "property list uint8 float extra\r\n"
                  "element edge 2\r\nproperty int vertex1\r\nproperty int vertex2\r\n"
                  "element face 6\r\nproperty uchar flags\r\nproperty list uint16 uint32 vertex_indices\r\n"
                  "property list uchar float texcoord\r\nend_header\r\n";
  bool ascii = format == "ascii", big = format == "binary_big_endian";
  std::string b;
  for (int i = 0; i < 8; ++i) {
    int n[3] = {P[i][0] ? 1 : -1, P[i][1] ? 1 : -1, P[i][2] ? 1 : -1};
    if (ascii) {
      b += std::to_string(P[i][0]) + " " + std::to_string(P[i][1]) + " " + std::to_string(P[i][2]) + " 200 " +
           std::to_string(n[0]) + " " + std::to_string(n[1]) + " " + std::to_string(n[2]) + " 2 0.5 -7\n";
    } else {
      put<double>(b, P[i][0], big);
      put<float>(b, P[i][1], big);
      put<float>(b, P[i][2], big);
      put<uint8_t>(b, 200, big);
      put<int16_t>(b, int16_t(n[0]), big);
      put<int8_t>(b, int8_t(n[1]), big);
      put<int32_t>(b, n[2], big);
      put<uint8_t>(b, 2, big);
      put<float>(b, 0.5f, big);
      put<float>(b, -7.f, big);
    }
  }
  for (int i = 0; i < 2; ++i) {
    if (ascii) b += "0 1\n";
    else put<int32_t>(b, 0, big), put<int32_t>(b, 1, big);
  }
  for (const auto& f : F) {
    if (ascii) {
      b += "7 4 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + " " +
           std::to_string(f[3]) + " 2 0.25 0.75\n";
    } else {
      put<uint8_t>(b, 7, big);
      put<uint16_t>(b, 4, big);
      for (int k = 0; k < 4; ++k) put<uint32_t>(b, uint32_t(f[k]), big);
      put<uint8_t>(b, 2, big);
      put<float>(b, 0.25f, big);
      put<float>(b, 0.75f, big);
    }
  }
  return h + b;
}

TEST(PlyLoader, AsciiLittleAndBigEndianReadTheSame) {
  MeshDesc ref;
  for (std::string fmt : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    std::vector<std::string> w;
    MeshDesc m = load_ply_mesh(write("cube_" + fmt + ".ply", cube_ply(fmt)), &w);
    ASSERT_EQ(m.positions.size(), 8u) << fmt;
    ASSERT_EQ(m.indices.size(), 36u) << fmt;
    EXPECT_NEAR(area(m), 6.0, 1e-5) << fmt;
    ASSERT_EQ(w.size(), 1u) << fmt;
    EXPECT_EQ(w[0], (test_dir() / ("cube_" + fmt + ".ply")).string() + ": ignored element 'edge'");
    // Normals from the file, normalized: (+-1, +-1, +-1) / sqrt(3), pointing outward.
    expect_outward_unit_normals(m, Vec3f(0.5f));
    EXPECT_TRUE(m.uvs.empty());
    if (fmt == "ascii") {
      ref = m;
      continue;
    }
    EXPECT_EQ(m.indices, ref.indices) << fmt;
    for (size_t i = 0; i < 8; ++i) {
      EXPECT_EQ(m.positions[i].x, ref.positions[i].x);
      EXPECT_EQ(m.positions[i].y, ref.positions[i].y);
      EXPECT_EQ(m.positions[i].z, ref.positions[i].z);
      EXPECT_EQ(m.normals[i].z, ref.normals[i].z);
    }
  }
}

TEST(PlyLoader, PolygonsAreFannedAndSmallFacesSkipped) {
  std::string p = write("penta.ply",
                        "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n2 0 0\n3 1 0\n1 2 0\n-1 1 0\n5 0 1 2 3 4\n2 0 1\n");
  std::vector<std::string> w;
  MeshDesc m = load_ply_mesh(p, &w);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0], p + ": skipped 1 face with fewer than 3 vertices");
}

TEST(PlyLoader, NanAndDegenerateTrianglesAreSkippedAndCounted) {
  std::string p = write("bad.ply",
                        "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\nnan 0 0\n2 0 0\n3 0 1 2\n3 0 1 3\n3 0 1 4\n3 0 0 2\n");
  std::vector<std::string> w;
  MeshDesc m = load_ply_mesh(p, &w);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2}));
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0], p + ": skipped 2 degenerate triangles");
  EXPECT_EQ(w[1], p + ": skipped 1 triangle with non-finite (NaN or infinite) vertex coordinates (1 such vertex)");
  for (Vec3f n : m.normals) EXPECT_TRUE(std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z));
}

TEST(PlyLoader, ErrorsNameTheFileAndTheLine) {
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string faces = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  struct Case {
    std::string name, text, message;
  } cases[] = {
      {"notply.ply", "plyx\n", "line 1 (header): expected 'ply' (the file does not start like a PLY file)"},
      {"fmt.ply", "ply\nformat binary 1.0\n",
       "line 2 (header): unknown format 'binary' (expected ascii, binary_little_endian or binary_big_endian)"},
      {"type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty flt x\n",
       "line 4 (header): unknown property type 'flt' (expected char, uchar, short, ushort, int, uint, float, double or "
       "int8 ... float64)"},
      {"count.ply", "ply\nformat ascii 1.0\nelement vertex many\n",
       "line 3 (header): element 'vertex': expected a non-negative integer count, got 'many'"},
      {"noend.ply", head, "line 7 (header): expected 'end_header' before the end of the file"},
      {"noz.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n" + faces,
       "line 3 (header): element 'vertex' has no property 'z'"},
      {"nofaces.ply", head + "end_header\n0 0 0\n1 0 0\n0 1 0\n",
       "line 7 (header): no 'face' element (point clouds are not supported)"},
      {"noidx.ply", head + "element face 1\nproperty list uchar int verts\nend_header\n",
       "line 7 (header): element 'face' has no list property 'vertex_indices' (or 'vertex_index')"},
      {"keyword.ply", "ply\nformat ascii 1.0\nelemnt vertex 3\n",
       "line 3 (header): unknown header keyword 'elemnt' (expected format, element, property, comment, obj_info or "
       "end_header)"},
      {"range.ply", head + faces + "0 0 0\n1 0 0\n0 1 0\n3 0 1 1200\n",
       "line 13: face 0: vertex index 1200 out of range (3 vertices)"},
      {"value.ply", head + faces + "0 0 0\n1 zero 0\n", "line 11: vertex 1: property 'y': expected a number, got 'zero'"},
      {"short.ply", head + faces + "0 0 0\n1 0 0\n",
       "line 12: vertex 2: property 'x': expected a number, got the end of the file"},
      {"extra.ply", head + faces + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n9\n",
       "line 14: unexpected data after the last element (the header's counts are too small?)"},
  };
  for (const Case& c : cases) {
    std::string p = write(c.name, c.text);
    EXPECT_EQ(error_of([&] { load_ply_mesh(p); }), p + ": " + c.message);
  }
  EXPECT_EQ(error_of([&] { load_ply_mesh((test_dir() / "none.ply").string()); }),
            (test_dir() / "none.ply").string() + ": cannot open the file");
}

TEST(PlyLoader, BinaryErrors) {
  std::string hdr = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";
  std::string verts;
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put<float>(verts, v, false);
  std::string face0;
  put<uint8_t>(face0, 3);
  for (int i : {0, 1, 2}) put<int32_t>(face0, i, false);
  // Truncated in the vertex block, then in the second face.
  std::string p1 = write("trunc_v.ply", hdr + verts.substr(0, 20));
  EXPECT_EQ(error_of([&] { load_ply_mesh(p1); }),
            p1 + ": truncated binary data: vertex 1 ends past the end of the file (" + std::to_string(hdr.size() + 20) +
                " bytes)");
  // A count the file cannot hold (found by the fuzzer: 2^31 vertices made the loader
  // allocate 48 GiB) is refused before anything is allocated.
  std::string huge_hdr = hdr;
  huge_hdr.replace(huge_hdr.find("vertex 3"), 8, "vertex 2147483648");
  std::string ph = write("huge.ply", huge_hdr + verts + face0 + face0);
  EXPECT_EQ(error_of([&] { load_ply_mesh(ph); }),
            ph + ": line 3 (header): element 'vertex' declares 2147483648 records, but the file has room for at most " +
                std::to_string((verts.size() + 2 * face0.size() + 1) / 12));
  std::string p2 = write("trunc_f.ply", hdr + verts + face0 + face0.substr(0, 6));
  EXPECT_EQ(error_of([&] { load_ply_mesh(p2); }),
            p2 + ": truncated binary data: face 1 ends past the end of the file (" +
                std::to_string(hdr.size() + verts.size() + face0.size() + 6) + " bytes)");
  std::string bad;
  put<uint8_t>(bad, 3);
  for (int i : {0, -1, 2}) put<int32_t>(bad, i, false);
  std::string p3 = write("neg.ply", hdr + verts + face0 + bad);
  EXPECT_EQ(error_of([&] { load_ply_mesh(p3); }), p3 + ": face 1: vertex index -1 out of range (3 vertices)");
}

TEST(PlyLoader, LargeBinaryLoadsQuickly) {
  // 1000 x 1000 grid = 2 M triangles: must read in well under the time a few-million-triangle budget allows.
  const int n = 1000;
  std::string b = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string((n + 1) * (n + 1)) +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(n * n) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) put<float>(b, float(i), false), put<float>(b, float(j), false), put<float>(b, 0.f, false);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int a = j * (n + 1) + i;
      put<uint8_t>(b, 4, false);
      for (int v : {a, a + 1, a + n + 2, a + n + 1}) put<int32_t>(b, v, false);
    }
  std::string p = write("grid.ply", b);
  auto t0 = std::chrono::steady_clock::now();
  MeshDesc m = load_ply_mesh(p);
  double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(m.indices.size(), size_t(6) * n * n);
  EXPECT_NEAR(area(m), double(n) * n, 1.0);
  EXPECT_LT(s, 5.0);
  fs::remove(p);
}

// ----------------------------------------------------------------------------- OBJ

TEST(ObjLoader, CubeWithoutNormalsGetsSmoothOutwardNormals) {
  std::string p = write("cube.obj", kCubeObjNoNormals);
  SceneDesc d = load_obj(p);
  ASSERT_EQ(d.meshes.size(), 1u);
  ASSERT_EQ(d.shapes.size(), 1u);
  const MeshDesc& m = d.meshes[0];
  EXPECT_EQ(m.positions.size(), 8u);  // one vertex per (v, vt, vn): vt and vn absent
  EXPECT_EQ(m.indices.size(), 36u);
  EXPECT_NEAR(area(m), 6.0, 1e-5);
  expect_outward_unit_normals(m, Vec3f(0.5f));
  expect_cube_corner_diagonals(m);
  EXPECT_EQ(d.shapes[0].name, "cube");
  EXPECT_EQ(d.material_names, (std::vector<std::string>{"cube/default"}));
  EXPECT_TRUE(d.warnings.empty());
}

TEST(ObjLoader, SmoothingOffGivesFlatFaces) {
  std::string p = write("flatcube.obj", std::string("s off\n") + kCubeObjNoNormals);
  SceneDesc d = load_obj(p);
  const MeshDesc& m = d.meshes[0];
  EXPECT_EQ(m.positions.size(), 24u);  // a vertex per face corner
  EXPECT_TRUE(m.normals.empty());      // all flat: the geometric normal
  // Smoothing group 1 on two faces, the rest flat: 8 shared + 16 flat = at most 24 vertices, with normals.
  std::string q = write("mixed.obj",
                        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                        "s 1\nf 1 4 3 2\nf 5 6 7 8\ns off\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n");
  SceneDesc e = load_obj(q);
  const MeshDesc& n = e.meshes[0];
  EXPECT_EQ(n.positions.size(), 8u + 16u);
  ASSERT_EQ(n.normals.size(), n.positions.size());
  for (size_t i = 0; i < n.normals.size(); ++i) EXPECT_NEAR(length(n.normals[i]), 1.f, 1e-5f);
}

TEST(ObjLoader, DedupsVertexTuplesAndReadsNormalsAndUVs) {
  // Cube with 8 positions, 6 face normals and 4 uvs: 24 distinct (v, vt, vn) tuples.
  std::string s = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                  "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                  "vn 0 0 -2\nvn 0 0 1\nvn 0 -1 0\nvn 1 0 0\nvn 0 1 0\nvn -1 0 0\n"
                  "f 1/1/1 4/2/1 3/3/1 2/4/1\nf 5/1/2 6/2/2 7/3/2 8/4/2\nf 1/1/3 2/2/3 6/3/3 5/4/3\n"
                  "f 2/1/4 3/2/4 7/3/4 6/4/4\nf 3/1/5 4/2/5 8/3/5 7/4/5\nf -5/1/-1 -8/2/-1 -4/3/-1 -1/4/-1\n";
  SceneDesc d = load_obj(write("uvcube.obj", s));
  const MeshDesc& m = d.meshes[0];
  EXPECT_EQ(m.positions.size(), 24u);
  EXPECT_EQ(m.indices.size(), 36u);
  ASSERT_EQ(m.uvs.size(), 24u);
  ASSERT_EQ(m.normals.size(), 24u);
  // The first face's first corner: v 1, vt 1, vn 1 normalized.
  EXPECT_EQ(m.positions[0].x, 0.f);
  EXPECT_EQ(m.uvs[0].x, 0.f);
  EXPECT_EQ(m.uvs[0].y, 0.f);
  EXPECT_EQ(m.normals[0].z, -1.f);
  EXPECT_EQ(m.uvs[2].x, 1.f);  // corner 3/3
  EXPECT_EQ(m.uvs[2].y, 1.f);
  expect_outward_unit_normals(m, Vec3f(0.5f));
}

TEST(ObjLoader, NgonsAreTriangulatedIncludingConcaveOnes) {
  // An L-shaped hexagon (concave) of area 3 and a convex pentagon.
  std::string p = write("ngon.obj",
                        "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nf 1 2 3 4 5 6\n"
                        "g pent\nv 0 0 1\nv 2 0 1\nv 3 1 1\nv 1 2 1\nv -1 1 1\nf 7 8 9 10 11\n");
  SceneDesc d = load_obj(p);
  ASSERT_EQ(d.meshes.size(), 2u);
  EXPECT_EQ(d.meshes[0].indices.size(), 3u * 4);
  EXPECT_NEAR(area(d.meshes[0]), 3.0, 1e-6);  // a fan from vertex 1 would cover 4 (overlapping the notch)
  EXPECT_EQ(d.meshes[1].indices.size(), 3u * 3);
  EXPECT_NEAR(area(d.meshes[1]), 5.0, 1e-6);
  for (const MeshDesc& m : d.meshes)
    for (Vec3f n : m.normals) EXPECT_NEAR(n.z, 1.f, 1e-6f);
  EXPECT_EQ(d.shapes[0].name, "ngon");
  EXPECT_EQ(d.shapes[1].name, "ngon/pent");
}

TEST(ObjLoader, GroupsMaterialsAndTheMtlMapping) {
  // A 2x2 PFM texture (linear values, as stored).
  std::string pfm = "PF\n2 2\n-1.0\n";
  for (int i = 0; i < 12; ++i) put<float>(pfm, 0.25f, false);
  write("tex/wood.pfm", pfm);
  write("mats.mtl",
        "# materials\nnewmtl red\nKd 0.8 0.1 0.1\n\nnewmtl grey1\nKd 0.3\n"
        "newmtl shiny\nKd 0.5 0.5 0.5\nKs 0.25 0.25 0.25\nNs 50\nillum 2\n"
        "newmtl hot\nKs 0.8 0.8 0.8\nKd 0.5 0.4 0.4\nillum 2\n"
        "newmtl mirror\nKd 0 0 0\nKs 0.9 0.9 0.9\nillum 3\n"
        "newmtl varnish\nKd 0.2 0.3 0.4\nKs 1 1 1\nNi 1.6\nillum 5\n"
        "newmtl glass\nKd 0 0 0\nNi 1.33\nTf 0.9 1 0.9\nillum 7\n"
        "newmtl pane\nd 0.5\nillum 2\n"
        "newmtl lamp\nKe 10 9 8\n"
        "newmtl wood\nKd 0.6 0.6 0.6\nmap_Kd -s 1 1 1 tex/wood.pfm\nrefl refl.png\n"
        "newmtl leaf\nKd 0.2 0.6 0.1\nmap_d tex/wood.pfm\n");
  std::string obj = "mtllib mats.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\n";
  const char* names[] = {"red", "grey1", "shiny", "hot", "mirror", "varnish", "glass", "pane", "lamp", "wood", "leaf"};
  for (const char* n : names) obj += std::string("g ") + n + "\nusemtl " + n + "\nf 1 2 3 4\n";
  obj += "g two\nusemtl red\nf 1 2 3\nusemtl grey1\nf 1 3 4\n";
  std::string p = write("mats.obj", obj);
  SceneDesc d = load_obj(p);
  ASSERT_EQ(d.shapes.size(), 13u);
  EXPECT_EQ(d.shapes[11].name, "mats/two/red");
  EXPECT_EQ(d.shapes[12].name, "mats/two/grey1");
  auto mat = [&](const std::string& n) -> const Material& {
    int i = d.material_index("mats/" + n);
    EXPECT_GE(i, 0) << n;
    return d.materials[size_t(std::max(i, 0))];
  };
  EXPECT_EQ(d.shapes[0].material, d.material_index("mats/red"));
  EXPECT_EQ(d.shapes[11].material, d.material_index("mats/red"));
  EXPECT_EQ(mat("red").type, MaterialType::kDiffuse);
  EXPECT_EQ(mat("red").diffuse.x, 0.8f);
  EXPECT_EQ(mat("grey1").diffuse.z, 0.3f);  // one number = grey
  EXPECT_EQ(mat("shiny").type, MaterialType::kPhong);
  EXPECT_EQ(mat("shiny").exponent, 50.f);
  EXPECT_EQ(mat("shiny").specular.y, 0.25f);
  EXPECT_EQ(mat("hot").type, MaterialType::kPhong);  // Kd + Ks = 1.3 -> scaled by 1/1.3
  EXPECT_NEAR(mat("hot").diffuse.x + mat("hot").specular.x, 1.f, 1e-6f);
  EXPECT_EQ(mat("mirror").type, MaterialType::kConductor);
  EXPECT_EQ(mat("mirror").specular.x, 0.9f);
  EXPECT_EQ(mat("varnish").type, MaterialType::kPlastic);
  EXPECT_EQ(mat("varnish").eta, 1.6f);
  EXPECT_EQ(mat("glass").type, MaterialType::kDielectric);
  EXPECT_EQ(mat("glass").eta, 1.33f);
  EXPECT_EQ(mat("glass").transmission.x, 0.9f);
  EXPECT_EQ(mat("pane").type, MaterialType::kThinDielectric);
  EXPECT_EQ(mat("pane").eta, 1.5f);
  EXPECT_EQ(mat("lamp").type, MaterialType::kDiffuse);
  EXPECT_EQ(mat("lamp").diffuse.x, 0.f);  // emissive and no Kd: black
  EXPECT_EQ(d.shapes[8].emission.x, 10.f);
  EXPECT_EQ(d.shapes[8].emission.z, 8.f);
  EXPECT_EQ(d.shapes[0].emission.x, 0.f);
  ASSERT_EQ(d.textures.size(), 2u);
  EXPECT_EQ(mat("wood").tex_color, 0);
  // map_d: a cut-out mask, linear, read by its luminance when the image has no alpha channel.
  EXPECT_EQ(mat("leaf").type, MaterialType::kDiffuse);
  EXPECT_EQ(mat("leaf").tex_opacity, 1);
  EXPECT_FALSE(d.textures[1].srgb);
  EXPECT_TRUE(mat("leaf").flags & kOpacityLuminance);
  EXPECT_LT(mat("leaf").opacity_cutoff, 0.f);
  EXPECT_EQ(mat("wood").tex_opacity, -1);
  EXPECT_EQ(mat("wood").diffuse.x, 1.f);  // the texture replaces Kd
  EXPECT_EQ(d.textures[0].width, 2);
  EXPECT_FLOAT_EQ(d.textures[0].rgba[0], 0.25f);
  ASSERT_EQ(d.warnings.size(), 2u);
  EXPECT_EQ(d.warnings[0], (test_dir() / "mats.mtl").string() + ": ignored MTL statements without a mapping (refl)");
  EXPECT_EQ(d.warnings[1], p + ": 1 material has Kd + Ks above 1; both scaled down to conserve energy");
  // The uv column: vt given on no face -> no uvs.
  EXPECT_TRUE(d.meshes[0].uvs.empty());
  // Loaded twice into one scene: material names stay unique.
  append_obj(d, p, Affine(), -1, p);
  EXPECT_GE(d.material_index("mats/red~2"), 0);
  // It builds and has one area light (two triangles).
  auto sc = Scene::build(d);
  EXPECT_GT(sc->view().num_lights, 0u);
}

// norm is a normal map; bump / map_Bump a height map unless its texels are a tangent-space normal map's
// (exporters write normal maps there); -bm scales either; norm wins over a bump map, with a warning.
TEST(ObjLoader, BumpAndNormalMaps) {
  auto pfm = [](float r, float g, float b) {
    std::string t = "PF\n2 2\n-1.0\n";
    for (int i = 0; i < 4; ++i) {
      put<float>(t, r, false);
      put<float>(t, g, false);
      put<float>(t, b, false);
    }
    return t;
  };
  write("tex/height.pfm", pfm(0.3f, 0.3f, 0.3f));
  write("tex/normal.pfm", pfm(0.6f, 0.45f, 0.95f));
  write("tex/bright.pfm", pfm(0.8f, 0.8f, 0.8f));  // a light grey height map: still heights
  write("bumps.mtl",
        "newmtl height\nKd 0.5\nbump -bm 0.02 tex/height.pfm\n"
        "newmtl blender\nKd 0.5\nmap_Bump -bm 0.7 tex/normal.pfm\n"
        "newmtl both\nKd 0.5\nnorm tex/normal.pfm\nmap_bump tex/height.pfm\n"
        "newmtl bright\nKd 0.5\nmap_Bump tex/bright.pfm\n");
  std::string obj = "mtllib bumps.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                    "vn 0 0 1\n";
  for (const char* n : {"height", "blender", "both", "bright"})
    obj += std::string("g ") + n + "\nusemtl " + n + "\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";
  std::string p = write("bumps.obj", obj);
  SceneDesc d = load_obj(p);
  auto mat = [&](const std::string& n) -> const Material& {
    int i = d.material_index("bumps/" + n);
    EXPECT_GE(i, 0) << n;
    return d.materials[size_t(std::max(i, 0))];
  };
  EXPECT_GE(mat("height").tex_bump, 0);
  EXPECT_EQ(mat("height").tex_normal, -1);
  EXPECT_FLOAT_EQ(mat("height").bump_scale, 0.02f);
  EXPECT_GE(mat("blender").tex_normal, 0);
  EXPECT_EQ(mat("blender").tex_bump, -1);
  EXPECT_FLOAT_EQ(mat("blender").normal_scale, 0.7f);
  EXPECT_GE(mat("both").tex_normal, 0);
  EXPECT_EQ(mat("both").tex_bump, -1);
  EXPECT_FLOAT_EQ(mat("both").normal_scale, 1.f);
  EXPECT_GE(mat("bright").tex_bump, 0);
  EXPECT_EQ(mat("bright").tex_normal, -1);
  EXPECT_FLOAT_EQ(mat("bright").bump_scale, 1.f);
  for (const TextureDesc* t : {&d.textures[size_t(mat("height").tex_bump)], &d.textures[size_t(mat("both").tex_normal)]})
    EXPECT_FALSE(t->srgb);  // data, read linearly
  const std::string mtl = (test_dir() / "bumps.mtl").string();
  ASSERT_EQ(d.warnings.size(), 2u);
  EXPECT_EQ(d.warnings[0], mtl + ": line 6: bump map 'tex/normal.pfm' read as a tangent-space normal map (its texels are one's)");
  EXPECT_EQ(d.warnings[1], mtl + ": line 10: bump map 'tex/height.pfm' not used: the material has a normal map (norm)");
  // The normal-mapped parts get smooth tangents; the height-mapped one needs none.
  for (const ShapeDesc& s : d.shapes)
    EXPECT_EQ(d.meshes[size_t(s.mesh)].tangents.empty(), d.materials[size_t(s.material)].tex_normal < 0) << s.name;
  auto sc = Scene::build(d);
  EXPECT_EQ(sc->view().num_triangles, 8u);
}

TEST(ObjLoader, MaterialOverrideIgnoresTheMtl) {
  std::string p = write("override.obj", "mtllib missing.mtl\nusemtl x\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  SceneDesc d;
  d.add_material("mine", make_diffuse(RGB(0.2f)));
  std::vector<int> s = append_obj(d, p, Affine(), 0, "scene.json");
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(d.shapes[size_t(s[0])].material, 0);
  EXPECT_EQ(d.materials.size(), 1u);
}

TEST(ObjLoader, NanAndDegenerateTrianglesAreSkippedAndCounted) {
  std::string p = write("bad.obj",
                        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nv 2 0 0\nv 0 1 0\n"
                        "f 1 2 3\nf 1 2 4\nf 1 2 5\nf 1 1 3\nf 3 6 1\nl 1 2\n"
                        "g light\nusemtl nothing\nf 1 2 5\n");
  SceneDesc d = load_obj(p);
  EXPECT_EQ(triangles(d), 1u);
  EXPECT_EQ(d.warnings, (std::vector<std::string>{
                            p + ": skipped 4 degenerate triangles",
                            p + ": skipped 1 triangle with non-finite (NaN or infinite) vertex coordinates (1 such vertex)",
                            p + ": ignored 1 line/point statement ('l', 'p')",
                            p + ": line 14: usemtl 'nothing' is not in the material libraries; those faces use a grey "
                                "diffuse material (white times their vertex colours where they have them)"}));
  // Zero-area light: all its triangles degenerate.
  write("zl.mtl", "newmtl lamp\nKe 1 1 1\n");
  std::string q = write("zl.obj", "mtllib zl.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nusemtl lamp\nf 1 2 4\n");
  SceneDesc e = load_obj(q);
  EXPECT_EQ(e.shapes.size(), 1u);
  EXPECT_EQ(e.warnings, (std::vector<std::string>{q + ": skipped 1 degenerate triangle",
                                                  q + ": 1 emissive shape has zero area (no valid triangles); not used as lights"}));
}

TEST(ObjLoader, ErrorsNameTheFileAndTheLine) {
  struct Case {
    std::string name, text, message;
  } cases[] = {
      {"v2.obj", "v 1 2\n", "line 1: expected 3 coordinates (x y z, optionally w or r g b) after 'v', got 'v 1 2'"},
      {"vx.obj", "# c\nv 1 x 2\n", "line 2: expected a number, got 'x'"},
      {"f2.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3: expected at least 3 vertices after 'f', got 'f 1 2'"},
      {"frange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1200\n",
       "line 4: vertex index 1200 out of range (3 vertices defined so far)"},
      {"fneg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
       "line 4: vertex index -4 out of range (3 vertices defined so far)"},
      {"fzero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4: vertex index 0 in '0' (OBJ indices start at 1)"},
      {"fvt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
       "line 5: texture coordinate index 2 out of range (1 texture coordinates defined so far)"},
      {"fvn.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n",
       "line 4: normal index 1 out of range (0 normals defined so far)"},
      {"fsyn.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/a 2 3\n", "line 4: expected an integer texture coordinate index, got '1/a'"},
      {"kw.obj", "v 0 0 0\nvertex 1 2 3\n",
       "line 2: unknown statement 'vertex' (expected v, vt, vn, f, l, p, g, o, s, usemtl, mtllib or a comment)"},
      {"s.obj", "s maybe\n", "line 1: expected 'off' or a smoothing group number after 's', got 's maybe'"},
      {"empty.obj", "v 0 0 0\n", "no faces (1 vertex and no 'f' statements)"},
      {"allbad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 2\n",
       "no valid triangles (all faces are degenerate or have non-finite coordinates)"},
  };
  for (const Case& c : cases) {
    std::string p = write(c.name, c.text);
    EXPECT_EQ(error_of([&] { load_obj(p); }), p + ": " + c.message) << c.name;
  }
}

TEST(ObjLoader, MtlErrorsAndMissingFilesNameBothFiles) {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
  std::string p = write("nomtl.obj", "mtllib gone.mtl\n" + tri);
  EXPECT_EQ(error_of([&] { load_obj(p); }),
            p + ": line 1: material library 'gone.mtl' not found (" + (test_dir() / "gone.mtl").string() + ")");
  write("notex.mtl", "newmtl a\nKd 1 1 1\nmap_Kd nothere.png\n");
  p = write("notex.obj", "mtllib notex.mtl\n" + tri);
  EXPECT_EQ(error_of([&] { load_obj(p); }),
            (test_dir() / "notex.mtl").string() + ": line 3: texture file 'nothere.png' not found (" +
                (test_dir() / "nothere.png").string() + ")");
  struct Case {
    std::string mtl, message;
  } cases[] = {
      {"newmtl a\nKd 1 1\n", "line 2: expected 1 or 3 numbers after 'Kd', got 'Kd 1 1'"},
      {"newmtl a\nKs 1 x 1\n", "line 2: expected a number after 'Ks', got 'x'"},
      {"newmtl a\nKd -1 0 0\n", "line 2: expected non-negative values after 'Kd'"},
      {"newmtl a\nNs\n", "line 2: expected one number after 'Ns', got 'Ns'"},
      {"newmtl a\nNi 0\n", "line 2: expected a positive index of refraction after 'Ni'"},
      {"newmtl a\nd 1.5\n", "line 2: expected a value in [0, 1] after 'd'"},
      {"newmtl a\nillum 2.5\n", "line 2: expected an illumination model 0 to 10 after 'illum'"},
      {"Kd 1 1 1\n", "line 1: 'Kd' before any 'newmtl'"},
      {"newmtl a\nKd spectral x.rfl\n", "line 2: 'Kd spectral' colours are not supported (expected Kd r g b)"},
      {"newmtl a\nmap_Kd\n", "line 2: expected a file name after 'map_Kd'"},
      {"newmtl a\nPr 1.5\n", "line 2: expected one number in [0, 1] after 'Pr', got 'Pr 1.5'"},
      {"newmtl a\nPm\n", "line 2: expected one number in [0, 1] after 'Pm', got 'Pm'"},
  };
  int k = 0;
  for (const Case& c : cases) {
    std::string mtl = write("bad" + std::to_string(k) + ".mtl", c.mtl);
    p = write("bad" + std::to_string(k++) + ".obj", "mtllib " + fs::path(mtl).filename().string() + "\n" + tri);
    EXPECT_EQ(error_of([&] { load_obj(p); }), mtl + ": " + c.message);
  }
  // A missing OBJ referenced from another file.
  EXPECT_EQ(error_of([&] {
              SceneDesc d;
              append_obj(d, "/nonexistent/x.obj", Affine(), -1, "scene.json");
            }),
            "scene.json: mesh file '/nonexistent/x.obj' does not exist");
}

// The MTL PBR extension: Pr, Pm, Pc, Pcr (any of them) make glTF's metallic-roughness material (alpha = Pr^2, the coat's
// alpha Pcr^2); Ks, Ns and illum 2 beside them are not read; the glass rules still come first. map_Pr and map_Pm
// replace their values and become one texture, roughness in G and metallic in B (each image's luminance), two
// images of different sizes meeting at the roughness map's texels.
TEST(ObjLoader, PbrExtension) {
  auto pfm = [](int w, int h, const std::vector<float>& rgb) {
    std::string s = "PF\n" + std::to_string(w) + " " + std::to_string(h) + "\n-1.0\n";
    for (float v : rgb) put<float>(s, v, false);
    return s;
  };
  write("pbr/r.pfm", pfm(2, 2, {0.1f, 0.1f, 0.1f, 0.2f, 0.2f, 0.2f, 0.3f, 0.3f, 0.3f, 0.4f, 0.4f, 0.4f}));
  write("pbr/m.pfm", pfm(1, 1, {0.5f, 0.25f, 1.f}));
  write("pbr/mats.mtl",
        "newmtl gold\nKd 1 0.8 0.3\nKs 0.5 0.5 0.5\nNs 200\nillum 2\nPr 0.3\nPm 1\nPc 0.5\nPcr 0.2\n"
        "newmtl paint\nKd 0.2 0.3 0.4\nPr 0.6\n"
        "newmtl mapped\nKd 0.5 0.5 0.5\nPr 0.9\nPm 0\nmap_Pr r.pfm\nmap_Pm m.pfm\n"
        "newmtl rough_only\nmap_Pr r.pfm\n"
        "newmtl glassy\nPr 0.1\nNi 1.4\nillum 7\n"
        "newmtl coated\nKd 0.1 0.2 0.3\nPc 1\n");
  std::string obj = "mtllib mats.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n";
  for (const char* n : {"gold", "paint", "mapped", "rough_only", "glassy", "coated"})
    obj += std::string("usemtl ") + n + "\nf 1/1 2/2 3/3\n";
  SceneDesc d = load_obj(write("pbr/pbr.obj", obj));
  auto mat = [&](const std::string& n) -> const Material& {
    int i = d.material_index("pbr/" + n);
    EXPECT_GE(i, 0) << n;
    return d.materials[size_t(std::max(i, 0))];
  };
  const Material& gold = mat("gold");
  EXPECT_EQ(gold.type, MaterialType::kMetallicRoughness);
  EXPECT_EQ(gold.diffuse.y, 0.8f);
  EXPECT_EQ(gold.metallic, 1.f);
  EXPECT_FLOAT_EQ(gold.alpha_x, 0.09f);
  EXPECT_EQ(gold.clearcoat, 0.5f);
  EXPECT_FLOAT_EQ(gold.clearcoat_alpha, 0.04f);
  EXPECT_EQ(gold.tex_roughness, -1);
  EXPECT_EQ(mat("paint").type, MaterialType::kMetallicRoughness);
  EXPECT_EQ(mat("paint").metallic, 0.f);
  EXPECT_FLOAT_EQ(mat("paint").alpha_y, 0.36f);
  EXPECT_EQ(mat("paint").clearcoat, 0.f);
  EXPECT_EQ(mat("glassy").type, MaterialType::kDielectric);
  EXPECT_EQ(mat("coated").type, MaterialType::kMetallicRoughness);  // a coat alone: Pr 1, Pm 0 beneath it
  EXPECT_EQ(mat("coated").clearcoat, 1.f);
  EXPECT_EQ(mat("coated").alpha_x, 1.f);
  EXPECT_EQ(mat("coated").metallic, 0.f);
  const Material& mapped = mat("mapped");
  EXPECT_EQ(mapped.metallic, 1.f);  // the maps replace Pm and Pr
  EXPECT_EQ(mapped.alpha_x, 1.f);
  ASSERT_GE(mapped.tex_roughness, 0);
  const TextureDesc& rm = d.textures[size_t(mapped.tex_roughness)];
  EXPECT_FALSE(rm.srgb);
  ASSERT_EQ(rm.width, 2);
  ASSERT_EQ(rm.height, 2);
  const float metal = luminance(RGB(0.5f, 0.25f, 1.f));
  std::vector<float> rough;
  for (const TextureDesc& t : d.textures)
    if (t.name == (test_dir() / "pbr/r.pfm").string())
      for (int i = 0; i < 4; ++i) rough.push_back(t.rgba[4 * size_t(i) + 1]);
  ASSERT_EQ(rough.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_FLOAT_EQ(rm.rgba[4 * size_t(i) + 1], rough[size_t(i)]);  // grey: the luminance is the value
    EXPECT_FLOAT_EQ(rm.rgba[4 * size_t(i) + 2], metal);
  }
  const Material& ro = mat("rough_only");
  EXPECT_EQ(ro.metallic, 0.f);
  ASSERT_GE(ro.tex_roughness, 0);
  EXPECT_NE(ro.tex_roughness, mapped.tex_roughness);
  EXPECT_EQ(d.textures[size_t(ro.tex_roughness)].rgba[2], 1.f);  // no metallic map: its factor alone
  EXPECT_TRUE(d.warnings.empty()) << d.warnings[0];
  Scene::build(d);
}

TEST(ObjLoader, SameQuadAsPlyBuildsTheSameGeometry) {
  std::string o = write("q.obj", "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n");
  std::string y = write("q.ply",
                        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                        "property float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\n"
                        "end_header\n-1 -1 0 0 0\n1 -1 0 1 0\n1 1 0 1 1\n-1 1 0 0 1\n4 0 1 2 3\n");
  SceneDesc d = load_obj(o);
  MeshDesc m = load_ply_mesh(y);
  const MeshDesc& a = d.meshes[0];
  EXPECT_EQ(a.indices, m.indices);
  ASSERT_EQ(a.positions.size(), m.positions.size());
  for (size_t i = 0; i < a.positions.size(); ++i) {
    EXPECT_EQ(a.positions[i].x, m.positions[i].x);
    EXPECT_EQ(a.positions[i].y, m.positions[i].y);
    EXPECT_EQ(a.uvs[i].x, m.uvs[i].x);
    EXPECT_EQ(a.uvs[i].y, m.uvs[i].y);
    EXPECT_EQ(a.normals[i].z, m.normals[i].z);
  }
}

TEST(ObjLoader, LoadSceneDescAddsCameraAndLight) {
  std::string p = write("scene_cube.obj", kCubeObjNoNormals);
  SceneDesc d = load_scene_desc(p);
  EXPECT_EQ(d.shapes.size(), 1u);
  EXPECT_EQ(d.lights.size(), 1u);  // the default environment
  auto sc = Scene::build(d);
  EXPECT_EQ(sc->indices.size(), 36u);
}

// Vertex colours: `v x y z r g b` (sRGB, as Blender writes and reads them) and ZBrush's #MRGB lines (bytes, for the
// vertices before them) become linear MeshDesc::colors; a shape of the default material whose vertices have
// colours gets diffuse 1 times them (kVertexColor), an MTL material keeps its own colour.
static bool same(RGB a, RGB b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

TEST(ObjLoader, VertexColours) {
  auto srgb = [](float r, float g, float b) { return RGB(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b)); };
  auto near = [](RGB a, RGB b) { return std::abs(a.x - b.x) + std::abs(a.y - b.y) + std::abs(a.z - b.z) < 1e-6f; };
  {
    // (vt with three numbers beside them: u v w, not colours.)
    std::string p = write("vc.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 0.5 0\nv 1 1 0 0 0 0.25\nv 0 1 0 1 1 1\nvt 0.5 0.5 0\n"
                                    "f 1/1 2/1 3/1 4/1\n");
    SceneDesc d = load_obj(p);
    ASSERT_EQ(d.meshes.size(), 1u);
    const MeshDesc& m = d.meshes[0];
    ASSERT_EQ(m.colors.size(), m.positions.size());
    const RGB want[4] = {srgb(1, 0, 0), srgb(0, 0.5f, 0), srgb(0, 0, 0.25f), RGB(1.f)};
    for (size_t i = 0; i < m.positions.size(); ++i) {
      const Vec3f q = m.positions[i];
      const int k = q.x == 0.f ? (q.y == 0.f ? 0 : 3) : (q.y == 0.f ? 1 : 2);
      EXPECT_TRUE(near(m.colors[i], want[k])) << i;
    }
    EXPECT_NEAR(m.colors[0].y + m.colors[1].y + m.colors[2].y + m.colors[3].y, 1.f + 0.21404114f, 1e-5f);
    const Material& mat = d.materials[size_t(d.shapes[0].material)];
    EXPECT_EQ(d.material_names[size_t(d.shapes[0].material)], "vc/default+colors");
    EXPECT_EQ(d.materials.size(), 1u);  // no unused grey default beside it
    EXPECT_EQ(mat.type, MaterialType::kDiffuse);
    EXPECT_TRUE(mat.flags & kVertexColor);
    EXPECT_TRUE(same(mat.diffuse, RGB(1.f)));
    EXPECT_TRUE(d.warnings.empty()) << d.warnings[0];
  }
  {  // x y z w is not a colour; a file without colours keeps the grey default and no colour array
    SceneDesc d = load_obj(write("vw.obj", "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n"));
    EXPECT_TRUE(d.meshes[0].colors.empty());
    EXPECT_FALSE(d.materials[size_t(d.shapes[0].material)].flags & kVertexColor);
    EXPECT_TRUE(same(d.materials[size_t(d.shapes[0].material)].diffuse, RGB(0.5f)));
  }
  {  // #MRGB runs colour the vertices before them, in order; a run may span lines; bad and missing colours
    std::string p = write("mrgb.obj",
                          "v 0 0 0\nv 1 0 0\nv 0 1 0\n#MRGB ff0000ff\n#MRGB ff00ff00\n"
                          "v 5 5 5 -1 0 0\nv 6 5 5 nan 1 1\nv 5 6 5\n#MRGB ff00ffff00ff000000ff0000 00ff0000\n"
                          "# a comment\nf 1 2 3\nf 4 5 6\n");
    SceneDesc d = load_obj(p);
    ASSERT_EQ(d.meshes.size(), 1u);
    const MeshDesc& m = d.meshes[0];
    ASSERT_EQ(m.colors.size(), 6u);
    EXPECT_TRUE(same(m.colors[0], RGB(1.f)));          // no colour: white
    EXPECT_TRUE(same(m.colors[1], RGB(0.f, 0.f, 1.f)));
    // The second run gives 4 colours after 6 vertices: vertices 3..6 (1-based), so vertex 3 turns from green to
    // cyan and the bad `v` colours of 4 and 5 are replaced by the run's red (the last word wins).
    EXPECT_TRUE(same(m.colors[2], RGB(0.f, 1.f, 1.f)));
    EXPECT_TRUE(same(m.colors[3], RGB(1.f, 0.f, 0.f)));
    EXPECT_TRUE(same(m.colors[4], RGB(1.f, 0.f, 0.f)));
    EXPECT_TRUE(same(m.colors[5], RGB(1.f, 0.f, 0.f)));
    EXPECT_EQ(d.warnings, (std::vector<std::string>{p + ": 1 vertex has no colour (5 vertices have one); white there"}));
  }
  {  // negative and non-finite colours become white (counted); an #MRGB run longer than the vertices before it
    std::string p = write("vbad.obj", "#MRGB ff0000ffff0000ff\nv 0 0 0 -1 0 0\nv 1 0 0 nan 1 1\nv 0 1 0 0 0 0\nf 1 2 3\n");
    SceneDesc d = load_obj(p);
    const MeshDesc& m = d.meshes[0];
    EXPECT_TRUE(same(m.colors[0], RGB(1.f)));
    EXPECT_TRUE(same(m.colors[1], RGB(1.f)));
    EXPECT_TRUE(same(m.colors[2], RGB(0.f)));
    EXPECT_EQ(d.warnings,
              (std::vector<std::string>{p + ": 2 negative or non-finite vertex colours made white",
                                        p + ": line 1: #MRGB gives colours for more vertices than precede it; the "
                                            "extra colours are ignored"}));
  }
  {  // an MTL material keeps its colour (the mesh keeps the colours, for JSON/XML materials that ask); a group
     // whose vertices have no colour gets the grey default and no colour array
    write("vcm.mtl", "newmtl red\nKd 0.8 0.1 0.1\n");
    std::string p = write("vcm.obj",
                          "mtllib vcm.mtl\nv 0 0 0 0 1 0\nv 1 0 0 0 1 0\nv 0 1 0 0 1 0\nv 5 0 0\nv 6 0 0\nv 5 1 0\n"
                          "g b\nf 4 5 6\ng a\nusemtl red\nf 1 2 3\n");
    SceneDesc d = load_obj(p);
    ASSERT_EQ(d.shapes.size(), 2u);
    const Material& red = d.materials[size_t(d.shapes[1].material)];
    EXPECT_FALSE(red.flags & kVertexColor);
    EXPECT_TRUE(same(red.diffuse, RGB(0.8f, 0.1f, 0.1f)));
    EXPECT_EQ(d.meshes[1].colors.size(), 3u);
    EXPECT_TRUE(d.meshes[0].colors.empty());
    EXPECT_EQ(d.material_names[size_t(d.shapes[0].material)], "vcm/default");
  }
  // Broken #MRGB lines are errors naming the line.
  for (const char* text : {"v 0 0 0\n#MRGB ff00ff\n", "v 0 0 0\n#MRGB ff00ff0g\n", "v 0 0 0\n#MRGB -f00ff00\n"}) {
    std::string p = write("mrgb_bad.obj", std::string(text) + "v 1 0 0\nv 0 1 0\nf 1 2 3\n");
    try {
      load_obj(p);
      ADD_FAILURE() << text;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(p + ": line 2: expected colours of 8 hexadecimal digits (MMRRGGBB) after "
                                                "'#MRGB', got '",
                                            0),
                0u)
          << e.what();
    }
  }
}

// A PLY file alone: the default material shows its vertex colours (diffuse 1 times them) and stays grey without.
TEST(PlyLoader, AloneItsVertexColoursShow) {
  std::string p = write("alone.ply",
                        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                        "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
                        "property list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n"
                        "0 1 0 0 0 255\n3 0 1 2\n");
  SceneDesc d = load_scene_desc(p);
  const Material& m = d.materials[size_t(d.shapes[0].material)];
  EXPECT_TRUE(m.flags & kVertexColor);
  EXPECT_TRUE(same(m.diffuse, RGB(1.f)));
  std::string q = write("alone_plain.ply",
                        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                        "3 0 1 2\n");
  SceneDesc e = load_scene_desc(q);
  EXPECT_FALSE(e.materials[size_t(e.shapes[0].material)].flags & kVertexColor);
  EXPECT_TRUE(same(e.materials[size_t(e.shapes[0].material)].diffuse, RGB(0.5f)));
}

// PLY face colours (MeshLab's; Mitsuba's face_color): with no vertex colours, each face takes its colour (8-bit:
// sRGB, decoded; float: linear), vertices are copied only where faces of different colours meet, and normals are
// those of the shared vertices; with vertex colours, the face colours are ignored (a warning).
TEST(PlyLoader, FaceColours) {
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 3\nproperty list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0.5\n";
  // A quad (two triangles) of one colour, and a red triangle sharing the edge (1, 2) with it.
  std::string p = write("fc.ply", head + "3 0 1 2 0 0 255\n3 0 2 3 0 0 255\n3 1 4 2 255 0 0\n");
  bool face_colors = false;
  std::vector<std::string> w;
  MeshDesc m = load_ply_mesh(p, &w, &face_colors);
  EXPECT_TRUE(face_colors);
  EXPECT_TRUE(w.empty());
  ASSERT_EQ(m.indices.size(), 9u);
  ASSERT_EQ(m.positions.size(), 7u);  // 5 + copies of vertices 1 and 2 for the red face
  ASSERT_EQ(m.colors.size(), 7u);
  ASSERT_EQ(m.normals.size(), 7u);
  MeshDesc plain = load_ply_mesh(write("fc_plain.ply", "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\n"
                                                       "property float y\nproperty float z\nelement face 3\nproperty "
                                                       "list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 "
                                                       "1 0\n0 1 0\n2 0 0.5\n3 0 1 2\n3 0 2 3\n3 1 4 2\n"));
  for (size_t t = 0; t < 3; ++t)
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t v = m.indices[3 * t + k], o = plain.indices[3 * t + k];
      EXPECT_TRUE(same(m.positions[v], plain.positions[o]));
      EXPECT_TRUE(same(m.normals[v], plain.normals[o])) << "the smooth normals of the unsplit mesh";
      EXPECT_TRUE(same(m.colors[v], t < 2 ? RGB(0.f, 0.f, 1.f) : RGB(1.f, 0.f, 0.f))) << t << " " << k;
    }
  // Float face colours are linear; bad ones become white (counted).
  std::string f = head;
  for (const char* ty : {"red", "green", "blue"})
    f.replace(f.find(std::string("property uchar ") + ty), 14, "property float");
  std::string q = write("fcf.ply", f + "3 0 1 2 0.25 0.5 1\n3 0 2 3 -1 0 0\n3 1 4 2 nan 0 0\n");
  w.clear();
  m = load_ply_mesh(q, &w, &face_colors);
  EXPECT_TRUE(same(m.colors[m.indices[0]], RGB(0.25f, 0.5f, 1.f)));
  EXPECT_TRUE(same(m.colors[m.indices[3]], RGB(1.f)));
  EXPECT_TRUE(same(m.colors[m.indices[6]], RGB(1.f)));
  EXPECT_EQ(w, (std::vector<std::string>{q + ": made 2 negative or non-finite face colours white"}));
  // Vertex colours win.
  std::string both = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
                     "property list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n"
                     "property uchar blue\nend_header\n0 0 0 255 255 255\n1 0 0 255 255 255\n0 1 0 255 255 255\n"
                     "3 0 1 2 255 0 0\n";
  std::string b = write("fcv.ply", both);
  w.clear();
  m = load_ply_mesh(b, &w, &face_colors);
  EXPECT_FALSE(face_colors);
  EXPECT_EQ(m.positions.size(), 3u);
  EXPECT_TRUE(same(m.colors[0], RGB(1.f)));
  EXPECT_EQ(w, (std::vector<std::string>{b + ": face colours ignored: the vertices have colours, which are used"}));
  // Binary files read them too (the face records are no longer the index list alone).
  std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nproperty uchar red\n"
                    "property uchar green\nproperty uchar blue\nend_header\n";
  const float P[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  bin.append(reinterpret_cast<const char*>(P), sizeof P);
  const int32_t I[3] = {0, 1, 2};
  bin.push_back(char(3));
  bin.append(reinterpret_cast<const char*>(I), sizeof I);
  bin += std::string("\xff\x80\x00", 3);
  m = load_ply_mesh(write("fcb.ply", bin), &w, &face_colors);
  EXPECT_TRUE(face_colors);
  EXPECT_TRUE(same(m.colors[0], RGB(1.f, srgb_to_linear(128.f / 255.f), 0.f)));
}
