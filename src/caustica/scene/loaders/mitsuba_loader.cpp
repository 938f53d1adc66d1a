// Mitsuba 3 XML scenes: the subset documented in docs/formats-mitsuba.md.
//
// The file is parsed with pugixml; every message names the file and line of the
// element concerned ("scene.xml:42: <bsdf type=\"velvet\">: ..."). Each plugin
// element's children are gathered into a property table; the code for a
// plugin asks for the properties it understands (which also builds the list of
// supported names shown in messages) and at the end every property it did not
// ask for is either ignorable (a warning, once per kind) or an error.
#include "mitsuba_loader.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <pugixml.hpp>
#include <set>
#include <sstream>

#include "../../base/error.h"
#include "../load.h"
#include "mesh_loaders.h"
#include "../volume_io.h"
#include "../spectrum.h"

namespace caustica {
namespace {

namespace fs = std::filesystem;
using pugi::xml_node;

// ---------------------------------------------------------------------------
// Small 4x4 (double) transforms, composed as Mitsuba does: every operation in
// a <transform> is applied after the ones before it (M = op * M).
struct M4 {
  double a[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
};
M4 mul(const M4& x, const M4& y) {
  M4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += x.a[i][k] * y.a[k][j];
      r.a[i][j] = s;
    }
  return r;
}
Affine to_affine(const M4& m) {
  Affine a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) a.m[i][j] = float(m.a[i][j]);
  return a;
}
double det3(const M4& m) {
  const auto& a = m.a;
  return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
         a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
}
struct V3 {
  double x = 0, y = 0, z = 0;
};
V3 sub(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 cross3(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double len3(V3 a) { return std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z); }
V3 scale3(V3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
V3 column(const M4& m, int j) { return {m.a[0][j], m.a[1][j], m.a[2][j]}; }
Vec3f to_vec(V3 v) { return Vec3f(float(v.x), float(v.y), float(v.z)); }

// ---------------------------------------------------------------------------
// Named data.

// Mitsuba 3's table of named indices of refraction (dielectric plugin
// documentation, "IOR values"); the values as Mitsuba 3.9.1 reports them.
struct NamedIor {
  const char* name;
  float ior;
};
const NamedIor kIors[] = {
    {"vacuum", 1.0f},          {"helium", 1.000036f},         {"hydrogen", 1.000132f},
    {"air", 1.000277f},        {"carbon dioxide", 1.00045f},  {"water", 1.333f},
    {"acetone", 1.36f},        {"ethanol", 1.361f},           {"carbon tetrachloride", 1.461f},
    {"glycerol", 1.4729f},     {"benzene", 1.501f},           {"silicone oil", 1.52045f},
    {"bromine", 1.661f},       {"water ice", 1.31f},          {"fused quartz", 1.458f},
    {"pyrex", 1.47f},          {"acrylic glass", 1.49f},      {"polypropylene", 1.49f},
    {"bk7", 1.5046f},          {"sodium chloride", 1.544f},   {"amber", 1.55f},
    {"pet", 1.575f},           {"diamond", 2.419f},
};

// Complex indices of refraction of Mitsuba 3's named conductors: the measured
// spectra shipped with Mitsuba 3 (data/ior/*.spd, from the Palik handbook via
// PBRT-v3's data) as Mitsuba 3.9.1's RGB variants reduce them to linear sRGB
// (the values its scalar_rgb variant reports for `conductor` with `material`).
struct NamedConductor {
  const char* name;
  RGB eta, k;
};
const NamedConductor kConductors[] = {
    {"a-C", {2.94405f, 2.22714f, 1.96816f}, {0.887465f, 0.799299f, 0.81529f}},
    {"Ag", {0.155276f, 0.116728f, 0.138388f}, {4.82835f, 3.12222f, 2.1469f}},
    {"Al", {1.6575f, 0.880405f, 0.521244f}, {9.22381f, 6.2695f, 4.837f}},
    {"AlAs", {3.6053f, 3.23294f, 2.21632f}, {0.000679437f, 0.f, 0.00751271f}},
    {"AlSb", {0.f, 4.13937f, 4.66925f}, {0.f, 0.0940091f, 1.30057f}},
    {"Au", {0.143036f, 0.375307f, 1.44205f}, {3.983f, 2.38556f, 1.60336f}},
    {"Be", {4.18501f, 3.18503f, 2.78406f}, {3.83547f, 3.01012f, 2.86899f}},
    {"Cr", {4.36967f, 2.91651f, 1.6549f}, {5.20655f, 4.23131f, 3.7547f}},
    {"CsI", {2.1449f, 1.70232f, 1.66243f}, {0.f, 0.f, 0.f}},
    {"Cu", {0.201005f, 0.92375f, 1.10222f}, {3.91326f, 2.45305f, 2.14209f}},
    {"Cu2O", {3.55177f, 2.94987f, 2.75188f}, {0.114207f, 0.193897f, 0.606134f}},
    {"CuO", {3.24754f, 2.44781f, 2.21022f}, {0.52109f, 0.570031f, 0.722179f}},
    {"d-C", {2.70872f, 2.31883f, 2.2289f}, {0.f, 0.f, 0.f}},
    {"Hg", {2.39894f, 1.44003f, 0.90957f}, {6.32759f, 4.37192f, 3.42176f}},
    {"HgTe", {4.77904f, 3.2312f, 2.6599f}, {1.63161f, 1.58081f, 1.72929f}},
    {"Ir", {3.0863f, 2.08219f, 1.61791f}, {5.59215f, 4.06709f, 3.26731f}},
    {"K", {0.0640432f, 0.0464098f, 0.0381849f}, {2.1042f, 1.34894f, 0.913126f}},
    {"Li", {0.265791f, 0.195618f, 0.220949f}, {3.54015f, 2.31112f, 1.66861f}},
    {"MgO", {2.08958f, 1.65072f, 1.59488f}, {0.f, 0.f, 0.f}},
    {"Mo", {4.48397f, 3.52513f, 2.77631f}, {4.11144f, 3.42083f, 3.15061f}},
    {"Na_palik", {0.0602694f, 0.0561409f, 0.0619884f}, {3.17927f, 2.11249f, 1.57904f}},
    {"Nb", {3.42007f, 2.79009f, 2.39563f}, {3.44139f, 2.73767f, 2.57975f}},
    {"Ni_palik", {2.3673f, 1.66337f, 1.46708f}, {4.49881f, 3.05015f, 2.34544f}},
    {"Rh", {2.58579f, 1.86022f, 1.55426f}, {6.78226f, 4.70299f, 3.97607f}},
    {"Se", {4.05831f, 2.84294f, 2.82085f}, {0.75405f, 0.638444f, 0.521808f}},
    {"Se-e", {5.72285f, 4.16574f, 4.08134f}, {0.871136f, 1.10516f, 1.56532f}},
    {"SiC", {3.17234f, 2.52597f, 2.47937f}, {7.53766e-07f, 0.f, 1.01925e-05f}},
    {"SnTe", {4.52425f, 1.98164f, 1.28159f}, {0.f, 0.f, 0.f}},
    {"Ta", {2.06272f, 2.39294f, 2.62793f}, {2.40836f, 1.74149f, 1.94703f}},
    {"Te", {7.39023f, 4.4821f, 2.63711f}, {3.25602f, 3.52706f, 3.29205f}},
    {"Te-e", {7.50891f, 4.29643f, 2.36999f}, {5.58393f, 4.94721f, 3.99759f}},
    {"ThF4", {1.83071f, 1.44223f, 1.38765f}, {0.f, 0.f, 0.f}},
    {"TiC", {3.70053f, 2.83742f, 2.58229f}, {3.26564f, 2.35159f, 2.17279f}},
    {"TiN", {1.64845f, 1.15052f, 1.37982f}, {3.36833f, 1.9435f, 1.10207f}},
    {"TiO2", {3.45661f, 2.80174f, 2.90517f}, {0.000105265f, 0.f, 0.000652887f}},
    {"TiO2-e", {3.10656f, 2.51317f, 2.58244f}, {2.97516e-05f, 0.f, 0.000182698f}},
    {"V_palik", {4.27758f, 3.51295f, 2.76107f}, {3.4913f, 2.88945f, 3.11152f}},
    {"VC", {3.65757f, 2.75274f, 2.53267f}, {3.0683f, 2.19869f, 1.96319f}},
    {"VN", {2.8656f, 2.11919f, 1.94009f}, {3.03224f, 2.05612f, 1.61631f}},
    {"W", {4.37082f, 3.30025f, 2.99841f}, {3.50064f, 2.60487f, 2.27323f}},
};

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}
// A number for messages (6 significant digits).
std::string fmt(double x) {
  std::ostringstream o;
  o << x;
  return o.str();
}
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

// Numbers separated by commas and/or whitespace; false on anything else.
bool parse_numbers(const std::string& s, std::vector<double>& out) {
  out.clear();
  std::string t = s;
  for (char& c : t)
    if (c == ',') c = ' ';
  const char* p = t.c_str();
  while (true) {
    while (*p && std::isspace((unsigned char)*p)) ++p;
    if (!*p) break;
    char* end = nullptr;
    double v = std::strtod(p, &end);
    if (end == p) return false;
    if (*end && !std::isspace((unsigned char)*end)) return false;
    out.push_back(v);
    p = end;
  }
  return true;
}

// ---------------------------------------------------------------------------

struct XmlFile {
  std::string path;  // as shown in messages
  fs::path dir;
  std::string text;
  std::vector<size_t> newlines;  // byte offsets of '\n'
  pugi::xml_document doc;
  int line_of(ptrdiff_t offset) const {
    if (offset < 0) return 0;
    return int(std::upper_bound(newlines.begin(), newlines.end(), size_t(offset)) - newlines.begin()) + 1;
  }
};

const char* const kPropertyTags[] = {"float", "integer", "boolean", "string", "rgb",
                                     "spectrum", "point", "vector", "transform"};
bool is_property_tag(const std::string& t) {
  for (const char* p : kPropertyTags)
    if (t == p) return true;
  return false;
}

struct ColorOrTexture {
  RGB value{0.f};
  int texture = -1;
};

// How Mitsuba 3's RGB variants reduce a <spectrum> given for a property (scene/spectrum.h): a reflectance
// (and every other bounded quantity) is seen under D65 and clamped to [0, 1]; a conductor's eta and k and a
// constvolume's value under D65, unclamped; an emitter's radiance, intensity or irradiance as it is,
// unclamped, and a single value there is the equal-energy white of that luminance. Negative channels become 0
// in all three. Colours given as <rgb> or <float> are used as they are in all three.
enum class SpectrumUse { kReflectance, kUnbounded, kEmission };

class Loader;

// The children of one plugin element.
struct Props {
  Loader& L;
  xml_node node;
  std::vector<xml_node> props;  // named property elements (including named <texture>/<ref>)
  std::vector<std::string> names;
  std::vector<bool> used;
  std::vector<xml_node> objects;  // nested plugin elements without a property name
  std::vector<bool> obj_used;
  std::vector<std::string> supported;  // names asked for, for messages

  Props(Loader& l, xml_node n);
  xml_node get(const std::string& name) {
    if (std::find(supported.begin(), supported.end(), name) == supported.end()) supported.push_back(name);
    for (size_t i = 0; i < props.size(); ++i)
      if (names[i] == name) {
        used[i] = true;
        return props[i];
      }
    return xml_node();
  }
  // The full list of properties a plugin understands (for messages).
  void declare(std::initializer_list<const char*> v) {
    for (const char* x : v)
      if (std::find(supported.begin(), supported.end(), x) == supported.end()) supported.push_back(x);
  }
  bool has(const std::string& name) const {
    return std::find(names.begin(), names.end(), name) != names.end();
  }
  float get_float(const std::string& name, float def);
  int get_int(const std::string& name, int def);
  bool get_bool(const std::string& name, bool def);
  std::string get_string(const std::string& name, const std::string& def);
  RGB get_color(const std::string& name, RGB def, SpectrumUse use = SpectrumUse::kReflectance);
  ColorOrTexture get_color_tex(const std::string& name, RGB def, SpectrumUse use = SpectrumUse::kReflectance);
  Vec3f get_point(const std::string& name, Vec3f def);
  M4 get_transform(const std::string& name, bool* present = nullptr);
  float get_ior(const std::string& name, float def);
  // The one texture a wrapper plugin (normalmap, bumpmap) holds, whatever its name: a nested <texture>, named
  // or not, or a named <ref> other than a BSDF's (marked used); null if there is none.
  xml_node take_texture() {
    for (size_t i = 0; i < props.size(); ++i)
      if (!used[i] && (std::string(props[i].name()) == "texture" ||
                       (std::string(props[i].name()) == "ref" && names[i] != "bsdf"))) {
        used[i] = true;
        return props[i];
      }
    for (size_t i = 0; i < objects.size(); ++i)
      if (!obj_used[i] && std::string(objects[i].name()) == "texture") {
        obj_used[i] = true;
        return objects[i];
      }
    return xml_node();
  }
  // The nested BSDFs of a wrapper plugin: <bsdf> elements and <ref>s to BSDFs, in the file's order (marked
  // used).
  std::vector<xml_node> take_bsdfs() {
    std::vector<xml_node> r = take_objects("bsdf"), refs = take_objects("ref");
    r.insert(r.end(), refs.begin(), refs.end());
    std::stable_sort(r.begin(), r.end(), [](xml_node a, xml_node b) { return a.offset_debug() < b.offset_debug(); });
    return r;
  }
  // Nested plugin elements with the given tag (marked used).
  std::vector<xml_node> take_objects(const std::string& tag) {
    std::vector<xml_node> r;
    if (tag == "ref")  // <ref name="..." id="..."/> names are not needed to place a BSDF
      for (size_t i = 0; i < props.size(); ++i)
        if (!used[i] && props[i].name() == tag && names[i] == "bsdf") {
          used[i] = true;
          r.push_back(props[i]);
        }
    for (size_t i = 0; i < objects.size(); ++i)
      if (!obj_used[i] && objects[i].name() == tag) {
        obj_used[i] = true;
        r.push_back(objects[i]);
      }
    return r;
  }
  // Reports every property not asked for: `ignorable` ones as a warning, the
  // rest as errors; and every nested element not taken.
  void finish(std::initializer_list<const char*> ignorable = {});
};

class Loader {
 public:
  SceneDesc d;
  std::map<std::string, std::string> params;
  std::set<std::string> given_params, used_params;
  std::vector<std::unique_ptr<XmlFile>> files;
  fs::path main_dir;
  std::vector<fs::path> search_dirs;  // <path value=...>
  struct Id {
    std::string kind;  // "bsdf", "texture", "shape", ...
    int index = -1;
    xml_node node;
  };
  std::map<std::string, Id> ids;
  std::set<std::string> warned;
  int default_material = -1, default_emitter_material = -1;
  bool have_integrator = false, have_environment = false;
  // Shapegroups (their shapes, each with its own to_world before an instance's) and the state while one is read.
  using ShapeGroup = std::vector<std::pair<ShapeDesc, M4>>;
  std::vector<ShapeGroup> groups_;
  bool in_shapegroup_ = false;
  M4 shape_to_world_;  // the to_world of the shapes parse_shape added last
  int anonymous_bsdfs = 0;

  // ---- messages ----
  const XmlFile* file_of(xml_node n) const {
    xml_node r = n.root();
    for (const auto& f : files)
      if (f->doc.root() == r) return f.get();
    return files.empty() ? nullptr : files.front().get();
  }
  std::string where(xml_node n) const {
    const XmlFile* f = file_of(n);
    if (!f) return "?";
    int line = f->line_of(n.offset_debug());
    return f->path + (line > 0 ? ":" + std::to_string(line) : "");
  }
  static std::string describe(xml_node n) {
    std::string s = "<" + std::string(n.name());
    for (const char* a : {"type", "name", "id"})
      if (xml_node(n).attribute(a)) s += std::string(" ") + a + "=\"" + n.attribute(a).value() + "\"";
    return s + ">";
  }
  [[noreturn]] void fail(xml_node n, const std::string& what) const {
    if (!n) throw InputError((files.empty() ? std::string("?") : files.front()->path) + ": " + what);
    throw InputError(where(n) + ": " + describe(n) + ": " + what);
  }
  void warn(xml_node n, const std::string& key, const std::string& what) {
    if (!warned.insert(key).second) return;
    d.warnings.push_back(where(n) + ": " + describe(n) + ": " + what);
  }

  // ---- attributes with $parameter substitution ----
  std::string subst(xml_node n, const std::string& s) {
    std::string r;
    for (size_t i = 0; i < s.size(); ++i) {
      if (s[i] != '$') {
        r += s[i];
        continue;
      }
      size_t j = i + 1;
      while (j < s.size() && (std::isalnum((unsigned char)s[j]) || s[j] == '_')) ++j;
      if (j == i + 1) {
        r += '$';
        continue;
      }
      std::string name = s.substr(i + 1, j - i - 1);
      auto it = params.find(name);
      if (it == params.end())
        fail(n, "undefined parameter $" + name + " (declare it with <default name=\"" + name +
                    "\" value=\"...\"/> or pass a value for it)");
      used_params.insert(name);
      r += it->second;
      i = j - 1;
    }
    return r;
  }
  bool has_attr(xml_node n, const char* a) const { return bool(n.attribute(a)); }
  std::string attr(xml_node n, const char* a) {
    if (!n.attribute(a)) fail(n, std::string("missing attribute '") + a + "'");
    return subst(n, n.attribute(a).value());
  }
  std::string attr_or(xml_node n, const char* a, const std::string& def) {
    return n.attribute(a) ? subst(n, n.attribute(a).value()) : def;
  }
  void check_attrs(xml_node n, std::initializer_list<const char*> allowed) {
    for (pugi::xml_attribute a : n.attributes()) {
      bool ok = false;
      for (const char* x : allowed) ok |= std::string(a.name()) == x;
      if (!ok) {
        std::vector<std::string> v;
        for (const char* x : allowed) v.push_back(x);
        fail(n, std::string("unknown attribute '") + a.name() + "' (allowed: " + join(v) + ")");
      }
    }
  }
  double number(xml_node n, const std::string& s, const char* what = "a number") {
    std::vector<double> v;
    if (!parse_numbers(s, v) || v.size() != 1) fail(n, std::string("expected ") + what + ", got '" + s + "'");
    if (!std::isfinite(v[0])) fail(n, std::string("expected a finite number, got '") + s + "'");
    return v[0];
  }
  std::vector<double> numbers(xml_node n, const std::string& s, std::initializer_list<size_t> counts,
                              const std::string& what) {
    std::vector<double> v;
    bool ok = parse_numbers(s, v);
    bool count_ok = false;
    for (size_t c : counts) count_ok |= v.size() == c;
    if (!ok || !count_ok) fail(n, "expected " + what + ", got '" + s + "'");
    for (double x : v)
      if (!std::isfinite(x)) fail(n, "expected finite numbers, got '" + s + "'");
    return v;
  }
  // x/y/z attributes (each defaulting to `def`) or value="x, y, z" (or one number for all three).
  V3 xyz(xml_node n, double def, bool allow_single) {
    if (has_attr(n, "value")) {
      if (has_attr(n, "x") || has_attr(n, "y") || has_attr(n, "z")) fail(n, "give either 'value' or x/y/z, not both");
      std::vector<double> v = allow_single ? numbers(n, attr(n, "value"), {1, 3}, "1 or 3 numbers")
                                           : numbers(n, attr(n, "value"), {3}, "3 numbers");
      if (v.size() == 1) return {v[0], v[0], v[0]};
      return {v[0], v[1], v[2]};
    }
    V3 r{def, def, def};
    if (has_attr(n, "x")) r.x = number(n, attr(n, "x"));
    if (has_attr(n, "y")) r.y = number(n, attr(n, "y"));
    if (has_attr(n, "z")) r.z = number(n, attr(n, "z"));
    return r;
  }

  // ---- spectra ----
  // A <spectrum> property reduced to linear sRGB as Mitsuba 3's RGB variants reduce it for `use`
  // (docs/formats-mitsuba.md, "Properties"): value="v" (one value), value="l1:v1, l2:v2, ..." (nanometres in
  // increasing order, a piecewise-linear spectrum, zero outside), filename="f.spd" (the same pairs, one per
  // line, '#' comments), type="uniform" (its `value`) or type="blackbody" (its `temperature` in kelvin; an
  // emission only: Planck's law in W m^-2 sr^-1 nm^-1, as Mitsuba's spectral variants render it, which its RGB
  // variants refuse to).
  RGB spectrum(xml_node n, SpectrumUse use) {
    check_attrs(n, {"name", "value", "filename", "type"});
    const bool emission = use == SpectrumUse::kEmission;
    SpectrumRgb c;
    if (has_attr(n, "type")) {
      if (has_attr(n, "value") || has_attr(n, "filename"))
        fail(n, "a <spectrum type=\"...\"> takes its parameters as nested properties, not value or filename");
      const std::string t = attr(n, "type");
      Props sp(*this, n);
      if (t == "uniform") {
        sp.declare({"value"});
        const float v = sp.get_float("value", 1.f);
        sp.finish();
        return RGB(v);
      }
      if (t != "blackbody")
        fail(n, "unsupported spectrum type '" + t +
                    "' (supported: uniform, blackbody; or value=\"wavelength:value, ...\" or filename=\"*.spd\")");
      if (!emission)
        fail(n, "a blackbody spectrum is an emission: it is accepted for an emitter's radiance, intensity or "
                "irradiance only");
      sp.declare({"temperature"});
      if (!sp.has("temperature")) fail(n, "missing <float name=\"temperature\"> (kelvin)");
      const double kelvin = sp.get_float("temperature", 0.f);
      if (!(kelvin > 0.0)) fail(n, "expected a temperature above 0 kelvin");
      sp.finish();
      c = spectrum_to_linear_srgb([kelvin](double nm) { return planck_radiance(nm, kelvin); }, false);
    } else {
      std::vector<double> nm, value;
      if (has_attr(n, "filename")) {
        if (has_attr(n, "value")) fail(n, "give either value or filename, not both");
        read_spd(n, nm, value);
      } else {
        if (!has_attr(n, "value")) fail(n, "missing value=\"...\" or filename=\"...\"");
        const std::string s = attr(n, "value");
        if (s.find(':') == std::string::npos) {
          const double v = number(n, s, "one value or wavelength:value pairs");
          if (!emission) return RGB(float(v));
          // The equal-energy spectrum of luminance v: XYZ = (v, v, v).
          c = xyz_to_linear_srgb({v, v, v});
          return RGB(float(c.r), float(c.g), float(c.b));
        }
        std::string t = s;
        for (char& ch : t)
          if (ch == ':') ch = ' ';
        std::vector<double> v;
        if (!parse_numbers(t, v) || v.size() % 2) fail(n, "expected wavelength:value pairs, got '" + s + "'");
        for (size_t i = 0; i + 1 < v.size(); i += 2) {
          if (!std::isfinite(v[i]) || !std::isfinite(v[i + 1])) fail(n, "expected finite numbers, got '" + s + "'");
          nm.push_back(v[i]);
          value.push_back(v[i + 1]);
        }
      }
      if (nm.size() < 2) fail(n, "a spectrum needs at least two wavelength:value pairs (or one value for a flat one)");
      for (size_t i = 1; i < nm.size(); ++i)
        if (!(nm[i] > nm[i - 1])) fail(n, "the wavelengths must increase (" + fmt(nm[i - 1]) + " then " + fmt(nm[i]) + ")");
      c = piecewise_linear_srgb(nm, value, !emission);
    }
    double rgb[3] = {c.r, c.g, c.b};
    bool clamped = false;
    for (double& x : rgb) {
      const double y = std::max(use == SpectrumUse::kReflectance ? std::min(x, 1.0) : x, 0.0);
      clamped |= y != x;
      x = y;
    }
    if (clamped)
      warn(n, "spectrum-gamut",
           "the spectrum's linear sRGB (" + fmt(c.r) + ", " + fmt(c.g) + ", " + fmt(c.b) + ") lies outside " +
               (use == SpectrumUse::kReflectance ? "[0, 1]" : "the non-negative colours") +
               "; clamped as Mitsuba 3 does");
    return RGB(float(rgb[0]), float(rgb[1]), float(rgb[2]));
  }
  // A Mitsuba .spd file: "wavelength value" per line, '#' to the end of a line a comment.
  void read_spd(xml_node n, std::vector<double>& nm, std::vector<double>& value) {
    const fs::path path = existing_file(n, attr(n, "filename"), "spectrum file");
    std::ifstream in(path);
    if (!in) fail(n, "cannot read spectrum file '" + path.string() + "'");
    std::string line;
    for (int no = 1; std::getline(in, line); ++no) {
      const size_t hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      std::vector<double> v;
      if (!parse_numbers(line, v) || (v.size() != 0 && v.size() != 2) ||
          (v.size() == 2 && !(std::isfinite(v[0]) && std::isfinite(v[1]))))
        fail(n, "spectrum file '" + path.string() + "' line " + std::to_string(no) +
                    ": expected a wavelength and a value, got '" + line + "'");
      if (v.empty()) continue;
      nm.push_back(v[0]);
      value.push_back(v[1]);
    }
  }

  // ---- files ----
  fs::path resolve(xml_node n, const std::string& name) {
    fs::path p(name);
    if (p.is_absolute()) return p;
    const XmlFile* f = file_of(n);
    std::vector<fs::path> dirs;
    if (f) dirs.push_back(f->dir);
    dirs.push_back(main_dir);
    for (const fs::path& s : search_dirs) dirs.push_back(s);
    std::error_code ec;
    for (const fs::path& dir : dirs) {
      fs::path c = dir / p;
      if (fs::exists(c, ec)) return c;
    }
    return dirs.front() / p;
  }
  fs::path existing_file(xml_node n, const std::string& name, const char* what) {
    fs::path p = resolve(n, name);
    std::error_code ec;
    if (!fs::exists(p, ec)) fail(n, std::string(what) + " '" + p.string() + "' does not exist");
    if (fs::is_directory(p, ec)) fail(n, std::string(what) + " '" + p.string() + "' is a directory");
    return p;
  }

  XmlFile& open(const std::string& path, xml_node referrer) {
    auto f = std::make_unique<XmlFile>();
    f->path = path;
    f->dir = fs::path(path).parent_path();
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      if (referrer) fail(referrer, "cannot open included file '" + path + "'");
      throw InputError(path + ": cannot open the file");
    }
    std::stringstream ss;
    ss << in.rdbuf();
    f->text = ss.str();
    for (size_t i = 0; i < f->text.size(); ++i)
      if (f->text[i] == '\n') f->newlines.push_back(i);
    pugi::xml_parse_result r =
        f->doc.load_buffer(f->text.data(), f->text.size(), pugi::parse_default, pugi::encoding_utf8);
    if (!r) throw InputError(path + ":" + std::to_string(f->line_of(r.offset)) + ": invalid XML: " + r.description());
    files.push_back(std::move(f));
    return *files.back();
  }

  xml_node root_of(XmlFile& f) {
    xml_node root;
    for (xml_node c : f.doc.children())
      if (c.type() == pugi::node_element) {
        if (root) fail(c, "expected a single <scene> root element");
        root = c;
      }
    if (!root) throw InputError(f.path + ": expected a <scene> root element, found none");
    if (std::string(root.name()) != "scene") fail(root, "expected a <scene> root element");
    check_attrs(root, {"version"});
    if (has_attr(root, "version")) {
      std::string v = attr(root, "version");
      std::string major = v.substr(0, v.find('.'));
      char* end = nullptr;
      long mj = std::strtol(major.c_str(), &end, 10);
      if (major.empty() || *end) fail(root, "expected a version such as \"3.0.0\", got '" + v + "'");
      if (mj < 2)
        fail(root, "version " + v + " is a Mitsuba 0.x scene; caustica reads the Mitsuba 3 format (convert it with Mitsuba 3 first)");
    }
    return root;
  }

  // ---- the scene ----
  void load(const std::string& path) {
    d.name = fs::path(path).stem().string();
    main_dir = fs::path(path).parent_path();
    XmlFile& f = open(path, xml_node());
    xml_node root = root_of(f);
    std::vector<std::string> stack{fs::absolute(path).lexically_normal().string()};
    scene_children(root, stack);
    for (const std::string& p : given_params)
      if (!used_params.count(p))
        d.warnings.push_back(path + ": parameter '" + p + "' was given but the scene does not use it");
    if (d.materials.empty()) default_bsdf();
    if (d.cameras.empty()) default_camera();
  }

  void scene_children(xml_node root, std::vector<std::string>& include_stack) {
    for (xml_node c : root.children()) {
      if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) fail(root, "unexpected text in <scene>");
      if (c.type() != pugi::node_element) continue;
      std::string tag = c.name();
      if (tag == "default") {
        check_attrs(c, {"name", "value"});
        std::string name = attr(c, "name");
        if (name.empty()) fail(c, "expected a parameter name");
        std::string value = attr(c, "value");
        if (!params.count(name)) params[name] = value;
      } else if (tag == "include") {
        check_attrs(c, {"filename"});
        fs::path p = existing_file(c, attr(c, "filename"), "included file");
        std::string key = fs::absolute(p).lexically_normal().string();
        if (std::find(include_stack.begin(), include_stack.end(), key) != include_stack.end())
          fail(c, "'" + p.string() + "' includes itself (an include cycle)");
        XmlFile& f = open(p.string(), c);
        xml_node r = root_of(f);
        include_stack.push_back(key);
        scene_children(r, include_stack);
        include_stack.pop_back();
      } else if (tag == "path") {
        check_attrs(c, {"value"});
        search_dirs.push_back(resolve(c, attr(c, "value")));
      } else if (tag == "bsdf") {
        parse_bsdf(c);
        if (!has_attr(c, "id"))
          warn(c, "unreferenced-bsdf", "a top-level BSDF without an id cannot be used; ignored");
      } else if (tag == "texture") {
        if (!has_attr(c, "id")) fail(c, "a top-level texture needs an id");
        int t = parse_texture(c, true);
        (void)t;
      } else if (tag == "shape") {
        parse_shape(c);
      } else if (tag == "emitter") {
        parse_emitter(c);
      } else if (tag == "sensor") {
        parse_sensor(c);
      } else if (tag == "integrator") {
        parse_integrator(c);
      } else if (tag == "medium") {
        if (!has_attr(c, "id")) fail(c, "a top-level medium needs an id");
        parse_medium(c);
      } else if (is_property_tag(tag)) {
        fail(c, "unexpected property of the scene (caustica reads no scene-level properties)");
      } else {
        fail(c, "unexpected element in <scene> (expected default, include, path, bsdf, texture, medium, shape, "
                "emitter, sensor, integrator)");
      }
    }
  }

  void register_id(xml_node n, const std::string& kind, int index) {
    if (!has_attr(n, "id")) return;
    std::string id = attr(n, "id");
    if (ids.count(id)) fail(n, "id '" + id + "' is already used (at " + where(ids[id].node) + ")");
    ids[id] = {kind, index, n};
  }
  const Id& lookup(xml_node ref, const std::string& kind) {
    check_attrs(ref, {"id", "name"});
    std::string id = attr(ref, "id");
    auto it = ids.find(id);
    if (it == ids.end()) fail(ref, "no " + kind + " with id '" + id + "' is defined before this line");
    if (it->second.kind != kind)
      fail(ref, "id '" + id + "' is a " + it->second.kind + " (defined at " + where(it->second.node) + "), expected a " + kind);
    return it->second;
  }

  int default_bsdf() {
    if (default_material < 0) default_material = d.add_material("default", make_diffuse(RGB(0.5f)));
    return default_material;
  }
  // An emitter's shape without a BSDF reflects nothing: Mitsuba 3 gives it a black diffuse BSDF (where other
  // shapes get diffuse 0.5).
  int default_emitter_bsdf() {
    if (default_emitter_material < 0)
      default_emitter_material = d.add_material("default emitter", make_diffuse(RGB(0.f)));
    return default_emitter_material;
  }

  // ---- textures ----
  // A <texture type="bitmap">; colour textures are decoded from sRGB unless
  // raw="true" (Mitsuba linearises 8-bit images whatever the use).
  // A Mitsuba to_uv (translations, rotations and scales of the uv plane) as caustica's uv transform.
  void uv_transform(xml_node n, const M4& uv, Vec2f& scale, Vec2f& offset, float& rotation) {
    // uv' = R(rotation) S uv + offset: the 2-D linear part's columns must be orthogonal.
    double a = uv.a[0][0], b = uv.a[0][1], c = uv.a[1][0], e = uv.a[1][1];
    double sx = std::hypot(a, c), sy = std::hypot(b, e);
    if (sx == 0 || sy == 0 || std::fabs(a * b + c * e) > 1e-6 * sx * sy || a * e - b * c < 0)
      fail(n, "to_uv: only translations, rotations and scales of the uv plane are supported");
    // Mitsuba looks textures up with v down (row = v); caustica with v up (row =
    // 1 - v), and its meshes carry v_c = 1 - v_m. So the transform caustica
    // applies is F T F with F(u, v) = (u, 1 - v): rotation -r, the same scales,
    // offset (o_u - s_v sin r, 1 - o_v - s_v cos r).
    double r = std::atan2(c, a), ou = uv.a[0][3], ov = uv.a[1][3];
    rotation = float(-r);
    scale = Vec2f(float(sx), float(sy));
    offset = Vec2f(float(ou - sy * std::sin(r)), float(1.0 - ov - sy * std::cos(r)));
  }

  // <texture type="checkerboard">: Mitsuba's color0 where the fractional parts of u and v lie in the same half of
  // [0, 1), color1 elsewhere; exactly a 2 x 2 image looked up with nearest texels and repeat (its top-left and
  // bottom-right texels color0, as Mitsuba's v points down), which is how caustica renders it.
  int checkerboard_texture(xml_node n, bool top_level) {
    Props p(*this, n);
    p.declare({"color0", "color1", "to_uv"});
    RGB c0 = p.get_color("color0", RGB(0.4f)), c1 = p.get_color("color1", RGB(0.2f));
    bool has_uv = false;
    M4 uv = p.get_transform("to_uv", &has_uv);
    p.finish();
    TextureDesc t;
    t.name = "checkerboard@" + where(n);
    t.width = t.height = 2;
    for (RGB c : {c0, c1, c1, c0}) t.rgba.insert(t.rgba.end(), {c.x, c.y, c.z, 1.f});  // rows from the top
    t.nearest = true;
    t.wrap_u = t.wrap_v = TexWrap::kRepeat;
    if (has_uv) uv_transform(n, uv, t.uv_scale, t.uv_offset, t.uv_rotation);
    d.textures.push_back(std::move(t));
    int idx = int(d.textures.size()) - 1;
    if (top_level) register_id(n, "texture", idx);
    return idx;
  }

  // <texture type="mesh_attribute"> of "vertex_color" or "face_color": the shape's vertex colours, or a PLY
  // file's face colours (which the PLY loader turns into vertex colours constant over each face), times `scale`.
  // Held as a 1 x 1 texture of the scale in the colour slot plus the material flag kVertexColor
  // (resolve_vertex_colors), which multiplies by the interpolated vertex colour; only a BSDF's colour slot takes it.
  struct MeshAttribute {
    xml_node node;
    std::string name;  // vertex_color or face_color
  };
  std::map<int, MeshAttribute> vertex_color_textures_;
  int mesh_attribute_texture(xml_node n, bool top_level) {
    Props p(*this, n);
    p.declare({"name", "scale"});
    xml_node nn = p.get("name");
    if (!nn) fail(n, "missing <string name=\"name\"> (the mesh attribute: vertex_color or face_color)");
    std::string attribute = p.get_string("name", "");
    if (attribute != "vertex_color" && attribute != "face_color")
      fail(nn, "unsupported mesh attribute '" + attribute + "' (supported: vertex_color, face_color)");
    float scale = p.get_float("scale", 1.f);
    if (!(scale >= 0.f)) fail(p.get("scale"), "expected a scale >= 0");
    p.finish();
    TextureDesc t;
    t.name = "mesh_attribute@" + where(n);
    t.width = t.height = 1;
    t.rgba = {scale, scale, scale, 1.f};
    d.textures.push_back(std::move(t));
    int idx = int(d.textures.size()) - 1;
    vertex_color_textures_[idx] = MeshAttribute{n, attribute};
    if (top_level) register_id(n, "texture", idx);
    return idx;
  }
  // A BSDF's colour slot holding a mesh_attribute texture reads the vertex colours (kVertexColor); any other slot
  // holding one is an error.
  void resolve_vertex_colors(Material& m) {
    if (vertex_color_textures_.count(m.tex_color)) m.flags |= kVertexColor;
    const auto slots = material_textures(m);  // tex_color first
    for (size_t i = 1; i < slots.size(); ++i) {
      auto it = vertex_color_textures_.find(slots[i]);
      if (it != vertex_color_textures_.end())
        fail(it->second.node, "a mesh_attribute texture is supported as a BSDF's colour only (reflectance, "
                         "diffuse_reflectance, base_color, specular_reflectance, specular_transmittance)");
    }
  }

  // A float parameter's texture as Mitsuba reads it (a bitmap's eval_1 is its luminance): the texture itself
  // where every texel is grey, else a grey copy holding the luminance (caustica's slots read one channel).
  DerivedTextures derived_;
  std::map<int, int> float_textures_;  // texture -> what float_texture made of it
  int float_texture(int t) {
    if (t < 0) return t;
    auto [it, fresh] = float_textures_.try_emplace(t, t);
    if (!fresh) return it->second;
    const std::vector<float>& px = d.textures[size_t(t)].rgba;
    bool grey = true;
    for (size_t i = 0; grey && i + 3 < px.size(); i += 4) grey = px[i] == px[i + 1] && px[i] == px[i + 2];
    if (!grey)
      it->second = derived_.get(d, t, "#luminance", [](float* c) {
        c[0] = c[1] = c[2] = luminance(RGB(c[0], c[1], c[2]));
      });
    return it->second;
  }

  int parse_texture(xml_node n, bool top_level) {
    check_attrs(n, {"type", "id", "name"});
    std::string type = attr(n, "type");
    if (type == "checkerboard") return checkerboard_texture(n, top_level);
    if (type == "mesh_attribute") return mesh_attribute_texture(n, top_level);
    if (type != "bitmap") fail(n, "unsupported texture type (supported: bitmap, checkerboard, mesh_attribute)");
    Props p(*this, n);
    p.declare({"filename", "raw", "filter_type", "wrap_mode", "to_uv"});
    xml_node fnode = p.get("filename");
    if (!fnode) fail(n, "missing <string name=\"filename\">");
    std::string fname = p.get_string("filename", "");
    bool raw = p.get_bool("raw", false);
    std::string filter = p.get_string("filter_type", "bilinear");
    std::string wrap = p.get_string("wrap_mode", "repeat");
    bool has_uv = false;
    M4 uv = p.get_transform("to_uv", &has_uv);
    p.finish({"format"});
    fs::path path = existing_file(fnode, fname, "texture file");
    int t = load_texture(d, path.string(), !raw, where(fnode));
    TexWrap w;
    if (wrap == "repeat") w = TexWrap::kRepeat;
    else if (wrap == "mirror") w = TexWrap::kMirror;
    else if (wrap == "clamp") w = TexWrap::kClamp;
    else fail(n, "unknown wrap_mode '" + wrap + "' (allowed: repeat, mirror, clamp)");
    bool nearest;
    if (filter == "bilinear") nearest = false;
    else if (filter == "nearest") nearest = true;
    else fail(n, "unknown filter_type '" + filter + "' (allowed: bilinear, nearest)");
    Vec2f scale(1.f, 1.f), offset(0.f, 0.f);
    float rotation = 0.f;
    if (has_uv) uv_transform(n, uv, scale, offset, rotation);
    TextureDesc& td = d.textures[t];
    bool same = td.wrap_u == w && td.wrap_v == w && td.nearest == nearest && td.uv_scale.x == scale.x && td.uv_scale.y == scale.y &&
                td.uv_offset.x == offset.x && td.uv_offset.y == offset.y && td.uv_rotation == rotation;
    if (!same) {
      bool fresh = td.wrap_u == TexWrap::kRepeat && td.wrap_v == TexWrap::kRepeat && !td.nearest && td.uv_scale.x == 1.f && td.uv_scale.y == 1.f &&
                   td.uv_offset.x == 0.f && td.uv_offset.y == 0.f && td.uv_rotation == 0.f;
      bool shared = false;
      for (const Material& m : d.materials)
        for (int u : material_textures(m)) shared |= u == t;
      for (const ShapeDesc& s : d.shapes) shared |= s.emission_texture == t;
      for (const Light& l : d.lights) shared |= l.texture == t;
      for (const auto& kv : ids) shared |= kv.second.kind == "texture" && kv.second.index == t;
      if (!fresh || shared) {
        TextureDesc copy = td;
        copy.name += "#" + std::to_string(d.textures.size());
        d.textures.push_back(copy);
        t = int(d.textures.size()) - 1;
      }
      TextureDesc& out = d.textures[t];
      out.wrap_u = out.wrap_v = w;
      out.nearest = nearest;
      out.uv_scale = scale;
      out.uv_offset = offset;
      out.uv_rotation = rotation;
    }
    if (top_level) register_id(n, "texture", t);
    return t;
  }

  // ---- BSDFs ----
  int parse_bsdf(xml_node n) {
    if (std::string(n.name()) == "ref") return lookup(n, "BSDF").index;
    check_attrs(n, {"type", "id", "name"});
    std::string type = attr(n, "type");
    std::string name = has_attr(n, "id") ? attr(n, "id") : type + "@" + where(n);
    Material m = bsdf_material(n, type);
    resolve_vertex_colors(m);
    int idx = d.add_material(name, m);
    register_id(n, "BSDF", idx);
    return idx;
  }

  // distribution "beckmann" (Mitsuba's default) sets kBeckmann (material/microfacet.h).
  void microfacet(Props& p, xml_node n, Material& m, bool allow_texture, bool allow_anisotropy = true) {
    std::string dist = p.get_string("distribution", "beckmann");
    if (dist == "beckmann")
      m.flags |= kBeckmann;
    else if (dist != "ggx")
      fail(p.get("distribution"), "unknown distribution '" + dist + "' (allowed: beckmann, ggx)");
    float alpha = 0.1f, alpha_v = -1.f;  // alpha_v >= 0: anisotropic (alpha along dp/du, alpha_v across)
    int tex = -1;
    if (p.has("alpha_u") || p.has("alpha_v")) {
      // Mitsuba 3's anisotropic roughness: alpha_u along the surface's dp/du (scene/shading.h,
      // shading_tangent), alpha_v along dp/dv. Roughplastic is isotropic in Mitsuba too.
      if (p.has("alpha")) fail(n, "give either alpha or alpha_u/alpha_v, not both");
      if (!allow_anisotropy) fail(p.has("alpha_u") ? p.get("alpha_u") : p.get("alpha_v"),
                                  "this BSDF's roughness is isotropic (expected alpha)");
      alpha = p.get_float("alpha_u", 0.1f);
      alpha_v = p.get_float("alpha_v", 0.1f);
      if (!(alpha >= 0.f)) fail(p.get("alpha_u"), "expected alpha_u >= 0");
      if (!(alpha_v >= 0.f)) fail(p.get("alpha_v"), "expected alpha_v >= 0");
    } else {
      xml_node an = p.get("alpha");
      if (an && (std::string(an.name()) == "texture" || std::string(an.name()) == "ref")) {
        if (!allow_texture) fail(an, "a roughness texture is not supported for this BSDF");
        tex = float_texture(p.get_color_tex("alpha", RGB(0.1f)).texture);
        alpha = 1.f;
      } else {
        alpha = p.get_float("alpha", 0.1f);
      }
    }
    if (!(alpha >= 0.f)) fail(p.get("alpha"), "expected alpha >= 0");
    p.get("sample_visible");  // sampling only
    set_alpha(m, alpha, alpha_v >= 0.f ? alpha_v : alpha);
    m.tex_roughness = tex;
  }

  Material bsdf_material(xml_node n, const std::string& type) {
    Props p(*this, n);
    if (type == "diffuse") p.declare({"reflectance"});
    if (type == "conductor" || type == "roughconductor") p.declare({"material", "eta", "k", "specular_reflectance"});
    if (type == "dielectric" || type == "roughdielectric" || type == "thindielectric")
      p.declare({"int_ior", "ext_ior", "specular_reflectance", "specular_transmittance"});
    if (type == "plastic" || type == "roughplastic")
      p.declare({"diffuse_reflectance", "specular_reflectance", "int_ior", "ext_ior", "nonlinear"});
    if (type.rfind("rough", 0) == 0) p.declare({"distribution", "alpha", "alpha_u", "alpha_v", "sample_visible"});
    if (type == "principled")
      p.declare({"base_color", "roughness", "metallic", "specular", "eta", "spec_trans", "anisotropic", "spec_tint",
                 "sheen", "sheen_tint", "clearcoat", "clearcoat_gloss", "flatness", "main_specular_sampling_rate",
                 "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate"});
    Material m;
    if (type == "diffuse") {
      ColorOrTexture r = p.get_color_tex("reflectance", RGB(0.5f));
      m = make_diffuse(r.value);
      m.tex_color = r.texture;
    } else if (type == "conductor" || type == "roughconductor") {
      std::string material = p.get_string("material", "");
      bool has_ek = p.has("eta") || p.has("k");
      RGB eta(0.f), k(1.f);
      if (has_ek) {
        if (!material.empty()) fail(n, "give either 'material' or eta/k, not both");
        eta = p.get_color("eta", RGB(0.f), SpectrumUse::kUnbounded);
        k = p.get_color("k", RGB(1.f), SpectrumUse::kUnbounded);
      } else {
        p.get("eta");
        p.get("k");
        if (material.empty()) material = "none";
      }
      ColorOrTexture spec = p.get_color_tex("specular_reflectance", RGB(1.f));
      bool mirror = !has_ek && material == "none";
      if (!has_ek && !mirror) {
        const NamedConductor* found = nullptr;
        for (const NamedConductor& c : kConductors)
          if (material == c.name) found = &c;
        if (!found) {
          std::vector<std::string> v{"none"};
          for (const NamedConductor& c : kConductors) v.push_back(c.name);
          fail(p.get("material"), "unknown conductor material '" + material + "' (known: " + join(v) + ")");
        }
        eta = found->eta;
        k = found->k;
      }
      if (mirror) m = make_mirror(spec.value);
      else m = make_conductor(eta, k, spec.value, 0.f);
      m.tex_color = spec.texture;
      if (type == "roughconductor") {
        microfacet(p, n, m, true);
        if (m.alpha_x > 0.f || m.alpha_y > 0.f || m.tex_roughness >= 0) m.type = MaterialType::kRoughConductor;
        else m.type = MaterialType::kConductor;
      }
    } else if (type == "dielectric" || type == "roughdielectric" || type == "thindielectric") {
      float int_ior = p.get_ior("int_ior", 1.5046f), ext_ior = p.get_ior("ext_ior", 1.000277f);
      float eta = int_ior / ext_ior;
      m = type == "thindielectric" ? make_thin_dielectric(eta) : make_dielectric(eta, 0.f);
      m.specular = p.get_color("specular_reflectance", RGB(1.f));
      ColorOrTexture t = p.get_color_tex("specular_transmittance", RGB(1.f));
      m.transmission = t.value;
      m.tex_color = t.texture;
      if (type == "roughdielectric") {
        microfacet(p, n, m, true);
        m.type = m.alpha_x > 0.f || m.alpha_y > 0.f || m.tex_roughness >= 0 ? MaterialType::kRoughDielectric : MaterialType::kDielectric;
      }
    } else if (type == "plastic" || type == "roughplastic") {
      ColorOrTexture kd = p.get_color_tex("diffuse_reflectance", RGB(0.5f));
      RGB ks = p.get_color("specular_reflectance", RGB(1.f));
      float eta = p.get_ior("int_ior", 1.49f) / p.get_ior("ext_ior", 1.000277f);
      bool nonlinear = p.get_bool("nonlinear", false);
      // The coat: smooth, or rough (material/rough_plastic.h, with the coat's own internal reflectance).
      if (type == "roughplastic") microfacet(p, n, m, false, false);
      if (type == "plastic" || m.alpha_x == 0.f)  // a roughplastic of alpha 0 is the smooth one
        m = make_plastic(kd.value, eta, ks);
      else
        m = make_rough_plastic(kd.value, eta, m.alpha_x, (m.flags & kBeckmann) != 0u, ks);
      if (!nonlinear) {
        // Mitsuba's default (linear) model scales the base by 1/(1 - Fdr); caustica's
        // base term is Kd/(1 - Kd Fdr) (Mitsuba's nonlinear model). Choose Kd' so
        // that Kd'/(1 - Kd' Fdr) = Kd/(1 - Fdr): then both agree exactly.
        const float fdr = m.fdr_int;
        for (int c = 0; c < 3; ++c) {
          float a = m.diffuse[c] / (1.f - fdr);
          m.diffuse[c] = a / (1.f + a * fdr);
        }
        if (kd.texture >= 0)
          warn(n, "plastic-linear-texture",
               "a textured diffuse_reflectance with nonlinear=false is approximated (caustica's plastic is Mitsuba's "
               "nonlinear model)");
      }
      m.tex_color = kd.texture;
    } else if (type == "normalmap" || type == "bumpmap") {
      // Mitsuba 3's wrappers: the nested BSDF shaded about a normal from a tangent-space normal map (n = 2 rgb
      // - 1 in the frame of dp/du and the normal) or from a height map's gradient (its value times `scale`
      // as height): Material::tex_normal / tex_bump (scene/shading.h). The texture is read as Mitsuba reads
      // it: linear with raw="true", else decoded from sRGB.
      if (type == "bumpmap") p.declare({"scale"});
      float scale = type == "bumpmap" ? p.get_float("scale", 1.f) : 1.f;
      // Since Mitsuba 3.7.1 both wrappers flip a perturbed normal that faces away from the viewer and
      // multiply by Conty Estevez et al.'s (2019) terminator shadowing term, unless told not to; caustica
      // does neither (the shading normal is used as it is: docs/formats-mitsuba.md).
      bool flip = p.get_bool("flip_invalid_normals", true), shadowing = p.get_bool("use_shadowing_function", true);
      if (flip || shadowing)
        warn(n, "wrapper-terminator",
             type + ": Mitsuba's flip_invalid_normals and use_shadowing_function (on unless set to false) are not "
             "applied; images differ near the shading terminator (set both to false for the same model)");
      xml_node tn = p.take_texture();
      if (!tn) fail(n, "expected a nested <texture> (the " + std::string(type == "normalmap" ? "normal" : "height") + " map)");
      int tex = std::string(tn.name()) == "ref" ? lookup(tn, "texture").index : parse_texture(tn, false);
      std::vector<xml_node> inner = p.take_bsdfs();
      if (inner.empty()) fail(n, "expected a nested <bsdf> or <ref>");
      if (inner.size() > 1) fail(inner[1], "a " + type + " wraps one BSDF");
      m = d.materials[parse_bsdf(inner[0])];
      if (m.tex_normal >= 0 || m.tex_bump >= 0)
        fail(inner[0], "a normalmap or bumpmap inside another is not supported");
      if (m.mix_b >= 0) fail(inner[0], "a " + type + " around a blendbsdf is not supported (put it inside, around each BSDF)");
      if (type == "normalmap") {
        m.tex_normal = tex;
        m.normal_scale = 1.f;
        m.flags |= kNormalMapCross;  // Mitsuba's y axis is n x dp/du
      } else {
        m.tex_bump = tex;
        m.bump_scale = scale;
      }
    } else if (type == "principled") {
      // Mitsuba 3's principled (Burley's Disney BSDF) as caustica's principled material, the same model
      // (material/principled.h): base colour, roughness, metallic, spec_trans, spec_tint, sheen, sheen_tint,
      // flatness, clearcoat, clearcoat_gloss (numbers in [0, 1] or textures, read as their luminance like
      // Mitsuba's eval_1), anisotropic (a number), eta or specular (eta = 2 / (1 - sqrt(0.08 specular)) - 1).
      ColorOrTexture base = p.get_color_tex("base_color", RGB(0.5f));
      auto is_texture = [](xml_node e) {
        return e && (std::string(e.name()) == "texture" || std::string(e.name()) == "ref");
      };
      auto scalar = [&](const char* k, float def, float hi) {
        xml_node e = p.get(k);
        if (is_texture(e))
          fail(e, std::string(k) + " takes a number, not a texture");
        float v = p.get_float(k, def);
        if (!(v >= 0.f && v <= hi)) fail(e, std::string("expected ") + k + " in [0, " + (hi == 1.f ? "1" : "2") + "]");
        return v;
      };
      // A weight: a number, or a texture (its luminance; the weight 1 that the texture multiplies).
      auto weight = [&](const char* k, float def, int32_t& tex) {
        if (!is_texture(p.get(k))) return scalar(k, def, 1.f);
        tex = float_texture(p.get_color_tex(k, RGB(1.f)).texture);
        return 1.f;
      };
      int32_t tex_rough = -1;
      const float roughness = weight("roughness", 0.5f, tex_rough);  // a grey texture: its G is the luminance
      Material weights;  // the weights (0 if absent) and their textures
      for (const PrincipledWeight& w : kPrincipledWeights) weights.*w.value = weight(w.name, 0.f, weights.*w.texture);
      const float trans = weights.transmission_weight;
      float eta;
      if (p.has("eta")) {
        eta = p.get_float("eta", 1.5f);
        if (!(eta > 0.f)) fail(p.get("eta"), "expected eta > 0");
        if (trans > 0.f && eta == 1.f) eta = 1.001f;  // as Mitsuba: no transmission through eta 1
        p.get("specular");
      } else {
        float specular = scalar("specular", 0.5f, 2.f);
        if (trans > 0.f && specular == 0.f) specular = 1e-3f;  // as Mitsuba
        eta = 2.f / (1.f - std::sqrt(std::min(0.08f * specular, 0.99f))) - 1.f;
      }
      m = make_principled(base.value, 0.f, roughness, scalar("anisotropic", 0.f, 1.f), trans, eta);
      m.tex_color = base.texture;
      m.tex_roughness = tex_rough;
      for (const PrincipledWeight& w : kPrincipledWeights) {
        m.*w.value = weights.*w.value;
        m.*w.texture = weights.*w.texture;
      }
      for (const char* k : {"main_specular_sampling_rate", "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate"})
        p.get(k);  // sampling only
    } else if (type == "blendbsdf") {
      // Mitsuba 3's blendbsdf: the second nested BSDF at a share `weight` (0.5; a number or a texture, read by
      // its luminance) of the surface, the first elsewhere: caustica's blend (Material::mix_a/mix_b; scene/
      // shading.h), which picks one per point where Mitsuba evaluates both: the same expected value.
      p.declare({"weight"});
      ColorOrTexture w = p.get_color_tex("weight", RGB(0.5f));
      std::vector<xml_node> inner = p.take_bsdfs();
      if (inner.size() != 2) fail(n, "expected two nested <bsdf> or <ref> elements (got " + std::to_string(inner.size()) + ")");
      float v = 0.2126f * w.value.x + 0.7152f * w.value.y + 0.0722f * w.value.z;
      if (!(v >= 0.f && v <= 1.f)) fail(p.get("weight"), "expected a weight in [0, 1]");
      m = Material();
      m.mix_a = parse_bsdf(inner[0]);
      m.mix_b = parse_bsdf(inner[1]);
      m.mix_weight = v;
      m.tex_mix = w.texture;
    } else if (type == "mask") {
      // Mitsuba 3's mask: the nested BSDF where a ray stops with probability `opacity` (0.5; a number or a
      // texture, read as its luminance, which is what Mitsuba's eval_1 of a bitmap gives), and a null
      // interaction (the ray goes on) elsewhere: caustica's stochastic opacity (Material::opacity).
      p.declare({"opacity"});
      ColorOrTexture o = p.get_color_tex("opacity", RGB(0.5f));
      std::vector<xml_node> inner = p.take_bsdfs();
      if (inner.empty()) fail(n, "expected a nested <bsdf> or <ref>");
      if (inner.size() > 1) fail(inner[1], "a mask wraps one BSDF");
      m = d.materials[parse_bsdf(inner[0])];
      if (m.opacity < 1.f || m.tex_opacity >= 0) fail(inner[0], "a mask inside another is not supported");
      float v = 0.2126f * o.value.x + 0.7152f * o.value.y + 0.0722f * o.value.z;
      if (!(v >= 0.f && v <= 1.f)) fail(p.get("opacity"), "expected an opacity in [0, 1]");
      m.opacity = v;
      m.tex_opacity = o.texture;
      if (o.texture >= 0) m.flags |= kOpacityLuminance;
      m.opacity_cutoff = -1.f;
    } else if (type == "twosided") {
      std::vector<xml_node> inner = p.take_bsdfs();
      if (inner.empty()) fail(n, "expected a nested <bsdf> or <ref>");
      if (inner.size() > 2) fail(inner[2], "a twosided takes one BSDF, or two (front, back)");
      // Around a blendbsdf: the blend of two-sided copies of its BSDFs (each checked as below).
      xml_node where = inner[0];
      std::function<Material(int)> two_sided = [&](int i) {
        Material x = d.materials[size_t(i)];
        if (x.mix_b >= 0) {
          x.mix_a = d.add_material(d.material_names[size_t(x.mix_a)] + "/twosided", two_sided(x.mix_a));
          x.mix_b = d.add_material(d.material_names[size_t(x.mix_b)] + "/twosided", two_sided(x.mix_b));
          return x;
        }
        switch (x.type) {
          case MaterialType::kDiffuse:
          case MaterialType::kConductor:
          case MaterialType::kRoughConductor:
          case MaterialType::kPlastic:
          case MaterialType::kRoughPlastic:
          case MaterialType::kMetallicRoughness: break;
          case MaterialType::kPrincipled:
            if (!material_is_transmissive(x)) break;
            [[fallthrough]];
          default: fail(where, "twosided applies to reflecting BSDFs only (diffuse, conductor, roughconductor, plastic, roughplastic, principled without spec_trans)");
        }
        x.flags |= kTwoSided;
        return x;
      };
      if (inner.size() == 1) {
        m = two_sided(parse_bsdf(inner[0]));
      } else {
        // Two BSDFs: the first seen from the front, the second from behind (as if from its own front):
        // caustica's pair of sides (Material kSides, resolved per hit in scene/interaction.h).
        const int front = parse_bsdf(inner[0]), back = parse_bsdf(inner[1]);
        m = Material();
        m.flags = kSides;
        m.mix_a = d.add_material(d.material_names[size_t(front)] + "/front", two_sided(front));
        where = inner[1];
        m.mix_b = d.add_material(d.material_names[size_t(back)] + "/back", two_sided(back));
      }
    } else if (type == "null") {
      m.type = MaterialType::kNull;  // a boundary of media that rays cross unchanged
    } else {
      fail(n, "unsupported BSDF type (supported: diffuse, conductor, roughconductor, dielectric, roughdielectric, "
              "thindielectric, plastic, roughplastic, principled, twosided, normalmap, bumpmap, mask, blendbsdf, null)");
    }
    p.finish();
    return m;
  }

  // ---- media ----
  // A medium's <volume name="sigma_t|albedo">: constvolume (its colour `value`, to *constant) or, with
  // `grid_ok`, gridvolume (a .vol file of one or three channels placed by to_world, docs/formats-mitsuba.md;
  // to *grid).
  void parse_medium_volume(xml_node v, bool grid_ok, RGB* constant, MediumGridDesc* grid) {
    check_attrs(v, {"type", "id", "name"});
    const std::string vt = attr(v, "type");
    Props vp(*this, v);
    if (vt == "constvolume") {
      vp.declare({"value", "to_world"});
      *constant = vp.get_color("value", RGB(1.f), SpectrumUse::kUnbounded);
      vp.get_transform("to_world");
      vp.finish();
      return;
    }
    if (vt != "gridvolume" || !grid_ok)
      fail(v, grid_ok ? "unsupported volume type (supported: gridvolume, constvolume)"
                      : "unsupported volume here (supported: constvolume; a gridvolume only as a heterogeneous "
                        "medium's sigma_t or a medium's albedo)");
    vp.declare({"filename", "to_world", "filter_type", "wrap_mode", "use_grid_bbox", "raw", "accel"});
    const std::string fname = vp.get_string("filename", "");
    if (fname.empty()) fail(v, "a gridvolume needs a filename (a .vol file)");
    const fs::path file = existing_file(vp.get("filename"), fname, "volume file");
    Vec3f lo, hi;
    *grid = read_vol_grid(file.string(), where(vp.get("filename")), &lo, &hi);
    M4 tw = vp.get_transform("to_world");
    if (vp.get_bool("use_grid_bbox", false)) {
      M4 box;
      for (int i = 0; i < 3; ++i) {
        box.a[i][i] = double(hi[i]) - double(lo[i]);
        box.a[i][3] = lo[i];
      }
      tw = mul(tw, box);
    }
    grid->to_world = to_affine(tw);
    const std::string filter = vp.get_string("filter_type", "trilinear");
    if (filter == "nearest") grid->nearest = true;
    else if (filter != "trilinear") fail(vp.get("filter_type"), "unsupported filter_type (supported: trilinear, nearest)");
    const std::string wrap = vp.get_string("wrap_mode", "clamp");
    if (wrap != "clamp") fail(vp.get("wrap_mode"), "unsupported wrap_mode (supported: clamp)");
    grid->clamp = true;  // Mitsuba 3 clamps at the border, inside and outside the unit cube
    vp.get_bool("raw", false);  // an RGB renderer: colour samples are used as they are
    vp.get_bool("accel", true);
    vp.finish();
  }

  // <medium type="homogeneous|heterogeneous">: sigma_t and albedo (Mitsuba's defaults 1 and 0.75) times
  // scale, and a <phase> (isotropic or hg); heterogeneous with sigma_t a gridvolume of one or three channels
  // (the grid times scale is the extinction, medium/medium_grid.h) or a constant; either with the albedo a
  // gridvolume (Medium::albedo_grid; with a constant sigma_t the density grid is a clamped 1 x 1 x 1 grid of
  // 1s). Registered under its id. Returns its index in d.media.
  int parse_medium(xml_node n) {
    if (std::string(n.name()) == "ref") return lookup(n, "medium").index;
    check_attrs(n, {"type", "id", "name"});
    std::string type = attr(n, "type");
    if (type != "homogeneous" && type != "heterogeneous")
      fail(n, "unsupported medium type (supported: homogeneous, heterogeneous)");
    const bool hetero = type == "heterogeneous";
    Props p(*this, n);
    p.declare({"sigma_t", "albedo", "scale", "sample_emitters"});
    if (hetero) p.declare({"has_spectral_extinction"});
    RGB sigma_t(1.f), albedo(0.75f);
    bool vol_sigma_t = false, vol_albedo = false;
    MediumGridDesc grid, albedo_grid;
    bool has_grid = false;
    for (xml_node v : p.take_objects("volume")) {
      if (!has_attr(v, "name")) fail(v, "a medium's <volume> needs name=\"sigma_t\" or name=\"albedo\"");
      const std::string vn = attr(v, "name");
      if (vn == "sigma_t") {
        if (vol_sigma_t || p.has("sigma_t")) fail(v, "sigma_t is given twice");
        vol_sigma_t = true;
        parse_medium_volume(v, hetero, &sigma_t, &grid);
        if (!grid.values.empty()) {
          has_grid = true;
          sigma_t = RGB(1.f);
        }
      } else if (vn == "albedo") {
        if (vol_albedo || p.has("albedo")) fail(v, "albedo is given twice");
        vol_albedo = true;
        parse_medium_volume(v, true, &albedo, &albedo_grid);
        for (size_t i = 0; i < albedo_grid.values.size(); ++i)
          if (!(albedo_grid.values[i] <= 1.f))
            fail(v, "albedo grid '" + albedo_grid.name + "': sample " + std::to_string(i) + " is " +
                        std::to_string(albedo_grid.values[i]) + " (expected an albedo in [0, 1])");
      } else {
        fail(v, "unknown volume '" + vn + "' (a medium takes sigma_t and albedo)");
      }
    }
    // (A heterogeneous medium with constant sigma_t and albedo is a homogeneous one.)
    if (!vol_sigma_t) sigma_t = p.get_color("sigma_t", RGB(1.f));
    if (!vol_albedo) albedo = p.get_color("albedo", RGB(0.75f));
    float scale = p.get_float("scale", 1.f);
    auto where_of = [&](const char* k) { xml_node x = p.get(k); return x ? x : n; };
    if (!(sigma_t.x >= 0.f && sigma_t.y >= 0.f && sigma_t.z >= 0.f)) fail(where_of("sigma_t"), "expected sigma_t >= 0");
    if (!(albedo.x >= 0.f && albedo.y >= 0.f && albedo.z >= 0.f && albedo.x <= 1.f && albedo.y <= 1.f &&
          albedo.z <= 1.f))
      fail(where_of("albedo"), "expected an albedo in [0, 1]");
    if (!(scale >= 0.f)) fail(p.get("scale"), "expected a scale >= 0");
    if (!p.get_bool("sample_emitters", true))
      warn(p.get("sample_emitters"), "sample_emitters", "sample_emitters=false ignored (caustica always samples emitters in media)");
    // A colour sigma_t grid's channels are used as they are (Mitsuba 3's default, true).
    if (hetero) p.get_bool("has_spectral_extinction", true);
    const bool has_albedo_grid = !albedo_grid.values.empty();
    if (has_albedo_grid) albedo = RGB(1.f);  // sigma_s(x) = albedo(x) sigma_t(x): the constants carry sigma_t
    Medium m;
    m.sigma_s = sigma_t * albedo * scale;
    m.sigma_a = sigma_t * scale - m.sigma_s;
    m.sigma_a = max0(m.sigma_a);
    std::vector<xml_node> phases = p.take_objects("phase");
    if (phases.size() > 1) fail(phases[1], "a medium takes one phase function");
    if (!phases.empty()) {
      xml_node ph = phases[0];
      check_attrs(ph, {"type", "id", "name"});
      std::string pt = attr(ph, "type");
      Props pp(*this, ph);
      if (pt == "hg") {
        pp.declare({"g"});
        m.g = pp.get_float("g", 0.8f);
        if (!(m.g > -1.f && m.g < 1.f)) fail(pp.get("g"), "expected g in (-1, 1)");
      } else if (pt != "isotropic") {
        fail(ph, "unsupported phase function (supported: isotropic, hg)");
      }
      pp.finish();
    }
    p.finish();
    std::string name = has_attr(n, "id") ? attr(n, "id") : "medium@" + where(n);
    if (has_albedo_grid && !has_grid) {  // a constant sigma_t: a clamped grid of one sample, 1
      grid = MediumGridDesc();
      grid.name = "constant density@" + where(n);
      grid.nx = grid.ny = grid.nz = 1;
      grid.values = {1.f};
      grid.clamp = true;
      has_grid = true;
    }
    if (has_grid) {
      d.grids.push_back(std::move(grid));
      m.grid = int(d.grids.size()) - 1;
    }
    if (has_albedo_grid) {
      d.grids.push_back(std::move(albedo_grid));
      m.albedo_grid = int(d.grids.size()) - 1;
    }
    d.medium_names.push_back(name);
    d.media.push_back(m);
    int idx = int(d.media.size()) - 1;
    register_id(n, "medium", idx);
    return idx;
  }

  // ---- shapes ----
  static bool zero_scale(const M4& m) {
    return len3(column(m, 0)) == 0 && len3(column(m, 1)) == 0 && len3(column(m, 2)) == 0;
  }
  static bool uniform_scale(const M4& m) {
    double l0 = len3(column(m, 0)), l1 = len3(column(m, 1)), l2 = len3(column(m, 2));
    return l0 > 0 && std::fabs(l0 - l1) <= 1e-4 * l0 && std::fabs(l0 - l2) <= 1e-4 * l0;
  }

  // Mitsuba's cylinder in its own space: the unit tube x^2 + y^2 = 1, 0 <= z <= 1, normals out, as a mesh of
  // kCylinderSegments quads around with smooth (radial) normals; uv = (phi / 2 pi, z) in Mitsuba's terms, so
  // caustica's v = 1 - z. The seam at phi = 0 has two columns of vertices (u = 0 and u = 1).
  static constexpr int kCylinderSegments = 256;  // the chords stay within r (1 - cos(pi / 256)) = 7.5e-5 r
  static MeshDesc unit_cylinder_mesh(const std::string& name) {
    MeshDesc m;
    m.name = name;
    const int n = kCylinderSegments;
    for (int i = 0; i <= n; ++i) {
      double phi = 2.0 * kPi * double(i) / n;
      float c = float(std::cos(phi)), sn = float(std::sin(phi));
      if (i == n) c = 1.f, sn = 0.f;
      for (int z = 0; z <= 1; ++z) {
        m.positions.push_back(Vec3f(c, sn, float(z)));
        m.normals.push_back(Vec3f(c, sn, 0.f));
        m.uvs.push_back(Vec2f(float(i) / n, 1.f - float(z)));
      }
    }
    for (uint32_t i = 0; i < uint32_t(n); ++i) {
      uint32_t a = 2 * i, b = 2 * i + 1, c = 2 * i + 2, e = 2 * i + 3;  // (phi_i, 0), (phi_i, 1), (phi_i+1, 0), ...
      m.indices.insert(m.indices.end(), {a, c, e, a, e, b});                // counter-clockwise seen from outside
    }
    return m;
  }

  // <shape type="shapegroup" id="...">: shapes kept aside for <shape type="instance">, not rendered themselves.
  void parse_shapegroup(xml_node n) {
    if (in_shapegroup_) fail(n, "a shapegroup inside a shapegroup is not supported (nested instancing, as in Mitsuba)");
    if (!has_attr(n, "id")) fail(n, "a shapegroup needs an id (instances refer to it)");
    Props p(*this, n);
    ShapeGroup group;
    in_shapegroup_ = true;
    for (xml_node c : p.take_objects("shape")) {
      std::string t = attr(c, "type");
      if (t == "instance") fail(c, "an instance inside a shapegroup is not supported (nested instancing, as in Mitsuba)");
      size_t before = d.shapes.size();
      parse_shape(c);
      for (size_t i = before; i < d.shapes.size(); ++i) group.push_back({d.shapes[i], shape_to_world_});
      d.shapes.resize(before);
    }
    in_shapegroup_ = false;
    p.finish();
    if (group.empty()) warn(n, "empty-shapegroup", "an empty shapegroup: its instances add nothing");
    groups_.push_back(std::move(group));
    register_id(n, "shapegroup", int(groups_.size()) - 1);
  }

  // <shape type="instance">: a <ref> to a shapegroup and a to_world, which is applied after each shape's own.
  // Meshes are shared between instances (ShapeDesc::mesh), not copied.
  void parse_instance(xml_node n) {
    if (in_shapegroup_) fail(n, "an instance inside a shapegroup is not supported (nested instancing, as in Mitsuba)");
    Props p(*this, n);
    p.declare({"to_world"});
    M4 to_world = p.get_transform("to_world");
    std::vector<xml_node> refs = p.take_objects("ref");
    if (refs.size() != 1) fail(n, "an instance takes one <ref id=\"...\"/> to a shapegroup");
    const ShapeGroup& group = groups_[size_t(lookup(refs[0], "shapegroup").index)];
    p.finish();
    std::string name = has_attr(n, "id") ? attr(n, "id") : "instance@" + where(n);
    for (const auto& [shape, local] : group) {
      ShapeDesc s = shape;
      M4 m = mul(to_world, local);
      if (s.type == ShapeType::kSphere) {
        if (zero_scale(m)) continue;
        if (!uniform_scale(m))
          fail(n, "the instance's to_world scales the sphere '" + s.name + "' unevenly (caustica's spheres are exact spheres)");
      }
      s.to_world = to_affine(m);
      s.name = name + "/" + s.name;
      d.shapes.push_back(std::move(s));
    }
  }

  void parse_shape(xml_node n) {
    check_attrs(n, {"type", "id", "name"});
    std::string type = attr(n, "type");
    static const char* kShapes =
        "supported: obj, ply, serialized, rectangle, cube, disk, sphere, cylinder, shapegroup, instance";
    const bool file_mesh = type == "obj" || type == "ply" || type == "serialized";
    if (type == "shapegroup") return parse_shapegroup(n);
    if (type == "instance") return parse_instance(n);
    if (!file_mesh && type != "rectangle" && type != "cube" && type != "sphere" && type != "disk" && type != "cylinder")
      fail(n, std::string("unsupported shape type (") + kShapes + ")");
    Props p(*this, n);
    p.declare({"to_world", "flip_normals"});
    if (type == "sphere") p.declare({"center", "radius"});
    if (type == "cylinder") p.declare({"p0", "p1", "radius"});
    if (file_mesh) p.declare({"filename", "face_normals"});
    if (type == "serialized") p.declare({"shape_index"});
    M4 to_world = p.get_transform("to_world");
    shape_to_world_ = to_world;
    Affine tw = to_affine(to_world);
    bool flip = p.get_bool("flip_normals", false);
    // Material.
    std::vector<xml_node> bsdfs = p.take_objects("bsdf");
    for (xml_node r : p.take_objects("ref")) {
      std::string id = attr(r, "id");
      auto it = ids.find(id);
      if (it != ids.end() && it->second.kind != "BSDF") fail(r, "a shape can only reference a BSDF here");
      bsdfs.push_back(r);
    }
    if (bsdfs.size() > 1) fail(bsdfs[1], "a shape takes one BSDF");
    int material = bsdfs.empty() ? -1 : parse_bsdf(bsdfs[0]);
    // Area emitter.
    RGB emission(0.f);
    int emission_tex = -1;
    std::vector<xml_node> emitters = p.take_objects("emitter");
    if (emitters.size() > 1) fail(emitters[1], "a shape takes one emitter");
    if (!emitters.empty()) {
      xml_node e = emitters[0];
      check_attrs(e, {"type", "id", "name"});
      std::string et = attr(e, "type");
      if (et != "area") fail(e, "only an area emitter can be attached to a shape");
      if (in_shapegroup_) fail(e, "an emitter inside a shapegroup is not supported (Mitsuba does not instance emitters)");
      Props ep(*this, e);
      ep.declare({"radiance"});
      ColorOrTexture r = ep.get_color_tex("radiance", RGB(1.f), SpectrumUse::kEmission);
      if (vertex_color_textures_.count(r.texture))
        fail(ep.get("radiance"), "a mesh_attribute texture is supported as a BSDF's colour only, not as radiance");
      ep.finish({"sampling_weight"});
      emission = r.value;
      emission_tex = r.texture;
    }
    if (material < 0) material = emitters.empty() ? default_bsdf() : default_emitter_bsdf();
    // Media: <ref name="interior|exterior" id="..."/> or a nested <medium name="interior|exterior">. One
    // given makes the other side vacuum, as in Mitsuba.
    int interior = -1, exterior = -1;
    bool interface = false;
    for (const char* side : {"interior", "exterior"}) {
      xml_node r = p.get(side);
      if (!r) continue;
      if (std::string(r.name()) != "ref") fail(r, std::string("expected a medium (<ref name=\"") + side + "\" id=\"...\"/>)");
      (std::string(side) == "interior" ? interior : exterior) = parse_medium(r);
      interface = true;
    }
    for (xml_node m : p.take_objects("medium")) {
      std::string side = attr(m, "name");
      if (side != "interior" && side != "exterior")
        fail(m, "a shape's medium needs name=\"interior\" or name=\"exterior\"");
      if ((side == "interior" ? interior : exterior) >= 0) fail(m, "the shape's " + side + " medium is given twice");
      (side == "interior" ? interior : exterior) = parse_medium(m);
      interface = true;
    }
    std::string shape_name = has_attr(n, "id") ? attr(n, "id") : type + "@" + where(n);
    bool face_colors = false;  // the shape's PLY file gave its colours per face
    auto finish_shape = [&](ShapeDesc& s) {
      if (d.materials[size_t(material)].flags & kVertexColor) {
        auto it = vertex_color_textures_.find(d.materials[size_t(material)].tex_color);
        const std::string attribute = it != vertex_color_textures_.end() ? it->second.name : "vertex_color";
        if (s.type != ShapeType::kMesh || d.meshes[size_t(s.mesh)].colors.empty() ||
            (attribute == "face_color") != face_colors)
          fail(n, "the BSDF reads the mesh attribute '" + attribute + "', which this shape does not have");
      }
      s.material = material;
      s.emission = emission;
      s.emission_texture = emission_tex;
      s.flip_normals = flip;
      s.medium_interface = interface;
      s.interior = interior;
      s.exterior = exterior;
    };
    if (type == "cylinder") {
      // Mitsuba's cylinder: the open tube of `radius` from p0 to p1 (no caps), its to_world composed with
      // translate(p0) * to_frame(Frame(axis)) * scale(radius, radius, length) about the unit tube along z.
      Vec3f pa = p.get_point("p0", Vec3f(0.f)), pb = p.get_point("p1", Vec3f(0.f, 0.f, 1.f));
      V3 a{pa.x, pa.y, pa.z}, b{pb.x, pb.y, pb.z};
      double radius = p.get_float("radius", 1.f), length = len3(sub(b, a));
      if (!(radius > 0)) fail(p.get("radius"), "expected a positive radius");
      if (!(length > 0)) fail(n, "p0 and p1 are the same point (a cylinder needs a length)");
      V3 axis = scale3(sub(b, a), 1.0 / length);
      Frame f(Vec3f(float(axis.x), float(axis.y), float(axis.z)));
      M4 local;
      for (int i = 0; i < 3; ++i) {
        const float fs[3] = {f.s.x, f.s.y, f.s.z}, ft[3] = {f.t.x, f.t.y, f.t.z};
        local.a[i][0] = fs[i] * radius;
        local.a[i][1] = ft[i] * radius;
        local.a[i][2] = (i == 0 ? axis.x : i == 1 ? axis.y : axis.z) * length;
        local.a[i][3] = i == 0 ? a.x : i == 1 ? a.y : a.z;
      }
      shape_to_world_ = to_world = mul(to_world, local);
      tw = to_affine(to_world);
      d.meshes.push_back(unit_cylinder_mesh(shape_name));
      ShapeDesc s;
      s.name = shape_name;
      s.type = ShapeType::kMesh;
      s.mesh = int(d.meshes.size()) - 1;
      s.to_world = tw;
      finish_shape(s);
      p.finish();
      d.shapes.push_back(s);
      return;
    }
    if (file_mesh) {
      xml_node fnode = p.get("filename");
      if (!fnode) fail(n, "missing <string name=\"filename\">");
      std::string fname = p.get_string("filename", "");
      bool face_normals = p.get_bool("face_normals", false);
      fs::path path = existing_file(fnode, fname, "mesh file");
      std::vector<int> added;
      if (type == "obj") {
        added = append_obj(d, path.string(), tw, material, where(fnode));
      } else {
        MeshDesc mesh;
        int index = type == "serialized" ? p.get_int("shape_index", 0) : 0;
        if (index < 0) fail(p.get("shape_index"), "expected a shape_index >= 0");
        try {
          mesh = type == "ply" ? load_ply_mesh(path.string(), &d.warnings, &face_colors)
                               : load_serialized_mesh(path.string(), size_t(index), &d.warnings);
        } catch (const InputError& e) {
          throw InputError(where(fnode) + ": " + e.what());
        }
        // Mitsuba reads PLY and serialized texture coordinates as they are (v down, its texture
        // convention), caustica's v is up: flip (OBJ needs nothing, Mitsuba flips OBJ's v itself).
        for (Vec2f& t : mesh.uvs) t.y = 1.f - t.y;
        mesh.name = shape_name;
        d.meshes.push_back(std::move(mesh));
        ShapeDesc s;
        s.name = shape_name;
        s.type = ShapeType::kMesh;
        s.mesh = int(d.meshes.size()) - 1;
        s.to_world = tw;
        d.shapes.push_back(s);
        added.push_back(int(d.shapes.size()) - 1);
      }
      for (size_t i = 0; i < added.size(); ++i) {
        ShapeDesc& s = d.shapes[added[i]];
        finish_shape(s);
        if (added.size() == 1) s.name = shape_name;
        else s.name = shape_name + "/" + s.name;
        if (face_normals && s.mesh >= 0 && size_t(s.mesh) < d.meshes.size()) d.meshes[s.mesh].normals.clear();
      }
      p.finish();
      return;
    }
    ShapeDesc s;
    s.name = shape_name;
    s.to_world = tw;
    if (type == "sphere") {
      s.type = ShapeType::kSphere;
      s.center = p.get_point("center", Vec3f(0.f));
      s.radius = p.get_float("radius", 1.f);
      if (!(s.radius > 0.f)) fail(p.get("radius"), "expected a positive radius");
      if (zero_scale(to_world)) {
        warn(n, "zero-sphere", "a sphere scaled to zero size has no effect on the image; skipped");
        p.finish();
        return;
      }
      if (!uniform_scale(to_world)) fail(n, "a sphere's to_world must scale uniformly (caustica's spheres are exact spheres)");
    } else if (type == "rectangle") {
      s.type = ShapeType::kRectangle;
    } else if (type == "cube") {
      s.type = ShapeType::kCube;
    } else {
      s.type = ShapeType::kDisk;
    }
    finish_shape(s);
    p.finish();
    d.shapes.push_back(s);
  }

  // ---- emitters ----
  void parse_emitter(xml_node n) {
    check_attrs(n, {"type", "id", "name"});
    std::string type = attr(n, "type");
    if (type == "area") fail(n, "an area emitter must be nested in a <shape>");
    Props p(*this, n);
    if (type == "point") p.declare({"position", "to_world", "intensity"});
    if (type == "spot") p.declare({"to_world", "intensity", "cutoff_angle", "beam_width"});
    if (type == "directional") p.declare({"direction", "to_world", "irradiance"});
    if (type == "constant") p.declare({"radiance"});
    if (type == "envmap") p.declare({"filename", "scale", "to_world"});
    Light l;
    if (type == "point") {
      bool has_tw = false;
      M4 tw = p.get_transform("to_world", &has_tw);
      if (has_tw && p.has("position")) fail(n, "give either position or to_world, not both");
      l.type = LightType::kPoint;
      l.p = has_tw ? to_vec(column(tw, 3)) : p.get_point("position", Vec3f(0.f));
      p.get("position");
      l.L = p.get_color("intensity", RGB(1.f), SpectrumUse::kEmission);
    } else if (type == "spot") {
      M4 tw = p.get_transform("to_world");
      l.type = LightType::kSpot;
      l.p = to_vec(column(tw, 3));
      V3 dir = column(tw, 2);
      if (len3(dir) == 0) fail(n, "to_world maps the spot's axis to zero");
      l.dir = to_vec(scale3(dir, 1.0 / len3(dir)));
      l.L = p.get_color("intensity", RGB(1.f), SpectrumUse::kEmission);
      float cutoff = p.get_float("cutoff_angle", 20.f);
      float beam = p.get_float("beam_width", cutoff * 0.75f);
      if (!(cutoff > 0.f && cutoff <= 180.f)) fail(p.get("cutoff_angle"), "expected degrees in (0, 180]");
      if (!(beam >= 0.f)) fail(p.get("beam_width"), "expected degrees >= 0");
      beam = std::min(beam, cutoff);
      l.spot_linear_angle = 1;  // Mitsuba's falloff, linear in the angle
      l.cos_total = std::cos(cutoff * kPi / 180.f);
      l.cos_falloff_start = std::cos(beam * kPi / 180.f);
      if (p.has("texture")) fail(p.get("texture"), "projected spot textures are not supported");
    } else if (type == "directional") {
      bool has_tw = false;
      M4 tw = p.get_transform("to_world", &has_tw);
      if (has_tw && p.has("direction")) fail(n, "give either direction or to_world, not both");
      l.type = LightType::kDirectional;
      Vec3f dir = has_tw ? to_vec(column(tw, 2)) : p.get_point("direction", Vec3f(0.f, 0.f, 1.f));
      p.get("direction");
      if (length(dir) == 0.f) fail(n, "expected a non-zero direction");
      l.dir = normalize(dir);
      l.L = p.get_color("irradiance", RGB(1.f), SpectrumUse::kEmission);
    } else if (type == "constant" || type == "envmap") {
      if (have_environment) fail(n, "only one environment emitter (constant or envmap) is supported");
      have_environment = true;
      l.type = LightType::kEnvironment;
      if (type == "constant") {
        l.L = p.get_color("radiance", RGB(1.f), SpectrumUse::kEmission);
      } else {
        xml_node fnode = p.get("filename");
        if (!fnode) fail(n, "missing <string name=\"filename\">");
        fs::path path = existing_file(fnode, p.get_string("filename", ""), "environment map");
        l.L = RGB(p.get_float("scale", 1.f));
        if (!(l.L.x >= 0.f)) fail(p.get("scale"), "expected a scale >= 0");
        d.environment_to_world = to_affine(p.get_transform("to_world"));
        l.texture = load_texture(d, path.string(), false, where(fnode));
        p.get("mis_compensation");
        if (p.get_bool("mis_compensation", false))
          warn(p.get("mis_compensation"), "mis_compensation", "mis_compensation only changes sampling; ignored");
      }
    } else {
      fail(n, "unsupported emitter type (supported: area (in a shape), point, spot, directional, constant, envmap)");
    }
    // An emitter's medium matters to Mitsuba's light tracing only; volpath's shadow rays take the media from
    // the point they start at, as caustica's do. Checked, then not needed.
    for (xml_node m : p.take_objects("medium")) (void)parse_medium(m);
    p.finish({"sampling_weight"});
    d.lights.push_back(l);
  }

  // ---- sensor, film, integrator ----
  void parse_sensor(xml_node n) {
    check_attrs(n, {"type", "id", "name"});
    std::string type = attr(n, "type");
    if (type != "perspective" && type != "thinlens" && type != "orthographic")
      fail(n, "unsupported sensor type (supported: perspective, thinlens, orthographic)");
    const bool ortho = type == "orthographic";
    Props p(*this, n);
    if (ortho) p.declare({"to_world", "near_clip", "far_clip"});
    else p.declare({"fov", "fov_axis", "focal_length", "to_world", "near_clip", "far_clip"});
    if (type == "thinlens") p.declare({"aperture_radius", "focus_distance"});
    CameraDesc cam;
    cam.name = has_attr(n, "id") ? attr(n, "id") : "sensor" + std::to_string(d.cameras.size());
    // Film first: the fov conversions need the aspect ratio.
    std::vector<xml_node> films = p.take_objects("film");
    if (films.size() > 1) fail(films[1], "a sensor takes one film");
    int width = 768, height = 576;
    Filter filter = make_filter(FilterType::kGaussian);
    if (!films.empty()) parse_film(films[0], width, height, filter, cam);
    cam.width = width;
    cam.height = height;
    if (d.cameras.empty()) d.filter = filter;
    double aspect = double(width) / double(height);
    // Field of view, as an x, y or smaller-axis angle.
    double fov = 0.0;
    std::string axis;
    if (ortho) {
      axis = "x";  // set below from to_world's scale
    } else if (p.has("fov")) {
      if (p.has("focal_length")) fail(n, "give either fov or focal_length, not both");
      fov = p.get_float("fov", 0.f);
      if (!(fov > 0 && fov < 180)) fail(p.get("fov"), "expected degrees in (0, 180)");
      axis = p.get_string("fov_axis", "x");
    } else {
      std::string f = p.get_string("focal_length", "50mm");
      xml_node fn = p.get("focal_length");
      std::string num = f;
      if (num.size() > 2 && num.substr(num.size() - 2) == "mm") num = num.substr(0, num.size() - 2);
      double mm = number(fn ? fn : n, num, "a focal length such as \"50mm\"");
      if (!(mm > 0)) fail(fn ? fn : n, "expected a positive focal length");
      fov = 2.0 * std::atan(std::sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * mm)) * 180.0 / kPi;
      axis = "diagonal";
      if (p.has("fov_axis")) fail(p.get("fov_axis"), "fov_axis applies only together with fov");
    }
    auto deg = [](double rad) { return rad * 180.0 / kPi; };
    double th = ortho ? 0.0 : std::tan(0.5 * fov * kPi / 180.0);
    if (axis == "x") {
      cam.fov_axis = CameraDesc::FovAxis::kX;
    } else if (axis == "y") {
      cam.fov_axis = CameraDesc::FovAxis::kY;
    } else if (axis == "smaller") {
      cam.fov_axis = CameraDesc::FovAxis::kSmaller;
    } else if (axis == "larger") {
      cam.fov_axis = aspect >= 1.0 ? CameraDesc::FovAxis::kX : CameraDesc::FovAxis::kY;
    } else if (axis == "diagonal") {
      double tx = th * aspect / std::sqrt(1.0 + aspect * aspect);
      fov = 2.0 * deg(std::atan(tx));
      cam.fov_axis = CameraDesc::FovAxis::kX;
    } else {
      fail(p.get("fov_axis"), "unknown fov_axis '" + axis + "' (allowed: x, y, smaller, larger, diagonal)");
    }
    if (!ortho) cam.fov_degrees = float(fov);
    // Frame: Mitsuba's camera looks along local +z with +y up.
    M4 tw = p.get_transform("to_world");
    V3 o = column(tw, 3), x = column(tw, 0), y = column(tw, 1), z = column(tw, 2);
    double lx = len3(x), ly = len3(y), lz = len3(z);
    double dxy = (x.x * y.x + x.y * y.y + x.z * y.z) / (lx * ly), dxz = (x.x * z.x + x.y * z.y + x.z * z.z) / (lx * lz),
           dyz = (y.x * z.x + y.y * z.y + y.z * z.z) / (ly * lz);
    if (std::fabs(dxy) > 1e-3 || std::fabs(dxz) > 1e-3 || std::fabs(dyz) > 1e-3 || !(lx > 0 && ly > 0 && lz > 0))
      fail(n, "the camera's to_world must be a rotation and translation (with a scale of x and y for an orthographic one)");
    if (ortho) {
      // Mitsuba's orthographic sensor sees [-1, 1] x [-1/aspect, 1/aspect] of its plane, scaled by to_world.
      if (std::fabs(lx / ly - 1) > 1e-3)
        fail(n, "an orthographic sensor's to_world must scale x and y alike (caustica's pixels are square)");
      cam.orthographic = true;
      cam.view_size = float(2.0 * lx);
    } else if (std::fabs(lx - 1) > 1e-3 || std::fabs(ly - 1) > 1e-3 || std::fabs(lz - 1) > 1e-3) {
      fail(n, "the camera's to_world must be a rotation and translation (Mitsuba allows no scale here either)");
    }
    cam.position = to_vec(o);
    cam.target = to_vec(V3{o.x + z.x / lz, o.y + z.y / lz, o.z + z.z / lz});
    cam.up = to_vec(scale3(y, 1.0 / ly));
    cam.flip_x = det3(tw) < 0;
    // Clipping planes, Mitsuba's defaults 0.01 and 10000: depths along the view axis in the sensor's
    // local frame (the orthographic sensor's rays then run far_clip - near_clip in world units).
    const float near_clip = p.get_float("near_clip", 0.01f), far_clip = p.get_float("far_clip", 1e4f);
    if (!(near_clip >= 0.f && std::isfinite(near_clip))) fail(p.get("near_clip"), "expected a depth >= 0");
    if (!(far_clip > near_clip)) fail(p.get("far_clip") ? p.get("far_clip") : p.get("near_clip"), "expected far_clip beyond near_clip");
    cam.near_clip = near_clip * float(lz);
    cam.far_clip = cam.near_clip + (far_clip - near_clip);
    if (type == "thinlens") {
      xml_node an = p.get("aperture_radius");
      if (!an) fail(n, "missing <float name=\"aperture_radius\">");
      cam.aperture_radius = p.get_float("aperture_radius", 0.f);
      if (!(cam.aperture_radius >= 0.f)) fail(an, "expected a radius >= 0");
      float far_clip = p.get_float("far_clip", 1e4f);
      cam.focus_distance = p.get_float("focus_distance", far_clip);
      if (!(cam.focus_distance > 0.f)) fail(p.get("focus_distance"), "expected a positive distance");
    } else if (!ortho) {
      p.get("focus_distance");  // no effect on a pinhole
    }
    for (xml_node s : p.take_objects("sampler")) {
      check_attrs(s, {"type", "id", "name"});
      Props sp(*this, s);
      sp.declare({"sample_count"});
      int spp = sp.get_int("sample_count", 4);
      if (spp <= 0) fail(sp.get("sample_count"), "expected a positive sample_count");
      sp.get("seed");
      sp.finish({"seed", "jitter", "scramble_seed", "strata"});
      // The first sensor's sampler gives the scene's default spp and sampler
      // (explicit render options override them): Mitsuba's independent sampler
      // is caustica's; its stratified and low-discrepancy samplers map to Sobol.
      if (d.cameras.empty()) {
        d.integrator.spp = spp;
        d.integrator.sampler = attr(s, "type") == "independent" ? "independent" : "sobol";
      }
    }
    // The medium the sensor is in: a nested <medium> or an unnamed <ref id="..."/> to one.
    std::vector<xml_node> media = p.take_objects("medium");
    for (xml_node r : p.take_objects("ref")) media.push_back(r);
    if (media.size() > 1) fail(media[1], "a sensor takes one medium");
    if (!media.empty()) cam.medium = parse_medium(media[0]);
    if (p.has("principal_point_offset_x") || p.has("principal_point_offset_y")) {
      // Mitsuba's perspective sensor: fractions of the film's width and height (its other sensors have none).
      const float px = p.get_float("principal_point_offset_x", 0.f), py = p.get_float("principal_point_offset_y", 0.f);
      if (type == "perspective") {
        if (!std::isfinite(px) || !std::isfinite(py)) fail(n, "expected finite principal point offsets");
        cam.principal_point = Vec2f(px, py);
      } else if (px != 0.f || py != 0.f) {
        fail(n, "a principal point offset applies to a perspective sensor (as in Mitsuba)");
      }
    }
    if (p.has("srf")) fail(p.get("srf"), "spectral response functions are not supported");
    p.finish({"shutter_open", "shutter_close"});
    d.cameras.push_back(cam);
    if (d.cameras.size() == 1) d.camera = cam;
  }

  void parse_film(xml_node f, int& width, int& height, Filter& filter, CameraDesc& cam) {
    check_attrs(f, {"type", "id", "name"});
    std::string type = attr(f, "type");
    if (type != "hdrfilm" && type != "ldrfilm") fail(f, "unsupported film type (supported: hdrfilm, ldrfilm)");
    Props p(*this, f);
    p.declare({"width", "height", "crop_offset_x", "crop_offset_y", "crop_width", "crop_height"});
    width = p.get_int("width", 768);
    height = p.get_int("height", 576);
    if (width <= 0) fail(p.get("width"), "expected a positive width");
    if (height <= 0) fail(p.get("height"), "expected a positive height");
    if (p.has("crop_offset_x") || p.has("crop_offset_y") || p.has("crop_width") || p.has("crop_height")) {
      int cx = p.get_int("crop_offset_x", 0), cy = p.get_int("crop_offset_y", 0);
      int cw = p.get_int("crop_width", width), ch = p.get_int("crop_height", height);
      if (cx != 0 || cy != 0 || cw != width || ch != height) {
        cam.crop_x = cx;
        cam.crop_y = cy;
        cam.crop_width = cw;
        cam.crop_height = ch;
        cam.width = width;
        cam.height = height;
        if (std::string why = crop_problem(cam); !why.empty()) fail(f, why);
      }
    }
    std::vector<xml_node> filters = p.take_objects("rfilter");
    if (filters.size() > 1) fail(filters[1], "a film takes one rfilter");
    filter = make_filter(FilterType::kGaussian);
    if (!filters.empty()) {
      // Mitsuba 3's rfilters and their parameters (defaults there and here alike): box; tent (radius);
      // gaussian (stddev; radius 4 stddev); mitchell (B, C; radius 2); catmullrom; lanczos (lobes; radius lobes).
      xml_node r = filters[0];
      check_attrs(r, {"type", "id", "name"});
      std::string rt = attr(r, "type");
      Props rp(*this, r);
      const float def = kFilterDefault;
      auto checked = [&](const char* key, FilterType t, float radius, float a, float b) {
        try {
          return make_filter(t, radius, a, b);
        } catch (const InputError& e) {
          fail(key ? rp.get(key) : r, e.what());
        }
      };
      if (rt == "box") {
        filter = make_filter(FilterType::kBox);
      } else if (rt == "tent") {
        filter = checked("radius", FilterType::kTent, rp.has("radius") ? rp.get_float("radius", 1.f) : def, def, def);
      } else if (rt == "gaussian") {
        filter = checked("stddev", FilterType::kGaussian, def, rp.get_float("stddev", 0.5f), def);
      } else if (rt == "mitchell") {
        const float B = rp.get_float("B", 1.f / 3.f), C = rp.get_float("C", 1.f / 3.f);
        filter = checked(nullptr, FilterType::kMitchell, def, B, C);
      } else if (rt == "catmullrom") {
        filter = make_filter(FilterType::kMitchell, def, 0.f, 0.5f);
      } else if (rt == "lanczos") {
        filter = checked("lobes", FilterType::kLanczos, def, float(rp.get_int("lobes", 3)), def);
      } else {
        fail(r, "unsupported reconstruction filter (supported: box, tent, gaussian, mitchell, catmullrom, lanczos)");
      }
      rp.finish();
    }
    if (type == "ldrfilm")
      warn(f, "ldrfilm", "ldrfilm's tone mapping is not applied: caustica's output file name chooses the format");
    p.finish({"pixel_format", "component_format", "file_format", "banner", "high_quality_edges", "sample_border",
              "compensate", "tonemap_method", "gamma", "exposure", "key", "burn"});
  }

  void parse_integrator(xml_node n) {
    check_attrs(n, {"type", "id", "name"});
    if (have_integrator) fail(n, "a scene takes one integrator");
    have_integrator = true;
    std::string type = attr(n, "type");
    // Mitsuba's differentiable integrators render the same primal image as their forward counterparts:
    // prb, prb_basic, prbvolpath and prb_projective as path/volpath, direct_projective as direct. Their options
    // for gradients (projective sampling and guiding) cannot change the image: warnings.
    const bool path_like = type == "path" || type == "volpath" || type == "volpathmis" || type == "prb" ||
                           type == "prb_basic" || type == "prbvolpath" || type == "prb_projective";
    const bool direct_like = type == "direct" || type == "direct_projective";
    if (!path_like && !direct_like && type != "ptracer")
      fail(n, "unsupported integrator (supported: path, volpath, volpathmis, direct, ptracer, and the differentiable "
              "prb, prb_basic, prbvolpath, prb_projective, direct_projective)");
    Props p(*this, n);
    p.declare({"hide_emitters"});
    if (type == "prb_projective" || type == "direct_projective")
      p.declare({"sppc", "sppp", "sppi", "guiding", "guiding_proj", "guiding_rounds"});
    if (direct_like) {
      // Mitsuba's direct: emitters seen from the camera and direct light at the first surface, i.e. paths of at
      // most two segments: caustica's path tracer with max depth 2 (its emitter/BSDF sample counts only change
      // the noise).
      if (type == "direct") p.declare({"emitter_samples", "bsdf_samples", "shading_samples"});
      for (const char* k : {"emitter_samples", "bsdf_samples", "shading_samples"})
        if (p.has(k) && p.get_int(k, 1) < 0) fail(p.get(k), std::string("expected ") + k + " >= 0");
      d.max_depth = 2;
      d.integrator.type = "path";
    } else {
      p.declare({"max_depth", "rr_depth"});
      if (type == "ptracer") p.declare({"samples_per_pass"});
      int md = p.get_int("max_depth", -1);
      if (md == 0 || md < -1) fail(p.get("max_depth"), "expected a positive max_depth or -1 (unlimited)");
      d.max_depth = md;
      int rr = p.get_int("rr_depth", 5);
      if (rr <= 0) fail(p.get("rr_depth"), "expected a positive rr_depth");
      d.integrator.rr_depth = rr;
      // Mitsuba's ptracer traces from the lights and splats onto the film: caustica's light tracer.
      d.integrator.type = type == "ptracer" ? "light" : "path";
    }
    // hide_emitters: every caustica integrator takes it (RenderOptions::hide_emitters).
    if (p.has("hide_emitters")) d.integrator.hide_emitters = p.get_bool("hide_emitters", false) ? 1 : 0;
    p.finish({"samples_per_pass", "sppc", "sppp", "sppi", "guiding", "guiding_proj", "guiding_rounds"});
  }

  // Mitsuba's default sensor: fov 45 degrees along x, looking along +z at the
  // bounds from far enough to see them, the default 768 x 576 film.
  void default_camera() {
    SceneStats st = scene_stats(d);
    CameraDesc cam;
    cam.name = "default";
    cam.width = 768;
    cam.height = 576;
    cam.fov_degrees = 45.f;
    cam.fov_axis = CameraDesc::FovAxis::kX;
    Vec3f c = (st.lo + st.hi) * 0.5f, ext = st.hi - st.lo;
    float m = std::max(ext.x, std::max(ext.y, ext.z));
    if (!(m > 0.f)) m = 1.f;
    float dist = m / (2.f * std::tan(0.5f * 45.f * kPi / 180.f));
    cam.position = Vec3f(c.x, c.y, st.lo.z - dist);
    cam.target = cam.position + Vec3f(0.f, 0.f, 1.f);
    cam.up = Vec3f(0.f, 1.f, 0.f);
    d.camera = cam;
    d.filter = make_filter(FilterType::kGaussian);
    d.warnings.push_back(files.front()->path +
                         ": no sensor in the file; using Mitsuba's default camera (fov 45, looking along +z at the scene)");
  }
};

// ---------------------------------------------------------------------------
// Props

Props::Props(Loader& l, xml_node n) : L(l), node(n) {
  for (xml_node c : n.children()) {
    if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata)
      L.fail(n, "unexpected text '" + std::string(c.value()) + "'");
    if (c.type() != pugi::node_element) continue;
    std::string tag = c.name();
    bool named = c.attribute("name");
    if (is_property_tag(tag) || (named && (tag == "texture" || tag == "ref"))) {
      if (!named) L.fail(c, "missing attribute 'name'");
      std::string name = L.attr(c, "name");
      for (size_t i = 0; i < names.size(); ++i)
        if (names[i] == name) L.fail(c, "property '" + name + "' is given twice (first at " + L.where(props[i]) + ")");
      props.push_back(c);
      names.push_back(name);
      used.push_back(false);
    } else {
      objects.push_back(c);
      obj_used.push_back(false);
    }
  }
}

void Props::finish(std::initializer_list<const char*> ignorable) {
  std::string what = std::string(node.name()) + (node.attribute("type") ? std::string(" ") + node.attribute("type").value() : "");
  for (size_t i = 0; i < props.size(); ++i) {
    if (used[i]) continue;
    bool ign = false;
    for (const char* x : ignorable) ign |= names[i] == x;
    if (ign)
      L.warn(props[i], what + "/" + names[i], "ignored (no effect on caustica's light transport)");
    else
      L.fail(props[i], "unknown property of " + what + " (supported: " + (supported.empty() ? "none" : join(supported)) + ")");
  }
  for (size_t i = 0; i < objects.size(); ++i) {
    if (obj_used[i]) continue;
    std::string tag = objects[i].name();
    if (tag == "medium") L.fail(objects[i], "a medium belongs to a shape (interior/exterior) or a sensor, not to " + what);
    L.fail(objects[i], "unexpected element in " + Loader::describe(node));
  }
}

float Props::get_float(const std::string& name, float def) {
  xml_node n = get(name);
  if (!n) return def;
  std::string tag = n.name();
  if (tag != "float" && tag != "integer") L.fail(n, "expected a <float>");
  L.check_attrs(n, {"name", "value"});
  return float(L.number(n, L.attr(n, "value")));
}
int Props::get_int(const std::string& name, int def) {
  xml_node n = get(name);
  if (!n) return def;
  if (std::string(n.name()) != "integer") L.fail(n, "expected an <integer>");
  L.check_attrs(n, {"name", "value"});
  std::string v = L.attr(n, "value");
  char* end = nullptr;
  long x = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end || x < INT32_MIN || x > INT32_MAX) L.fail(n, "expected an integer, got '" + v + "'");
  return int(x);
}
bool Props::get_bool(const std::string& name, bool def) {
  xml_node n = get(name);
  if (!n) return def;
  if (std::string(n.name()) != "boolean") L.fail(n, "expected a <boolean>");
  L.check_attrs(n, {"name", "value"});
  std::string v = lower(L.attr(n, "value"));
  if (v == "true") return true;
  if (v == "false") return false;
  L.fail(n, "expected true or false, got '" + L.attr(n, "value") + "'");
}
std::string Props::get_string(const std::string& name, const std::string& def) {
  xml_node n = get(name);
  if (!n) return def;
  if (std::string(n.name()) != "string") L.fail(n, "expected a <string>");
  L.check_attrs(n, {"name", "value"});
  return L.attr(n, "value");
}
RGB Props::get_color(const std::string& name, RGB def, SpectrumUse use) {
  xml_node n = get(name);
  if (!n) return def;
  std::string tag = n.name();
  if (tag == "texture" || tag == "ref") L.fail(n, "a texture is not supported for this property");
  ColorOrTexture c = get_color_tex(name, def, use);
  return c.value;
}
ColorOrTexture Props::get_color_tex(const std::string& name, RGB def, SpectrumUse use) {
  xml_node n = get(name);
  ColorOrTexture r;
  r.value = def;
  if (!n) return r;
  std::string tag = n.name();
  if (tag == "texture") {
    r.texture = L.parse_texture(n, false);
    r.value = RGB(1.f);
  } else if (tag == "ref") {
    r.texture = L.lookup(n, "texture").index;
    r.value = RGB(1.f);
  } else if (tag == "float" || tag == "integer") {
    L.check_attrs(n, {"name", "value"});
    r.value = RGB(float(L.number(n, L.attr(n, "value"))));
  } else if (tag == "rgb") {
    L.check_attrs(n, {"name", "value"});
    std::vector<double> v = L.numbers(n, L.attr(n, "value"), {1, 3}, "\"r, g, b\" or one value");
    r.value = v.size() == 1 ? RGB(float(v[0])) : RGB(float(v[0]), float(v[1]), float(v[2]));
  } else if (tag == "spectrum") {
    r.value = L.spectrum(n, use);
  } else {
    L.fail(n, "expected <rgb>, <spectrum>, <float> or a <texture>");
  }
  if (!(r.value.x >= 0.f && r.value.y >= 0.f && r.value.z >= 0.f)) L.fail(n, "expected non-negative values");
  return r;
}
Vec3f Props::get_point(const std::string& name, Vec3f def) {
  xml_node n = get(name);
  if (!n) return def;
  std::string tag = n.name();
  if (tag != "point" && tag != "vector") L.fail(n, "expected a <point> or <vector>");
  L.check_attrs(n, {"name", "value", "x", "y", "z"});
  return to_vec(L.xyz(n, 0.0, false));
}
float Props::get_ior(const std::string& name, float def) {
  xml_node n = get(name);
  if (!n) return def;
  std::string tag = n.name();
  float v;
  if (tag == "string") {
    L.check_attrs(n, {"name", "value"});
    std::string s = lower(L.attr(n, "value"));
    bool found = false;
    for (const NamedIor& x : kIors)
      if (s == x.name) {
        v = x.ior;
        found = true;
      }
    if (!found) {
      std::vector<std::string> names;
      for (const NamedIor& x : kIors) names.push_back(x.name);
      L.fail(n, "unknown index of refraction '" + L.attr(n, "value") + "' (known: " + join(names) + ")");
    }
  } else if (tag == "float" || tag == "integer") {
    L.check_attrs(n, {"name", "value"});
    v = float(L.number(n, L.attr(n, "value")));
  } else {
    L.fail(n, "expected a <float> or a named material <string>");
  }
  if (!(v >= 1.f)) L.fail(n, "expected an index of refraction >= 1");
  return v;
}
M4 Props::get_transform(const std::string& name, bool* present) {
  xml_node n = get(name);
  if (present) *present = bool(n);
  M4 m;
  if (!n) return m;
  if (std::string(n.name()) != "transform") L.fail(n, "expected a <transform>");
  L.check_attrs(n, {"name"});
  for (xml_node c : n.children()) {
    if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) L.fail(n, "unexpected text in <transform>");
    if (c.type() != pugi::node_element) continue;
    std::string tag = c.name();
    M4 op;
    if (tag == "translate") {
      L.check_attrs(c, {"value", "x", "y", "z"});
      V3 t = L.xyz(c, 0.0, false);
      op.a[0][3] = t.x;
      op.a[1][3] = t.y;
      op.a[2][3] = t.z;
    } else if (tag == "scale") {
      L.check_attrs(c, {"value", "x", "y", "z"});
      V3 s = L.xyz(c, 1.0, true);
      op.a[0][0] = s.x;
      op.a[1][1] = s.y;
      op.a[2][2] = s.z;
    } else if (tag == "rotate") {
      L.check_attrs(c, {"value", "x", "y", "z", "angle"});
      V3 ax = L.xyz(c, 0.0, false);
      double len = len3(ax);
      if (len == 0) L.fail(c, "expected a non-zero rotation axis (x, y, z or value)");
      ax = scale3(ax, 1.0 / len);
      double th = L.number(c, L.attr(c, "angle")) * kPi / 180.0;
      double cs = std::cos(th), sn = std::sin(th), t = 1 - cs;
      double R[3][3] = {{t * ax.x * ax.x + cs, t * ax.x * ax.y - sn * ax.z, t * ax.x * ax.z + sn * ax.y},
                        {t * ax.x * ax.y + sn * ax.z, t * ax.y * ax.y + cs, t * ax.y * ax.z - sn * ax.x},
                        {t * ax.x * ax.z - sn * ax.y, t * ax.y * ax.z + sn * ax.x, t * ax.z * ax.z + cs}};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) op.a[i][j] = R[i][j];
    } else if (tag == "matrix") {
      L.check_attrs(c, {"value"});
      std::vector<double> v = L.numbers(c, L.attr(c, "value"), {9, 16}, "16 numbers (a row-major 4x4 matrix) or 9 (3x3)");
      if (v.size() == 9) {
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) op.a[i][j] = v[i * 3 + j];
      } else {
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) op.a[i][j] = v[i * 4 + j];
        if (std::fabs(v[12]) > 1e-6 || std::fabs(v[13]) > 1e-6 || std::fabs(v[14]) > 1e-6 || std::fabs(v[15] - 1) > 1e-6)
          L.fail(c, "projective matrices are not supported (the last row must be 0 0 0 1)");
      }
    } else if (tag == "lookat") {
      L.check_attrs(c, {"origin", "target", "up"});
      auto vec = [&](const char* a) {
        std::vector<double> v = L.numbers(c, L.attr(c, a), {3}, std::string("3 numbers for '") + a + "'");
        return V3{v[0], v[1], v[2]};
      };
      V3 o = vec("origin"), tg = vec("target"), up = vec("up");
      V3 dir = sub(tg, o);
      if (len3(dir) == 0) L.fail(c, "origin and target must differ");
      dir = scale3(dir, 1.0 / len3(dir));
      V3 left = cross3(up, dir);
      if (len3(left) < 1e-9 * std::max(1.0, len3(up))) L.fail(c, "'up' must not be parallel to the view direction");
      left = scale3(left, 1.0 / len3(left));
      V3 nup = cross3(dir, left);
      V3 cols[4] = {left, nup, dir, o};
      for (int j = 0; j < 4; ++j) {
        op.a[0][j] = cols[j].x;
        op.a[1][j] = cols[j].y;
        op.a[2][j] = cols[j].z;
      }
    } else {
      L.fail(c, "unknown transform operation (allowed: translate, rotate, scale, matrix, lookat)");
    }
    m = mul(op, m);
  }
  return m;
}

}  // namespace

namespace {

// Mitsuba's own texture coordinates on its analytic shapes, in caustica's
// convention (v_c = 1 - v_m): rectangle uv_m = ((x+1)/2, (y+1)/2); disk uv_m =
// (r, phi / 2pi); cube: Mitsuba's 24-vertex table (read from Mitsuba 3.9.1's
// `cube` mesh). caustica's own rectangle, disk and cube are parameterised
// otherwise (docs/materials.md), so textured ones become meshes with these UVs;
// untextured ones keep their shape type (the UVs cannot matter).
MeshDesc mitsuba_rectangle() {
  MeshDesc m;
  m.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  m.uvs = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}
MeshDesc mitsuba_disk() {
  // A fan with the seam duplicated and one centre vertex per triangle, so the
  // polar coordinate interpolates without wrapping across a triangle.
  MeshDesc m;
  const int n = 128;
  for (int i = 0; i <= n; ++i) {
    float phi = 2.f * kPi * float(i) / float(n);
    m.positions.push_back({std::cos(phi), std::sin(phi), 0.f});
    m.uvs.push_back({1.f, 1.f - float(i) / float(n)});
  }
  for (int i = 0; i < n; ++i) {
    m.positions.push_back({0.f, 0.f, 0.f});
    m.uvs.push_back({0.f, 1.f - (float(i) + 0.5f) / float(n)});
    uint32_t c = uint32_t(m.positions.size() - 1);
    m.indices.insert(m.indices.end(), {c, uint32_t(i), uint32_t(i + 1)});
  }
  return m;
}
MeshDesc mitsuba_cube() {
  static const float P[24][3] = {{1, -1, -1}, {1, -1, 1},  {-1, -1, 1}, {-1, -1, -1}, {1, 1, -1},  {-1, 1, -1},
                                 {-1, 1, 1},  {1, 1, 1},   {1, -1, -1}, {1, 1, -1},   {1, 1, 1},   {1, -1, 1},
                                 {1, -1, 1},  {1, 1, 1},   {-1, 1, 1},  {-1, -1, 1},  {-1, -1, 1}, {-1, 1, 1},
                                 {-1, 1, -1}, {-1, -1, -1}, {1, 1, -1}, {1, -1, -1},  {-1, -1, -1}, {-1, 1, -1}};
  static const float T[4][2] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};  // per face, in vertex order
  MeshDesc m;
  for (int i = 0; i < 24; ++i) {
    m.positions.push_back({P[i][0], P[i][1], P[i][2]});
    m.uvs.push_back({T[i % 4][0], 1.f - T[i % 4][1]});
  }
  for (uint32_t f = 0; f < 6; ++f) {
    uint32_t b = 4 * f;
    m.indices.insert(m.indices.end(), {b, b + 1, b + 2, b + 3, b, b + 2});
  }
  return m;
}

// Whether the shape's parameterisation shows: a texture, or anisotropic roughness (measured along dp/du,
// which on Mitsuba's disk is radial and on its cube differs per face from caustica's own shapes).
// A blend's materials count too.
bool material_uses_parameterisation(const SceneDesc& d, int i, uint32_t depth = 0) {
  if (i < 0 || size_t(i) >= d.materials.size()) return false;
  const Material& m = d.materials[size_t(i)];
  for (int t : material_textures(m))
    if (t >= 0) return true;
  if (m.mix_b < 0 && m.alpha_x != m.alpha_y) return true;
  return m.mix_b >= 0 && depth < kMaxMixDepth &&
         (material_uses_parameterisation(d, m.mix_a, depth + 1) || material_uses_parameterisation(d, m.mix_b, depth + 1));
}

bool uses_parameterisation(const SceneDesc& d, const ShapeDesc& s) {
  return s.emission_texture >= 0 || material_uses_parameterisation(d, s.material);
}

void mitsuba_shape_uvs(SceneDesc& d) {
  int mesh_of[3] = {-1, -1, -1};  // rectangle, disk, cube: one shared mesh each
  for (ShapeDesc& s : d.shapes) {
    int k = s.type == ShapeType::kRectangle ? 0 : s.type == ShapeType::kDisk ? 1 : s.type == ShapeType::kCube ? 2 : -1;
    if (k < 0 || !uses_parameterisation(d, s)) continue;
    if (mesh_of[k] < 0) {
      d.meshes.push_back(k == 0 ? mitsuba_rectangle() : k == 1 ? mitsuba_disk() : mitsuba_cube());
      d.meshes.back().name = k == 0 ? "mitsuba-rectangle" : k == 1 ? "mitsuba-disk" : "mitsuba-cube";
      mesh_of[k] = int(d.meshes.size()) - 1;
    }
    s.type = ShapeType::kMesh;
    s.mesh = mesh_of[k];
  }
}

}  // namespace

SceneDesc load_mitsuba_scene(const std::string& path, const std::map<std::string, std::string>& params) {
  Loader L;
  L.params = params;
  for (const auto& kv : params) L.given_params.insert(kv.first);
  L.load(path);
  mitsuba_shape_uvs(L.d);
  return std::move(L.d);
}

}  // namespace caustica
