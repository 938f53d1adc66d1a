// SmallVCM's Cornell box variants (SmallVCM, scene.hxx LoadCornellBox), from
// the facts in shared/scenes/smallvcm-scenes.md: z up, an open front, a glossy
// floor (Lambert 0.1 + modified Phong 0.7, exponent 90), a blue back wall, a
// thin light box under the ceiling, mirror and glass (IOR 1.6) spheres, and
// one of four lights. Path length counts segments, at most 10.
#include "builtin.h"

#include <cmath>

namespace caustica {

SceneDesc make_smallvcm_cornell(bool large_mirror_sphere, bool small_spheres, SmallVCMLight light) {
  SceneDesc d;
  d.max_depth = 10;
  d.filter = make_filter(FilterType::kBox);
  d.camera.position = {-0.0439815f, -4.12529f, 0.222539f};
  d.camera.target = d.camera.position + normalize(Vec3f(0.00688625f, 0.998505f, -0.0542161f));
  d.camera.up = {3.73896e-4f, 0.0542148f, 0.998529f};
  d.camera.fov_degrees = 45.f;
  d.camera.fov_axis = CameraDesc::FovAxis::kX;
  d.camera.width = d.camera.height = 512;

  int black = d.add_material("light", make_diffuse(RGB(0.f)));
  int floor = d.add_material("glossy-floor", make_phong(RGB(0.1f), RGB(0.7f), 90.f));
  int green = d.add_material("green", make_diffuse({0.156863f, 0.803922f, 0.172549f}));
  int red = d.add_material("red", make_diffuse({0.803922f, 0.152941f, 0.152941f}));
  int white = d.add_material("white", make_diffuse(RGB(0.803922f)));
  int mirror = d.add_material("mirror", make_mirror(RGB(1.f)));
  int glass = d.add_material("glass", make_dielectric(1.6f));
  int blue = d.add_material("blue", make_diffuse({0.156863f, 0.172549f, 0.803922f}));

  const Vec3f cb[8] = {{-1.27029f, 1.30455f, -1.28002f}, {1.28975f, 1.30455f, -1.28002f},
                       {1.28975f, 1.30455f, 1.28002f},   {-1.27029f, 1.30455f, 1.28002f},
                       {-1.27029f, -1.25549f, -1.28002f}, {1.28975f, -1.25549f, -1.28002f},
                       {1.28975f, -1.25549f, 1.28002f},  {-1.27029f, -1.25549f, 1.28002f}};
  auto add_mesh = [&](const char* name, const Vec3f* pts, std::initializer_list<uint32_t> tris, int mat,
                      RGB emission = RGB(0.f)) {
    MeshDesc m;
    m.name = name;
    m.positions.assign(pts, pts + 8);
    m.indices = tris;
    d.meshes.push_back(m);
    ShapeDesc s;
    s.name = name;
    s.type = ShapeType::kMesh;
    s.mesh = int(d.meshes.size()) - 1;
    s.material = mat;
    s.emission = emission;
    d.shapes.push_back(s);
  };
  add_mesh("floor", cb, {0, 4, 5, 5, 1, 0}, floor);
  add_mesh("back-wall", cb, {0, 1, 2, 2, 3, 0}, blue);
  add_mesh("ceiling", cb, {2, 6, 7, 7, 3, 2}, white);
  add_mesh("left-wall", cb, {3, 7, 4, 4, 0, 3}, green);
  add_mesh("right-wall", cb, {1, 5, 6, 6, 2, 1}, red);

  if (light != SmallVCMLight::kPoint) {
    const Vec3f lb[8] = {{-0.25f, 0.25f, 1.26002f},  {0.25f, 0.25f, 1.26002f},  {0.25f, 0.25f, 1.28002f},
                         {-0.25f, 0.25f, 1.28002f},  {-0.25f, -0.25f, 1.26002f}, {0.25f, -0.25f, 1.26002f},
                         {0.25f, -0.25f, 1.28002f},  {-0.25f, -0.25f, 1.28002f}};
    add_mesh("light-box", lb, {0, 2, 1, 2, 0, 3, 3, 4, 7, 4, 3, 0, 1, 6, 5, 6, 1, 2, 4, 5, 6, 6, 7, 4}, white);
    if (light == SmallVCMLight::kArea)
      add_mesh("light", lb, {0, 5, 4, 5, 0, 1}, black, RGB(25.03329895614464f));
    else
      add_mesh("light-box-bottom", lb, {0, 5, 4, 5, 0, 1}, white);
  }

  // Spheres, placed from the corner table as SmallVCM does.
  Vec3f floor_center = (cb[0] + cb[5]) * 0.5f;
  float box_width = cb[1].x - cb[0].x;
  auto sphere = [&](const char* name, Vec3f c, float r, int mat) {
    ShapeDesc s;
    s.name = name;
    s.type = ShapeType::kSphere;
    s.center = c;
    s.radius = r;
    s.material = mat;
    d.shapes.push_back(s);
  };
  if (large_mirror_sphere) sphere("large-mirror-sphere", floor_center + Vec3f(0, 0, 0.8f), 0.8f, mirror);
  if (small_spheres) {
    Vec3f left_wall = (cb[0] + cb[7]) * 0.5f, right_wall = (cb[1] + cb[6]) * 0.5f;
    left_wall.z = right_wall.z = floor_center.z + 0.5f;
    float shift = box_width * 2.f / 7.f;
    sphere("mirror-sphere", left_wall + Vec3f(shift, 0, 0), 0.5f, mirror);
    sphere("glass-sphere", right_wall - Vec3f(shift, 0, 0), 0.5f, glass);
  }

  switch (light) {
    case SmallVCMLight::kSun: {
      Light l;
      l.type = LightType::kDirectional;
      l.dir = normalize(Vec3f(-1.f, 1.5f, -1.f));
      l.L = {10.f, 4.f, 0.f};
      d.lights.push_back(l);
      break;
    }
    case SmallVCMLight::kPoint: {
      Light l;
      l.type = LightType::kPoint;
      l.p = {0.f, -0.5f, 1.f};
      l.L = RGB(70.f / (4.f * kPi));
      d.lights.push_back(l);
      break;
    }
    case SmallVCMLight::kBackground: {
      Light l;
      l.type = LightType::kEnvironment;
      l.L = {0.529412f, 0.807843f, 0.980392f};
      d.lights.push_back(l);
      break;
    }
    case SmallVCMLight::kArea: break;
  }
  return d;
}

SceneDesc make_point_in_glass() {
  // SmallVCM's box without spheres and with the point light, a glass sphere
  // (IOR 1.5) of radius 0.3 put around the light: every photon leaves through
  // the glass, and every light path to the camera is L S+ D (S|D)* E.
  SceneDesc d = make_smallvcm_cornell(false, false, SmallVCMLight::kPoint);
  d.lights[0].p = {0.f, 0.f, 0.4f};
  int glass = d.add_material("glass-shell", make_dielectric(1.5f));
  ShapeDesc s;
  s.name = "glass-shell";
  s.type = ShapeType::kSphere;
  s.center = d.lights[0].p;
  s.radius = 0.3f;
  s.material = glass;
  d.shapes.push_back(s);
  d.max_depth = 12;
  return d;
}

namespace {

// The inside of SmallVCM's box, 0.005 in from the walls (a face in a wall's plane would be ambiguous to the
// ray queries), as a null cube whose interior is medium `medium`: the front, open side included, so camera
// rays enter the medium at the box's opening.
void add_box_medium(SceneDesc& d, const char* name, int medium) {
  int null_material = d.add_material(std::string(name) + "-boundary", Material());
  d.materials[size_t(null_material)].type = MaterialType::kNull;
  const Vec3f lo(-1.27029f, -1.25549f, -1.28002f), hi(1.28975f, 1.30455f, 1.28002f);
  const Vec3f half = (hi - lo) * 0.5f - Vec3f(0.005f), centre = (hi + lo) * 0.5f;
  ShapeDesc box;
  box.name = name;
  box.type = ShapeType::kCube;
  for (int k = 0; k < 3; ++k) {
    box.to_world.m[k][k] = half[k];
    box.to_world.m[k][3] = centre[k];
  }
  box.material = null_material;
  box.medium_interface = true;
  box.interior = medium;
  d.shapes.push_back(box);
}

}  // namespace

// SmallVCM's box with the area light and both spheres, filled with a homogeneous haze (participating
// media, medium/medium.h): a null box just inside the walls holds it; the glass sphere is clear inside (its
// exterior is the haze). Rendered by the volumetric path tracer (`path`).
SceneDesc make_smallvcm_fog() {
  SceneDesc d = make_smallvcm_cornell(false, true, SmallVCMLight::kArea);
  Medium haze;
  haze.sigma_a = RGB(0.01f);
  haze.sigma_s = RGB(0.22f, 0.25f, 0.3f);
  haze.g = 0.4f;
  d.medium_names.push_back("haze");
  d.media.push_back(haze);
  add_box_medium(d, "haze", 0);
  for (ShapeDesc& s : d.shapes)
    if (s.name == "glass-sphere") {
      s.medium_interface = true;
      s.exterior = 0;
    }
  d.max_depth = 16;
  return d;
}

// SmallVCM's box with the area light and its glossy floor, the spheres replaced by a plume of smoke rising
// from the floor (a heterogeneous medium, medium/medium_grid.h): a 48^3 density grid filling the box, a
// column that widens and sways as it rises and fades out between 0.6 and 0.85 of the box's height, its
// density modulated by a product of sines (billows), in a faint haze. sigma_s 2.4, sigma_a 0.1 per unit
// density (up to about 6), forward scattering (g 0.3). Rendered by `path` (its default) and `pppm`.
SceneDesc make_smallvcm_smoke() {
  SceneDesc d = make_smallvcm_cornell(false, false, SmallVCMLight::kArea);
  Medium smoke;
  smoke.sigma_a = RGB(0.1f);
  smoke.sigma_s = RGB(2.4f);
  smoke.g = 0.3f;
  MediumGridDesc g;
  g.name = "smallvcm-smoke plume";
  g.nx = g.ny = g.nz = 48;
  g.values.resize(size_t(48) * 48 * 48);
  for (int k = 0; k < 48; ++k)
    for (int j = 0; j < 48; ++j)
      for (int i = 0; i < 48; ++i) {
        // The box is z-up (SmallVCM's frame): h is the height, (x, y) the floor's coordinates.
        const float x = (i + 0.5f) / 48.f, y = (j + 0.5f) / 48.f, h = (k + 0.5f) / 48.f;
        // The column's axis sways with height; its radius grows from 0.05 to 0.19 of the box.
        const float cx = 0.5f + 0.1f * std::sin(5.f * h + 0.5f), cy = 0.55f + 0.08f * std::cos(4.f * h);
        const float r2 = (x - cx) * (x - cx) + (y - cy) * (y - cy), w = 0.05f + 0.14f * h;
        const float billow = 0.55f + 0.45f * std::sin(19.f * x + 7.f * h) * std::sin(17.f * h + 2.f) *
                                         std::sin(23.f * y + 5.f * h + 1.f);
        const float fade = h < 0.6f ? 1.f : (h < 0.85f ? (0.85f - h) / 0.25f : 0.f);
        g.values[(size_t(k) * 48 + size_t(j)) * 48 + size_t(i)] =
            (1.2f / (w * 4.f)) * std::exp(-r2 / (w * w)) * billow * fade + 0.004f;
      }
  const Vec3f lo(-1.27029f, -1.25549f, -1.28002f), hi(1.28975f, 1.30455f, 1.28002f);
  for (int c = 0; c < 3; ++c) {
    g.to_world.m[c][c] = hi[c] - lo[c];
    g.to_world.m[c][3] = lo[c];
  }
  d.grids.push_back(std::move(g));
  smoke.grid = 0;
  d.medium_names.push_back("smoke");
  d.media.push_back(smoke);
  add_box_medium(d, "smoke", 0);
  d.max_depth = 16;
  return d;
}

}  // namespace caustica

namespace caustica {

// A volumetric caustic (tests/python/test_media_photons.py's fog box with the lens): a point light 0.4
// above a glass ball (radius 0.4, IOR 1.5) in a 4 x 4 x 4 box of fog (null boundary; sigma_s 0.3, sigma_a
// 0.02, g 0.3) over a grey floor, the camera inside the fog. The ball focuses the light into a cone that
// narrows towards the floor: paths L S S V E (and L S S D E on the floor), which the path tracer cannot
// sample from a point light and pppm renders (its default here).
SceneDesc make_fog_lens() {
  SceneDesc d;
  d.camera.position = {0.f, 0.f, 1.9f};
  d.camera.target = {0.f, -0.3f, 0.f};
  d.camera.up = {0.f, 1.f, 0.f};
  d.camera.fov_degrees = 70.f;
  d.camera.width = d.camera.height = 512;
  Medium fog;
  fog.sigma_a = RGB(0.02f);
  fog.sigma_s = RGB(0.3f);
  fog.g = 0.3f;
  d.medium_names.push_back("fog");
  d.media.push_back(fog);
  d.camera.medium = 0;
  const int boundary = d.add_material("fog", Material());
  d.materials[size_t(boundary)].type = MaterialType::kNull;
  const int floor = d.add_material("floor", make_diffuse(RGB(0.5f)));
  const int glass = d.add_material("glass", make_dielectric(1.5f));
  ShapeDesc box;
  box.name = "fog";
  box.type = ShapeType::kCube;
  for (int k = 0; k < 3; ++k) box.to_world.m[k][k] = 2.f;
  box.material = boundary;
  box.medium_interface = true;
  box.interior = 0;
  d.shapes.push_back(box);
  ShapeDesc ground;  // [-1, 1]^2 in z = 0 turned to face +y, scaled by 1.9, at y = -1.9
  ground.name = "floor";
  ground.type = ShapeType::kRectangle;
  ground.to_world.m[0][0] = 1.9f;
  ground.to_world.m[1][1] = 0.f;
  ground.to_world.m[1][2] = 1.9f;
  ground.to_world.m[1][3] = -1.9f;
  ground.to_world.m[2][1] = -1.9f;
  ground.to_world.m[2][2] = 0.f;
  ground.material = floor;
  d.shapes.push_back(ground);
  ShapeDesc ball;
  ball.name = "lens";
  ball.type = ShapeType::kSphere;
  ball.center = {0.f, 0.4f, 0.f};
  ball.radius = 0.4f;
  ball.material = glass;
  ball.medium_interface = true;
  ball.exterior = 0;
  d.shapes.push_back(ball);
  Light l;
  l.type = LightType::kPoint;
  l.p = {0.f, 1.2f, 0.f};
  l.L = RGB(4.f);
  d.lights.push_back(l);
  d.integrator.type = "pppm";
  return d;
}

}  // namespace caustica
