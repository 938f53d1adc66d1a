// glTF 2.0 / GLB loader. The JSON is parsed and checked here first (with
// nlohmann::json, so that every error names the file, the glTF object path such
// as /meshes/3/primitives/0, and what was expected); tinygltf then resolves the
// buffers (external files, data URIs, the GLB BIN chunk) and the encoded image
// bytes, which are decoded once per image by load_texture_from_memory. The
// scene itself is converted from the checked JSON. docs/formats-gltf.md
// describes the mapping and the conventions.
#include "gltf_loader.h"

#include <draco/compression/decode.h>
#include <meshoptimizer.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "../../base/error.h"
#include "../../material/fresnel.h"
#include "json_text.h"
#include "mesh_loaders.h"
#include "../load.h"

namespace caustica {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// Photometric to radiometric: KHR_lights_punctual intensities are in candela
// (point, spot) and lux (directional); dividing by 683 lm/W undoes the factor
// the Blender exporter applies in its default "Standard" lighting mode.
constexpr float kLumensPerWatt = 683.f;

constexpr int kByte = 5120, kUByte = 5121, kShort = 5122, kUShort = 5123, kUInt = 5125, kFloat = 5126;

const std::set<std::string>& supported_extensions() {
  static const std::set<std::string> s = {
      "KHR_materials_transmission", "KHR_materials_ior",    "KHR_materials_volume",
      "KHR_materials_emissive_strength", "KHR_materials_anisotropy", "KHR_materials_clearcoat", "KHR_materials_specular", "KHR_materials_sheen", "KHR_materials_diffuse_transmission", "KHR_lights_punctual",
      "KHR_texture_transform", "KHR_mesh_quantization", "EXT_mesh_gpu_instancing",
      "KHR_materials_pbrSpecularGlossiness", "EXT_texture_webp", "KHR_draco_mesh_compression",
      "EXT_meshopt_compression", "KHR_materials_unlit", "KHR_materials_iridescence", "KHR_materials_variants",
      "KHR_node_visibility"};
  return s;
}
// Known extensions that change only appearance details caustica does not model.
const std::set<std::string>& ignored_extensions() {
  static const std::set<std::string> s = {
      "KHR_materials_dispersion", "KHR_texture_basisu",
      "KHR_animation_pointer", "KHR_xmp_json_ld"};
  return s;
}

struct Ctx {
  std::string file;
  fs::path base_dir;
  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError(file + ": " + (path.empty() ? "/" : path) + ": " + what);
  }
};

const json* member(const json& o, const char* key) {
  if (!o.is_object()) return nullptr;
  auto it = o.find(key);
  return it == o.end() ? nullptr : &*it;
}

std::string P(const std::string& base, const std::string& key) { return base + "/" + key; }
std::string P(const std::string& base, size_t i) { return base + "/" + std::to_string(i); }

double number(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_number()) c.fail(path, std::string("expected a number, got ") + j.type_name());
  double v = j.get<double>();
  if (!std::isfinite(v)) c.fail(path, "expected a finite number");
  return v;
}
double number_or(const Ctx& c, const json& o, const char* key, const std::string& path, double def) {
  const json* m = member(o, key);
  return m ? number(c, *m, P(path, key)) : def;
}
int64_t integer(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_number_integer()) c.fail(path, std::string("expected an integer, got ") + j.type_name());
  return j.get<int64_t>();
}
const json& object_at(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_object()) c.fail(path, std::string("expected an object, got ") + j.type_name());
  return j;
}
const json& array_at(const Ctx& c, const json& j, const std::string& path) {
  if (!j.is_array()) c.fail(path, std::string("expected an array, got ") + j.type_name());
  return j;
}
const json& empty_array() {
  static const json e = json::array();
  return e;
}
// A top-level array such as "meshes" (empty when absent).
const json& top(const Ctx& c, const json& root, const char* key) {
  const json* m = member(root, key);
  return m ? array_at(c, *m, std::string("/") + key) : empty_array();
}
const json& lights_array(const Ctx& c, const json& root) {
  const json* e = member(root, "extensions");
  const json* k = e ? member(*e, "KHR_lights_punctual") : nullptr;
  const json* l = k ? member(*k, "lights") : nullptr;
  return l ? array_at(c, *l, "/extensions/KHR_lights_punctual/lights") : empty_array();
}
// KHR_materials_variants: the root's array of variants (empty without the extension; the extension without
// it is an error, the specification requiring it).
const char* const kVariantsPath = "/extensions/KHR_materials_variants/variants";
const json& variants_array(const Ctx& c, const json& root) {
  const json* e = member(root, "extensions");
  const json* k = e ? member(*e, "KHR_materials_variants") : nullptr;
  if (!k) return empty_array();
  const json* v = member(object_at(c, *k, "/extensions/KHR_materials_variants"), "variants");
  if (!v) c.fail(kVariantsPath, "missing (an array of variants, each with a name)");
  return array_at(c, *v, kVariantsPath);
}

// An index into `arr` (named `arr_path` in messages).
size_t index_into(const Ctx& c, const json& j, const std::string& path, const json& arr, const std::string& arr_path) {
  int64_t v = integer(c, j, path);
  if (v < 0 || size_t(v) >= arr.size())
    c.fail(path, "index " + std::to_string(v) + " out of range (" + arr_path +
                     (arr.empty() ? " is empty)" : " has " + std::to_string(arr.size()) + " entries)"));
  return size_t(v);
}
std::vector<double> numbers(const Ctx& c, const json& j, const std::string& path, size_t n) {
  if (!j.is_array() || j.size() != n) c.fail(path, "expected an array of " + std::to_string(n) + " numbers");
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = number(c, j[i], P(path, i));
  return v;
}
std::string string_or(const Ctx& c, const json& o, const char* key, const std::string& path, const std::string& def) {
  const json* m = member(o, key);
  if (!m) return def;
  if (!m->is_string()) c.fail(P(path, key), std::string("expected a string, got ") + m->type_name());
  return m->get<std::string>();
}

int component_size(int ct) {
  switch (ct) {
    case kByte: case kUByte: return 1;
    case kShort: case kUShort: return 2;
    case kUInt: case kFloat: return 4;
    default: return 0;
  }
}
int type_components(const std::string& t) {
  if (t == "SCALAR") return 1;
  if (t == "VEC2") return 2;
  if (t == "VEC3") return 3;
  if (t == "VEC4") return 4;
  if (t == "MAT2") return 4;
  if (t == "MAT3") return 9;
  if (t == "MAT4") return 16;
  return 0;
}

std::string url_decode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit((unsigned char)s[i + 1]) && std::isxdigit((unsigned char)s[i + 2])) {
      out += char(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}
bool is_data_uri(const std::string& u) { return u.rfind("data:", 0) == 0; }

// ---------------------------------------------------------------- checks ----
// Everything tinygltf would trip over (and every reference the conversion
// follows) is checked here, so that errors carry a glTF object path.
// An EXT_meshopt_compression fallback buffer (no data of its own; its views are compressed elsewhere).
bool meshopt_fallback(const json& buffer) {
  const json* ex = buffer.is_object() ? member(buffer, "extensions") : nullptr;
  const json* mo = ex && ex->is_object() ? member(*ex, "EXT_meshopt_compression") : nullptr;
  const json* fb = mo && mo->is_object() ? member(*mo, "fallback") : nullptr;
  return fb && fb->is_boolean() && fb->get<bool>();
}

void check_structure(const Ctx& c, const json& root, bool glb_has_bin, std::vector<std::string>& warnings) {
  if (!root.is_object()) c.fail("/", std::string("expected a JSON object, got ") + root.type_name());
  const json* asset = member(root, "asset");
  if (!asset) c.fail("/asset", "missing (every glTF file has an asset object with a version)");
  object_at(c, *asset, "/asset");
  std::string version = string_or(c, *asset, "version", "/asset", "");
  if (version.empty()) c.fail("/asset/version", "missing (expected \"2.0\")");
  if (version.rfind("2.", 0) != 0) c.fail("/asset/version", "glTF version '" + version + "' is not supported (expected 2.x)");

  // Extensions.
  if (const json* req = member(root, "extensionsRequired")) {
    array_at(c, *req, "/extensionsRequired");
    for (size_t i = 0; i < req->size(); ++i) {
      std::string e = (*req)[i].is_string() ? (*req)[i].get<std::string>() : "";
      if (!supported_extensions().count(e)) {
        std::string list;
        for (const std::string& s : supported_extensions()) list += (list.empty() ? "" : ", ") + s;
        c.fail(P("/extensionsRequired", i), "extension '" + e + "' is required but not supported (supported: " + list + ")");
      }
    }
  }
  if (const json* used = member(root, "extensionsUsed")) {
    array_at(c, *used, "/extensionsUsed");
    for (size_t i = 0; i < used->size(); ++i) {
      std::string e = (*used)[i].is_string() ? (*used)[i].get<std::string>() : "";
      if (supported_extensions().count(e)) continue;
      if (ignored_extensions().count(e))
        warnings.push_back(c.file + ": extension " + e + " is not supported; its properties are ignored");
      else
        warnings.push_back(c.file + ": unknown extension " + e + " ignored");
    }
  }

  const json& buffers = top(c, root, "buffers");
  const json& views = top(c, root, "bufferViews");
  const json& accessors = top(c, root, "accessors");
  const json& images = top(c, root, "images");
  const json& samplers = top(c, root, "samplers");
  const json& textures = top(c, root, "textures");
  const json& materials = top(c, root, "materials");
  const json& meshes = top(c, root, "meshes");
  const json& nodes = top(c, root, "nodes");
  const json& scenes = top(c, root, "scenes");
  const json& cameras = top(c, root, "cameras");
  const json& skins = top(c, root, "skins");
  const json& lights = lights_array(c, root);
  const json& variants = variants_array(c, root);

  auto req = [&](const json& o, const char* key, const std::string& path, const std::string& what) -> const json& {
    const json* m = member(o, key);
    if (!m) c.fail(P(path, key), "missing (" + what + ")");
    return *m;
  };
  for (size_t i = 0; i < variants.size(); ++i) {  // KHR_materials_variants: --variant picks one by its name
    const std::string p = P(kVariantsPath, i);
    req(object_at(c, variants[i], p), "name", p, "the variant's name");
    string_or(c, variants[i], "name", p, "");
  }

  // Buffers: external files must exist and be large enough.
  std::vector<int64_t> buffer_len(buffers.size());
  for (size_t i = 0; i < buffers.size(); ++i) {
    std::string p = P("/buffers", i);
    const json& b = object_at(c, buffers[i], p);
    buffer_len[i] = integer(c, req(b, "byteLength", p, "the buffer's size in bytes"), P(p, "byteLength"));
    if (buffer_len[i] < 1) c.fail(P(p, "byteLength"), "expected a positive integer");
    std::string uri = string_or(c, b, "uri", p, "");
    if (uri.empty() && meshopt_fallback(b)) {
      // EXT_meshopt_compression's fallback buffer: no data; its views are decoded from another buffer.
    } else if (uri.empty()) {
      if (i != 0 || !glb_has_bin)
        c.fail(p, glb_has_bin || i != 0 ? "missing 'uri' (only the first buffer of a GLB file may omit it)"
                                        : "missing 'uri' (and the file has no GLB binary chunk)");
    } else if (!is_data_uri(uri)) {
      fs::path f = c.base_dir / url_decode(uri);
      std::error_code ec;
      if (!fs::is_regular_file(f, ec)) c.fail(P(p, "uri"), "buffer file '" + f.string() + "' does not exist");
      auto size = fs::file_size(f, ec);
      if (!ec && int64_t(size) < buffer_len[i])
        c.fail(P(p, "byteLength"), "buffer file '" + f.string() + "' has " + std::to_string(size) +
                                       " bytes, fewer than byteLength " + std::to_string(buffer_len[i]));
    }
  }
  // Buffer views.
  std::vector<int64_t> view_len(views.size());
  for (size_t i = 0; i < views.size(); ++i) {
    std::string p = P("/bufferViews", i);
    const json& v = object_at(c, views[i], p);
    size_t b = index_into(c, req(v, "buffer", p, "an index into /buffers"), P(p, "buffer"), buffers, "/buffers");
    int64_t off = member(v, "byteOffset") ? integer(c, v["byteOffset"], P(p, "byteOffset")) : 0;
    int64_t len = integer(c, req(v, "byteLength", p, "the view's size in bytes"), P(p, "byteLength"));
    if (off < 0) c.fail(P(p, "byteOffset"), "expected a non-negative integer");
    if (len < 1) c.fail(P(p, "byteLength"), "expected a positive integer");
    if (off + len > buffer_len[b])
      c.fail(p, "bytes [" + std::to_string(off) + ", " + std::to_string(off + len) + ") exceed buffer " +
                    std::to_string(b) + " (" + std::to_string(buffer_len[b]) + " bytes)");
    if (const json* s = member(v, "byteStride")) {
      int64_t st = integer(c, *s, P(p, "byteStride"));
      if (st < 4 || st > 252 || st % 4) c.fail(P(p, "byteStride"), "expected a multiple of 4 in [4, 252]");
    }
    view_len[i] = len;
    // EXT_meshopt_compression: count elements of byteStride bytes, decoded from a range of another buffer.
    const json* ex = member(v, "extensions");
    const json* mo = ex ? member(object_at(c, *ex, P(p, "extensions")), "EXT_meshopt_compression") : nullptr;
    if (!mo) {
      if (meshopt_fallback(buffers[b]))
        c.fail(p, "refers to buffer " + std::to_string(b) + ", an EXT_meshopt_compression fallback without data, but "
                      "has no EXT_meshopt_compression of its own");
      continue;
    }
    const std::string mp = P(P(p, "extensions"), "EXT_meshopt_compression");
    object_at(c, *mo, mp);
    const size_t mb = index_into(c, req(*mo, "buffer", mp, "an index into /buffers"), P(mp, "buffer"), buffers, "/buffers");
    if (meshopt_fallback(buffers[mb])) c.fail(P(mp, "buffer"), "refers to a fallback buffer, which has no data");
    const int64_t moff = member(*mo, "byteOffset") ? integer(c, (*mo)["byteOffset"], P(mp, "byteOffset")) : 0;
    const int64_t mlen = integer(c, req(*mo, "byteLength", mp, "the compressed size in bytes"), P(mp, "byteLength"));
    if (moff < 0 || mlen < 1 || moff + mlen > buffer_len[mb])
      c.fail(mp, "bytes [" + std::to_string(moff) + ", " + std::to_string(moff + mlen) + ") do not lie in buffer " +
                     std::to_string(mb) + " (" + std::to_string(buffer_len[mb]) + " bytes)");
    const int64_t stride = integer(c, req(*mo, "byteStride", mp, "the size of an element"), P(mp, "byteStride"));
    const int64_t count = integer(c, req(*mo, "count", mp, "the number of elements"), P(mp, "count"));
    const std::string mode = string_or(c, *mo, "mode", mp, "");
    const std::string filter = string_or(c, *mo, "filter", mp, "NONE");
    if (mode == "ATTRIBUTES") {
      if (stride < 4 || stride > 256 || stride % 4) c.fail(P(mp, "byteStride"), "expected a multiple of 4 in [4, 256]");
    } else if (mode == "TRIANGLES" || mode == "INDICES") {
      if (stride != 2 && stride != 4) c.fail(P(mp, "byteStride"), "expected 2 or 4 (bytes per index)");
      if (mode == "TRIANGLES" && count % 3) c.fail(P(mp, "count"), "expected a multiple of 3 (whole triangles)");
      if (filter != "NONE") c.fail(P(mp, "filter"), "expected NONE for mode " + mode);
    } else {
      c.fail(P(mp, "mode"), "expected ATTRIBUTES, TRIANGLES or INDICES, got '" + mode + "'");
    }
    if (filter == "OCTAHEDRAL") {
      if (stride != 4 && stride != 8) c.fail(P(mp, "byteStride"), "expected 4 or 8 for the OCTAHEDRAL filter");
    } else if (filter == "QUATERNION") {
      if (stride != 8) c.fail(P(mp, "byteStride"), "expected 8 for the QUATERNION filter");
    } else if (filter != "NONE" && filter != "EXPONENTIAL") {
      c.fail(P(mp, "filter"), "expected NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL, got '" + filter + "'");
    }
    if (count < 1 || count * stride != len)
      c.fail(mp, "count " + std::to_string(count) + " x byteStride " + std::to_string(stride) +
                     " differs from the view's byteLength " + std::to_string(len));
  }
  // Accessors (and their byte ranges).
  auto check_range = [&](const std::string& p, size_t view, int64_t offset, int64_t count, int64_t elem) {
    int64_t stride = elem;
    if (const json* s = member(views[view], "byteStride")) stride = std::max<int64_t>(stride, s->get<int64_t>());
    int64_t end = offset + stride * (count - 1) + elem;
    if (end > view_len[view])
      c.fail(p, "needs bytes [" + std::to_string(offset) + ", " + std::to_string(end) + ") of bufferView " +
                    std::to_string(view) + ", which has " + std::to_string(view_len[view]) + " bytes");
  };
  for (size_t i = 0; i < accessors.size(); ++i) {
    std::string p = P("/accessors", i);
    const json& a = object_at(c, accessors[i], p);
    int64_t ct = integer(c, req(a, "componentType", p, "5120, 5121, 5122, 5123, 5125 or 5126"), P(p, "componentType"));
    if (!component_size(int(ct)))
      c.fail(P(p, "componentType"), "unknown component type " + std::to_string(ct) + " (expected 5120, 5121, 5122, 5123, 5125 or 5126)");
    int64_t count = integer(c, req(a, "count", p, "the number of elements"), P(p, "count"));
    if (count < 1) c.fail(P(p, "count"), "expected a positive integer");
    const json& tj = req(a, "type", p, "SCALAR, VEC2, VEC3, VEC4, MAT2, MAT3 or MAT4");
    std::string type = tj.is_string() ? tj.get<std::string>() : "";
    int nc = type_components(type);
    if (!nc) c.fail(P(p, "type"), "expected SCALAR, VEC2, VEC3, VEC4, MAT2, MAT3 or MAT4");
    int64_t off = member(a, "byteOffset") ? integer(c, a["byteOffset"], P(p, "byteOffset")) : 0;
    if (off < 0) c.fail(P(p, "byteOffset"), "expected a non-negative integer");
    if (const json* bv = member(a, "bufferView")) {
      size_t v = index_into(c, *bv, P(p, "bufferView"), views, "/bufferViews");
      check_range(p, v, off, count, int64_t(nc) * component_size(int(ct)));
    }
    if (const json* sp = member(a, "sparse")) {
      std::string sp_p = P(p, "sparse");
      object_at(c, *sp, sp_p);
      int64_t sc = integer(c, req(*sp, "count", sp_p, "the number of sparse elements"), P(sp_p, "count"));
      if (sc < 1 || sc > count) c.fail(P(sp_p, "count"), "expected an integer in [1, " + std::to_string(count) + "]");
      const json& ind = object_at(c, req(*sp, "indices", sp_p, "an object"), P(sp_p, "indices"));
      const json& val = object_at(c, req(*sp, "values", sp_p, "an object"), P(sp_p, "values"));
      std::string ip = P(sp_p, "indices"), vp = P(sp_p, "values");
      size_t iv = index_into(c, req(ind, "bufferView", ip, "an index into /bufferViews"), P(ip, "bufferView"), views, "/bufferViews");
      int64_t ict = integer(c, req(ind, "componentType", ip, "5121, 5123 or 5125"), P(ip, "componentType"));
      if (ict != kUByte && ict != kUShort && ict != kUInt) c.fail(P(ip, "componentType"), "expected 5121, 5123 or 5125");
      int64_t ioff = member(ind, "byteOffset") ? integer(c, ind["byteOffset"], P(ip, "byteOffset")) : 0;
      check_range(ip, iv, ioff, sc, component_size(int(ict)));
      size_t vv = index_into(c, req(val, "bufferView", vp, "an index into /bufferViews"), P(vp, "bufferView"), views, "/bufferViews");
      int64_t voff = member(val, "byteOffset") ? integer(c, val["byteOffset"], P(vp, "byteOffset")) : 0;
      int64_t elem = int64_t(nc) * component_size(int(ct));
      if (voff < 0 || voff + elem * sc > view_len[vv])
        c.fail(vp, "needs " + std::to_string(elem * sc) + " bytes at offset " + std::to_string(voff) + " of bufferView " +
                       std::to_string(vv) + ", which has " + std::to_string(view_len[vv]) + " bytes");
    }
  }
  // Images, samplers, textures.
  for (size_t i = 0; i < images.size(); ++i) {
    std::string p = P("/images", i);
    const json& im = object_at(c, images[i], p);
    const json* bv = member(im, "bufferView");
    if (bv) {
      const size_t v = index_into(c, *bv, P(p, "bufferView"), views, "/bufferViews");
      if (meshopt_fallback(buffers[views[v]["buffer"].get<size_t>()]))  // its view is compressed: not for images
        c.fail(P(p, "bufferView"), "refers to bufferView " + std::to_string(v) + ", which EXT_meshopt_compression "
                                       "compresses (images are stored as they are)");
    }
    std::string uri = string_or(c, im, "uri", p, "");
    if (!bv && uri.empty()) c.fail(p, "expected a 'uri' or a 'bufferView'");
  }
  for (size_t i = 0; i < samplers.size(); ++i) object_at(c, samplers[i], P("/samplers", i));
  for (size_t i = 0; i < textures.size(); ++i) {
    std::string p = P("/textures", i);
    const json& t = object_at(c, textures[i], p);
    if (const json* s = member(t, "source")) index_into(c, *s, P(p, "source"), images, "/images");
    if (const json* ex = member(t, "extensions"))
      if (const json* w = member(object_at(c, *ex, P(p, "extensions")), "EXT_texture_webp")) {
        const std::string wp = P(P(p, "extensions"), "EXT_texture_webp");
        index_into(c, req(object_at(c, *w, wp), "source", wp, "an index into /images"), P(wp, "source"), images, "/images");
      }
    if (const json* s = member(t, "sampler")) index_into(c, *s, P(p, "sampler"), samplers, "/samplers");
  }
  // Materials: texture references.
  auto check_texinfo = [&](const json& o, const char* key, const std::string& path) {
    const json* ti = member(o, key);
    if (!ti) return;
    std::string p = P(path, key);
    object_at(c, *ti, p);
    index_into(c, req(*ti, "index", p, "an index into /textures"), P(p, "index"), textures, "/textures");
    if (const json* tc = member(*ti, "texCoord")) {
      if (integer(c, *tc, P(p, "texCoord")) < 0) c.fail(P(p, "texCoord"), "expected a non-negative integer");
    }
  };
  for (size_t i = 0; i < materials.size(); ++i) {
    std::string p = P("/materials", i);
    const json& m = object_at(c, materials[i], p);
    if (const json* pbr = member(m, "pbrMetallicRoughness")) {
      object_at(c, *pbr, P(p, "pbrMetallicRoughness"));
      check_texinfo(*pbr, "baseColorTexture", P(p, "pbrMetallicRoughness"));
      check_texinfo(*pbr, "metallicRoughnessTexture", P(p, "pbrMetallicRoughness"));
    }
    check_texinfo(m, "normalTexture", p);
    check_texinfo(m, "occlusionTexture", p);
    check_texinfo(m, "emissiveTexture", p);
    if (const json* ext = member(m, "extensions")) {
      object_at(c, *ext, P(p, "extensions"));
      std::string ep = P(p, "extensions");
      // The texture infos of the material extensions; every one Converter::material reads must be listed here:
      // it indexes them without checks.
      struct ExtTextures {
        const char* ext;
        std::vector<const char*> keys;
      };
      static const ExtTextures kExtTextures[] = {
          {"KHR_materials_transmission", {"transmissionTexture"}},
          {"KHR_materials_volume", {"thicknessTexture"}},
          {"KHR_materials_clearcoat", {"clearcoatTexture", "clearcoatRoughnessTexture", "clearcoatNormalTexture"}},
          {"KHR_materials_specular", {"specularTexture", "specularColorTexture"}},
          {"KHR_materials_sheen", {"sheenColorTexture", "sheenRoughnessTexture"}},
          {"KHR_materials_diffuse_transmission", {"diffuseTransmissionTexture", "diffuseTransmissionColorTexture"}},
          {"KHR_materials_iridescence", {"iridescenceTexture", "iridescenceThicknessTexture"}},
          {"KHR_materials_anisotropy", {"anisotropyTexture"}},
          {"KHR_materials_pbrSpecularGlossiness", {"diffuseTexture", "specularGlossinessTexture"}}};
      for (const ExtTextures& e : kExtTextures)
        if (const json* t = member(*ext, e.ext)) {
          const std::string xp = P(ep, e.ext);
          object_at(c, *t, xp);
          for (const char* k : e.keys) check_texinfo(*t, k, xp);
        }
    }
  }
  // Meshes.
  for (size_t i = 0; i < meshes.size(); ++i) {
    std::string p = P("/meshes", i);
    const json& m = object_at(c, meshes[i], p);
    const json& prims = array_at(c, req(m, "primitives", p, "an array of primitives"), P(p, "primitives"));
    if (prims.empty()) c.fail(P(p, "primitives"), "expected at least one primitive");
    for (size_t k = 0; k < prims.size(); ++k) {
      std::string pp = P(P(p, "primitives"), k);
      const json& pr = object_at(c, prims[k], pp);
      const json& attrs = object_at(c, req(pr, "attributes", pp, "an object of accessor indices"), P(pp, "attributes"));
      for (auto it = attrs.begin(); it != attrs.end(); ++it)
        index_into(c, it.value(), P(P(pp, "attributes"), it.key()), accessors, "/accessors");
      if (const json* ix = member(pr, "indices")) index_into(c, *ix, P(pp, "indices"), accessors, "/accessors");
      if (const json* ex = member(pr, "extensions"))
        if (const json* dc = member(object_at(c, *ex, P(pp, "extensions")), "KHR_draco_mesh_compression")) {
          const std::string dp = P(P(pp, "extensions"), "KHR_draco_mesh_compression");
          object_at(c, *dc, dp);
          index_into(c, req(*dc, "bufferView", dp, "an index into /bufferViews"), P(dp, "bufferView"), views, "/bufferViews");
          const json& da = object_at(c, req(*dc, "attributes", dp, "an object of Draco attribute ids"), P(dp, "attributes"));
          for (auto it = da.begin(); it != da.end(); ++it) {
            if (!attrs.contains(it.key()))
              c.fail(P(P(dp, "attributes"), it.key()), "not among the primitive's attributes");
            const int64_t id = integer(c, it.value(), P(P(dp, "attributes"), it.key()));
            if (id < 0) c.fail(P(P(dp, "attributes"), it.key()), "expected a non-negative Draco attribute id");
          }
        }
      if (const json* mt = member(pr, "material")) index_into(c, *mt, P(pp, "material"), materials, "/materials");
      // KHR_materials_variants: each mapping gives a material to some variants, each variant at most once.
      if (const json* mv = member(pr, "extensions") ? member(pr["extensions"], "KHR_materials_variants") : nullptr) {
        const std::string vp = P(P(pp, "extensions"), "KHR_materials_variants");
        const json& maps = array_at(c, req(object_at(c, *mv, vp), "mappings", vp, "an array of material mappings"),
                                    P(vp, "mappings"));
        std::vector<bool> mapped(variants.size(), false);
        for (size_t m = 0; m < maps.size(); ++m) {
          const std::string mp = P(P(vp, "mappings"), m);
          const json& mo = object_at(c, maps[m], mp);
          index_into(c, req(mo, "material", mp, "an index into /materials"), P(mp, "material"), materials, "/materials");
          const json& vs = array_at(c, req(mo, "variants", mp, "an array of indices into " + std::string(kVariantsPath)),
                                    P(mp, "variants"));
          for (size_t k = 0; k < vs.size(); ++k) {
            const size_t v = index_into(c, vs[k], P(P(mp, "variants"), k), variants, kVariantsPath);
            if (mapped[v])
              c.fail(P(P(mp, "variants"), k), "variant " + std::to_string(v) +
                                                  " has a material already (each variant is mapped once per primitive)");
            mapped[v] = true;
          }
        }
      }
      if (const json* md = member(pr, "mode")) {
        int64_t mode = integer(c, *md, P(pp, "mode"));
        if (mode < 0 || mode > 6) c.fail(P(pp, "mode"), "expected a primitive mode in [0, 6]");
      }
      if (const json* tg = member(pr, "targets")) {
        array_at(c, *tg, P(pp, "targets"));
        for (size_t t = 0; t < tg->size(); ++t) {
          const json& o = object_at(c, (*tg)[t], P(P(pp, "targets"), t));
          for (auto it = o.begin(); it != o.end(); ++it)
            index_into(c, it.value(), P(P(P(pp, "targets"), t), it.key()), accessors, "/accessors");
        }
      }
    }
  }
  // Cameras and lights.
  for (size_t i = 0; i < cameras.size(); ++i) {
    std::string p = P("/cameras", i);
    const json& cam = object_at(c, cameras[i], p);
    std::string type = string_or(c, cam, "type", p, "");
    if (type == "perspective") {
      const json& per = object_at(c, req(cam, "perspective", p, "an object with yfov and znear"), P(p, "perspective"));
      std::string pp = P(p, "perspective");
      double yfov = number(c, req(per, "yfov", pp, "the vertical field of view in radians"), P(pp, "yfov"));
      if (!(yfov > 0.0 && yfov < kPi)) c.fail(P(pp, "yfov"), "expected radians in (0, pi)");
      if (!(number(c, req(per, "znear", pp, "the near plane distance"), P(pp, "znear")) >= 0.0))
        c.fail(P(pp, "znear"), "expected a distance >= 0");
      if (const json* zf = member(per, "zfar"))
        if (!(number(c, *zf, P(pp, "zfar")) > per["znear"].get<double>()))
          c.fail(P(pp, "zfar"), "expected a distance beyond znear");
      if (const json* ar = member(per, "aspectRatio"))
        if (!(number(c, *ar, P(pp, "aspectRatio")) > 0.0)) c.fail(P(pp, "aspectRatio"), "expected a positive number");
    } else if (type == "orthographic") {
      const json& o = object_at(c, req(cam, "orthographic", p, "an object with xmag, ymag, zfar and znear"), P(p, "orthographic"));
      for (const char* k : {"xmag", "ymag", "zfar", "znear"})
        number(c, req(o, k, P(p, "orthographic"), "a number"), P(P(p, "orthographic"), k));
      for (const char* k : {"xmag", "ymag"})
        if (!(o[k].get<double>() > 0.0)) c.fail(P(P(p, "orthographic"), k), "expected a positive half-extent");
      if (!(o["znear"].get<double>() >= 0.0)) c.fail(P(P(p, "orthographic"), "znear"), "expected a distance >= 0");
      if (!(o["zfar"].get<double>() > o["znear"].get<double>()))
        c.fail(P(P(p, "orthographic"), "zfar"), "expected a distance beyond znear");
    } else {
      c.fail(P(p, "type"), type.empty() ? "missing (expected \"perspective\" or \"orthographic\")"
                                        : "unknown camera type '" + type + "' (expected perspective or orthographic)");
    }
  }
  for (size_t i = 0; i < lights.size(); ++i) {
    std::string p = P("/extensions/KHR_lights_punctual/lights", i);
    const json& l = object_at(c, lights[i], p);
    std::string type = string_or(c, l, "type", p, "");
    if (type != "point" && type != "spot" && type != "directional")
      c.fail(P(p, "type"), type.empty() ? "missing (expected point, spot or directional)"
                                        : "unknown light type '" + type + "' (expected point, spot or directional)");
  }
  // Nodes: references, transforms, and a forest (one parent at most, no cycles).
  std::vector<int64_t> parent(nodes.size(), -1);
  for (size_t i = 0; i < nodes.size(); ++i) {
    std::string p = P("/nodes", i);
    const json& n = object_at(c, nodes[i], p);
    if (const json* ch = member(n, "children")) {
      array_at(c, *ch, P(p, "children"));
      for (size_t k = 0; k < ch->size(); ++k) {
        size_t child = index_into(c, (*ch)[k], P(P(p, "children"), k), nodes, "/nodes");
        if (parent[child] >= 0 || child == i)
          c.fail(P(P(p, "children"), k), "node " + std::to_string(child) + " already has a parent (" +
                                             (child == i ? "itself" : "node " + std::to_string(parent[child])) +
                                             "; nodes must form trees)");
        parent[child] = int64_t(i);
      }
    }
    if (const json* x = member(n, "mesh")) index_into(c, *x, P(p, "mesh"), meshes, "/meshes");
    if (const json* x = member(n, "camera")) index_into(c, *x, P(p, "camera"), cameras, "/cameras");
    if (const json* x = member(n, "skin")) index_into(c, *x, P(p, "skin"), skins, "/skins");
    if (const json* e = member(n, "extensions")) {
      if (const json* lp = member(*e, "KHR_lights_punctual")) {
        std::string lpp = P(P(p, "extensions"), "KHR_lights_punctual");
        index_into(c, req(object_at(c, *lp, lpp), "light", lpp, "an index into the lights"), P(lpp, "light"), lights,
                   "/extensions/KHR_lights_punctual/lights");
      }
      if (const json* nv = member(*e, "KHR_node_visibility")) {
        const std::string vp = P(P(p, "extensions"), "KHR_node_visibility");
        const json* v = member(object_at(c, *nv, vp), "visible");
        if (v && !v->is_boolean()) c.fail(P(vp, "visible"), std::string("expected true or false, got ") + v->type_name());
      }
    }
    if (const json* m = member(n, "matrix")) {
      numbers(c, *m, P(p, "matrix"), 16);
      if (member(n, "translation") || member(n, "rotation") || member(n, "scale"))
        c.fail(P(p, "matrix"), "cannot be combined with translation, rotation or scale");
    }
    if (const json* t = member(n, "translation")) numbers(c, *t, P(p, "translation"), 3);
    if (const json* r = member(n, "rotation")) {
      std::vector<double> q = numbers(c, *r, P(p, "rotation"), 4);
      if (!(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] > 0.0))
        c.fail(P(p, "rotation"), "expected a unit quaternion (x, y, z, w), got all zeros");
    }
    if (const json* s = member(n, "scale")) numbers(c, *s, P(p, "scale"), 3);
  }
  for (size_t i = 0; i < nodes.size(); ++i) {  // with one parent each, a cycle is a loop of parent links
    size_t steps = 0;
    for (int64_t k = parent[i]; k >= 0; k = parent[size_t(k)])
      if (++steps > nodes.size()) c.fail(P("/nodes", i), "is part of a cycle of children (nodes must form trees)");
  }
  for (size_t i = 0; i < scenes.size(); ++i) {
    std::string p = P("/scenes", i);
    const json& s = object_at(c, scenes[i], p);
    if (const json* ns = member(s, "nodes")) {
      array_at(c, *ns, P(p, "nodes"));
      for (size_t k = 0; k < ns->size(); ++k) {
        size_t n = index_into(c, (*ns)[k], P(P(p, "nodes"), k), nodes, "/nodes");
        if (parent[n] >= 0)
          c.fail(P(P(p, "nodes"), k), "node " + std::to_string(n) + " is a child of node " + std::to_string(parent[n]) +
                                          " (a scene lists root nodes only)");
      }
    }
  }
  if (const json* s = member(root, "scene")) index_into(c, *s, "/scene", scenes, "/scenes");
}

// ------------------------------------------------------------ conversion ----

struct Mat4 {  // row-major 4x4 (affine)
  double m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
  Mat4 operator*(const Mat4& b) const {
    Mat4 r;
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 4; ++k) {
        double s = 0;
        for (int j = 0; j < 4; ++j) s += m[i][j] * b.m[j][k];
        r.m[i][k] = s;
      }
    return r;
  }
  Affine affine() const {
    Affine a;
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 4; ++k) a.m[i][k] = float(m[i][k]);
    return a;
  }
  double det3() const {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  }
};

Mat4 trs_matrix(const double t[3], const double q[4], const double s[3]);

Mat4 local_matrix(const json& n) {
  Mat4 r;
  if (const json* mj = member(n, "matrix")) {  // column-major in glTF
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) r.m[row][col] = (*mj)[col * 4 + row].get<double>();
    return r;
  }
  double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
  if (const json* j = member(n, "translation")) for (int i = 0; i < 3; ++i) t[i] = (*j)[i].get<double>();
  if (const json* j = member(n, "rotation")) for (int i = 0; i < 4; ++i) q[i] = (*j)[i].get<double>();
  if (const json* j = member(n, "scale")) for (int i = 0; i < 3; ++i) s[i] = (*j)[i].get<double>();
  return trs_matrix(t, q, s);
}

// T * R * S from a translation, a unit quaternion (x, y, z, w; normalized here) and a scale.
Mat4 trs_matrix(const double t[3], const double q[4], const double s[3]) {
  Mat4 r;
  double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  double x = q[0] / len, y = q[1] / len, z = q[2] / len, w = q[3] / len;
  double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                    {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                    {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
  for (int i = 0; i < 3; ++i) {  // T * R * S
    for (int k = 0; k < 3; ++k) r.m[i][k] = R[i][k] * s[k];
    r.m[i][3] = t[i];
  }
  return r;
}

// Image loader callback for tinygltf: keep the encoded bytes (decoded later,
// once per image, by load_texture_from_memory).
bool keep_encoded_image(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                        const unsigned char* bytes, int size, void*) {
  image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

struct TexKey {
  size_t image;
  bool srgb, nearest;
  TexWrap wrap_u, wrap_v;
  float ox, oy, sx, sy, rot;
  bool operator<(const TexKey& o) const {
    return std::tie(image, srgb, nearest, wrap_u, wrap_v, ox, oy, sx, sy, rot) <
           std::tie(o.image, o.srgb, o.nearest, o.wrap_u, o.wrap_v, o.ox, o.oy, o.sx, o.sy, o.rot);
  }
};

class Converter {
 public:
  Converter(const Ctx& c, const json& root, tinygltf::Model& model, SceneDesc& d, int64_t variant)
      : c_(c), root_(root), model_(model), d_(d), variant_(variant) {}

  void run();

 private:
  const Ctx& c_;
  const json& root_;
  tinygltf::Model& model_;
  SceneDesc& d_;
  const int64_t variant_;  // the KHR_materials_variants variant chosen (-1: none)
  std::map<size_t, int> material_of_;  // glTF material -> caustica material
  std::map<int, int> vertex_colored_;  // caustica material -> its copy with kVertexColor (primitives with COLOR_0)
  struct MatExtra {
    RGB emission{0.f};
    int emission_texture = -1;
    bool two_sided = false;
    bool unlit = false;  // KHR_materials_unlit: the emission is the base colour
  };
  std::map<size_t, MatExtra> mat_extra_;
  // Texture coordinate sets: those the textures of the material being converted read (texCoord, or its
  // KHR_texture_transform override), and the one each converted glTF material's primitives take as their UVs.
  std::set<int64_t> uv_sets_;
  std::map<size_t, int64_t> uv_set_of_;
  std::map<std::pair<size_t, size_t>, int> mesh_of_;  // (mesh, primitive) -> meshes index (-1: skipped)
  std::map<std::pair<bool, size_t>, int> image_tex_;  // (srgb, image) -> decoded texture
  std::map<TexKey, int> tex_of_;
  int default_material_ = -1;
  // Warning counters (reported once each at the end).
  size_t skipped_points_lines_ = 0, nan_triangles_ = 0, degenerate_triangles_ = 0, bad_index_triangles_ = 0,
         singular_instances_ = 0, zero_area_lights_ = 0, skinned_ = 0;
  std::set<std::string> once_;

  void warn_once(const std::string& w) {
    if (once_.insert(w).second) d_.warnings.push_back(c_.file + ": " + w);
  }

  // Reads an accessor as floats (count * ncomp), applying normalization and sparse substitution.
  std::vector<float> read_floats(size_t ai, const std::string& use_path, const std::vector<std::string>& types,
                                 size_t& count, int& ncomp);
  std::vector<uint32_t> read_indices(size_t ai, const std::string& use_path);
  int accessor_components(size_t ai, const std::string& use_path, const std::vector<std::string>& types);
  // KHR_draco_mesh_compression: a primitive's Draco data, decoded, and one attribute of it as floats.
  std::unique_ptr<draco::Mesh> decode_draco(const json& ext, const std::string& ext_path);
  std::vector<float> draco_floats(const draco::Mesh& mesh, const json& ext, const std::string& ext_path,
                                  const std::string& name, size_t ai, const std::string& use_path,
                                  const std::vector<std::string>& types, size_t& count, int& ncomp);
  const unsigned char* view_bytes(size_t view, int64_t& len);
  // EXT_meshopt_compression: a view's data, decoded once (meshoptimizer's decoders and filters).
  std::map<size_t, std::vector<unsigned char>> meshopt_views_;
  const unsigned char* meshopt_view(size_t view, const json& ext, int64_t& len);

  int texture(const json& info, const std::string& path, bool srgb);
  DerivedTextures derived_;  // the values a material slot reads from another channel
  template <class F>
  int derived_texture(int t, const std::string& suffix, F&& f) {
    return derived_.get(d_, t, suffix, std::forward<F>(f));
  }
  // Texels for a slot that reads red from a glTF texture's alpha: grey of that alpha, opaque.
  static void alpha_to_red(float* px) { px[0] = px[1] = px[2] = px[3], px[3] = 1.f; }
  static void green_to_red(float* px) { px[0] = px[2] = px[1], px[3] = 1.f; }
  int material(size_t i);
  const json* primitive_material(const json& prim) const;
  int mesh(size_t mi, size_t pi);
  // visible: KHR_node_visibility's, false below a hidden node (its meshes and lights are left out, its cameras
  // are not).
  void visit(size_t node, const Mat4& parent_world, bool visible);
  std::vector<std::pair<size_t, CameraDesc>> cams_;  // (camera index, camera) in traversal order
};

const unsigned char* Converter::view_bytes(size_t view, int64_t& len) {
  const json& v = root_["bufferViews"][view];
  if (const json* ex = member(v, "extensions"))
    if (const json* mo = member(*ex, "EXT_meshopt_compression")) return meshopt_view(view, *mo, len);
  size_t b = v["buffer"].get<size_t>();
  int64_t off = member(v, "byteOffset") ? v["byteOffset"].get<int64_t>() : 0;
  len = v["byteLength"].get<int64_t>();
  const std::vector<unsigned char>& data = model_.buffers.at(b).data;
  if (size_t(off + len) > data.size())
    c_.fail(P("/bufferViews", view), "exceeds the data of buffer " + std::to_string(b) + " (" +
                                         std::to_string(data.size()) + " bytes)");
  return data.data() + off;
}

const unsigned char* Converter::meshopt_view(size_t view, const json& ext, int64_t& len) {
  const size_t count = ext["count"].get<size_t>(), stride = ext["byteStride"].get<size_t>();
  len = int64_t(count * stride);
  auto hit = meshopt_views_.find(view);
  if (hit != meshopt_views_.end()) return hit->second.data();
  const std::string mp = P(P(P("/bufferViews", view), "extensions"), "EXT_meshopt_compression");
  const size_t b = ext["buffer"].get<size_t>();
  const size_t off = member(ext, "byteOffset") ? ext["byteOffset"].get<size_t>() : 0;
  const size_t n = ext["byteLength"].get<size_t>();
  const std::vector<unsigned char>& data = model_.buffers.at(b).data;
  if (off + n > data.size())
    c_.fail(mp, "exceeds the data of buffer " + std::to_string(b) + " (" + std::to_string(data.size()) + " bytes)");
  std::vector<unsigned char> out(count * stride);
  const std::string mode = ext["mode"].get<std::string>();
  const std::string filter = member(ext, "filter") ? ext["filter"].get<std::string>() : "NONE";
  const unsigned char* src = data.data() + off;
  const int rc = mode == "ATTRIBUTES" ? meshopt_decodeVertexBuffer(out.data(), count, stride, src, n)
                 : mode == "TRIANGLES" ? meshopt_decodeIndexBuffer(out.data(), count, stride, src, n)
                                       : meshopt_decodeIndexSequence(out.data(), count, stride, src, n);
  if (rc != 0) c_.fail(mp, "cannot decode the compressed " + mode + " (meshoptimizer error " + std::to_string(rc) + ")");
  if (filter == "OCTAHEDRAL") meshopt_decodeFilterOct(out.data(), count, stride);
  else if (filter == "QUATERNION") meshopt_decodeFilterQuat(out.data(), count, stride);
  else if (filter == "EXPONENTIAL") meshopt_decodeFilterExp(out.data(), count, stride);
  return (meshopt_views_[view] = std::move(out)).data();
}

float read_component(const unsigned char* p, int ct, bool normalized) {
  switch (ct) {
    case kFloat: { float f; std::memcpy(&f, p, 4); return f; }
    case kByte: { int8_t v; std::memcpy(&v, p, 1); return normalized ? std::max(v / 127.f, -1.f) : float(v); }
    case kUByte: return normalized ? p[0] / 255.f : float(p[0]);
    case kShort: { int16_t v; std::memcpy(&v, p, 2); return normalized ? std::max(v / 32767.f, -1.f) : float(v); }
    case kUShort: { uint16_t v; std::memcpy(&v, p, 2); return normalized ? v / 65535.f : float(v); }
    case kUInt: { uint32_t v; std::memcpy(&v, p, 4); return float(v); }
  }
  return 0.f;
}
uint32_t read_uint(const unsigned char* p, int ct) {
  if (ct == kUByte) return p[0];
  if (ct == kUShort) { uint16_t v; std::memcpy(&v, p, 2); return v; }
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

// The number of components of accessor ai, whose type must be one of `types`.
int Converter::accessor_components(size_t ai, const std::string& use_path, const std::vector<std::string>& types) {
  const std::string type = root_["accessors"][ai]["type"].get<std::string>();
  if (std::find(types.begin(), types.end(), type) == types.end()) {
    std::string list;
    for (const std::string& t : types) list += (list.empty() ? "" : " or ") + t;
    c_.fail(use_path, "expected an accessor of type " + list + ", got accessor " + std::to_string(ai) + " of type " + type);
  }
  return type_components(type);
}

std::vector<float> Converter::read_floats(size_t ai, const std::string& use_path, const std::vector<std::string>& types,
                                          size_t& count, int& ncomp) {
  const json& a = root_["accessors"][ai];
  ncomp = accessor_components(ai, use_path, types);
  int ct = a["componentType"].get<int>();
  bool normalized = member(a, "normalized") && a["normalized"].is_boolean() && a["normalized"].get<bool>();
  count = a["count"].get<size_t>();
  int elem = ncomp * component_size(ct);
  std::vector<float> out(count * ncomp, 0.f);
  if (const json* bv = member(a, "bufferView")) {
    size_t view = bv->get<size_t>();
    int64_t len;
    const unsigned char* base = view_bytes(view, len);
    int64_t off = member(a, "byteOffset") ? a["byteOffset"].get<int64_t>() : 0;
    int64_t stride = elem;
    if (const json* s = member(root_["bufferViews"][view], "byteStride")) stride = std::max<int64_t>(elem, s->get<int64_t>());
    for (size_t i = 0; i < count; ++i)
      for (int k = 0; k < ncomp; ++k)
        out[i * ncomp + k] = read_component(base + off + stride * int64_t(i) + k * component_size(ct), ct, normalized);
  }
  if (const json* sp = member(a, "sparse")) {
    const json& ind = (*sp)["indices"];
    const json& val = (*sp)["values"];
    size_t sc = (*sp)["count"].get<size_t>();
    int ict = ind["componentType"].get<int>();
    int64_t ilen, vlen;
    const unsigned char* ib = view_bytes(ind["bufferView"].get<size_t>(), ilen) +
                              (member(ind, "byteOffset") ? ind["byteOffset"].get<int64_t>() : 0);
    const unsigned char* vb = view_bytes(val["bufferView"].get<size_t>(), vlen) +
                              (member(val, "byteOffset") ? val["byteOffset"].get<int64_t>() : 0);
    for (size_t s = 0; s < sc; ++s) {
      uint32_t idx = read_uint(ib + s * component_size(ict), ict);
      if (idx >= count)
        c_.fail(P(P("/accessors", ai), "sparse"), "sparse index " + std::to_string(idx) + " out of range (the accessor has " +
                                                      std::to_string(count) + " elements)");
      for (int k = 0; k < ncomp; ++k)
        out[idx * ncomp + k] = read_component(vb + s * elem + k * component_size(ct), ct, normalized);
    }
  }
  return out;
}

std::vector<uint32_t> Converter::read_indices(size_t ai, const std::string& use_path) {
  const json& a = root_["accessors"][ai];
  int ct = a["componentType"].get<int>();
  if (a["type"].get<std::string>() != "SCALAR" || (ct != kUByte && ct != kUShort && ct != kUInt))
    c_.fail(use_path, "expected an accessor of unsigned byte, short or int scalars (5121, 5123, 5125), got accessor " +
                          std::to_string(ai) + " of " + a["type"].get<std::string>() + " " + std::to_string(ct));
  size_t count = a["count"].get<size_t>();
  std::vector<uint32_t> out(count, 0);
  if (const json* bv = member(a, "bufferView")) {
    size_t view = bv->get<size_t>();
    int64_t len;
    const unsigned char* base = view_bytes(view, len) + (member(a, "byteOffset") ? a["byteOffset"].get<int64_t>() : 0);
    int64_t stride = component_size(ct);
    if (const json* s = member(root_["bufferViews"][view], "byteStride")) stride = std::max<int64_t>(stride, s->get<int64_t>());
    for (size_t i = 0; i < count; ++i) out[i] = read_uint(base + stride * int64_t(i), ct);
  }
  if (member(a, "sparse")) {  // rare for indices; reuse the float path (exact below 2^24)
    size_t n;
    int nc;
    std::vector<float> f = read_floats(ai, use_path, {"SCALAR"}, n, nc);
    for (size_t i = 0; i < count; ++i) out[i] = uint32_t(f[i]);
  }
  return out;
}

std::unique_ptr<draco::Mesh> Converter::decode_draco(const json& ext, const std::string& ext_path) {
  int64_t len;
  const unsigned char* bytes = view_bytes(ext["bufferView"].get<size_t>(), len);
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes), size_t(len));
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) c_.fail(ext_path, "cannot decode the Draco data: " + decoded.status().error_msg_string());
  std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  if (!mesh) c_.fail(ext_path, "cannot decode the Draco data: not a mesh");
  return mesh;
}

// The glTF accessor still gives the attribute's type and count (KHR_draco_mesh_compression); the values are
// the Draco attribute's, converted to floats (normalized integers to [0, 1] or [-1, 1] by Draco).
std::vector<float> Converter::draco_floats(const draco::Mesh& mesh, const json& ext, const std::string& ext_path,
                                           const std::string& name, size_t ai, const std::string& use_path,
                                           const std::vector<std::string>& types, size_t& count, int& ncomp) {
  ncomp = accessor_components(ai, use_path, types);
  const std::string ap = P(P(ext_path, "attributes"), name);
  const int64_t id = ext["attributes"][name].get<int64_t>();
  const draco::PointAttribute* att = mesh.GetAttributeByUniqueId(uint32_t(id));
  if (!att) c_.fail(ap, "the Draco data has no attribute with id " + std::to_string(id));
  count = mesh.num_points();
  const size_t declared = root_["accessors"][ai]["count"].get<size_t>();
  if (declared != count)
    c_.fail(use_path, "accessor " + std::to_string(ai) + " has count " + std::to_string(declared) + ", the Draco data " +
                          std::to_string(count) + " points");
  if (att->num_components() < ncomp)
    c_.fail(ap, "the Draco attribute has " + std::to_string(int(att->num_components())) + " components, accessor " +
                    std::to_string(ai) + " " + std::to_string(ncomp));
  std::vector<float> out(count * size_t(ncomp));
  for (size_t i = 0; i < count; ++i)
    if (!att->ConvertValue<float>(att->mapped_index(draco::PointIndex(uint32_t(i))), int8_t(ncomp), &out[i * size_t(ncomp)]))
      c_.fail(ap, "the Draco attribute's values cannot be read as floats");
  return out;
}

int Converter::texture(const json& info, const std::string& path, bool srgb) {
  size_t ti = info["index"].get<size_t>();
  const json& t = root_["textures"][ti];
  int64_t uv_set = member(info, "texCoord") ? info["texCoord"].get<int64_t>() : 0;
  if (const json* ex = member(info, "extensions"))
    if (const json* tt = member(*ex, "KHR_texture_transform"))
      if (const json* tc = tt->is_object() ? member(*tt, "texCoord") : nullptr) {
        const std::string tp = P(P(P(path, "extensions"), "KHR_texture_transform"), "texCoord");
        uv_set = integer(c_, *tc, tp);
        if (uv_set < 0) c_.fail(tp, "expected a non-negative integer");
      }
  // EXT_texture_webp: its WebP image in place of `source` (a PNG or JPEG fallback, if there is one).
  const json* src = member(t, "source");
  if (const json* ex = member(t, "extensions"))
    if (const json* w = member(*ex, "EXT_texture_webp")) src = member(*w, "source");
  if (!src) {
    warn_once(P("/textures", ti) + ": no image source; the texture is ignored");
    return -1;
  }
  uv_sets_.insert(uv_set);
  size_t ii = src->get<size_t>();
  // Decode the image once per colour space.
  auto key = std::make_pair(srgb, ii);
  auto hit = image_tex_.find(key);
  int base;
  if (hit != image_tex_.end()) {
    base = hit->second;
  } else {
    const json& im = root_["images"][ii];
    const tinygltf::Image& gi = model_.images.at(ii);
    std::string uri = string_or(c_, im, "uri", P("/images", ii), "");
    std::string name;
    if (!member(im, "bufferView") && !is_data_uri(uri)) {
      fs::path f = c_.base_dir / url_decode(uri);
      name = f.string();
      std::error_code ec;
      if (!fs::is_regular_file(f, ec)) c_.fail(P(P("/images", ii), "uri"), "image file '" + name + "' does not exist");
    } else {
      name = c_.file + "#/images/" + std::to_string(ii);
    }
    if (gi.image.empty()) c_.fail(P("/images", ii), "no image data could be read");
    base = load_texture_from_memory(d_, name, gi.image.data(), gi.image.size(), srgb, c_.file + ": " + P("/images", ii));
    image_tex_[key] = base;
  }
  // Sampler and KHR_texture_transform: a copy of the decoded texture when they differ from the defaults.
  TexKey k{ii, srgb, false, TexWrap::kRepeat, TexWrap::kRepeat, 0.f, 0.f, 1.f, 1.f, 0.f};
  if (const json* s = member(t, "sampler")) {
    const json& sm = root_["samplers"][s->get<size_t>()];
    std::string sp = P("/samplers", s->get<size_t>());
    auto wrap_of = [&](const char* key) {
      int64_t w = member(sm, key) ? integer(c_, sm[key], P(sp, key)) : 10497;
      if (w == 10497) return TexWrap::kRepeat;
      if (w == 33071) return TexWrap::kClamp;
      if (w == 33648) return TexWrap::kMirror;
      c_.fail(P(sp, key), "unknown wrap mode " + std::to_string(w) + " (expected 10497, 33071 or 33648)");
    };
    k.wrap_u = wrap_of("wrapS");  // along u; wrapT along v (caustica's v = 1 - glTF's: the same modes)
    k.wrap_v = wrap_of("wrapT");
    if (const json* mf = member(sm, "magFilter")) k.nearest = integer(c_, *mf, P(sp, "magFilter")) == 9728;
  }
  if (const json* ex = member(info, "extensions")) {
    if (const json* tt = member(*ex, "KHR_texture_transform")) {
      std::string tp = P(P(path, "extensions"), "KHR_texture_transform");
      object_at(c_, *tt, tp);
      std::vector<double> off = member(*tt, "offset") ? numbers(c_, (*tt)["offset"], P(tp, "offset"), 2) : std::vector<double>{0, 0};
      std::vector<double> sc = member(*tt, "scale") ? numbers(c_, (*tt)["scale"], P(tp, "scale"), 2) : std::vector<double>{1, 1};
      double rot = number_or(c_, *tt, "rotation", tp, 0.0);
      // glTF applies uv' = T R(rot) S uv with v pointing down the image; caustica's v'
      // = 1 - v points up. Conjugating with F(u, v) = (u, 1 - v) gives the same
      // form in caustica's uv: rotation -rot, the same scale, and the offset below.
      double s = std::sin(rot), co = std::cos(rot);
      k.sx = float(sc[0]);
      k.sy = float(sc[1]);
      k.rot = float(-rot);
      k.ox = float(off[0] - sc[1] * s);
      k.oy = float(1.0 - off[1] - sc[1] * co);
    }
  }
  if (!k.nearest && k.wrap_u == TexWrap::kRepeat && k.wrap_v == TexWrap::kRepeat && k.ox == 0.f && k.oy == 0.f && k.sx == 1.f && k.sy == 1.f && k.rot == 0.f)
    return base;
  auto it = tex_of_.find(k);
  if (it != tex_of_.end()) return it->second;
  TextureDesc copy = d_.textures[size_t(base)];
  std::ostringstream nm;
  nm << copy.name << "#sampler" << int(k.wrap_u) << int(k.wrap_v) << (k.nearest ? "n" : "l") << "#" << k.ox << "," << k.oy << "," << k.sx
     << "," << k.sy << "," << k.rot;
  copy.name = nm.str();
  copy.wrap_u = k.wrap_u;
  copy.wrap_v = k.wrap_v;
  copy.nearest = k.nearest;
  copy.uv_offset = Vec2f(k.ox, k.oy);
  copy.uv_scale = Vec2f(k.sx, k.sy);
  copy.uv_rotation = k.rot;
  d_.textures.push_back(std::move(copy));
  int idx = int(d_.textures.size()) - 1;
  tex_of_[k] = idx;
  return idx;
}

RGB nonneg_color(const Ctx& c, const json& j, const std::string& path, size_t n) {
  std::vector<double> v = numbers(c, j, path, n);
  for (size_t i = 0; i < n; ++i)
    if (v[i] < 0.0) c.fail(path, "expected non-negative colour values");
  return RGB(float(v[0]), float(v[1]), float(v[2]));
}
float unit_interval(const Ctx& c, const json& o, const char* key, const std::string& path, float def) {
  double v = number_or(c, o, key, path, def);
  if (v < 0.0 || v > 1.0) c.fail(P(path, key), "expected a number in [0, 1]");
  return float(v);
}

// A primitive's material: the chosen variant's where one of the primitive's KHR_materials_variants mappings
// lists it, else the primitive's own `material` (the extension's fallback to plain glTF), or none.
const json* Converter::primitive_material(const json& prim) const {
  const json* ex = variant_ >= 0 ? member(prim, "extensions") : nullptr;
  if (const json* mv = ex ? member(*ex, "KHR_materials_variants") : nullptr)
    for (const json& m : mv->at("mappings"))
      for (const json& v : m.at("variants"))
        if (v.get<int64_t>() == variant_) return &m.at("material");
  return member(prim, "material");
}

int Converter::material(size_t i) {
  auto hit = material_of_.find(i);
  if (hit != material_of_.end()) return hit->second;
  uv_sets_.clear();
  std::string p = P("/materials", i);
  const json& m = root_["materials"][i];
  const json empty = json::object();
  const json* pbr = member(m, "pbrMetallicRoughness");
  const json& pb = pbr ? *pbr : empty;
  std::string pp = P(p, "pbrMetallicRoughness");
  RGB base(1.f);
  float base_alpha = 1.f;
  if (const json* bc = member(pb, "baseColorFactor")) {
    base = nonneg_color(c_, *bc, P(pp, "baseColorFactor"), 4);
    base_alpha = float((*bc)[3].get<double>());
    if (base_alpha > 1.f) c_.fail(P(pp, "baseColorFactor/3"), "expected an alpha in [0, 1]");
  }
  float metallic = unit_interval(c_, pb, "metallicFactor", pp, 1.f);
  float roughness = unit_interval(c_, pb, "roughnessFactor", pp, 1.f);
  float transmission = 0.f, ior = 1.5f, aniso_strength = 0.f, aniso_rotation = 0.f;
  const json* aniso_texture = nullptr;
  std::string aniso_texture_path;
  RGB absorption(0.f);
  const json *sg_diffuse_texture = nullptr, *sg_texture = nullptr;  // KHR_materials_pbrSpecularGlossiness
  std::string sg_path;
  float glossiness = -1.f;  // >= 0: the material is specular-glossiness, converted below
  RGB sg_specular(1.f);     // its specularFactor: F0, the reflectance at normal incidence
  MatExtra ex;
  if (const json* e = member(m, "emissiveFactor")) ex.emission = nonneg_color(c_, *e, P(p, "emissiveFactor"), 3);
  if (const json* exts = member(m, "extensions")) {
    std::string ep = P(p, "extensions");
    if (const json* t = member(*exts, "KHR_materials_transmission")) {
      transmission = unit_interval(c_, *t, "transmissionFactor", P(ep, "KHR_materials_transmission"), 0.f);
    }
    if (const json* t = member(*exts, "KHR_materials_ior")) {
      object_at(c_, *t, P(ep, "KHR_materials_ior"));
      double v = number_or(c_, *t, "ior", P(ep, "KHR_materials_ior"), 1.5);
      if (v < 1.0) c_.fail(P(P(ep, "KHR_materials_ior"), "ior"), "expected an index of refraction >= 1");
      ior = float(v);
    }
    if (const json* t = member(*exts, "KHR_materials_volume")) {
      std::string vp = P(ep, "KHR_materials_volume");
      object_at(c_, *t, vp);
      double thickness = number_or(c_, *t, "thicknessFactor", vp, 0.0);
      RGB att(1.f);
      if (const json* a = member(*t, "attenuationColor")) att = nonneg_color(c_, *a, P(vp, "attenuationColor"), 3);
      double dist = kInf;
      if (const json* a = member(*t, "attenuationDistance")) {
        dist = number(c_, *a, P(vp, "attenuationDistance"));
        if (!(dist > 0.0)) c_.fail(P(vp, "attenuationDistance"), "expected a positive distance");
      }
      if (thickness > 0.0 && std::isfinite(dist)) {
        for (int k = 0; k < 3; ++k) {
          double col = std::clamp(double(att[k]), 1e-6, 1.0);  // a zero colour absorbs everything: clamp
          absorption[k] = float(-std::log(col) / dist);
        }
      }
    }
    if (const json* t = member(*exts, "KHR_materials_anisotropy")) {
      // The roughness along the direction (dp/du turned by anisotropyRotation towards dp/dv) becomes
      // mix(alpha, 1, strength^2), across it alpha stays (the extension's definition); scene/shading.h.
      std::string ap = P(ep, "KHR_materials_anisotropy");
      object_at(c_, *t, ap);
      aniso_strength = unit_interval(c_, *t, "anisotropyStrength", ap, 0.f);
      double rot = number_or(c_, *t, "anisotropyRotation", ap, 0.0);
      if (!std::isfinite(rot)) c_.fail(P(ap, "anisotropyRotation"), "expected a finite angle in radians");
      aniso_rotation = float(rot);
      if (const json* at = member(*t, "anisotropyTexture")) {
        aniso_texture = at;
        aniso_texture_path = P(ap, "anisotropyTexture");
      }
    }
    if (const json* t = member(*exts, "KHR_materials_pbrSpecularGlossiness")) {
      // The archived specular-glossiness model, which takes the place of pbrMetallicRoughness (its fallback),
      // as a dielectric metallic-roughness material with KHR_materials_specular (below, after the material
      // exists): the diffuse colour as base colour, metallic 0, roughness = 1 - glossiness, and the specular
      // colour as the layer's reflectance at normal incidence. This is how that extension's authors meant
      // specular-glossiness to be carried over (gltf-transform's metalRough does the same with IOR 1000);
      // there is no metallic to solve for.
      sg_path = P(ep, "KHR_materials_pbrSpecularGlossiness");
      object_at(c_, *t, sg_path);
      for (const char* other : {"KHR_materials_specular", "KHR_materials_ior"})
        if (member(*exts, other))
          c_.fail(P(ep, other), std::string("must not be used with KHR_materials_pbrSpecularGlossiness (which sets "
                                            "the specular colour itself)"));
      RGB diffuse(1.f);
      if (const json* d = member(*t, "diffuseFactor")) {
        diffuse = nonneg_color(c_, *d, P(sg_path, "diffuseFactor"), 4);
        base_alpha = float((*d)[3].get<double>());
        if (base_alpha > 1.f) c_.fail(P(sg_path, "diffuseFactor/3"), "expected an alpha in [0, 1]");
      }
      if (const json* s = member(*t, "specularFactor")) sg_specular = nonneg_color(c_, *s, P(sg_path, "specularFactor"), 3);
      glossiness = unit_interval(c_, *t, "glossinessFactor", sg_path, 1.f);
      base = diffuse;
      metallic = 0.f;
      roughness = 1.f - glossiness;
      sg_diffuse_texture = member(*t, "diffuseTexture");
      sg_texture = member(*t, "specularGlossinessTexture");
    }
    if (const json* t = member(*exts, "KHR_materials_emissive_strength")) {
      std::string sp = P(ep, "KHR_materials_emissive_strength");
      object_at(c_, *t, sp);
      double s = number_or(c_, *t, "emissiveStrength", sp, 1.0);
      if (s < 0.0) c_.fail(P(sp, "emissiveStrength"), "expected a non-negative number");
      ex.emission = ex.emission * float(s);
    }
  }
  Material mat = make_metallic_roughness(base, metallic, roughness, transmission, ior);
  mat.absorption = absorption;
  if (aniso_strength > 0.f) {
    const float a = roughness * roughness, s2 = aniso_strength * aniso_strength;
    set_alpha(mat, a * (1.f - s2) + s2, a);
    if (mat.alpha_x != mat.alpha_y) mat.aniso_rotation = aniso_rotation;
    // The texture's RG turn the direction and its B scales the strength (material.h, tex_aniso); with
    // strength 0 there is nothing for it to scale.
    if (aniso_texture && mat.alpha_x != mat.alpha_y) mat.tex_aniso = texture(*aniso_texture, aniso_texture_path, false);
  }
  // The layers' extensions (material/metallic_roughness.h), read once the material exists: the extension's
  // object (or null) and its JSON path.
  const json* const exts = member(m, "extensions");
  auto extension = [&](const char* name, std::string& path) -> const json* {
    path = P(P(p, "extensions"), name);
    return exts ? member(*exts, name) : nullptr;
  };
  std::string cp, sp;
  if (const json* clearcoat = extension("KHR_materials_clearcoat", cp)) {
    // A GGX coat of IOR 1.5 (material/metallic_roughness.h): clearcoatFactor times the clearcoatTexture's R,
    // roughness clearcoatRoughnessFactor times the clearcoatRoughnessTexture's G (alpha = roughness^2), its
    // normal the surface's (not the normalTexture's) or clearcoatNormalTexture's.
    const json& t = *clearcoat;
    mat.clearcoat = unit_interval(c_, t, "clearcoatFactor", cp, 0.f);
    const float rough = unit_interval(c_, t, "clearcoatRoughnessFactor", cp, 0.f);
    mat.clearcoat_alpha = rough * rough;
    if (mat.clearcoat > 0.f) {
      if (const json* tx = member(t, "clearcoatTexture")) mat.tex_clearcoat = texture(*tx, P(cp, "clearcoatTexture"), false);
      if (const json* tx = member(t, "clearcoatRoughnessTexture"))
        mat.tex_clearcoat_roughness = texture(*tx, P(cp, "clearcoatRoughnessTexture"), false);
      if (const json* tx = member(t, "clearcoatNormalTexture")) {  // a normal map for the coat alone
        mat.tex_clearcoat_normal = texture(*tx, P(cp, "clearcoatNormalTexture"), false);
        mat.clearcoat_normal_scale = float(number_or(c_, *tx, "scale", P(cp, "clearcoatNormalTexture"), 1.0));
      }
    }
  }
  if (const json* tr = extension("KHR_materials_transmission", sp)) {  // transmissionTexture: its red channel
    if (const json* tx = member(*tr, "transmissionTexture"); tx && mat.transmission_weight > 0.f)
      mat.tex_transmission = texture(*tx, P(sp, "transmissionTexture"), false);
  }
  if (const json* specular = extension("KHR_materials_specular", sp)) {
    // The dielectric's specular weight specularFactor times the specularTexture's alpha (moved to a grey copy:
    // the weight slot reads red, which a JSON export's RGB images keep), its colour
    // specularColorFactor (may exceed 1; the reflectance at normal incidence is capped at 1) times the
    // specularColorTexture (sRGB); material/metallic_roughness.h, mr_dielectric_fresnel.
    const json& t = *specular;
    mat.specular_weight = unit_interval(c_, t, "specularFactor", sp, 1.f);
    if (const json* f = member(t, "specularColorFactor")) mat.specular = nonneg_color(c_, *f, P(sp, "specularColorFactor"), 3);
    if (const json* tx = member(t, "specularTexture")) {
      const int ti = texture(*tx, P(sp, "specularTexture"), false);
      if (ti >= 0) mat.tex_specular = derived_texture(ti, "#red-from-alpha", alpha_to_red);
    }
    if (const json* tx = member(t, "specularColorTexture"))
      mat.tex_specular_color = texture(*tx, P(sp, "specularColorTexture"), true);
  }
  if (const json* dt = extension("KHR_materials_diffuse_transmission", sp)) {
    // The diffuse base's share dt = diffuseTransmissionFactor times diffuseTransmissionTexture's alpha (moved to
    // a grey copy's red), transmitted as Lambertian light of colour diffuseTransmissionColorFactor times
    // diffuseTransmissionColorTexture (sRGB); material/metallic_roughness.h.
    const json& t = *dt;
    mat.diffuse_transmission = unit_interval(c_, t, "diffuseTransmissionFactor", sp, 0.f);
    if (const json* f = member(t, "diffuseTransmissionColorFactor"))
      mat.transmission = nonneg_color(c_, *f, P(sp, "diffuseTransmissionColorFactor"), 3);
    if (max_component(mat.transmission) > 1.f)
      c_.fail(P(sp, "diffuseTransmissionColorFactor"), "expected colour values in [0, 1]");
    if (mat.diffuse_transmission > 0.f) {
      if (const json* tx = member(t, "diffuseTransmissionTexture")) {
        const int ti = texture(*tx, P(sp, "diffuseTransmissionTexture"), false);
        if (ti >= 0) mat.tex_diffuse_transmission = derived_texture(ti, "#red-from-alpha", alpha_to_red);
      }
      if (const json* tx = member(t, "diffuseTransmissionColorTexture"))
        mat.tex_diffuse_transmission_color = texture(*tx, P(sp, "diffuseTransmissionColorTexture"), true);
    }
  }
  if (const json* sheen = extension("KHR_materials_sheen", sp)) {
    // The sheen colour sheenColorFactor times sheenColorTexture (sRGB), its roughness sheenRoughnessFactor
    // times sheenRoughnessTexture's alpha (moved to a grey copy's red); material/metallic_roughness.h.
    const json& t = *sheen;
    if (const json* f = member(t, "sheenColorFactor")) mat.sheen_color = nonneg_color(c_, *f, P(sp, "sheenColorFactor"), 3);
    if (max_component(mat.sheen_color) > 1.f) c_.fail(P(sp, "sheenColorFactor"), "expected colour values in [0, 1]");
    mat.sheen_roughness = unit_interval(c_, t, "sheenRoughnessFactor", sp, 0.f);
    if (max_component(mat.sheen_color) > 0.f) {
      if (const json* tx = member(t, "sheenColorTexture")) mat.tex_sheen_color = texture(*tx, P(sp, "sheenColorTexture"), true);
      if (const json* tx = member(t, "sheenRoughnessTexture")) {
        const int ti = texture(*tx, P(sp, "sheenRoughnessTexture"), false);
        if (ti >= 0) mat.tex_sheen_roughness = derived_texture(ti, "#red-from-alpha", alpha_to_red);
      }
    }
  }
  if (const json* irid = extension("KHR_materials_iridescence", sp)) {
    // A thin film (material/thin_film.h): its weight iridescenceFactor times iridescenceTexture's red, its IOR,
    // and its thickness from iridescenceThicknessMinimum to _Maximum by iridescenceThicknessTexture's green
    // (moved to a copy's red), or the maximum without that texture.
    const json& t = *irid;
    mat.iridescence = unit_interval(c_, t, "iridescenceFactor", sp, 0.f);
    const double eta = number_or(c_, t, "iridescenceIor", sp, 1.3);
    if (!(eta >= 1.0)) c_.fail(P(sp, "iridescenceIor"), "expected an index of refraction >= 1");
    mat.iridescence_eta = float(eta);
    const double lo = number_or(c_, t, "iridescenceThicknessMinimum", sp, 100.0);
    const double hi = number_or(c_, t, "iridescenceThicknessMaximum", sp, 400.0);
    if (!(lo >= 0.0)) c_.fail(P(sp, "iridescenceThicknessMinimum"), "expected a thickness >= 0 (nm)");
    if (!(hi >= 0.0)) c_.fail(P(sp, "iridescenceThicknessMaximum"), "expected a thickness >= 0 (nm)");
    mat.iridescence_thickness = float(hi);
    if (mat.iridescence > 0.f) {
      if (const json* tx = member(t, "iridescenceTexture")) mat.tex_iridescence = texture(*tx, P(sp, "iridescenceTexture"), false);
      if (const json* tx = member(t, "iridescenceThicknessTexture")) {
        const int ti = texture(*tx, P(sp, "iridescenceThicknessTexture"), false);
        if (ti >= 0) {
          mat.tex_iridescence_thickness = derived_texture(ti, "#red-from-green", green_to_red);
          mat.iridescence_thickness_min = float(lo);
        }
      }
    }
  }
  if (glossiness >= 0.f) {
    // KHR_materials_specular's colour scales the dielectric's F0 (mr_dielectric_fresnel, at weight 1), so
    // specular / F0 gives F0 = specular; the texture's RGB (sRGB) multiplies it.
    mat.specular = sg_specular / fresnel_dielectric(1.f, mat.eta);
    if (sg_diffuse_texture) mat.tex_color = texture(*sg_diffuse_texture, P(sg_path, "diffuseTexture"), true);
    if (sg_texture) {
      mat.tex_specular_color = texture(*sg_texture, P(sg_path, "specularGlossinessTexture"), true);
      // Roughness 1 - glossiness x the texture's alpha, as a metallic-roughness texture (green: the roughness,
      // the factor being 1; blue: 1, keeping the metallic factor).
      const int t = texture(*sg_texture, P(sg_path, "specularGlossinessTexture"), false);
      if (t >= 0) {
        // One copy per glossiness factor (the texels hold 1 - glossiness x alpha).
        mat.tex_roughness = derived_texture(t, "#roughness-from-glossiness-" + std::to_string(glossiness), [&](float* px) {
          px[0] = 0.f, px[1] = 1.f - glossiness * px[3], px[2] = 1.f, px[3] = 1.f;
        });
        mat.alpha_x = mat.alpha_y = 1.f;  // the factor: the texture holds the whole roughness
      }
    }
  } else {
    if (const json* t = member(pb, "baseColorTexture")) mat.tex_color = texture(*t, P(pp, "baseColorTexture"), true);
    if (const json* t = member(pb, "metallicRoughnessTexture"))
      mat.tex_roughness = texture(*t, P(pp, "metallicRoughnessTexture"), false);
  }
  if (const json* t = member(m, "normalTexture")) {
    mat.tex_normal = texture(*t, P(p, "normalTexture"), false);
    mat.normal_scale = float(number_or(c_, *t, "scale", P(p, "normalTexture"), 1.0));
  }
  if (member(m, "emissiveTexture") && max_component(ex.emission) > 0.f)
    ex.emission_texture = texture(m["emissiveTexture"], P(p, "emissiveTexture"), true);
  if (const json* ds = member(m, "doubleSided")) {
    if (!ds->is_boolean()) c_.fail(P(p, "doubleSided"), std::string("expected true or false, got ") + ds->type_name());
    ex.two_sided = ds->get<bool>();
  }
  if (ex.two_sided) mat.flags |= kTwoSided;
  // Opacity (glTF 2.0 Sec. 3.9.4): the base colour's alpha (factor x texture) cuts the surface out. MASK is
  // an alpha test against alphaCutoff; BLEND, meant for compositing in a rasteriser, is stochastic
  // transparency here (scene/opacity.h); OPAQUE ignores alpha.
  std::string mode = string_or(c_, m, "alphaMode", p, "OPAQUE");
  if (mode == "MASK" || mode == "BLEND") {
    mat.opacity = base_alpha;
    mat.tex_opacity = mat.tex_color;  // its alpha channel (linear)
    if (mode == "MASK") {
      double cutoff = number_or(c_, m, "alphaCutoff", p, 0.5);
      if (cutoff < 0.0) c_.fail(P(p, "alphaCutoff"), "expected a number >= 0");
      if (cutoff > 1.0) {  // no alpha reaches it: the surface is absent
        mat.opacity = 0.f;
        mat.tex_opacity = -1;
        cutoff = 1.0;
      }
      mat.opacity_cutoff = float(cutoff);
    }
  } else if (mode != "OPAQUE") {
    c_.fail(P(p, "alphaMode"), "expected OPAQUE, MASK or BLEND, got '" + mode + "'");
  }
  // KHR_materials_unlit: a surface drawn in its base colour whatever the light. Read physically: it reflects
  // nothing and emits its base colour (factor times baseColorTexture, in place of any emissive colour) as
  // radiance, so the camera sees exactly that colour, as a rasteriser draws it, and it lights what it faces
  // (Blender's importer emits too). Cut-outs stay.
  if (exts && member(*exts, "KHR_materials_unlit")) {
    object_at(c_, (*exts)["KHR_materials_unlit"], P(P(p, "extensions"), "KHR_materials_unlit"));
    ex.emission = base;
    ex.emission_texture = mat.tex_color;
    ex.unlit = true;
    Material black = make_diffuse(RGB(0.f), ex.two_sided);
    black.opacity = mat.opacity;
    black.tex_opacity = mat.tex_opacity;
    black.opacity_cutoff = mat.opacity_cutoff;
    mat = black;
  }
  std::string name = string_or(c_, m, "name", p, "");
  int idx = d_.add_material(name.empty() ? "material" + std::to_string(i) : name, mat);
  material_of_[i] = idx;
  mat_extra_[i] = ex;
  // A primitive has one set of UVs here: that of its material's textures; where they read different sets, the
  // lowest of them, with a warning.
  uv_set_of_[i] = uv_sets_.empty() ? 0 : *uv_sets_.begin();
  if (uv_sets_.size() > 1) {
    std::string sets;
    for (int64_t k : uv_sets_) sets += (sets.empty() ? "" : ", ") + std::to_string(k);
    d_.warnings.push_back(c_.file + ": " + p + ": its textures read texture coordinate sets " + sets +
                          "; one set per material is supported: all read TEXCOORD_" + std::to_string(uv_set_of_[i]));
  }
  return idx;
}

int Converter::mesh(size_t mi, size_t pi) {
  auto key = std::make_pair(mi, pi);
  auto hit = mesh_of_.find(key);
  if (hit != mesh_of_.end()) return hit->second;
  std::string p = P(P(P("/meshes", mi), "primitives"), pi);
  const json& pr = root_["meshes"][mi]["primitives"][pi];
  int mode = member(pr, "mode") ? pr["mode"].get<int>() : 4;
  if (mode < 4) {
    ++skipped_points_lines_;
    mesh_of_[key] = -1;
    return -1;
  }
  const json& attrs = pr["attributes"];
  if (!member(attrs, "POSITION")) c_.fail(P(p, "attributes"), "missing POSITION");
  // KHR_draco_mesh_compression: the attributes it lists, and the triangles, come from its Draco data.
  std::unique_ptr<draco::Mesh> draco_mesh;
  const json* draco = nullptr;
  const std::string draco_path = P(P(p, "extensions"), "KHR_draco_mesh_compression");
  if (const json* ex = member(pr, "extensions"))
    if ((draco = member(*ex, "KHR_draco_mesh_compression"))) draco_mesh = decode_draco(*draco, draco_path);
  auto floats = [&](const char* name, const std::vector<std::string>& types, size_t& count, int& comps) {
    const size_t ai = attrs[name].get<size_t>();
    const std::string ap = P(P(p, "attributes"), name);
    if (draco && member((*draco)["attributes"], name))
      return draco_floats(*draco_mesh, *draco, draco_path, name, ai, ap, types, count, comps);
    return read_floats(ai, ap, types, count, comps);
  };
  size_t n;
  int nc;
  std::vector<float> pos = floats("POSITION", {"VEC3"}, n, nc);
  // The UVs: the texture coordinate set the material's textures read (TEXCOORD_0 without a material).
  const json* prim_mat = primitive_material(pr);
  int64_t uv_set = 0;
  if (prim_mat) {
    material(prim_mat->get<size_t>());  // converted first: its textures decide the set
    uv_set = uv_set_of_[prim_mat->get<size_t>()];
  }
  const std::string uv_name = "TEXCOORD_" + std::to_string(uv_set);
  MeshDesc md;
  md.name = string_or(c_, root_["meshes"][mi], "name", P("/meshes", mi), "mesh" + std::to_string(mi));
  md.positions.resize(n);
  for (size_t i = 0; i < n; ++i) md.positions[i] = Vec3f(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]);
  if (member(attrs, "NORMAL")) {
    size_t nn;
    std::vector<float> nor = floats("NORMAL", {"VEC3"}, nn, nc);
    if (nn != n) c_.fail(P(P(p, "attributes"), "NORMAL"), "has " + std::to_string(nn) + " elements, POSITION has " + std::to_string(n));
    md.normals.resize(n);
    bool ok = true;
    for (size_t i = 0; i < n && ok; ++i) {
      Vec3f v(nor[3 * i], nor[3 * i + 1], nor[3 * i + 2]);
      float l = length(v);
      if (!(l > 0.f) || !std::isfinite(l)) ok = false;
      else md.normals[i] = v / l;
    }
    if (!ok) {
      md.normals.clear();
      d_.warnings.push_back(c_.file + ": " + p + ": zero or non-finite normals; using geometric normals");
    }
  }
  if (member(attrs, uv_name.c_str())) {
    size_t nt;
    std::vector<float> uv = floats(uv_name.c_str(), {"VEC2"}, nt, nc);
    if (nt != n) c_.fail(P(P(p, "attributes"), uv_name), "has " + std::to_string(nt) + " elements, POSITION has " + std::to_string(n));
    md.uvs.resize(n);
    bool ok = true;
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(uv[2 * i]) || !std::isfinite(uv[2 * i + 1])) ok = false;
      md.uvs[i] = Vec2f(uv[2 * i], 1.f - uv[2 * i + 1]);  // glTF v points down the image; caustica's up
    }
    if (!ok) {
      md.uvs.clear();
      d_.warnings.push_back(c_.file + ": " + p + ": non-finite texture coordinates; the primitive is untextured");
    }
  }
  // Vertex tangents, for the materials that use a tangent frame (a normal map, anisotropic roughness):
  // TANGENT where the primitive has one (ignored without NORMAL, as glTF 2.0 Sec. 3.7.2.1 says), else
  // generated from the normals and UVs (generate_tangents; the spec asks for MikkTSpace, whose angle
  // weighting it shares but not its splitting of vertices at tangent-space seams).
  bool wants_tangents = false, generate = false;
  if (prim_mat) {
    const Material& mat = d_.materials[size_t(material(prim_mat->get<size_t>()))];
    wants_tangents = mat.tex_normal >= 0 || mat.alpha_x != mat.alpha_y;
  }
  if (wants_tangents && !md.normals.empty() && !md.uvs.empty()) {
    if (member(attrs, "TANGENT")) {
      size_t ng;
      std::vector<float> tg = floats("TANGENT", {"VEC4"}, ng, nc);
      if (ng != n) c_.fail(P(P(p, "attributes"), "TANGENT"), "has " + std::to_string(ng) + " elements, POSITION has " + std::to_string(n));
      md.tangents.resize(n);
      size_t bad = 0;
      for (size_t i = 0; i < n; ++i) {
        Vec3f t(tg[4 * i], tg[4 * i + 1], tg[4 * i + 2]);
        float l = length(t), w = tg[4 * i + 3];
        if (!(l > 0.f) || !std::isfinite(l) || !std::isfinite(w) || w == 0.f) ++bad;  // w = 0: the triangle's dp/du
        else md.tangents[i] = Tangent{t / l, w < 0.f ? -1.f : 1.f};
      }
      if (bad)
        d_.warnings.push_back(c_.file + ": " + p + ": " + std::to_string(bad) +
                              " zero or non-finite tangents; those triangles use their UVs' dp/du");
    } else {
      generate = true;  // once the triangles are known
    }
  }
  // COLOR_0 (glTF 2.0 Sec. 3.7.2.1: linear RGB or RGBA, float or normalized unsigned integers) multiplies the
  // base colour: the primitive's shape gets its material's kVertexColor copy (visit). Its alpha would multiply
  // the base colour's alpha, which caustica does not apply (a warning where it is below 1).
  if (member(attrs, "COLOR_0")) {
    size_t ncol;
    int comps;
    std::vector<float> col = floats("COLOR_0", {"VEC3", "VEC4"}, ncol, comps);
    if (ncol != n) c_.fail(P(P(p, "attributes"), "COLOR_0"), "has " + std::to_string(ncol) + " elements, POSITION has " + std::to_string(n));
    md.colors.resize(n);
    size_t bad = 0;
    bool alpha = false;
    for (size_t i = 0; i < n; ++i) {
      const float* v = &col[size_t(comps) * i];
      RGB c(v[0], v[1], v[2]);
      if (!usable_color(c)) ++bad, c = RGB(1.f);
      md.colors[i] = c;
      alpha |= comps == 4 && v[3] < 1.f;
    }
    if (bad)
      d_.warnings.push_back(c_.file + ": " + p + ": " + std::to_string(bad) +
                            " negative or non-finite vertex colours (COLOR_0); white there");
    if (alpha) warn_once("the alpha of vertex colours (COLOR_0) is not applied; their RGB is");
  }
  if (member(attrs, "JOINTS_0") || member(pr, "targets")) warn_once("skinning and morph targets are not supported; meshes are used in their rest pose");
  std::vector<uint32_t> idx;
  if (draco_mesh) {  // Draco's faces, a triangle list whatever the mode (TRIANGLES or TRIANGLE_STRIP)
    idx.reserve(size_t(draco_mesh->num_faces()) * 3);
    for (uint32_t f = 0; f < draco_mesh->num_faces(); ++f)
      for (draco::PointIndex v : draco_mesh->face(draco::FaceIndex(f))) idx.push_back(v.value());
    mode = 4;
  } else if (const json* ij = member(pr, "indices")) {
    idx = read_indices(ij->get<size_t>(), P(p, "indices"));
  } else {
    idx.resize(n);
    for (size_t i = 0; i < n; ++i) idx[i] = uint32_t(i);
  }
  std::vector<uint32_t> tris;
  if (mode == 4) {
    tris.assign(idx.begin(), idx.end() - idx.size() % 3);
  } else {
    for (size_t i = 2; i < idx.size(); ++i) {
      if (mode == 5) {  // strip: keep the winding of the first triangle
        if (i % 2 == 0) tris.insert(tris.end(), {idx[i - 2], idx[i - 1], idx[i]});
        else tris.insert(tris.end(), {idx[i - 1], idx[i - 2], idx[i]});
      } else {  // fan
        tris.insert(tris.end(), {idx[0], idx[i - 1], idx[i]});
      }
    }
  }
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    uint32_t a = tris[t], b = tris[t + 1], cc = tris[t + 2];
    if (a >= n || b >= n || cc >= n) {
      ++bad_index_triangles_;
      continue;
    }
    Vec3f pa = md.positions[a], pb = md.positions[b], pc = md.positions[cc];
    bool finite = true;
    for (Vec3f q : {pa, pb, pc}) finite &= std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
    if (!finite) {
      ++nan_triangles_;
      continue;
    }
    if (!(length(cross(pb - pa, pc - pa)) > 0.f)) {
      ++degenerate_triangles_;
      continue;
    }
    md.indices.insert(md.indices.end(), {a, b, cc});
  }
  // Non-finite positions not used by any kept triangle are harmless, but scene bounds use every
  // position: move them to a kept vertex.
  if (!md.indices.empty()) {
    Vec3f safe = md.positions[md.indices[0]];
    for (Vec3f& q : md.positions)
      if (!(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z))) q = safe;
  }
  if (generate) generate_tangents(md);
  if (md.indices.empty()) {
    mesh_of_[key] = -1;
    return -1;
  }
  d_.meshes.push_back(std::move(md));
  int id = int(d_.meshes.size()) - 1;
  mesh_of_[key] = id;
  return id;
}

void Converter::visit(size_t ni, const Mat4& parent_world, bool visible) {
  const json& n = root_["nodes"][ni];
  std::string p = P("/nodes", ni);
  Mat4 world = parent_world * local_matrix(n);
  Affine A = world.affine();
  std::string node_name = string_or(c_, n, "name", p, "");
  const json* node_ext = member(n, "extensions");
  if (const json* nv = node_ext ? member(*node_ext, "KHR_node_visibility") : nullptr)
    if (const json* v = member(*nv, "visible")) visible = visible && v->get<bool>();
  if (visible && member(n, "skin")) ++skinned_;
  if (const json* mj = visible ? member(n, "mesh") : nullptr) {
    size_t mi = mj->get<size_t>();
    const json& prims = root_["meshes"][mi]["primitives"];
    // EXT_mesh_gpu_instancing: the mesh once per instance, each at the node's world matrix times the instance's
    // T * R * S (accessors TRANSLATION, ROTATION, SCALE of one count; absent ones are identity). Meshes are
    // shared, not copied.
    std::vector<Mat4> worlds{world};
    const json* inst = node_ext ? member(*node_ext, "EXT_mesh_gpu_instancing") : nullptr;
    if (inst) {
      const std::string ip = P(P(p, "extensions"), "EXT_mesh_gpu_instancing");
      const json* at = member(*inst, "attributes");
      if (!at || !at->is_object()) c_.fail(ip, "missing attributes (TRANSLATION, ROTATION and/or SCALE)");
      std::vector<float> tr, ro, sc;
      size_t count = 0;
      bool any = false;
      auto read = [&](const char* key, std::vector<float>& out, const char* type) {
        const json* aj = member(*at, key);
        if (!aj) return;
        size_t cnt;
        int comps;
        out = read_floats(aj->get<size_t>(), P(P(ip, "attributes"), key), {type}, cnt, comps);
        if (any && cnt != count)
          c_.fail(P(P(ip, "attributes"), key), "has " + std::to_string(cnt) + " elements, the other attributes " +
                                                  std::to_string(count));
        count = cnt;
        any = true;
      };
      read("TRANSLATION", tr, "VEC3");
      read("ROTATION", ro, "VEC4");
      read("SCALE", sc, "VEC3");
      if (!any) c_.fail(P(ip, "attributes"), "expected TRANSLATION, ROTATION and/or SCALE");
      worlds.clear();
      for (size_t i = 0; i < count; ++i) {
        double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s3[3] = {1, 1, 1};
        for (int k = 0; k < 3 && !tr.empty(); ++k) t[k] = tr[3 * i + k];
        for (int k = 0; k < 4 && !ro.empty(); ++k) q[k] = ro[4 * i + k];
        for (int k = 0; k < 3 && !sc.empty(); ++k) s3[k] = sc[3 * i + k];
        if (!(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] > 0.0))
          c_.fail(P(P(ip, "attributes"), "ROTATION"), "instance " + std::to_string(i) + ": a zero quaternion");
        worlds.push_back(world * trs_matrix(t, q, s3));
      }
    }
    for (size_t wi = 0; wi < worlds.size(); ++wi)
    for (size_t k = 0; k < prims.size(); ++k) {
      int id = mesh(mi, k);
      if (id < 0) continue;
      if (!(std::abs(worlds[wi].det3()) > 0.0)) {
        ++singular_instances_;
        continue;
      }
      ShapeDesc s;
      s.name = node_name.empty() ? "node" + std::to_string(ni) : node_name;
      if (inst) s.name += "#" + std::to_string(wi);
      if (prims.size() > 1) s.name += "/" + std::to_string(k);
      s.type = ShapeType::kMesh;
      s.mesh = id;
      s.to_world = worlds[wi].affine();
      if (const json* mt = primitive_material(prims[k])) {
        size_t gm = mt->get<size_t>();
        s.material = material(gm);
        const MatExtra& ex = mat_extra_[gm];
        s.emission = ex.emission;
        s.emission_texture = ex.emission_texture;
        s.emission_two_sided = ex.two_sided;
        if (ex.unlit && !d_.meshes[size_t(id)].colors.empty())
          warn_once("vertex colours (COLOR_0) do not tint an unlit material's colour (KHR_materials_unlit); the base "
                    "colour is used alone");
      } else {
        if (default_material_ < 0)  // the glTF default material: white, metallic 1, roughness 1
          default_material_ = d_.add_material("default", make_metallic_roughness(RGB(1.f), 1.f, 1.f));
        s.material = default_material_;
      }
      if (!d_.meshes[size_t(id)].colors.empty()) {
        auto it = vertex_colored_.find(s.material);
        if (it == vertex_colored_.end()) {
          Material m = d_.materials[size_t(s.material)];
          m.flags |= kVertexColor;
          it = vertex_colored_.emplace(s.material, d_.add_material(d_.material_names[size_t(s.material)] + "+COLOR_0", m)).first;
        }
        s.material = it->second;
      }
      d_.shapes.push_back(s);
    }
  }
  if (const json* cj = member(n, "camera")) {
    size_t ci = cj->get<size_t>();
    const json& cam = root_["cameras"][ci];
    {
      const bool ortho = cam["type"].get<std::string>() == "orthographic";
      CameraDesc cd;
      std::string name = string_or(c_, cam, "name", P("/cameras", ci), "");
      cd.name = name.empty() ? "camera" + std::to_string(ci) : name;
      cd.position = A.point(Vec3f(0.f));
      Vec3f fwd = A.vector(Vec3f(0.f, 0.f, -1.f)), up = A.vector(Vec3f(0.f, 1.f, 0.f));
      if (!(length(fwd) > 0.f) || !(length(up) > 0.f) || !(length(cross(fwd, up)) > 0.f))
        c_.fail(p, "the camera's node transform is singular");
      cd.target = cd.position + normalize(fwd);
      cd.up = normalize(up);
      cd.flip_x = world.det3() < 0.0;
      cd.fov_axis = CameraDesc::FovAxis::kY;
      cd.height = 512;
      cd.width = 512;
      if (ortho) {
        // xmag, ymag: half the view's width and height; the film's aspect follows their ratio.
        const json& o = cam["orthographic"];
        double xmag = o["xmag"].get<double>(), ymag = o["ymag"].get<double>();
        cd.orthographic = true;
        cd.view_size = float(2.0 * ymag);
        cd.width = std::max(1, int(std::lround(512.0 * xmag / ymag)));
      } else {
        const json& per = cam["perspective"];
        cd.fov_degrees = float(per["yfov"].get<double>() * 180.0 / kPi);
        if (const json* ar = member(per, "aspectRatio")) cd.width = std::max(1, int(std::lround(512.0 * ar->get<double>())));
      }
      // The clipping planes, as a viewer draws the camera: depths along the view axis in the camera's frame
      // (scaled by the node's transform, as everything in it).
      const json& proj = cam[ortho ? "orthographic" : "perspective"];
      const float depth_scale = length(fwd);
      cd.near_clip = float(proj["znear"].get<double>()) * depth_scale;
      if (const json* zf = member(proj, "zfar")) cd.far_clip = float(zf->get<double>()) * depth_scale;
      cams_.emplace_back(ci, cd);
    }
  }
  if (node_ext && visible) {
    if (const json* lp = member(*node_ext, "KHR_lights_punctual")) {
      size_t li = (*lp)["light"].get<size_t>();
      std::string lp_path = P("/extensions/KHR_lights_punctual/lights", li);
      const json& l = root_["extensions"]["KHR_lights_punctual"]["lights"][li];
      std::string type = l["type"].get<std::string>();
      RGB color(1.f);
      if (const json* cj = member(l, "color")) color = nonneg_color(c_, *cj, P(lp_path, "color"), 3);
      double intensity = number_or(c_, l, "intensity", lp_path, 1.0);
      if (intensity < 0.0) c_.fail(P(lp_path, "intensity"), "expected a non-negative number");
      Light L;
      L.L = color * float(intensity / kLumensPerWatt);
      L.p = A.point(Vec3f(0.f));
      Vec3f dir = A.vector(Vec3f(0.f, 0.f, -1.f));
      if (type != "point" && !(length(dir) > 0.f)) c_.fail(p, "the light's node transform is singular");
      if (type == "point") {
        L.type = LightType::kPoint;
      } else if (type == "directional") {
        L.type = LightType::kDirectional;
        L.dir = normalize(dir);
      } else {
        L.type = LightType::kSpot;
        L.dir = normalize(dir);
        double inner = 0.0, outer = kPi / 4.0;
        if (const json* sp = member(l, "spot")) {
          std::string spp = P(lp_path, "spot");
          object_at(c_, *sp, spp);
          inner = number_or(c_, *sp, "innerConeAngle", spp, 0.0);
          outer = number_or(c_, *sp, "outerConeAngle", spp, kPi / 4.0);
          if (!(outer > 0.0 && outer <= kPi / 2.0)) c_.fail(P(spp, "outerConeAngle"), "expected radians in (0, pi/2]");
          if (!(inner >= 0.0 && inner < outer)) c_.fail(P(spp, "innerConeAngle"), "expected radians in [0, outerConeAngle)");
        }
        L.cos_total = float(std::cos(outer));
        L.cos_falloff_start = float(std::cos(inner));
      }
      if (member(l, "range")) warn_once("KHR_lights_punctual range is ignored (lights fall off with the inverse square law)");
      d_.lights.push_back(L);
    }
  }
  if (const json* ch = member(n, "children"))
    for (const json& k : *ch) visit(k.get<size_t>(), world, visible);
}

void Converter::run() {
  const json& nodes = top(c_, root_, "nodes");
  const json& scenes = top(c_, root_, "scenes");
  std::vector<size_t> roots;
  if (!scenes.empty()) {
    size_t si = member(root_, "scene") ? root_["scene"].get<size_t>() : 0;
    if (const json* ns = member(scenes[si], "nodes"))
      for (const json& k : *ns) roots.push_back(k.get<size_t>());
  } else {  // no scenes: every root node
    std::vector<bool> child(nodes.size(), false);
    for (const json& n : nodes)
      if (const json* ch = member(n, "children"))
        for (const json& k : *ch) child[k.get<size_t>()] = true;
    for (size_t i = 0; i < nodes.size(); ++i)
      if (!child[i]) roots.push_back(i);
  }
  for (size_t r : roots) visit(r, Mat4(), true);
  if (!top(c_, root_, "animations").empty()) warn_once("animations are not supported; the scene is loaded at rest");
  // Emissive instances whose world-space area is zero are not lights.
  for (ShapeDesc& s : d_.shapes) {
    if (!(max_component(s.emission) > 0.f)) continue;
    const MeshDesc& m = d_.meshes[size_t(s.mesh)];
    double area = 0;
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      Vec3f a = s.to_world.point(m.positions[m.indices[t]]), b = s.to_world.point(m.positions[m.indices[t + 1]]),
            cc = s.to_world.point(m.positions[m.indices[t + 2]]);
      area += 0.5 * double(length(cross(b - a, cc - a)));
    }
    if (!(area > 0.0)) {
      s.emission = RGB(0.f);
      s.emission_texture = -1;
      ++zero_area_lights_;
    }
  }
  auto count_warning = [&](size_t n, const std::string& what) {
    if (n) d_.warnings.push_back(c_.file + ": " + std::to_string(n) + " " + what);
  };
  count_warning(skipped_points_lines_, "primitive(s) of points or lines skipped (only triangles are rendered)");
  count_warning(bad_index_triangles_, "triangle(s) with vertex indices out of range skipped");
  count_warning(nan_triangles_, "triangle(s) with non-finite (NaN or infinite) vertex positions skipped");
  count_warning(degenerate_triangles_, "degenerate (zero-area) triangle(s) skipped");
  count_warning(singular_instances_, "mesh instance(s) with a singular (zero-scale) transform skipped");
  count_warning(zero_area_lights_, "emissive mesh instance(s) of zero area are not lights");
  count_warning(skinned_, "skinned node(s) rendered in their rest pose (skinning is not supported)");

  // Cameras: ordered by camera index (the first glTF camera is the default), then traversal order.
  std::stable_sort(cams_.begin(), cams_.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::set<std::string> names;
  for (auto& [ci, cd] : cams_) {
    std::string name = cd.name;
    for (int k = 2; names.count(name); ++k) name = cd.name + "#" + std::to_string(k);
    cd.name = name;
    names.insert(name);
    d_.cameras.push_back(cd);
  }
  if (!d_.cameras.empty()) d_.camera = d_.cameras.front();
  add_default_camera_and_light(d_, d_.cameras.empty());
}

std::vector<unsigned char> read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot open file");
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

uint32_t le32(const unsigned char* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }

}  // namespace

SceneDesc load_gltf_scene(const std::string& path, const std::string& variant) {
  std::vector<unsigned char> bytes = read_file(path);
  Ctx c{path, fs::path(path).parent_path()};
  bool glb = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
  if (ext == ".glb" && !glb) throw InputError(path + ": not a GLB file (expected the magic bytes 'glTF' at the start)");
  std::string text;
  size_t bin_chunk = 0, bin_chunk_len = 0;  // GLB: the BIN chunk's offset and size (header included; 0: none)
  if (glb) {
    auto bad = [&](const std::string& what) { throw InputError(path + ": invalid GLB file: " + what); };
    if (bytes.size() < 20) bad("shorter than the 12-byte header and a chunk header");
    uint32_t version = le32(&bytes[4]), length = le32(&bytes[8]);
    if (version != 2) bad("container version " + std::to_string(version) + " (expected 2)");
    if (length > bytes.size())
      bad("the header's length " + std::to_string(length) + " exceeds the file size " + std::to_string(bytes.size()));
    uint32_t jlen = le32(&bytes[12]), jtype = le32(&bytes[16]);
    if (jtype != 0x4E4F534Au) bad("the first chunk is not JSON");
    if (size_t(20) + jlen > length) bad("the JSON chunk exceeds the file length");
    text.assign(reinterpret_cast<const char*>(&bytes[20]), jlen);
    size_t bin = 20 + size_t(jlen);
    if (bin + 8 <= length) {
      uint32_t blen = le32(&bytes[bin]), btype = le32(&bytes[bin + 4]);
      if (btype == 0x004E4942u) {
        if (bin + 8 + blen > length) bad("the BIN chunk exceeds the file length");
        bin_chunk = bin, bin_chunk_len = 8 + size_t(blen);
      }
    }
  } else {
    text.assign(bytes.begin(), bytes.end());
  }
  json root;
  root = parse_json_text<json>(text, path);
  SceneDesc d;
  d.name = fs::path(path).stem().string();
  check_structure(c, root, bin_chunk_len > 0, d.warnings);
  // KHR_materials_variants: the variant to render, by name (the first of that name where names repeat).
  for (const json& v : variants_array(c, root)) {
    std::string name = v.at("name").get<std::string>();
    if (std::find(d.variants.begin(), d.variants.end(), name) != d.variants.end())
      d.warnings.push_back(path + ": " + kVariantsPath + ": the name '" + name +
                           "' is given to more than one variant; the first of them is used by that name");
    d.variants.push_back(std::move(name));
  }
  int64_t chosen = -1;
  if (!variant.empty()) {
    chosen = std::find(d.variants.begin(), d.variants.end(), variant) - d.variants.begin();
    if (size_t(chosen) == d.variants.size()) {
      std::string names;
      for (const std::string& n : d.variants) names += (names.empty() ? "" : ", ") + n;
      throw InputError(path + ": no material variant named '" + variant + "' (" +
                       (names.empty() ? "the file has no KHR_materials_variants" : "variants: " + names) + ")");
    }
    d.variant = variant;
  }

  // tinygltf reads what caustica takes from it, the buffers and the (still encoded) images, from a document of
  // those alone (and the GLB's BIN chunk): the rest, checked and converted here, stays out of its way (it
  // refuses, for one, the index accessors of Draco-compressed primitives, which have no bufferView).
  json slim = {{"asset", root["asset"]}};
  for (const char* k : {"buffers", "bufferViews", "images"})
    if (root.contains(k)) slim[k] = root[k];
  if (slim.contains("buffers"))  // EXT_meshopt_compression's fallback buffers have no data: a byte stands in
    for (json& b : slim["buffers"])
      if (meshopt_fallback(b)) b = {{"byteLength", 1}, {"uri", "data:application/octet-stream;base64,AA=="}};
  std::string slim_text = slim.dump();
  std::vector<unsigned char> slim_glb;
  if (glb) {
    while (slim_text.size() % 4) slim_text += ' ';
    auto put32 = [&](uint32_t v) {
      for (int k = 0; k < 4; ++k) slim_glb.push_back((unsigned char)(v >> (8 * k)));
    };
    slim_glb.insert(slim_glb.end(), {'g', 'l', 'T', 'F'});
    put32(2);
    put32(uint32_t(12 + 8 + slim_text.size() + bin_chunk_len));
    put32(uint32_t(slim_text.size()));
    put32(0x4E4F534Au);
    slim_glb.insert(slim_glb.end(), slim_text.begin(), slim_text.end());
    slim_glb.insert(slim_glb.end(), bytes.begin() + bin_chunk, bytes.begin() + bin_chunk + bin_chunk_len);
  }
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(keep_encoded_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  bool ok = glb ? loader.LoadBinaryFromMemory(&model, &err, &warn, slim_glb.data(), unsigned(slim_glb.size()), c.base_dir.string())
                : loader.LoadASCIIFromString(&model, &err, &warn, slim_text.data(), unsigned(slim_text.size()), c.base_dir.string());
  if (!ok) {
    std::string first = err.substr(0, err.find('\n'));
    throw InputError(path + ": invalid glTF: " + (first.empty() ? "tinygltf could not load the file" : first));
  }
  size_t nbuf = top(c, root, "buffers").size(), nimg = top(c, root, "images").size();
  if (model.buffers.size() != nbuf || model.images.size() != nimg)
    throw InputError(path + ": invalid glTF: tinygltf read " + std::to_string(model.buffers.size()) + " buffers and " +
                     std::to_string(model.images.size()) + " images");
  Converter(c, root, model, d, chosen).run();
  return d;
}

}  // namespace caustica
