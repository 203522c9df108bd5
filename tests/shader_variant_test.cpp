// Lean shader variants: the ray-cast fragment shader of a box holds only the code of the features
// the box uses. assemble_shader resolves the RAYWARP_* conditionals itself, so the text handed to
// the GL compiler of a continuous twist has no cut code, and a box cut's has no deformation
// texture; every variant still compiles and links.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>

#include "base/error.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "gl/shader_sources.h"
#include "tests/mesh_fixtures.h"

using namespace raywarp;

namespace {

bool has(const std::string& text, const std::string& word) {
  return text.find(word) != std::string::npos;
}

long lines(const std::string& text) {
  long n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

BoxTextures twist_box() {
  BoxTextures b;
  b.box.half_extents = Eigen::Vector3d(1, 1, 1);
  return b;
}

BoxTextures box_cut_box(CutMode mode) {
  BoxTextures b;
  b.box.half_extents = Eigen::Vector3d(1, 1, 1);
  b.has_cut = true;
  b.cut_mode = mode;
  b.moves_nothing = true;
  b.lipschitz = 1.0;
  return b;
}

TEST(ResolveConditionals, TakesOneBranchPerGroup) {
  const std::string text =
      "#version 450 core\n#define A 2\n#define B\n"
      "#if A == 2 && defined(B)\nyes1 // comment\n#else\nno1\n#endif\n"
      "#if A == 1\nno2\n#elif A == 2 || !defined(C)\nyes2\n#elif 1\nno3\n#else\nno4\n#endif\n"
      "#ifndef B\nno5\n#if 1\nno6\n#endif\n#else\n  // only a comment\n\nyes3\n#endif\n"
      "#ifdef C\nno7\n#elif (A > 1) && !(A >= 3)\nyes4\n#endif\n";
  const std::string out = gl::resolve_conditionals(text, "test");
  EXPECT_EQ(out, "#version 450 core\n#define A 2\n#define B\nyes1\nyes2\nyes3\nyes4\n");
}

TEST(ResolveConditionals, RejectsWhatItCannotEvaluate) {
  EXPECT_THROW(gl::resolve_conditionals("#if 1\nx\n", "t"), Error);        // no #endif
  EXPECT_THROW(gl::resolve_conditionals("#endif\n", "t"), Error);          // no #if
  EXPECT_THROW(gl::resolve_conditionals("#else\n", "t"), Error);           // no #if
  EXPECT_THROW(gl::resolve_conditionals("#if (1\n#endif\n", "t"), Error);  // no ')'
  EXPECT_THROW(gl::resolve_conditionals("#define X a\n#if X\n#endif\n", "t"), Error);
  try {
    gl::resolve_conditionals("a\n#if 1 +\n#endif\n", "shader s.glsl");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_TRUE(has(e.what(), "shader s.glsl:2")) << e.what();
  }
}

TEST(ShaderVariants, TwistHasNoCutCodeAndBoxCutNoDeformationCode) {
  RenderSettings linear;
  linear.sampling = "linear";
  const std::string twist = gl::raycast_fragment_source(twist_box(), linear);
  for (const char* word : {"u_alpha", "alpha_at", "u_cut_colour", "u_thickness", "CutFace"})
    EXPECT_FALSE(has(twist, word)) << word << " in the twist's shader";
  for (const char* word : {"jacobian_step", "u_bricks", "u_threshold", "#if", "#else", "//"})
    EXPECT_FALSE(has(twist, word)) << word << " in the linear twist's shader";
  EXPECT_TRUE(has(twist, "u_deformation"));

  const std::string cut = gl::raycast_fragment_source(box_cut_box(CutMode::Solid), linear);
  for (const char* word : {"u_deformation", "deformation(", "u_def_spacing"})
    EXPECT_FALSE(has(cut, word)) << word << " in the box cut's shader";
  EXPECT_TRUE(has(cut, "alpha_at"));
  EXPECT_TRUE(has(cut, "u_cut_colour"));

  RenderSettings jacobian = linear;
  jacobian.sampling = "jacobian";
  const std::string twist_jacobian = gl::raycast_fragment_source(twist_box(), jacobian);
  EXPECT_TRUE(has(twist_jacobian, "jacobian_step"));
  EXPECT_GT(twist_jacobian.size(), twist.size());
  // A box cut has D = 0, so even the jacobian variant reads no deformation texture.
  EXPECT_FALSE(
      has(gl::raycast_fragment_source(box_cut_box(CutMode::Solid), jacobian), "jacobian_step"));

  std::printf(
      "[figures] ray-cast fragment shader: linear twist %zu bytes (%ld lines), jacobian twist "
      "%zu bytes, solid box cut %zu bytes (%ld lines); the source with every branch: %zu bytes "
      "before resolution\n",
      twist.size(), lines(twist), twist_jacobian.size(), cut.size(), lines(cut),
      gl::embedded_shaders().at("raycast.frag.glsl").size());
}

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

// Every variant the renderer can ask for compiles and links: each is drawn once in a one-box
// scene (the renderer compiles a variant at its first draw and keeps it).
TEST(ShaderVariants, EveryVariantCompiles) {
  context();
  gl::Renderer renderer;
  renderer.set_mesh(fixtures::cube(0.5));
  int variants = 0;
  size_t smallest = SIZE_MAX, largest = 0;
  for (int cut = 0; cut <= 3; ++cut)
    for (int moves_nothing = 0; moves_nothing <= (cut ? 1 : 0); ++moves_nothing)
      for (const char* sampling : {"linear", "threshold", "jacobian"})
        for (bool skipping : {false, true}) {
          BoxTextures b = cut ? box_cut_box(CutMode(cut - 1)) : twist_box();
          b.moves_nothing = moves_nothing;
          b.lipschitz = 1.0;
          b.sdf.grid =
              Grid3<float>(Eigen::Vector3d(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4), 1.f);
          b.sdf.background = 1.0f;
          if (!moves_nothing)
            b.deformation.grid =
                Grid3<Eigen::Vector4f>(Eigen::Vector3d(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4),
                                       Eigen::Vector4f(0, 0, 0, 1));
          if (cut)
            b.alpha.grid =
                Grid3<float>(Eigen::Vector3d(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4), -1.f);
          b.region = Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1));
          RenderSettings settings;
          settings.sampling = sampling;
          settings.skipping = skipping;
          renderer.set_boxes({b});
          Camera camera;
          EXPECT_NO_THROW(renderer.render(camera, 8, 8, settings))
              << "cut " << cut << ", moves nothing " << moves_nothing << ", " << sampling;
          ++variants;
          const size_t bytes = gl::raycast_fragment_source(b, settings).size();
          smallest = std::min(smallest, bytes);
          largest = std::max(largest, bytes);
        }
  std::printf("[figures] %d ray-cast variants compiled and linked, %zu to %zu bytes\n", variants,
              smallest, largest);
}

}  // namespace
