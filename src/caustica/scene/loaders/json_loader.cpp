#include "json_loader.h"

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "../../base/error.h"

namespace caustica {
namespace {

using json = nlohmann::json;

struct Ctx {
  std::string source;
  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError(source + ": " + (path.empty() ? "/" : path) + ": " + what);
  }
};

const char* type_name(const json& j) { return j.type_name(); }

float num(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_number()) c.fail(path, std::string("expected a number, got ") + type_name(j));
  double v = j.get<double>();
  if (!std::isfinite(v)) c.fail(path, "expected a finite number");
  return float(v);
}
Vec3f vec3(const Ctx& c, const json& j, const std::string& path) {
  if (j.is_number()) return Vec3f(num(c, j, path));  // a grey value
  if (!j.is_array() || j.size() != 3) c.fail(path, "expected an array of 3 numbers");
  return {num(c, j[0], path + "/0"), num(c, j[1], path + "/1"), num(c, j[2], path + "/2")};
}
RGB color(const Ctx& c, const json& j, const std::string& path) {
  Vec3f v = vec3(c, j, path);
  if (v.x < 0 || v.y < 0 || v.z < 0) c.fail(path, "expected non-negative colour values");
  return v;
}
std::string str(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_string()) c.fail(path, std::string("expected a string, got ") + type_name(j));
  return j.get<std::string>();
}
int integer(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_number_integer()) c.fail(path, std::string("expected an integer, got ") + type_name(j));
  return j.get<int>();
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

Affine parse_transform(const Ctx& c, const json& j, const std::string& path) {
  check_keys(c, j, path, {"matrix", "translate", "rotate", "scale"});
  Affine a;
  if (j.contains("matrix")) {
    const json& m = j["matrix"];
    if (!m.is_array() || (m.size() != 12 && m.size() != 16))
      c.fail(path + "/matrix", "expected 12 or 16 numbers (row-major 3x4 or 4x4)");
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 4; ++k) a.m[i][k] = num(c, m[i * 4 + k], path + "/matrix/" + std::to_string(i * 4 + k));
    if (j.size() > 1) c.fail(path, "'matrix' cannot be combined with translate/rotate/scale");
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
    Vec3f ax = vec3(c, r["axis"], path + "/rotate/axis");
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
  if (j.contains("translate")) tr = vec3(c, j["translate"], path + "/translate");
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) a.m[i][k] = R[i][k] * s[k];
    a.m[i][3] = tr[i];
  }
  return a;
}

Material parse_material(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_object()) c.fail(path, "expected an object");
  if (!j.contains("type")) c.fail(path, "missing 'type' (diffuse, conductor, dielectric, thindielectric, plastic, difftrans, phong)");
  std::string type = str(c, j["type"], path + "/type");
  auto get_c = [&](const char* k, RGB def) { return j.contains(k) ? color(c, j[k], path + "/" + k) : def; };
  auto get_f = [&](const char* k, float def) { return j.contains(k) ? num(c, j[k], path + "/" + k) : def; };
  auto positive = [&](const char* k, float v) {
    if (!(v > 0.f)) c.fail(path + "/" + k, "expected a positive number");
    return v;
  };
  Material m;
  if (type == "diffuse") {
    check_keys(c, j, path, {"type", "reflectance", "two_sided"});
    m = make_diffuse(get_c("reflectance", RGB(0.5f)));
  } else if (type == "conductor") {
    check_keys(c, j, path, {"type", "eta", "k", "specular", "roughness", "two_sided"});
    float alpha = get_f("roughness", 0.f);
    if (alpha < 0.f) c.fail(path + "/roughness", "expected a roughness >= 0");
    if (j.contains("eta") != j.contains("k")) c.fail(path, "give both 'eta' and 'k' (or neither for a tinted mirror)");
    if (j.contains("eta")) {
      m = make_conductor(get_c("eta", RGB(0.f)), get_c("k", RGB(0.f)), get_c("specular", RGB(1.f)), alpha);
    } else {
      m = make_mirror(get_c("specular", RGB(1.f)));
      if (alpha > 0.f) { m.type = MaterialType::kRoughConductor; m.alpha_x = m.alpha_y = alpha; }
    }
  } else if (type == "dielectric") {
    check_keys(c, j, path, {"type", "eta", "roughness", "specular", "transmission"});
    m = make_dielectric(positive("eta", get_f("eta", 1.5f)), get_f("roughness", 0.f));
    m.specular = get_c("specular", RGB(1.f));
    m.transmission = get_c("transmission", RGB(1.f));
  } else if (type == "thindielectric") {
    check_keys(c, j, path, {"type", "eta", "specular", "transmission"});
    m = make_thin_dielectric(positive("eta", get_f("eta", 1.5f)));
    m.specular = get_c("specular", RGB(1.f));
    m.transmission = get_c("transmission", RGB(1.f));
  } else if (type == "plastic") {
    check_keys(c, j, path, {"type", "diffuse", "eta", "specular", "two_sided"});
    m = make_plastic(get_c("diffuse", RGB(0.5f)), positive("eta", get_f("eta", 1.49f)), get_c("specular", RGB(1.f)));
  } else if (type == "difftrans") {
    check_keys(c, j, path, {"type", "reflectance", "transmittance"});
    m = make_diffuse_transmission(get_c("reflectance", RGB(0.f)), get_c("transmittance", RGB(0.5f)));
  } else if (type == "phong") {
    check_keys(c, j, path, {"type", "diffuse", "specular", "exponent", "two_sided"});
    m = make_phong(get_c("diffuse", RGB(0.1f)), get_c("specular", RGB(0.7f)), positive("exponent", get_f("exponent", 90.f)));
  } else {
    c.fail(path + "/type", "unknown material type '" + type +
                               "' (allowed: diffuse, conductor, dielectric, thindielectric, plastic, difftrans, phong)");
  }
  if (j.contains("two_sided") && boolean(c, j["two_sided"], path + "/two_sided")) m.flags |= kTwoSided;
  return m;
}

}  // namespace

SceneDesc load_json_scene_text(const std::string& text, const std::string& source) {
  Ctx c{source};
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    size_t line = 1, byte = std::min<size_t>(e.byte, text.size());
    for (size_t i = 0; i + 1 < byte; ++i) line += text[i] == '\n';
    std::string msg = e.what();
    auto p = msg.find("syntax error");
    throw InputError(source + ":" + std::to_string(line) + ": invalid JSON: " + (p == std::string::npos ? msg : msg.substr(p)));
  }
  check_keys(c, root, "", {"name", "camera", "filter", "max_depth", "materials", "shapes", "lights", "$schema"});
  SceneDesc d;
  d.name = root.contains("name") ? str(c, root["name"], "/name") : source;
  if (root.contains("max_depth")) {
    d.max_depth = integer(c, root["max_depth"], "/max_depth");
    if (d.max_depth == 0 || d.max_depth < -1) c.fail("/max_depth", "expected a positive integer or -1 (unlimited)");
  }
  if (root.contains("filter")) {
    std::string f = str(c, root["filter"], "/filter");
    if (f == "box") d.filter = FilterType::kBox;
    else if (f == "tent") d.filter = FilterType::kTent;
    else if (f == "gaussian") d.filter = FilterType::kGaussian;
    else c.fail("/filter", "unknown filter '" + f + "' (allowed: box, tent, gaussian)");
  }
  if (!root.contains("camera")) c.fail("/camera", "missing (a scene needs a camera)");
  {
    const json& j = root["camera"];
    check_keys(c, j, "/camera", {"position", "target", "up", "fov", "fov_axis", "width", "height", "aperture_radius", "focus_distance"});
    CameraDesc& cam = d.camera;
    if (j.contains("position")) cam.position = vec3(c, j["position"], "/camera/position");
    if (j.contains("target")) cam.target = vec3(c, j["target"], "/camera/target");
    if (j.contains("up")) cam.up = vec3(c, j["up"], "/camera/up");
    if (j.contains("fov")) cam.fov_degrees = num(c, j["fov"], "/camera/fov");
    if (!(cam.fov_degrees > 0.f && cam.fov_degrees < 180.f)) c.fail("/camera/fov", "expected degrees in (0, 180)");
    if (j.contains("fov_axis")) {
      std::string a = str(c, j["fov_axis"], "/camera/fov_axis");
      if (a == "x") cam.fov_axis = CameraDesc::FovAxis::kX;
      else if (a == "y") cam.fov_axis = CameraDesc::FovAxis::kY;
      else if (a == "smaller") cam.fov_axis = CameraDesc::FovAxis::kSmaller;
      else c.fail("/camera/fov_axis", "unknown axis '" + a + "' (allowed: x, y, smaller)");
    }
    if (j.contains("width")) cam.width = integer(c, j["width"], "/camera/width");
    if (j.contains("height")) cam.height = integer(c, j["height"], "/camera/height");
    if (cam.width <= 0 || cam.height <= 0) c.fail("/camera", "width and height must be positive integers");
    if (j.contains("aperture_radius")) cam.aperture_radius = num(c, j["aperture_radius"], "/camera/aperture_radius");
    if (j.contains("focus_distance")) cam.focus_distance = num(c, j["focus_distance"], "/camera/focus_distance");
    if (length(cam.target - cam.position) == 0.f) c.fail("/camera/target", "must differ from the position");
    if (length(cross(cam.target - cam.position, cam.up)) == 0.f) c.fail("/camera/up", "must not be parallel to the view direction");
  }
  std::map<std::string, int> mat_index;
  if (root.contains("materials")) {
    const json& mats = root["materials"];
    if (!mats.is_object()) c.fail("/materials", "expected an object mapping names to materials");
    for (auto it = mats.begin(); it != mats.end(); ++it) {
      mat_index[it.key()] = d.add_material(it.key(), parse_material(c, it.value(), "/materials/" + it.key()));
    }
  }
  if (!root.contains("shapes")) c.fail("/shapes", "missing (a scene needs at least one shape)");
  const json& shapes = root["shapes"];
  if (!shapes.is_array() || shapes.empty()) c.fail("/shapes", "expected a non-empty array");
  int default_mat = -1;
  for (size_t i = 0; i < shapes.size(); ++i) {
    std::string p = "/shapes/" + std::to_string(i);
    const json& j = shapes[i];
    check_keys(c, j, p, {"name", "type", "material", "emission", "emission_two_sided", "flip_normals", "transform",
                         "center", "radius", "positions", "indices", "normals"});
    ShapeDesc s;
    s.name = j.contains("name") ? str(c, j["name"], p + "/name") : p;
    if (!j.contains("type")) c.fail(p, "missing 'type' (sphere, rectangle, cube, disk, mesh)");
    std::string type = str(c, j["type"], p + "/type");
    if (type == "sphere") {
      s.type = ShapeType::kSphere;
      if (j.contains("center")) s.center = vec3(c, j["center"], p + "/center");
      if (j.contains("radius")) s.radius = num(c, j["radius"], p + "/radius");
      if (!(s.radius > 0.f)) c.fail(p + "/radius", "expected a positive radius");
    } else if (type == "rectangle") s.type = ShapeType::kRectangle;
    else if (type == "cube") s.type = ShapeType::kCube;
    else if (type == "disk") s.type = ShapeType::kDisk;
    else if (type == "mesh") {
      s.type = ShapeType::kMesh;
      MeshDesc m;
      if (!j.contains("positions") || !j["positions"].is_array()) c.fail(p + "/positions", "expected an array of [x,y,z] points");
      for (size_t k = 0; k < j["positions"].size(); ++k)
        m.positions.push_back(vec3(c, j["positions"][k], p + "/positions/" + std::to_string(k)));
      if (!j.contains("indices") || !j["indices"].is_array() || j["indices"].size() % 3 != 0 || j["indices"].empty())
        c.fail(p + "/indices", "expected a flat array of vertex indices, 3 per triangle");
      for (size_t k = 0; k < j["indices"].size(); ++k) {
        int v = integer(c, j["indices"][k], p + "/indices/" + std::to_string(k));
        if (v < 0 || size_t(v) >= m.positions.size())
          c.fail(p + "/indices/" + std::to_string(k), "vertex index " + std::to_string(v) + " out of range");
        m.indices.push_back(uint32_t(v));
      }
      if (j.contains("normals")) {
        if (!j["normals"].is_array() || j["normals"].size() != m.positions.size())
          c.fail(p + "/normals", "expected one normal per position");
        for (size_t k = 0; k < j["normals"].size(); ++k)
          m.normals.push_back(vec3(c, j["normals"][k], p + "/normals/" + std::to_string(k)));
      }
      m.name = s.name;
      d.meshes.push_back(std::move(m));
      s.mesh = int(d.meshes.size()) - 1;
    } else {
      c.fail(p + "/type", "unknown shape type '" + type + "' (allowed: sphere, rectangle, cube, disk, mesh)");
    }
    if (j.contains("material")) {
      std::string mn = str(c, j["material"], p + "/material");
      auto it = mat_index.find(mn);
      if (it == mat_index.end()) c.fail(p + "/material", "no material named '" + mn + "' in /materials");
      s.material = it->second;
    } else {
      if (default_mat < 0) default_mat = d.add_material("default", make_diffuse(RGB(0.5f)));
      s.material = default_mat;
    }
    if (j.contains("emission")) s.emission = color(c, j["emission"], p + "/emission");
    if (j.contains("emission_two_sided")) s.emission_two_sided = boolean(c, j["emission_two_sided"], p + "/emission_two_sided");
    if (j.contains("flip_normals")) s.flip_normals = boolean(c, j["flip_normals"], p + "/flip_normals");
    if (j.contains("transform")) s.to_world = parse_transform(c, j["transform"], p + "/transform");
    d.shapes.push_back(s);
  }
  if (root.contains("lights")) {
    const json& lights = root["lights"];
    if (!lights.is_array()) c.fail("/lights", "expected an array");
    for (size_t i = 0; i < lights.size(); ++i) {
      std::string p = "/lights/" + std::to_string(i);
      const json& j = lights[i];
      if (!j.is_object() || !j.contains("type")) c.fail(p, "expected an object with a 'type' (point, spot, directional, environment)");
      std::string type = str(c, j["type"], p + "/type");
      Light l;
      if (type == "point") {
        check_keys(c, j, p, {"type", "position", "intensity"});
        l.type = LightType::kPoint;
        l.p = j.contains("position") ? vec3(c, j["position"], p + "/position") : Vec3f(0.f);
        l.L = j.contains("intensity") ? color(c, j["intensity"], p + "/intensity") : RGB(1.f);
      } else if (type == "spot") {
        check_keys(c, j, p, {"type", "position", "target", "intensity", "cutoff_angle", "falloff_start"});
        l.type = LightType::kSpot;
        l.p = j.contains("position") ? vec3(c, j["position"], p + "/position") : Vec3f(0.f);
        Vec3f tgt = j.contains("target") ? vec3(c, j["target"], p + "/target") : l.p + Vec3f(0, 0, -1);
        if (length(tgt - l.p) == 0.f) c.fail(p + "/target", "must differ from the position");
        l.dir = normalize(tgt - l.p);
        l.L = j.contains("intensity") ? color(c, j["intensity"], p + "/intensity") : RGB(1.f);
        float cutoff = j.contains("cutoff_angle") ? num(c, j["cutoff_angle"], p + "/cutoff_angle") : 30.f;
        float start = j.contains("falloff_start") ? num(c, j["falloff_start"], p + "/falloff_start") : cutoff * 0.75f;
        if (!(cutoff > 0.f && cutoff <= 180.f)) c.fail(p + "/cutoff_angle", "expected degrees in (0, 180]");
        if (!(start >= 0.f && start <= cutoff)) c.fail(p + "/falloff_start", "expected degrees in [0, cutoff_angle]");
        l.cos_total = std::cos(cutoff * kPi / 180.f);
        l.cos_falloff_start = std::cos(start * kPi / 180.f);
      } else if (type == "directional") {
        check_keys(c, j, p, {"type", "direction", "irradiance"});
        l.type = LightType::kDirectional;
        l.dir = j.contains("direction") ? vec3(c, j["direction"], p + "/direction") : Vec3f(0, 0, -1);
        if (length(l.dir) == 0.f) c.fail(p + "/direction", "expected a non-zero direction");
        l.L = j.contains("irradiance") ? color(c, j["irradiance"], p + "/irradiance") : RGB(1.f);
      } else if (type == "environment") {
        check_keys(c, j, p, {"type", "radiance"});
        l.type = LightType::kEnvironment;
        l.L = j.contains("radiance") ? color(c, j["radiance"], p + "/radiance") : RGB(1.f);
      } else {
        c.fail(p + "/type", "unknown light type '" + type + "' (allowed: point, spot, directional, environment)");
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
  return load_json_scene_text(ss.str(), path);
}

}  // namespace caustica
