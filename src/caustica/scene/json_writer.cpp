// SceneDesc -> caustica JSON. The output reads back (json_loader.cpp) to the same
// description: floats are printed with the fewest digits that parse back to the
// same float, spot angles and texture rotations as doubles chosen so that the
// loader's double arithmetic gives back the same float, and materials are
// written with the parameters their make_* constructors take.
#include "json_writer.h"
#include "volume_io.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "../base/error.h"
#include "../film/image_io.h"

namespace caustica {
namespace {

constexpr double kPiD = 3.14159265358979323846;

// A small JSON value that remembers whether a number is a float or a double
// (they are printed differently).
struct JV {
  enum class K { kNull, kBool, kInt, kFloat, kDouble, kString, kArray, kObject } k = K::kNull;
  bool b = false;
  int64_t i = 0;
  double d = 0.0;
  std::string s;
  std::vector<JV> arr;
  std::vector<std::pair<std::string, JV>> obj;

  static JV boolean(bool v) { JV j; j.k = K::kBool; j.b = v; return j; }
  static JV integer(int64_t v) { JV j; j.k = K::kInt; j.i = v; return j; }
  static JV flt(float v) { JV j; j.k = K::kFloat; j.d = v; return j; }
  static JV dbl(double v) { JV j; j.k = K::kDouble; j.d = v; return j; }
  static JV str(const std::string& v) { JV j; j.k = K::kString; j.s = v; return j; }
  static JV array() { JV j; j.k = K::kArray; return j; }
  static JV object() { JV j; j.k = K::kObject; return j; }
  JV& set(const std::string& key, JV v) {
    obj.emplace_back(key, std::move(v));
    return *this;
  }
  JV& push(JV v) {
    arr.push_back(std::move(v));
    return *this;
  }
  bool scalar() const { return k != K::kArray && k != K::kObject; }
};

JV vec(Vec3f v) { return JV::array().push(JV::flt(v.x)).push(JV::flt(v.y)).push(JV::flt(v.z)); }
JV vec2(Vec2f v) { return JV::array().push(JV::flt(v.x)).push(JV::flt(v.y)); }
// A colour: one number when grey.
JV col(RGB c) { return c.x == c.y && c.y == c.z ? JV::flt(c.x) : vec(c); }

std::string fmt_number(const JV& v) {
  if (!std::isfinite(v.d)) throw InputError("export: cannot write a non-finite number in JSON");
  char buf[48];
  if (v.d == 0.0) return std::signbit(v.d) ? "-0.0" : "0";
  const float f = float(v.d);
  for (int p = 1; p <= 17; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, v.d);
    double back = std::strtod(buf, nullptr);  // what the JSON parser will see
    if (v.k == JV::K::kFloat ? float(back) == f : back == v.d) break;
  }
  return buf;
}

std::string quote(const std::string& s) {
  return nlohmann::json(s).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// Compact text of a small value, or "" when it is too big to put on one line.
bool inline_text(const JV& v, std::string& out, size_t limit) {
  switch (v.k) {
    case JV::K::kNull: out += "null"; break;
    case JV::K::kBool: out += v.b ? "true" : "false"; break;
    case JV::K::kInt: out += std::to_string(v.i); break;
    case JV::K::kFloat:
    case JV::K::kDouble: out += fmt_number(v); break;
    case JV::K::kString: out += quote(v.s); break;
    case JV::K::kArray:
      out += '[';
      for (size_t n = 0; n < v.arr.size(); ++n) {
        if (n) out += ", ";
        if (!inline_text(v.arr[n], out, limit)) return false;
      }
      out += ']';
      break;
    case JV::K::kObject:
      out += '{';
      for (size_t n = 0; n < v.obj.size(); ++n) {
        if (n) out += ", ";
        out += quote(v.obj[n].first) + ": ";
        if (!inline_text(v.obj[n].second, out, limit)) return false;
      }
      out += '}';
      break;
  }
  return out.size() <= limit;
}

void dump(const JV& v, std::string& out, int indent) {
  const size_t width = 110;
  std::string one;
  size_t room = width > size_t(indent) + 20 ? width - indent : 20;
  // A scalar goes on its line however long (a long string, such as a name with a file's path in it).
  if (inline_text(v, one, room) || v.scalar()) {
    out += one;
    return;
  }
  std::string pad(indent + 2, ' ');
  if (v.k == JV::K::kObject) {
    out += "{\n";
    for (size_t n = 0; n < v.obj.size(); ++n) {
      out += pad + quote(v.obj[n].first) + ": ";
      dump(v.obj[n].second, out, indent + 2);
      out += n + 1 < v.obj.size() ? ",\n" : "\n";
    }
    out += std::string(indent, ' ') + "}";
    return;
  }
  // Arrays: lists of numbers or of small arrays are packed several to a line.
  bool packable = true;
  for (const JV& e : v.arr) {
    if (e.scalar()) continue;
    if (e.k != JV::K::kArray) { packable = false; break; }
    for (const JV& x : e.arr) packable &= x.scalar();
    if (!packable) break;
  }
  out += "[\n";
  if (packable) {
    std::string line;
    for (size_t n = 0; n < v.arr.size(); ++n) {
      std::string t;
      inline_text(v.arr[n], t, size_t(-1));
      if (!line.empty() && pad.size() + line.size() + t.size() + 2 > width) {
        out += pad + line + "\n";
        line.clear();
      }
      line += t;
      if (n + 1 < v.arr.size()) line += ", ";
    }
    if (!line.empty()) out += pad + line + "\n";
  } else {
    for (size_t n = 0; n < v.arr.size(); ++n) {
      out += pad;
      dump(v.arr[n], out, indent + 2);
      out += n + 1 < v.arr.size() ? ",\n" : "\n";
    }
  }
  out += std::string(indent, ' ') + "]";
}

bool is_identity(const Affine& a) {
  Affine id;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 4; ++k)
      if (a.m[i][k] != id.m[i][k] || std::signbit(a.m[i][k]) != std::signbit(id.m[i][k])) return false;
  return true;
}
JV matrix(const Affine& a) {
  JV m = JV::array();
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 4; ++k) m.push(JV::flt(a.m[i][k]));
  return JV::object().set("matrix", m);
}

// Degrees whose cosine, computed as the loader does (double, then rounded to
// float), gives back `c` exactly.
double angle_for_cos(float c) {
  double deg = std::acos(std::fmin(1.0, std::fmax(-1.0, double(c)))) * 180.0 / kPiD;
  for (int it = 0; it < 64; ++it) {
    float back = float(std::cos(deg * kPiD / 180.0));
    if (back == c) break;
    deg = std::nextafter(deg, back > c ? 1e9 : -1e9);  // cos decreases on [0, 180]
  }
  return deg;
}
// Degrees for a rotation in radians, read back as float(deg * pi / 180).
double degrees_for_radians(float r) {
  double deg = double(r) * 180.0 / kPiD;
  for (int it = 0; it < 64; ++it) {
    float back = float(deg * kPiD / 180.0);
    if (back == r) break;
    deg = std::nextafter(deg, back < r ? 1e300 : -1e300);
  }
  return deg;
}
// metallic-roughness: a perceptual roughness r with r * r == alpha in float, if there is one.
bool roughness_for_alpha(float alpha, float& r) {
  float s = std::sqrt(alpha);
  for (float cand : {s, std::nextafter(s, 0.f), std::nextafter(s, 2.f)}) {
    if (cand >= 0.f && cand <= 1.f && cand * cand == alpha) {
      r = cand;
      return true;
    }
  }
  return false;
}

bool same_camera(const CameraDesc& a, const CameraDesc& b) {
  auto eq = [](Vec3f x, Vec3f y) { return x.x == y.x && x.y == y.y && x.z == y.z; };
  return a.name == b.name && eq(a.position, b.position) && eq(a.target, b.target) && eq(a.up, b.up) &&
         a.orthographic == b.orthographic && a.view_size == b.view_size && a.fov_degrees == b.fov_degrees && a.fov_axis == b.fov_axis && a.aperture_radius == b.aperture_radius &&
         a.focus_distance == b.focus_distance && a.width == b.width && a.height == b.height && a.flip_x == b.flip_x &&
         a.moving == b.moving && (!a.moving || (eq(a.position1, b.position1) && eq(a.target1, b.target1) &&
                                                eq(a.up1, b.up1))) &&
         a.shutter_open == b.shutter_open && a.shutter_close == b.shutter_close && a.medium == b.medium;
}

struct Writer {
  const SceneDesc& d;
  std::string stem;

  // Unique keys for named things (names may repeat or be empty in other formats).
  static std::vector<std::string> unique_keys(const std::vector<std::string>& names, const char* fallback) {
    std::vector<std::string> keys;
    std::set<std::string> used;
    for (size_t i = 0; i < names.size(); ++i) {
      std::string k = names[i];
      if (k.empty()) k.append(fallback).append(std::to_string(i));
      if (used.count(k)) {
        int n = 2;
        auto numbered = [&](int x) { return std::string(k).append("#").append(std::to_string(x)); };
        while (used.count(numbered(n))) ++n;
        k = numbered(n);
      }
      used.insert(k);
      keys.push_back(k);
    }
    return keys;
  }

  // alpha_as_grey: the image's alpha channel, written out as a grey image (exported_alpha_texture_name).
  JV texture(int index, bool srgb_default, const JV* scale, bool alpha_as_grey = false) const {
    if (index < 0 || size_t(index) >= d.textures.size())
      throw InputError("export: texture index " + std::to_string(index) + " out of range");
    const TextureDesc& t = d.textures[index];
    JV o = JV::object();
    o.set("texture", JV::str(alpha_as_grey ? exported_alpha_texture_name(stem, size_t(index))
                                           : exported_texture_name(stem, size_t(index))));
    if (scale) o.set("scale", *scale);
    if (t.srgb != srgb_default) o.set("srgb", JV::boolean(t.srgb));
    auto wrap_name = [](TexWrap w) { return JV::str(w == TexWrap::kClamp ? "clamp" : w == TexWrap::kMirror ? "mirror" : "repeat"); };
    if (t.wrap_u != t.wrap_v) o.set("wrap", JV::array().push(wrap_name(t.wrap_u)).push(wrap_name(t.wrap_v)));
    else if (t.wrap_u != TexWrap::kRepeat) o.set("wrap", wrap_name(t.wrap_u));
    if (t.nearest) o.set("filter", JV::str("nearest"));
    if (t.uv_scale.x != 1.f || t.uv_scale.y != 1.f) o.set("uv_scale", vec2(t.uv_scale));
    if (t.uv_offset.x != 0.f || t.uv_offset.y != 0.f || std::signbit(t.uv_offset.x) || std::signbit(t.uv_offset.y))
      o.set("uv_offset", vec2(t.uv_offset));
    if (t.uv_rotation != 0.f) o.set("uv_rotation", JV::dbl(degrees_for_radians(t.uv_rotation)));
    return o;
  }
  // A colour slot: the colour, or the texture with the colour as its scale.
  JV color_slot(RGB c, int tex, bool srgb_default = true) const {
    if (tex < 0) return col(c);
    JV s = col(c);
    return texture(tex, srgb_default, &s);
  }
  JV alpha_value(const Material& m) const {
    return m.alpha_x == m.alpha_y ? JV::flt(m.alpha_x) : vec2(Vec2f(m.alpha_x, m.alpha_y));
  }
  JV roughness_slot(const Material& m) const {
    JV a = alpha_value(m);
    return m.tex_roughness >= 0 ? texture(m.tex_roughness, false, &a) : a;
  }
  // metallic_roughness's and principled's "roughness" (a number, or a texture with the roughness as its
  // scale), or "alpha" where the alphas are no roughness^2 pair.
  void perceptual_roughness(const Material& m, JV& o) const {
    float r = 0.f;
    bool exact = m.alpha_x == m.alpha_y && roughness_for_alpha(m.alpha_x, r);
    if (m.tex_roughness >= 0) {
      JV s = JV::flt(r);
      o.set("roughness", texture(m.tex_roughness, false, exact ? &s : nullptr));
    } else if (exact) {
      o.set("roughness", JV::flt(r));
    }
    if (!exact) o.set("alpha", alpha_value(m));
  }

  // keys: every material's key (a blend names two).
  JV material(const Material& m, const std::vector<std::string>& keys) const {
    JV o = JV::object();
    bool two_sided_key = true;
    if (m.mix_b >= 0) {
      JV names = JV::array();
      names.push(JV::str(keys.at(size_t(m.mix_a)))).push(JV::str(keys.at(size_t(m.mix_b))));
      if (m.flags & kSides) {
        o.set("type", JV::str("two_sided")).set("materials", names);
        opacity(m, o);
        return o;
      }
      o.set("type", JV::str("blend")).set("materials", names);
      if (m.tex_mix >= 0) {
        JV s = JV::flt(m.mix_weight);
        o.set("weight", texture(m.tex_mix, false, &s));
      } else {
        o.set("weight", JV::flt(m.mix_weight));
      }
      opacity(m, o);
      return o;
    }
    switch (m.type) {
      case MaterialType::kDiffuse:
        o.set("type", JV::str("diffuse")).set("reflectance", color_slot(m.diffuse, m.tex_color));
        break;
      case MaterialType::kConductor:
      case MaterialType::kRoughConductor:
        o.set("type", JV::str("conductor"));
        if (!(m.flags & kConductorTint)) o.set("eta", col(m.eta_c)).set("k", col(m.k_c));
        o.set("specular", color_slot(m.specular, m.tex_color));
        if (m.type == MaterialType::kRoughConductor) o.set("roughness", roughness_slot(m));
        break;
      case MaterialType::kDielectric:
      case MaterialType::kRoughDielectric:
        two_sided_key = false;
        o.set("type", JV::str("dielectric")).set("eta", JV::flt(m.eta));
        if (m.type == MaterialType::kRoughDielectric) o.set("roughness", roughness_slot(m));
        o.set("specular", col(m.specular)).set("transmission", color_slot(m.transmission, m.tex_color));
        if (!is_black(m.absorption)) o.set("absorption", col(m.absorption));
        break;
      case MaterialType::kThinDielectric:
        two_sided_key = false;
        o.set("type", JV::str("thindielectric")).set("eta", JV::flt(m.eta)).set("specular", col(m.specular));
        o.set("transmission", color_slot(m.transmission, m.tex_color));
        break;
      case MaterialType::kPlastic:
      case MaterialType::kRoughPlastic:
        o.set("type", JV::str("plastic")).set("diffuse", color_slot(m.diffuse, m.tex_color));
        o.set("eta", JV::flt(m.eta)).set("specular", col(m.specular));
        if (m.type == MaterialType::kRoughPlastic) o.set("roughness", JV::flt(m.alpha_x));
        break;
      case MaterialType::kDiffuseTransmission:
        two_sided_key = false;
        o.set("type", JV::str("difftrans")).set("reflectance", color_slot(m.diffuse, m.tex_color));
        o.set("transmittance", color_slot(m.transmission, m.tex_diffuse_transmission_color));
        break;
      case MaterialType::kPhong:
        o.set("type", JV::str("phong")).set("diffuse", color_slot(m.diffuse, m.tex_color));
        o.set("specular", col(m.specular)).set("exponent", JV::flt(m.exponent));
        break;
      case MaterialType::kMetallicRoughness: {
        o.set("type", JV::str("metallic_roughness")).set("base_color", color_slot(m.diffuse, m.tex_color));
        o.set("metallic", JV::flt(m.metallic));
        perceptual_roughness(m, o);
        JV tw = JV::flt(m.transmission_weight);
        o.set("transmission", m.tex_transmission >= 0 ? texture(m.tex_transmission, false, &tw) : tw);
        o.set("eta", JV::flt(m.eta));
        if (m.flags & kPlasticBase) o.set("diffuse_base", JV::str("plastic"));
        if (!is_black(m.absorption)) o.set("absorption", col(m.absorption));
        if (m.specular_weight != 1.f || m.tex_specular >= 0) {
          JV w = JV::flt(m.specular_weight);
          o.set("specular", m.tex_specular >= 0 ? texture(m.tex_specular, false, &w) : w);
        }
        if (m.specular.x != 1.f || m.specular.y != 1.f || m.specular.z != 1.f || m.tex_specular_color >= 0)
          o.set("specular_color", color_slot(m.specular, m.tex_specular_color));
        if (max_component(m.sheen_color) > 0.f || m.tex_sheen_color >= 0) {
          JV r = JV::flt(m.sheen_roughness);
          o.set("sheen_color", color_slot(m.sheen_color, m.tex_sheen_color));
          o.set("sheen_roughness", m.tex_sheen_roughness >= 0 ? texture(m.tex_sheen_roughness, false, &r) : r);
        }
        if (m.diffuse_transmission > 0.f || m.tex_diffuse_transmission >= 0) {
          JV w = JV::flt(m.diffuse_transmission);
          o.set("diffuse_transmission", m.tex_diffuse_transmission >= 0 ? texture(m.tex_diffuse_transmission, false, &w) : w);
          o.set("diffuse_transmission_color", color_slot(m.transmission, m.tex_diffuse_transmission_color));
        }
        if (m.iridescence > 0.f || m.tex_iridescence >= 0) {
          JV w = JV::flt(m.iridescence), t = JV::flt(m.iridescence_thickness);
          o.set("iridescence", m.tex_iridescence >= 0 ? texture(m.tex_iridescence, false, &w) : w);
          o.set("iridescence_eta", JV::flt(m.iridescence_eta));
          o.set("iridescence_thickness", m.tex_iridescence_thickness >= 0 ? texture(m.tex_iridescence_thickness, false, &t) : t);
          if (m.tex_iridescence_thickness >= 0) o.set("iridescence_thickness_min", JV::flt(m.iridescence_thickness_min));
        }
        if (m.clearcoat > 0.f || m.tex_clearcoat >= 0) {
          float rough = std::sqrt(m.clearcoat_alpha);
          roughness_for_alpha(m.clearcoat_alpha, rough);  // the roughness whose square is alpha, where one is
          JV w = JV::flt(m.clearcoat), r = JV::flt(rough);
          o.set("clearcoat", m.tex_clearcoat >= 0 ? texture(m.tex_clearcoat, false, &w) : w);
          o.set("clearcoat_roughness", m.tex_clearcoat_roughness >= 0 ? texture(m.tex_clearcoat_roughness, false, &r) : r);
          if (m.tex_clearcoat_normal >= 0) {
            JV sc = JV::flt(m.clearcoat_normal_scale);
            o.set("clearcoat_normal_map", texture(m.tex_clearcoat_normal, false, &sc));
          }
        }
        break;
      }
      case MaterialType::kPrincipled: {
        o.set("type", JV::str("principled")).set("base_color", color_slot(m.diffuse, m.tex_color));
        perceptual_roughness(m, o);
        o.set("eta", JV::flt(m.eta));
        // Each weight a number, or its texture with the number as "scale"; zeros without a texture left out
        // (but metallic and spec_trans).
        for (const PrincipledWeight& w : kPrincipledWeights) {
          JV v = JV::flt(m.*w.value);
          const bool always = w.value == &Material::metallic || w.value == &Material::transmission_weight;
          if (m.*w.texture >= 0) o.set(w.name, texture(m.*w.texture, false, &v));
          else if (always || m.*w.value != 0.f) o.set(w.name, v);
        }
        break;
      }
      case MaterialType::kNull:
        o.set("type", JV::str("null"));
        return o;
      default:
        throw InputError("export: material type " + std::to_string(int(m.type)) + " has no JSON form");
    }
    if (m.aniso_rotation != 0.f) o.set("anisotropy_rotation", JV::dbl(degrees_for_radians(m.aniso_rotation)));
    if (m.tex_aniso >= 0) o.set("anisotropy_texture", texture(m.tex_aniso, false, nullptr));
    if (two_sided_key && (m.flags & kTwoSided)) o.set("two_sided", JV::boolean(true));
    if (m.flags & kBeckmann) o.set("distribution", JV::str("beckmann"));
    if (m.flags & kVertexColor) o.set("vertex_colors", JV::boolean(true));
    if (m.tex_normal >= 0) {
      JV s = JV::flt(m.normal_scale);
      JV t = texture(m.tex_normal, false, &s);
      if (m.flags & kNormalMapCross) t.set("bitangent", JV::str("cross"));
      o.set("normal_map", t);
    } else if (m.tex_bump >= 0) {
      JV s = JV::flt(m.bump_scale);
      o.set("bump_map", texture(m.tex_bump, false, &s));
    }
    opacity(m, o);
    return o;
  }

  void opacity(const Material& m, JV& o) const {
    if (m.tex_opacity >= 0) {
      // The written images are RGB: an alpha channel goes out as a grey image read by its luminance.
      JV s = JV::flt(m.opacity);
      JV t = texture(m.tex_opacity, false, &s, !(m.flags & kOpacityLuminance));
      t.set("channel", JV::str("luminance"));
      o.set("opacity", t);
    } else if (m.opacity < 1.f) {
      o.set("opacity", JV::flt(m.opacity));
    }
    if (m.opacity_cutoff >= 0.f && (m.tex_opacity >= 0 || m.opacity < 1.f))
      o.set("opacity_cutoff", JV::flt(m.opacity_cutoff));
  }

  JV camera(const CameraDesc& c, bool with_name) const {
    JV o = JV::object();
    if (with_name && !c.name.empty()) o.set("name", JV::str(c.name));
    o.set("position", vec(c.position)).set("target", vec(c.target)).set("up", vec(c.up));
    if (c.orthographic) o.set("type", JV::str("orthographic")).set("view_size", JV::flt(c.view_size));
    else o.set("fov", JV::flt(c.fov_degrees));
    if (c.fov_axis == CameraDesc::FovAxis::kX) o.set("fov_axis", JV::str("x"));
    if (c.fov_axis == CameraDesc::FovAxis::kY) o.set("fov_axis", JV::str("y"));
    if (c.width != d.camera.width) o.set("width", JV::integer(c.width));
    if (c.height != d.camera.height) o.set("height", JV::integer(c.height));
    if (c.aperture_radius != 0.f && !c.orthographic) o.set("aperture_radius", JV::flt(c.aperture_radius));
    if (c.focus_distance != 0.f && !c.orthographic) o.set("focus_distance", JV::flt(c.focus_distance));
    if (c.flip_x) o.set("flip_x", JV::boolean(true));
    if (c.principal_point.x != 0.f || c.principal_point.y != 0.f) o.set("principal_point", vec2(c.principal_point));
    if (c.near_clip != 0.f) o.set("near_clip", JV::flt(c.near_clip));
    if (c.far_clip < kInf) o.set("far_clip", JV::flt(c.far_clip));
    if (c.moving) {
      JV m = JV::object();
      m.set("position", vec(c.position1)).set("target", vec(c.target1)).set("up", vec(c.up1));
      o.set("motion", m);
    }
    if (c.shutter_open != 0.f) o.set("shutter_open", JV::flt(c.shutter_open));
    if (c.shutter_close != 1.f) o.set("shutter_close", JV::flt(c.shutter_close));
    if (c.medium >= 0) o.set("medium", JV::str(medium_key(c.medium)));
    return o;
  }

  // The JSON key of medium i (its name, made unique).
  std::string medium_key(int i) const {
    if (i < 0 || size_t(i) >= d.media.size()) throw InputError("export: medium index out of range");
    std::vector<std::string> names = d.medium_names;
    names.resize(d.media.size());
    return unique_keys(names, "medium")[size_t(i)];
  }

  JV light(const Light& l) const {
    JV o = JV::object();
    switch (l.type) {
      case LightType::kPoint:
        o.set("type", JV::str("point")).set("position", vec(l.p)).set("intensity", col(l.L));
        break;
      case LightType::kSpot:
        o.set("type", JV::str("spot")).set("position", vec(l.p)).set("direction", vec(l.dir));
        o.set("intensity", col(l.L));
        o.set("cutoff_angle", JV::dbl(angle_for_cos(l.cos_total)));
        o.set("falloff_start", JV::dbl(angle_for_cos(l.cos_falloff_start)));
        if (l.spot_linear_angle) o.set("falloff", JV::str("linear_angle"));
        break;
      case LightType::kDirectional:
        o.set("type", JV::str("directional")).set("direction", vec(l.dir)).set("irradiance", col(l.L));
        break;
      case LightType::kEnvironment:
        o.set("type", JV::str("environment"));
        if (l.texture >= 0) {
          if (size_t(l.texture) >= d.textures.size()) throw InputError("export: environment texture out of range");
          o.set("file", JV::str(exported_texture_name(stem, size_t(l.texture)))).set("scale", col(l.L));
          if (!is_identity(d.environment_to_world)) o.set("transform", matrix(d.environment_to_world));
        } else {
          o.set("radiance", col(l.L));
        }
        break;
      default:
        throw InputError("export: area lights are written as emissive shapes, not as lights");
    }
    return o;
  }

  JV mesh(const MeshDesc& m) const {
    JV o = JV::object();
    JV p = JV::array();
    for (Vec3f v : m.positions) p.push(vec(v));
    JV idx = JV::array();
    for (uint32_t i : m.indices) idx.push(JV::integer(i));
    o.set("positions", p).set("indices", idx);
    if (!m.normals.empty()) {
      JV n = JV::array();
      for (Vec3f v : m.normals) n.push(vec(v));
      o.set("normals", n);
    }
    if (!m.uvs.empty()) {
      JV u = JV::array();
      for (Vec2f v : m.uvs) u.push(vec2(v));
      o.set("uvs", u);
    }
    if (!m.tangents.empty()) {
      JV ta = JV::array();
      for (const Tangent& t : m.tangents) {
        JV e = JV::array();
        for (float x : {t.t.x, t.t.y, t.t.z, t.w}) e.push(JV::flt(x));
        ta.push(e);
      }
      o.set("tangents", ta);
    }
    if (!m.colors.empty()) {
      JV cs = JV::array();
      for (RGB c : m.colors) cs.push(vec(c));
      o.set("colors", cs);
    }
    return o;
  }

  // A filter as its name where it has the type's defaults, else as an object with every parameter.
  static JV filter_json(const Filter& f) {
    const Filter def = make_filter(f.type);
    if (f.radius == def.radius && f.a == def.a && f.b == def.b) return JV::str(filter_type_name(f.type));
    JV o = JV::object();
    o.set("type", JV::str(filter_type_name(f.type))).set("radius", JV::flt(f.radius));
    if (f.type == FilterType::kGaussian) o.set("stddev", JV::flt(f.a));
    if (f.type == FilterType::kMitchell) o.set("B", JV::flt(f.a)).set("C", JV::flt(f.b));
    if (f.type == FilterType::kLanczos) o.set("lobes", JV::flt(f.a));
    return o;
  }

  JV scene() const {
    JV root = JV::object();
    root.set("name", JV::str(d.name));
    JV film = JV::object();
    film.set("width", JV::integer(d.camera.width)).set("height", JV::integer(d.camera.height));
    film.set("filter", filter_json(d.filter));
    if (d.camera.crop_width > 0) {
      JV crop = JV::array();
      for (int v : {d.camera.crop_x, d.camera.crop_y, d.camera.crop_width, d.camera.crop_height})
        crop.push(JV::integer(v));
      film.set("crop", crop);
    }
    root.set("film", film);

    const SceneDesc::IntegratorDefaults& in = d.integrator;
    JV integ = JV::object();
    if (!in.type.empty()) integ.set("type", JV::str(in.type));
    if (in.spp > 0) integ.set("spp", JV::integer(in.spp));
    if (in.time > 0.0) integ.set("time", JV::dbl(in.time));
    if (d.max_depth != -1) integ.set("max_depth", JV::integer(d.max_depth));
    if (in.rr_depth > 0) integ.set("rr_depth", JV::integer(in.rr_depth));
    if (!in.sampler.empty()) integ.set("sampler", JV::str(in.sampler));
    if (in.photons > 0) integ.set("photons", JV::integer(in.photons));
    if (in.radius > 0.f) integ.set("radius", JV::flt(in.radius));
    if (in.alpha > 0.f) integ.set("alpha", JV::flt(in.alpha));
    if (in.k > 0) integ.set("k", JV::integer(in.k));
    if (!in.photon_sampling.empty()) integ.set("photon_sampling", JV::str(in.photon_sampling));
    if (!in.light_sampler.empty()) integ.set("light_sampler", JV::str(in.light_sampler));
    if (in.hide_emitters >= 0) integ.set("hide_emitters", JV::boolean(in.hide_emitters == 1));
    if (in.restir_candidates >= 0) integ.set("restir_candidates", JV::integer(in.restir_candidates));
    if (in.restir_neighbors >= 0) integ.set("restir_neighbors", JV::integer(in.restir_neighbors));
    if (in.restir_radius >= 0.f) integ.set("restir_radius", JV::flt(in.restir_radius));
    if (in.restir_history >= 0.f) integ.set("restir_history", JV::flt(in.restir_history));
    if (!integ.obj.empty()) root.set("integrator", integ);

    if (!d.media.empty()) {
      JV media = JV::object();
      for (size_t i = 0; i < d.media.size(); ++i) {
        const Medium& m = d.media[i];
        JV o = JV::object();
        o.set("type", JV::str(m.grid >= 0 ? "heterogeneous" : "homogeneous"));
        // With an albedo grid the constant coefficients carry only sigma_t (Medium::albedo_grid).
        if (m.grid >= 0 && m.albedo_grid >= 0) o.set("sigma_t", col(medium_sigma_t(m)));
        else o.set("sigma_a", col(m.sigma_a)).set("sigma_s", col(m.sigma_s));
        if (m.g != 0.f) o.set("g", JV::flt(m.g));
        if (medium_emits(m) && !(m.grid >= 0 && m.emission_grid >= 0)) o.set("emission", col(m.Le));
        if (m.grid >= 0) {
          auto grid_of = [&](int index, const char* what) -> const MediumGridDesc& {
            if (size_t(index) >= d.grids.size()) throw InputError(std::string("export: ") + what + " grid index out of range");
            return d.grids[size_t(index)];
          };
          const MediumGridDesc& g = grid_of(m.grid, "density");
          o.set("density", JV::object().set("file", JV::str(exported_grid_name(stem, size_t(m.grid)))));
          if (!is_identity(g.to_world)) o.set("transform", matrix(g.to_world));
          if (g.nearest) o.set("filter", JV::str("nearest"));
          if (g.clamp) o.set("outside", JV::str("clamp"));
          // An albedo or emission grid: its file, and its placement and lookup where they differ from the
          // density grid's.
          auto other_grid = [&](int index, const char* key) {
            const MediumGridDesc& a = grid_of(index, key);
            JV ao = JV::object().set("file", JV::str(exported_grid_name(stem, size_t(index))));
            bool same = true;
            for (int r = 0; r < 3; ++r)
              for (int k = 0; k < 4; ++k) same = same && a.to_world.m[r][k] == g.to_world.m[r][k];
            if (!same) ao.set("transform", matrix(a.to_world));
            if (a.nearest != g.nearest) ao.set("filter", JV::str(a.nearest ? "nearest" : "trilinear"));
            if (a.clamp != g.clamp) ao.set("outside", JV::str(a.clamp ? "clamp" : "zero"));
            o.set(key, ao);
          };
          if (m.albedo_grid >= 0) other_grid(m.albedo_grid, "albedo");
          if (m.emission_grid >= 0) {
            // The grid holds Le(x) / Le; export folds a non-unit Le into its samples.
            if (!(m.Le.x == 1.f && m.Le.y == 1.f && m.Le.z == 1.f))
              throw InputError("export: an emission grid with a scale other than 1 is not representable in JSON");
            other_grid(m.emission_grid, "emission");
          }
        }
        media.set(medium_key(int(i)), o);
      }
      root.set("media", media);
    }

    std::vector<std::string> cam_names;
    for (const CameraDesc& c : d.cameras) cam_names.push_back(c.name);
    std::vector<std::string> cam_keys = unique_keys(cam_names, "camera");
    int current = -1;
    for (size_t i = 0; i < d.cameras.size(); ++i)
      if (current < 0 && cam_keys[i] == d.cameras[i].name && same_camera(d.cameras[i], d.camera)) current = int(i);
    root.set("camera", current >= 0 ? JV::str(cam_keys[current]) : camera(d.camera, true));
    if (!d.cameras.empty()) {
      JV cams = JV::object();
      for (size_t i = 0; i < d.cameras.size(); ++i) cams.set(cam_keys[i], camera(d.cameras[i], false));
      root.set("cameras", cams);
    }

    std::vector<std::string> mat_keys = unique_keys(d.material_names.size() == d.materials.size()
                                                        ? d.material_names
                                                        : std::vector<std::string>(d.materials.size()),
                                                    "material");
    JV mats = JV::object();
    for (size_t i = 0; i < d.materials.size(); ++i) mats.set(mat_keys[i], material(d.materials[i], mat_keys));
    root.set("materials", mats);

    std::vector<std::string> mesh_names;
    for (const MeshDesc& m : d.meshes) mesh_names.push_back(m.name);
    std::vector<std::string> mesh_keys = unique_keys(mesh_names, "mesh");
    if (!d.meshes.empty()) {
      JV meshes = JV::object();
      for (size_t i = 0; i < d.meshes.size(); ++i) meshes.set(mesh_keys[i], mesh(d.meshes[i]));
      root.set("meshes", meshes);
    }

    JV shapes = JV::array();
    for (const ShapeDesc& s : d.shapes) {
      JV o = JV::object();
      if (!s.name.empty()) o.set("name", JV::str(s.name));
      switch (s.type) {
        case ShapeType::kSphere: o.set("type", JV::str("sphere")); break;
        case ShapeType::kRectangle: o.set("type", JV::str("rectangle")); break;
        case ShapeType::kCube: o.set("type", JV::str("cube")); break;
        case ShapeType::kDisk: o.set("type", JV::str("disk")); break;
        case ShapeType::kMesh: o.set("type", JV::str("mesh")); break;
      }
      if (s.material < 0 || size_t(s.material) >= d.materials.size())
        throw InputError("export: shape '" + s.name + "': material index out of range");
      o.set("material", JV::str(mat_keys[s.material]));
      if (s.type == ShapeType::kSphere) o.set("center", vec(s.center)).set("radius", JV::flt(s.radius));
      if (s.type == ShapeType::kMesh) {
        if (s.mesh < 0 || size_t(s.mesh) >= d.meshes.size())
          throw InputError("export: shape '" + s.name + "': mesh index out of range");
        o.set("mesh", JV::str(mesh_keys[s.mesh]));
      }
      if (!is_identity(s.to_world)) o.set("transform", matrix(s.to_world));
      if (!is_black(s.emission) || s.emission_texture >= 0) o.set("emission", color_slot(s.emission, s.emission_texture));
      if (s.emission_two_sided) o.set("emission_two_sided", JV::boolean(true));
      if (s.flip_normals) o.set("flip_normals", JV::boolean(true));
      if (s.medium_interface) {
        // Both sides; null is vacuum.
        o.set("interior", s.interior >= 0 ? JV::str(medium_key(s.interior)) : JV());
        o.set("exterior", s.exterior >= 0 ? JV::str(medium_key(s.exterior)) : JV());
      }
      shapes.push(o);
    }
    root.set("shapes", shapes);

    if (!d.lights.empty()) {
      JV lights = JV::array();
      for (const Light& l : d.lights) lights.push(light(l));
      root.set("lights", lights);
    }
    return root;
  }
};

}  // namespace

std::string exported_texture_name(const std::string& texture_stem, size_t index) {
  return texture_stem + ".tex" + std::to_string(index) + ".exr";
}
std::string exported_grid_name(const std::string& texture_stem, size_t index) {
  return texture_stem + ".grid" + std::to_string(index) + ".vol";
}
std::string exported_alpha_texture_name(const std::string& texture_stem, size_t index) {
  return texture_stem + ".tex" + std::to_string(index) + ".alpha.exr";
}

std::string scene_desc_to_json(const SceneDesc& desc, const std::string& texture_stem) {
  Writer w{desc, texture_stem};
  std::string out;
  dump(w.scene(), out, 0);
  out += "\n";
  return out;
}

void write_scene_json(const SceneDesc& desc, const std::string& path) {
  namespace fs = std::filesystem;
  fs::path p(path);
  std::string stem = p.stem().string();
  std::string text = scene_desc_to_json(desc, stem);
  fs::path dir = p.parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::is_directory(dir, ec))
    throw InputError("cannot write '" + path + "': directory '" + dir.string() + "' does not exist");
  // Only the textures something refers to (a loader may keep images nothing uses).
  std::vector<bool> used(desc.textures.size(), false), used_alpha(desc.textures.size(), false);
  auto mark = [&](int t) {
    if (t >= 0 && size_t(t) < used.size()) used[t] = true;
  };
  for (const Material& m : desc.materials) {
    for (int t : material_textures(m, false)) mark(t);  // the opacity's below
    if (m.tex_opacity >= 0 && size_t(m.tex_opacity) < used.size()) {
      if (m.flags & kOpacityLuminance) used[m.tex_opacity] = true;
      else used_alpha[m.tex_opacity] = true;
    }
  }
  for (const ShapeDesc& sh : desc.shapes) mark(sh.emission_texture);
  for (const Light& l : desc.lights) mark(l.texture);
  for (size_t i = 0; i < desc.textures.size(); ++i) {
    if (!used[i]) continue;
    const TextureDesc& t = desc.textures[i];
    std::vector<float> rgb(size_t(t.width) * t.height * 3);
    for (size_t k = 0; k < size_t(t.width) * t.height; ++k)
      for (int ch = 0; ch < 3; ++ch) rgb[k * 3 + ch] = t.rgba[k * 4 + ch];
    write_image((dir / exported_texture_name(stem, i)).string(), rgb, t.width, t.height);
  }
  for (size_t i = 0; i < desc.textures.size(); ++i) {
    if (!used_alpha[i]) continue;
    const TextureDesc& t = desc.textures[i];
    std::vector<float> grey(size_t(t.width) * t.height * 3);
    for (size_t k = 0; k < size_t(t.width) * t.height; ++k)
      for (int ch = 0; ch < 3; ++ch) grey[k * 3 + ch] = t.rgba[k * 4 + 3];
    write_image((dir / exported_alpha_texture_name(stem, i)).string(), grey, t.width, t.height);
  }
  // The density and albedo grids the media use (Mitsuba's .vol format).
  for (const Medium& m : desc.media)
    for (int gi : {m.grid, m.albedo_grid, m.emission_grid})
      if (gi >= 0 && size_t(gi) < desc.grids.size())
        write_vol_grid(desc.grids[gi], (dir / exported_grid_name(stem, size_t(gi))).string());
  std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw InputError("cannot write '" + path + "': cannot create the file");
    f << text;
    if (!f) throw InputError("cannot write '" + path + "': write failed");
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError("cannot write '" + path + "': " + ec.message());
  }
}

}  // namespace caustica
