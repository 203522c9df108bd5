// The EGL context beside OSMesa: EGL gives OpenGL 4.5 core, and a scene renders in it to the
// image of the CPU reference of the same ray cast, as it does in OSMesa (tests/render_test.cpp).
// On a machine without a GPU, EGL runs Mesa's llvmpipe through its software device or
// surfaceless platform. One context per process: this test uses EGL only.
#include "gl/context.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>

#include "base/error.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "verify/reference.h"

using namespace raywarp;

namespace {

TEST(Context, EglRendersTheReferenceImage) {
  const std::string root = RAYWARP_SOURCE_DIR;
  Scene scene = load_scene(root + "/examples/bunny_cut_solid.json");
  std::ostringstream log;
  PreparedScene prepared = prepare_scene(scene, log);
  auto context = gl::create_context("egl");
  EXPECT_NE(context->description().find("EGL"), std::string::npos);
  constexpr int kSize = 192;
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  gl::FrameStats stats;
  Image image = renderer.render(*scene.camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  Image cpu = reference_render(prepared.mesh(), prepared.textures(), *scene.camera, kSize, kSize,
                               scene.render);
  ImageComparison c = compare_images(image, cpu, 0.01 * 15.8);
  std::printf("[figures] %s: frame %.1f ms; vs CPU reference IoU %.4f, over %.2f%%\n",
              context->description().c_str(), stats.milliseconds, c.iou, 100 * c.fraction_over);
  EXPECT_GE(c.iou, 0.99);
  EXPECT_LE(c.fraction_over, 0.01);
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
