// Named after no one source: the shaders/ variants as gl/ assembles and compiles them.
// Lean shader variants: the ray-cast fragment shader of a box holds only the code of the features
// the box uses. assemble_shader resolves the RAYWARP_* conditionals itself, so the text handed to
// the GL compiler of a continuous twist has no cut code, and a box cut's has no deformation
// texture; every variant still compiles and links. The assembly expands #include and writes
// #line directives, so that a compile error names the piece and line it is in; variants and
// texture units come from the tables of gl/raycast_tables.h.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "gl/context.h"
#include "gl/raycast_tables.h"
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

// The tetrahedral route's pieces (shaders/tet_*.glsl, gl/tet_render.h) have their own macros and
// textures, outside the ray-cast pass's tables.
bool is_tet_route(const std::string& file) { return file.rfind("tet_", 0) == 0; }

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) out.push_back(line);
  return out;
}

// The message of the Error that `f` throws ("" when it throws none).
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// Follows `assembled` as GLSL counts its lines (line 1 of source string 0 first; `#line L S`: the
// next line is line L of source string S, which is line L - S * kLineStride of file S) and checks
// that every other line is the line of that number of that file (or of the preamble, "#version
// 450 core" and `defines`), its comment and trailing blanks dropped. Returns how many #line
// directives it holds.
int expect_lines_map_to_sources(const std::string& assembled, const gl::ShaderFiles& files,
                                const std::string& defines) {
  int source = 0, line = 1, directives = 0;
  for (const std::string& text : split_lines(assembled)) {
    if (text.rfind("#line ", 0) == 0) {
      std::istringstream words(text.substr(6));
      EXPECT_TRUE(words >> line >> source) << text;
      EXPECT_EQ(line / gl::ShaderFiles::kLineStride, source) << text;
      line -= source * gl::ShaderFiles::kLineStride;
      ++directives;
      continue;
    }
    const std::string* name = files.name(source);
    EXPECT_NE(name, nullptr) << "source string " << source;
    if (!name) return directives;
    const std::vector<std::string> original =
        split_lines(source == 0 ? "#version 450 core\n" + defines : *files.text(*name));
    EXPECT_GE(line, 1);
    EXPECT_LE(line, static_cast<int>(original.size())) << *name;
    if (line >= 1 && line <= static_cast<int>(original.size())) {
      EXPECT_EQ(original[line - 1].compare(0, text.size(), text), 0)
          << *name << ":" << line << " is '" << original[line - 1] << "', not '" << text << "'";
    }
    ++line;
  }
  return directives;
}

// The line number of the first line of `text` that contains `word` (0: none).
int line_of(const std::string& text, const std::string& word) {
  const std::vector<std::string> all = split_lines(text);
  for (size_t i = 0; i < all.size(); ++i)
    if (all[i].find(word) != std::string::npos) return static_cast<int>(i) + 1;
  return 0;
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

TEST(ResolveConditionals, SumsAndLiveErrors) {
  EXPECT_EQ(gl::resolve_conditionals(
                "#define A\n#if defined(A) + defined(B) + 2 - 1 == 2\nyes\n#endif\n", "t"),
            "#define A\nyes\n");
  EXPECT_EQ(gl::resolve_conditionals("#if 0\n#error not here\n#endif\nok\n", "t"), "ok\n");
  EXPECT_NE(error_of([] {
              gl::resolve_conditionals("a\n#error two samplings\n", "s.glsl");
            }).find("s.glsl:2: #error two samplings"),
            std::string::npos);
}

using Texts = std::map<std::string, std::string>;

// Three pieces: main.glsl includes a.glsl and b.glsl, a.glsl includes b.glsl too.
gl::ShaderFiles three_pieces() {
  return gl::ShaderFiles(Texts{{"main.glsl",
                                "// the main piece\n"              // 1
                                "#include \"a.glsl\"\n"            // 2
                                "#include \"b.glsl\"  // again\n"  // 3
                                "#ifdef FLAG\n"                    // 4
                                "float flag;\n"                    // 5
                                "#else\n"                          // 6
                                "float no_flag;\n"                 // 7
                                "#endif\n"                         // 8
                                "void main() {}\n"},               // 9
                               {"a.glsl", "#include \"b.glsl\"\nfloat a;\n"},
                               {"b.glsl", "\nfloat b;  // b\n"}});
}

TEST(ShaderAssembly, NumbersFilesByName) {
  const gl::ShaderFiles files = three_pieces();
  EXPECT_EQ(files.number("a.glsl"), 1);
  EXPECT_EQ(files.number("b.glsl"), 2);
  EXPECT_EQ(files.number("main.glsl"), 3);
  EXPECT_EQ(files.number("c.glsl"), -1);
  EXPECT_EQ(*files.name(0), gl::ShaderFiles::kPreamble);
  EXPECT_EQ(*files.name(2), "b.glsl");
  EXPECT_EQ(files.name(4), nullptr);
  EXPECT_EQ(files.describe(), "a.glsl 1, b.glsl 2, main.glsl 3");
  // The embedded table: every shaders/*.glsl, numbered by name.
  const gl::ShaderFiles& embedded = gl::ShaderFiles::embedded();
  int n = 1;
  for (const auto& [name, text] : gl::embedded_shaders()) EXPECT_EQ(embedded.number(name), n++);
}

TEST(ShaderAssembly, ExpandsIncludesOnceWithLineDirectives) {
  const gl::ShaderFiles files = three_pieces();
  const std::string defines = "#define FLAG\n";
  const std::string text = gl::assemble_shader(files, "main.glsl", defines);
  EXPECT_EQ(text,
            "#version 450 core\n"
            "#define FLAG\n"
            "#line 20002 2\n"  // b.glsl:2, by a.glsl's #include; its blank line 1 dropped
            "float b;\n"
            "#line 10002 1\n"  // back in a.glsl, line 2
            "float a;\n"
            "#line 30005 3\n"  // main.glsl:5: b.glsl is not included again
            "float flag;\n"
            "#line 30009 3\n"  // main.glsl:9, after the #else branch and #endif
            "void main() {}\n");
  EXPECT_EQ(expect_lines_map_to_sources(text, files, defines), 4);
  const std::string other = gl::assemble_shader(files, "main.glsl");
  EXPECT_TRUE(has(other, "#line 30007 3\nfloat no_flag;\n#line 30009 3\n")) << other;
  expect_lines_map_to_sources(other, files, "");
}

TEST(ShaderAssembly, IncludeErrorsNameTheFileAndLine) {
  gl::ShaderFiles cycle(Texts{{"main.glsl", "#include \"a.glsl\"\n"},
                              {"a.glsl", "float a;\n#include \"b.glsl\"\n"},
                              {"b.glsl", "\n\n#include \"a.glsl\"\n"}});
  std::string e = error_of([&] { gl::assemble_shader(cycle, "main.glsl"); });
  EXPECT_TRUE(has(e, "b.glsl:3: #include \"a.glsl\": an include cycle, a.glsl -> b.glsl -> a.glsl"))
      << e;

  gl::ShaderFiles missing(Texts{{"main.glsl",
                                 "float x;\n#ifdef NOPE\n#include \"gone.glsl\"\n#endif\n"
                                 "#include \"nope.glsl\"\n"}});
  e = error_of([&] { gl::assemble_shader(missing, "main.glsl"); });  // gone.glsl: not live
  EXPECT_TRUE(has(e, "main.glsl:5: #include \"nope.glsl\": no such shader file")) << e;

  gl::ShaderFiles malformed(Texts{{"main.glsl", "\n#include <other.glsl>\n"}});
  e = error_of([&] { gl::assemble_shader(malformed, "main.glsl"); });
  EXPECT_TRUE(has(e, "main.glsl:2: malformed #include")) << e;

  gl::ShaderFiles unbalanced(
      {{"main.glsl", "#include \"a.glsl\"\n#endif\n"}, {"a.glsl", "\n#ifdef X\n"}});
  e = error_of([&] { gl::assemble_shader(unbalanced, "main.glsl"); });
  EXPECT_TRUE(has(e, "a.glsl:2: #ifdef X: no #endif in a.glsl")) << e;

  e = error_of([&] { gl::assemble_shader(malformed, "absent.glsl"); });
  EXPECT_TRUE(has(e, "shader absent.glsl: not among the shader files")) << e;
}

TEST(ShaderAssembly, RewritesDriverLocations) {
  const gl::ShaderFiles files = three_pieces();
  EXPECT_EQ(gl::rewrite_info_log("2:20005(12): error: `x' undeclared\n"
                                 "0:20005(12): error: as Mesa reports it, source 0\n"
                                 "3(30009) : error C1008: undefined variable\n"  // NVIDIA
                                 "ERROR: 1:10002: 'y' : undeclared identifier\n"
                                 "0:2(1): error: in the defines\n"
                                 "0:70003(1): error: no file 7\n"
                                 "error: no location\n",
                                 files),
            "b.glsl:5(12): error: `x' undeclared\n"
            "b.glsl:5(12): error: as Mesa reports it, source 0\n"
            "main.glsl:9 : error C1008: undefined variable\n"
            "ERROR: a.glsl:2: 'y' : undeclared identifier\n"
            "<preamble>:2(1): error: in the defines\n"
            "0:70003(1): error: no file 7\n"
            "error: no location\n");
}

// Every line of every ray-cast variant the assembler writes is where its #line says it is.
TEST(ShaderAssembly, EveryVariantsLinesMapToTheirFiles) {
  RenderSettings settings;
  int variants = 0, directives = 0;
  size_t bytes = 0;
  for (int cut = 0; cut <= 3; ++cut)
    for (const gl::FeatureInfo& f : gl::kFeatures) {
      if (!f.sampling || f.feature == gl::Feature::SamplingBounded) continue;
      BoxTextures b = cut ? box_cut_box(CutMode(cut - 1)) : twist_box();
      settings.sampling = *f.sampling;
      const std::string defines = gl::raycast_defines(b, settings) + "#define RAYWARP_FRAGMENT\n";
      const std::string text = gl::assemble_shader("raycast.frag.glsl", defines);
      directives += expect_lines_map_to_sources(text, gl::ShaderFiles::embedded(), defines);
      bytes += text.size();
      ++variants;
    }
  std::printf("[figures] %d variants: %d #line directives, %zu bytes in all\n", variants,
              directives, bytes);
}

// The feature macros: each variant's defines are its features' macros from kFeatures, and the
// shaders test no RAYWARP_ macro that is not in that table (besides the fragment stage's).
TEST(ShaderVariants, FeatureMacrosComeFromTheTable) {
  std::set<std::string> table;
  for (const gl::FeatureInfo& f : gl::kFeatures) table.insert(f.macro);
  EXPECT_EQ(table.size(), gl::kFeatureCount);
  std::set<std::string> tested;
  const std::regex conditional(R"(^\s*#\s*(if|ifdef|ifndef|elif)\b(.*)$)");
  const std::regex macro(R"(\bRAYWARP_[A-Z0-9_]+\b)");
  for (const auto& [name, text] : gl::embedded_shaders())
    for (const std::string& line : split_lines(is_tet_route(name) ? "" : text)) {
      std::smatch m;
      if (!std::regex_match(line, m, conditional)) continue;
      const std::string condition = m[2];
      for (auto it = std::sregex_iterator(condition.begin(), condition.end(), macro);
           it != std::sregex_iterator(); ++it)
        tested.insert(it->str());
    }
  for (const std::string& name : tested)
    EXPECT_TRUE(table.count(name) || name == "RAYWARP_FRAGMENT")
        << name << " is tested by the shaders but is no kFeatures macro";
  for (const std::string& name : table)
    EXPECT_TRUE(tested.count(name)) << name << " is in kFeatures but no shader tests it";

  RenderSettings jacobian;
  jacobian.sampling = Sampling::Jacobian;
  const gl::Variant cut = gl::raycast_variant(box_cut_box(CutMode::ThickShell), jacobian);
  EXPECT_TRUE(cut.has(gl::Feature::Cut) && cut.has(gl::Feature::CutThick) &&
              cut.has(gl::Feature::MovesNothing) && cut.has(gl::Feature::SamplingJacobian));
  EXPECT_EQ(gl::raycast_defines(box_cut_box(CutMode::ThickShell), jacobian),
            "#define RAYWARP_SAMPLING_JACOBIAN\n#define RAYWARP_CUT\n#define RAYWARP_CUT_THICK\n"
            "#define RAYWARP_MOVES_NOTHING\n#define RAYWARP_SKIP\n");
  // "bounded" is traces_bounded's to decide: a box cut is not sphere traced but sampled linearly.
  RenderSettings bounded;
  bounded.sampling = Sampling::Bounded;
  EXPECT_TRUE(
      gl::raycast_variant(box_cut_box(CutMode::Solid), bounded).has(gl::Feature::SamplingLinear));
}

// The texture units: every sampler the shaders declare is in kTextureUnits, with its target.
TEST(ShaderVariants, SamplersComeFromTheTextureUnitTable) {
  std::map<std::string, GLenum> table;
  for (const gl::TextureUnitInfo& t : gl::kTextureUnits) table[t.sampler] = t.target;
  EXPECT_EQ(table.size(), gl::kTextureUnitCount);
  const std::map<std::string, GLenum> targets = {{"sampler3D", GL_TEXTURE_3D},
                                                 {"sampler2DArray", GL_TEXTURE_2D_ARRAY}};
  const std::regex sampler(R"(^\s*uniform\s+(\w*sampler\w*)\s+(\w+)\s*;)");
  std::set<std::string> declared;
  for (const auto& [name, text] : gl::embedded_shaders())
    for (const std::string& line : split_lines(is_tet_route(name) ? "" : text)) {
      std::smatch m;
      if (!std::regex_search(line, m, sampler)) continue;
      declared.insert(m[2]);
      ASSERT_TRUE(table.count(m[2])) << name << ": sampler " << m[2] << " has no texture unit";
      ASSERT_TRUE(targets.count(m[1])) << m[1];
      EXPECT_EQ(table.at(m[2]), targets.at(m[1])) << m[2];
    }
  EXPECT_EQ(declared.size(), table.size());
}

TEST(ShaderVariants, TwistHasNoCutCodeAndBoxCutNoDeformationCode) {
  RenderSettings linear;
  linear.sampling = Sampling::Linear;
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
  jacobian.sampling = Sampling::Jacobian;
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
      gl::embedded_shaders().at("raycast.frag.glsl").size() +
          gl::embedded_shaders().at("march.glsl").size());
}

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

// The embedded shaders with one line of `file` replaced by `broken` (line `line`, 1-based).
gl::ShaderFiles with_broken_line(const std::string& file, int line, const std::string& broken) {
  std::map<std::string, std::string> texts = gl::embedded_shaders();
  std::vector<std::string> all = split_lines(texts.at(file));
  all.at(line - 1) = broken;
  std::string text;
  for (const std::string& l : all) text += l + "\n";
  texts[file] = text;
  return gl::ShaderFiles(texts);
}

// A broken piece, compiled for real by the driver: the error names the piece and its line, past
// the includes, the conditional blocks the variant removed and the comments it dropped.
TEST(ShaderAssembly, DriverErrorsNameTheFileAndLine) {
  context();
  RenderSettings linear;
  linear.sampling = Sampling::Linear;
  const std::string twist = gl::raycast_defines(twist_box(), linear);
  const std::string cut = gl::raycast_defines(box_cut_box(CutMode::Solid), linear);
  const auto& sources = gl::embedded_shaders();

  // shading.glsl, included by raycast.frag.glsl after camera.glsl.
  const int shade_line = line_of(sources.at("shading.glsl"), "float lambert =");
  ASSERT_GT(shade_line, 0);
  const gl::ShaderFiles broken_shading =
      with_broken_line("shading.glsl", shade_line, "  float lambert = undeclared_lambert;");
  std::string e = error_of(
      [&] { gl::compile_shader(GL_FRAGMENT_SHADER, broken_shading, "raycast.frag.glsl", twist); });
  std::printf("[example] %s\n", e.c_str());
  EXPECT_TRUE(has(e, "shader raycast.frag.glsl does not compile")) << e;
  EXPECT_TRUE(has(e, "shading.glsl:" + std::to_string(shade_line) + "(")) << e;
  EXPECT_TRUE(has(e, "undeclared_lambert")) << e;

  // march.glsl, included by raycast.frag.glsl, near its end: in both variants the lines before
  // it lose different conditional blocks.
  const std::string march = sources.at("march.glsl");
  const int miss_line = line_of(march, "if (!hit) return false;");
  ASSERT_GT(miss_line, 300);
  const gl::ShaderFiles broken_march =
      with_broken_line("march.glsl", miss_line, "  if (!hit) return_this_fragment;");
  for (const std::string& defines : {twist, cut}) {
    e = error_of([&] {
      gl::compile_shader(GL_FRAGMENT_SHADER, broken_march, "raycast.frag.glsl", defines);
    });
    EXPECT_TRUE(has(e, "march.glsl:" + std::to_string(miss_line) + "(")) << e;
    EXPECT_TRUE(has(e, "return_this_fragment")) << e;
  }

  // camera.glsl in a vertex shader, through link_program as the renderer compiles.
  const int camera_line = line_of(sources.at("camera.glsl"), "float linear_depth(vec3 p)");
  ASSERT_GT(camera_line, 0);
  const gl::ShaderFiles broken_camera =
      with_broken_line("camera.glsl", camera_line,
                       "float linear_depth(vec3 p) { return dot(p - eye, u_view_dir); }");
  e = error_of([&] {
    gl::link_program(broken_camera, "raster.vert.glsl", "raster.frag.glsl",
                     "#define RAYWARP_MAX_BOXES 16\n");
  });
  EXPECT_TRUE(has(e, "shader raster.vert.glsl does not compile")) << e;
  EXPECT_TRUE(has(e, "camera.glsl:" + std::to_string(camera_line) + "(")) << e;

  // The pieces as embedded compile.
  EXPECT_NO_THROW(gl::glDeleteShader(gl::compile_shader(
      GL_FRAGMENT_SHADER, gl::ShaderFiles::embedded(), "raycast.frag.glsl", twist)));
}

// Every variant the renderer can ask for compiles and links: each is drawn once in a one-box
// scene (the renderer compiles a variant at its first draw and keeps it).
TEST(ShaderVariants, EveryVariantCompiles) {
  context();
  gl::Renderer renderer;
  renderer.set_mesh(fixtures::cube(0.5));
  int renders = 0;
  std::map<unsigned long, std::string> variants;  // by Variant::key: the fragment shader's text
  std::set<gl::Feature> seen;
  size_t smallest = SIZE_MAX, largest = 0;
  for (int cut = 0; cut <= 3; ++cut)
    // moves: 0 D, 1 no D, 2 (no cut) D read through a texture map, 3 (no cut) a cylindrical D,
    // 2 (cut) no D and a cylindrical A.
    for (int moves = 0; moves <= (cut ? 2 : 3); ++moves)
      for (const gl::FeatureInfo& sampling : gl::kFeatures) {
        if (!sampling.sampling) continue;
        const bool mapped = !cut && moves == 2, cylindrical = moves == (cut ? 2 : 3);
        if (sampling.feature == gl::Feature::SamplingBounded && (mapped || cylindrical)) continue;
        for (bool skipping : {false, true}) {
          BoxTextures b = cut ? box_cut_box(CutMode(cut - 1)) : twist_box();
          b.moves_nothing = moves == 1 || (cut && moves == 2);
          b.lipschitz = 1.0;
          b.sdf.grid =
              Grid3<float>(Eigen::Vector3d(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4), 1.f);
          b.sdf.background = 1.0f;
          if (!b.moves_nothing)
            b.deformation.grid =
                Grid3<Eigen::Vector4f>(Eigen::Vector3d(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4),
                                       Eigen::Vector4f(0, 0, 0, 1));
          if (mapped) b.texture_map(0, 3) = 0.25;
          if (cylindrical) b.cylindrical_axis = 1;
          if (cut)
            b.alpha.grid =
                Grid3<float>(Eigen::Vector3d(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4), -1.f);
          b.step_bounds.bricks =
              Grid3<float>(Eigen::Vector3d(-1, -1, -1), 2.0, Eigen::Vector3i(1, 1, 1), 1.f);
          b.step_bounds.sdf_bricks = b.step_bounds.bricks;
          b.region = Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1));
          RenderSettings settings;
          settings.sampling = *sampling.sampling;
          settings.skipping = skipping;
          renderer.set_boxes({b});
          Camera camera;
          EXPECT_NO_THROW(renderer.render(camera, 8, 8, settings))
              << "cut " << cut << ", moves " << moves << ", " << sampling_name(*sampling.sampling);
          ++renders;
          const gl::Variant variant = gl::raycast_variant(b, settings);
          for (const gl::FeatureInfo& f : gl::kFeatures)
            if (variant.has(f.feature)) seen.insert(f.feature);
          const std::string text = gl::raycast_fragment_source(b, settings);
          // One program per key: the variants of a key have one text.
          auto at = variants.emplace(variant.key(), text).first;
          EXPECT_EQ(at->second, text) << gl::raycast_defines(b, settings);
          smallest = std::min(smallest, text.size());
          largest = std::max(largest, text.size());
        }
      }
  for (const gl::FeatureInfo& f : gl::kFeatures)
    EXPECT_TRUE(seen.count(f.feature) || f.feature == gl::Feature::DepthCube)  // depth_cube_test's
        << f.macro << " in no variant";
  std::printf(
      "[figures] %d renders, %zu distinct ray-cast variants compiled and linked, %zu to %zu "
      "bytes\n",
      renders, variants.size(), smallest, largest);
}

}  // namespace
