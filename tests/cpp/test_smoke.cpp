#include <gtest/gtest.h>

#include "caustica/scene/builtin/builtin.h"
#include "caustica/scene/scene.h"

using namespace caustica;

TEST(Smoke, BuiltinScenesBuild) {
  for (const auto& s : builtin_scenes()) {
    auto scene = Scene::build(builtin_scene(s.first));
    EXPECT_GT(scene->view().num_lights, 0u) << s.first;
  }
}
