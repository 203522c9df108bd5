// The Godot 4 bundle (cli/engine_godot.h). Godot's own shader compiler (Godot 4.6's web export in
// headless Chromium, tests/godot/compile_gdshader.mjs) compiles, in one run, the box shader of a
// variant for every feature macro of gl::kFeatures, the remainder shader and the shaders of two
// exported boxes; a shader with `return` in fragment() must fail there, so the run is known to
// check. Without Godot: the rewrite's text (no #version, precision, #line or gl_*; every uniform of
// the variant with its hints and default), the import script's tables against the sidecar, and
// the scene file's references and numbers. GDScript cannot run here and the scene cannot be
// loaded: docs/engines_godot.md says what only Godot can check. The run takes 2 to 3.5 minutes, all
// of it in Godot's compiler under Chromium: it is the only compiler of Godot's shading language.
#include "cli/engine_godot.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "cli/engine_bundles.h"
#include "cli/engine_shaders.h"
#include "cli/export.h"
#include "gl/raycast_tables.h"
#include "gl/shader_sources.h"
#include "library/export.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "tests/engine_scenes.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;
using gl::Feature;
using nlohmann::json;

// One variant per line of what the test covers; together every feature macro of gl::kFeatures.
struct NamedVariant {
  std::string name;
  gl::Variant variant;
};

gl::Variant make(std::initializer_list<Feature> features) {
  gl::Variant v;
  for (Feature f : features) v.add(f);
  return v;
}

std::vector<NamedVariant> variants() {
  using F = Feature;
  return {
      {"linear", make({F::SamplingLinear})},
      {"threshold_skip", make({F::SamplingThreshold, F::Skip})},
      {"jacobian", make({F::SamplingJacobian})},
      {"jacobian_moves_nothing", make({F::SamplingJacobian, F::MovesNothing})},
      {"bounded", make({F::SamplingBounded})},
      {"hollow", make({F::SamplingThreshold, F::Cut, F::CutHollow, F::Skip})},
      {"solid", make({F::SamplingThreshold, F::Cut, F::CutSolid, F::Skip})},
      {"thick", make({F::SamplingLinear, F::Cut, F::CutThick})},
      {"box_cut_solid",
       make({F::SamplingThreshold, F::Cut, F::CutSolid, F::MovesNothing, F::Skip})},
      {"box_cut_hollow", make({F::SamplingLinear, F::Cut, F::CutHollow, F::MovesNothing})},
      {"texture_map", make({F::SamplingThreshold, F::TextureMap, F::Skip})},
      {"texture_map_thick", make({F::SamplingJacobian, F::TextureMap, F::Cut, F::CutThick})},
      {"depth_cube", make({F::SamplingThreshold, F::DepthCube})},
      {"depth_cube_cut", make({F::SamplingLinear, F::DepthCube, F::Cut, F::CutSolid, F::Skip})},
      {"cylindrical", make({F::SamplingThreshold, F::Cylindrical})},
      {"cylindrical_groove", make({F::SamplingLinear, F::Cylindrical, F::Cut, F::CutSolid})},
  };
}

// Values for every uniform any variant declares (what raycast_uniform_values gives, plus the
// depth cube's and the cylinder's scalars), so that defaults are written.
json all_values() {
  return {{"u_half_extents", {1.0, 2.0, 3.0}},
          {"u_region_lower", {-1.1, -2.1, -3.1}},
          {"u_region_upper", {1.1, 2.1, 3.1}},
          {"u_sdf_origin", {-1.0, -2.0, -3.0}},
          {"u_sdf_size", {2.0, 4.0, 6.0}},
          {"u_sdf_spacing", 0.0625},
          {"u_background", 0.25},
          {"u_step", 0.25},
          {"u_max_steps", 1024},
          {"u_refine_steps", 8},
          {"u_seam", 0.0625},
          {"u_def_origin", {-1.2, -2.2, -3.2}},
          {"u_def_size", {2.4, 4.4, 6.4}},
          {"u_def_spacing", {0.1, 0.1, 0.1}},
          {"u_texture_map_x", {1.0, 0.0, 0.0, 0.0}},
          {"u_texture_map_y", {0.0, 1.0, 0.0, 0.5}},
          {"u_texture_map_z", {0.0, 0.0, 1.0, 0.0}},
          {"u_cyl_e_u", {0.0, 0.0, 1.0}},
          {"u_cyl_e_v", {1.0, 0.0, 0.0}},
          {"u_cyl_e_a", {0.0, 1.0, 0.0}},
          {"u_alpha_origin", {-1.0, -2.0, -3.0}},
          {"u_alpha_size", {2.0, 4.0, 6.0}},
          {"u_alpha_spacing", {0.1, 0.1, 0.1}},
          {"u_thickness", 0.3},
          {"u_threshold", 0.125},
          {"u_fine_factor", 0.125},
          {"u_brick_origin", {-1.0, -2.0, -3.0}},
          {"u_brick_spacing", {0.8, 0.8, 0.8}},
          {"u_sdf_brick_origin", {-1.0, -2.0, -3.0}},
          {"u_sdf_brick_spacing", 0.5},
          {"u_inv_lipschitz_w", 0.02},
          {"u_epsilon", 0.00125},
          {"u_lipschitz", -1.0},
          {"u_cut_margin", 0.2},
          {"u_depth_layer", {64.0, 64.0}},
          {"u_depth_origin_x", {-1.0, -1.0}},
          {"u_depth_origin_y", {-1.0, -1.0}},
          {"u_depth_origin_z", {-1.0, -1.0}},
          {"u_depth_last_x", {31.0, 31.0}},
          {"u_depth_last_y", {31.0, 31.0}},
          {"u_depth_last_z", {31.0, 31.0}},
          {"u_albedo", {0.8, 0.62, 0.45}},
          {"u_inside_colour", {0.3, 0.42, 0.62}},
          {"u_cut_colour", {0.75, 0.18, 0.16}},
          {"u_def_decode", {1.0, 1.0, 1.0, 1.0}},
          {"u_sdf_decode", 1.0},
          {"u_alpha_decode", 1.0}};
}

// An export's uniform values as gl/renderer.cpp sets them, under the default render settings.
json export_values(const json& sidecar) {
  return raycast_uniform_values(sidecar, RenderSettings());
}

// The uniforms of the variant's march as GLSL declares them: name -> (type, array size).
std::map<std::string, std::pair<std::string, int>> glsl_uniforms(const gl::Variant& v) {
  const std::string glsl = gl::assemble_shader("march.glsl", v.defines());
  static const std::regex decl(R"(^uniform (\w+) (\w+)(?:\[(\d+)\])?;$)");
  std::map<std::string, std::pair<std::string, int>> out;
  std::istringstream in(glsl);
  std::string line;
  std::smatch m;
  while (std::getline(in, line))
    if (std::regex_match(line, m, decl)) out[m[2]] = {m[1], m[3].matched ? std::stoi(m[3]) : 0};
  return out;
}

// The hints the brief asks for, per uniform.
std::string expected_hints(const std::string& name, const std::string& type, bool cylindrical) {
  if (type.find("sampler") == std::string::npos) {
    if (name == "u_max_steps") return "hint_range(1, 100000)";
    if (name == "u_refine_steps") return "hint_range(0, 64)";
    return "";
  }
  if (name == "u_bricks" || name == "u_sdf_bricks") return "filter_nearest, repeat_disable";
  if (cylindrical && (name == "u_deformation" || name == "u_alpha"))
    return "filter_linear, repeat_enable";
  return "filter_linear, repeat_disable";
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

// The body of fragment() in a Godot shader.
std::string fragment_body(const std::string& shader) {
  const size_t at = shader.find("void fragment() {");
  if (at == std::string::npos) return "";
  return shader.substr(at, shader.find("\n}\n", at) - at);
}

// One run of Godot's compiler over `files`.
struct CheckerRun {
  int status = -1;
  json report;
  std::string errors;  // its standard error
  double seconds = 0;
};

CheckerRun run_checker(const std::vector<fs::path>& files, const fs::path& dir) {
  const fs::path script = fs::path(RAYWARP_SOURCE_DIR) / "tests/godot/compile_gdshader.mjs";
  std::string command = "node '" + script.string() + "'";
  for (const fs::path& f : files) command += " '" + f.string() + "'";
  command +=
      " > '" + (dir / "report.json").string() + "' 2> '" + (dir / "stderr.txt").string() + "'";
  CheckerRun run;
  const auto start = std::chrono::steady_clock::now();
  const int status = std::system(command.c_str());
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.errors = slurp(dir / "stderr.txt");
  const std::string out = slurp(dir / "report.json");
  if (!out.empty()) run.report = json::parse(out, nullptr, false);
  return run;
}

// A small twisted octahedron and a box cut of it, baked once and exported as EXR atlases and
// DDS volumes, with the variants the renderer would pick under the default render settings.
struct Export {
  std::string stem;
  json sidecar;
  gl::Variant variant;
};

class GodotBundleTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    folder_ = new fs::path(fs::temp_directory_path() /
                           ("raywarp_engine_godot_" + std::to_string(::getpid())));
    fs::create_directories(*folder_);
    std::ofstream(*folder_ / "m.obj")
        << "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
           "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
    std::ofstream(*folder_ / "oct.json") << R"({"mesh": "m.obj", "boxes": [
              {"min": [-0.6, 0.1, -0.6], "max": [0.6, 1.1, 0.6],
               "deformer": {"type": "twist", "axis": "y", "angle_deg": 90},
               "implicit": {"type": "sdf", "resolution": 16}, "deformation": {"resolution": 16}},
              {"min": [-1.1, -1.1, -1.1], "max": [1.1, 0.0, 1.1],
               "deformer": {"type": "box_cut", "wedge": {"axis": "y", "from_deg": 0, "angle_deg": 90}},
               "cut_mode": "solid", "implicit": {"type": "sdf", "resolution": 16}}]})";
    const fs::path scene_file = *folder_ / "oct.json";
    const json document = read_scene_document(scene_file);
    const Scene scene = load_scene_json(document, scene_file);
    BakeSession session;
    MeshPtr mesh = session.mesh(scene.mesh);
    exports_ = new std::vector<Export>;
    ExportOptions options;
    options.formats = parse_formats("atlas-exr,dds", "formats");
    using F = Feature;
    const gl::Variant variants[2] = {
        make({F::SamplingThreshold, F::Skip}),
        make({F::SamplingThreshold, F::Cut, F::CutSolid, F::MovesNothing, F::Skip})};
    for (size_t i = 0; i < 2; ++i) {
      const BakedBox baked = session.bake(export_job(scene, i, mesh));
      const ExportSource source = export_source(scene, document, i, *mesh);
      const std::string stem = "oct_box" + std::to_string(i);
      exports_->push_back({stem, export_box(baked, source, options, *folder_, stem), variants[i]});
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*folder_);
    delete folder_;
    delete exports_;
  }
  static fs::path* folder_;
  static std::vector<Export>* exports_;
};
fs::path* GodotBundleTest::folder_ = nullptr;
std::vector<Export>* GodotBundleTest::exports_ = nullptr;

TEST(GodotRewrite, EveryUniformOfEveryVariantWithItsHintsAndDefault) {
  std::set<std::string> macros;
  const json values = all_values();
  for (const NamedVariant& nv : variants()) {
    SCOPED_TRACE(nv.name);
    for (const gl::FeatureInfo& f : gl::kFeatures)
      if (nv.variant.has(f.feature)) macros.insert(f.macro);
    const GodotMarch march = godot_march(nv.variant, values);
    for (const char* banned : {"#version", "precision", "#line", "gl_FragCoord", "gl_", "layout(",
                               "#if", "#include", "source_color"})
      EXPECT_EQ(march.text.find(banned), std::string::npos) << banned;
    for (const gl::FeatureInfo& f : gl::kFeatures)  // resolved, not carried
      EXPECT_EQ(march.text.find(f.macro), std::string::npos) << f.macro;
    EXPECT_NE(march.text.find("bool raywarp_clip("), std::string::npos);
    EXPECT_NE(march.text.find("bool raywarp_cast("), std::string::npos);
    const auto expected = glsl_uniforms(nv.variant);
    ASSERT_EQ(march.uniforms.size(), expected.size());
    const bool cylindrical = nv.variant.has(Feature::Cylindrical);
    for (const GodotUniform& u : march.uniforms) {
      SCOPED_TRACE(u.name);
      ASSERT_TRUE(expected.count(u.name));
      EXPECT_EQ(u.type, expected.at(u.name).first);
      EXPECT_EQ(u.array, expected.at(u.name).second);
      EXPECT_EQ(u.hints, expected_hints(u.name, u.type, cylindrical));
      // The declaration, as Godot reads it, is in the text.
      std::string decl = "uniform " + u.type + " " + u.name +
                         (u.array ? "[" + std::to_string(u.array) + "]" : "") +
                         (u.hints.empty() ? "" : " : " + u.hints) +
                         (u.value.empty() ? "" : " = " + u.value) + ";\n";
      EXPECT_NE(march.text.find(decl), std::string::npos) << decl;
      const bool sampler = u.type.find("sampler") != std::string::npos;
      // Defaults: every non-sampler, non-array uniform has one here; arrays take none in Godot.
      EXPECT_EQ(u.value.empty(), sampler || u.array > 0) << u.value;
    }
    for (const std::string& name : march.unset) EXPECT_GT(expected.at(name).second, 0) << name;
  }
  // Every feature macro of the table is covered by some variant.
  for (const gl::FeatureInfo& f : gl::kFeatures) EXPECT_TRUE(macros.count(f.macro)) << f.macro;
}

TEST(GodotRewrite, DefaultsAreGodotLiterals) {
  const json values = all_values();
  const GodotMarch march = godot_march(make({Feature::SamplingThreshold, Feature::Skip}), values);
  std::map<std::string, std::string> value;
  for (const GodotUniform& u : march.uniforms) value[u.name] = u.value;
  EXPECT_EQ(value["u_half_extents"], "vec3(1.0, 2.0, 3.0)");
  EXPECT_EQ(value["u_max_steps"], "1024");
  EXPECT_EQ(value["u_sdf_spacing"], "0.0625");
  EXPECT_EQ(value["u_lipschitz"], "1.0e+30");  // -1 (unknown) is no skipping by f
  // Floats always with a point (Godot converts no int to float).
  for (const GodotUniform& u : march.uniforms)
    if (u.type == "float") {
      EXPECT_NE(u.value.find('.'), std::string::npos) << u.name;
    }
  // A uniform without a value gets no default and is listed.
  json fewer = values;
  fewer.erase("u_step");
  const GodotMarch partial = godot_march(make({Feature::SamplingLinear}), fewer);
  EXPECT_EQ(partial.unset, std::vector<std::string>{"u_step"});
  EXPECT_NE(partial.text.find("uniform float u_step;\n"), std::string::npos);
  // A value of the wrong shape is an Error naming the uniform.
  json wrong = values;
  wrong["u_half_extents"] = {1.0, 2.0};
  try {
    godot_march(make({Feature::SamplingLinear}), wrong);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("u_half_extents"), std::string::npos) << e.what();
  }
}

TEST(GodotRewrite, RefusesWhatGodotCannotTake) {
  const gl::Variant v = make({Feature::SamplingLinear});
  const std::string ok =
      "#version 450 core\n#define RAYWARP_SAMPLING_LINEAR\n#line 2 1\n"
      "uniform float u_step;\nconst float k = 1.0;\nstruct S {\n  float f;\n};\n"
      "bool raywarp_cast(vec3 o,\n    vec3 d) {\n  return true;\n}\n";
  const GodotMarch m = godot_rewrite(ok, v, json::object());
  EXPECT_EQ(m.text.find("#version"), std::string::npos);
  EXPECT_EQ(m.text.find("#line"), std::string::npos);
  EXPECT_EQ(m.text.find("RAYWARP_SAMPLING_LINEAR"), std::string::npos);
  EXPECT_NE(m.text.find("bool raywarp_cast(vec3 o,\n    vec3 d) {"), std::string::npos);
  EXPECT_EQ(godot_rewrite("precision highp float;\n" + ok, v, json::object()).text, m.text);
  for (const std::string bad :
       {"float counter;\n", "vec3 g = vec3(1.0);\n", "float f(vec3 p);\n",
        "#extension GL_ARB_foo : enable\n", "layout(location = 0) out vec4 c;\n",
        "#include \"x.glsl\"\n", "float f() { return gl_FragCoord.x; }\n",
        "uniform sampler3D u_mystery;\n"}) {
    SCOPED_TRACE(bad);
    EXPECT_THROW(godot_rewrite(ok + bad, v, json::object()), Error);
  }
}

TEST(GodotShaders, BoxAndRemainderShape) {
  const json values = all_values();
  const gl::Variant v = make({Feature::SamplingThreshold, Feature::Cut, Feature::CutSolid});
  const std::string s = godot_box_shader(v, values, "demo_box0");
  EXPECT_EQ(s.rfind("shader_type spatial;\nrender_mode cull_front;\n", 0), 0u);
  EXPECT_EQ(s.find('@'), std::string::npos);  // every placeholder filled
  const std::string body = fragment_body(s);
  ASSERT_FALSE(body.empty());
  EXPECT_EQ(body.find("return"), std::string::npos);  // Godot refuses return in fragment()
  for (const char* needle :
       {"discard;", "DEPTH = ", "NORMAL = ", "ALBEDO = ", "LIGHT_VERTEX = ",
        "inverse(MODEL_MATRIX)", "MODEL_NORMAL_MATRIX", "INV_PROJECTION_MATRIX"})
    EXPECT_NE(body.find(needle), std::string::npos) << needle;
  EXPECT_NE(s.find("CURRENT_RENDERER == RENDERER_COMPATIBILITY"), std::string::npos);
  EXPECT_NE(s.find("VERTEX = mix(u_region_lower, u_region_upper, VERTEX + 0.5);"),
            std::string::npos);
  // source_color on the three colours and nowhere else; their defaults are sRGB-encoded.
  const std::regex colour(R"(uniform vec3 (\w+) : source_color = vec3\(([^)]*)\);)");
  std::set<std::string> colours;
  for (auto it = std::sregex_iterator(s.begin(), s.end(), colour); it != std::sregex_iterator();
       ++it)
    colours.insert((*it)[1]);
  EXPECT_EQ(colours, (std::set<std::string>{"u_albedo", "u_inside_colour", "u_cut_colour"}));
  size_t count = 0;
  for (size_t at = s.find(": source_color"); at != std::string::npos;
       at = s.find(": source_color", at + 1))
    ++count;
  EXPECT_EQ(count, 3u);
  const std::string albedo = "vec3(" + std::to_string(srgb_encode(0.8)).substr(0, 6);
  EXPECT_NE(s.find("u_albedo : source_color = " + albedo), std::string::npos) << albedo;

  const std::string r = godot_remainder_shader(3);
  EXPECT_EQ(r.find('@'), std::string::npos);
  EXPECT_NE(r.find("uniform vec3 u_box_centre[3];"), std::string::npos);
  EXPECT_NE(r.find("render_mode cull_disabled;"), std::string::npos);
  EXPECT_EQ(fragment_body(r).find("return"), std::string::npos);
  EXPECT_THROW(godot_remainder_shader(0), Error);
  EXPECT_THROW(godot_remainder_shader(17), Error);
}

TEST_F(GodotBundleTest, ImportScriptTablesAreTheSidecars) {
  for (const Export& e : *exports_) {
    SCOPED_TRACE(e.stem);
    const std::string gd = godot_import_script(e.sidecar, e.stem);
    EXPECT_EQ(gd.rfind("@tool\nextends EditorScript\n", 0), 0u);
    EXPECT_FALSE(std::regex_search(gd, std::regex("@[A-Z][A-Z0-9_]*@")));
    // GDScript indents with tabs only, and its brackets balance.
    std::istringstream in(gd);
    std::string line;
    int round = 0, square = 0, curly = 0;
    while (std::getline(in, line)) {
      EXPECT_NE(line.substr(0, line.find_first_not_of(" \t")).find(' '), 0u) << line;
      for (char c : line) {
        round += c == '(' ? 1 : c == ')' ? -1 : 0;
        square += c == '[' ? 1 : c == ']' ? -1 : 0;
        curly += c == '{' ? 1 : c == '}' ? -1 : 0;
      }
    }
    EXPECT_EQ(round, 0);
    EXPECT_EQ(square, 0);
    EXPECT_EQ(curly, 0);
    // The table (JSON, which is GDScript) is the sidecar's, and its files exist.
    const std::string marker = "const TEXTURES := ";
    const size_t at = gd.find(marker);
    ASSERT_NE(at, std::string::npos);
    const size_t end = gd.find("\n]\n", at);
    const json table = json::parse(gd.substr(at + marker.size(), end + 2 - at - marker.size()));
    std::set<std::string> uniforms;
    for (const json& t : table) {
      SCOPED_TRACE(t["name"].get<std::string>());
      const json& s = e.sidecar["textures"][t["name"].get<std::string>()];
      EXPECT_EQ(t["dims"], s["dims"]);
      EXPECT_EQ(t["scale"], s["scale"]);
      EXPECT_EQ(t["channels"], s["channels"].size());
      ASSERT_TRUE(t["exr"].is_object());
      ASSERT_TRUE(t["dds"].is_string());
      EXPECT_TRUE(fs::is_regular_file(*folder_ / t["exr"]["file"].get<std::string>()));
      EXPECT_TRUE(fs::is_regular_file(*folder_ / t["dds"].get<std::string>()));
      const json& tiles = t["exr"]["tiles"];
      EXPECT_GE(tiles[0].get<int>() * tiles[1].get<int>(), s["dims"][2].get<int>());
      EXPECT_EQ(t["resource"], e.stem + "." + t["name"].get<std::string>() + ".res");
      uniforms.insert(t["uniform"]);
    }
    // Every sampler of the box's variant has its texture (an export may carry more: the step
    // bounds for the bounded tracer, a box cut's identity deformation; they are made too).
    for (const auto& [name, type] : glsl_uniforms(e.variant))
      if (type.first.find("sampler") != std::string::npos) {
        EXPECT_TRUE(uniforms.count(name)) << name;
      }
  }
}

TEST_F(GodotBundleTest, SceneReferencesAndNumbersAreTheSidecars) {
  for (const Export& e : *exports_) {
    SCOPED_TRACE(e.stem);
    const json values = export_values(e.sidecar);
    const std::string scene = godot_scene(e.sidecar, e.stem, values);
    EXPECT_EQ(scene.rfind("[gd_scene format=3]\n", 0), 0u);
    EXPECT_FALSE(std::regex_search(scene, std::regex("@[A-Z][A-Z0-9_]*@")));
    const GodotFileNames names = godot_file_names(e.stem);
    const std::string folder = godot_folder(e.stem);
    EXPECT_EQ(folder, "res://raywarp/" + e.stem);
    for (const std::string& file : {names.box_shader, names.remainder_shader, std::string("m.obj")})
      EXPECT_NE(scene.find("path=\"" + folder + "/" + file + "\""), std::string::npos) << file;
    // Every ExtResource / SubResource used is declared, once.
    std::map<std::string, int> declared;
    const std::regex decl(R"re(^\[(ext|sub)_resource [^\]]*id="([^"]+)"\]$)re");
    std::istringstream in(scene);
    std::string line;
    while (std::getline(in, line)) {
      std::smatch m;
      if (std::regex_match(line, m, decl)) ++declared[m[1].str() + ":" + m[2].str()];
    }
    for (const auto& [id, n] : declared) EXPECT_EQ(n, 1) << id;
    const std::regex use(R"re((Ext|Sub)Resource\("([^"]+)"\))re");
    int uses = 0;
    for (auto it = std::sregex_iterator(scene.begin(), scene.end(), use);
         it != std::sregex_iterator(); ++it, ++uses) {
      const std::string kind = (*it)[1] == "Ext" ? "ext" : "sub";
      EXPECT_TRUE(declared.count(kind + ":" + (*it)[2].str())) << (*it)[0];
    }
    EXPECT_GE(uses, 6);
    // Every sampler of the variant gets its texture, the one the import script writes.
    for (const auto& [name, type] : glsl_uniforms(e.variant)) {
      if (type.first.find("sampler") == std::string::npos) continue;
      EXPECT_NE(scene.find("shader_parameter/" + name + " = ExtResource(\"" + name + "\")"),
                std::string::npos)
          << name;
    }
    // The box's transform (Godot writes a basis by rows, then the origin) and region.
    const json& R = e.sidecar["box"]["rotation"];
    const json& c = e.sidecar["box"]["centre"];
    const json& h = e.sidecar["box"]["half_extents"];
    const std::regex transform(R"(transform = Transform3D\(([^)]*)\))");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(scene, m, transform));
    std::vector<double> t;
    std::istringstream numbers(std::regex_replace(m[1].str(), std::regex(","), " "));
    for (double x; numbers >> x;) t.push_back(x);
    ASSERT_EQ(t.size(), 12u);
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(t[3 * r + k], R[r][k].get<double>(), 1e-8);
      EXPECT_NEAR(t[9 + r], c[r].get<double>(), 1e-8);
    }
    ASSERT_TRUE(std::regex_search(scene, m, std::regex(R"(custom_aabb = AABB\(([^)]*)\))")));
    std::vector<double> box;
    std::istringstream aabb(std::regex_replace(m[1].str(), std::regex(","), " "));
    for (double x; aabb >> x;) box.push_back(x);
    ASSERT_EQ(box.size(), 6u);
    const json& region = e.sidecar["render"]["ray_cast_region"];
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(box[a], region["min"][a].get<double>() * h[a].get<double>(), 1e-7);
      EXPECT_NEAR(box[a] + box[3 + a], region["max"][a].get<double>() * h[a].get<double>(), 1e-7);
    }
    const bool cut = e.sidecar["render"]["has_cut"].get<bool>();
    EXPECT_NE(scene.find(std::string("shader_parameter/u_two_sided = ") + (cut ? "true" : "false")),
              std::string::npos);
    // The exports' values leave no uniform of their variant without a default.
    EXPECT_TRUE(godot_march(e.variant, values).unset.empty());
  }
}

// All the shaders in one run of Godot's compiler: it boots once.
TEST_F(GodotBundleTest, EveryShaderCompilesInGodot) {
  const fs::path dir = *folder_ / "godot";
  fs::create_directories(dir);
  std::vector<fs::path> files;
  auto add = [&](const std::string& name, const std::string& text) {
    files.push_back(dir / (name + ".gdshader"));
    write(files.back(), text);
  };
  const json values = all_values();
  for (const NamedVariant& nv : variants())
    add("box_" + nv.name, godot_box_shader(nv.variant, values, nv.name));
  add("remainder_1", godot_remainder_shader(1));
  add("remainder_16", godot_remainder_shader(16));
  for (const Export& e : *exports_)
    add("export_" + e.stem, godot_box_shader(e.variant, export_values(e.sidecar), e.stem));
  // What `raywarp bake --engines godot` writes for every example and the extra scenes
  // (tests/engine_scenes.h): each box's shader.
  const fs::path exported = *folder_ / "examples";
  int boxes = 0;
  for (const fs::path& scene : testing::engine_test_scenes(exported / "scenes")) {
    const std::string command = std::string(RAYWARP_BINARY) + " bake '" + scene.string() +
                                "' --out '" + exported.string() +
                                "' --format atlas-exr --engines godot > /dev/null 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
  }
  for (const auto& e : fs::recursive_directory_iterator(exported)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".gdshader" || name.find(".remainder.") != std::string::npos)
      continue;
    files.push_back(e.path());
    ++boxes;
  }
  EXPECT_GE(boxes, 25);
  // The control: Godot must refuse a return in fragment() (the checker checks).
  std::string bad = godot_box_shader(variants()[0].variant, values, "bad");
  bad.replace(bad.find("\t\tdiscard;\n"), 11, "\t\treturn;\n");
  add("control_return_in_fragment", bad);
  // The renderer defines the box shader's depth convention relies on: under the checker's
  // Compatibility renderer the branch of RENDERER_COMPATIBILITY is taken (an invalid line there
  // fails), the other is not, and all three names are defined (an undefined one fails #if).
  const std::string probe =
      "shader_type spatial;\n#if CURRENT_RENDERER == RENDERER_COMPATIBILITY\n%s\n"
      "#elif CURRENT_RENDERER == RENDERER_FORWARD_PLUS || CURRENT_RENDERER == "
      "RENDERER_MOBILE\n%s\n#endif\nvoid fragment() {\n\tALBEDO = vec3(0.5);\n}\n";
  auto probe_with = [&](const char* compat, const char* other) {
    std::string text = probe;
    text.replace(text.find("%s"), 2, compat);
    text.replace(text.find("%s"), 2, other);
    return text;
  };
  add("control_compatibility_branch_taken", probe_with("not a shader line;", ""));
  add("renderer_defines", probe_with("", "not a shader line;"));

  // RAYWARP_KEEP_GODOT=DIR keeps what this test generates there (with the first export's import
  // script and scene), to look at or to try in Godot.
  if (const char* keep = std::getenv("RAYWARP_KEEP_GODOT")) {
    const Export& e = exports_->front();
    const GodotFileNames names = godot_file_names(e.stem);
    write(dir / names.import_script, godot_import_script(e.sidecar, e.stem));
    write(dir / names.scene, godot_scene(e.sidecar, e.stem, export_values(e.sidecar)));
    fs::create_directories(keep);
    fs::copy(dir, keep, fs::copy_options::overwrite_existing | fs::copy_options::recursive);
  }
  const CheckerRun run = run_checker(files, dir);
  if (run.status == 2 && (run.errors.find("npm ci") != std::string::npos ||
                          run.errors.find("Chromium not found") != std::string::npos))
    GTEST_SKIP() << "Godot's shader compiler cannot run here (tests/godot/README.md): "
                 << run.errors;
  ASSERT_EQ(run.status == 0 || run.status == 1, true) << "status " << run.status << "\n"
                                                      << run.errors;
  ASSERT_TRUE(run.report.is_object() && run.report.contains("results")) << run.errors;
  const json& results = run.report["results"];
  ASSERT_EQ(results.size(), files.size());
  int compiled = 0;
  for (size_t i = 0; i < files.size(); ++i) {
    const json& r = results[i];
    const std::string name = files[i].stem().string();
    EXPECT_EQ(fs::path(r["file"].get<std::string>()).filename(), files[i].filename());
    if (name.rfind("control_", 0) == 0) {
      EXPECT_FALSE(r["ok"].get<bool>()) << name << " compiled: the checker does not check";
      continue;
    }
    EXPECT_TRUE(r["ok"].get<bool>() && r["errors"].empty()) << name << ":\n" << r["errors"].dump(1);
    compiled += r["ok"].get<bool>();
  }
  std::printf(
      "[figures] Godot %s compiled %d of %zu shaders (and refused the 2 controls) in one "
      "run of %.1f s (boot %.1f s)\n",
      run.report.value("godot", "?").c_str(), compiled, files.size() - 2, run.seconds,
      run.report.value("boot_ms", 0) / 1000.0);
  std::printf(
      "[figures] of them %d box shaders that raywarp bake wrote for the examples and the "
      "extra scenes of tests/engine_scenes.h\n",
      boxes);
}

}  // namespace
}  // namespace raywarp
