// caustica's JSON scene format: strict key checking, one-line errors naming the
// file and the JSON path (docs/scene-format.md; the schema is docs/scene.schema.json).
#include "json_loader.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "../../base/error.h"
#include "json_text.h"
#include "../../integrator/render.h"
#include "mesh_loaders.h"
#include "../blackbody.h"
#include "../vdb_io.h"
#include "../volume_io.h"

namespace caustica {
namespace {

namespace fs = std::filesystem;
// Ordered: materials, meshes and cameras keep the file's order (their indices
// follow it, and an exported scene reads back with the same indices).
using json = nlohmann::ordered_json;

constexpr double kPiD = 3.14159265358979323846;

// A shape's worth of a named mesh: an OBJ file gives one part per (group, material).
struct MeshPart {
  std::string name;
  int mesh = -1;
  int material = -1;  // the OBJ's material, or -1 (the instancing shape's, or the default)
  RGB emission{0.f};
  int emission_texture = -1;
  bool emission_two_sided = false;
};

struct Ctx {
  std::string source;
  fs::path base;
  SceneDesc* d = nullptr;
  std::vector<bool> claimed;  // a texture's sampler settings were fixed by an earlier reference

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError(source + ": " + (path.empty() ? "/" : path) + ": " + what);
  }
  std::string resolve(const std::string& f) const {
    fs::path p(f);
    if (p.is_absolute() || base.empty()) return p.string();
    return (base / p).string();
  }
};

const char* type_name(const json& j) { return j.type_name(); }

double numd(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_number()) c.fail(path, std::string("expected a number, got ") + type_name(j));
  double v = j.get<double>();
  if (!std::isfinite(v)) c.fail(path, "expected a finite number");
  return v;
}
float num(const Ctx& c, const json& j, const std::string& path) {
  double v = numd(c, j, path);
  if (std::fabs(v) > 3.4e38) c.fail(path, "expected a number within the float range");
  return float(v);
}
Vec3f vec3(const Ctx& c, const json& j, const std::string& path) {
  if (j.is_number()) return Vec3f(num(c, j, path));  // a grey value
  if (!j.is_array() || j.size() != 3) c.fail(path, "expected an array of 3 numbers");
  return {num(c, j[0], path + "/0"), num(c, j[1], path + "/1"), num(c, j[2], path + "/2")};
}
Vec3f point3(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) c.fail(path, "expected an array of 3 numbers");
  return vec3(c, j, path);
}
Vec2f vec2(const Ctx& c, const json& j, const std::string& path, bool allow_scalar) {
  if (allow_scalar && j.is_number()) {
    float v = num(c, j, path);
    return {v, v};
  }
  if (!j.is_array() || j.size() != 2) c.fail(path, allow_scalar ? "expected a number or an array of 2 numbers" : "expected an array of 2 numbers");
  return {num(c, j[0], path + "/0"), num(c, j[1], path + "/1")};
}
RGB color(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_number() && !j.is_array()) c.fail(path, std::string("expected a colour (a number or [r, g, b]), got ") + type_name(j));
  Vec3f v = vec3(c, j, path);
  if (v.x < 0 || v.y < 0 || v.z < 0) c.fail(path, "expected non-negative colour values");
  return v;
}
std::string str(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_string()) c.fail(path, std::string("expected a string, got ") + type_name(j));
  return j.get<std::string>();
}
int64_t integer64(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_number_integer()) c.fail(path, std::string("expected an integer, got ") + type_name(j));
  return j.get<int64_t>();
}
int integer(const Ctx& c, const json& j, const std::string& path) {
  int64_t v = integer64(c, j, path);
  if (v < -2147483647 || v > 2147483647) c.fail(path, "integer out of range");
  return int(v);
}
bool boolean(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_boolean()) c.fail(path, std::string("expected true or false, got ") + type_name(j));
  return j.get<bool>();
}
void check_keys(const Ctx& c, const json& obj, const std::string& path, std::initializer_list<const char*> allowed) {
  if (!obj.is_object()) c.fail(path, std::string("expected an object, got ") + type_name(obj));
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    bool ok = false;
    for (const char* a : allowed) ok |= it.key() == a;
    if (!ok) {
      std::string list;
      for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      c.fail(path + "/" + it.key(), "unknown key (allowed: " + list + ")");
    }
  }
}
std::string join_keys(const json& obj) {
  std::string s;
  for (auto it = obj.begin(); it != obj.end(); ++it) s += (s.empty() ? "" : ", ") + it.key();
  return s.empty() ? "none" : s;
}
// JSON Pointer escaping of an object key (RFC 6901).
std::string esc(const std::string& k) {
  std::string r;
  for (char ch : k) {
    if (ch == '~') r += "~0";
    else if (ch == '/') r += "~1";
    else r += ch;
  }
  return r;
}

// ---------------------------------------------------------------- transforms

Affine mul(const Affine& a, const Affine& b) {  // a * b: b first
  Affine r;
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 4; ++k) {
      float v = a.m[i][0] * b.m[0][k] + a.m[i][1] * b.m[1][k] + a.m[i][2] * b.m[2][k];
      r.m[i][k] = k == 3 ? v + a.m[i][3] : v;
    }
  }
  return r;
}

Affine parse_transform_step(const Ctx& c, const json& j, const std::string& path) {
  check_keys(c, j, path, {"matrix", "translate", "rotate", "scale", "look_at"});
  Affine a;
  if (j.contains("matrix")) {
    if (j.size() > 1) c.fail(path, "'matrix' cannot be combined with other keys (use a list of steps)");
    const json& m = j["matrix"];
    if (!m.is_array() || (m.size() != 12 && m.size() != 16))
      c.fail(path + "/matrix", "expected 12 or 16 numbers (row-major 3x4 or 4x4)");
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 4; ++k) a.m[i][k] = num(c, m[i * 4 + k], path + "/matrix/" + std::to_string(i * 4 + k));
    if (m.size() == 16)
      for (int k = 0; k < 4; ++k)
        if (num(c, m[12 + k], path + "/matrix/" + std::to_string(12 + k)) != (k == 3 ? 1.f : 0.f))
          c.fail(path + "/matrix", "expected an affine matrix (last row 0, 0, 0, 1)");
    return a;
  }
  if (j.contains("look_at")) {
    if (j.size() > 1) c.fail(path, "'look_at' cannot be combined with other keys (use a list of steps)");
    const json& l = j["look_at"];
    std::string p = path + "/look_at";
    check_keys(c, l, p, {"origin", "target", "up"});
    if (!l.contains("origin") || !l.contains("target"))
      c.fail(p, "expected {\"origin\": [x,y,z], \"target\": [x,y,z], \"up\": [x,y,z]}");
    Vec3f o = point3(c, l["origin"], p + "/origin"), t = point3(c, l["target"], p + "/target");
    Vec3f up = l.contains("up") ? point3(c, l["up"], p + "/up") : Vec3f(0, 1, 0);
    if (length(t - o) == 0.f) c.fail(p + "/target", "must differ from the origin");
    Vec3f dir = normalize(t - o);
    Vec3f left = cross(up, dir);
    if (length(left) == 0.f) c.fail(p + "/up", "must not be parallel to the direction from origin to target");
    left = normalize(left);
    Vec3f new_up = cross(dir, left);
    for (int i = 0; i < 3; ++i) {
      a.m[i][0] = left[i];
      a.m[i][1] = new_up[i];
      a.m[i][2] = dir[i];
      a.m[i][3] = o[i];
    }
    return a;
  }
  // scale, then rotate (axis-angle, degrees), then translate.
  Vec3f s(1.f);
  if (j.contains("scale")) s = vec3(c, j["scale"], path + "/scale");
  float R[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  if (j.contains("rotate")) {
    const json& r = j["rotate"];
    check_keys(c, r, path + "/rotate", {"axis", "angle"});
    if (!r.contains("axis") || !r.contains("angle")) c.fail(path + "/rotate", "expected {\"axis\": [x,y,z], \"angle\": degrees}");
    Vec3f ax = point3(c, r["axis"], path + "/rotate/axis");
    if (length(ax) == 0.f) c.fail(path + "/rotate/axis", "expected a non-zero axis");
    ax = normalize(ax);
    float th = num(c, r["angle"], path + "/rotate/angle") * kPi / 180.f;
    float cs = std::cos(th), sn = std::sin(th), t = 1.f - cs;
    float M[3][3] = {{t * ax.x * ax.x + cs, t * ax.x * ax.y - sn * ax.z, t * ax.x * ax.z + sn * ax.y},
                     {t * ax.x * ax.y + sn * ax.z, t * ax.y * ax.y + cs, t * ax.y * ax.z - sn * ax.x},
                     {t * ax.x * ax.z - sn * ax.y, t * ax.y * ax.z + sn * ax.x, t * ax.z * ax.z + cs}};
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) R[i][k] = M[i][k];
  }
  Vec3f tr(0.f);
  if (j.contains("translate")) tr = point3(c, j["translate"], path + "/translate");
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) a.m[i][k] = R[i][k] * s[k];
    a.m[i][3] = tr[i];
  }
  return a;
}

// An object (one step) or a list of steps applied in order (the first one first).
Affine parse_transform(const Ctx& c, const json& j, const std::string& path) {
  if (j.is_array()) {
    Affine a;
    for (size_t i = 0; i < j.size(); ++i) a = mul(parse_transform_step(c, j[i], path + "/" + std::to_string(i)), a);
    return a;
  }
  if (!j.is_object()) c.fail(path, std::string("expected an object or a list of steps, got ") + type_name(j));
  return parse_transform_step(c, j, path);
}

// ---------------------------------------------------------------- textures

bool is_texture_ref(const json& j) { return j.is_string() || (j.is_object() && j.contains("texture")); }

bool same_sampling(const TextureDesc& a, const TextureDesc& b) {
  return a.wrap_u == b.wrap_u && a.wrap_v == b.wrap_v && a.nearest == b.nearest && a.uv_offset.x == b.uv_offset.x &&
         a.uv_offset.y == b.uv_offset.y && a.uv_scale.x == b.uv_scale.x && a.uv_scale.y == b.uv_scale.y &&
         a.uv_rotation == b.uv_rotation;
}

// "file.png" or {"texture": "file.png", "srgb", "wrap", "filter", "uv_scale", "uv_offset", "uv_rotation", "scale"};
// "scale" is read by the caller.
// extra_key: one more key the caller reads (a normal map's "bitangent", an opacity's "channel").
int parse_texture(Ctx& c, const json& j, const std::string& path, bool srgb_default, const char* extra_key = nullptr) {
  std::string file;
  TextureDesc want;
  bool srgb = srgb_default;
  std::string fpath = path;
  if (j.is_string()) {
    file = j.get<std::string>();
  } else {
    if (extra_key)
      check_keys(c, j, path, {"texture", "scale", "srgb", "wrap", "filter", "uv_scale", "uv_offset", "uv_rotation", extra_key});
    else
      check_keys(c, j, path, {"texture", "scale", "srgb", "wrap", "filter", "uv_scale", "uv_offset", "uv_rotation"});
    fpath = path + "/texture";
    file = str(c, j["texture"], fpath);
    if (j.contains("srgb")) srgb = boolean(c, j["srgb"], path + "/srgb");
    if (j.contains("wrap")) {  // one mode for both axes, or [u, v]
      auto mode = [&](const json& v, const std::string& p) {
        std::string w = str(c, v, p);
        if (w == "repeat") return TexWrap::kRepeat;
        if (w == "clamp") return TexWrap::kClamp;
        if (w == "mirror") return TexWrap::kMirror;
        c.fail(p, "unknown wrap mode '" + w + "' (allowed: repeat, clamp, mirror)");
      };
      const json& w = j["wrap"];
      if (w.is_array()) {
        if (w.size() != 2) c.fail(path + "/wrap", "expected a wrap mode or two ([u, v])");
        want.wrap_u = mode(w[0], path + "/wrap/0");
        want.wrap_v = mode(w[1], path + "/wrap/1");
      } else {
        want.wrap_u = want.wrap_v = mode(w, path + "/wrap");
      }
    }
    if (j.contains("filter")) {
      std::string f = str(c, j["filter"], path + "/filter");
      if (f == "nearest") want.nearest = true;
      else if (f != "bilinear") c.fail(path + "/filter", "unknown texture filter '" + f + "' (allowed: bilinear, nearest)");
    }
    if (j.contains("uv_scale")) want.uv_scale = vec2(c, j["uv_scale"], path + "/uv_scale", true);
    if (j.contains("uv_offset")) want.uv_offset = vec2(c, j["uv_offset"], path + "/uv_offset", false);
    if (j.contains("uv_rotation")) want.uv_rotation = float(numd(c, j["uv_rotation"], path + "/uv_rotation") * kPiD / 180.0);
  }
  if (file.empty()) c.fail(fpath, "expected a file name");
  SceneDesc& d = *c.d;
  int tex = load_texture(d, c.resolve(file), srgb, c.source + ": " + fpath);
  c.claimed.resize(d.textures.size(), false);
  auto apply = [&](TextureDesc& t) {
    t.wrap_u = want.wrap_u;
    t.wrap_v = want.wrap_v;
    t.nearest = want.nearest;
    t.uv_offset = want.uv_offset;
    t.uv_scale = want.uv_scale;
    t.uv_rotation = want.uv_rotation;
  };
  if (!c.claimed[tex]) {
    apply(d.textures[tex]);
    c.claimed[tex] = true;
    return tex;
  }
  for (size_t i = 0; i < d.textures.size(); ++i)
    if (d.textures[i].name == d.textures[tex].name && d.textures[i].srgb == srgb && same_sampling(d.textures[i], want))
      return int(i);
  TextureDesc copy = d.textures[tex];  // the same image with other sampler settings
  apply(copy);
  d.textures.push_back(std::move(copy));
  c.claimed.push_back(true);
  return int(d.textures.size()) - 1;
}

// A colour, or a texture multiplied by "scale" (default 1).
RGB color_or_texture(Ctx& c, const json& j, const std::string& path, int& tex, bool srgb_default = true) {
  if (is_texture_ref(j)) {
    tex = parse_texture(c, j, path, srgb_default);
    return j.is_object() && j.contains("scale") ? color(c, j["scale"], path + "/scale") : RGB(1.f);
  }
  if (j.is_object()) c.fail(path, "expected a colour (a number or [r, g, b]) or a texture ({\"texture\": file})");
  return color(c, j, path);
}

// ---------------------------------------------------------------- materials

const char* kMaterialTypes =
    "diffuse, conductor, dielectric, thindielectric, plastic, difftrans, phong, metallic_roughness, principled, blend, "
    "two_sided, null";

// names: every material's index (a blend names two others).
Material parse_material(Ctx& c, const json& j, const std::string& path, const std::map<std::string, int>& names) {
  if (!j.is_object()) c.fail(path, std::string("expected an object, got ") + type_name(j));
  if (!j.contains("type")) c.fail(path, std::string("missing 'type' (") + kMaterialTypes + ")");
  std::string type = str(c, j["type"], path + "/type");
  int tex_color = -1, tex_rough = -1;
  auto get_c = [&](const char* k, RGB def) { return j.contains(k) ? color(c, j[k], path + "/" + k) : def; };
  auto get_ct = [&](const char* k, RGB def) {
    return j.contains(k) ? color_or_texture(c, j[k], path + "/" + k, tex_color) : def;
  };
  auto get_f = [&](const char* k, float def) { return j.contains(k) ? num(c, j[k], path + "/" + k) : def; };
  auto positive = [&](const char* k, float v) {
    if (!(v > 0.f)) c.fail(path + "/" + k, "expected a positive number");
    return v;
  };
  auto unit = [&](const char* k, float v) {
    if (!(v >= 0.f && v <= 1.f)) c.fail(path + "/" + k, "expected a number in [0, 1]");
    return v;
  };
  // A number in [0, 1] or a texture whose "scale" (default 1) is that number, multiplied by one of the
  // texture's channels (scene/shading.h): metallic-roughness's KHR_materials_transmission weight (R),
  // KHR_materials_clearcoat's weight (R) and perceptual roughness (G), KHR_materials_specular's weight (R) and
  // KHR_materials_sheen's roughness (R); principled's weights (R).
  auto unit_value = [&](const char* k, float def, int32_t& tex) {
    if (!j.contains(k)) return def;
    const json& v = j[k];
    std::string p = path + "/" + k;
    float x = 1.f;
    const bool texture = is_texture_ref(v);
    if (texture && v.is_object() && v.contains("scale")) x = num(c, v["scale"], p + "/scale"), p += "/scale";
    else if (!texture && v.is_object()) c.fail(p, "expected a number in [0, 1] or a texture ({\"texture\": file, \"scale\": s})");
    else if (!texture) x = num(c, v, p);
    if (!(x >= 0.f && x <= 1.f)) c.fail(p, "expected a number in [0, 1]");
    if (texture) tex = parse_texture(c, v, path + "/" + k, false);
    return x;
  };
  // GGX alpha: a number, [alpha_x, alpha_y], or a texture (its "scale" is alpha).
  auto alpha_value = [&](const json& v, const std::string& p) {
    Vec2f a = vec2(c, v, p, true);
    if (a.x < 0.f || a.y < 0.f) c.fail(p, "expected a roughness >= 0");
    return a;
  };
  // Perceptual roughness (GGX alpha = roughness^2; 0.5 if absent): a number in [0, 1] or a texture whose
  // "scale" (default 1) is the roughness its G channel multiplies; a number excludes "alpha".
  auto perceptual_roughness = [&]() {
    if (!j.contains("roughness")) return 0.5f;
    const json& v = j["roughness"];
    std::string p = path + "/roughness";
    float rough;
    if (is_texture_ref(v)) {
      tex_rough = parse_texture(c, v, p, false);
      rough = v.is_object() && v.contains("scale") ? num(c, v["scale"], p + "/scale") : 1.f;
      if (!(rough >= 0.f && rough <= 1.f)) c.fail(p + "/scale", "expected a number in [0, 1]");
    } else {
      if (j.contains("alpha")) c.fail(p, "give 'roughness' or 'alpha', not both");
      rough = num(c, v, p);
      if (!(rough >= 0.f && rough <= 1.f)) c.fail(p, "expected a number in [0, 1]");
    }
    return rough;
  };
  auto roughness = [&](const char* k) {
    Vec2f a(0.f, 0.f);
    if (!j.contains(k)) return a;
    const json& v = j[k];
    std::string p = path + "/" + k;
    if (is_texture_ref(v)) {
      tex_rough = parse_texture(c, v, p, false);
      a = v.is_object() && v.contains("scale") ? alpha_value(v["scale"], p + "/scale") : Vec2f(1.f, 1.f);
      if (!(a.x > 0.f && a.y > 0.f)) c.fail(p + "/scale", "expected a positive roughness under a roughness texture");
      return a;
    }
    if (v.is_object()) c.fail(p, "expected a number, [alpha_x, alpha_y] or a texture ({\"texture\": file})");
    return alpha_value(v, p);
  };
  Material m;
  if (type == "diffuse") {
    check_keys(c, j, path, {"type", "reflectance", "two_sided", "normal_map", "bump_map", "opacity", "opacity_cutoff", "vertex_colors"});
    m = make_diffuse(get_ct("reflectance", RGB(0.5f)));
  } else if (type == "conductor") {
    check_keys(c, j, path, {"type", "eta", "k", "specular", "roughness", "distribution", "anisotropy_rotation", "anisotropy_texture", "two_sided", "normal_map", "bump_map", "opacity", "opacity_cutoff", "vertex_colors"});
    Vec2f a = roughness("roughness");
    if (j.contains("eta") != j.contains("k")) c.fail(path, "give both 'eta' and 'k' (or neither for a tinted mirror)");
    RGB spec = get_ct("specular", RGB(1.f));
    if (j.contains("eta")) {
      m = make_conductor(get_c("eta", RGB(0.f)), get_c("k", RGB(0.f)), spec, a.x);
    } else {
      m = make_mirror(spec);
      if (a.x > 0.f || a.y > 0.f) set_alpha(m, a.x, a.y);
    }
    if (a.x > 0.f || a.y > 0.f) {
      m.type = MaterialType::kRoughConductor;
      set_alpha(m, a.x, a.y);
    }
  } else if (type == "dielectric") {
    check_keys(c, j, path, {"type", "eta", "roughness", "distribution", "anisotropy_rotation", "anisotropy_texture", "specular", "transmission", "absorption",
                            "normal_map", "bump_map", "opacity", "opacity_cutoff", "vertex_colors"});
    Vec2f a = roughness("roughness");
    m = make_dielectric(positive("eta", get_f("eta", 1.5f)), a.x);
    if (a.x > 0.f || a.y > 0.f) {
      m.type = MaterialType::kRoughDielectric;
      set_alpha(m, a.x, a.y);
    }
    m.specular = get_c("specular", RGB(1.f));
    m.transmission = get_ct("transmission", RGB(1.f));
    m.absorption = get_c("absorption", RGB(0.f));
  } else if (type == "thindielectric") {
    check_keys(c, j, path, {"type", "eta", "specular", "transmission", "normal_map", "bump_map", "opacity", "opacity_cutoff", "vertex_colors"});
    m = make_thin_dielectric(positive("eta", get_f("eta", 1.5f)));
    m.specular = get_c("specular", RGB(1.f));
    m.transmission = get_ct("transmission", RGB(1.f));
  } else if (type == "plastic") {
    check_keys(c, j, path, {"type", "diffuse", "eta", "specular", "roughness", "distribution", "two_sided", "normal_map", "bump_map", "opacity", "opacity_cutoff", "vertex_colors"});
    RGB kd = get_ct("diffuse", RGB(0.5f));
    const float eta = positive("eta", get_f("eta", 1.49f));
    const float alpha = j.contains("roughness") ? num(c, j["roughness"], path + "/roughness") : 0.f;
    if (!(alpha >= 0.f)) c.fail(path + "/roughness", "expected a GGX alpha >= 0 (a number: rough plastic is isotropic)");
    if (alpha > 0.f) {  // material/rough_plastic.h; its tables are computed when the scene is built
      m = make_rough_plastic(kd, eta, alpha, false, get_c("specular", RGB(1.f)));
    } else {
      m = make_plastic(kd, eta, get_c("specular", RGB(1.f)));
    }
  } else if (type == "difftrans") {
    check_keys(c, j, path, {"type", "reflectance", "transmittance", "normal_map", "bump_map", "opacity", "opacity_cutoff", "vertex_colors"});
    RGB r = get_ct("reflectance", RGB(0.f));
    int32_t tex_t = -1;
    const RGB t = j.contains("transmittance")
                      ? color_or_texture(c, j["transmittance"], path + "/transmittance", tex_t)
                      : RGB(0.5f);
    m = make_diffuse_transmission(r, t);
    m.tex_diffuse_transmission_color = tex_t;  // the transmittance's texture (Material::tex_diffuse_transmission_color)
  } else if (type == "phong") {
    check_keys(c, j, path, {"type", "diffuse", "specular", "exponent", "two_sided", "normal_map", "bump_map", "opacity", "opacity_cutoff", "vertex_colors"});
    RGB kd = get_ct("diffuse", RGB(0.1f));
    m = make_phong(kd, get_c("specular", RGB(0.7f)), positive("exponent", get_f("exponent", 90.f)));
  } else if (type == "metallic_roughness") {
    check_keys(c, j, path, {"type", "base_color", "metallic", "roughness", "alpha", "distribution", "anisotropy_rotation", "anisotropy_texture", "transmission",
                            "eta", "absorption", "two_sided", "normal_map", "bump_map", "opacity", "opacity_cutoff",
                            "diffuse_base", "vertex_colors", "clearcoat", "clearcoat_roughness", "clearcoat_normal_map", "specular", "specular_color",
                            "sheen_color", "sheen_roughness", "iridescence", "iridescence_eta",
                            "iridescence_thickness", "iridescence_thickness_min", "diffuse_transmission",
                            "diffuse_transmission_color"});
    RGB base = get_ct("base_color", RGB(0.8f));
    float metallic = unit("metallic", get_f("metallic", 0.f));
    float rough = perceptual_roughness();
    int32_t tex_transmission = -1;
    float transmission = unit_value("transmission", 0.f, tex_transmission);
    m = make_metallic_roughness(base, metallic, rough, transmission, positive("eta", get_f("eta", 1.5f)));
    m.tex_transmission = tex_transmission;
    if (j.contains("alpha")) {
      const Vec2f al = alpha_value(j["alpha"], path + "/alpha");
      set_alpha(m, al.x, al.y);
    }
    m.absorption = get_c("absorption", RGB(0.f));
    if (j.contains("diffuse_base")) {  // material/metallic_roughness.h
      std::string b = str(c, j["diffuse_base"], path + "/diffuse_base");
      if (b == "plastic") m.flags |= kPlasticBase;
      else if (b != "gltf") c.fail(path + "/diffuse_base", "unknown diffuse base '" + b + "' (allowed: gltf, plastic)");
    }
    m.clearcoat = unit_value("clearcoat", 0.f, m.tex_clearcoat);
    const float coat_rough = unit_value("clearcoat_roughness", 0.f, m.tex_clearcoat_roughness);
    m.clearcoat_alpha = coat_rough * coat_rough;
    m.specular_weight = unit_value("specular", 1.f, m.tex_specular);
    if (j.contains("specular_color"))
      m.specular = color_or_texture(c, j["specular_color"], path + "/specular_color", m.tex_specular_color);
    if (j.contains("sheen_color"))
      m.sheen_color = color_or_texture(c, j["sheen_color"], path + "/sheen_color", m.tex_sheen_color);
    if (max_component(m.sheen_color) > 1.f || min_component(m.sheen_color) < 0.f)
      c.fail(path + "/sheen_color", "expected colour values in [0, 1]");
    m.sheen_roughness = unit_value("sheen_roughness", 0.f, m.tex_sheen_roughness);
    // KHR_materials_diffuse_transmission: the diffuse base's transmitted share and its colour.
    m.diffuse_transmission = unit_value("diffuse_transmission", 0.f, m.tex_diffuse_transmission);
    if (j.contains("diffuse_transmission_color"))
      m.transmission = color_or_texture(c, j["diffuse_transmission_color"], path + "/diffuse_transmission_color",
                                        m.tex_diffuse_transmission_color);
    if (max_component(m.transmission) > 1.f || min_component(m.transmission) < 0.f)
      c.fail(path + "/diffuse_transmission_color", "expected colour values in [0, 1]");
    // KHR_materials_iridescence's thin film (material/thin_film.h): weight, IOR, thickness in nm (a number,
    // or a texture whose red channel goes from iridescence_thickness_min to its "scale").
    m.iridescence = unit_value("iridescence", 0.f, m.tex_iridescence);
    m.iridescence_eta = positive("iridescence_eta", get_f("iridescence_eta", 1.3f));
    if (j.contains("iridescence_thickness")) {
      const json& v = j["iridescence_thickness"];
      std::string p = path + "/iridescence_thickness";
      if (is_texture_ref(v)) {
        m.tex_iridescence_thickness = parse_texture(c, v, p, false);
        m.iridescence_thickness = v.is_object() && v.contains("scale") ? num(c, v["scale"], p += "/scale") : 400.f;
      } else if (v.is_object()) {
        c.fail(p, "expected a thickness in nm or a texture ({\"texture\": file, \"scale\": nm})");
      } else {
        m.iridescence_thickness = num(c, v, p);
      }
      if (!(m.iridescence_thickness >= 0.f)) c.fail(p, "expected a thickness >= 0 (nm)");
    }
    m.iridescence_thickness_min = get_f("iridescence_thickness_min", 0.f);
    if (!(m.iridescence_thickness_min >= 0.f)) c.fail(path + "/iridescence_thickness_min", "expected a thickness >= 0 (nm)");
  } else if (type == "principled") {
    // Mitsuba 3's principled BSDF (material/principled.h).
    check_keys(c, j, path, {"type", "base_color", "metallic", "roughness", "anisotropic", "alpha", "anisotropy_rotation",
                            "spec_trans", "eta", "spec_tint", "sheen", "sheen_tint", "flatness", "clearcoat",
                            "clearcoat_gloss", "two_sided", "normal_map", "bump_map", "opacity", "opacity_cutoff",
                            "vertex_colors"});
    RGB base = get_ct("base_color", RGB(0.5f));
    float rough = perceptual_roughness();
    float aniso = unit("anisotropic", get_f("anisotropic", 0.f));
    if (aniso > 0.f && j.contains("alpha")) c.fail(path + "/anisotropic", "give 'anisotropic' or 'alpha', not both");
    m = make_principled(base, 0.f, rough, aniso, 0.f, positive("eta", get_f("eta", 1.5f)));
    if (j.contains("alpha")) {
      const Vec2f al = alpha_value(j["alpha"], path + "/alpha");
      m.alpha_x = al.x;
      m.alpha_y = al.y;
    }
    // Each weight (0 if absent) a number or a texture (its red channel times "scale").
    for (const PrincipledWeight& w : kPrincipledWeights) m.*w.value = unit_value(w.name, 0.f, m.*w.texture);
  } else if (type == "blend" || type == "two_sided") {
    // Two materials by name: a blend's second at a share `weight` of the surface; two_sided's first seen from
    // the front (the side the surface's normal faces) and its second from behind (scene/interaction.h).
    if (type == "blend") check_keys(c, j, path, {"type", "materials", "weight", "opacity", "opacity_cutoff"});
    else check_keys(c, j, path, {"type", "materials", "opacity", "opacity_cutoff"});
    std::string mp = path + "/materials";
    if (!j.contains("materials") || !j["materials"].is_array() || j["materials"].size() != 2)
      c.fail(mp, type == "blend" ? "expected two material names [first, second]" : "expected two material names [front, back]");
    int32_t idx[2];
    for (int k = 0; k < 2; ++k) {
      std::string n = str(c, j["materials"][k], mp + "/" + std::to_string(k));
      auto f = names.find(n);
      if (f == names.end()) c.fail(mp + "/" + std::to_string(k), "unknown material '" + n + "'");
      idx[k] = f->second;
    }
    m.mix_a = idx[0];
    m.mix_b = idx[1];
    if (type == "two_sided") m.flags |= kSides;
    if (j.contains("weight")) {
      const json& v = j["weight"];
      std::string p = path + "/weight";
      if (is_texture_ref(v)) {  // its luminance, times scale
        m.tex_mix = parse_texture(c, v, p, false);
        m.mix_weight = v.is_object() && v.contains("scale") ? num(c, v["scale"], p + "/scale") : 1.f;
        if (!(m.mix_weight >= 0.f && m.mix_weight <= 1.f)) c.fail(p + "/scale", "expected a number in [0, 1]");
      } else {
        if (v.is_object()) c.fail(p, "expected a number in [0, 1] or a texture ({\"texture\": file})");
        m.mix_weight = unit("weight", num(c, v, p));
      }
    }
  } else {
    if (type == "null") {
      // A boundary between media that rays cross unchanged (medium/medium.h).
      check_keys(c, j, path, {"type"});
      m.type = MaterialType::kNull;
      return m;
    }
    c.fail(path + "/type", "unknown material type '" + type + "' (allowed: " + kMaterialTypes + ")");
  }
  if (j.contains("two_sided") && boolean(c, j["two_sided"], path + "/two_sided")) m.flags |= kTwoSided;
  // The rough conductor's and dielectric's microfacet distribution (material/microfacet.h).
  if (j.contains("distribution")) {
    std::string dist = str(c, j["distribution"], path + "/distribution");
    if (dist == "beckmann") m.flags |= kBeckmann;
    else if (dist != "ggx") c.fail(path + "/distribution", "unknown distribution '" + dist + "' (allowed: ggx, beckmann)");
  }
  // The main colour times the mesh's vertex colours (material.h: kVertexColor).
  if (j.contains("vertex_colors") && boolean(c, j["vertex_colors"], path + "/vertex_colors")) m.flags |= kVertexColor;
  if (j.contains("anisotropy_rotation")) {  // degrees from dp/du towards dp/dv (scene/shading.h)
    m.aniso_rotation = float(numd(c, j["anisotropy_rotation"], path + "/anisotropy_rotation") * kPiD / 180.0);
  }
  if (j.contains("anisotropy_texture")) {  // glTF's anisotropyTexture: RG direction, B strength (material.h)
    const json& v = j["anisotropy_texture"];
    std::string p = path + "/anisotropy_texture";
    if (!is_texture_ref(v)) c.fail(p, "expected a texture (a file name or {\"texture\": file})");
    if (v.is_object() && v.contains("scale")) c.fail(p + "/scale", "unknown key (the texture's blue channel scales the strength)");
    if (m.alpha_x == m.alpha_y) c.fail(p, "needs anisotropic roughness ([alpha_x, alpha_y] with alpha_x != alpha_y)");
    m.tex_aniso = parse_texture(c, v, p, false);
  }
  m.tex_color = tex_color;
  m.tex_roughness = tex_rough;
  // A tangent-space normal map (linear) with its optional `scale`; extra_key: one more key the caller reads.
  auto normal_map = [&](const char* key, int32_t& tex, float& scale, const char* extra_key) {
    const json& v = j[key];
    const std::string p = path + "/" + key;
    if (!is_texture_ref(v)) c.fail(p, "expected a texture (a file name or {\"texture\": file, \"scale\": s})");
    tex = parse_texture(c, v, p, false, extra_key);
    if (v.is_object() && v.contains("scale")) scale = num(c, v["scale"], p + "/scale");
  };
  if (j.contains("clearcoat_normal_map"))  // metallic_roughness only (its check_keys)
    normal_map("clearcoat_normal_map", m.tex_clearcoat_normal, m.clearcoat_normal_scale, nullptr);
  if (j.contains("normal_map") && j.contains("bump_map")) c.fail(path + "/bump_map", "give normal_map or bump_map, not both");
  if (j.contains("normal_map")) {
    normal_map("normal_map", m.tex_normal, m.normal_scale, "bitangent");
    const json& v = j["normal_map"];
    const std::string p = path + "/normal_map";
    if (v.is_object() && v.contains("bitangent")) {
      // "uv": the y axis along dp/dv (mirrored UVs mirror the map: MikkTSpace, glTF); "cross": n x dp/du
      // (Mitsuba 3, pbrt-v4).
      std::string b = str(c, v["bitangent"], p + "/bitangent");
      if (b == "cross") m.flags |= kNormalMapCross;
      else if (b != "uv") c.fail(p + "/bitangent", "unknown bitangent '" + b + "' (allowed: uv, cross)");
    }
  }
  if (j.contains("bump_map")) {
    // A height map: its luminance times `scale` (scene units) is the height along the normal.
    const json& v = j["bump_map"];
    std::string p = path + "/bump_map";
    if (!is_texture_ref(v)) c.fail(p, "expected a texture (a file name or {\"texture\": file, \"scale\": s})");
    m.tex_bump = parse_texture(c, v, p, false);
    if (v.is_object() && v.contains("scale")) m.bump_scale = num(c, v["scale"], p + "/scale");
  }
  auto unit01 = [&](const json& v, const std::string& p) {
    float x = num(c, v, p);
    if (x < 0.f || x > 1.f) c.fail(p, "expected a number in [0, 1]");
    return x;
  };
  if (j.contains("opacity")) {
    // Cut-outs (scene/opacity.h): a number, or a texture whose alpha channel (or luminance) times `scale`.
    const json& v = j["opacity"];
    std::string p = path + "/opacity";
    if (is_texture_ref(v)) {
      m.tex_opacity = parse_texture(c, v, p, false, "channel");
      std::string ch = v.is_object() && v.contains("channel") ? str(c, v["channel"], p + "/channel") : "auto";
      if (ch != "auto" && ch != "alpha" && ch != "luminance")
        c.fail(p + "/channel", "unknown channel '" + ch + "' (allowed: alpha, luminance, auto)");
      if (ch == "luminance" || (ch == "auto" && !texture_has_alpha(c.d->textures[m.tex_opacity])))
        m.flags |= kOpacityLuminance;
      if (v.is_object() && v.contains("scale")) m.opacity = unit01(v["scale"], p + "/scale");
    } else {
      if (v.is_object()) c.fail(p, "expected a number in [0, 1] or a texture ({\"texture\": file})");
      m.opacity = unit01(v, p);
    }
  }
  if (j.contains("opacity_cutoff")) {
    if (!j.contains("opacity")) c.fail(path + "/opacity_cutoff", "needs \"opacity\" (a number or a texture)");
    m.opacity_cutoff = unit01(j["opacity_cutoff"], path + "/opacity_cutoff");
  }
  return m;
}

// ---------------------------------------------------------------- meshes

MeshDesc parse_mesh_data(const Ctx& c, const json& j, const std::string& p) {
  MeshDesc m;
  if (!j.contains("positions") || !j["positions"].is_array() || j["positions"].empty())
    c.fail(p + "/positions", "expected a non-empty array of [x,y,z] points");
  const json& P = j["positions"];
  m.positions.reserve(P.size());
  for (size_t k = 0; k < P.size(); ++k) m.positions.push_back(point3(c, P[k], p + "/positions/" + std::to_string(k)));
  if (!j.contains("indices") || !j["indices"].is_array() || j["indices"].size() % 3 != 0 || j["indices"].empty())
    c.fail(p + "/indices", "expected a flat array of vertex indices, 3 per triangle");
  const json& I = j["indices"];
  m.indices.reserve(I.size());
  for (size_t k = 0; k < I.size(); ++k) {
    int64_t v = integer64(c, I[k], p + "/indices/" + std::to_string(k));
    if (v < 0 || size_t(v) >= m.positions.size())
      c.fail(p + "/indices/" + std::to_string(k), "vertex index " + std::to_string(v) + " out of range (" +
                                                        std::to_string(m.positions.size()) + " positions)");
    m.indices.push_back(uint32_t(v));
  }
  if (j.contains("normals")) {
    const json& N = j["normals"];
    if (!N.is_array() || N.size() != m.positions.size()) c.fail(p + "/normals", "expected one normal [x,y,z] per position");
    for (size_t k = 0; k < N.size(); ++k) m.normals.push_back(point3(c, N[k], p + "/normals/" + std::to_string(k)));
  }
  if (j.contains("uvs")) {
    const json& U = j["uvs"];
    if (!U.is_array() || U.size() != m.positions.size()) c.fail(p + "/uvs", "expected one [u,v] per position");
    for (size_t k = 0; k < U.size(); ++k) m.uvs.push_back(vec2(c, U[k], p + "/uvs/" + std::to_string(k), false));
  }
  if (j.contains("colors")) {  // linear RGB per vertex, >= 0 (materials with "vertex_colors": true use them)
    const json& C = j["colors"];
    if (!C.is_array() || C.size() != m.positions.size()) c.fail(p + "/colors", "expected one colour [r,g,b] per position");
    for (size_t k = 0; k < C.size(); ++k) {
      const std::string cp = p + "/colors/" + std::to_string(k);
      Vec3f v = point3(c, C[k], cp);
      if (!(v.x >= 0.f && v.y >= 0.f && v.z >= 0.f)) c.fail(cp, "expected a colour with components >= 0");
      m.colors.push_back(RGB(v.x, v.y, v.z));
    }
  }
  if (j.contains("tangents")) {
    // [tx, ty, tz, w]: the tangent along +u and the handedness w = 1 or -1 (bitangent w * cross(n, t); glTF's
    // TANGENT), or [0, 0, 0, 0] for a vertex without one.
    const json& T = j["tangents"];
    if (!T.is_array() || T.size() != m.positions.size())
      c.fail(p + "/tangents", "expected one tangent [tx,ty,tz,w] per position");
    for (size_t k = 0; k < T.size(); ++k) {
      std::string tp = p + "/tangents/" + std::to_string(k);
      if (!T[k].is_array() || T[k].size() != 4) c.fail(tp, "expected an array of 4 numbers [tx,ty,tz,w]");
      Vec3f t(num(c, T[k][0], tp + "/0"), num(c, T[k][1], tp + "/1"), num(c, T[k][2], tp + "/2"));
      float w = num(c, T[k][3], tp + "/3");
      if (w == 0.f && length_sq(t) == 0.f) {
        m.tangents.push_back(Tangent{});
        continue;
      }
      if (w != 1.f && w != -1.f) c.fail(tp + "/3", "expected the handedness 1 or -1 (or [0,0,0,0]: no tangent)");
      float l2 = length_sq(t);
      if (!(l2 > 0.f) || !std::isfinite(l2)) c.fail(tp, "expected a non-zero tangent");
      m.tangents.push_back(Tangent{t / std::sqrt(l2), w});
    }
  }
  return m;
}

// Runs a mesh-file loader; its errors get the scene file and JSON path in front.
template <typename F>
auto with_file_context(const Ctx& c, const std::string& jpath, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const InputError& e) {
    std::string w = e.what();
    if (w.rfind(c.source + ":", 0) == 0) throw;
    c.fail(jpath, w);
  }
}

std::string checked_file(const Ctx& c, const json& j, const std::string& jpath, std::string* ext_out) {
  std::string file = str(c, j, jpath);
  std::string full = c.resolve(file);
  std::string ext = fs::path(file).extension().string();
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".obj" && ext != ".ply")
    c.fail(jpath, "unsupported mesh file '" + file + "' (allowed: .obj, .ply)");
  std::error_code ec;
  if (!fs::is_regular_file(full, ec))
    c.fail(jpath, "mesh file '" + file + "' does not exist" + (full != file ? " (looked for " + full + ")" : ""));
  *ext_out = ext;
  return full;
}

// A mesh file as parts. OBJ shapes are appended by the loader and moved out of desc.shapes.
std::vector<MeshPart> load_mesh_file_parts(Ctx& c, const json& j, const std::string& jpath, const std::string& name) {
  SceneDesc& d = *c.d;
  std::string ext;
  std::string full = checked_file(c, j, jpath, &ext);
  std::vector<MeshPart> parts;
  if (ext == ".ply") {
    MeshDesc m = with_file_context(c, jpath, [&] { return load_ply_mesh(full, &d.warnings); });
    if (m.name.empty()) m.name = name;
    d.meshes.push_back(std::move(m));
    parts.push_back({name, int(d.meshes.size()) - 1});
    return parts;
  }
  size_t first = d.shapes.size();
  std::vector<int> added = with_file_context(c, jpath, [&] { return append_obj(d, full, Affine(), -1, c.source); });
  for (int i : added) {
    const ShapeDesc& s = d.shapes[i];
    parts.push_back({s.name, s.mesh, s.material, s.emission, s.emission_texture, s.emission_two_sided});
  }
  d.shapes.resize(first);
  return parts;
}

// ---------------------------------------------------------------- media

// A grid's placement keys (docs/scene-format.md#media) in object j at p, applied to g where given: "bounds"
// ([lo, hi]) places the grid's unit cube onto that box; "transform" places the unit cube in the world or, for
// a grid from an OpenVDB file (`vdb`, whose to_world is already the file's own placement), moves the file's
// world space into the scene.
void parse_grid_box(const Ctx& c, const json& j, const std::string& p, MediumGridDesc& g, bool vdb) {
  if (j.contains("bounds") && j.contains("transform")) c.fail(p, "give \"bounds\" or \"transform\", not both");
  if (j.contains("bounds")) {
    const json& b = j["bounds"];
    if (!b.is_array() || b.size() != 2) c.fail(p + "/bounds", "expected [[x0, y0, z0], [x1, y1, z1]]");
    const Vec3f lo = point3(c, b[0], p + "/bounds/0"), hi = point3(c, b[1], p + "/bounds/1");
    if (!(hi.x > lo.x && hi.y > lo.y && hi.z > lo.z)) c.fail(p + "/bounds", "expected the second corner above the first on every axis");
    g.to_world = Affine();
    for (int i = 0; i < 3; ++i) {
      g.to_world.m[i][i] = hi[i] - lo[i];
      g.to_world.m[i][3] = lo[i];
    }
  } else if (j.contains("transform")) {
    const Affine t = parse_transform(c, j["transform"], p + "/transform");
    g.to_world = vdb ? mul(t, g.to_world) : t;
  }
}

// A grid's lookup keys in object j at p, applied to g where given: "filter" trilinear or nearest; "outside"
// zero or clamp.
void parse_grid_lookup(const Ctx& c, const json& j, const std::string& p, MediumGridDesc& g) {
  if (j.contains("filter")) {
    const std::string f = str(c, j["filter"], p + "/filter");
    if (f == "nearest") g.nearest = true;
    else if (f == "trilinear") g.nearest = false;
    else c.fail(p + "/filter", "unknown filter '" + f + "' (allowed: trilinear, nearest)");
  }
  if (j.contains("outside")) {
    const std::string o = str(c, j["outside"], p + "/outside");
    if (o == "clamp") g.clamp = true;
    else if (o == "zero") g.clamp = false;
    else c.fail(p + "/outside", "unknown value '" + o + "' (allowed: zero, clamp)");
  }
}

// An emission grid of temperatures made a colour emission grid (scene/blackbody.h): each sample v becomes
// scale * blackbody_rgb((v - temperature_offset) * temperature_scale), the keys of object j at p (defaults 1,
// 0 and 1; pbrt-v4's Lescale, temperaturecutoff and temperaturescale).
void apply_blackbody(const Ctx& c, const json& j, const std::string& p, MediumGridDesc& g) {
  if (!j.is_object()) c.fail(p, std::string("expected an object, got ") + type_name(j));
  check_keys(c, j, p, {"scale", "temperature_offset", "temperature_scale"});
  auto number = [&](const char* k, float dflt) {
    const float v = j.contains(k) ? num(c, j[k], p + "/" + k) : dflt;
    if (!std::isfinite(v)) c.fail(p + "/" + k, "expected a finite number");
    return v;
  };
  const float scale = number("scale", 1.f), offset = number("temperature_offset", 0.f);
  const float tscale = number("temperature_scale", 1.f);
  if (!(scale >= 0.f)) c.fail(p + "/scale", "expected a number >= 0");
  if (!(tscale > 0.f)) c.fail(p + "/temperature_scale", "expected a number > 0");
  if (g.channels != 1) c.fail(p, "expected a grid of one channel (temperatures)");
  std::vector<float> rgb(g.values.size() * 3);
  for (size_t i = 0; i < g.values.size(); ++i) {
    const RGB e = blackbody_rgb(double(g.values[i] - offset) * double(tscale)) * scale;
    for (int k = 0; k < 3; ++k) rgb[i * 3 + size_t(k)] = e[k];
  }
  g.values = std::move(rgb);
  g.channels = 3;
}

// A heterogeneous medium's grid, key `key` ("density", "albedo" or "emission") of medium j at p: {"file": a
// Mitsuba .vol file, or an OpenVDB .vdb file with "grid": the grid's name (default: the key)} or
// {"resolution": [nx, ny, nz], "values": [nx * ny * nz * channels numbers, x fastest, channels innermost],
// "channels": 1 or 3}, its samples in [0, max_value]; placed by the medium's placement keys, which the
// grid's own override (parse_grid_box, parse_grid_lookup). Appended to c.d->grids; returns its index.
int parse_medium_grid(const Ctx& c, const json& j, const std::string& p, const char* key, float max_value) {
  const json& dj = j[key];
  const std::string dp = p + "/" + key;
  const std::string what = max_value < 1e30f ? "an albedo" : std::string(key) == "emission" ? "a radiance" : "a density";
  if (!dj.is_object())
    c.fail(dp, std::string("expected an object ({\"file\": ...} or {\"resolution\": ..., \"values\": ...}), got ") +
                   type_name(dj));
  if (std::string(key) == "emission")
    check_keys(c, dj, dp, {"file", "grid", "resolution", "values", "channels", "bounds", "transform", "filter",
                           "outside", "blackbody"});
  else
    check_keys(c, dj, dp, {"file", "grid", "resolution", "values", "channels", "bounds", "transform", "filter",
                           "outside"});
  MediumGridDesc g;
  auto check_range = [&](float v, const std::string& vp) {
    if (!(v >= 0.f && v <= max_value))
      c.fail(vp, "expected " + what + (max_value < 1e30f ? " in [0, 1]" : " >= 0"));
  };
  bool vdb = false;
  if (dj.contains("file")) {
    if (dj.contains("resolution") || dj.contains("values") || dj.contains("channels"))
      c.fail(dp, "give \"file\", or \"resolution\" and \"values\", not both");
    const std::string file = str(c, dj["file"], dp + "/file");
    std::string ext = fs::path(file).extension().string();
    for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    vdb = ext == ".vdb";
    if (dj.contains("grid") && !vdb) c.fail(dp + "/grid", "applies to an OpenVDB file (.vdb)");
    const std::string referrer = c.source + ": " + dp + "/file";
    if (vdb)
      g = read_vdb_grid(c.resolve(file), referrer, dj.contains("grid") ? str(c, dj["grid"], dp + "/grid") : key);
    else
      g = read_vol_grid(c.resolve(file), referrer);
    for (size_t i = 0; i < g.values.size(); ++i)
      if (!(g.values[i] <= max_value))
        c.fail(dp + "/file", "grid '" + g.name + "': sample " + std::to_string(i) + " is " +
                                 std::to_string(g.values[i]) + " (expected " + what + " in [0, 1])");
  } else {
    if (!dj.contains("resolution") || !dj.contains("values"))
      c.fail(dp, "expected {\"file\": \"grid.vol\"} or {\"resolution\": [nx, ny, nz], \"values\": [...]}");
    if (dj.contains("grid")) c.fail(dp + "/grid", "applies to an OpenVDB file (.vdb)");
    const json& r = dj["resolution"];
    if (!r.is_array() || r.size() != 3) c.fail(dp + "/resolution", "expected [nx, ny, nz]");
    int n[3];
    for (int k = 0; k < 3; ++k) {
      const std::string rp = dp + "/resolution/" + std::to_string(k);
      if (!r[k].is_number_integer() || r[k].get<int64_t>() < 1 || r[k].get<int64_t>() > (1 << 16))
        c.fail(rp, "expected an integer in [1, 65536]");
      n[k] = int(r[k].get<int64_t>());
    }
    g.nx = n[0];
    g.ny = n[1];
    g.nz = n[2];
    if (dj.contains("channels")) {
      const json& ch = dj["channels"];
      if (!ch.is_number_integer() || (ch.get<int64_t>() != 1 && ch.get<int64_t>() != 3))
        c.fail(dp + "/channels", "expected 1 or 3");
      g.channels = int(ch.get<int64_t>());
    }
    const json& v = dj["values"];
    const size_t count = size_t(n[0]) * size_t(n[1]) * size_t(n[2]) * size_t(g.channels);
    if (!v.is_array()) c.fail(dp + "/values", std::string("expected a list of numbers, got ") + type_name(v));
    if (v.size() != count)
      c.fail(dp + "/values", "expected " + std::to_string(count) + " numbers (" + std::to_string(n[0]) + " x " +
                                 std::to_string(n[1]) + " x " + std::to_string(n[2]) +
                                 (g.channels > 1 ? " x " + std::to_string(g.channels) + " channels" : std::string()) +
                                 "), got " + std::to_string(v.size()));
    g.values.resize(count);
    for (size_t i = 0; i < count; ++i) {
      const std::string vp = dp + "/values/" + std::to_string(i);
      g.values[i] = num(c, v[i], vp);
      check_range(g.values[i], vp);
    }
    g.name = "grid@" + c.source + ":" + dp;
  }
  if (dj.contains("blackbody")) apply_blackbody(c, dj["blackbody"], dp + "/blackbody", g);
  // The grid's own bounds/transform replace the medium's; filter and outside override it one by one.
  if (dj.contains("bounds") || dj.contains("transform")) parse_grid_box(c, dj, dp, g, vdb);
  else parse_grid_box(c, j, p, g, vdb);
  parse_grid_lookup(c, j, p, g);
  parse_grid_lookup(c, dj, dp, g);
  c.d->grids.push_back(std::move(g));
  return int(c.d->grids.size()) - 1;
}

// A medium: sigma_a and sigma_s, or sigma_t and albedo (Mitsuba's parameters), times scale; g the
// Henyey-Greenstein asymmetry; homogeneous, or heterogeneous with a density grid (parse_medium_grid) that
// multiplies the coefficients and optionally an albedo grid.
Medium parse_medium(const Ctx& c, const json& j, const std::string& p) {
  if (!j.is_object()) c.fail(p, std::string("expected an object, got ") + type_name(j));
  bool grid = false;
  if (j.contains("type")) {
    std::string t = str(c, j["type"], p + "/type");
    if (t == "heterogeneous") grid = true;
    else if (t != "homogeneous") c.fail(p + "/type", "unknown medium type '" + t + "' (allowed: homogeneous, heterogeneous)");
  }
  if (grid)
    check_keys(c, j, p, {"type", "sigma_a", "sigma_s", "sigma_t", "albedo", "scale", "g", "emission", "density",
                         "bounds", "transform", "filter", "outside"});
  else
    check_keys(c, j, p, {"type", "sigma_a", "sigma_s", "sigma_t", "albedo", "scale", "g", "emission"});
  Medium m;
  const bool as = j.contains("sigma_a") || j.contains("sigma_s");
  const bool ta = j.contains("sigma_t") || j.contains("albedo");
  if (as && ta) c.fail(p, "give sigma_a and sigma_s, or sigma_t and albedo, not both pairs");
  if (!as && !ta) c.fail(p, "expected sigma_a and sigma_s, or sigma_t and albedo");
  // An albedo grid (a heterogeneous medium's "albedo" given as a grid object): sigma_s(x) = albedo(x)
  // sigma_t(x), so the constant coefficients only carry sigma_t (Medium::albedo_grid).
  const bool albedo_grid = j.contains("albedo") && j["albedo"].is_object();
  if (albedo_grid && !grid)
    c.fail(p + "/albedo", "an albedo grid needs \"type\": \"heterogeneous\" (give a colour or a number here)");
  if (as) {
    m.sigma_a = j.contains("sigma_a") ? color(c, j["sigma_a"], p + "/sigma_a") : RGB(0.f);
    m.sigma_s = j.contains("sigma_s") ? color(c, j["sigma_s"], p + "/sigma_s") : RGB(0.f);
  } else {
    RGB st = j.contains("sigma_t") ? color(c, j["sigma_t"], p + "/sigma_t") : RGB(1.f);
    RGB al = albedo_grid ? RGB(1.f) : j.contains("albedo") ? color(c, j["albedo"], p + "/albedo") : RGB(0.75f);
    if (al.x > 1.f || al.y > 1.f || al.z > 1.f) c.fail(p + "/albedo", "expected values in [0, 1]");
    m.sigma_s = st * al;
    m.sigma_a = st - m.sigma_s;
  }
  if (j.contains("scale")) {
    float sc = num(c, j["scale"], p + "/scale");
    if (!(sc >= 0.f)) c.fail(p + "/scale", "expected a number >= 0");
    m.sigma_a *= sc;
    m.sigma_s *= sc;
  }
  // Emission: a colour (radiance; the medium adds sigma_a Le per unit length), or for a heterogeneous medium a
  // grid of it (one or three channels >= 0).
  const bool emission_grid = j.contains("emission") && j["emission"].is_object();
  if (emission_grid && !grid)
    c.fail(p + "/emission", "an emission grid needs \"type\": \"heterogeneous\" (give a colour or a number here)");
  if (j.contains("emission")) m.Le = emission_grid ? RGB(1.f) : color(c, j["emission"], p + "/emission");
  if (j.contains("g")) m.g = num(c, j["g"], p + "/g");
  if (!(m.g > -1.f && m.g < 1.f)) c.fail(p + "/g", "expected a number in (-1, 1)");
  if (grid) {
    if (!j.contains("density")) c.fail(p, "a heterogeneous medium needs \"density\" (a grid)");
    m.grid = parse_medium_grid(c, j, p, "density", std::numeric_limits<float>::infinity());
    if (albedo_grid) m.albedo_grid = parse_medium_grid(c, j, p, "albedo", 1.f);
    if (emission_grid) m.emission_grid = parse_medium_grid(c, j, p, "emission", std::numeric_limits<float>::infinity());
  }
  return m;
}

// The index of the medium a "medium", "interior" or "exterior" key names (null: vacuum, -1).
int medium_ref(const Ctx& c, const json& j, const std::string& p) {
  if (j.is_null()) return -1;  // vacuum
  std::string n = str(c, j, p);
  for (size_t i = 0; i < c.d->medium_names.size(); ++i)
    if (c.d->medium_names[i] == n) return int(i);
  std::string list;
  for (const std::string& m : c.d->medium_names) list += (list.empty() ? "" : ", ") + m;
  c.fail(p, "no medium named '" + n + "' in /media (media: " + (list.empty() ? std::string("none") : list) + ")");
}

// ---------------------------------------------------------------- cameras

void parse_camera(const Ctx& c, const json& j, const std::string& path, CameraDesc& cam) {
  check_keys(c, j, path, {"name", "type", "position", "target", "up", "fov", "view_size", "fov_axis", "width", "height",
                          "aperture_radius", "focus_distance", "flip_x", "motion", "shutter_open", "shutter_close",
                          "medium", "near_clip", "far_clip", "principal_point"});
  if (j.contains("medium")) cam.medium = medium_ref(c, j["medium"], path + "/medium");
  if (j.contains("name")) cam.name = str(c, j["name"], path + "/name");
  if (j.contains("type")) {
    std::string t = str(c, j["type"], path + "/type");
    if (t == "orthographic") cam.orthographic = true;
    else if (t != "perspective") c.fail(path + "/type", "unknown camera type '" + t + "' (allowed: perspective, orthographic)");
  }
  if (cam.orthographic) {
    for (const char* k : {"fov", "aperture_radius", "focus_distance"})
      if (j.contains(k))
        c.fail(path + "/" + k, std::string("applies to a perspective camera (an orthographic one takes view_size)"));
    if (j.contains("view_size")) cam.view_size = num(c, j["view_size"], path + "/view_size");
    if (!(cam.view_size > 0.f && std::isfinite(cam.view_size)))
      c.fail(path + "/view_size", "expected the view's width in scene units (> 0)");
  } else if (j.contains("view_size")) {
    c.fail(path + "/view_size", "applies to an orthographic camera (\"type\": \"orthographic\")");
  }
  if (j.contains("position")) cam.position = point3(c, j["position"], path + "/position");
  if (j.contains("target")) cam.target = point3(c, j["target"], path + "/target");
  if (j.contains("up")) cam.up = point3(c, j["up"], path + "/up");
  if (j.contains("fov")) cam.fov_degrees = num(c, j["fov"], path + "/fov");
  if (!(cam.fov_degrees > 0.f && cam.fov_degrees < 180.f)) c.fail(path + "/fov", "expected degrees in (0, 180)");
  if (j.contains("fov_axis")) {
    std::string a = str(c, j["fov_axis"], path + "/fov_axis");
    if (a == "x") cam.fov_axis = CameraDesc::FovAxis::kX;
    else if (a == "y") cam.fov_axis = CameraDesc::FovAxis::kY;
    else if (a == "smaller") cam.fov_axis = CameraDesc::FovAxis::kSmaller;
    else c.fail(path + "/fov_axis", "unknown axis '" + a + "' (allowed: x, y, smaller)");
  }
  if (j.contains("width")) cam.width = integer(c, j["width"], path + "/width");
  if (j.contains("height")) cam.height = integer(c, j["height"], path + "/height");
  if (cam.width <= 0 || cam.height <= 0) c.fail(path, "width and height must be positive integers");
  if (j.contains("aperture_radius")) cam.aperture_radius = num(c, j["aperture_radius"], path + "/aperture_radius");
  if (cam.aperture_radius < 0.f) c.fail(path + "/aperture_radius", "expected a radius >= 0");
  if (j.contains("focus_distance")) cam.focus_distance = num(c, j["focus_distance"], path + "/focus_distance");
  if (cam.focus_distance < 0.f) c.fail(path + "/focus_distance", "expected a distance >= 0 (0: the distance to the target)");
  if (j.contains("flip_x")) cam.flip_x = boolean(c, j["flip_x"], path + "/flip_x");
  if (j.contains("principal_point")) {
    const json& pp = j["principal_point"];
    if (!pp.is_array() || pp.size() != 2)
      c.fail(path + "/principal_point", "expected [x, y]: the offset as fractions of the film's width and height");
    cam.principal_point = Vec2f(num(c, pp[0], path + "/principal_point/0"), num(c, pp[1], path + "/principal_point/1"));
    if (!std::isfinite(cam.principal_point.x) || !std::isfinite(cam.principal_point.y))
      c.fail(path + "/principal_point", "expected finite offsets");
  }
  if (j.contains("near_clip")) cam.near_clip = num(c, j["near_clip"], path + "/near_clip");
  if (!(cam.near_clip >= 0.f && std::isfinite(cam.near_clip)))
    c.fail(path + "/near_clip", "expected a depth >= 0 along the view axis");
  if (j.contains("far_clip")) cam.far_clip = num(c, j["far_clip"], path + "/far_clip");
  if (!(cam.far_clip > cam.near_clip))
    c.fail(path + "/far_clip", "expected a depth along the view axis beyond near_clip");
  if (length(cam.target - cam.position) == 0.f) c.fail(path + "/target", "must differ from the position");
  if (length(cross(cam.target - cam.position, cam.up)) == 0.f) c.fail(path + "/up", "must not be parallel to the view direction");
  // Motion blur: "motion" is the pose at time 1 (keys left out keep their time-0 value).
  if (j.contains("motion")) {
    const std::string mp = path + "/motion";
    const json& m = j["motion"];
    if (!m.is_object()) c.fail(mp, "expected an object with the camera's position, target and up at time 1");
    check_keys(c, m, mp, {"position", "target", "up"});
    cam.moving = true;
    cam.position1 = m.contains("position") ? point3(c, m["position"], mp + "/position") : cam.position;
    cam.target1 = m.contains("target") ? point3(c, m["target"], mp + "/target") : cam.target;
    cam.up1 = m.contains("up") ? point3(c, m["up"], mp + "/up") : cam.up;
    if (length(cam.target1 - cam.position1) == 0.f) c.fail(mp + "/target", "must differ from the position");
    if (length(cross(cam.target1 - cam.position1, cam.up1)) == 0.f)
      c.fail(mp + "/up", "must not be parallel to the view direction");
  }
  if (j.contains("shutter_open")) cam.shutter_open = num(c, j["shutter_open"], path + "/shutter_open");
  if (j.contains("shutter_close")) cam.shutter_close = num(c, j["shutter_close"], path + "/shutter_close");
  if (!(cam.shutter_open >= 0.f && cam.shutter_open <= 1.f))
    c.fail(path + "/shutter_open", "expected a time in [0, 1] (0: the camera's pose, 1: its \"motion\" pose)");
  if (!(cam.shutter_close >= cam.shutter_open && cam.shutter_close <= 1.f))
    c.fail(path + "/shutter_close", "expected a time in [shutter_open, 1]");
}

// A pixel filter: a name (the type's defaults) or {"type", and its parameters}: "radius" (every type),
// "stddev" (gaussian), "B" and "C" (mitchell), "lobes" (lanczos).
Filter parse_filter(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_object()) {
    const std::string name = str(c, j, path);
    try {
      return filter_by_name(name);
    } catch (const InputError& e) {
      c.fail(path, e.what());
    }
  }
  if (!j.contains("type")) c.fail(path, "a filter object needs a \"type\" (" + std::string(kFilterNames) + ")");
  const std::string type = str(c, j["type"], path + "/type");
  auto opt = [&](const char* key) { return j.contains(key) ? num(c, j[key], path + "/" + key) : kFilterDefault; };
  const float radius = opt("radius");
  FilterType t;
  float a = kFilterDefault, b = kFilterDefault;
  if (type == "box" || type == "tent") {
    check_keys(c, j, path, {"type", "radius"});
    t = type == "box" ? FilterType::kBox : FilterType::kTent;
  } else if (type == "gaussian") {
    check_keys(c, j, path, {"type", "radius", "stddev"});
    t = FilterType::kGaussian;
    a = opt("stddev");
  } else if (type == "mitchell") {
    check_keys(c, j, path, {"type", "radius", "B", "C"});
    t = FilterType::kMitchell;
    a = opt("B");
    b = opt("C");
  } else if (type == "catmullrom") {
    check_keys(c, j, path, {"type", "radius"});
    t = FilterType::kMitchell;
    a = 0.f;
    b = 0.5f;
  } else if (type == "lanczos") {
    check_keys(c, j, path, {"type", "radius", "lobes"});
    t = FilterType::kLanczos;
    a = opt("lobes");
  } else {
    c.fail(path + "/type", "unknown filter '" + type + "' (allowed: " + kFilterNames + ")");
  }
  try {
    return make_filter(t, radius, a, b);
  } catch (const InputError& e) {
    c.fail(path, e.what());
  }
}

int parse_max_depth(const Ctx& c, const json& j, const std::string& path) {
  int v = integer(c, j, path);
  if (v == 0 || v < -1) c.fail(path, "expected a positive integer or -1 (unlimited)");
  return v;
}

void parse_integrator(const Ctx& c, const json& j, SceneDesc& d) {
  const std::string p = "/integrator";
  check_keys(c, j, p, {"type", "spp", "time", "max_depth", "rr_depth", "sampler", "photons", "radius", "alpha", "k",
                       "photon_sampling", "restir_candidates", "restir_neighbors", "restir_radius",
                       "restir_history", "light_sampler", "hide_emitters"});
  SceneDesc::IntegratorDefaults& in = d.integrator;
  if (j.contains("hide_emitters")) in.hide_emitters = boolean(c, j["hide_emitters"], p + "/hide_emitters") ? 1 : 0;
  if (j.contains("type")) {
    in.type = str(c, j["type"], p + "/type");
    std::string list;
    bool known = false;
    for (const std::string& n : integrator_names()) {
      known |= n == in.type;
      list += (list.empty() ? "" : ", ") + n;
    }
    if (!known) c.fail(p + "/type", "unknown integrator '" + in.type + "' (allowed: " + list + ")");
  }
  auto pos_int = [&](const char* k) -> int64_t {
    if (!j.contains(k)) return 0;
    int64_t v = integer64(c, j[k], p + "/" + k);
    if (v <= 0) c.fail(p + "/" + k, "expected a positive integer");
    return v;
  };
  in.spp = pos_int("spp");
  in.photons = pos_int("photons");
  int64_t rr = pos_int("rr_depth"), k = pos_int("k");
  if (rr > 1000000 || k > 1000000) c.fail(p, "rr_depth and k must be below 1000000");
  in.rr_depth = int(rr);
  in.k = int(k);
  if (j.contains("time")) {
    in.time = numd(c, j["time"], p + "/time");
    if (!(in.time > 0.0)) c.fail(p + "/time", "expected a positive number of seconds");
  }
  if (j.contains("max_depth")) d.max_depth = parse_max_depth(c, j["max_depth"], p + "/max_depth");
  if (j.contains("sampler")) {
    in.sampler = str(c, j["sampler"], p + "/sampler");
    if (in.sampler != "sobol" && in.sampler != "independent")
      c.fail(p + "/sampler", "unknown sampler '" + in.sampler + "' (allowed: sobol, independent)");
  }
  if (j.contains("radius")) {
    in.radius = num(c, j["radius"], p + "/radius");
    if (!(in.radius > 0.f)) c.fail(p + "/radius", "expected a positive radius");
  }
  if (j.contains("alpha")) {
    in.alpha = num(c, j["alpha"], p + "/alpha");
    if (!(in.alpha > 0.f && in.alpha < 1.f)) c.fail(p + "/alpha", "expected a number in (0, 1)");
  }
  if (j.contains("photon_sampling")) {
    in.photon_sampling = str(c, j["photon_sampling"], p + "/photon_sampling");
    if (in.photon_sampling != "uniform" && in.photon_sampling != "adaptive")
      c.fail(p + "/photon_sampling", "unknown photon sampling '" + in.photon_sampling + "' (allowed: uniform, adaptive)");
  }
  if (j.contains("light_sampler")) {
    const std::string kp = p + "/light_sampler";
    in.light_sampler = str(c, j["light_sampler"], kp);
    if (in.light_sampler != "power" && in.light_sampler != "bvh")
      c.fail(kp, "unknown light sampler '" + in.light_sampler + "' (allowed: power, bvh)");
    if (!in.type.empty() && !light_sampler_applies(in.type))
      c.fail(kp, "applies to integrators " + light_sampler_integrators() + ", but /integrator/type is '" + in.type +
                     "'");
  }
  // restir's options (RenderOptions::restir_*; their ranges are restir_option_expected's).
  for (const char* name : {"candidates", "neighbors", "radius", "history"}) {
    const std::string key = std::string("restir_") + name, kp = p + "/" + key;
    if (!j.contains(key)) continue;
    if (!in.type.empty() && in.type != "restir")
      c.fail(kp, "applies to integrator 'restir', but /integrator/type is '" + in.type + "'");
    double v = numd(c, j[key], kp);
    std::string expected = restir_option_expected(name, v);
    if (!expected.empty()) c.fail(kp, "expected " + expected);
    if (key == "restir_candidates") in.restir_candidates = int(v);
    else if (key == "restir_neighbors") in.restir_neighbors = int(v);
    else if (key == "restir_radius") in.restir_radius = float(v);
    else in.restir_history = float(v);
  }
}

// ---------------------------------------------------------------- lights

Light parse_light(Ctx& c, const json& j, const std::string& p, SceneDesc& d) {
  if (!j.is_object() || !j.contains("type")) c.fail(p, "expected an object with a 'type' (point, spot, directional, environment)");
  std::string type = str(c, j["type"], p + "/type");
  Light l;
  if (type == "point") {
    check_keys(c, j, p, {"type", "position", "intensity"});
    l.type = LightType::kPoint;
    l.p = j.contains("position") ? point3(c, j["position"], p + "/position") : Vec3f(0.f);
    l.L = j.contains("intensity") ? color(c, j["intensity"], p + "/intensity") : RGB(1.f);
  } else if (type == "spot") {
    check_keys(c, j, p, {"type", "position", "target", "direction", "intensity", "cutoff_angle", "falloff_start",
                         "falloff"});
    l.type = LightType::kSpot;
    l.p = j.contains("position") ? point3(c, j["position"], p + "/position") : Vec3f(0.f);
    if (j.contains("target") && j.contains("direction")) c.fail(p, "give 'target' or 'direction', not both");
    if (j.contains("direction")) {
      l.dir = point3(c, j["direction"], p + "/direction");  // Scene::build normalizes
      if (length(l.dir) == 0.f) c.fail(p + "/direction", "expected a non-zero direction");
    } else {
      Vec3f tgt = j.contains("target") ? point3(c, j["target"], p + "/target") : l.p + Vec3f(0, 0, -1);
      if (length(tgt - l.p) == 0.f) c.fail(p + "/target", "must differ from the position");
      l.dir = normalize(tgt - l.p);
    }
    l.L = j.contains("intensity") ? color(c, j["intensity"], p + "/intensity") : RGB(1.f);
    // Angles in double so that an exported scene (angles from acos in double) reads back bit-exactly.
    double cutoff = j.contains("cutoff_angle") ? numd(c, j["cutoff_angle"], p + "/cutoff_angle") : 30.0;
    double start = j.contains("falloff_start") ? numd(c, j["falloff_start"], p + "/falloff_start") : cutoff * 0.75;
    if (!(cutoff > 0.0 && cutoff <= 180.0)) c.fail(p + "/cutoff_angle", "expected degrees in (0, 180]");
    if (!(start >= 0.0 && start <= cutoff)) c.fail(p + "/falloff_start", "expected degrees in [0, cutoff_angle]");
    l.cos_total = float(std::cos(cutoff * kPiD / 180.0));
    l.cos_falloff_start = float(std::cos(start * kPiD / 180.0));
    if (j.contains("falloff")) {  // light/light.h, spot_falloff
      std::string f = str(c, j["falloff"], p + "/falloff");
      if (f == "linear_angle") l.spot_linear_angle = 1;
      else if (f != "smoothstep") c.fail(p + "/falloff", "unknown falloff '" + f + "' (allowed: smoothstep, linear_angle)");
    }
  } else if (type == "directional") {
    check_keys(c, j, p, {"type", "direction", "irradiance"});
    l.type = LightType::kDirectional;
    l.dir = j.contains("direction") ? point3(c, j["direction"], p + "/direction") : Vec3f(0, 0, -1);
    if (length(l.dir) == 0.f) c.fail(p + "/direction", "expected a non-zero direction");
    l.L = j.contains("irradiance") ? color(c, j["irradiance"], p + "/irradiance") : RGB(1.f);
  } else if (type == "environment") {
    check_keys(c, j, p, {"type", "radiance", "file", "scale", "transform"});
    l.type = LightType::kEnvironment;
    if (j.contains("file")) {
      if (j.contains("radiance")) c.fail(p + "/radiance", "give 'radiance' (constant) or 'file' and 'scale', not both");
      std::string file = str(c, j["file"], p + "/file");
      if (file.empty()) c.fail(p + "/file", "expected a file name");
      l.texture = load_texture(d, c.resolve(file), true, c.source + ": " + p + "/file");
      c.claimed.resize(d.textures.size(), false);
      l.L = j.contains("scale") ? color(c, j["scale"], p + "/scale") : RGB(1.f);
      if (j.contains("transform")) d.environment_to_world = parse_transform(c, j["transform"], p + "/transform");
    } else {
      if (j.contains("scale")) c.fail(p + "/scale", "'scale' goes with 'file' (use 'radiance' for a constant environment)");
      if (j.contains("transform")) c.fail(p + "/transform", "'transform' goes with 'file' (a constant environment has no orientation)");
      l.L = j.contains("radiance") ? color(c, j["radiance"], p + "/radiance") : RGB(1.f);
    }
  } else {
    c.fail(p + "/type", "unknown light type '" + type + "' (allowed: point, spot, directional, environment)");
  }
  return l;
}

}  // namespace

SceneDesc load_json_scene_text(const std::string& text, const std::string& source, const std::string& base_dir) {
  SceneDesc d;
  Ctx c{source, fs::path(base_dir), &d, {}};
  json root;
  root = parse_json_text<json>(text, source);
  check_keys(c, root, "", {"$schema", "name", "film", "camera", "cameras", "filter", "max_depth", "integrator", "materials",
                           "meshes", "shapes", "lights", "media"});
  d.name = root.contains("name") ? str(c, root["name"], "/name") : source;
  if (root.contains("media")) {
    const json& media = root["media"];
    if (!media.is_object()) c.fail("/media", "expected an object mapping names to media");
    for (auto it = media.begin(); it != media.end(); ++it) {
      d.medium_names.push_back(it.key());
      d.media.push_back(parse_medium(c, it.value(), "/media/" + esc(it.key())));
    }
  }

  // Film (or, as in older files, the top-level filter and the camera's width/height).
  CameraDesc film_cam;
  if (root.contains("film")) {
    const json& f = root["film"];
    check_keys(c, f, "/film", {"width", "height", "filter", "crop"});
    if (f.contains("width")) film_cam.width = integer(c, f["width"], "/film/width");
    if (f.contains("height")) film_cam.height = integer(c, f["height"], "/film/height");
    if (film_cam.width <= 0) c.fail("/film/width", "expected a positive integer");
    if (film_cam.height <= 0) c.fail("/film/height", "expected a positive integer");
    if (f.contains("crop")) {
      // [x, y, width, height] in pixels of the film, top left (0, 0).
      const json& cr = f["crop"];
      if (!cr.is_array() || cr.size() != 4)
        c.fail("/film/crop", "expected [x, y, width, height]: the part of the film to render, in pixels");
      film_cam.crop_x = integer(c, cr[0], "/film/crop/0");
      film_cam.crop_y = integer(c, cr[1], "/film/crop/1");
      film_cam.crop_width = integer(c, cr[2], "/film/crop/2");
      film_cam.crop_height = integer(c, cr[3], "/film/crop/3");
      if (film_cam.crop_width <= 0 || film_cam.crop_height <= 0)
        c.fail("/film/crop", "the crop window's width and height must be positive");
    }
    if (f.contains("filter")) {
      if (root.contains("filter")) c.fail("/filter", "give the filter once (here or in /film)");
      d.filter = parse_filter(c, f["filter"], "/film/filter");
    }
  }
  if (root.contains("filter")) d.filter = parse_filter(c, root["filter"], "/filter");

  if (root.contains("max_depth")) d.max_depth = parse_max_depth(c, root["max_depth"], "/max_depth");
  if (root.contains("integrator")) {
    if (root.contains("max_depth") && root["integrator"].is_object() && root["integrator"].contains("max_depth"))
      c.fail("/integrator/max_depth", "give max_depth once (here or at /max_depth)");
    parse_integrator(c, root["integrator"], d);
  }

  // Cameras: named ones in "cameras"; "camera" is an object or one of their names.
  if (root.contains("cameras")) {
    const json& cams = root["cameras"];
    if (!cams.is_object()) c.fail("/cameras", "expected an object mapping names to cameras");
    for (auto it = cams.begin(); it != cams.end(); ++it) {
      CameraDesc cam = film_cam;
      cam.name = it.key();
      std::string p = "/cameras/" + esc(it.key());
      if (it.value().is_object() && it.value().contains("name")) c.fail(p + "/name", "a named camera takes its name from its key");
      parse_camera(c, it.value(), p, cam);
      d.cameras.push_back(cam);
    }
  }
  if (root.contains("camera")) {
    const json& j = root["camera"];
    if (j.is_string()) {
      std::string n = j.get<std::string>();
      bool found = false;
      for (const CameraDesc& cam : d.cameras)
        if (cam.name == n) {
          d.camera = cam;
          found = true;
        }
      if (!found)
        c.fail("/camera", "no camera named '" + n + "' in /cameras (cameras: " +
                              (root.contains("cameras") ? join_keys(root["cameras"]) : std::string("none")) + ")");
    } else {
      d.camera = film_cam;
      parse_camera(c, j, "/camera", d.camera);
    }
  } else if (!d.cameras.empty()) {
    d.camera = d.cameras.front();
  } else {
    c.fail("/camera", "missing (a scene needs a camera, or named cameras in /cameras)");
  }
  for (const CameraDesc& cam : d.cameras)
    if (std::string why = crop_problem(cam); !why.empty()) c.fail("/film/crop", why);
  if (std::string why = crop_problem(d.camera); !why.empty()) c.fail("/film/crop", why);

  std::map<std::string, int> mat_index;
  if (root.contains("materials")) {
    const json& mats = root["materials"];
    if (!mats.is_object()) c.fail("/materials", "expected an object mapping names to materials");
    // Every name first (a blend may name materials further down), then each material.
    for (auto it = mats.begin(); it != mats.end(); ++it) mat_index[it.key()] = d.add_material(it.key(), Material());
    for (auto it = mats.begin(); it != mats.end(); ++it)
      d.materials[size_t(mat_index[it.key()])] = parse_material(c, it.value(), "/materials/" + esc(it.key()), mat_index);
    // A blend may not contain itself, through any chain of blends; a two_sided's materials reflect only.
    for (auto it = mats.begin(); it != mats.end(); ++it) {
      std::vector<int> stack{mat_index[it.key()]};
      std::vector<int> seen;
      const bool sides = d.materials[size_t(mat_index[it.key()])].flags & kSides;
      while (!stack.empty()) {
        int i = stack.back();
        stack.pop_back();
        const Material& m = d.materials[size_t(i)];
        if (sides && m.mix_b < 0 && (material_is_transmissive(m) || m.type == MaterialType::kNull))
          c.fail("/materials/" + esc(it.key()) + "/materials",
                 "a two_sided material's materials must reflect only ('" + d.material_names[size_t(i)] +
                     "' transmits or is null)");
        if (m.mix_b < 0) continue;
        for (int k : {m.mix_a, m.mix_b}) {
          if (k == mat_index[it.key()])
            c.fail("/materials/" + esc(it.key()) + "/materials", "a blend may not contain itself");
          if (std::find(seen.begin(), seen.end(), k) == seen.end()) {
            seen.push_back(k);
            stack.push_back(k);
          }
        }
      }
    }
  }

  // Named meshes, instanced by shapes with "mesh": name.
  std::map<std::string, std::vector<MeshPart>> named;
  if (root.contains("meshes")) {
    const json& meshes = root["meshes"];
    if (!meshes.is_object()) c.fail("/meshes", "expected an object mapping names to meshes");
    for (auto it = meshes.begin(); it != meshes.end(); ++it) {
      std::string p = "/meshes/" + esc(it.key());
      const json& j = it.value();
      check_keys(c, j, p, {"file", "positions", "indices", "normals", "uvs", "tangents", "colors"});
      if (j.contains("file")) {
        if (j.size() > 1) c.fail(p, "a mesh is a 'file' or inline 'positions' and 'indices', not both");
        named[it.key()] = load_mesh_file_parts(c, j["file"], p + "/file", it.key());
      } else {
        MeshDesc m = parse_mesh_data(c, j, p);
        m.name = it.key();
        d.meshes.push_back(std::move(m));
        named[it.key()] = {MeshPart{it.key(), int(d.meshes.size()) - 1}};
      }
    }
  }

  if (!root.contains("shapes")) c.fail("/shapes", "missing (a scene needs at least one shape)");
  const json& shapes = root["shapes"];
  if (!shapes.is_array() || shapes.empty()) c.fail("/shapes", "expected a non-empty array");
  int default_mat = -1;
  auto default_material = [&] {
    if (default_mat < 0) default_mat = d.add_material("default", make_diffuse(RGB(0.5f)));
    return default_mat;
  };
  for (size_t i = 0; i < shapes.size(); ++i) {
    std::string p = "/shapes/" + std::to_string(i);
    const json& j = shapes[i];
    if (!j.is_object()) c.fail(p, std::string("expected an object, got ") + type_name(j));
    if (!j.contains("type")) c.fail(p, "missing 'type' (sphere, rectangle, cube, disk, mesh)");
    std::string type = str(c, j["type"], p + "/type");
    if (type == "sphere")
      check_keys(c, j, p, {"name", "type", "material", "emission", "emission_two_sided", "flip_normals", "transform",
                           "center", "radius", "interior", "exterior"});
    else if (type == "mesh")
      check_keys(c, j, p, {"name", "type", "material", "emission", "emission_two_sided", "flip_normals", "transform",
                           "positions", "indices", "normals", "uvs", "tangents", "colors", "file", "mesh", "interior",
                           "exterior"});
    else if (type == "rectangle" || type == "cube" || type == "disk")
      check_keys(c, j, p, {"name", "type", "material", "emission", "emission_two_sided", "flip_normals", "transform",
                           "interior", "exterior"});
    else
      c.fail(p + "/type", "unknown shape type '" + type + "' (allowed: sphere, rectangle, cube, disk, mesh)");
    ShapeDesc s;
    s.name = j.contains("name") ? str(c, j["name"], p + "/name") : p;
    if (j.contains("transform")) s.to_world = parse_transform(c, j["transform"], p + "/transform");
    int material = -1;
    if (j.contains("material")) {
      std::string mn = str(c, j["material"], p + "/material");
      auto it = mat_index.find(mn);
      if (it == mat_index.end()) c.fail(p + "/material", "no material named '" + mn + "' in /materials");
      material = it->second;
    }
    bool has_emission = j.contains("emission");
    if (has_emission) s.emission = color_or_texture(c, j["emission"], p + "/emission", s.emission_texture);
    if (j.contains("emission_two_sided")) s.emission_two_sided = boolean(c, j["emission_two_sided"], p + "/emission_two_sided");
    if (j.contains("flip_normals")) s.flip_normals = boolean(c, j["flip_normals"], p + "/flip_normals");
    // Media on either side: one given makes the shape a medium boundary, the other side vacuum.
    if (j.contains("interior")) s.interior = medium_ref(c, j["interior"], p + "/interior");
    if (j.contains("exterior")) s.exterior = medium_ref(c, j["exterior"], p + "/exterior");
    s.medium_interface = j.contains("interior") || j.contains("exterior");

    std::vector<MeshPart> parts;  // mesh shapes: what this shape instances
    if (type == "sphere") {
      s.type = ShapeType::kSphere;
      if (j.contains("center")) s.center = point3(c, j["center"], p + "/center");
      if (j.contains("radius")) s.radius = num(c, j["radius"], p + "/radius");
      if (!(s.radius > 0.f)) c.fail(p + "/radius", "expected a positive radius");
    } else if (type == "rectangle") s.type = ShapeType::kRectangle;
    else if (type == "cube") s.type = ShapeType::kCube;
    else if (type == "disk") s.type = ShapeType::kDisk;
    else {
      s.type = ShapeType::kMesh;
      bool inline_data = j.contains("positions") || j.contains("indices") || j.contains("normals") || j.contains("uvs") ||
                         j.contains("tangents") || j.contains("colors");
      int forms = int(inline_data) + int(j.contains("file")) + int(j.contains("mesh"));
      if (forms != 1)
        c.fail(p, forms == 0 ? "a mesh needs inline 'positions' and 'indices', a 'file' or a 'mesh' name from /meshes"
                             : "give one of inline 'positions'/'indices', 'file' or 'mesh'");
      if (inline_data) {
        MeshDesc m = parse_mesh_data(c, j, p);
        m.name = s.name;
        d.meshes.push_back(std::move(m));
        parts.push_back({s.name, int(d.meshes.size()) - 1});
      } else if (j.contains("mesh")) {
        std::string mn = str(c, j["mesh"], p + "/mesh");
        auto it = named.find(mn);
        if (it == named.end())
          c.fail(p + "/mesh", "no mesh named '" + mn + "' in /meshes (meshes: " +
                                  (root.contains("meshes") ? join_keys(root["meshes"]) : std::string("none")) + ")");
        parts = it->second;
      } else {
        std::string ext;
        std::string full = checked_file(c, j["file"], p + "/file", &ext);
        if (ext == ".ply") {
          parts = load_mesh_file_parts(c, j["file"], p + "/file", s.name);
        } else {
          // OBJ: the loader adds one shape per (group, material) with this transform.
          std::vector<int> added = with_file_context(c, p + "/file", [&] {
            return append_obj(d, full, s.to_world, material, c.source);
          });
          for (int k : added) {
            ShapeDesc& o = d.shapes[k];
            if (has_emission) {
              o.emission = s.emission;
              o.emission_texture = s.emission_texture;
            }
            if (j.contains("emission_two_sided")) o.emission_two_sided = s.emission_two_sided;
            o.flip_normals = s.flip_normals;
            o.medium_interface = s.medium_interface;
            o.interior = s.interior;
            o.exterior = s.exterior;
            if (j.contains("name")) o.name = added.size() == 1 ? s.name : s.name + "/" + o.name;
          }
          continue;
        }
      }
    }
    if (s.type != ShapeType::kMesh) {
      s.material = material >= 0 ? material : default_material();
      d.shapes.push_back(s);
      continue;
    }
    for (const MeshPart& part : parts) {
      ShapeDesc o = s;
      o.mesh = part.mesh;
      o.material = material >= 0 ? material : (part.material >= 0 ? part.material : default_material());
      if (!has_emission) {
        o.emission = part.emission;
        o.emission_texture = part.emission_texture;
        if (!j.contains("emission_two_sided")) o.emission_two_sided = part.emission_two_sided;
      }
      if (parts.size() > 1) o.name = s.name + "/" + part.name;
      d.shapes.push_back(o);
    }
  }
  if (root.contains("lights")) {
    const json& lights = root["lights"];
    if (!lights.is_array()) c.fail("/lights", "expected an array");
    int env = -1;
    for (size_t i = 0; i < lights.size(); ++i) {
      std::string p = "/lights/" + std::to_string(i);
      Light l = parse_light(c, lights[i], p, d);
      if (l.type == LightType::kEnvironment) {
        if (env >= 0) c.fail(p, "at most one environment light (the first is /lights/" + std::to_string(env) + ")");
        env = int(i);
      }
      d.lights.push_back(l);
    }
  }
  if (d.materials.empty()) d.add_material("default", make_diffuse(RGB(0.5f)));
  return d;
}

SceneDesc load_json_scene_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot open the file");
  std::stringstream ss;
  ss << f.rdbuf();
  return load_json_scene_text(ss.str(), path, fs::path(path).parent_path().string());
}

Filter parse_filter_json(const std::string& text, const std::string& source) {
  Ctx c;
  c.source = source;
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception&) {
    throw InputError(source + ": expected a filter name or object");
  }
  return parse_filter(c, j, "");
}

}  // namespace caustica
