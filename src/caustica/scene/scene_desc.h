// SceneDesc: the plain-data description every loader produces (built-in
// scenes, JSON, and later OBJ/glTF/Mitsuba XML). It holds no pointers into
// libraries; Scene::build turns it into flat arrays and acceleration structures.
#pragma once
#include <map>
#include <string>
#include <utility>
#include <vector>
#include "../camera/camera.h"
#include "../film/filter.h"
#include "../geometry/shapes.h"
#include "../light/light.h"
#include "../material/material.h"
#include "../medium/medium.h"
#include "../texture/texture.h"

namespace caustica {

struct MeshDesc {
  std::string name;
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;  // empty, or one per position
  std::vector<Vec2f> uvs;      // empty, or one per position; (0,0) = bottom-left of a texture image
  std::vector<Tangent> tangents;  // empty, or one per position (geometry/shapes.h; w = +-1, or 0: none there)
  // Empty, or one linear RGB per position (glTF COLOR_0, PLY vertex colours, JSON "colors"): multiplies the main
  // colour of a material with kVertexColor (scene/shading.h).
  std::vector<RGB> colors;
  std::vector<uint32_t> indices;  // 3 per triangle
};

// Per-vertex tangents for a mesh with normals and UVs and none of its own (what glTF 2.0 asks for a normal
// map without a TANGENT attribute): each triangle's dp/du and dp/dv (pbrt-v4 Eq. 6.7), made orthogonal to
// the vertex normal, summed with the triangle's angle at the vertex as weight (the weighting MikkTSpace
// uses; the sum itself is Lengyel 2001, "Computing Tangent Space Basis Vectors for an Arbitrary Mesh").
// A vertex whose triangles disagree on the UVs' handedness (a mirrored seam) or whose sum vanishes gets
// w = 0, so the triangles there keep their own dp/du. Does nothing without normals or UVs.
void generate_tangents(MeshDesc& m);

// An image texture: linear RGBA floats, row 0 = the TOP row of the image (as
// stored in files). Lookups use uv with v = 0 at the BOTTOM (OBJ, Mitsuba and
// pbrt convention; the glTF loader flips v). Colour textures are decoded from
// sRGB to linear when loaded; data textures (roughness, normals) are not.
struct TextureDesc {
  std::string name;  // the file it came from (the cache key) or a generated name
  int width = 0, height = 0;
  std::vector<float> rgba;  // width * height * 4
  bool srgb = false;        // what the loader was asked for (part of the cache key)
  TexWrap wrap_u = TexWrap::kRepeat, wrap_v = TexWrap::kRepeat;  // along u and along v
  bool nearest = false;     // nearest-texel lookup instead of bilinear
  // uv' = R(rotation) * (scale * uv) + offset (KHR_texture_transform order).
  Vec2f uv_offset{0.f, 0.f}, uv_scale{1.f, 1.f};
  float uv_rotation = 0.f;  // radians
};

// The density grid of a heterogeneous medium (medium/medium_grid.h): nx * ny * nz samples, x fastest, then
// y, then z, filling the unit cube of grid space, which to_world places in the scene.
struct MediumGridDesc {
  std::string name;  // the file it came from, or a generated name
  int nx = 0, ny = 0, nz = 0;
  int channels = 1;           // 1, or 3 (a colour grid)
  std::vector<float> values;  // nx * ny * nz * channels: x fastest, then y, then z, channels innermost
  Affine to_world;
  bool nearest = false;  // nearest sample instead of trilinear interpolation
  bool clamp = false;    // outside the cube: the nearest border sample (Mitsuba 3) instead of 0 (pbrt-v4)
};

enum class ShapeType { kMesh, kSphere, kRectangle, kCube, kDisk };

struct ShapeDesc {
  std::string name;
  ShapeType type = ShapeType::kMesh;
  int mesh = -1;             // kMesh: index into SceneDesc::meshes (shared meshes are instances)
  Affine to_world;           // local to world (applied to every type)
  Vec3f center{0.f};         // kSphere (before to_world)
  float radius = 1.f;        // kSphere
  int material = 0;
  RGB emission{0.f};         // radiance; non-zero makes the shape an area light
  int emission_texture = -1; // multiplies `emission` (index into SceneDesc::textures)
  bool emission_two_sided = false;
  bool flip_normals = false;
  // Participating media on either side (indices into SceneDesc::media, -1: vacuum), when
  // `medium_interface` is set (Mitsuba's interior/exterior: one given, the other is vacuum). Without an
  // interface the shape keeps the medium of the rays that cross it (medium/medium.h).
  bool medium_interface = false;
  int interior = -1, exterior = -1;
};

struct CameraDesc {
  std::string name;  // glTF / XML camera name (for --camera NAME)
  Vec3f position{0, 0, 0}, target{0, 0, -1}, up{0, 1, 0};
  bool orthographic = false;
  float view_size = 2.f;  // orthographic: the view's width in scene units across fov_axis
  float fov_degrees = 39.3077f;  // perspective
  enum class FovAxis { kSmaller, kX, kY } fov_axis = FovAxis::kSmaller;
  float aperture_radius = 0.f;
  float focus_distance = 0.f;  // 0: distance to target
  int width = 256, height = 256;  // the film (the whole of it, when a crop window renders a part)
  // Crop window: the pixels [crop_x, crop_x + crop_width) x [crop_y, crop_y + crop_height) of the film are
  // rendered, into a crop_width x crop_height image (Mitsuba's crop_offset / crop_size). crop_width 0: no crop.
  int crop_x = 0, crop_y = 0, crop_width = 0, crop_height = 0;
  // Principal point offset (a shift lens; Mitsuba's principal_point_offset_x/y): the image shows what the
  // unshifted camera sees offset by (x W, y H) pixels, right and down (W x H: the whole film).
  Vec2f principal_point{0.f, 0.f};
  // Clipping planes: depths along the view axis from the lens plane (Camera::clip); 0 and infinity: none.
  float near_clip = 0.f, far_clip = kInf;
  bool flip_x = false;  // mirror the image horizontally (a camera matrix with negative determinant)
  // Motion blur: with `moving`, the fields above are the pose at time 0 and these the pose
  // at time 1 (JSON "motion"); the shutter is open over [shutter_open, shutter_close] within [0, 1].
  bool moving = false;
  Vec3f position1{0, 0, 0}, target1{0, 0, -1}, up1{0, 1, 0};
  float shutter_open = 0.f, shutter_close = 1.f;
  int medium = -1;  // the participating medium the camera is in (index into SceneDesc::media, -1: vacuum)
};

// Why a camera's crop window is invalid (it must lie inside the film), or "" when it is valid or absent
// (scene.cpp).
std::string crop_problem(const CameraDesc& c);

struct SceneDesc {
  std::string name;
  CameraDesc camera;               // the camera used
  std::vector<CameraDesc> cameras; // all named cameras of the file (glTF, XML); may be empty
  // glTF KHR_materials_variants: the file's variant names, and the one whose materials the shapes have
  // ("" = none chosen: every primitive has its own `material`). Chosen when loading (LoadOptions::variant).
  std::vector<std::string> variants;
  std::string variant;
  Filter filter;  // the pixel filter (film/filter.h; make_filter)
  std::vector<std::string> material_names;
  std::vector<Material> materials;
  std::vector<MeshDesc> meshes;
  std::vector<ShapeDesc> shapes;
  std::vector<std::string> medium_names;
  std::vector<Medium> media;  // participating media (medium/medium.h)
  std::vector<MediumGridDesc> grids;  // the density and albedo grids of heterogeneous media (Medium::grid, albedo_grid)
  std::vector<Light> lights;  // point, spot, directional, environment (area lights come from shapes)
  // An environment light with Light::texture >= 0 is an equirectangular map
  // (Mitsuba's envmap convention in its local frame, y up); this rotation
  // (linear part only) takes the local frame to the world.
  Affine environment_to_world;
  std::vector<TextureDesc> textures;
  std::vector<std::string> warnings;  // one line each, shown once by the front ends
  int max_depth = -1;  // the scene's preferred default (-1: unlimited)
  // Integrator defaults from the scene file (JSON "integrator", XML <integrator>/<sampler>): the front
  // ends use them unless options override them. Empty / 0 = unset (the front end's own default).
  struct IntegratorDefaults {
    std::string type;      // "path", "sppm", ...
    std::string sampler;   // "sobol" or "independent"
    int64_t spp = 0;       // samples per pixel (photon integrators: passes)
    double time = 0.0;     // seconds
    int rr_depth = 0;
    int64_t photons = 0;   // photon paths per pass
    float radius = 0.f;    // initial gather radius
    float alpha = 0.f;     // radius reduction, in (0, 1)
    int k = 0;             // pm: photons per density estimate
    std::string photon_sampling;  // ppm, sppm, pppm: "uniform" or "adaptive"
    std::string light_sampler;    // "power" or "bvh" (RenderOptions::light_sampler; light_sampler_applies)
    // restir: candidates, neighbours, radius (pixels), history cap; < 0: not given (0 is a value for some)
    int restir_candidates = -1, restir_neighbors = -1;
    float restir_radius = -1.f, restir_history = -1.f;
    int hide_emitters = -1;  // RenderOptions::hide_emitters: 1 or 0; -1: not given
  } integrator;

  int add_material(const std::string& name, const Material& m) {
    material_names.push_back(name);
    materials.push_back(m);
    return int(materials.size()) - 1;
  }
  int material_index(const std::string& name) const {
    for (size_t i = 0; i < material_names.size(); ++i)
      if (material_names[i] == name) return int(i);
    return -1;
  }
};

// The sRGB transfer function's inverse (IEC 61966-2-1): an encoded value in [0, 1] to linear.
float srgb_to_linear(float c);

// Loads an image file (PNG, JPEG, BMP, TGA, HDR, EXR, PFM) as a texture once:
// a second request for the same (path, srgb) returns the same index. Errors
// throw InputError naming `referrer` (the scene file) and the image.
int load_texture(SceneDesc& desc, const std::string& path, bool srgb, const std::string& referrer);
// Whether the image has an alpha channel that is not 1 everywhere (an opacity texture's default channel).
bool texture_has_alpha(const TextureDesc& t);
// The same from an encoded image in memory (PNG/JPEG/... bytes, e.g. a GLB
// buffer or a data URI); `name` is the cache key.
int load_texture_from_memory(SceneDesc& desc, const std::string& name, const unsigned char* bytes, size_t size,
                             bool srgb, const std::string& referrer);
// Copies of a scene's textures with every texel's RGBA rewritten by f(float* rgba), for a material slot that
// reads its value from another channel than the image keeps it in (glTF's factors packed in alpha, Mitsuba's
// float textures read as their luminance). One copy per (texture, key), named the texture's name + key; the
// copy keeps the texture's sampler and uv transform.
class DerivedTextures {
 public:
  template <class F>
  int get(SceneDesc& desc, int t, const std::string& key, F&& f);

 private:
  std::map<std::pair<int, std::string>, int> made_;
};

// Picks the camera called `name` from desc.cameras (InputError listing the names otherwise).
void select_camera(SceneDesc& desc, const std::string& name);
// Counts and bounds for `scene.describe()` / `caustica info`.
struct SceneStats {
  size_t shapes = 0, meshes = 0, triangles = 0, spheres = 0, materials = 0, lights = 0, area_lights = 0,
         textures = 0;
  Vec3f lo{0.f}, hi{0.f};
};

// Material constructors with the parameters people know.
Material make_diffuse(RGB reflectance, bool two_sided = false);
Material make_mirror(RGB tint = RGB(1.f));
Material make_conductor(RGB eta, RGB k, RGB tint = RGB(1.f), float alpha = 0.f);
Material make_dielectric(float eta, float alpha = 0.f);
Material make_thin_dielectric(float eta);
Material make_plastic(RGB diffuse, float eta = 1.49f, RGB specular = RGB(1.f));
Material make_diffuse_transmission(RGB reflectance, RGB transmittance);
Material make_phong(RGB kd, RGB ks, float exponent);
// Sets GGX alpha (ax along the anisotropy direction, ay across it; scene/shading.h). An anisotropic pair keeps
// each alpha >= 1e-4, as Mitsuba 3 clamps them: GGX's D divides by both.
void set_alpha(Material& m, float ax, float ay);
// glTF 2.0 metallic-roughness: base colour, metallic in [0,1], perceptual
// roughness in [0,1] (GGX alpha = roughness^2), KHR_materials_transmission
// weight, KHR_materials_ior.
Material make_metallic_roughness(RGB base_color, float metallic, float roughness, float transmission = 0.f,
                                 float ior = 1.5f);
// Mitsuba 3's principled BSDF (material/principled.h): base colour, metallic, roughness (GGX alpha = roughness^2),
// anisotropic (alpha / aspect along the anisotropy direction, alpha x aspect across it, aspect = sqrt(1 - 0.9
// anisotropic)), spec_trans, eta; the other weights (spec_tint, sheen, ...) are set on the Material.
Material make_principled(RGB base_color, float metallic, float roughness, float anisotropic = 0.f,
                         float spec_trans = 0.f, float eta = 1.5f);
// A rough dielectric coat (GGX alpha, or Beckmann) over Lambert, Mitsuba's roughplastic
// (material/rough_plastic.h); computes its coat tables (prepare_rough_plastic).
Material make_rough_plastic(RGB diffuse, float eta, float alpha, bool beckmann = false, RGB specular = RGB(1.f));
// A rough plastic's derived state: Material::table and fdr_int from alpha, eta and the distribution (Scene::build
// calls it for every rough plastic).
void prepare_rough_plastic(Material& m);
// A metallic-roughness material's sheen albedo table (Material::table; material/metallic_roughness.h) from its
// sheen roughness (Scene::build calls it for every such material with a sheen colour).
void prepare_sheen(Material& m);
// The sheen's directional albedo table (Material::table's form) for the Charlie alpha `alpha` (computed once per
// alpha in a process).
std::array<uint16_t, kMaterialTable> sheen_albedo_table(float alpha);
// Hemispherical average of dielectric Fresnel reflectance, 2 int_0^1 F(mu) mu dmu.
float diffuse_fresnel_reflectance(float eta);

template <class F>
int DerivedTextures::get(SceneDesc& desc, int t, const std::string& key, F&& f) {
  auto [it, fresh] = made_.try_emplace({t, key}, -1);
  if (!fresh) return it->second;
  TextureDesc r = desc.textures[size_t(t)];
  r.name += key;
  for (size_t i = 0; i + 3 < r.rgba.size(); i += 4) f(&r.rgba[i]);
  desc.textures.push_back(std::move(r));
  return it->second = int(desc.textures.size()) - 1;
}

}  // namespace caustica
