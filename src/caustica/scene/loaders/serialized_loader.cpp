// Mitsuba's serialized mesh format, as Mitsuba's documentation of its `serialized` shape describes it (and as
// Mitsuba 3.9.1 reads it; tests/python/test_mitsuba_shapes.py writes files both renderers load):
//
//   per mesh:   uint16 0x041C, uint16 version (3 or 4), then one zlib stream holding
//                 uint32 flags        0x0001 vertex normals, 0x0002 texture coordinates, 0x0008 vertex colours,
//                                     0x0010 "face normals" (Mitsuba 3 ignores it: so does this reader),
//                                     0x1000 single precision, 0x2000 double precision
//                 name                (version 4 only) a NUL-terminated UTF-8 string
//                 uint64 vertex count, uint64 triangle count
//                 positions (3 per vertex), [normals (3)], [texture coordinates (2)], [colours (3)]
//                 indices (3 per triangle; uint32, or uint64 when there are more than 2^32 vertices)
//   at the end: the byte offset of each mesh (uint64 in version 4, uint32 in version 3), then uint32 mesh count.
//
// Everything is little-endian. Vertex colours are read past: Mitsuba 3 does not make them a mesh attribute either
// (a mesh_attribute texture over a serialized mesh renders black there; caustica's XML loader rejects it).
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "../../base/error.h"
#include "mesh_loaders.h"

namespace caustica {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw InputError(path + ": " + what); }

template <class T>
T read_le(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // the hosts caustica builds for are little-endian, as the format
  return v;
}

// Inflates one zlib stream that starts at `src` and lies within `n` bytes.
std::string inflate_stream(const std::string& path, size_t mesh, const unsigned char* src, size_t n) {
  z_stream z{};
  if (inflateInit(&z) != Z_OK) fail(path, "cannot initialise zlib");
  std::string out;
  z.next_in = const_cast<unsigned char*>(src);
  size_t left = n;
  int rc = Z_OK;
  char buf[1 << 16];
  while (rc != Z_STREAM_END) {
    if (z.avail_in == 0) {
      if (left == 0) break;
      z.avail_in = uInt(std::min<size_t>(left, 1u << 30));
      left -= z.avail_in;
    }
    z.next_out = reinterpret_cast<Bytef*>(buf);
    z.avail_out = sizeof(buf);
    rc = inflate(&z, Z_NO_FLUSH);
    if (rc != Z_OK && rc != Z_STREAM_END) {
      std::string msg = z.msg ? z.msg : "error " + std::to_string(rc);
      inflateEnd(&z);
      fail(path, "mesh " + std::to_string(mesh) + ": corrupt compressed data (zlib: " + msg + ")");
    }
    out.append(buf, sizeof(buf) - z.avail_out);
  }
  inflateEnd(&z);
  if (rc != Z_STREAM_END) fail(path, "mesh " + std::to_string(mesh) + ": the compressed data ends early (truncated file?)");
  return out;
}

}  // namespace

MeshDesc load_serialized_mesh(const std::string& path, size_t shape_index, std::vector<std::string>* warnings) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the file");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string file = ss.str();
  const auto* b = reinterpret_cast<const unsigned char*>(file.data());
  const size_t size = file.size();
  if (size < 8 || read_le<uint16_t>(b) != 0x041C)
    fail(path, "not a Mitsuba serialized mesh file (expected the identifier 0x041C at its start)");
  const uint16_t version = read_le<uint16_t>(b + 2);
  if (version != 3 && version != 4)
    fail(path, "unsupported serialized format version " + std::to_string(version) + " (supported: 3, 4)");

  // The table of offsets at the end.
  const uint32_t count = read_le<uint32_t>(b + size - 4);
  const size_t osize = version == 4 ? 8 : 4;
  if (count == 0 || size_t(count) > (size - 4) / osize)
    fail(path, "the mesh count at the end of the file (" + std::to_string(count) + ") does not fit the file (truncated?)");
  const size_t table = size - 4 - size_t(count) * osize;
  auto offset = [&](size_t i) -> uint64_t {
    return version == 4 ? read_le<uint64_t>(b + table + 8 * i) : read_le<uint32_t>(b + table + 4 * i);
  };
  if (shape_index >= count)
    fail(path, "shape_index " + std::to_string(shape_index) + " is out of range (the file holds " + std::to_string(count) +
                   (count == 1 ? " mesh)" : " meshes)"));
  const uint64_t start = offset(shape_index);
  const uint64_t end = shape_index + 1 < count ? offset(shape_index + 1) : table;
  if (start + 4 > end || end > table)
    fail(path, "mesh " + std::to_string(shape_index) + ": its offset " + std::to_string(start) + " lies outside the file");
  if (read_le<uint16_t>(b + start) != 0x041C || read_le<uint16_t>(b + start + 2) != version)
    fail(path, "mesh " + std::to_string(shape_index) + ": no mesh header at offset " + std::to_string(start));

  const std::string data = inflate_stream(path, shape_index, b + start + 4, size_t(end - start - 4));
  const auto* d = reinterpret_cast<const unsigned char*>(data.data());
  size_t pos = 0;
  auto need = [&](size_t n, const char* what) {
    if (n > data.size() - pos)
      fail(path, "mesh " + std::to_string(shape_index) + ": the data ends inside the " + what + " (truncated?)");
  };
  need(4, "flags");
  const uint32_t flags = read_le<uint32_t>(d);
  pos = 4;
  const bool has_n = flags & 0x0001, has_uv = flags & 0x0002, has_colour = flags & 0x0008;
  const bool single = flags & 0x1000, dbl = flags & 0x2000;
  if (single == dbl) fail(path, "mesh " + std::to_string(shape_index) + ": the flags give " +
                                    (single ? "both single and double precision" : "neither single nor double precision"));
  if (flags & ~uint32_t(0x0001 | 0x0002 | 0x0008 | 0x0010 | 0x1000 | 0x2000))
    fail(path, "mesh " + std::to_string(shape_index) + ": unknown flags 0x" + [&] {
      char hex[16];
      std::snprintf(hex, sizeof hex, "%x", flags);
      return std::string(hex);
    }());
  MeshDesc m;
  if (version == 4) {
    size_t z = pos;
    while (z < data.size() && d[z] != 0) ++z;
    if (z == data.size()) fail(path, "mesh " + std::to_string(shape_index) + ": the name is not terminated");
    m.name = std::string(reinterpret_cast<const char*>(d + pos), z - pos);
    pos = z + 1;
  }
  need(16, "counts");
  const uint64_t nv = read_le<uint64_t>(d + pos), nt = read_le<uint64_t>(d + pos + 8);
  pos += 16;
  const size_t fs = dbl ? 8 : 4;
  const size_t per_vertex = fs * (3 + (has_n ? 3 : 0) + (has_uv ? 2 : 0) + (has_colour ? 3 : 0));
  const size_t isize = nv > 0xFFFFFFFFull ? 8 : 4;
  // Counts the data cannot hold are errors before anything is allocated for them.
  if (nv > (data.size() - pos) / per_vertex || nt > (data.size() - pos - nv * per_vertex) / (3 * isize))
    fail(path, "mesh " + std::to_string(shape_index) + ": " + std::to_string(nv) + " vertices and " + std::to_string(nt) +
                   " triangles do not fit its " + std::to_string(data.size()) + " bytes of data");
  if (nv >= 0xFFFFFFFFull) fail(path, "mesh " + std::to_string(shape_index) + ": too many vertices (at most 2^32 - 2)");
  auto real = [&](size_t i) -> float {
    return dbl ? float(read_le<double>(d + pos + 8 * i)) : read_le<float>(d + pos + 4 * i);
  };
  auto vec3s = [&](std::vector<Vec3f>& v) {
    v.resize(nv);
    for (size_t i = 0; i < nv; ++i) v[i] = Vec3f(real(3 * i), real(3 * i + 1), real(3 * i + 2));
    pos += nv * 3 * fs;
  };
  vec3s(m.positions);
  if (has_n) vec3s(m.normals);
  if (has_uv) {
    m.uvs.resize(nv);
    for (size_t i = 0; i < nv; ++i) m.uvs[i] = Vec2f(real(2 * i), real(2 * i + 1));
    pos += nv * 2 * fs;
  }
  if (has_colour) pos += nv * 3 * fs;

  MeshRepairs r;
  std::vector<uint8_t> bad(nv, 0);
  for (size_t i = 0; i < nv; ++i) {
    Vec3f q = m.positions[i];
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) bad[i] = 1, ++r.bad_vertices;
  }
  m.indices.reserve(3 * nt);
  for (size_t t = 0; t < nt; ++t) {
    uint32_t v[3];
    for (int k = 0; k < 3; ++k) {
      uint64_t x = isize == 8 ? read_le<uint64_t>(d + pos + 8 * (3 * t + k)) : read_le<uint32_t>(d + pos + 4 * (3 * t + k));
      if (x >= nv)
        fail(path, "mesh " + std::to_string(shape_index) + ", triangle " + std::to_string(t) + ": vertex index " +
                       std::to_string(x) + " out of range (" + std::to_string(nv) + " vertices)");
      v[k] = uint32_t(x);
    }
    if (r.bad_vertices && (bad[v[0]] || bad[v[1]] || bad[v[2]])) {
      ++r.nan;
      continue;
    }
    Vec3f w = cross(m.positions[v[1]] - m.positions[v[0]], m.positions[v[2]] - m.positions[v[0]]);
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2] || !(length_sq(w) > 0.f)) {
      ++r.degenerate;
      continue;
    }
    m.indices.insert(m.indices.end(), v, v + 3);
  }
  finish_mesh_attributes(m, has_n, r);
  if (warnings) report_mesh_repairs(path, r, *warnings);
  if (m.indices.empty())
    fail(path, "mesh " + std::to_string(shape_index) + ": no valid triangles (" + std::to_string(nt) + " in the file)");
  return m;
}

}  // namespace caustica
