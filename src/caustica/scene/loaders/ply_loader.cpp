// PLY reader (no library), after Greg Turk's description of the format, "The
// PLY Polygon File Format" (Stanford, 1994), as used by the Stanford 3D
// Scanning Repository, Blender, MeshLab and Mitsuba:
//
//   ply
//   format ascii 1.0 | binary_little_endian 1.0 | binary_big_endian 1.0
//   comment ... / obj_info ...
//   element <name> <count>
//   property <type> <name>
//   property list <count type> <item type> <name>
//   end_header
//
// followed by the elements' data in header order (ASCII: whitespace-separated
// numbers; binary: packed values of the given types, no padding). Scalar types:
// char uchar short ushort int uint float double, or int8 uint8 int16 uint16
// int32 uint32 float32 float64.
//
// Read: element "vertex" (x y z; nx ny nz; u v, s t or texture_u texture_v;
// red green blue) and element "face" (list "vertex_indices" or "vertex_index";
// red green blue, when the vertices have no colours); every other element and
// property is skipped. Binary data is read from one buffer holding
// the whole file.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <tuple>

#include "../../base/error.h"
#include "mesh_loaders.h"

namespace caustica {

namespace {

enum class PType : uint8_t { kI8, kU8, kI16, kU16, kI32, kU32, kF32, kF64 };
constexpr int kSize[] = {1, 1, 2, 2, 4, 4, 4, 8};

bool parse_type(const std::string& s, PType& t) {
  static const struct {
    const char* name;
    PType t;
  } names[] = {{"char", PType::kI8},    {"int8", PType::kI8},     {"uchar", PType::kU8},   {"uint8", PType::kU8},
               {"short", PType::kI16},  {"int16", PType::kI16},   {"ushort", PType::kU16}, {"uint16", PType::kU16},
               {"int", PType::kI32},    {"int32", PType::kI32},   {"uint", PType::kU32},   {"uint32", PType::kU32},
               {"float", PType::kF32},  {"float32", PType::kF32}, {"double", PType::kF64}, {"float64", PType::kF64}};
  for (const auto& n : names)
    if (s == n.name) {
      t = n.t;
      return true;
    }
  return false;
}

struct Prop {
  std::string name;
  PType type = PType::kF32;
  bool list = false;
  PType count_type = PType::kU8;
};

struct Element {
  std::string name;
  size_t count = 0;
  int line = 0;
  std::vector<Prop> props;
  int find(const char* n) const {
    for (size_t i = 0; i < props.size(); ++i)
      if (props[i].name == n) return int(i);
    return -1;
  }
};

enum class Format { kAscii, kLittle, kBig };

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw InputError(path + ": " + what); }

// Reads a binary scalar at p (bounds checked by the caller) as double.
template <bool kSwap>
inline double read_binary(const unsigned char* p, PType t) {
  auto load = [&](auto v) {
    std::memcpy(&v, p, sizeof(v));
    if constexpr (kSwap) {
      if constexpr (sizeof(v) == 2) v = decltype(v)(__builtin_bswap16(uint16_t(v)));
      if constexpr (sizeof(v) == 4) v = decltype(v)(__builtin_bswap32(uint32_t(v)));
    }
    return v;
  };
  switch (t) {
    case PType::kI8: return double(int8_t(*p));
    case PType::kU8: return double(*p);
    case PType::kI16: return double(int16_t(load(uint16_t(0))));
    case PType::kU16: return double(load(uint16_t(0)));
    case PType::kI32: return double(int32_t(load(uint32_t(0))));
    case PType::kU32: return double(load(uint32_t(0)));
    case PType::kF32: {
      uint32_t u = load(uint32_t(0));
      float f;
      std::memcpy(&f, &u, 4);
      return double(f);
    }
    case PType::kF64: {
      uint64_t u;
      std::memcpy(&u, p, 8);
      if constexpr (kSwap) u = __builtin_bswap64(u);
      double d;
      std::memcpy(&d, &u, 8);
      return d;
    }
  }
  return 0.0;
}

// The element data: a cursor over the bytes after the header.
class Reader {
 public:
  Reader(const std::string& path, const std::vector<unsigned char>& buf, size_t pos, Format fmt, int line)
      : path_(path), buf_(buf), pos_(pos), fmt_(fmt), line_(line) {}

  // One value of type t; `what` describes it for error messages ("vertex 12 (property 'y')").
  double value(PType t, const std::string& elem, size_t index, const std::string& prop) {
    if (fmt_ == Format::kAscii) return ascii_value(t, elem, index, prop);
    size_t n = size_t(kSize[int(t)]);
    if (pos_ + n > buf_.size()) truncated(elem, index);
    double v = fmt_ == Format::kLittle ? read_binary<false>(&buf_[pos_], t) : read_binary<true>(&buf_[pos_], t);
    pos_ += n;
    return v;
  }
  // Skips `n` values of type t.
  void skip(PType t, size_t n, const std::string& elem, size_t index, const std::string& prop) {
    if (fmt_ == Format::kAscii) {
      for (size_t i = 0; i < n; ++i) ascii_value(t, elem, index, prop);
      return;
    }
    size_t bytes = n * size_t(kSize[int(t)]);
    if (bytes > buf_.size() - pos_) truncated(elem, index);
    pos_ += bytes;
  }
  bool binary() const { return fmt_ != Format::kAscii; }
  bool big_endian() const { return fmt_ == Format::kBig; }
  size_t pos() const { return pos_; }
  void set_pos(size_t p) { pos_ = p; }
  const unsigned char* data() const { return buf_.data(); }
  size_t size() const { return buf_.size(); }
  [[noreturn]] void truncated(const std::string& elem, size_t index) const {
    fail(path_, "truncated binary data: " + elem + " " + std::to_string(index) + " ends past the end of the file (" +
                    std::to_string(buf_.size()) + " bytes)");
  }
  // Error prefix for the current position ("line N: " in ASCII files).
  std::string where() const { return fmt_ == Format::kAscii ? "line " + std::to_string(line_) + ": " : ""; }
  // ASCII: anything but whitespace left after the last element?
  bool ascii_trailing() {
    skip_space();
    return pos_ < buf_.size();
  }

  // ASCII: moves to the next value (counting lines).
  void skip_space() {
    if (fmt_ != Format::kAscii) return;
    while (pos_ < buf_.size()) {
      unsigned char c = buf_[pos_];
      if (c == '\n') ++line_;
      else if (c != ' ' && c != '\t' && c != '\r' && c != '\f' && c != '\v') break;
      ++pos_;
    }
  }

 private:
  double ascii_value(PType t, const std::string& elem, size_t index, const std::string& prop) {
    skip_space();
    const char* b = reinterpret_cast<const char*>(buf_.data()) + pos_;
    const char* e = b;
    const char* end = reinterpret_cast<const char*>(buf_.data()) + buf_.size();
    while (e < end && !std::isspace(static_cast<unsigned char>(*e))) ++e;
    std::string ctx = where() + elem + " " + std::to_string(index) + ": property '" + prop + "': ";
    if (b == e) fail(path_, ctx + "expected a number, got the end of the file");
    double v = 0.0;
    bool ok;
    if (t == PType::kF32 || t == PType::kF64) {
      const char* s = b + (*b == '+');
      auto r = std::from_chars(s, e, v);
      ok = r.ec == std::errc() && r.ptr == e;
    } else {
      int64_t i = 0;
      const char* s = b + (*b == '+');
      auto r = std::from_chars(s, e, i);
      ok = r.ec == std::errc() && r.ptr == e;
      v = double(i);
    }
    if (!ok)
      fail(path_, ctx + "expected " + (t == PType::kF32 || t == PType::kF64 ? "a number" : "an integer") + ", got '" +
                      std::string(b, std::min<size_t>(size_t(e - b), 40)) + "'");
    pos_ += size_t(e - b);
    return v;
  }

  const std::string& path_;
  const std::vector<unsigned char>& buf_;
  size_t pos_;
  Format fmt_;
  int line_;
};

std::vector<unsigned char> read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) fail(path, "cannot open the file");
  std::streamoff n = f.tellg();
  if (n < 0) fail(path, "cannot read the file");
  std::vector<unsigned char> buf(static_cast<size_t>(n));
  f.seekg(0);
  if (n > 0 && !f.read(reinterpret_cast<char*>(buf.data()), n)) fail(path, "cannot read the file");
  return buf;
}

std::vector<std::string> split_words(const std::string& s) {
  std::vector<std::string> w;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    size_t j = i;
    while (j < s.size() && s[j] != ' ' && s[j] != '\t') ++j;
    if (j > i) w.push_back(s.substr(i, j - i));
    i = j;
  }
  return w;
}

std::string plural(size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

}  // namespace

bool angle_weighted_terms(Vec3f p0, Vec3f p1, Vec3f p2, Vec3f w[3]) {
  const Vec3f c = cross(p1 - p0, p2 - p0);
  const float l = length(c);
  if (!(l > 0.f) || !std::isfinite(l)) return false;
  const Vec3f n = c / l;
  const Vec3f p[3] = {p0, p1, p2};
  for (int k = 0; k < 3; ++k) {
    const Vec3f e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
    // The corner's angle, atan2(|e1 x e2|, e1 . e2): accurate for thin triangles, where acos is not.
    w[k] = n * std::atan2(length(cross(e1, e2)), dot(e1, e2));
  }
  return true;
}

std::vector<Vec3f> angle_weighted_normals(const std::vector<Vec3f>& p, const std::vector<uint32_t>& idx) {
  std::vector<Vec3f> n(p.size(), Vec3f(0.f));
  for (size_t t = 0; t + 2 < idx.size(); t += 3) {
    Vec3f w[3];
    if (!angle_weighted_terms(p[idx[t]], p[idx[t + 1]], p[idx[t + 2]], w)) continue;
    for (int k = 0; k < 3; ++k) n[idx[t + k]] += w[k];
  }
  for (Vec3f& v : n) {
    float l = length(v);
    v = l > 0.f && std::isfinite(l) ? v / l : Vec3f(0.f, 0.f, 1.f);
  }
  return n;
}

// Per-face colours as vertex colours, constant over each face: a vertex keeps its index for the first colour a
// triangle gives it and is copied (position, normal, UV) for each other colour, so faces of one colour still share
// their vertices and only the borders between colours are split.
static void face_colors_to_vertices(MeshDesc& m, const std::vector<RGB>& tri_colors) {
  const size_t nv = m.positions.size();
  m.colors.assign(nv, RGB(1.f));
  std::vector<uint8_t> taken(nv, 0);
  std::map<std::tuple<uint32_t, float, float, float>, uint32_t> copies;
  for (size_t t = 0; t < tri_colors.size(); ++t) {
    const RGB c = tri_colors[t];
    for (size_t k = 0; k < 3; ++k) {
      uint32_t& v = m.indices[3 * t + k];
      if (!taken[v]) {
        taken[v] = 1, m.colors[v] = c;
        continue;
      }
      const RGB o = m.colors[v];
      if (o.x == c.x && o.y == c.y && o.z == c.z) continue;
      auto [it, fresh] = copies.try_emplace({v, c.x, c.y, c.z}, uint32_t(m.positions.size()));
      if (fresh) {
        m.positions.push_back(m.positions[v]);
        if (!m.normals.empty()) m.normals.push_back(m.normals[v]);
        if (!m.uvs.empty()) m.uvs.push_back(m.uvs[v]);
        m.colors.push_back(c);
      }
      v = it->second;
    }
  }
}

void finish_mesh_attributes(MeshDesc& m, bool has_normals, MeshRepairs& r) {
  if (has_normals) {
    std::vector<Vec3f> computed;
    for (size_t i = 0; i < m.normals.size(); ++i) {
      Vec3f n = m.normals[i];
      float l = length(n);
      if (l > 0.f && std::isfinite(l)) {
        m.normals[i] = n / l;
      } else {
        if (computed.empty()) computed = angle_weighted_normals(m.positions, m.indices);
        m.normals[i] = computed[i];
        ++r.normals;
      }
    }
  } else {
    m.normals = angle_weighted_normals(m.positions, m.indices);
  }
  for (Vec2f& t : m.uvs)
    if (!std::isfinite(t.x) || !std::isfinite(t.y)) t = Vec2f(0.f, 0.f);
  for (RGB& c : m.colors)
    if (!usable_color(c)) c = RGB(1.f), ++r.colors;
}

void report_mesh_repairs(const std::string& path, const MeshRepairs& r, std::vector<std::string>& warnings) {
  if (r.degenerate)
    warnings.push_back(path + ": skipped " + plural(r.degenerate, "degenerate triangle", "degenerate triangles"));
  if (r.nan)
    warnings.push_back(path + ": skipped " + plural(r.nan, "triangle", "triangles") +
                       " with non-finite (NaN or infinite) vertex coordinates (" +
                       plural(r.bad_vertices, "such vertex", "such vertices") + ")");
  if (r.normals)
    warnings.push_back(path + ": replaced " + plural(r.normals, "zero or non-finite normal", "zero or non-finite normals") +
                       " by computed ones");
  if (r.colors)
    warnings.push_back(path + ": made " + plural(r.colors, "negative or non-finite vertex colour", "negative or non-finite vertex colours") +
                       " white");
}

MeshDesc load_ply_mesh(const std::string& path) { return load_ply_mesh(path, nullptr); }

MeshDesc load_ply_mesh(const std::string& path, std::vector<std::string>* warnings, bool* face_colors) {
  const std::vector<unsigned char> buf = read_file(path);

  // ---- header ----
  size_t pos = 0;
  int line_no = 0;
  auto next_line = [&](std::string& out) -> bool {
    if (pos >= buf.size()) return false;
    size_t e = pos;
    while (e < buf.size() && buf[e] != '\n') ++e;
    out.assign(reinterpret_cast<const char*>(buf.data()) + pos, e - pos);
    if (!out.empty() && out.back() == '\r') out.pop_back();
    pos = e < buf.size() ? e + 1 : e;
    ++line_no;
    return true;
  };
  auto header_fail = [&](const std::string& what) -> void {
    fail(path, "line " + std::to_string(line_no) + " (header): " + what);
  };
  std::string line;
  if (!next_line(line) || line != "ply") {
    line_no = 1;
    header_fail("expected 'ply' (the file does not start like a PLY file)");
  }
  Format fmt = Format::kAscii;
  bool have_format = false, have_end = false;
  std::vector<Element> elems;
  while (next_line(line)) {
    std::vector<std::string> w = split_words(line);
    if (w.empty()) continue;
    const std::string& kw = w[0];
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "end_header") {
      have_end = true;
      break;
    }
    if (kw == "format") {
      if (w.size() != 3) header_fail("expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      if (w[1] == "ascii") fmt = Format::kAscii;
      else if (w[1] == "binary_little_endian") fmt = Format::kLittle;
      else if (w[1] == "binary_big_endian") fmt = Format::kBig;
      else header_fail("unknown format '" + w[1] + "' (expected ascii, binary_little_endian or binary_big_endian)");
      if (w[2] != "1.0" && w[2] != "1") header_fail("unsupported PLY version '" + w[2] + "' (expected 1.0)");
      have_format = true;
    } else if (kw == "element") {
      if (!have_format) header_fail("expected the 'format' line before the first element");
      if (w.size() != 3) header_fail("expected 'element <name> <count>'");
      Element e;
      e.name = w[1];
      e.line = line_no;
      unsigned long long c = 0;
      auto r = std::from_chars(w[2].data(), w[2].data() + w[2].size(), c);
      if (r.ec != std::errc() || r.ptr != w[2].data() + w[2].size())
        header_fail("element '" + w[1] + "': expected a non-negative integer count, got '" + w[2] + "'");
      e.count = size_t(c);
      elems.push_back(e);
    } else if (kw == "property") {
      if (elems.empty()) header_fail("'property' before any 'element'");
      Prop p;
      const char* types = " (expected char, uchar, short, ushort, int, uint, float, double or int8 ... float64)";
      if (w.size() >= 2 && w[1] == "list") {
        if (w.size() != 5) header_fail("expected 'property list <count type> <item type> <name>'");
        p.list = true;
        if (!parse_type(w[2], p.count_type)) header_fail("unknown list count type '" + w[2] + "'" + types);
        if (p.count_type == PType::kF32 || p.count_type == PType::kF64)
          header_fail("list count type '" + w[2] + "' must be an integer type");
        if (!parse_type(w[3], p.type)) header_fail("unknown list item type '" + w[3] + "'" + types);
        p.name = w[4];
      } else {
        if (w.size() != 3) header_fail("expected 'property <type> <name>'");
        if (!parse_type(w[1], p.type)) header_fail("unknown property type '" + w[1] + "'" + types);
        p.name = w[2];
      }
      elems.back().props.push_back(p);
    } else {
      header_fail("unknown header keyword '" + kw +
                  "' (expected format, element, property, comment, obj_info or end_header)");
    }
  }
  if (!have_end) {
    ++line_no;
    header_fail("expected 'end_header' before the end of the file");
  }
  if (!have_format) header_fail("expected a 'format' line in the header");

  // ---- which properties we read ----
  const Element* vert = nullptr;
  const Element* face = nullptr;
  for (const Element& e : elems) {
    if (e.name == "vertex" && !vert) vert = &e;
    if (e.name == "face" && !face) face = &e;
  }
  auto fail_at = [&](int ln, const std::string& what) { fail(path, "line " + std::to_string(ln) + " (header): " + what); };
  if (!vert) fail_at(line_no, "no 'vertex' element");
  if (!face) fail_at(line_no, "no 'face' element (point clouds are not supported)");
  int px = vert->find("x"), py = vert->find("y"), pz = vert->find("z");
  for (auto [i, n] : {std::pair{px, "x"}, std::pair{py, "y"}, std::pair{pz, "z"}}) {
    if (i < 0) fail_at(vert->line, std::string("element 'vertex' has no property '") + n + "'");
    if (vert->props[i].list) fail_at(vert->line, std::string("vertex property '") + n + "' must not be a list");
  }
  int pn[3] = {vert->find("nx"), vert->find("ny"), vert->find("nz")};
  bool has_n = pn[0] >= 0 && pn[1] >= 0 && pn[2] >= 0;
  int puv[2] = {-1, -1};
  for (auto [u, v] : {std::pair{"u", "v"}, std::pair{"s", "t"}, std::pair{"texture_u", "texture_v"},
                      std::pair{"texture_s", "texture_t"}}) {
    if (puv[0] < 0 && vert->find(u) >= 0 && vert->find(v) >= 0) {
      puv[0] = vert->find(u);
      puv[1] = vert->find(v);
    }
  }
  bool has_uv = puv[0] >= 0;
  // Vertex colours: red green blue (or r g b, diffuse_red ...); integer ones are 8- or 16-bit sRGB (as MeshLab and
  // Blender write them), float ones linear.
  // Face colours, under the same names (MeshLab writes them; Mitsuba 3 calls them the attribute face_color), are
  // read when the vertices have none: each face is that colour (see below).
  auto find_color = [](const Element* e, int pc[3]) {
    pc[0] = pc[1] = pc[2] = -1;
    for (auto names : {std::array<const char*, 3>{"red", "green", "blue"}, std::array<const char*, 3>{"r", "g", "b"},
                       std::array<const char*, 3>{"diffuse_red", "diffuse_green", "diffuse_blue"}})
      if (pc[0] < 0 && e->find(names[0]) >= 0 && e->find(names[1]) >= 0 && e->find(names[2]) >= 0)
        for (int k = 0; k < 3; ++k) pc[k] = e->find(names[k]);
    return pc[0] >= 0;
  };
  int pc[3], pfc[3];
  const bool has_c = find_color(vert, pc);
  const bool file_has_fc = find_color(face, pfc), has_fc = file_has_fc && !has_c;
  for (int i : {pn[0], pn[1], pn[2], puv[0], puv[1], pc[0], pc[1], pc[2]})
    if (i >= 0 && vert->props[i].list) fail_at(vert->line, "vertex property '" + vert->props[i].name + "' must not be a list");
  if (has_fc)
    for (int i : pfc)
      if (face->props[i].list) fail_at(face->line, "face property '" + face->props[i].name + "' must not be a list");
  int pidx = face->find("vertex_indices");
  if (pidx < 0) pidx = face->find("vertex_index");
  if (pidx < 0) fail_at(face->line, "element 'face' has no list property 'vertex_indices' (or 'vertex_index')");
  if (!face->props[pidx].list) fail_at(face->line, "face property '" + face->props[pidx].name + "' must be a list");
  if (face->props[pidx].type == PType::kF32 || face->props[pidx].type == PType::kF64)
    fail_at(face->line, "face property '" + face->props[pidx].name + "' must have an integer item type");
  if (vert->count > size_t(UINT32_MAX) - 1) fail_at(vert->line, "too many vertices (at most 2^32 - 2)");

  // ---- data ----
  MeshDesc m;
  m.name = path;
  Reader rd(path, buf, pos, fmt, line_no + 1);
  std::vector<float> pflat;  // per-vertex values of interest, by property slot
  std::vector<uint8_t> bad_vertex;
  size_t n_bad_vertices = 0;
  std::vector<uint32_t> poly;
  std::vector<RGB> tri_colors;  // has_fc: each triangle's face colour
  size_t skipped_small = 0, skipped_nan = 0, skipped_degenerate = 0;
  std::vector<std::string> ignored;

  for (const Element& e : elems) {
    // A header count the rest of the file cannot hold is an error before anything
    // is allocated for it: each record takes at least its scalars' sizes and its
    // lists' length fields (binary), or one character and a separator per value (ASCII).
    {
      size_t min_bytes = 0;
      for (const Prop& p : e.props) min_bytes += rd.binary() ? size_t(kSize[int(p.list ? p.count_type : p.type)]) : 2;
      // (Small shortfalls are left to the record reader, whose messages say which
      // record ends where; this guard only stops absurd counts from allocating.)
      size_t remaining = rd.size() - rd.pos();
      if (min_bytes > 0 && e.count > 2 * ((remaining + 1) / min_bytes) + 64)
        fail_at(e.line, "element '" + e.name + "' declares " + std::to_string(e.count) +
                            " records, but the file has room for at most " + std::to_string((remaining + 1) / min_bytes));
    }
    if (&e == vert) {
      m.positions.resize(e.count);
      if (has_n) m.normals.resize(e.count);
      if (has_uv) m.uvs.resize(e.count);
      if (has_c) m.colors.resize(e.count);
      bad_vertex.assign(e.count, 0);
      // slot of each property: 0..2 xyz, 3..5 normal, 6..7 uv, 8..10 colour, -1 skipped
      std::vector<int> slot(e.props.size(), -1);
      slot[px] = 0, slot[py] = 1, slot[pz] = 2;
      if (has_n) slot[pn[0]] = 3, slot[pn[1]] = 4, slot[pn[2]] = 5;
      if (has_uv) slot[puv[0]] = 6, slot[puv[1]] = 7;
      if (has_c) slot[pc[0]] = 8, slot[pc[1]] = 9, slot[pc[2]] = 10;
      bool all_scalar = std::none_of(e.props.begin(), e.props.end(), [](const Prop& p) { return p.list; });
      if (rd.binary() && all_scalar) {
        // Fixed stride: one bounds check, then straight reads.
        std::vector<size_t> off(e.props.size());
        size_t stride = 0;
        for (size_t k = 0; k < e.props.size(); ++k) off[k] = stride, stride += size_t(kSize[int(e.props[k].type)]);
        size_t avail = (rd.size() - rd.pos()) / std::max<size_t>(stride, 1);
        if (avail < e.count) rd.truncated("vertex", avail);
        const unsigned char* base = rd.data() + rd.pos();
        bool swap = rd.big_endian();
        for (size_t i = 0; i < e.count; ++i) {
          float v[11] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
          const unsigned char* row = base + i * stride;
          for (size_t k = 0; k < e.props.size(); ++k)
            if (slot[k] >= 0)
              v[slot[k]] = float(swap ? read_binary<true>(row + off[k], e.props[k].type)
                                      : read_binary<false>(row + off[k], e.props[k].type));
          m.positions[i] = Vec3f(v[0], v[1], v[2]);
          if (has_n) m.normals[i] = Vec3f(v[3], v[4], v[5]);
          if (has_uv) m.uvs[i] = Vec2f(v[6], v[7]);
          if (has_c) m.colors[i] = RGB(v[8], v[9], v[10]);
        }
        rd.set_pos(rd.pos() + e.count * stride);
      } else {
        for (size_t i = 0; i < e.count; ++i) {
          float v[11] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
          for (size_t k = 0; k < e.props.size(); ++k) {
            const Prop& p = e.props[k];
            if (p.list) {
              double c = rd.value(p.count_type, "vertex", i, p.name);
              if (c < 0) fail(path, rd.where() + "vertex " + std::to_string(i) + ": negative list length");
              rd.skip(p.type, size_t(c), "vertex", i, p.name);
            } else {
              double x = rd.value(p.type, "vertex", i, p.name);
              if (slot[k] >= 0) v[slot[k]] = float(x);
            }
          }
          m.positions[i] = Vec3f(v[0], v[1], v[2]);
          if (has_n) m.normals[i] = Vec3f(v[3], v[4], v[5]);
          if (has_uv) m.uvs[i] = Vec2f(v[6], v[7]);
          if (has_c) m.colors[i] = RGB(v[8], v[9], v[10]);
        }
      }
      for (size_t i = 0; i < e.count; ++i) {
        Vec3f q = m.positions[i];
        if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) bad_vertex[i] = 1, ++n_bad_vertices;
      }
    } else if (&e == face) {
      m.indices.reserve(e.count * 3);
      const size_t nv = m.positions.size();
      const Prop& ip = e.props[pidx];
      const bool fast = rd.binary() && e.props.size() == 1;  // the common layout: the index list alone
      std::vector<int> fslot(e.props.size(), -1);               // has_fc: 0..2 the colour's channels
      if (has_fc) fslot[size_t(pfc[0])] = 0, fslot[size_t(pfc[1])] = 1, fslot[size_t(pfc[2])] = 2;
      RGB fcol(1.f);
      const bool swap = rd.big_endian();
      const int csize = kSize[int(ip.count_type)], isize = kSize[int(ip.type)];
      for (size_t i = 0; i < e.count; ++i) {
        poly.clear();
        if (fast) {
          size_t p0 = rd.pos();
          if (p0 + size_t(csize) > rd.size()) rd.truncated("face", i);
          const unsigned char* d = rd.data() + p0;
          double cd = swap ? read_binary<true>(d, ip.count_type) : read_binary<false>(d, ip.count_type);
          if (cd < 0) fail(path, "face " + std::to_string(i) + ": negative vertex count");
          size_t c = size_t(cd);
          if (c * size_t(isize) > rd.size() - p0 - size_t(csize)) rd.truncated("face", i);
          d += csize;
          for (size_t k = 0; k < c; ++k, d += isize) {
            double x = swap ? read_binary<true>(d, ip.type) : read_binary<false>(d, ip.type);
            if (x < 0 || x >= double(nv))
              fail(path, "face " + std::to_string(i) + ": vertex index " + std::to_string(int64_t(x)) +
                             " out of range (" + std::to_string(nv) + " vertices)");
            poly.push_back(uint32_t(x));
          }
          rd.set_pos(p0 + size_t(csize) + c * size_t(isize));
        } else {
          for (size_t k = 0; k < e.props.size(); ++k) {
            const Prop& p = e.props[k];
            if (!p.list) {
              if (fslot[k] >= 0) fcol[fslot[k]] = float(rd.value(p.type, "face", i, p.name));
              else rd.skip(p.type, 1, "face", i, p.name);
              continue;
            }
            rd.skip_space();
            std::string where = rd.where();
            double cd = rd.value(p.count_type, "face", i, p.name);
            if (cd < 0) fail(path, where + "face " + std::to_string(i) + ": negative list length");
            size_t c = size_t(cd);
            if (int(k) != pidx) {
              rd.skip(p.type, c, "face", i, p.name);
              continue;
            }
            for (size_t j = 0; j < c; ++j) {
              double x = rd.value(p.type, "face", i, p.name);
              if (x < 0 || x >= double(nv))
                fail(path, where + "face " + std::to_string(i) + ": vertex index " + std::to_string(int64_t(x)) +
                               " out of range (" + std::to_string(nv) + " vertices)");
              poly.push_back(uint32_t(x));
            }
          }
        }
        size_t c = poly.size();
        if (c < 3) {
          ++skipped_small;
          continue;
        }
        auto emit = [&](uint32_t a, uint32_t b, uint32_t d) {
          if (n_bad_vertices && (bad_vertex[a] || bad_vertex[b] || bad_vertex[d])) {
            ++skipped_nan;
            return;
          }
          Vec3f w = cross(m.positions[b] - m.positions[a], m.positions[d] - m.positions[a]);
          if (a == b || b == d || a == d || !(length_sq(w) > 0.f)) {
            ++skipped_degenerate;
            return;
          }
          m.indices.push_back(a);
          m.indices.push_back(b);
          m.indices.push_back(d);
          if (has_fc) tri_colors.push_back(fcol);
        };
        if (c == 3) {
          emit(poly[0], poly[1], poly[2]);
        } else if (c == 4) {
          // Split along the shorter diagonal (the better choice for a non-planar quad).
          const Vec3f *q0 = &m.positions[poly[0]], *q1 = &m.positions[poly[1]], *q2 = &m.positions[poly[2]],
                      *q3 = &m.positions[poly[3]];
          if (!(length_sq(*q2 - *q0) > length_sq(*q3 - *q1))) {
            emit(poly[0], poly[1], poly[2]);
            emit(poly[0], poly[2], poly[3]);
          } else {
            emit(poly[0], poly[1], poly[3]);
            emit(poly[1], poly[2], poly[3]);
          }
        } else {
          for (size_t k = 1; k + 1 < c; ++k) emit(poly[0], poly[k], poly[k + 1]);
        }
      }
    } else {
      ignored.push_back(e.name);
      for (size_t i = 0; i < e.count; ++i)
        for (const Prop& p : e.props) {
          if (p.list) {
            double c = rd.value(p.count_type, e.name, i, p.name);
            if (c < 0) fail(path, rd.where() + e.name + " " + std::to_string(i) + ": negative list length");
            rd.skip(p.type, size_t(c), e.name, i, p.name);
          } else {
            rd.skip(p.type, 1, e.name, i, p.name);
          }
        }
    }
  }
  if (!rd.binary() && rd.ascii_trailing())
    fail(path, rd.where() + "unexpected data after the last element (the header's counts are too small?)");

  // Integer colours: to [0, 1] by their type's largest value, then from sRGB; float colours are linear.
  auto decode = [](const Element* e, const int pc[3], std::vector<RGB>& colors) {
    for (int k = 0; k < 3; ++k) {
      const PType t = e->props[size_t(pc[k])].type;
      if (t == PType::kF32 || t == PType::kF64) continue;
      const float top = kSize[int(t)] == 1 ? 255.f : kSize[int(t)] == 2 ? 65535.f : 4294967295.f;
      for (RGB& c : colors) c[k] = srgb_to_linear(std::min(std::max(c[k] / top, 0.f), 1.f));
    }
  };
  if (has_c) decode(vert, pc, m.colors);
  MeshRepairs repairs;
  repairs.degenerate = skipped_degenerate;
  repairs.nan = skipped_nan;
  repairs.bad_vertices = n_bad_vertices;
  finish_mesh_attributes(m, has_n, repairs);  // normals from the shared vertices, before faces split them
  size_t bad_fc = 0;
  if (has_fc) {
    decode(face, pfc, tri_colors);
    for (RGB& c : tri_colors)
      if (!usable_color(c)) c = RGB(1.f), ++bad_fc;
    face_colors_to_vertices(m, tri_colors);
  }
  if (face_colors) *face_colors = has_fc;

  if (warnings) {
    report_mesh_repairs(path, repairs, *warnings);
    if (skipped_small)
      warnings->push_back(path + ": skipped " + plural(skipped_small, "face", "faces") + " with fewer than 3 vertices");
    if (bad_fc)
      warnings->push_back(path + ": made " + plural(bad_fc, "negative or non-finite face colour", "negative or non-finite face colours") +
                          " white");
    if (file_has_fc && has_c)
      warnings->push_back(path + ": face colours ignored: the vertices have colours, which are used");
    if (!ignored.empty()) {
      std::string list;
      for (const std::string& s : ignored) list += (list.empty() ? "'" : ", '") + s + "'";
      warnings->push_back(path + ": ignored element" + (ignored.size() > 1 ? "s " : " ") + list);
    }
  }
  if (m.indices.empty()) fail(path, "no valid triangles (" + std::to_string(face->count) + " faces in the file)");
  return m;
}

}  // namespace caustica
