// Named after no one source: a property of every render, across the bake and the renderer.
// No crack where the deformed part meets the rest of the mesh (tests/seam_check.h), on every
// shipped example and the scenes of examples/seams (a peel by 120 degrees and by 1 degree), at the
// defaults; tests/zoo_test.cpp runs the same check on every scene of examples/zoo.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "gl/context.h"
#include "gl/renderer.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "tests/seam_check.h"

namespace raywarp {
namespace {

using testing::kSeamImageSize;

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

class SeamTest : public ::testing::TestWithParam<std::string> {};

TEST_P(SeamTest, NoCrackAtIdentityFaces) {
  const Scene scene = load_scene(std::string(RAYWARP_SOURCE_DIR) + "/examples/" + GetParam());
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(scene, log);
  const Camera camera =
      scene.camera ? *scene.camera
                   : load_camera(std::string(RAYWARP_SOURCE_DIR) + "/examples/cameras/front.json");
  context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  const Image gl = renderer.render(camera, kSeamImageSize, kSeamImageSize, scene.render);
  const testing::SeamFigures seams =
      testing::check_seams(GetParam(), prepared, camera, gl, scene.render);
  EXPECT_LE(seams.cracked, seams.allowed);
}

std::vector<std::string> seam_scenes() {
  std::vector<std::string> out;
  const std::string root = std::string(RAYWARP_SOURCE_DIR) + "/examples";
  for (const char* folder : {"", "seams"})
    for (const auto& e : std::filesystem::directory_iterator(root + "/" + folder))
      if (e.path().extension() == ".json")
        out.push_back((std::string(folder).empty() ? "" : std::string(folder) + "/") +
                      e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

INSTANTIATE_TEST_SUITE_P(Examples, SeamTest, ::testing::ValuesIn(seam_scenes()),
                         [](const auto& info) {
                           std::string s = info.param.substr(0, info.param.size() - 5);
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

}  // namespace
}  // namespace raywarp
