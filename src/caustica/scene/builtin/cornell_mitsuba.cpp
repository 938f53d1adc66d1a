// Mitsuba 3's `cornell_box()` (Mitsuba 3.9.1), from the facts in
// shared/scenes/cornell-box.md: y up, camera at (0, 0, 3.9) looking down -z,
// fov 39.3077 degrees on the smaller axis, one-sided diffuse walls, a one-sided
// rectangular area light that also reflects with the white BSDF, path max depth 8.
#include "builtin.h"

namespace caustica {
namespace {

Affine rows(std::initializer_list<float> v) {
  Affine a;
  auto it = v.begin();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) a.m[i][j] = *it++;
  return a;
}

}  // namespace

SceneDesc make_cornell_mitsuba() {
  SceneDesc d;
  d.name = "cornell";
  d.camera.position = {0.f, 0.f, 3.9f};
  d.camera.target = {0.f, 0.f, 2.9f};
  d.camera.up = {0.f, 1.f, 0.f};
  d.camera.fov_degrees = 39.3077f;
  d.camera.width = d.camera.height = 256;
  d.filter = make_filter(FilterType::kGaussian);  // Mitsuba's default reconstruction filter
  d.max_depth = 8;
  int white = d.add_material("white", make_diffuse({0.885809f, 0.698859f, 0.666422f}));
  int green = d.add_material("green", make_diffuse({0.105421f, 0.37798f, 0.076425f}));
  int red = d.add_material("red", make_diffuse({0.570068f, 0.0430135f, 0.0443706f}));
  auto rect = [&](const char* name, int mat, Affine m) {
    ShapeDesc s;
    s.name = name;
    s.type = ShapeType::kRectangle;
    s.material = mat;
    s.to_world = m;
    d.shapes.push_back(s);
    return &d.shapes.back();
  };
  ShapeDesc* light = rect("light", white, rows({0.23f, 0, 0, 0, 0, 0, -0.19f, 0.99f, 0, 0.19f, 0, 0.01f}));
  light->emission = {18.387f, 13.9873f, 6.75357f};
  rect("floor", white, rows({1, 0, 0, 0, 0, 0, 1, -1, 0, -1, 0, 0}));
  rect("ceiling", white, rows({1, 0, 0, 0, 0, 0, -1, 1, 0, 1, 0, 0}));
  rect("back", white, rows({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, -1}));
  rect("green-wall", green, rows({0, 0, -1, 1, 0, 1, 0, 0, 1, 0, 0, 0}));
  rect("red-wall", red, rows({0, 0, 1, -1, 0, 1, 0, 0, -1, 0, 0, 0}));
  ShapeDesc box;
  box.type = ShapeType::kCube;
  box.material = white;
  box.name = "small-box";
  box.to_world = rows({0.286891f, 0, -0.087712f, 0.335f, 0, 0.3f, 0, -0.7f, 0.087712f, 0, 0.286891f, 0.38f});
  d.shapes.push_back(box);
  box.name = "large-box";
  box.to_world = rows({0.28491f, 0, 0.093949f, -0.33f, 0, 0.61f, 0, -0.4f, -0.093949f, 0, 0.28491f, -0.28f});
  d.shapes.push_back(box);
  return d;
}

}  // namespace caustica
