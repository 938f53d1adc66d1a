// Load-time benchmark for mesh files: OBJ (Wavefront OBJ, text), PLY (Greg Turk's PLY, binary little endian)
// and GLB (glTF 2.0 binary container) holding the same mesh of a few million triangles.
//
// Build: cmake --build build/py --target caustica_bench_load   (after `make build`)
// Run:   ./build/py/caustica_bench_load generate DIR [triangles=3000000]   writes DIR/mesh.{obj,ply,glb}
//        ./build/py/caustica_bench_load load FILE                         loads one file, prints one JSON line
// bench/bench_load.py runs both (a fresh process per format, so that each peak RSS is that format's alone)
// and prints the Markdown rows for bench/RESULTS.md.
//
// The mesh: a torus of n x m vertices (positions, unit normals, uvs) and 2 n m triangles, written by this
// program. `load` times load_scene_desc (parsing, vertex dedup, normals, the default camera and light) and
// Scene::build (flattening into world-space arrays, the portable BVH and the Embree BVH) separately, then
// builds one more CpuAccel (Kind::kEmbree) over the built arrays to time Embree's BVH build alone. Peak memory is
// getrusage's ru_maxrss after the load and after the build.
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "caustica/backend/cpu/cpu_accel.h"
#include "caustica/base/error.h"
#include "caustica/scene/load.h"
#include "caustica/scene/scene.h"

using namespace caustica;

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

double peak_mib() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_maxrss) / 1024.0;  // kilobytes on Linux
}

struct Torus {
  std::vector<float> p, n, uv;  // 3, 3, 2 per vertex
  std::vector<uint32_t> idx;
};

// n x m vertices on a torus (R = 1, r = 0.35); the seam vertices are duplicated so uvs run 0..1.
Torus make_torus(size_t target_triangles) {
  size_t m = size_t(std::sqrt(double(target_triangles) / 2.0 / 3.0));
  size_t n = 3 * m;
  Torus t;
  const double R = 1.0, r = 0.35, pi = 3.14159265358979323846;
  for (size_t j = 0; j <= m; ++j)
    for (size_t i = 0; i <= n; ++i) {
      double u = double(i) / n, v = double(j) / m;
      double a = 2 * pi * u, b = 2 * pi * v;
      double cx = std::cos(a), sx = std::sin(a), cb = std::cos(b), sb = std::sin(b);
      t.p.insert(t.p.end(), {float((R + r * cb) * cx), float((R + r * cb) * sx), float(r * sb)});
      t.n.insert(t.n.end(), {float(cb * cx), float(cb * sx), float(sb)});
      t.uv.insert(t.uv.end(), {float(u), float(v)});
    }
  for (size_t j = 0; j < m; ++j)
    for (size_t i = 0; i < n; ++i) {
      uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1) + 1, d = a + uint32_t(n + 1);
      t.idx.insert(t.idx.end(), {a, b, c, a, c, d});
    }
  return t;
}

void write_obj(const Torus& t, const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw InputError(path + ": cannot write");
  std::fprintf(f, "# caustica load benchmark: torus, %zu triangles\no torus\n", t.idx.size() / 3);
  size_t nv = t.p.size() / 3;
  for (size_t i = 0; i < nv; ++i) std::fprintf(f, "v %.6g %.6g %.6g\n", t.p[3 * i], t.p[3 * i + 1], t.p[3 * i + 2]);
  for (size_t i = 0; i < nv; ++i) std::fprintf(f, "vt %.6g %.6g\n", t.uv[2 * i], t.uv[2 * i + 1]);
  for (size_t i = 0; i < nv; ++i) std::fprintf(f, "vn %.6g %.6g %.6g\n", t.n[3 * i], t.n[3 * i + 1], t.n[3 * i + 2]);
  for (size_t k = 0; k < t.idx.size(); k += 3) {
    uint32_t a = t.idx[k] + 1, b = t.idx[k + 1] + 1, c = t.idx[k + 2] + 1;
    std::fprintf(f, "f %u/%u/%u %u/%u/%u %u/%u/%u\n", a, a, a, b, b, b, c, c, c);
  }
  std::fclose(f);
}

void write_ply(const Torus& t, const std::string& path) {
  std::ofstream f(path, std::ios::binary);
  size_t nv = t.p.size() / 3, nt = t.idx.size() / 3;
  f << "ply\nformat binary_little_endian 1.0\ncomment caustica load benchmark: torus\nelement vertex " << nv
    << "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
       "property float nz\nproperty float u\nproperty float v\nelement face "
    << nt << "\nproperty list uchar int vertex_indices\nend_header\n";
  std::vector<char> buf;
  buf.reserve(nv * 32);
  for (size_t i = 0; i < nv; ++i) {
    float v[8] = {t.p[3 * i], t.p[3 * i + 1], t.p[3 * i + 2], t.n[3 * i], t.n[3 * i + 1], t.n[3 * i + 2],
                  t.uv[2 * i], t.uv[2 * i + 1]};
    buf.insert(buf.end(), reinterpret_cast<char*>(v), reinterpret_cast<char*>(v) + 32);
  }
  f.write(buf.data(), std::streamsize(buf.size()));
  buf.clear();
  buf.reserve(nt * 13);
  for (size_t k = 0; k < nt; ++k) {
    buf.push_back(3);
    buf.insert(buf.end(), reinterpret_cast<const char*>(&t.idx[3 * k]), reinterpret_cast<const char*>(&t.idx[3 * k]) + 12);
  }
  f.write(buf.data(), std::streamsize(buf.size()));
}

// glTF 2.0 binary: a 12-byte header, a JSON chunk and a BIN chunk (positions, normals, uvs, indices).
void write_glb(const Torus& t, const std::string& path) {
  size_t nv = t.p.size() / 3, ni = t.idx.size();
  std::string bin;
  auto append = [&](const void* d, size_t n) {
    bin.append(static_cast<const char*>(d), n);
    while (bin.size() % 4) bin.push_back('\0');
  };
  size_t o_p = 0;
  append(t.p.data(), t.p.size() * 4);
  size_t o_n = bin.size();
  append(t.n.data(), t.n.size() * 4);
  size_t o_uv = bin.size();
  // glTF's v runs down the image: store 1 - v so the texture orientation matches OBJ/PLY.
  std::vector<float> uv = t.uv;
  for (size_t i = 1; i < uv.size(); i += 2) uv[i] = 1.f - uv[i];
  append(uv.data(), uv.size() * 4);
  size_t o_i = bin.size();
  append(t.idx.data(), ni * 4);
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], t.p[3 * i + k]), hi[k] = std::max(hi[k], t.p[3 * i + k]);
  char js[4096];
  std::snprintf(
      js, sizeof(js),
      "{\"asset\":{\"version\":\"2.0\",\"generator\":\"caustica bench_load\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
      "\"nodes\":[{\"mesh\":0,\"name\":\"torus\"}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,"
      "\"NORMAL\":1,\"TEXCOORD_0\":2},\"indices\":3,\"mode\":4}]}],"
      "\"buffers\":[{\"byteLength\":%zu}],\"bufferViews\":["
      "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,\"target\":34962},"
      "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,\"target\":34962},"
      "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,\"target\":34962},"
      "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,\"target\":34963}],\"accessors\":["
      "{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\",\"min\":[%g,%g,%g],\"max\":[%g,%g,%g]},"
      "{\"bufferView\":1,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\"},"
      "{\"bufferView\":2,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC2\"},"
      "{\"bufferView\":3,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"}]}",
      bin.size(), o_p, t.p.size() * 4, o_n, t.n.size() * 4, o_uv, uv.size() * 4, o_i, ni * 4, nv, lo[0], lo[1], lo[2],
      hi[0], hi[1], hi[2], nv, nv, ni);
  std::string json = js;
  while (json.size() % 4) json.push_back(' ');
  std::ofstream f(path, std::ios::binary);
  auto u32 = [&](uint32_t v) { f.write(reinterpret_cast<const char*>(&v), 4); };
  u32(0x46546C67u);  // "glTF"
  u32(2);
  u32(uint32_t(12 + 8 + json.size() + 8 + bin.size()));
  u32(uint32_t(json.size()));
  u32(0x4E4F534Au);  // "JSON"
  f.write(json.data(), std::streamsize(json.size()));
  u32(uint32_t(bin.size()));
  u32(0x004E4942u);  // "BIN\0"
  f.write(bin.data(), std::streamsize(bin.size()));
}

}  // namespace

int main(int argc, char** argv) {
  std::string mode = argc > 1 ? argv[1] : "";
  try {
    if (mode == "generate" && argc >= 3) {
      std::string dir = argv[2];
      size_t tris = argc > 3 ? size_t(std::atof(argv[3])) : 3000000;
      double t0 = now();
      Torus t = make_torus(tris);
      write_obj(t, dir + "/mesh.obj");
      write_ply(t, dir + "/mesh.ply");
      write_glb(t, dir + "/mesh.glb");
      std::printf("{\"vertices\": %zu, \"triangles\": %zu, \"seconds\": %.2f}\n", t.p.size() / 3, t.idx.size() / 3,
                  now() - t0);
      return 0;
    }
    if (mode == "load" && argc == 3) {
      double base = peak_mib();
      double t0 = now();
      SceneDesc d = load_scene_desc(argv[2]);
      double t_load = now() - t0;
      double rss_load = peak_mib();
      SceneStats st = scene_stats(d);
      t0 = now();
      std::shared_ptr<Scene> sc = Scene::build(d);
      double t_build = now() - t0;
      double rss_build = peak_mib();
      t0 = now();
      { CpuAccel again(sc->view(), CpuAccel::Kind::kEmbree); }
      double t_embree = now() - t0;
      std::printf(
          "{\"file\": \"%s\", \"triangles\": %zu, \"vertices\": %zu, \"load_s\": %.3f, \"build_s\": %.3f, "
          "\"embree_s\": %.3f, \"rss_start_mib\": %.0f, \"peak_after_load_mib\": %.0f, \"peak_after_build_mib\": %.0f, "
          "\"warnings\": %zu}\n",
          argv[2], st.triangles, sc->positions.size(), t_load, t_build, t_embree, base, rss_load, rss_build,
          d.warnings.size());
      return 0;
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  std::fprintf(stderr, "usage: %s generate DIR [triangles] | load FILE\n", argv[0]);
  return 2;
}
