// Mitsuba 3 XML loader: the Cornell box against the built-in scene, the
// mapping of every supported element, and the exact message of each error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <unistd.h>

#include "caustica/base/error.h"
#include "caustica/scene/builtin/builtin.h"
#include "caustica/scene/load.h"
#include "caustica/scene/loaders/mitsuba_loader.h"
#include "caustica/scene/scene.h"

using namespace caustica;
namespace fs = std::filesystem;

namespace {

fs::path tmp_dir() {
  static fs::path p = [] {
    fs::path d = fs::temp_directory_path() / ("caustica_mitsuba_test_" + std::to_string(getpid()));
    fs::create_directories(d);
    return d;
  }();
  return p;
}
std::string write_file(const std::string& name, const std::string& text) {
  fs::path p = tmp_dir() / name;
  fs::create_directories(p.parent_path());
  std::ofstream f(p, std::ios::binary);
  f << text;
  return p.string();
}
// A scene file whose body starts on line 2.
std::string scene_file(const std::string& name, const std::string& body) {
  return write_file(name, "<scene version=\"3.0.0\">\n" + body + "</scene>\n");
}
std::string error_of(const std::string& path, const std::map<std::string, std::string>& params = {}) {
  try {
    load_mitsuba_scene(path, params);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}
std::string data_file(const std::string& name) {
  return (fs::path(__FILE__).parent_path().parent_path() / "data" / "mitsuba" / name).string();
}
bool has_warning(const SceneDesc& d, const std::string& w) {
  for (const std::string& x : d.warnings)
    if (x == w) return true;
  return false;
}
std::string all_warnings(const SceneDesc& d) {
  std::string s;
  for (const std::string& x : d.warnings) s += x + "\n";
  return s;
}
// A 2 x 1 PFM image (linear RGB floats).
std::string write_pfm(const std::string& name) {
  std::string s = "PF\n2 1\n-1.0\n";
  float px[6] = {1.f, 2.f, 3.f, 4.f, 5.f, 6.f};
  s.append(reinterpret_cast<const char*>(px), sizeof(px));
  return write_file(name, s);
}
void expect_affine_near(const Affine& a, const Affine& b, float tol = 1e-5f) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(a.m[i][j], b.m[i][j], tol) << "entry (" << i << "," << j << ")";
}
void expect_vec_near(Vec3f a, Vec3f b, float tol = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}
const std::string kCamera =
    "<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>"
    "<film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/><integer name=\"height\" value=\"32\"/></film></sensor>\n";

}  // namespace

// ---------------------------------------------------------------------------
// The Cornell box.

TEST(MitsubaCornell, EqualsBuiltin) {
  SceneDesc x = load_mitsuba_scene(data_file("cornell.xml"));
  SceneDesc b = builtin_scene("cornell");
  expect_vec_near(x.camera.position, b.camera.position);
  expect_vec_near(x.camera.target, b.camera.target);
  expect_vec_near(x.camera.up, b.camera.up);
  EXPECT_FLOAT_EQ(x.camera.fov_degrees, b.camera.fov_degrees);
  EXPECT_EQ(x.camera.fov_axis, b.camera.fov_axis);
  EXPECT_EQ(x.camera.width, b.camera.width);
  EXPECT_EQ(x.camera.height, b.camera.height);
  EXPECT_EQ(x.camera.flip_x, b.camera.flip_x);
  EXPECT_EQ(x.camera.aperture_radius, 0.f);
  EXPECT_TRUE(x.filter == b.filter);
  EXPECT_EQ(x.max_depth, b.max_depth);
  ASSERT_EQ(x.materials.size(), b.materials.size());
  for (size_t i = 0; i < b.materials.size(); ++i) {
    EXPECT_EQ(x.material_names[i], b.material_names[i]);
    EXPECT_EQ(x.materials[i].type, b.materials[i].type);
    EXPECT_EQ(x.materials[i].flags, b.materials[i].flags);
    expect_vec_near(x.materials[i].diffuse, b.materials[i].diffuse, 0.f);
  }
  ASSERT_EQ(x.shapes.size(), b.shapes.size());
  for (size_t i = 0; i < b.shapes.size(); ++i) {
    SCOPED_TRACE(b.shapes[i].name);
    EXPECT_EQ(x.shapes[i].name, b.shapes[i].name);
    EXPECT_EQ(x.shapes[i].type, b.shapes[i].type);
    EXPECT_EQ(x.shapes[i].material, b.shapes[i].material);
    expect_affine_near(x.shapes[i].to_world, b.shapes[i].to_world);
    expect_vec_near(x.shapes[i].emission, b.shapes[i].emission, 0.f);
    EXPECT_EQ(x.shapes[i].emission_two_sided, b.shapes[i].emission_two_sided);
    EXPECT_EQ(x.shapes[i].flip_normals, b.shapes[i].flip_normals);
  }
  EXPECT_TRUE(x.lights.empty());
  std::string f = data_file("cornell.xml");
  // The sensor's sampler gives the scene's default spp and sampler (render options override them).
  EXPECT_EQ(x.integrator.spp, 64);
  EXPECT_EQ(x.integrator.sampler, "independent");
  // The clipping planes are the sensor's (no longer ignored with a warning).
  EXPECT_FLOAT_EQ(x.camera.near_clip, 0.001f);
  EXPECT_FLOAT_EQ(x.camera.far_clip, 100.f);
  EXPECT_FALSE(has_warning(x, f + ":17: <float name=\"near_clip\">: ignored (no effect on caustica's light transport)"))
      << all_warnings(x);
  // It builds, through the format dispatch too.
  SceneDesc y = load_scene_desc(f);
  EXPECT_EQ(y.shapes.size(), b.shapes.size());
  EXPECT_NO_THROW(Scene::build(y));
}

TEST(MitsubaCornell, ParametersOverrideDefaults) {
  SceneDesc x = load_mitsuba_scene(data_file("cornell.xml"), {{"res", "64"}, {"max_depth", "3"}, {"rfilter", "box"}});
  EXPECT_EQ(x.camera.width, 64);
  EXPECT_EQ(x.camera.height, 64);
  EXPECT_EQ(x.max_depth, 3);
  EXPECT_EQ(x.filter.type, FilterType::kBox);
}

// ---------------------------------------------------------------------------
// Transforms.

TEST(MitsubaTransform, ComposesInDocumentOrder) {
  std::string f = scene_file("transform.xml", kCamera +
      "<shape type=\"rectangle\" id=\"a\"><transform name=\"to_world\">\n"
      "  <scale value=\"2\"/><rotate z=\"1\" angle=\"90\"/><translate x=\"1\"/>\n"
      "</transform></shape>\n"
      "<shape type=\"rectangle\" id=\"b\"><transform name=\"to_world\">\n"
      "  <translate x=\"1\"/><rotate value=\"0 0 1\" angle=\"90\"/><scale x=\"2\" y=\"3\"/>\n"
      "</transform></shape>\n"
      "<shape type=\"rectangle\" id=\"c\"><transform name=\"to_world\">\n"
      "  <matrix value=\"1 0 0 5  0 0 -1 6  0 1 0 7  0 0 0 1\"/><translate z=\"1\"/>\n"
      "</transform></shape>\n"
      "<shape type=\"rectangle\" id=\"d\"><transform name=\"to_world\">\n"
      "  <lookat origin=\"1, 2, 3\" target=\"1, 2, 4\" up=\"0, 1, 0\"/>\n"
      "</transform></shape>\n"
      "<shape type=\"rectangle\" id=\"e\"><transform name=\"to_world\">\n"
      "  <scale value=\"1 2 3\"/><matrix value=\"0 -1 0  1 0 0  0 0 1\"/>\n"
      "</transform></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 5u);
  // a: (1,0,0) -> scale (2,0,0) -> rotate about z (0,2,0) -> translate (1,2,0).
  expect_vec_near(d.shapes[0].to_world.point({1, 0, 0}), {1, 2, 0});
  // b: (1,1,0) -> translate (2,1,0) -> rotate (-1,2,0) -> scale (-2,6,0).
  expect_vec_near(d.shapes[1].to_world.point({1, 1, 0}), {-2, 6, 0});
  // c: the matrix, then a translation in world z.
  expect_vec_near(d.shapes[2].to_world.point({0, 1, 0}), {5, 6, 9});
  // d: Mitsuba's look_at: local z to the target direction, local x = up x dir.
  expect_vec_near(d.shapes[3].to_world.point({0, 0, 1}), {1, 2, 4});
  expect_vec_near(d.shapes[3].to_world.vector({1, 0, 0}), {1, 0, 0});
  expect_vec_near(d.shapes[3].to_world.vector({0, 1, 0}), {0, 1, 0});
  // e: a 3x3 matrix after a scale.
  expect_vec_near(d.shapes[4].to_world.point({1, 1, 1}), {-2, 1, 3});
}

TEST(MitsubaTransform, Errors) {
  std::string f = scene_file("terr1.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                                          "<matrix value=\"1 0 0 0 0 1 0 0 0 0 1 0\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <matrix>: expected 16 numbers (a row-major 4x4 matrix) or 9 (3x3), got "
                             "'1 0 0 0 0 1 0 0 0 0 1 0'");
  f = scene_file("terr2.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                              "<matrix value=\"1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <matrix>: projective matrices are not supported (the last row must be 0 0 0 1)");
  f = scene_file("terr3.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                              "<rotate angle=\"30\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <rotate>: expected a non-zero rotation axis (x, y, z or value)");
  f = scene_file("terr4.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                              "<shear x=\"1\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <shear>: unknown transform operation (allowed: translate, rotate, scale, matrix, lookat)");
  f = scene_file("terr5.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                              "<lookat origin=\"0 0 0\" target=\"0 1 0\" up=\"0 1 0\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <lookat>: 'up' must not be parallel to the view direction");
  f = scene_file("terr6.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                              "<translate x=\"1\" value=\"1 2 3\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <translate>: give either 'value' or x/y/z, not both");
  f = scene_file("terr7.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                              "<translate x=\"nan\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <translate>: expected a finite number, got 'nan'");
  f = scene_file("terr8.xml", "<shape type=\"cube\"><transform name=\"to_world\">\n"
                              "<rotate x=\"1\" angle=\"30\" axis=\"x\"/></transform></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <rotate>: unknown attribute 'axis' (allowed: value, x, y, z, angle)");
}

// ---------------------------------------------------------------------------
// Parameters, include, ref.

TEST(MitsubaParams, DefaultsSubstitutionAndOverrides) {
  std::string f = scene_file("params.xml",
                             "<default name=\"r\" value=\"0.25\"/>\n"
                             "<default name=\"ab\" value=\"9\"/>\n"
                             "<default name=\"a\" value=\"1\"/>\n" + kCamera +
                             "<shape type=\"sphere\"><float name=\"radius\" value=\"$r\"/>\n"
                             "<point name=\"center\" x=\"$a\" y=\"$ab\" z=\"$a$a\"/></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  EXPECT_FLOAT_EQ(d.shapes[0].radius, 0.25f);
  expect_vec_near(d.shapes[0].center, {1, 9, 11}, 0.f);
  d = load_mitsuba_scene(f, {{"r", "2"}, {"a", "3"}, {"unused", "1"}});
  EXPECT_FLOAT_EQ(d.shapes[0].radius, 2.f);
  expect_vec_near(d.shapes[0].center, {3, 9, 33}, 0.f);
  EXPECT_TRUE(has_warning(d, f + ": parameter 'unused' was given but the scene does not use it")) << all_warnings(d);

  std::string g = scene_file("params_undef.xml", "<shape type=\"sphere\">\n<float name=\"radius\" value=\"$size\"/></shape>\n");
  EXPECT_EQ(error_of(g), g + ":3: <float name=\"radius\">: undefined parameter $size (declare it with <default "
                             "name=\"size\" value=\"...\"/> or pass a value for it)");
  EXPECT_EQ(load_mitsuba_scene(g, {{"size", "3"}}).shapes[0].radius, 3.f);
}

TEST(MitsubaInclude, IncludesRelativeToTheIncludingFile) {
  write_file("inc/sub/materials.xml",
             "<scene version=\"3.0.0\">\n"
             "  <bsdf type=\"diffuse\" id=\"grey\"><rgb name=\"reflectance\" value=\"0.3\"/></bsdf>\n"
             "  <include filename=\"more.xml\"/>\n"
             "</scene>\n");
  write_file("inc/sub/more.xml",
             "<scene version=\"3.0.0\">\n"
             "  <bsdf type=\"conductor\" id=\"mirror\"/>\n"
             "</scene>\n");
  std::string f = write_file("inc/main.xml", "<scene version=\"3.0.0\">\n  <include filename=\"sub/materials.xml\"/>\n" +
                                                 kCamera + "  <shape type=\"cube\"><ref id=\"grey\"/></shape>\n"
                                                 "  <shape type=\"cube\"><ref name=\"bsdf\" id=\"mirror\"/></shape>\n</scene>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 2u);
  EXPECT_EQ(d.material_names[d.shapes[0].material], "grey");
  expect_vec_near(d.materials[d.shapes[0].material].diffuse, RGB(0.3f), 0.f);
  EXPECT_EQ(d.material_names[d.shapes[1].material], "mirror");
  EXPECT_EQ(d.materials[d.shapes[1].material].type, MaterialType::kConductor);
  EXPECT_EQ(d.materials[d.shapes[1].material].flags, uint32_t(kConductorTint));

  std::string g = scene_file("inc_missing.xml", "\n<include filename=\"nowhere/x.xml\"/>\n");
  EXPECT_EQ(error_of(g), g + ":3: <include>: included file '" + (tmp_dir() / "nowhere/x.xml").string() +
                             "' does not exist");
  std::string bad = write_file("inc_bad_child.xml", "<scene version=\"3.0.0\">\n\n  <bsdf type=\"velvet\"/>\n</scene>\n");
  g = scene_file("inc_error.xml", "<include filename=\"inc_bad_child.xml\"/>\n");
  EXPECT_EQ(error_of(g), bad + ":3: <bsdf type=\"velvet\">: unsupported BSDF type (supported: diffuse, conductor, "
                               "roughconductor, dielectric, roughdielectric, thindielectric, plastic, roughplastic, principled, twosided, normalmap, bumpmap, mask, blendbsdf, null)");
  g = scene_file("inc_self.xml", "<include filename=\"inc_self.xml\"/>\n");
  EXPECT_EQ(error_of(g), g + ":2: <include>: '" + g + "' includes itself (an include cycle)");
}

TEST(MitsubaRef, ReferencesAndShapeLevelIds) {
  std::string f = scene_file("ref.xml", kCamera +
                             "<shape type=\"cube\"><bsdf type=\"diffuse\" id=\"inner\"><float name=\"reflectance\" value=\"0.7\"/></bsdf></shape>\n"
                             "<shape type=\"disk\"><ref id=\"inner\"/></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 2u);
  EXPECT_EQ(d.shapes[0].material, d.shapes[1].material);
  EXPECT_EQ(d.shapes[1].type, ShapeType::kDisk);
  expect_vec_near(d.materials[d.shapes[1].material].diffuse, RGB(0.7f), 0.f);

  std::string g = scene_file("ref_missing.xml", "<shape type=\"cube\">\n<ref id=\"nope\"/></shape>\n");
  EXPECT_EQ(error_of(g), g + ":3: <ref id=\"nope\">: no BSDF with id 'nope' is defined before this line");
  std::string p = write_pfm("ref_tex.pfm");
  g = scene_file("ref_kind.xml", "<texture type=\"bitmap\" id=\"t\"><string name=\"filename\" value=\"ref_tex.pfm\"/></texture>\n"
                                 "<shape type=\"cube\">\n<ref id=\"t\"/></shape>\n");
  EXPECT_EQ(error_of(g), g + ":4: <ref id=\"t\">: a shape can only reference a BSDF here");
  g = scene_file("ref_dup.xml", "<bsdf type=\"diffuse\" id=\"x\"/>\n<bsdf type=\"diffuse\" id=\"x\"/>\n");
  EXPECT_EQ(error_of(g), g + ":3: <bsdf type=\"diffuse\" id=\"x\">: id 'x' is already used (at " + g + ":2)");
}

// ---------------------------------------------------------------------------
// BSDFs.

TEST(MitsubaBsdf, Mapping) {
  std::string f = scene_file("bsdfs.xml", kCamera +
      "<bsdf type=\"twosided\" id=\"ts\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1 0.2 0.3\"/></bsdf></bsdf>\n"
      "<bsdf type=\"conductor\" id=\"au\"><string name=\"material\" value=\"Au\"/></bsdf>\n"
      "<bsdf type=\"conductor\" id=\"ek\"><rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/><rgb name=\"k\" value=\"3.9, 2.4, 2.1\"/>"
      "<rgb name=\"specular_reflectance\" value=\"0.5\"/></bsdf>\n"
      "<bsdf type=\"roughconductor\" id=\"rc\"><string name=\"material\" value=\"Al\"/><string name=\"distribution\" value=\"ggx\"/>"
      "<float name=\"alpha\" value=\"0.2\"/></bsdf>\n"
      "<bsdf type=\"roughconductor\" id=\"rcb\"><float name=\"alpha\" value=\"0.3\"/></bsdf>\n"
      "<bsdf type=\"dielectric\" id=\"glass\"><string name=\"int_ior\" value=\"water\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>\n"
      "<bsdf type=\"dielectric\" id=\"dflt\"/>\n"
      "<bsdf type=\"roughdielectric\" id=\"rd\"><float name=\"int_ior\" value=\"1.5\"/><float name=\"ext_ior\" value=\"1\"/>"
      "<string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.05\"/></bsdf>\n"
      "<bsdf type=\"thindielectric\" id=\"thin\"><string name=\"int_ior\" value=\"diamond\"/><string name=\"ext_ior\" value=\"vacuum\"/></bsdf>\n"
      "<bsdf type=\"plastic\" id=\"pl\"><rgb name=\"diffuse_reflectance\" value=\"0.5\"/><float name=\"int_ior\" value=\"1.5\"/>"
      "<float name=\"ext_ior\" value=\"1\"/></bsdf>\n"
      "<bsdf type=\"plastic\" id=\"pln\"><rgb name=\"diffuse_reflectance\" value=\"0.5\"/><boolean name=\"nonlinear\" value=\"true\"/></bsdf>\n"
      "<bsdf type=\"roughplastic\" id=\"rp\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.25\"/>"
      "<float name=\"int_ior\" value=\"1.5\"/><float name=\"ext_ior\" value=\"1\"/><boolean name=\"nonlinear\" value=\"true\"/></bsdf>\n"
      "<bsdf type=\"twosided\" id=\"ts2\"><ref id=\"au\"/></bsdf>\n"
      "<shape type=\"cube\"/>\n");
  SceneDesc d = load_mitsuba_scene(f);
  auto M = [&](const char* n) {
    int i = d.material_index(n);
    EXPECT_GE(i, 0) << n;
    return d.materials[i];
  };
  Material m = M("ts");
  EXPECT_EQ(m.type, MaterialType::kDiffuse);
  EXPECT_EQ(m.flags, uint32_t(kTwoSided));
  expect_vec_near(m.diffuse, {0.1f, 0.2f, 0.3f}, 0.f);
  m = M("au");
  EXPECT_EQ(m.type, MaterialType::kConductor);
  EXPECT_EQ(m.flags, 0u);
  expect_vec_near(m.eta_c, {0.143036f, 0.375307f, 1.44205f}, 0.f);
  expect_vec_near(m.k_c, {3.983f, 2.38556f, 1.60336f}, 0.f);
  m = M("ek");
  expect_vec_near(m.eta_c, {0.2f, 0.9f, 1.1f}, 0.f);
  expect_vec_near(m.specular, RGB(0.5f), 0.f);
  m = M("rc");
  EXPECT_EQ(m.type, MaterialType::kRoughConductor);
  EXPECT_FLOAT_EQ(m.alpha_x, 0.2f);
  expect_vec_near(m.eta_c, {1.6575f, 0.880405f, 0.521244f}, 0.f);
  EXPECT_EQ(m.flags & kBeckmann, 0u);  // distribution ggx
  m = M("rcb");  // material "none": a rough mirror, Mitsuba's default distribution (Beckmann)
  EXPECT_EQ(m.type, MaterialType::kRoughConductor);
  EXPECT_EQ(m.flags, uint32_t(kConductorTint | kBeckmann));
  EXPECT_FLOAT_EQ(m.alpha_y, 0.3f);
  EXPECT_FALSE(has_warning(d, f + ":7: <bsdf type=\"roughconductor\" id=\"rcb\">: distribution \"beckmann\" (Mitsuba's "
                                  "default) is rendered with GGX of the same alpha"))
      << all_warnings(d);
  EXPECT_FLOAT_EQ(M("glass").eta, 1.333f);
  EXPECT_EQ(M("glass").type, MaterialType::kDielectric);
  EXPECT_FLOAT_EQ(M("dflt").eta, 1.5046f / 1.000277f);
  EXPECT_EQ(M("rd").type, MaterialType::kRoughDielectric);
  EXPECT_FLOAT_EQ(M("rd").alpha_x, 0.05f);
  EXPECT_EQ(M("thin").type, MaterialType::kThinDielectric);
  EXPECT_FLOAT_EQ(M("thin").eta, 2.419f);
  // plastic, Mitsuba's linear model: caustica's Kd'/(1 - Kd' Fdr) equals Mitsuba's Kd/(1 - Fdr).
  m = M("pl");
  EXPECT_EQ(m.type, MaterialType::kPlastic);
  float fdr = diffuse_fresnel_reflectance(1.f / 1.5f);
  EXPECT_NEAR(m.diffuse.x / (1.f - m.diffuse.x * fdr), 0.5f / (1.f - fdr), 1e-5f);
  expect_vec_near(M("pln").diffuse, RGB(0.5f), 0.f);
  m = M("rp");  // roughplastic: caustica's rough plastic, the coat's own tables (material/rough_plastic.h)
  EXPECT_EQ(m.type, MaterialType::kRoughPlastic);
  EXPECT_FLOAT_EQ(m.alpha_x, 0.25f);
  EXPECT_EQ(m.flags & kBeckmann, 0u);
  EXPECT_FLOAT_EQ(m.eta, 1.5f);
  expect_vec_near(m.diffuse, RGB(0.5f), 0.f);  // nonlinear="true": as given
  EXPECT_GT(m.fdr_int, 0.f);
  EXPECT_GT(m.table[kMaterialTable - 1], m.table[0]);  // the coat lets more through head-on
  EXPECT_EQ(all_warnings(d).find("roughplastic"), std::string::npos) << all_warnings(d);
  m = M("ts2");
  EXPECT_EQ(m.type, MaterialType::kConductor);
  EXPECT_EQ(m.flags, uint32_t(kTwoSided));
  // A shape without a BSDF gets Mitsuba's default, diffuse 0.5.
  EXPECT_EQ(d.material_names[d.shapes[0].material], "default");
  EXPECT_NO_THROW(Scene::build(d));
}

TEST(MitsubaBsdf, Textures) {
  write_pfm("tex/t.pfm");
  std::string f = scene_file("textures.xml", kCamera +
      "<shape type=\"rectangle\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">"
      "<string name=\"filename\" value=\"tex/t.pfm\"/><string name=\"wrap_mode\" value=\"clamp\"/>"
      "<string name=\"filter_type\" value=\"nearest\"/></texture></bsdf></shape>\n"
      "<shape type=\"rectangle\"><bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"ggx\"/>"
      "<texture type=\"bitmap\" name=\"alpha\"><string name=\"filename\" value=\"tex/t.pfm\"/>"
      "<boolean name=\"raw\" value=\"true\"/></texture></bsdf></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 2u);
  const Material& a = d.materials[d.shapes[0].material];
  ASSERT_GE(a.tex_color, 0);
  expect_vec_near(a.diffuse, RGB(1.f), 0.f);
  EXPECT_EQ(d.textures[a.tex_color].wrap_u, TexWrap::kClamp);
  EXPECT_EQ(d.textures[a.tex_color].wrap_v, TexWrap::kClamp);
  EXPECT_TRUE(d.textures[a.tex_color].nearest);
  EXPECT_TRUE(d.textures[a.tex_color].srgb);
  const Material& b = d.materials[d.shapes[1].material];
  EXPECT_EQ(b.type, MaterialType::kRoughConductor);
  ASSERT_GE(b.tex_roughness, 0);
  EXPECT_FALSE(d.textures[b.tex_roughness].srgb);
  EXPECT_EQ(d.textures[b.tex_roughness].wrap_u, TexWrap::kRepeat);
  EXPECT_EQ(d.textures[b.tex_roughness].wrap_v, TexWrap::kRepeat);
  EXPECT_EQ(d.textures[b.tex_roughness].width, 2);
  // Mitsuba reads a float texture's luminance (a bitmap's eval_1): the colour image's grey copy.
  EXPECT_NEAR(d.textures[b.tex_roughness].rgba[0], luminance(RGB(1.f, 2.f, 3.f)), 1e-6f);
  EXPECT_EQ(d.textures[b.tex_roughness].rgba[1], d.textures[b.tex_roughness].rgba[0]);
  EXPECT_NEAR(d.textures[b.tex_roughness].rgba[4], luminance(RGB(4.f, 5.f, 6.f)), 1e-6f);

  std::string g = scene_file("tex_missing.xml", "<shape type=\"cube\"><bsdf type=\"diffuse\">\n"
                                                "<texture type=\"bitmap\" name=\"reflectance\">\n"
                                                "<string name=\"filename\" value=\"missing.png\"/></texture></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":4: <string name=\"filename\">: texture file '" + (tmp_dir() / "missing.png").string() +
                             "' does not exist");
  g = scene_file("tex_type.xml", "<shape type=\"cube\"><bsdf type=\"diffuse\">\n"
                                 "<texture type=\"volume\" name=\"reflectance\"/></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":3: <texture type=\"volume\" name=\"reflectance\">: unsupported texture type "
                             "(supported: bitmap, checkerboard, mesh_attribute)");
  g = scene_file("tex_slot.xml", "<shape type=\"cube\"><bsdf type=\"dielectric\">\n"
                                 "<texture type=\"bitmap\" name=\"specular_reflectance\"><string name=\"filename\" "
                                 "value=\"tex/t.pfm\"/></texture></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":3: <texture type=\"bitmap\" name=\"specular_reflectance\">: a texture is not supported "
                             "for this property");

  // normalmap and bumpmap wrap a BSDF with a texture of any name (or none); raw decides sRGB as elsewhere;
  // twosided can hold them.
  f = scene_file("wrapped.xml", kCamera +
      "<shape type=\"rectangle\"><bsdf type=\"normalmap\"><texture type=\"bitmap\" name=\"normalmap\">"
      "<string name=\"filename\" value=\"tex/t.pfm\"/><boolean name=\"raw\" value=\"true\"/></texture>"
      "<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"ggx\"/></bsdf></bsdf></shape>\n"
      "<shape type=\"rectangle\"><bsdf type=\"twosided\"><bsdf type=\"bumpmap\"><texture type=\"bitmap\">"
      "<string name=\"filename\" value=\"tex/t.pfm\"/></texture><float name=\"scale\" value=\"0.25\"/>"
      "<bsdf type=\"diffuse\"/></bsdf></bsdf></shape>\n");
  d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 2u);
  const Material& nm = d.materials[d.shapes[0].material];
  EXPECT_EQ(nm.type, MaterialType::kRoughConductor);
  ASSERT_GE(nm.tex_normal, 0);
  EXPECT_FALSE(d.textures[nm.tex_normal].srgb);
  EXPECT_EQ(nm.tex_bump, -1);
  const Material& bm = d.materials[d.shapes[1].material];
  EXPECT_EQ(bm.type, MaterialType::kDiffuse);
  EXPECT_TRUE(bm.flags & kTwoSided);
  ASSERT_GE(bm.tex_bump, 0);
  EXPECT_TRUE(d.textures[bm.tex_bump].srgb);  // raw not given: Mitsuba decodes it too
  EXPECT_EQ(bm.bump_scale, 0.25f);
  EXPECT_EQ(bm.tex_normal, -1);
  EXPECT_TRUE(nm.flags & kNormalMapCross);  // Mitsuba's y axis is n x dp/du
  EXPECT_FALSE(bm.flags & kNormalMapCross);
  // Mitsuba's terminator options (on by default) are reported once; with both false nothing is said.
  auto said = [](const SceneDesc& sd) {
    int k = 0;
    for (const std::string& w : sd.warnings) k += w.find("flip_invalid_normals") != std::string::npos;
    return k;
  };
  EXPECT_EQ(said(d), 1);
  f = scene_file("wrapped_plain.xml", kCamera +
      "<shape type=\"rectangle\"><bsdf type=\"normalmap\"><boolean name=\"flip_invalid_normals\" value=\"false\"/>"
      "<boolean name=\"use_shadowing_function\" value=\"false\"/><texture type=\"bitmap\" name=\"normalmap\">"
      "<string name=\"filename\" value=\"tex/t.pfm\"/><boolean name=\"raw\" value=\"true\"/></texture>"
      "<bsdf type=\"diffuse\"/></bsdf></shape>\n");
  EXPECT_EQ(said(load_mitsuba_scene(f)), 0);
  // mask: the nested BSDF with stochastic opacity, a number (default 0.5) or a texture read by luminance;
  // twosided inside or outside it.
  f = scene_file("masked.xml", kCamera +
      "<shape type=\"rectangle\"><bsdf type=\"mask\"><float name=\"opacity\" value=\"0.3\"/>"
      "<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf></bsdf></shape>\n"
      "<shape type=\"rectangle\"><bsdf type=\"twosided\"><bsdf type=\"mask\"><texture type=\"bitmap\" "
      "name=\"opacity\"><string name=\"filename\" value=\"tex/t.pfm\"/></texture>"
      "<bsdf type=\"diffuse\"/></bsdf></bsdf></shape>\n"
      "<shape type=\"rectangle\"><bsdf type=\"mask\"><bsdf type=\"roughconductor\"/></bsdf></shape>\n");
  d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 3u);
  const Material& m0 = d.materials[d.shapes[0].material];
  EXPECT_EQ(m0.type, MaterialType::kDiffuse);
  EXPECT_TRUE(m0.flags & kTwoSided);
  EXPECT_FLOAT_EQ(m0.opacity, 0.3f);
  EXPECT_EQ(m0.tex_opacity, -1);
  EXPECT_LT(m0.opacity_cutoff, 0.f);  // stochastic, as Mitsuba's
  const Material& m1 = d.materials[d.shapes[1].material];
  EXPECT_TRUE(m1.flags & kTwoSided);
  ASSERT_GE(m1.tex_opacity, 0);
  EXPECT_TRUE(m1.flags & kOpacityLuminance);
  EXPECT_EQ(m1.opacity, 1.f);
  const Material& m2 = d.materials[d.shapes[2].material];
  EXPECT_EQ(m2.type, MaterialType::kRoughConductor);
  EXPECT_EQ(m2.opacity, 0.5f);
  // A textured opacity shows the rectangle's parameterisation: Mitsuba's own, as for any texture.
  EXPECT_EQ(d.shapes[0].type, ShapeType::kRectangle);
  EXPECT_EQ(d.shapes[1].type, ShapeType::kMesh);
  // blendbsdf: two nested BSDFs (or refs), the second at a share `weight` (0.5; a texture read by luminance).
  f = scene_file("blended.xml", kCamera +
      "<bsdf type=\"diffuse\" id=\"red\"><rgb name=\"reflectance\" value=\"0.8, 0.1, 0.1\"/></bsdf>\n"
      "<shape type=\"rectangle\"><bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.3\"/>"
      "<ref id=\"red\"/><bsdf type=\"roughconductor\"/></bsdf></shape>\n"
      "<shape type=\"rectangle\"><bsdf type=\"mask\"><float name=\"opacity\" value=\"0.5\"/><bsdf type=\"blendbsdf\">"
      "<texture type=\"bitmap\" name=\"weight\"><string name=\"filename\" value=\"tex/t.pfm\"/></texture>"
      "<bsdf type=\"diffuse\"/><bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf></bsdf></bsdf></shape>\n");
  d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 2u);
  const Material& b0 = d.materials[d.shapes[0].material];
  ASSERT_GE(b0.mix_b, 0);
  EXPECT_FLOAT_EQ(b0.mix_weight, 0.3f);
  EXPECT_EQ(d.materials[b0.mix_a].diffuse.x, 0.8f);  // the first nested BSDF is mix_a
  EXPECT_EQ(d.materials[b0.mix_b].type, MaterialType::kRoughConductor);
  const Material& b1 = d.materials[d.shapes[1].material];
  ASSERT_GE(b1.mix_b, 0);
  EXPECT_GE(b1.tex_mix, 0);
  EXPECT_EQ(b1.mix_weight, 1.f);
  EXPECT_EQ(b1.opacity, 0.5f);  // the mask around it
  EXPECT_EQ(d.shapes[0].type, ShapeType::kRectangle);
  EXPECT_EQ(d.shapes[1].type, ShapeType::kMesh);  // a textured weight: Mitsuba's rectangle parameterisation
  EXPECT_TRUE(d.materials[b1.mix_b].flags & kTwoSided);
  EXPECT_NO_THROW(Scene::build(d));
  // principled: caustica's principled material (material/principled.h), every weight; eta from specular (0.5:
  // F0 0.04, eta 1.5) or given; anisotropy as Mitsuba's aspect; a texture roughness with metallic too.
  f = scene_file("principled.xml", kCamera +
      "<shape type=\"rectangle\"><bsdf type=\"principled\"><rgb name=\"base_color\" value=\"0.8, 0.2, 0.1\"/>"
      "<float name=\"roughness\" value=\"0.4\"/><float name=\"metallic\" value=\"0.25\"/>"
      "<float name=\"spec_trans\" value=\"0.5\"/><float name=\"anisotropic\" value=\"0.5\"/>"
      "<float name=\"clearcoat\" value=\"0.3\"/><float name=\"clearcoat_gloss\" value=\"0.6\"/>"
      "<float name=\"sheen\" value=\"0.2\"/><float name=\"sheen_tint\" value=\"0.7\"/>"
      "<float name=\"spec_tint\" value=\"0.1\"/><float name=\"flatness\" value=\"0.9\"/></bsdf></shape>\n"
      "<shape type=\"rectangle\"><bsdf type=\"principled\"><float name=\"eta\" value=\"1.33\"/>"
      "<float name=\"metallic\" value=\"1\"/>"
      "<texture type=\"bitmap\" name=\"roughness\"><string name=\"filename\" value=\"tex/t.pfm\"/></texture>"
      "</bsdf></shape>\n");
  d = load_mitsuba_scene(f);
  EXPECT_TRUE(d.warnings.empty());
  const Material& p0 = d.materials[d.shapes[0].material];
  EXPECT_EQ(p0.type, MaterialType::kPrincipled);
  EXPECT_EQ(p0.diffuse.x, 0.8f);
  EXPECT_EQ(p0.metallic, 0.25f);
  EXPECT_EQ(p0.transmission_weight, 0.5f);
  EXPECT_NEAR(p0.eta, 1.5f, 1e-5f);
  const float aspect = std::sqrt(1.f - 0.45f);
  EXPECT_NEAR(p0.alpha_x, 0.16f / aspect, 1e-6f);
  EXPECT_NEAR(p0.alpha_y, 0.16f * aspect, 1e-6f);
  EXPECT_EQ(p0.clearcoat, 0.3f);
  EXPECT_EQ(p0.clearcoat_gloss, 0.6f);
  EXPECT_EQ(p0.sheen, 0.2f);
  EXPECT_EQ(p0.sheen_tint, 0.7f);
  EXPECT_EQ(p0.spec_tint, 0.1f);
  EXPECT_EQ(p0.flatness, 0.9f);
  const Material& p1 = d.materials[d.shapes[1].material];
  EXPECT_EQ(p1.type, MaterialType::kPrincipled);
  EXPECT_NEAR(p1.eta, 1.33f, 1e-6f);
  EXPECT_EQ(p1.diffuse.x, 0.5f);  // Mitsuba's default base colour
  EXPECT_EQ(p1.metallic, 1.f);
  EXPECT_GE(p1.tex_roughness, 0);
  EXPECT_EQ(p1.alpha_x, 1.f);  // the texture is the roughness
  // Every weight takes a texture, read as its luminance (a grey copy of a colour image; a grey one as it is),
  // the weight 1 that it multiplies; anisotropic takes numbers only, and vertex colours only the base colour.
  write_pfm("tex/t.pfm");
  write_file("tex/grey.pfm", std::string("PF\n1 1\n-1.0\n") + std::string("\0\0\0?\0\0\0?\0\0\0?", 12));
  std::string weights;
  for (const char* k : {"metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint", "flatness", "clearcoat",
                        "clearcoat_gloss"})
    weights += std::string("<texture type=\"bitmap\" name=\"") + k +
               "\"><string name=\"filename\" value=\"tex/t.pfm\"/></texture>";
  f = scene_file("principled_tex.xml", kCamera + "<shape type=\"rectangle\"><bsdf type=\"principled\">" + weights +
                                       "<texture type=\"bitmap\" name=\"roughness\"><string name=\"filename\" "
                                       "value=\"tex/grey.pfm\"/></texture></bsdf></shape>\n");
  d = load_mitsuba_scene(f);
  const Material& pt = d.materials[d.shapes[0].material];
  const int32_t slots[] = {pt.tex_metallic, pt.tex_transmission, pt.tex_spec_tint, pt.tex_sheen, pt.tex_sheen_tint,
                           pt.tex_flatness, pt.tex_clearcoat, pt.tex_clearcoat_gloss};
  for (int32_t t : slots) {
    ASSERT_GE(t, 0);
    EXPECT_EQ(t, pt.tex_metallic);  // one grey copy of the one image
    EXPECT_NEAR(d.textures[size_t(t)].rgba[0], luminance(RGB(1.f, 2.f, 3.f)), 1e-6f);
    EXPECT_EQ(d.textures[size_t(t)].rgba[2], d.textures[size_t(t)].rgba[0]);
  }
  for (float w : {pt.metallic, pt.transmission_weight, pt.spec_tint, pt.sheen, pt.sheen_tint, pt.flatness,
                  pt.clearcoat, pt.clearcoat_gloss})
    EXPECT_EQ(w, 1.f);
  ASSERT_GE(pt.tex_roughness, 0);
  EXPECT_EQ(d.textures[size_t(pt.tex_roughness)].name.find("#luminance"), std::string::npos);  // grey: no copy
  EXPECT_EQ(d.textures[size_t(pt.tex_roughness)].rgba[1], 0.5f);
  EXPECT_TRUE(material_is_transmissive(pt));
  g = scene_file("principled_aniso_tex.xml", "<shape type=\"cube\"><bsdf type=\"principled\">\n<texture "
                 "type=\"bitmap\" name=\"anisotropic\"><string name=\"filename\" value=\"tex/t.pfm\"/></texture>"
                 "</bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":3: <texture type=\"bitmap\" name=\"anisotropic\">: anisotropic takes a number, "
                             "not a texture");
  g = scene_file("principled_vc.xml", "<shape type=\"cube\"><bsdf type=\"principled\">\n<texture "
                 "type=\"mesh_attribute\" name=\"sheen\"><string name=\"name\" value=\"vertex_color\"/></texture>"
                 "</bsdf></shape>\n");
  EXPECT_NE(error_of(g).find("a mesh_attribute texture is supported as a BSDF's colour only"), std::string::npos)
      << error_of(g);
  // The same texture as the base colour and a weight (one id): the weight's slot is still refused.
  g = scene_file("principled_vc_ref.xml", "<texture type=\"mesh_attribute\" id=\"vc\"><string name=\"name\" "
                 "value=\"vertex_color\"/></texture>\n<shape type=\"cube\"><bsdf type=\"principled\">"
                 "<ref name=\"base_color\" id=\"vc\"/><ref name=\"sheen\" id=\"vc\"/></bsdf></shape>\n");
  EXPECT_NE(error_of(g).find("a mesh_attribute texture is supported as a BSDF's colour only"), std::string::npos)
      << error_of(g);
  g = scene_file("blend_one.xml", "<shape type=\"cube\"><bsdf type=\"blendbsdf\">\n<bsdf type=\"diffuse\"/></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":2: <bsdf type=\"blendbsdf\">: expected two nested <bsdf> or <ref> elements (got 1)");
  // twosided around a blend: the blend of two-sided copies; a transmissive BSDF inside is refused as alone.
  f = scene_file("blend_twosided.xml", kCamera + "<shape type=\"cube\"><bsdf type=\"twosided\">\n<bsdf type=\"blendbsdf\">"
                                       "<bsdf type=\"diffuse\"/><bsdf type=\"plastic\"/></bsdf></bsdf></shape>\n");
  d = load_mitsuba_scene(f);
  const Material& b2 = d.materials[d.shapes[0].material];
  ASSERT_GE(b2.mix_b, 0);
  EXPECT_TRUE(d.materials[b2.mix_a].flags & kTwoSided);
  EXPECT_TRUE(d.materials[b2.mix_b].flags & kTwoSided);
  EXPECT_EQ(d.materials[b2.mix_b].type, MaterialType::kPlastic);
  g = scene_file("blend_twosided_glass.xml", "<shape type=\"cube\"><bsdf type=\"twosided\">\n<bsdf type=\"blendbsdf\">"
                                             "<bsdf type=\"diffuse\"/><bsdf type=\"dielectric\"/></bsdf></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":3: <bsdf type=\"blendbsdf\">: twosided applies to reflecting BSDFs only (diffuse, "
                             "conductor, roughconductor, plastic, roughplastic, principled without spec_trans)");
  g = scene_file("mask_nobsdf.xml", "<shape type=\"cube\"><bsdf type=\"mask\">\n</bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":2: <bsdf type=\"mask\">: expected a nested <bsdf> or <ref>");
  g = scene_file("mask_range.xml", "<shape type=\"cube\"><bsdf type=\"mask\">\n<float name=\"opacity\" value=\"2\"/>"
                                   "<bsdf type=\"diffuse\"/></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":3: <float name=\"opacity\">: expected an opacity in [0, 1]");
  g = scene_file("wrap_notex.xml", "<shape type=\"cube\"><bsdf type=\"bumpmap\">\n<bsdf type=\"diffuse\"/></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":2: <bsdf type=\"bumpmap\">: expected a nested <texture> (the height map)");
  g = scene_file("wrap_nobsdf.xml", "<shape type=\"cube\"><bsdf type=\"normalmap\">\n<texture type=\"bitmap\">"
                                    "<string name=\"filename\" value=\"tex/t.pfm\"/></texture></bsdf></shape>\n");
  EXPECT_EQ(error_of(g), g + ":2: <bsdf type=\"normalmap\">: expected a nested <bsdf> or <ref>");
}

TEST(MitsubaBsdf, Errors) {
  struct Case {
    std::string body, message;
  };
  std::vector<Case> cases = {
      {"<bsdf type=\"velvet\" id=\"v\"/>\n",
       ":2: <bsdf type=\"velvet\" id=\"v\">: unsupported BSDF type (supported: diffuse, conductor, roughconductor, "
       "dielectric, roughdielectric, thindielectric, plastic, roughplastic, principled, twosided, normalmap, bumpmap, mask, blendbsdf, null)"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<rgb name=\"reflectanse\" value=\"1\"/></bsdf>\n",
       ":3: <rgb name=\"reflectanse\">: unknown property of bsdf diffuse (supported: reflectance)"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<rgb name=\"reflectance\" value=\"1, 2\"/></bsdf>\n",
       ":3: <rgb name=\"reflectance\">: expected \"r, g, b\" or one value, got '1, 2'"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<rgb name=\"reflectance\" value=\"-1\"/></bsdf>\n",
       ":3: <rgb name=\"reflectance\">: expected non-negative values"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<spectrum name=\"reflectance\" value=\"700:0.1, 400:0.9\"/></bsdf>\n",
       ":3: <spectrum name=\"reflectance\">: the wavelengths must increase (700 then 400)"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<rgb name=\"reflectance\" value=\"0.5\"/>\n<rgb name=\"reflectance\" "
       "value=\"0.5\"/></bsdf>\n",
       ":4: <rgb name=\"reflectance\">: property 'reflectance' is given twice (first at FILE:3)"},
      {"<bsdf type=\"conductor\" id=\"v\">\n<string name=\"material\" value=\"Unobtainium\"/></bsdf>\n",
       ":3: <string name=\"material\">: unknown conductor material 'Unobtainium' (known: none, a-C, Ag, Al, AlAs, AlSb, "
       "Au, Be, Cr, CsI, Cu, Cu2O, CuO, d-C, Hg, HgTe, Ir, K, Li, MgO, Mo, Na_palik, Nb, Ni_palik, Rh, Se, Se-e, SiC, "
       "SnTe, Ta, Te, Te-e, ThF4, TiC, TiN, TiO2, TiO2-e, V_palik, VC, VN, W)"},
      {"<bsdf type=\"conductor\" id=\"v\">\n<string name=\"material\" value=\"Au\"/><rgb name=\"eta\" value=\"1\"/></bsdf>\n",
       ":2: <bsdf type=\"conductor\" id=\"v\">: give either 'material' or eta/k, not both"},
      {"<bsdf type=\"roughplastic\" id=\"v\">\n<float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" "
       "value=\"0.2\"/></bsdf>\n",
       ":3: <float name=\"alpha_u\">: this BSDF's roughness is isotropic (expected alpha)"},
      {"<bsdf type=\"roughconductor\" id=\"v\">\n<float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha\" "
       "value=\"0.2\"/></bsdf>\n",
       ":2: <bsdf type=\"roughconductor\" id=\"v\">: give either alpha or alpha_u/alpha_v, not both"},
      {"<bsdf type=\"roughconductor\" id=\"v\">\n<string name=\"distribution\" value=\"phong\"/></bsdf>\n",
       ":3: <string name=\"distribution\">: unknown distribution 'phong' (allowed: beckmann, ggx)"},
      {"<bsdf type=\"dielectric\" id=\"v\">\n<string name=\"int_ior\" value=\"glass\"/></bsdf>\n",
       ":3: <string name=\"int_ior\">: unknown index of refraction 'glass' (known: vacuum, helium, hydrogen, air, carbon "
       "dioxide, water, acetone, ethanol, carbon tetrachloride, glycerol, benzene, silicone oil, bromine, water ice, "
       "fused quartz, pyrex, acrylic glass, polypropylene, bk7, sodium chloride, amber, pet, diamond)"},
      {"<bsdf type=\"dielectric\" id=\"v\">\n<float name=\"int_ior\" value=\"0.5\"/></bsdf>\n",
       ":3: <float name=\"int_ior\">: expected an index of refraction >= 1"},
      {"<bsdf type=\"twosided\" id=\"v\">\n<bsdf type=\"dielectric\"/></bsdf>\n",
       ":3: <bsdf type=\"dielectric\">: twosided applies to reflecting BSDFs only (diffuse, conductor, roughconductor, "
       "plastic, roughplastic, principled without spec_trans)"},
      {"<bsdf type=\"twosided\" id=\"v\">\n<bsdf type=\"diffuse\"/>\n<bsdf type=\"diffuse\"/>\n<bsdf type=\"diffuse\"/></bsdf>\n",
       ":5: <bsdf type=\"diffuse\">: a twosided takes one BSDF, or two (front, back)"},
      {"<bsdf type=\"twosided\" id=\"v\">\n<bsdf type=\"diffuse\"/>\n<bsdf type=\"roughdielectric\"/></bsdf>\n",
       ":4: <bsdf type=\"roughdielectric\">: twosided applies to reflecting BSDFs only (diffuse, conductor, roughconductor, "
       "plastic, roughplastic, principled without spec_trans)"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<float value=\"1\"/></bsdf>\n", ":3: <float>: missing attribute 'name'"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<float name=\"reflectance\"/></bsdf>\n",
       ":3: <float name=\"reflectance\">: missing attribute 'value'"},
      {"<bsdf type=\"diffuse\" id=\"v\">\n<float name=\"reflectance\" value=\"abc\"/></bsdf>\n",
       ":3: <float name=\"reflectance\">: expected a number, got 'abc'"},
      {"<bsdf type=\"plastic\" id=\"v\">\n<integer name=\"nonlinear\" value=\"1\"/></bsdf>\n",
       ":3: <integer name=\"nonlinear\">: expected a <boolean>"},
      {"<bsdf type=\"plastic\" id=\"v\">\n<boolean name=\"nonlinear\" value=\"yes\"/></bsdf>\n",
       ":3: <boolean name=\"nonlinear\">: expected true or false, got 'yes'"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    std::string f = scene_file("bsdf_err" + std::to_string(i) + ".xml", cases[i].body);
    std::string msg = cases[i].message;
    size_t k = msg.find("FILE");
    if (k != std::string::npos) msg.replace(k, 4, f);
    EXPECT_EQ(error_of(f), f + msg) << "case " << i;
  }
}

// ---------------------------------------------------------------------------
// Shapes.

TEST(MitsubaShape, EmittersWithoutABsdfReflectNothing) {
  // Mitsuba 3 gives an emitter's shape without a BSDF a black diffuse one, other shapes diffuse 0.5.
  std::string f = scene_file("emitter_bsdf.xml", kCamera +
      "<shape type=\"rectangle\"><emitter type=\"area\"/></shape>\n<shape type=\"cube\"/>\n"
      "<shape type=\"disk\"><bsdf type=\"diffuse\"/><emitter type=\"area\"/></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 3u);
  expect_vec_near(d.materials[d.shapes[0].material].diffuse, {0, 0, 0}, 0.f);
  expect_vec_near(d.materials[d.shapes[1].material].diffuse, {0.5f, 0.5f, 0.5f}, 0.f);
  expect_vec_near(d.materials[d.shapes[2].material].diffuse, {0.5f, 0.5f, 0.5f}, 0.f);  // its own BSDF
}

TEST(MitsubaShape, LocalShapesAndEmitters) {
  std::string f = scene_file("shapes.xml", kCamera +
      "<shape type=\"sphere\" id=\"ball\"><point name=\"center\" value=\"1, 2, 3\"/><float name=\"radius\" value=\"0.5\"/>"
      "<boolean name=\"flip_normals\" value=\"true\"/>"
      "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1 2 3\"/></emitter></shape>\n"
      "<shape type=\"disk\"><transform name=\"to_world\"><scale value=\"2\"/></transform>"
      "<emitter type=\"area\"><spectrum name=\"radiance\" value=\"5\"/></emitter></shape>\n"
      "<shape type=\"cube\"><emitter type=\"area\"><spectrum name=\"radiance\" value=\"400:2, 500:2, 600:2\"/></emitter></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 3u);
  EXPECT_EQ(d.shapes[0].name, "ball");
  EXPECT_EQ(d.shapes[0].type, ShapeType::kSphere);
  expect_vec_near(d.shapes[0].center, {1, 2, 3}, 0.f);
  EXPECT_EQ(d.shapes[0].radius, 0.5f);
  EXPECT_TRUE(d.shapes[0].flip_normals);
  expect_vec_near(d.shapes[0].emission, {1, 2, 3}, 0.f);
  EXPECT_EQ(d.shapes[1].type, ShapeType::kDisk);
  // Mitsuba 3.9.1's reductions (tests/python/test_mitsuba_spectra.py): a single value on an emitter is the
  // equal-energy white of that luminance, XYZ = (5, 5, 5); 2 from 400 to 600 nm is (0.461936, 1.98875, 1.83486).
  expect_vec_near(d.shapes[1].emission, RGB(1.204794f, 0.948291f, 0.908916f) * 5.f, 1e-5f);
  EXPECT_FALSE(d.shapes[1].emission_two_sided);
  expect_vec_near(d.shapes[2].emission, {0.461936f, 1.98875f, 1.83486f}, 2e-5f);
  EXPECT_NO_THROW(Scene::build(d));
}

TEST(MitsubaShape, Meshes) {
  write_file("mesh/tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n");
  write_file("mesh/quad.ply",
             "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
  std::string f = scene_file("meshes.xml", kCamera +
      "<shape type=\"obj\" id=\"tri\"><string name=\"filename\" value=\"mesh/tri.obj\"/>"
      "<boolean name=\"face_normals\" value=\"true\"/><transform name=\"to_world\"><translate x=\"5\"/></transform>"
      "<bsdf type=\"diffuse\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"4\"/></emitter></shape>\n"
      "<shape type=\"ply\" id=\"quad\"><string name=\"filename\" value=\"mesh/quad.ply\"/></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 2u);
  EXPECT_EQ(d.shapes[0].name, "tri");
  EXPECT_EQ(d.shapes[0].type, ShapeType::kMesh);
  expect_vec_near(d.shapes[0].to_world.point({0, 0, 0}), {5, 0, 0});
  expect_vec_near(d.shapes[0].emission, RGB(4.f), 0.f);
  EXPECT_TRUE(d.meshes[d.shapes[0].mesh].normals.empty());  // face_normals
  EXPECT_EQ(d.meshes[d.shapes[0].mesh].indices.size(), 3u);
  EXPECT_EQ(d.shapes[1].name, "quad");
  EXPECT_EQ(d.meshes[d.shapes[1].mesh].indices.size(), 6u);
  EXPECT_EQ(d.material_names[d.shapes[1].material], "default");
  EXPECT_NO_THROW(Scene::build(d));
}

TEST(MitsubaShape, Errors) {
  std::string f = scene_file("shape_err1.xml", "<shape type=\"bsplinecurve\"/>\n");
  EXPECT_EQ(error_of(f), f + ":2: <shape type=\"bsplinecurve\">: unsupported shape type (supported: obj, ply, "
                             "serialized, rectangle, cube, disk, sphere, cylinder, shapegroup, instance)");
  f = scene_file("shape_err2.xml", "<shape type=\"obj\">\n<string name=\"filename\" value=\"no/such.obj\"/></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <string name=\"filename\">: mesh file '" + (tmp_dir() / "no/such.obj").string() +
                             "' does not exist");
  f = scene_file("shape_err3.xml", "<shape type=\"ply\"/>\n");
  EXPECT_EQ(error_of(f), f + ":2: <shape type=\"ply\">: missing <string name=\"filename\">");
  f = scene_file("shape_err4.xml", "<shape type=\"sphere\"><transform name=\"to_world\">\n"
                                   "<scale x=\"1\" y=\"2\"/></transform>\n</shape>\n");
  EXPECT_EQ(error_of(f), f + ":2: <shape type=\"sphere\">: a sphere's to_world must scale uniformly (caustica's spheres "
                             "are exact spheres)");
  f = scene_file("shape_err5.xml", "<shape type=\"sphere\">\n<float name=\"radius\" value=\"0\"/></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <float name=\"radius\">: expected a positive radius");
  f = scene_file("shape_err6.xml", "<shape type=\"cube\">\n<emitter type=\"point\"/></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <emitter type=\"point\">: only an area emitter can be attached to a shape");
  f = scene_file("shape_err7.xml", "<shape type=\"cube\">\n<medium type=\"grid\" name=\"interior\"/></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <medium type=\"grid\" name=\"interior\">: unsupported medium type (supported: "
                             "homogeneous, heterogeneous)");
  f = scene_file("shape_err8.xml", "<shape type=\"cube\">\n<float name=\"radius\" value=\"1\"/></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <float name=\"radius\">: unknown property of shape cube (supported: to_world, "
                             "flip_normals, interior, exterior)");
  f = scene_file("shape_err9.xml", "<shape type=\"cube\">\n<bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <bsdf type=\"diffuse\">: a shape takes one BSDF");
  f = scene_file("shape_err10.xml", "<shape type=\"cube\">\n<sensor type=\"perspective\"/></shape>\n");
  EXPECT_EQ(error_of(f), f + ":3: <sensor type=\"perspective\">: unexpected element in <shape type=\"cube\">");
}

// ---------------------------------------------------------------------------
// Emitters.

TEST(MitsubaEmitter, Lights) {
  std::string env = write_pfm("env/sky.pfm");
  std::string f = scene_file("emitters.xml", kCamera + "<shape type=\"cube\"/>\n"
      "<emitter type=\"point\"><point name=\"position\" value=\"1, 2, 3\"/><rgb name=\"intensity\" value=\"4\"/></emitter>\n"
      "<emitter type=\"point\"><transform name=\"to_world\"><translate x=\"7\"/></transform></emitter>\n"
      "<emitter type=\"spot\"><transform name=\"to_world\"><lookat origin=\"0 5 0\" target=\"0 0 0\" up=\"0 0 1\"/></transform>"
      "<float name=\"cutoff_angle\" value=\"30\"/><float name=\"beam_width\" value=\"20\"/><rgb name=\"intensity\" value=\"9\"/></emitter>\n"
      "<emitter type=\"directional\"><vector name=\"direction\" x=\"0\" y=\"-2\" z=\"0\"/><rgb name=\"irradiance\" value=\"3\"/></emitter>\n"
      "<emitter type=\"envmap\"><string name=\"filename\" value=\"env/sky.pfm\"/><float name=\"scale\" value=\"2\"/>"
      "<transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/></transform></emitter>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.lights.size(), 5u);
  EXPECT_EQ(d.lights[0].type, LightType::kPoint);
  expect_vec_near(d.lights[0].p, {1, 2, 3}, 0.f);
  expect_vec_near(d.lights[0].L, RGB(4.f), 0.f);
  expect_vec_near(d.lights[1].p, {7, 0, 0}, 0.f);
  expect_vec_near(d.lights[1].L, RGB(1.f), 0.f);
  EXPECT_EQ(d.lights[2].type, LightType::kSpot);
  expect_vec_near(d.lights[2].p, {0, 5, 0});
  expect_vec_near(d.lights[2].dir, {0, -1, 0});
  EXPECT_NEAR(d.lights[2].cos_total, std::cos(30.0 * M_PI / 180.0), 1e-6);
  EXPECT_NEAR(d.lights[2].cos_falloff_start, std::cos(20.0 * M_PI / 180.0), 1e-6);
  EXPECT_TRUE(d.lights[2].spot_linear_angle);  // Mitsuba's falloff: linear in the angle
  // Half way between 20 and 30 degrees, half the intensity; a quarter of the way in, 3/4 (light/light.h).
  EXPECT_NEAR(spot_falloff(d.lights[2], float(std::cos(25.0 * M_PI / 180.0))), 0.5f, 1e-5f);
  EXPECT_NEAR(spot_falloff(d.lights[2], float(std::cos(22.5 * M_PI / 180.0))), 0.75f, 1e-5f);
  EXPECT_EQ(spot_falloff(d.lights[2], float(std::cos(19.0 * M_PI / 180.0))), 1.f);
  EXPECT_EQ(spot_falloff(d.lights[2], float(std::cos(31.0 * M_PI / 180.0))), 0.f);
  EXPECT_TRUE(d.warnings.empty()) << all_warnings(d);
  EXPECT_EQ(d.lights[3].type, LightType::kDirectional);
  expect_vec_near(d.lights[3].dir, {0, -1, 0}, 0.f);
  expect_vec_near(d.lights[3].L, RGB(3.f), 0.f);
  EXPECT_EQ(d.lights[4].type, LightType::kEnvironment);
  expect_vec_near(d.lights[4].L, RGB(2.f), 0.f);
  ASSERT_GE(d.lights[4].texture, 0);
  EXPECT_EQ(d.textures[d.lights[4].texture].name, env);
  EXPECT_FALSE(d.textures[d.lights[4].texture].srgb);
  expect_vec_near(d.environment_to_world.vector({1, 0, 0}), {0, 0, -1});

  std::string g = scene_file("constant.xml", kCamera + "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.5\"/></emitter>\n");
  SceneDesc c = load_mitsuba_scene(g);
  ASSERT_EQ(c.lights.size(), 1u);
  EXPECT_EQ(c.lights[0].type, LightType::kEnvironment);
  EXPECT_EQ(c.lights[0].texture, -1);
  expect_vec_near(c.lights[0].L, RGB(0.5f), 0.f);
}

TEST(MitsubaEmitter, Errors) {
  std::string f = scene_file("em_err1.xml", "<emitter type=\"constant\"/>\n<emitter type=\"constant\"/>\n");
  EXPECT_EQ(error_of(f), f + ":3: <emitter type=\"constant\">: only one environment emitter (constant or envmap) is supported");
  f = scene_file("em_err2.xml", "<emitter type=\"area\"/>\n");
  EXPECT_EQ(error_of(f), f + ":2: <emitter type=\"area\">: an area emitter must be nested in a <shape>");
  f = scene_file("em_err3.xml", "<emitter type=\"sunsky\"/>\n");
  EXPECT_EQ(error_of(f), f + ":2: <emitter type=\"sunsky\">: unsupported emitter type (supported: area (in a shape), "
                             "point, spot, directional, constant, envmap)");
  f = scene_file("em_err4.xml", "<emitter type=\"envmap\">\n<string name=\"filename\" value=\"sky.exr\"/></emitter>\n");
  EXPECT_EQ(error_of(f), f + ":3: <string name=\"filename\">: environment map '" + (tmp_dir() / "sky.exr").string() +
                             "' does not exist");
  f = scene_file("em_err5.xml", "<emitter type=\"point\">\n<point name=\"position\" value=\"1 2 3\"/>"
                                "<transform name=\"to_world\"/></emitter>\n");
  EXPECT_EQ(error_of(f), f + ":2: <emitter type=\"point\">: give either position or to_world, not both");
}

// ---------------------------------------------------------------------------
// Sensor, film, integrator.

TEST(MitsubaSensor, ReconstructionFilters) {
  struct Case {
    const char* rfilter;
    Filter expected;
  };
  const float d = kFilterDefault;
  const Case cases[] = {
      {"<rfilter type=\"box\"/>", make_filter(FilterType::kBox)},
      {"<rfilter type=\"tent\"><float name=\"radius\" value=\"2.5\"/></rfilter>", make_filter(FilterType::kTent, 2.5f)},
      {"<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"0.3\"/></rfilter>",
       make_filter(FilterType::kGaussian, 1.2f, 0.3f)},  // radius 4 stddev, as Mitsuba's
      {"<rfilter type=\"mitchell\"/>", make_filter(FilterType::kMitchell, 2.f, 1.f / 3.f, 1.f / 3.f)},
      {"<rfilter type=\"mitchell\"><float name=\"B\" value=\"0.2\"/><float name=\"C\" value=\"0.4\"/></rfilter>",
       make_filter(FilterType::kMitchell, d, 0.2f, 0.4f)},
      {"<rfilter type=\"catmullrom\"/>", make_filter(FilterType::kMitchell, 2.f, 0.f, 0.5f)},
      {"<rfilter type=\"lanczos\"/>", make_filter(FilterType::kLanczos, 3.f, 3.f)},
      {"<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"2\"/></rfilter>", make_filter(FilterType::kLanczos, 2.f, 2.f)},
      {"", make_filter(FilterType::kGaussian, 2.f, 0.5f)},  // no rfilter: Mitsuba's default gaussian
  };
  int k = 0;
  for (const Case& c : cases) {
    std::string f = scene_file("rfilter" + std::to_string(k++) + ".xml",
                               std::string("<shape type=\"cube\"/>\n<sensor type=\"perspective\"><film type=\"hdrfilm\">") +
                                   c.rfilter + "</film></sensor>\n");
    SceneDesc s = load_mitsuba_scene(f);
    EXPECT_TRUE(s.filter == c.expected) << c.rfilter << ": type " << int(s.filter.type) << " radius " << s.filter.radius
                                        << " a " << s.filter.a << " b " << s.filter.b;
  }
}

TEST(MitsubaSensor, Cameras) {
  std::string f = scene_file("sensors.xml", "<shape type=\"cube\"/>\n"
      "<sensor type=\"perspective\" id=\"wide\"><float name=\"fov\" value=\"60\"/><string name=\"fov_axis\" value=\"larger\"/>"
      "<transform name=\"to_world\"><scale x=\"-1\"/><lookat origin=\"0 0 5\" target=\"0 0 0\" up=\"0 1 0\"/></transform>"
      "<film type=\"hdrfilm\"><integer name=\"width\" value=\"100\"/><integer name=\"height\" value=\"50\"/>"
      "<rfilter type=\"tent\"/></film></sensor>\n"
      "<sensor type=\"thinlens\" id=\"lens\"><float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"diagonal\"/>"
      "<float name=\"aperture_radius\" value=\"0.1\"/><float name=\"focus_distance\" value=\"4\"/>"
      "<film type=\"hdrfilm\"><integer name=\"width\" value=\"200\"/><integer name=\"height\" value=\"100\"/></film></sensor>\n"
      "<sensor type=\"perspective\" id=\"lens50\"/>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.cameras.size(), 3u);
  EXPECT_EQ(d.camera.name, "wide");
  EXPECT_EQ(d.filter.type, FilterType::kTent);
  const CameraDesc& a = d.cameras[0];
  expect_vec_near(a.position, {0, 0, 5});
  expect_vec_near(a.target, {0, 0, 4});
  expect_vec_near(a.up, {0, 1, 0});
  EXPECT_TRUE(a.flip_x);  // the mirrored frame
  EXPECT_EQ(a.fov_axis, CameraDesc::FovAxis::kX);
  EXPECT_FLOAT_EQ(a.fov_degrees, 60.f);
  EXPECT_EQ(a.width, 100);
  const CameraDesc& b = d.cameras[1];
  EXPECT_FALSE(b.flip_x);
  expect_vec_near(b.target, {0, 0, 1});  // identity: looks along +z
  EXPECT_EQ(b.fov_axis, CameraDesc::FovAxis::kX);
  // Mitsuba 3.9.1 reports x_fov = 36.0648 for fov 40 on the diagonal of a 200 x 100 film.
  EXPECT_NEAR(b.fov_degrees, 36.0648f, 1e-3f);
  EXPECT_FLOAT_EQ(b.aperture_radius, 0.1f);
  EXPECT_FLOAT_EQ(b.focus_distance, 4.f);
  // No fov: a 50 mm lens; Mitsuba 3.9.1 reports x_fov = 38.1848 on its default 768 x 576 film.
  const CameraDesc& c = d.cameras[2];
  EXPECT_NEAR(c.fov_degrees, 38.1848f, 1e-3f);
  EXPECT_EQ(c.width, 768);
  EXPECT_EQ(c.height, 576);
  select_camera(d, "lens");
  EXPECT_FLOAT_EQ(d.camera.aperture_radius, 0.1f);
}

TEST(MitsubaSensor, Orthographic) {
  // Mitsuba's orthographic sensor sees [-1, 1] x [-1/aspect, 1/aspect] of its plane, scaled by to_world.
  std::string f = scene_file("ortho.xml", "<shape type=\"cube\"/>\n"
      "<sensor type=\"orthographic\"><transform name=\"to_world\"><scale x=\"3\" y=\"3\"/>"
      "<lookat origin=\"0 0 5\" target=\"0 0 0\" up=\"0 1 0\"/></transform>"
      "<film type=\"hdrfilm\"><integer name=\"width\" value=\"200\"/><integer name=\"height\" value=\"100\"/></film>"
      "</sensor>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.cameras.size(), 1u);
  const CameraDesc& c = d.camera;
  EXPECT_TRUE(c.orthographic);
  EXPECT_FLOAT_EQ(c.view_size, 6.f);
  EXPECT_EQ(c.fov_axis, CameraDesc::FovAxis::kX);
  expect_vec_near(c.position, {0, 0, 5});
  expect_vec_near(c.target, {0, 0, 4});
  expect_vec_near(c.up, {0, 1, 0});
  Camera cam = make_camera(c);
  EXPECT_TRUE(cam.orthographic);
  EXPECT_FLOAT_EQ(cam.tan_half_x, 3.f);
  EXPECT_FLOAT_EQ(cam.tan_half_y, 1.5f);
}

TEST(MitsubaSensor, DefaultCameraAndIntegrator) {
  std::string f = scene_file("nosensor.xml", "<integrator type=\"volpath\"><integer name=\"max_depth\" value=\"-1\"/>"
                                             "<integer name=\"rr_depth\" value=\"10\"/></integrator>\n"
                                             "<shape type=\"cube\"/>\n");
  SceneDesc d = load_mitsuba_scene(f);
  EXPECT_EQ(d.max_depth, -1);
  expect_vec_near(d.camera.target - d.camera.position, {0, 0, 1});
  EXPECT_EQ(d.camera.width, 768);
  EXPECT_TRUE(has_warning(d, f + ": no sensor in the file; using Mitsuba's default camera (fov 45, looking along +z at "
                                 "the scene)"))
      << all_warnings(d);
  EXPECT_EQ(d.integrator.rr_depth, 10);  // the scene's default Russian-roulette depth
  EXPECT_EQ(d.integrator.hide_emitters, -1);  // not given
  for (const char* v : {"true", "false"}) {
    std::string g = scene_file("hide.xml", std::string("<integrator type=\"path\"><boolean name=\"hide_emitters\" "
                                                       "value=\"") + v + "\"/></integrator>\n<shape type=\"cube\"/>\n");
    EXPECT_EQ(load_mitsuba_scene(g).integrator.hide_emitters, std::string(v) == "true" ? 1 : 0) << v;
  }
  EXPECT_TRUE(d.lights.empty());  // no light is invented: the image is black, as in Mitsuba
}

TEST(MitsubaSensor, Errors) {
  struct Case {
    std::string body, message;
  };
  std::vector<Case> cases = {
      {"<sensor type=\"radiancemeter\"/>\n",
       ":2: <sensor type=\"radiancemeter\">: unsupported sensor type (supported: perspective, thinlens, orthographic)"},
      {"<sensor type=\"orthographic\"><transform name=\"to_world\"><scale x=\"2\" y=\"3\"/></transform></sensor>\n",
       ":2: <sensor type=\"orthographic\">: an orthographic sensor's to_world must scale x and y alike (caustica's "
       "pixels are square)"},
      {"<sensor type=\"orthographic\"><float name=\"fov\" value=\"30\"/></sensor>\n",
       ":2: <float name=\"fov\">: unknown property of sensor orthographic (supported: to_world, near_clip, far_clip)"},
      {"<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><rfilter type=\"bicubic\"/></film></sensor>\n",
       ":3: <rfilter type=\"bicubic\">: unsupported reconstruction filter (supported: box, tent, gaussian, mitchell, "
       "catmullrom, lanczos)"},
      {"<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><rfilter type=\"gaussian\"><float name=\"stddev\" "
       "value=\"0\"/></rfilter></film></sensor>\n",
       ":3: <float name=\"stddev\">: the gaussian filter's stddev must be positive"},
      {"<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><rfilter type=\"tent\"><float name=\"radius\" "
       "value=\"40\"/></rfilter></film></sensor>\n",
       ":3: <float name=\"radius\">: a pixel filter's radius must be in [0.001, 16] pixels"},
      {"<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><rfilter type=\"mitchell\"><float name=\"radius\" "
       "value=\"3\"/></rfilter></film></sensor>\n",
       ":3: <float name=\"radius\">: unknown property of rfilter mitchell (supported: B, C)"},
      {"<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><integer name=\"width\" value=\"0\"/></film></sensor>\n",
       ":3: <integer name=\"width\">: expected a positive width"},
      {"<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><float name=\"width\" value=\"10\"/></film></sensor>\n",
       ":3: <float name=\"width\">: expected an <integer>"},
      {"<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><integer name=\"crop_width\" value=\"1000\"/></film></sensor>\n",
       ":3: <film type=\"hdrfilm\">: the crop window (x 0, y 0, width 1000, height 576) does not fit the 768x576 film "
       "(expected x, y >= 0, width, height > 0, x + width <= 768, y + height <= 576)"},
      {"<sensor type=\"perspective\">\n<float name=\"near_clip\" value=\"-1\"/></sensor>\n",
       ":3: <float name=\"near_clip\">: expected a depth >= 0"},
      {"<sensor type=\"perspective\">\n<float name=\"near_clip\" value=\"2\"/><float name=\"far_clip\" value=\"1\"/></sensor>\n",
       ":3: <float name=\"far_clip\">: expected far_clip beyond near_clip"},
      {"<sensor type=\"perspective\">\n<string name=\"fov_axis\" value=\"z\"/></sensor>\n",
       ":3: <string name=\"fov_axis\">: fov_axis applies only together with fov"},
      {"<sensor type=\"perspective\">\n<float name=\"fvo\" value=\"40\"/></sensor>\n",
       ":3: <float name=\"fvo\">: unknown property of sensor perspective (supported: fov, fov_axis, focal_length, "
       "to_world, near_clip, far_clip, focus_distance)"},
      {"<sensor type=\"perspective\">\n<float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"z\"/></sensor>\n",
       ":3: <string name=\"fov_axis\">: unknown fov_axis 'z' (allowed: x, y, smaller, larger, diagonal)"},
      {"<sensor type=\"perspective\">\n<float name=\"fov\" value=\"180\"/></sensor>\n",
       ":3: <float name=\"fov\">: expected degrees in (0, 180)"},
      {"<sensor type=\"perspective\">\n<transform name=\"to_world\"><scale value=\"2\"/></transform></sensor>\n",
       ":2: <sensor type=\"perspective\">: the camera's to_world must be a rotation and translation (Mitsuba allows no "
       "scale here either)"},
      {"<sensor type=\"thinlens\">\n</sensor>\n", ":2: <sensor type=\"thinlens\">: missing <float name=\"aperture_radius\">"},
      {"<integrator type=\"bdpt\"/>\n",
       ":2: <integrator type=\"bdpt\">: unsupported integrator (supported: path, volpath, volpathmis, direct, "
       "ptracer, and the differentiable prb, prb_basic, prbvolpath, prb_projective, direct_projective)"},
      {"<integrator type=\"path\">\n<integer name=\"max_depth\" value=\"0\"/></integrator>\n",
       ":3: <integer name=\"max_depth\">: expected a positive max_depth or -1 (unlimited)"},
      {"<integrator type=\"path\">\n<boolean name=\"hide_emitters\" value=\"yes\"/></integrator>\n",
       ":3: <boolean name=\"hide_emitters\">: expected true or false, got 'yes'"},
      {"<integrator type=\"path\"/>\n<integrator type=\"path\"/>\n",
       ":3: <integrator type=\"path\">: a scene takes one integrator"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    std::string f = scene_file("sensor_err" + std::to_string(i) + ".xml", cases[i].body);
    EXPECT_EQ(error_of(f), f + cases[i].message) << "case " << i;
  }
}

// ---------------------------------------------------------------------------
// Files.

TEST(MitsubaFile, Errors) {
  std::string f = write_file("file_err1.xml", "<scene version=\"3.0.0\">\n  <shape type=\"cube\">\n</scene>\n");
  EXPECT_EQ(error_of(f), f + ":3: invalid XML: Start-end tags mismatch");
  f = write_file("file_err2.xml", "<?xml version=\"1.0\"?>\n<scene_x version=\"3.0.0\"/>\n");
  EXPECT_EQ(error_of(f), f + ":2: <scene_x>: expected a <scene> root element");
  f = write_file("file_err3.xml", "<scene version=\"0.6.0\">\n</scene>\n");
  EXPECT_EQ(error_of(f), f + ":1: <scene>: version 0.6.0 is a Mitsuba 0.x scene; caustica reads the Mitsuba 3 format "
                             "(convert it with Mitsuba 3 first)");
  f = write_file("file_err4.xml", "<scene version=\"3.0.0\">\n<camera type=\"perspective\"/>\n</scene>\n");
  EXPECT_EQ(error_of(f), f + ":2: <camera type=\"perspective\">: unexpected element in <scene> (expected default, "
                             "include, path, bsdf, texture, medium, shape, emitter, sensor, integrator)");
  f = write_file("file_err5.xml", "<scene version=\"3.0.0\">\n<medium type=\"homogeneous\"/>\n</scene>\n");
  EXPECT_EQ(error_of(f), f + ":2: <medium type=\"homogeneous\">: a top-level medium needs an id");
  f = write_file("file_err6.xml", "<scene version=\"3.0.0\" foo=\"1\">\n</scene>\n");
  EXPECT_EQ(error_of(f), f + ":1: <scene>: unknown attribute 'foo' (allowed: version)");
  f = write_file("file_err7.xml", "");
  EXPECT_EQ(error_of(f), f + ":1: invalid XML: No document element found");
  std::string missing = (tmp_dir() / "does_not_exist.xml").string();
  EXPECT_EQ(error_of(missing), missing + ": cannot open the file");
}

TEST(MitsubaShape, TopLevelTextureAndZeroSphere) {
  write_pfm("tl/t.pfm");
  std::string f = scene_file("toplevel.xml", kCamera +
      "<texture type=\"bitmap\" id=\"wood\"><string name=\"filename\" value=\"tl/t.pfm\"/></texture>\n"
      "<shape type=\"cube\"><bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"wood\"/></bsdf></shape>\n"
      "<shape type=\"sphere\"><transform name=\"to_world\"><scale value=\"0\"/></transform></shape>\n");
  SceneDesc d = load_mitsuba_scene(f);
  ASSERT_EQ(d.shapes.size(), 1u);  // the zero-size sphere is skipped
  const Material& m = d.materials[d.shapes[0].material];
  ASSERT_GE(m.tex_color, 0);
  EXPECT_EQ(d.textures[m.tex_color].width, 2);
  EXPECT_TRUE(has_warning(d, f + ":5: <shape type=\"sphere\">: a sphere scaled to zero size has no effect on the "
                                 "image; skipped"))
      << all_warnings(d);
}
