// Wavefront OBJ + MTL loader. The formats: "Object Files (.obj)" and "Material
// Library File (.mtl)", Appendices B1 and B7 of the Wavefront Advanced
// Visualizer manual (Alias|Wavefront, version 3.0, 1995).
//
// Parsing is done by tinyobjloader (Debian's libtinyobjloader-dev 2.0.0rc10).
// tinyobjloader is lenient (a malformed number reads as 0, an out-of-range
// index is noticed only at the end of the file, if at all), so a first pass of
// our own checks every statement and reports the first broken one with its
// file and line; it also resolves `mtllib` files (relative to the OBJ's folder),
// reads the MTL values whose defaults and one-number forms tinyobjloader does
// not follow, and notes non-finite coordinates. The mapping of MTL to caustica
// materials, normals and what is skipped are documented in docs/formats-obj-ply.md.
#include <tiny_obj_loader.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

#include "../../base/error.h"
#include "mesh_loaders.h"

namespace caustica {

namespace {

namespace fs = std::filesystem;

std::string plural(size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

bool read_text(const std::string& path, std::string& out) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) return false;
  std::streamoff n = f.tellg();
  if (n < 0) return false;
  out.resize(static_cast<size_t>(n));
  f.seekg(0);
  return n == 0 || bool(f.read(out.data(), n));
}

// Splits text into lines ("\n", "\r\n" or "\r"), calling fn(line_number, begin, end).
template <class F>
void for_each_line(const std::string& text, F&& fn) {
  const char* p = text.data();
  const char* end = p + text.size();
  int line = 0;
  while (p < end) {
    const char* e = p;
    while (e < end && *e != '\n' && *e != '\r') ++e;
    fn(++line, p, e);
    if (e < end && *e == '\r' && e + 1 < end && e[1] == '\n') ++e;
    p = e + 1;
  }
}

struct Tokens {
  std::vector<std::string_view> t;
  void split(const char* b, const char* e) {
    t.clear();
    while (b < e) {
      while (b < e && (*b == ' ' || *b == '\t')) ++b;
      const char* s = b;
      while (b < e && *b != ' ' && *b != '\t') ++b;
      if (b > s) t.emplace_back(s, size_t(b - s));
    }
  }
};

bool to_double(std::string_view s, double& v) {
  const char* b = s.data();
  const char* e = b + s.size();
  if (b < e && *b == '+') ++b;
  auto r = std::from_chars(b, e, v);
  return r.ec == std::errc() && r.ptr == e;
}
bool to_int(std::string_view s, int64_t& v) {
  const char* b = s.data();
  const char* e = b + s.size();
  if (b < e && *b == '+') ++b;
  auto r = std::from_chars(b, e, v);
  return r.ec == std::errc() && r.ptr == e;
}

// What the first pass learns about one MTL material.
struct MtlInfo {
  std::string file;  // the MTL path
  int line = 0;      // of `newmtl`
  RGB kd{0.5f}, ks{0.f}, ke{0.f}, tf{1.f};
  float ns = 10.f, ni = 1.5f, d = 1.f;
  int illum = -1;
  bool has_kd = false, has_ks = false, has_ke = false, has_tf = false, has_ni = false, has_d = false;
  int map_kd_line = 0, map_ke_line = 0, map_d_line = 0;  // lines of map_Kd / map_Ke / map_d (0: none)
  int bump_line = 0, norm_line = 0;  // lines of bump / map_Bump / map_bump and of norm (0: none)
  // The PBR extension (Exocortex's, as Blender's exporter writes it): roughness Pr, metallic Pm, clearcoat Pc
  // and its roughness Pcr, each in [0, 1]; map_Pr and map_Pm (lines, 0: none).
  float pr = 1.f, pm = 0.f, pc = 0.f, pcr = 0.f;
  bool has_pbr = false;  // any of them
  int map_pr_line = 0, map_pm_line = 0;
  bool pbr() const { return has_pbr || map_pr_line || map_pm_line; }
};

struct MtlLib {
  std::map<std::string, MtlInfo> materials;  // by name, first definition wins
  std::map<std::string, std::string> text_by_token;  // tinyobjloader's mtllib token -> MTL text
  std::vector<std::string> ignored;                  // MTL statements that have no meaning here
};

// Whether a texture holds a tangent-space normal map rather than heights: its red and green average within
// 0.25 of 0.5 (x and y of 2 rgb - 1 near 0), its blue above 0.7 (z near 1), and in nine texels of ten blue
// exceeds both other channels by 0.1. A grey height map (r = g = b) fails the last test, whatever its level.
bool looks_like_normal_map(const TextureDesc& t) {
  const size_t n = size_t(t.width) * size_t(t.height);
  if (n == 0) return false;
  double r = 0, g = 0, b = 0;
  size_t blue = 0;
  for (size_t i = 0; i < n; ++i) {
    const float* px = &t.rgba[4 * i];
    r += px[0], g += px[1], b += px[2];
    blue += px[2] >= std::max(px[0], px[1]) + 0.1f;
  }
  r /= double(n), g /= double(n), b /= double(n);
  return b > 0.7 && std::fabs(r - 0.5) < 0.25 && std::fabs(g - 0.5) < 0.25 && blue * 10 >= n * 9;
}

// map_Pr and map_Pm as the one texture the metallic-roughness material reads them from (roughness times G,
// metallic times B; material/material.h): each image's luminance (a grey map's value), 1 in the channel of a map
// not given (its factor alone). Two images of different sizes meet at the roughness map's texels (the metallic
// map's nearest texel). The result is linear, named after its images; `made` keeps one per pair.
int roughness_metallic_texture(SceneDesc& desc, int rough, int metal, std::map<std::pair<int, int>, int>& made) {
  auto hit = made.find({rough, metal});
  if (hit != made.end()) return hit->second;
  const TextureDesc& a = desc.textures[size_t(rough >= 0 ? rough : metal)];
  TextureDesc t;
  t.name = (rough >= 0 ? desc.textures[size_t(rough)].name : std::string()) + "#Pr|" +
           (metal >= 0 ? desc.textures[size_t(metal)].name : std::string()) + "#Pm";
  t.width = a.width, t.height = a.height;
  t.rgba.assign(size_t(t.width) * size_t(t.height) * 4, 1.f);
  auto lum = [](const TextureDesc& s, int x, int y) {
    const float* px = &s.rgba[4 * (size_t(y) * size_t(s.width) + size_t(x))];
    return luminance(RGB(px[0], px[1], px[2]));
  };
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) {
      float* px = &t.rgba[4 * (size_t(y) * size_t(t.width) + size_t(x))];
      px[0] = 0.f;
      if (rough >= 0) px[1] = lum(desc.textures[size_t(rough)], x, y);
      if (metal >= 0) {
        const TextureDesc& m = desc.textures[size_t(metal)];
        px[2] = lum(m, std::min(m.width - 1, x * m.width / t.width), std::min(m.height - 1, y * m.height / t.height));
      }
    }
  desc.textures.push_back(std::move(t));
  return made[{rough, metal}] = int(desc.textures.size()) - 1;
}

// Checks one MTL file and records its materials.
void scan_mtl(const std::string& path, const std::string& text, MtlLib& lib) {
  Tokens tk;
  MtlInfo* cur = nullptr;
  MtlInfo scratch;
  for_each_line(text, [&](int ln, const char* b, const char* e) {
    tk.split(b, e);
    if (tk.t.empty() || tk.t[0][0] == '#') return;
    auto fail = [&](const std::string& what) {
      throw InputError(path + ": line " + std::to_string(ln) + ": " + what);
    };
    std::string kw(tk.t[0]);
    std::string line_text(b, size_t(std::min<ptrdiff_t>(e - b, 60)));
    if (kw == "newmtl") {
      if (tk.t.size() < 2) fail("expected a material name after 'newmtl'");
      std::string name(tk.t[1].data(), size_t(e - tk.t[1].data()));
      while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.pop_back();
      auto [it, fresh] = lib.materials.emplace(name, MtlInfo{});
      cur = fresh ? &it->second : &scratch;  // a repeated name: tinyobjloader keeps the first too
      if (!fresh) scratch = MtlInfo{};
      cur->file = path;
      cur->line = ln;
      return;
    }
    auto need_material = [&]() {
      if (!cur) fail("'" + kw + "' before any 'newmtl'");
    };
    if (kw == "Ka" || kw == "Kd" || kw == "Ks" || kw == "Ke" || kw == "Tf") {
      need_material();
      if (tk.t.size() >= 2 && (tk.t[1] == "spectral" || tk.t[1] == "xyz"))
        fail("'" + kw + " " + std::string(tk.t[1]) + "' colours are not supported (expected " + kw + " r g b)");
      double v[3];
      if (tk.t.size() != 2 && tk.t.size() != 4) fail("expected 1 or 3 numbers after '" + kw + "', got '" + line_text + "'");
      for (size_t i = 1; i < tk.t.size(); ++i)
        if (!to_double(tk.t[i], v[i - 1]) || !std::isfinite(v[i - 1]))
          fail("expected a number after '" + kw + "', got '" + std::string(tk.t[i]) + "'");
      if (tk.t.size() == 2) v[1] = v[2] = v[0];
      if (v[0] < 0 || v[1] < 0 || v[2] < 0) fail("expected non-negative values after '" + kw + "'");
      RGB c{float(v[0]), float(v[1]), float(v[2])};
      if (kw == "Kd") cur->kd = c, cur->has_kd = true;
      else if (kw == "Ks") cur->ks = c, cur->has_ks = true;
      else if (kw == "Ke") cur->ke = c, cur->has_ke = true;
      else if (kw == "Tf") cur->tf = c, cur->has_tf = true;
      return;
    }
    if (kw == "Pr" || kw == "Pm" || kw == "Pc" || kw == "Pcr") {
      need_material();
      double v;
      if (tk.t.size() != 2 || !to_double(tk.t[1], v) || !(v >= 0 && v <= 1))
        fail("expected one number in [0, 1] after '" + kw + "', got '" + line_text + "'");
      (kw == "Pr" ? cur->pr : kw == "Pm" ? cur->pm : kw == "Pc" ? cur->pc : cur->pcr) = float(v);
      cur->has_pbr = true;
      return;
    }
    if (kw == "Ns" || kw == "Ni" || kw == "d" || kw == "Tr" || kw == "illum" || kw == "sharpness") {
      need_material();
      size_t i = 1;
      if (kw == "d" && tk.t.size() > 1 && tk.t[1] == "-halo") ++i;
      double v;
      if (tk.t.size() != i + 1 || !to_double(tk.t[i], v) || !std::isfinite(v))
        fail("expected one number after '" + kw + "', got '" + line_text + "'");
      if (kw == "Ns") {
        if (v < 0) fail("expected a non-negative specular exponent after 'Ns'");
        cur->ns = float(v);
      } else if (kw == "Ni") {
        if (v <= 0) fail("expected a positive index of refraction after 'Ni'");
        cur->ni = float(v), cur->has_ni = true;
      } else if (kw == "d" || kw == "Tr") {
        if (v < 0 || v > 1) fail("expected a value in [0, 1] after '" + kw + "'");
        if (kw == "d") cur->d = float(v), cur->has_d = true;
        else if (!cur->has_d) cur->d = float(1.0 - v);  // Tr = 1 - d; `d` wins when both are given
      } else if (kw == "illum") {
        if (v != std::floor(v) || v < 0 || v > 10) fail("expected an illumination model 0 to 10 after 'illum'");
        cur->illum = int(v);
      }
      return;
    }
    if (kw.rfind("map_", 0) == 0 || kw == "bump" || kw == "disp" || kw == "decal" || kw == "refl" || kw == "norm") {
      need_material();
      if (tk.t.size() < 2) fail("expected a file name after '" + kw + "'");
      if (kw == "map_Kd") cur->map_kd_line = ln;
      else if (kw == "map_Ke") cur->map_ke_line = ln;
      else if (kw == "map_d") cur->map_d_line = ln;
      else if (kw == "bump" || kw == "map_Bump" || kw == "map_bump") cur->bump_line = ln;
      else if (kw == "norm") cur->norm_line = ln;
      else if (kw == "map_Pr") cur->map_pr_line = ln;
      else if (kw == "map_Pm") cur->map_pm_line = ln;
      else if (std::find(lib.ignored.begin(), lib.ignored.end(), kw) == lib.ignored.end()) lib.ignored.push_back(kw);
      return;
    }
    // The rest of the PBR extension (Ps, aniso, anisor, ...) and anything else: not part of the mapping;
    // reported once per keyword.
    if (std::find(lib.ignored.begin(), lib.ignored.end(), kw) == lib.ignored.end()) lib.ignored.push_back(kw);
  });
}

// tinyobjloader's split of an `mtllib` line (space-separated, backslash escapes).
std::vector<std::string> tinyobj_split(const std::string& s) {
  std::vector<std::string> out;
  std::string tok;
  bool esc = false;
  for (char ch : s) {
    if (esc) esc = false;
    else if (ch == '\\') {
      esc = true;
      continue;
    } else if (ch == ' ') {
      if (!tok.empty()) out.push_back(tok);
      tok.clear();
      continue;
    }
    tok += ch;
  }
  out.push_back(tok);
  return out;
}

// The first pass over the OBJ text.
struct ObjScan {
  size_t nv = 0, nvt = 0, nvn = 0;
  std::vector<uint8_t> bad_v, bad_vt, bad_vn;  // non-finite values
  size_t n_bad_v = 0, n_bad_vt = 0, n_bad_vn = 0;
  size_t faces = 0, lines_points = 0;
  bool has_s = false;
  std::vector<std::string> mtl_files;
  std::vector<std::string> ignored;  // free-form geometry and display statements
  size_t unknown_usemtl = 0;
  std::string first_unknown_usemtl;
  int first_unknown_usemtl_line = 0;
  // Vertex colours as the file gives them (sRGB): `v x y z r g b` and ZBrush's `#MRGB` lines. Both vectors are
  // empty when no vertex has a colour, else one entry per vertex (white where `colored` is 0).
  std::vector<RGB> colors;
  std::vector<uint8_t> colored;
  size_t n_colored = 0;
  std::vector<RGB> mrgb_run;   // the #MRGB colours since the last `v` line
  size_t mrgb_dropped = 0;     // #MRGB colours for more vertices than preceded them
  int first_mrgb_dropped_line = 0;
};

void scan_obj(const std::string& path, const std::string& text, bool load_mtl, MtlLib& lib, ObjScan& s) {
  static const char* kIgnored[] = {"vp",   "cstype", "deg",   "bmat", "step",    "curv",     "curv2",     "surf",
                                   "parm", "trim",   "hole",  "scrv", "sp",      "end",      "con",       "mg",
                                   "bevel", "c_interp", "d_interp", "lod", "maplib", "usemap", "shadow_obj",
                                   "trace_obj", "ctech", "stech", "call", "csh"};
  const fs::path dir = fs::path(path).parent_path();
  auto set_color = [&](size_t v, RGB c) {
    if (s.colors.size() < s.nv) s.colors.resize(s.nv, RGB(1.f)), s.colored.resize(s.nv, 0);
    s.n_colored += !s.colored[v];
    s.colored[v] = 1;
    s.colors[v] = c;
  };
  // ZBrush's #MRGB lines follow the vertices they colour: a run of them (up to the next `v` line) gives, in
  // order, the colours of the run's length of vertices before it (Paul Bourke's OBJ colour notes; Blender's
  // importer reads them so). Colours for more vertices than came before are dropped, the first ones.
  int mrgb_line = 0;
  auto end_mrgb_run = [&] {
    const size_t n = s.mrgb_run.size(), k = std::min(n, s.nv);
    if (k < n && s.mrgb_dropped++ == 0) s.first_mrgb_dropped_line = mrgb_line;
    for (size_t i = 0; i < k; ++i) set_color(s.nv - k + i, s.mrgb_run[n - k + i]);
    s.mrgb_run.clear();
  };
  Tokens tk;
  for_each_line(text, [&](int ln, const char* b, const char* e) {
    tk.split(b, e);
    auto fail = [&](const std::string& what) {
      throw InputError(path + ": line " + std::to_string(ln) + ": " + what);
    };
    if (!tk.t.empty() && tk.t[0] == "#MRGB") {
      mrgb_line = ln;
      for (size_t i = 1; i < tk.t.size(); ++i) {
        const std::string_view h = tk.t[i];
        for (size_t j = 0; j < h.size(); j += 8) {
          uint32_t v = 0;
          const char* end = h.data() + std::min(j + 8, h.size());
          auto r = std::from_chars(h.data() + j, end, v, 16);
          if (end - (h.data() + j) != 8 || r.ec != std::errc() || r.ptr != end)
            fail("expected colours of 8 hexadecimal digits (MMRRGGBB) after '#MRGB', got '" +
                 std::string(h.substr(0, 40)) + "'");
          s.mrgb_run.push_back(RGB(float((v >> 16) & 255u) / 255.f, float((v >> 8) & 255u) / 255.f,
                                   float(v & 255u) / 255.f));
        }
      }
      return;
    }
    if (tk.t.empty() || tk.t[0][0] == '#') return;
    const std::string_view kw = tk.t[0];
    std::string line_text(b, size_t(std::min<ptrdiff_t>(e - b, 60)));
    if (kw == "v" || kw == "vn" || kw == "vt") {
      size_t lo = kw == "vt" ? 1 : 3, hi = kw == "v" ? 7 : 3;  // v: x y z [w | r g b]; vt: u [v [w]]
      if (kw == "vt") hi = 3;
      size_t n = tk.t.size() - 1;
      if (n < lo || n > hi) {
        std::string want = kw == "v" ? "3 coordinates (x y z, optionally w or r g b)"
                          : kw == "vn" ? "3 numbers (x y z)" : "1 to 3 numbers (u [v [w]])";
        fail("expected " + want + " after '" + std::string(kw) + "', got '" + line_text + "'");
      }
      bool finite = true;
      double rgb[3] = {1.0, 1.0, 1.0};
      for (size_t i = 1; i <= n; ++i) {
        double v;
        if (!to_double(tk.t[i], v)) fail("expected a number, got '" + std::string(tk.t[i]) + "'");
        if (i <= (kw == "vt" ? 2u : 3u)) finite &= std::isfinite(v);
        else if (kw == "v" && i <= 6) rgb[i - 4] = v;  // x y z r g b
      }
      if (kw == "v") {
        if (!s.mrgb_run.empty()) end_mrgb_run();
        s.bad_v.push_back(!finite), s.n_bad_v += !finite, ++s.nv;
        // `v x y z r g b`: Blender's, MeshLab's and many scanners' vertex colours (tinyobjloader reads the same
        // three numbers as colour); four numbers are x y z w.
        if (n >= 6) set_color(s.nv - 1, RGB(float(rgb[0]), float(rgb[1]), float(rgb[2])));
      } else if (kw == "vn") {
        s.bad_vn.push_back(!finite), s.n_bad_vn += !finite, ++s.nvn;
      } else {
        s.bad_vt.push_back(!finite), s.n_bad_vt += !finite, ++s.nvt;
      }
      return;
    }
    if (kw == "f") {
      if (tk.t.size() < 4) fail("expected at least 3 vertices after 'f', got '" + line_text + "'");
      for (size_t i = 1; i < tk.t.size(); ++i) {
        std::string_view ref = tk.t[i];
        std::string_view part[3];
        size_t np = 0, start = 0;
        for (size_t k = 0; k <= ref.size(); ++k)
          if (k == ref.size() || ref[k] == '/') {
            if (np == 3) fail("expected v, v/vt, v//vn or v/vt/vn, got '" + std::string(ref) + "'");
            part[np++] = ref.substr(start, k - start);
            start = k + 1;
          }
        static const char* what[3] = {"vertex", "texture coordinate", "normal"};
        const size_t count[3] = {s.nv, s.nvt, s.nvn};
        for (size_t k = 0; k < np; ++k) {
          if (k > 0 && part[k].empty()) {
            if (k == 1 && np == 3) continue;  // v//vn
            fail("expected v, v/vt, v//vn or v/vt/vn, got '" + std::string(ref) + "'");
          }
          int64_t idx;
          if (!to_int(part[k], idx)) fail("expected an integer " + std::string(what[k]) + " index, got '" + std::string(ref) + "'");
          if (idx == 0) fail(std::string(what[k]) + " index 0 in '" + std::string(ref) + "' (OBJ indices start at 1)");
          int64_t r = idx > 0 ? idx - 1 : int64_t(count[k]) + idx;
          if (r < 0 || r >= int64_t(count[k]))
            fail(std::string(what[k]) + " index " + std::to_string(idx) + " out of range (" + std::to_string(count[k]) +
                 " " + (k == 0 ? "vertices" : k == 1 ? "texture coordinates" : "normals") + " defined so far)");
        }
      }
      ++s.faces;
      return;
    }
    if (kw == "l" || kw == "p") {
      ++s.lines_points;
      return;
    }
    if (kw == "g" || kw == "o") return;
    if (kw == "s") {
      int64_t v;
      if (tk.t.size() != 2 || !(tk.t[1] == "off" || (to_int(tk.t[1], v) && v >= 0)))
        fail("expected 'off' or a smoothing group number after 's', got '" + line_text + "'");
      s.has_s = true;
      return;
    }
    if (kw == "usemtl") {
      if (tk.t.size() < 2) fail("expected a material name after 'usemtl'");
      if (load_mtl) {
        std::string name(tk.t[1].data(), size_t(e - tk.t[1].data()));
        while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.pop_back();
        if (!lib.materials.count(name)) {
          if (s.unknown_usemtl++ == 0) s.first_unknown_usemtl = name, s.first_unknown_usemtl_line = ln;
        }
      }
      return;
    }
    if (kw == "mtllib") {
      // tinyobjloader reads the rest of the line after "mtllib" and one character.
      if (e - b < 7 || (b[6] != ' ' && b[6] != '\t') || tk.t.size() < 2) fail("expected a file name after 'mtllib'");
      if (!load_mtl) return;
      std::string rest(tk.t[1].data(), size_t(e - tk.t[1].data()));
      while (!rest.empty() && (rest.back() == ' ' || rest.back() == '\t')) rest.pop_back();
      // One file whose name has spaces, or several files.
      std::vector<std::string> names;
      std::error_code ec;
      if (fs::is_regular_file(dir / rest, ec)) names.push_back(rest);
      else
        for (size_t i = 1; i < tk.t.size(); ++i) names.emplace_back(tk.t[i]);
      std::string all;
      for (const std::string& n : names) {
        fs::path p = dir / n;
        std::string text_mtl;
        if (!fs::is_regular_file(p, ec) || !read_text(p.string(), text_mtl))
          fail("material library '" + n + "' not found (" + p.string() + ")");
        scan_mtl(p.string(), text_mtl, lib);
        s.mtl_files.push_back(p.string());
        all += text_mtl;
        all += "\n";
      }
      std::string raw(b + 7, size_t(e - b - 7));
      for (const std::string& t : tinyobj_split(raw))
        if (!t.empty()) lib.text_by_token.emplace(t, all);
      return;
    }
    for (const char* k : kIgnored)
      if (kw == k) {
        std::string ks(kw);
        if (std::find(s.ignored.begin(), s.ignored.end(), ks) == s.ignored.end()) s.ignored.push_back(ks);
        return;
      }
    fail("unknown statement '" + std::string(kw.substr(0, 30)) +
         "' (expected v, vt, vn, f, l, p, g, o, s, usemtl, mtllib or a comment)");
  });
  end_mrgb_run();
  if (!s.colors.empty()) s.colors.resize(s.nv, RGB(1.f)), s.colored.resize(s.nv, 0);
}

// Hands tinyobjloader the MTL texts the first pass read.
class CachedMtlReader : public tinyobj::MaterialReader {
 public:
  explicit CachedMtlReader(const MtlLib& lib) : lib_(lib) {}
  bool operator()(const std::string& id, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* map, std::string* warn, std::string* err) override {
    auto it = lib_.text_by_token.find(id);
    if (it == lib_.text_by_token.end()) return false;
    std::istringstream in(it->second);
    tinyobj::LoadMtl(map, materials, &in, warn, err);
    return true;
  }

 private:
  const MtlLib& lib_;
};

struct MemBuf : std::streambuf {
  MemBuf(char* b, size_t n) { setg(b, b, b + n); }
};

bool black(RGB c) { return !(max_component(c) > 0.f); }

// Triangulates polygon corners [0, n) of a face: triangles (as corner numbers)
// appended to `tris`. Quads split along the shorter diagonal; larger polygons by
// ear clipping in the plane of their Newell normal (a fan if that fails).
void triangulate(const std::vector<Vec3f>& pts, std::vector<uint32_t>& tris) {
  const size_t n = pts.size();
  if (n == 3) {
    tris.insert(tris.end(), {0, 1, 2});
    return;
  }
  if (n == 4) {
    if (!(length_sq(pts[2] - pts[0]) > length_sq(pts[3] - pts[1]))) tris.insert(tris.end(), {0, 1, 2, 0, 2, 3});
    else tris.insert(tris.end(), {0, 1, 3, 1, 2, 3});
    return;
  }
  Vec3f nrm(0.f);
  for (size_t i = 0; i < n; ++i) nrm += cross(pts[i], pts[(i + 1) % n]);
  std::vector<uint32_t> ring(n);
  for (size_t i = 0; i < n; ++i) ring[i] = uint32_t(i);
  auto fan = [&]() {
    for (size_t k = 1; k + 1 < ring.size(); ++k) tris.insert(tris.end(), {ring[0], ring[k], ring[k + 1]});
  };
  if (!(length_sq(nrm) > 0.f) || !std::isfinite(length_sq(nrm))) return fan();
  auto convex = [&](uint32_t a, uint32_t b, uint32_t c) { return dot(cross(pts[b] - pts[a], pts[c] - pts[b]), nrm) > 0.f; };
  auto inside = [&](Vec3f p, uint32_t a, uint32_t b, uint32_t c) {
    return dot(cross(pts[b] - pts[a], p - pts[a]), nrm) >= 0.f && dot(cross(pts[c] - pts[b], p - pts[b]), nrm) >= 0.f &&
           dot(cross(pts[a] - pts[c], p - pts[c]), nrm) >= 0.f;
  };
  size_t guard = 0;
  size_t i = 0;
  while (ring.size() > 3 && guard < 2 * n * n) {
    ++guard;
    size_t m = ring.size();
    uint32_t a = ring[(i + m - 1) % m], b = ring[i % m], c = ring[(i + 1) % m];
    bool ear = convex(a, b, c);
    for (size_t k = 0; ear && k < m; ++k) {
      uint32_t q = ring[k];
      if (q != a && q != b && q != c && inside(pts[q], a, b, c)) ear = false;
    }
    if (ear) {
      tris.insert(tris.end(), {a, b, c});
      ring.erase(ring.begin() + long(i % m));
    } else {
      ++i;
    }
  }
  fan();  // the last triangle, or all that is left if no ear was found
}

struct Run {  // consecutive faces of one tinyobjloader shape going into one bucket
  uint32_t shape;
  size_t first_face, end_face, first_corner;
};
struct Bucket {
  std::string group;
  int material;  // tinyobjloader material id (-1: none)
  std::vector<Run> runs;
};

}  // namespace

std::vector<int> append_obj(SceneDesc& desc, const std::string& path, const Affine& to_world, int material_override,
                            const std::string& referrer) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    if (referrer != path) throw InputError(referrer + ": mesh file '" + path + "' does not exist");
    throw InputError(path + ": no such file");
  }
  std::string text;
  if (!read_text(path, text)) throw InputError(path + ": cannot read the file");
  const bool use_mtl = material_override < 0;
  const std::string stem = fs::path(path).stem().string();

  // ---- first pass: checks, MTL files, non-finite values ----
  MtlLib lib;
  ObjScan scan;
  scan_obj(path, text, use_mtl, lib, scan);
  if (scan.faces == 0)
    throw InputError(path + ": no faces (" + plural(scan.nv, "vertex", "vertices") + " and no 'f' statements)");

  // ---- tinyobjloader ----
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> tmats;
  {
    std::string warn, err;
    MemBuf mb(text.data(), text.size());
    std::istream in(&mb);
    CachedMtlReader reader(lib);
    bool ok = tinyobj::LoadObj(&attrib, &shapes, &tmats, &warn, &err, &in, use_mtl ? &reader : nullptr,
                               /*triangulate=*/false, /*default_vcols_fallback=*/false);
    if (!ok) {
      std::string first = err.substr(0, err.find('\n'));
      throw InputError(path + ": " + (first.empty() ? "tinyobjloader could not read the file" : first));
    }
  }
  std::string().swap(text);
  if (attrib.vertices.size() != 3 * scan.nv || attrib.normals.size() != 3 * scan.nvn ||
      attrib.texcoords.size() != 2 * scan.nvt)
    throw InputError(path + ": internal error: tinyobjloader read a different number of vertices");

  const size_t nv = scan.nv;
  std::vector<Vec3f> P(nv);
  for (size_t i = 0; i < nv; ++i)
    P[i] = Vec3f(float(attrib.vertices[3 * i]), float(attrib.vertices[3 * i + 1]), float(attrib.vertices[3 * i + 2]));
  std::vector<tinyobj::real_t>().swap(attrib.vertices);
  std::vector<tinyobj::real_t>().swap(attrib.colors);  // scan_obj read them, #MRGB lines too

  // Vertex colours: sRGB in the file (Blender's exporter encodes them so and its importer decodes them so;
  // MeshLab and ZBrush write display colours), linear here. Negative or non-finite ones become white.
  std::vector<RGB>& C = scan.colors;
  size_t bad_colors = 0;
  for (size_t i = 0; i < C.size(); ++i) {
    if (!scan.colored[i]) continue;
    RGB& c = C[i];
    if (!usable_color(c)) {
      c = RGB(1.f), ++bad_colors;
      continue;
    }
    c = RGB(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
  }

  // Normals from the file: usable if finite and non-zero.
  std::vector<Vec3f> N(scan.nvn);
  std::vector<uint8_t> n_ok(scan.nvn, 0);
  for (size_t i = 0; i < scan.nvn; ++i) {
    Vec3f n(float(attrib.normals[3 * i]), float(attrib.normals[3 * i + 1]), float(attrib.normals[3 * i + 2]));
    float l = length(n);
    if (!scan.bad_vn[i] && l > 0.f && std::isfinite(l)) N[i] = n / l, n_ok[i] = 1;
  }

  // ---- buckets: (group, material) in order of first appearance ----
  std::vector<Bucket> buckets;
  std::map<std::pair<std::string, int>, size_t> bucket_of;
  for (size_t si = 0; si < shapes.size(); ++si) {
    const tinyobj::mesh_t& m = shapes[si].mesh;
    size_t corner = 0;
    for (size_t f = 0; f < m.num_face_vertices.size();) {
      int mat = use_mtl ? m.material_ids[f] : -1;
      size_t g = f, c0 = corner;
      while (g < m.num_face_vertices.size() && (use_mtl ? m.material_ids[g] : -1) == mat) corner += m.num_face_vertices[g++];
      auto key = std::make_pair(shapes[si].name, mat);
      auto it = bucket_of.find(key);
      if (it == bucket_of.end()) {
        it = bucket_of.emplace(key, buckets.size()).first;
        buckets.push_back(Bucket{shapes[si].name, mat, {}});
      }
      buckets[it->second].runs.push_back(Run{uint32_t(si), f, g, c0});
      f = g;
    }
  }

  // ---- smooth normals for corners without a usable `vn` ----
  // Faces are smooth unless the file uses smoothing groups and puts them in
  // `s off` / `s 0`; smooth normals are shared per (position, smoothing group).
  auto face_smooth = [&](const tinyobj::mesh_t& m, size_t f) { return !scan.has_s || m.smoothing_group_ids[f] != 0; };
  bool need_smooth = false;
  for (const auto& sh : shapes)
    for (const auto& ix : sh.mesh.indices)
      if (ix.normal_index < 0 || !n_ok[size_t(ix.normal_index)]) {
        need_smooth = true;
        break;
      }
  std::vector<Vec3f> acc;                               // !has_s: indexed by position
  std::unordered_map<uint64_t, Vec3f> acc_groups;       //  has_s: by (position, group)
  std::vector<Vec3f> pts;
  std::vector<uint32_t> tri;
  auto polygon = [&](const tinyobj::mesh_t& m, size_t corner, size_t n) {
    pts.resize(n);
    for (size_t k = 0; k < n; ++k) pts[k] = P[size_t(m.indices[corner + k].vertex_index)];
    tri.clear();
    triangulate(pts, tri);
  };
  auto tri_ok = [&](const tinyobj::mesh_t& m, size_t corner, uint32_t a, uint32_t b, uint32_t c, bool& nan) {
    int va = m.indices[corner + a].vertex_index, vb = m.indices[corner + b].vertex_index,
        vc = m.indices[corner + c].vertex_index;
    nan = scan.n_bad_v && (scan.bad_v[size_t(va)] || scan.bad_v[size_t(vb)] || scan.bad_v[size_t(vc)]);
    if (nan) return false;
    return va != vb && vb != vc && va != vc && length_sq(cross(pts[b] - pts[a], pts[c] - pts[a])) > 0.f;
  };
  if (need_smooth) {
    if (!scan.has_s) acc.assign(nv, Vec3f(0.f));
    for (const auto& sh : shapes) {
      const tinyobj::mesh_t& m = sh.mesh;
      size_t corner = 0;
      for (size_t f = 0; f < m.num_face_vertices.size(); corner += m.num_face_vertices[f++]) {
        if (!face_smooth(m, f)) continue;
        polygon(m, corner, m.num_face_vertices[f]);
        for (size_t t = 0; t < tri.size(); t += 3) {
          bool nan;
          if (!tri_ok(m, corner, tri[t], tri[t + 1], tri[t + 2], nan)) continue;
          Vec3f w[3];
          if (!angle_weighted_terms(pts[tri[t]], pts[tri[t + 1]], pts[tri[t + 2]], w)) continue;
          for (int k = 0; k < 3; ++k) {
            size_t v = size_t(m.indices[corner + tri[t + k]].vertex_index);
            if (!scan.has_s) acc[v] += w[k];
            else acc_groups[(uint64_t(v) << 32) | m.smoothing_group_ids[f]] += w[k];
          }
        }
      }
    }
  }
  auto smooth_normal = [&](size_t v, unsigned sg) {
    Vec3f n = !scan.has_s ? acc[v] : acc_groups[(uint64_t(v) << 32) | sg];
    float l = length(n);
    return l > 0.f && std::isfinite(l) ? n / l : Vec3f(0.f, 0.f, 1.f);
  };

  // ---- materials ----
  size_t clamped_kd = 0, scaled_phong = 0;
  std::map<int, int> converted;  // tinyobj id -> desc material
  auto unique_name = [&](const std::string& base) {
    std::string n = base;
    for (int k = 2; desc.material_index(n) >= 0; ++k) n = base + "~" + std::to_string(k);
    return n;
  };
  // Faces with no MTL material: grey diffuse `<stem>/default`, or where the shape's vertices have colours
  // `<stem>/default+colors`, reflectance 1 times them (as glTF's default material takes COLOR_0). Made when first
  // used; material_for answers kDefault for them.
  constexpr int kDefault = -2;
  int default_material[2] = {-1, -1};  // [colored]
  auto default_for = [&](bool colored) {
    int& idx = default_material[colored];
    if (idx < 0) {
      Material m = make_diffuse(RGB(colored ? 1.f : 0.5f));
      if (colored) m.flags |= kVertexColor;
      idx = desc.add_material(unique_name(stem + (colored ? "/default+colors" : "/default")), m);
    }
    return idx;
  };
  struct Emit {
    RGB L{0.f};
    int tex = -1;
  };
  std::map<int, Emit> emission;
  std::map<std::pair<int, int>, int> rough_metal;  // (map_Pr, map_Pm) -> the texture made of them
  auto material_for = [&](int id) -> int {
    if (!use_mtl) return material_override;
    auto it = converted.find(id);
    if (it != converted.end()) return it->second;
    const MtlInfo* mi = nullptr;
    if (id >= 0 && size_t(id) < tmats.size()) {
      auto f = lib.materials.find(tmats[size_t(id)].name);
      if (f != lib.materials.end()) mi = &f->second;
    }
    if (!mi) return converted[id] = kDefault;
    const tinyobj::material_t& tm = tmats[size_t(id)];
    const fs::path mdir = fs::path(mi->file).parent_path();
    auto texture = [&](const std::string& name, int line, bool srgb = true) {
      std::string p = (mdir / name).string();
      std::string where = mi->file + ": line " + std::to_string(line);
      std::error_code e2;
      if (!fs::is_regular_file(p, e2)) throw InputError(where + ": texture file '" + name + "' not found (" + p + ")");
      return load_texture(desc, p, srgb, where);
    };
    Emit em;
    if (mi->has_ke) em.L = mi->ke;
    if (mi->map_ke_line && !tm.emissive_texname.empty()) {
      em.tex = texture(tm.emissive_texname, mi->map_ke_line);
      if (black(em.L)) em.L = RGB(1.f);
    }
    emission[id] = em;
    bool emissive = !black(em.L);
    int tex_kd = mi->map_kd_line && !tm.diffuse_texname.empty() ? texture(tm.diffuse_texname, mi->map_kd_line) : -1;
    RGB kd = tex_kd >= 0 ? RGB(1.f) : mi->has_kd ? mi->kd : RGB(emissive ? 0.f : 0.5f);
    if (max_component(kd) > 1.f) {
      ++clamped_kd;
      kd = Vec3f(std::min(kd.x, 1.f), std::min(kd.y, 1.f), std::min(kd.z, 1.f));
    }
    RGB ks = mi->ks;
    float eta = mi->has_ni && mi->ni != 1.f ? mi->ni : 1.5f;
    RGB tint = mi->has_tf && !black(mi->tf) ? mi->tf : RGB(1.f);
    tint = Vec3f(std::min(tint.x, 1.f), std::min(tint.y, 1.f), std::min(tint.z, 1.f));
    const int il = mi->illum;
    Material m;
    bool uses_kd = true;
    if (il == 6 || il == 7) {
      m = make_dielectric(eta);
      m.transmission = tint;
      uses_kd = false;
    } else if (il == 4 || il == 9 || mi->d < 1.f) {
      m = make_thin_dielectric(eta);
      m.transmission = tint;
      uses_kd = false;
    } else if (mi->pbr()) {
      // The PBR extension: glTF's metallic-roughness material (materials.md) with base colour Kd (or map_Kd),
      // metallic Pm, roughness Pr (GGX alpha Pr^2) and a coat of weight Pc and roughness Pcr. Ks, Ns and illum,
      // which exporters write beside them as a Phong stand-in for the same surface, are not read.
      m = make_metallic_roughness(kd, mi->pm, mi->pr);
      m.clearcoat = mi->pc;
      m.clearcoat_alpha = mi->pcr * mi->pcr;
      const int tr =
          mi->map_pr_line && !tm.roughness_texname.empty() ? texture(tm.roughness_texname, mi->map_pr_line, false) : -1;
      const int tmet =
          mi->map_pm_line && !tm.metallic_texname.empty() ? texture(tm.metallic_texname, mi->map_pm_line, false) : -1;
      if (tr >= 0 || tmet >= 0) {  // a map replaces its value, as map_Kd replaces Kd (and Blender's importer does)
        if (tr >= 0) m.alpha_x = m.alpha_y = 1.f;
        if (tmet >= 0) m.metallic = 1.f;
        m.tex_roughness = roughness_metallic_texture(desc, tr, tmet, rough_metal);
      }
    } else if (il == 3 || il == 5 || il == 8) {
      RGB spec = mi->has_ks ? ks : RGB(1.f);
      spec = Vec3f(std::min(spec.x, 1.f), std::min(spec.y, 1.f), std::min(spec.z, 1.f));
      if (black(kd) && tex_kd < 0) {
        m = make_mirror(spec);
        uses_kd = false;
      } else {
        m = make_plastic(kd, eta, spec);
      }
    } else if (il != 0 && il != 1 && !black(ks)) {
      float mx = std::max({kd.x + ks.x, kd.y + ks.y, kd.z + ks.z});
      if (mx > 1.f) {
        ++scaled_phong;
        kd = kd / mx;
        ks = ks / mx;
      }
      m = make_phong(kd, ks, std::max(mi->ns, 0.f));
    } else {
      m = make_diffuse(kd);
    }
    if (uses_kd && tex_kd >= 0) m.tex_color = tex_kd;
    if (mi->map_d_line && !tm.alpha_texname.empty()) {
      // map_d: a cut-out mask (scene/opacity.h), stochastic where the mask is between 0 and 1 (its filtered
      // edges). Its alpha channel where it has one (the map_Kd image, often), else its luminance, linear.
      m.tex_opacity = tex_kd >= 0 && tm.alpha_texname == tm.diffuse_texname ? tex_kd
                                                                              : texture(tm.alpha_texname, mi->map_d_line, false);
      if (!texture_has_alpha(desc.textures[m.tex_opacity])) m.flags |= kOpacityLuminance;
    }
    // norm: a tangent-space normal map. bump / map_Bump: a height map in the MTL spec, but exporters
    // (Blender's among them) write normal maps there too; a map whose texels are those of a tangent-space
    // normal map (looks_like_normal_map) is read as one, anything else as heights.
    if (mi->norm_line && !tm.normal_texname.empty()) {
      m.tex_normal = texture(tm.normal_texname, mi->norm_line, false);
      if (mi->bump_line && !tm.bump_texname.empty())
        desc.warnings.push_back(mi->file + ": line " + std::to_string(mi->bump_line) + ": bump map '" +
                                tm.bump_texname + "' not used: the material has a normal map (norm)");
    } else if (mi->bump_line && !tm.bump_texname.empty()) {
      int t = texture(tm.bump_texname, mi->bump_line, false);
      const float bm = float(tm.bump_texopt.bump_multiplier);
      if (looks_like_normal_map(desc.textures[size_t(t)])) {
        m.tex_normal = t;
        m.normal_scale = bm;
        desc.warnings.push_back(mi->file + ": line " + std::to_string(mi->bump_line) + ": bump map '" +
                                tm.bump_texname + "' read as a tangent-space normal map (its texels are one's)");
      } else {
        m.tex_bump = t;
        m.bump_scale = bm;
      }
    }
    int idx = desc.add_material(unique_name(stem + "/" + tm.name), m);
    return converted[id] = idx;
  };

  // ---- meshes, one per bucket ----
  // Vertex dedup by (position, uv, normal source): head[v] starts a chain of
  // this bucket's vertices made from position v.
  struct VKey {
    int32_t vt;
    int32_t vn;     // file normal, or -1
    uint32_t tag;   // smooth corners: smoothing group + 1; others 0
    uint32_t face;  // flat corners: the face's running number (a vertex per face); others 0
  };
  std::vector<int32_t> head(nv, -1);
  std::vector<int32_t> next;
  std::vector<VKey> keys;
  std::vector<uint32_t> src_v;
  size_t skipped_degenerate = 0, skipped_nan = 0, dropped_lights = 0;
  std::vector<int> added;
  std::map<std::string, int> materials_per_group;
  for (const Bucket& bk : buckets) ++materials_per_group[bk.group];
  uint32_t flat_face_counter = 0;
  std::vector<uint32_t> corner_vertex;
  std::vector<Vec3f> face_normal_tmp;

  for (const Bucket& bk : buckets) {
    MeshDesc mesh;
    bool want_uv = false, want_n = false, any_colored = false;
    for (const Run& r : bk.runs) {
      const tinyobj::mesh_t& m = shapes[r.shape].mesh;
      size_t corner = r.first_corner;
      for (size_t f = r.first_face; f < r.end_face; corner += m.num_face_vertices[f++])
        for (size_t k = 0; k < m.num_face_vertices[f]; ++k) {
          const auto& ix = m.indices[corner + k];
          want_uv |= ix.texcoord_index >= 0;
          want_n |= (ix.normal_index >= 0 && n_ok[size_t(ix.normal_index)]) || face_smooth(m, f);
        }
    }
    next.clear();
    keys.clear();
    src_v.clear();
    for (const Run& r : bk.runs) {
      const tinyobj::mesh_t& m = shapes[r.shape].mesh;
      size_t corner = r.first_corner;
      for (size_t f = r.first_face; f < r.end_face; corner += m.num_face_vertices[f++]) {
        const size_t n = m.num_face_vertices[f];
        polygon(m, corner, n);
        const bool smooth = face_smooth(m, f);
        uint32_t flat_id = 0;
        Vec3f fn(0.f, 0.f, 1.f);
        if (!smooth) {
          flat_id = ++flat_face_counter;
          Vec3f s(0.f);
          for (size_t k = 0; k < n; ++k) s += cross(pts[k], pts[(k + 1) % n]);
          float l = length(s);
          if (l > 0.f && std::isfinite(l)) fn = s / l;
        }
        corner_vertex.assign(n, UINT32_MAX);
        auto vertex_of = [&](uint32_t k) -> uint32_t {
          if (corner_vertex[k] != UINT32_MAX) return corner_vertex[k];
          const auto& ix = m.indices[corner + k];
          size_t v = size_t(ix.vertex_index);
          VKey key{ix.texcoord_index, -1, 0, 0};
          Vec3f nrm;
          if (ix.normal_index >= 0 && n_ok[size_t(ix.normal_index)]) {
            key.vn = ix.normal_index;
            nrm = N[size_t(ix.normal_index)];
          } else if (smooth) {
            key.tag = m.smoothing_group_ids[f] + 1;
            nrm = smooth_normal(v, m.smoothing_group_ids[f]);
          } else {
            key.face = flat_id;
            nrm = fn;
          }
          for (int32_t h = head[v]; h >= 0; h = next[size_t(h)]) {
            const VKey& o = keys[size_t(h)];
            if (o.vt == key.vt && o.vn == key.vn && o.tag == key.tag && o.face == key.face)
              return corner_vertex[k] = uint32_t(h);
          }
          uint32_t id = uint32_t(mesh.positions.size());
          mesh.positions.push_back(P[v]);
          if (!C.empty()) mesh.colors.push_back(C[v]), any_colored |= scan.colored[v] != 0;
          if (want_n) mesh.normals.push_back(nrm);
          if (want_uv) {
            Vec2f uv(0.f, 0.f);
            if (ix.texcoord_index >= 0 && !scan.bad_vt[size_t(ix.texcoord_index)])
              uv = Vec2f(float(attrib.texcoords[2 * size_t(ix.texcoord_index)]),
                         float(attrib.texcoords[2 * size_t(ix.texcoord_index) + 1]));
            mesh.uvs.push_back(uv);
          }
          keys.push_back(key);
          next.push_back(head[v]);
          head[v] = int32_t(id);
          src_v.push_back(uint32_t(v));
          return corner_vertex[k] = id;
        };
        for (size_t t = 0; t < tri.size(); t += 3) {
          bool nan;
          if (!tri_ok(m, corner, tri[t], tri[t + 1], tri[t + 2], nan)) {
            ++(nan ? skipped_nan : skipped_degenerate);
            continue;
          }
          for (int k = 0; k < 3; ++k) mesh.indices.push_back(vertex_of(tri[t + k]));
        }
      }
    }
    for (uint32_t v : src_v) head[v] = -1;

    const Emit em = use_mtl ? (material_for(bk.material), emission[bk.material]) : Emit{};
    const bool emissive = !black(em.L);
    if (mesh.indices.empty()) {
      dropped_lights += emissive;
      continue;
    }
    if (!any_colored) std::vector<RGB>().swap(mesh.colors);
    std::string name = stem;
    if (!bk.group.empty()) name += "/" + bk.group;
    if (materials_per_group[bk.group] > 1)
      name += "/" + (bk.material >= 0 && size_t(bk.material) < tmats.size() ? tmats[size_t(bk.material)].name : "default");
    mesh.name = name;
    desc.meshes.push_back(std::move(mesh));
    ShapeDesc sd;
    sd.name = name;
    sd.type = ShapeType::kMesh;
    sd.mesh = int(desc.meshes.size()) - 1;
    sd.to_world = to_world;
    sd.material = material_for(bk.material);
    if (sd.material == kDefault) sd.material = default_for(!desc.meshes.back().colors.empty());
    sd.emission = em.L;
    sd.emission_texture = em.tex;
    desc.shapes.push_back(sd);
    added.push_back(int(desc.shapes.size()) - 1);
  }

  // ---- warnings, one line each ----
  auto& W = desc.warnings;
  if (skipped_degenerate) W.push_back(path + ": skipped " + plural(skipped_degenerate, "degenerate triangle", "degenerate triangles"));
  if (skipped_nan)
    W.push_back(path + ": skipped " + plural(skipped_nan, "triangle", "triangles") +
                " with non-finite (NaN or infinite) vertex coordinates (" + plural(scan.n_bad_v, "such vertex", "such vertices") + ")");
  if (scan.n_bad_vn)
    W.push_back(path + ": " + plural(scan.n_bad_vn, "non-finite normal", "non-finite normals") + " replaced by computed ones");
  if (scan.n_bad_vt)
    W.push_back(path + ": " + plural(scan.n_bad_vt, "non-finite texture coordinate", "non-finite texture coordinates") + " set to (0, 0)");
  if (dropped_lights)
    W.push_back(path + ": " + plural(dropped_lights, "emissive shape has", "emissive shapes have") +
                " zero area (no valid triangles); not used as lights");
  if (scan.lines_points)
    W.push_back(path + ": ignored " + plural(scan.lines_points, "line/point statement", "line/point statements") + " ('l', 'p')");
  if (!scan.ignored.empty()) {
    std::string l;
    for (const auto& k : scan.ignored) l += (l.empty() ? "" : ", ") + k;
    W.push_back(path + ": ignored unsupported statements (" + l + ")");
  }
  if (scan.unknown_usemtl)
    W.push_back(path + ": line " + std::to_string(scan.first_unknown_usemtl_line) + ": usemtl '" + scan.first_unknown_usemtl +
                "' is not in the material libraries" +
                (scan.unknown_usemtl > 1 ? " (and " + std::to_string(scan.unknown_usemtl - 1) + " more)" : "") +
                "; those faces use a grey diffuse material (white times their vertex colours where they have them)");
  if (!lib.ignored.empty() && use_mtl) {
    std::string l;
    for (const auto& k : lib.ignored) l += (l.empty() ? "" : ", ") + k;
    std::string files;
    for (const auto& f : scan.mtl_files) files += (files.empty() ? "" : ", ") + f;
    W.push_back(files + ": ignored MTL statements without a mapping (" + l + ")");
  }
  if (bad_colors)
    W.push_back(path + ": " + plural(bad_colors, "negative or non-finite vertex colour", "negative or non-finite vertex colours") +
                " made white");
  if (scan.n_colored && scan.n_colored < nv)
    W.push_back(path + ": " + plural(nv - scan.n_colored, "vertex has", "vertices have") + " no colour (" +
                plural(scan.n_colored, "vertex has", "vertices have") + " one); white there");
  if (scan.mrgb_dropped)
    W.push_back(path + ": line " + std::to_string(scan.first_mrgb_dropped_line) +
                ": #MRGB gives colours for more vertices than precede it; the extra colours are ignored" +
                (scan.mrgb_dropped > 1 ? " (and in " + std::to_string(scan.mrgb_dropped - 1) + " more runs)" : ""));
  if (clamped_kd) W.push_back(path + ": " + plural(clamped_kd, "material's Kd was", "materials' Kd were") + " above 1 and clamped to 1");
  if (scaled_phong)
    W.push_back(path + ": " + plural(scaled_phong, "material has", "materials have") +
                " Kd + Ks above 1; both scaled down to conserve energy");
  if (added.empty()) throw InputError(path + ": no valid triangles (all faces are degenerate or have non-finite coordinates)");
  // Normal maps turn with smooth tangent frames where the mesh has normals and UVs (as glTF asks for a
  // normal map without TANGENT; scene_desc.h).
  for (int k : added) {
    const ShapeDesc& sh = desc.shapes[size_t(k)];
    if (sh.mesh < 0 || sh.material < 0 || desc.materials[size_t(sh.material)].tex_normal < 0) continue;
    MeshDesc& mesh = desc.meshes[size_t(sh.mesh)];
    if (mesh.tangents.empty()) generate_tangents(mesh);
  }
  return added;
}

}  // namespace caustica
