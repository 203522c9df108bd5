// The EGL context beside OSMesa: both give OpenGL 4.5 core, and the same scene renders to the
// same image in each (on a machine without a GPU, EGL runs Mesa's llvmpipe through its
// software device or surfaceless platform).
#include "library/gl/context.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>

#include "editor/pipeline.h"
#include "library/error.h"
#include "library/gl/renderer.h"
#include "library/image.h"
#include "library/scene.h"

using namespace raywarp;

namespace {

Image render_in(const std::string& kind, const PreparedScene& prepared, const Scene& scene,
                const Camera& camera, std::string& description) {
  auto context = gl::create_context(kind);
  description = context->description();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh);
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  Image image = renderer.render(camera, 192, 192, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  std::printf("[figures] %s: frame %.1f ms\n", description.c_str(), stats.milliseconds);
  return image;
}

TEST(Context, EglAndOsmesaRenderTheSameImage) {
  const std::string root = RAYWARP_SOURCE_DIR;
  Scene scene = load_scene(root + "/examples/bunny_cut_solid.json");
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  std::string osmesa_name, egl_name;
  Image a = render_in("osmesa", prepared, scene, *scene.camera, osmesa_name);
  Image b = render_in("egl", prepared, scene, *scene.camera, egl_name);
  EXPECT_NE(osmesa_name.find("OSMesa"), std::string::npos);
  EXPECT_NE(egl_name.find("EGL"), std::string::npos);
  ImageComparison c = compare_images(a, b, 1e-3);
  EXPECT_GE(c.iou, 0.999);
  EXPECT_LE(c.fraction_over, 0.001);
}

TEST(Context, UnknownKindIsRefused) {
  try {
    gl::create_context("vulkan");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("auto, egl, osmesa"), std::string::npos);
  }
}

}  // namespace
