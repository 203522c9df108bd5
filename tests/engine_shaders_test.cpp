// The engines' HLSL (cli/engine_shaders.h) executes as raywarp's GLSL does. No engine or D3D
// compiler runs here, so the HLSL goes the other way round: the translated march, in Unity's form
// (the include) and in Unreal's (the struct), under a stand-in engine entry
// (tests/engines/raycast_entry.hlsl), is compiled by glslang's HLSL front end, carried to GLSL 4.50
// by SPIRV-Cross and drawn by raywarp's renderer in place of raycast.frag.glsl. Its image must be
// the native shader's: IoU >= 0.9999 and no pixel's depth off by 1 % of the scene's diagonal, on
// every shipped example, each cut mode, both mappings, a depth cube, bounded sampling and two
// boxes.
#include "cli/engine_shaders.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
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
#include "library/bake_cache.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "library/texture_map.h"
#include "tests/engine_scenes.h"
#include "tests/run_raywarp.h"
#include "translate/translate.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

// Unity's include, the struct alone, and the struct inside Unreal's Custom node.
enum class Form { Include, Struct, UnrealNode };
const char* form_name(Form f) {
  return f == Form::Include ? "include" : f == Form::Struct ? "struct" : "unreal node";
}

// The Custom node's code as the body of a function of its inputs, called by the stand-in material
// (tests/engines/unreal_entry.hlsl) with the renderer's uniforms.
std::string unreal_hlsl(const MarchHlsl& march) {
  std::string s =
      "struct FMaterialPixelParameters { float4 SvPosition; };\n"
      "struct FViewStandIn { float3 ViewForward; };\nstatic FViewStandIn ResolvedView;\n";
  for (const std::string& u : march.uniforms) s += u + ";\n";
  for (const std::string& r : march.resources) s += r + ";\n";
  std::string params = "FMaterialPixelParameters Parameters", args = "parameters";
  std::map<std::string, std::string> sampler_of;  // a texture's sampler global
  for (const std::string& r : march.resources)
    if (r.rfind("SamplerState ", 0) == 0) {
      const std::string name = r.substr(13);
      sampler_of[name.substr(
          0, name.find(name.find("_linear_") != std::string::npos ? "_linear_" : "_point_"))] =
          name;
    }
  const std::map<std::string, std::string> engine = {{"PixelWorld", "pixel_world"},
                                                     {"CameraWorld", "u_eye"},
                                                     {"WorldToBoxX", "u_object_to_box[0]"},
                                                     {"WorldToBoxY", "u_object_to_box[1]"},
                                                     {"WorldToBoxZ", "u_object_to_box[2]"},
                                                     {"BoxToWorldX", "u_box_to_object[0]"},
                                                     {"BoxToWorldY", "u_box_to_object[1]"},
                                                     {"BoxToWorldZ", "u_box_to_object[2]"},
                                                     {"Albedo", "u_albedo"},
                                                     {"InsideColour", "u_inside_colour"},
                                                     {"CutColour", "u_cut_colour"}};
  for (const auto& [type, name] : unreal_node_inputs(march)) {
    params += ", " + type + " " + name;
    std::string arg = name;
    if (engine.count(name)) arg = engine.at(name);
    if (type == "SamplerState") arg = sampler_of.at(name.substr(0, name.size() - 7));
    args += ", " + arg;
  }
  // glslang takes a struct with methods at file scope only (declared in a function body, its
  // methods are reported as recursive), while D3D's compilers take it in the body, where the node
  // puts it: the struct is lifted out of the body, the rest stays as Unreal runs it.
  std::string body = unreal_custom_node(march, "test");
  std::string structure = march_hlsl_struct(march, "RaywarpMarch_test");
  while (structure.back() == '\n') structure.pop_back();
  const size_t at = body.find(structure);
  if (at == std::string::npos) throw Error("the node's code does not hold the march's struct");
  body.erase(at, structure.size());
  s += structure + "\nfloat4 RaywarpCustomNode(" + params +
       ", out float3 WorldNormal, out float DepthOffset) {\n" + body + "\n}\n";
  s += "#define RAYWARP_NODE_CALL RaywarpCustomNode(" + args + ", world_normal, depth_offset)\n";
  return s + read_text(fs::path(RAYWARP_SOURCE_DIR) / "tests/engines/unreal_entry.hlsl");
}

// The stand-in entry over the march in `form`, as HLSL.
std::string entry_hlsl(const MarchHlsl& march, Form form) {
  if (form == Form::UnrealNode) return unreal_hlsl(march);
  const std::string entry =
      read_text(fs::path(RAYWARP_SOURCE_DIR) / "tests/engines/raycast_entry.hlsl");
  if (form == Form::Include)
    return march_hlsl_include(march) +
           "\n#define RAYWARP_MARCH_SETUP\n#define RAYWARP_MARCH(f) f\n" + entry;
  // Unreal's form: the uniforms and textures arrive as the node's inputs (here globals of the
  // same names) and are copied into the struct.
  std::string s;
  for (const std::string& u : march.uniforms) s += u + ";\n";
  for (const std::string& r : march.resources) s += r + ";\n";
  s += march_hlsl_struct(march, "RaywarpMarch") + "\n#define RAYWARP_MARCH_SETUP RaywarpMarch m;";
  for (const std::string& name : march_members(march)) s += " m." + name + " = " + name + ";";
  return s + "\n#define RAYWARP_MARCH(f) m.f\n" + entry;
}

// `glsl` (SPIRV-Cross's GLSL 4.50) as the body of a raycast.frag.glsl that the assembler keeps for
// exactly `variant`: its #version line dropped, the text under #if over every feature macro.
std::string variant_branch(const gl::Variant& variant, const std::string& glsl, bool first) {
  std::string condition;
  for (const gl::FeatureInfo& f : gl::kFeatures)
    condition += std::string(condition.empty() ? "" : " && ") +
                 (variant.has(f.feature) ? "" : "!") + "defined(" + f.macro + ")";
  std::string body = glsl.substr(glsl.find('\n') + 1);
  return std::string(first ? "#if " : "#elif ") + condition + "\n" + body;
}

struct RoundTrip {
  Image native, translated;
  ImageComparison comparison;
  double diagonal = 0.0;
  std::vector<std::string> variants;
};

// Renders `scene` natively and through the HLSL round trip in `form`.
// `map` (if any) changes the prepared boxes before they are drawn (a texture map M).
using MapBoxes = std::function<void(const Scene&, std::vector<BoxTextures>&)>;

RoundTrip round_trip(const Scene& scene, Form form, int width, int height, const MapBoxes& map) {
  std::ostringstream log;
  BakeCache cache(fs::path(RAYWARP_BUILD_DIR) / "test-cache");
  const PreparedScene prepared = prepare_scene(scene, log, &cache, bool(map));
  std::vector<BoxTextures> boxes = prepared.textures();
  if (map) map(scene, boxes);
  context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(boxes);
  RoundTrip r;
  r.native = renderer.render(scene.camera.value(), width, height, scene.render);

  std::map<std::string, std::string> files = gl::embedded_shaders();
  std::string frag;
  std::set<unsigned long> seen;
  for (const BoxTextures& b : boxes) {
    const gl::Variant variant = gl::raycast_variant(b, scene.render);
    if (!seen.insert(variant.key()).second) continue;
    const MarchHlsl march = translate_march(variant);
    r.variants.push_back(std::string(form_name(form)) + ": " +
                         std::to_string(march.features.size()) + " features");
    const std::string hlsl = entry_hlsl(march, form);
    const std::string glsl = translate::spirv_to_glsl(
        translate::hlsl_to_spirv(hlsl, translate::Stage::Fragment, "main", "raycast_entry.hlsl"));
    frag += variant_branch(variant, glsl, frag.empty());
  }
  files["raycast.frag.glsl"] = frag + "#endif\n";
  renderer.set_shader_files(gl::ShaderFiles(files));
  r.translated = renderer.render(scene.camera.value(), width, height, scene.render);
  const Eigen::AlignedBox3d bounds = mesh_bounds(prepared.mesh());
  r.diagonal = bounds.diagonal().norm();
  r.comparison = compare_images(r.native, r.translated, 0.01 * r.diagonal);
  return r;
}

Scene example(const std::string& name, const std::function<void(nlohmann::json&)>& edit = {}) {
  const fs::path path = fs::path(RAYWARP_SOURCE_DIR) / "examples" / name;
  nlohmann::json doc = nlohmann::json::parse(read_text(path));
  if (edit) edit(doc);
  return load_scene_json(doc, path);
}

struct Case {
  std::string name;
  std::function<Scene()> scene;
  MapBoxes map;  // baked with D's texel centres on the lower faces, then mapped
};
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

std::vector<Case> cases() {
  std::vector<Case> out;
  for (const auto& e : fs::directory_iterator(fs::path(RAYWARP_SOURCE_DIR) / "examples"))
    if (e.path().extension() == ".json") {
      const std::string file = e.path().filename().string();
      out.push_back({file, [file] { return example(file); }, {}});
    }
  std::sort(out.begin(), out.end(), [](const Case& a, const Case& b) { return a.name < b.name; });
  // Beyond the examples: the cut modes and mappings they do not combine, a depth cube, bounded
  // sampling, two boxes (tests/engine_scenes.h).
  for (const raywarp::testing::ExtraScene& e : raywarp::testing::extra_scenes())
    out.push_back({e.name, [e] { return example(e.example, e.edit); }, {}});
  // The animation an engine drives through M (the sidecar's "animation"): the head's 360-degree
  // twist shown at 150 degrees by M, no bake.
  out.push_back({"head_twist_at_150_by_m", [] { return example("bunny_head_twist.json"); },
                 [](const Scene& scene, std::vector<BoxTextures>& boxes) {
                   BoxSpec spec = scene.boxes[0];
                   spec.deformer.angle_deg = 150.0;
                   const TextureMapping m = twist_angle_mapping(spec, boxes[0], 360.0);
                   boxes[0].texture_map = m.map;
                   boxes[0].region = m.region;
                   boxes[0].lipschitz = m.lipschitz;
                 }});
  return out;
}

class EngineRoundTrip : public ::testing::TestWithParam<Case> {};

TEST_P(EngineRoundTrip, HlslDrawsTheNativeImage) {
  const Case& c = GetParam();
  Scene scene;
  try {
    scene = c.scene();
  } catch (const Error& e) {
    FAIL() << c.name << ": " << e.what();
  }
  const int w = 256, h = 256;
  for (Form form : {Form::Include, Form::Struct, Form::UnrealNode}) {
    RoundTrip r;
    try {
      r = round_trip(scene, form, w, h, c.map);
    } catch (const Error& e) {
      FAIL() << c.name << " (" << form_name(form) << "): " << e.what();
    }
    const ImageComparison& k = r.comparison;
    std::printf(
        "[figures] %s, %s form: IoU %.5f, %.3f %% of pixels over 1 %% of the diagonal, "
        "max depth error %.2e (diagonal %.2f)\n",
        c.name.c_str(), form_name(form), k.iou, 100.0 * k.fraction_over, k.max_depth_error,
        r.diagonal);
    if (const char* dir = std::getenv("RAYWARP_ROUND_TRIP_IMAGES")) {
      const std::string base = std::string(dir) + "/" + c.name + "_" + form_name(form);
      write_png(base + "_native.png", r.native);
      write_png(base + "_hlsl.png", r.translated);
    }
    EXPECT_GE(k.iou, 0.9999) << c.name << " " << form_name(form);
    EXPECT_EQ(k.fraction_over, 0.0) << c.name << " " << form_name(form);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, EngineRoundTrip, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           std::string s = info.param.name;
                           for (char& ch : s)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return s;
                         });

}  // namespace

namespace {

// The programs of a ShaderLab file: for each Pass, its HLSL (the Shader's and its SubShader's
// HLSLINCLUDE blocks, then its HLSLPROGRAM) and the entry points its #pragmas name.
struct UnityPass {
  std::string label, hlsl, vertex, fragment;
  std::vector<std::string> keywords;  // of its multi_compile pragmas
};

std::vector<UnityPass> unity_passes(const std::string& shader) {
  std::vector<UnityPass> passes;
  std::istringstream in(shader);
  std::string line, shader_include, subshader_include, block, name;
  enum { None, Include, Program } mode = None;
  int subshader = -1, pass = 0;
  while (std::getline(in, line)) {
    const std::string t = line.substr(std::min(line.size(), line.find_first_not_of(' ')));
    if (mode == None) {
      if (t == "SubShader") {
        ++subshader;
        subshader_include.clear();
      } else if (t == "HLSLINCLUDE" || t == "HLSLPROGRAM") {
        mode = t == "HLSLINCLUDE" ? Include : Program;
        block.clear();
      } else if (t.rfind("Name ", 0) == 0) {
        name = t.substr(5);
      }
      continue;
    }
    if (t != "ENDHLSL") {
      block += line + "\n";
      continue;
    }
    if (mode == Include) {
      (subshader < 0 ? shader_include : subshader_include) += block;
    } else {
      UnityPass p;
      p.label =
          "SubShader " + std::to_string(subshader) + " pass " + std::to_string(pass++) + " " + name;
      p.hlsl = shader_include + subshader_include + block;
      std::smatch m;
      static const std::regex vert(R"(#pragma vertex (\w+))"), frag(R"(#pragma fragment (\w+))"),
          multi(R"(#pragma multi_compile\w* _ ([\w ]+))");
      if (std::regex_search(block, m, vert)) p.vertex = m[1];
      if (std::regex_search(block, m, frag)) p.fragment = m[1];
      for (auto it = std::sregex_iterator(block.begin(), block.end(), multi);
           it != std::sregex_iterator(); ++it) {
        std::istringstream words((*it)[1].str());
        std::string w;
        while (words >> w) p.keywords.push_back(w);
      }
      passes.push_back(p);
      name.clear();
    }
    mode = None;
  }
  return passes;
}

// `hlsl` with its #include lines replaced by the files of `files` (by the name in quotes), once
// each, recursively; an include of no file of `files` is an Error.
std::string resolve_includes(const std::string& hlsl,
                             const std::map<std::string, std::string>& files,
                             std::set<std::string>& done) {
  std::istringstream in(hlsl);
  std::string line, out;
  static const std::regex include(R"re(^\s*#include\s+"([^"]+)")re");
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, include)) {
      out += line + "\n";
      continue;
    }
    const auto f = files.find(m[1]);
    if (f == files.end()) throw Error("no stand-in for #include \"" + m[1].str() + "\"");
    if (done.insert(m[1]).second) out += resolve_includes(f->second, files, done);
  }
  return out;
}

// The exported shaders of every example and extra scene (raywarp bake, DDS, tests/engine_scenes.h)
// compile pass by pass in glslang's HLSL front end against the stand-ins of tests/engines/unity/,
// without keywords and with every keyword of the pass's multi_compile pragmas. About a minute:
// every keyword combination of every pass of every scene is its own compile, and a combination
// left out is a shader that can fail in Unity unseen.
TEST(UnityShader, EveryPassOfTheExportCompilesAgainstStandIns) {
  const fs::path out = fs::path(RAYWARP_BUILD_DIR) / "test-unity-shaders";
  fs::remove_all(out);
  const fs::path stand_ins = fs::path(RAYWARP_SOURCE_DIR) / "tests/engines/unity";
  int compiles = 0, shaders = 0, boxes = 0;
  for (const fs::path& scene : raywarp::testing::engine_test_scenes(out / "scenes")) {
    std::string log;
    ASSERT_EQ(raywarp::testing::run_raywarp("bake " + scene.string() + " --out " + out.string() +
                                                " --format dds --engines unity",
                                            &log),
              0)
        << log;
    for (size_t at = log.find("engine bundles in"); at != std::string::npos;
         at = log.find("engine bundles in", at + 1))
      ++boxes;
  }
  int remainders = 0, graphs = 0;
  for (const auto& e : fs::recursive_directory_iterator(out)) {
    if (e.path().extension() != ".shader") continue;
    const bool remainder = e.path().stem().string().rfind("RaywarpRemainder_", 0) == 0;
    (remainder ? remainders : shaders) += 1;
    const fs::path dir = e.path().parent_path();
    const std::string stem = e.path().stem().string().substr(
        std::string(remainder ? "RaywarpRemainder_" : "Raywarp_").size());
    std::map<std::string, std::string> files = {
        {"Packages/com.unity.render-pipelines.universal/ShaderLibrary/Core.hlsl",
         read_text(stand_ins / "urp_core.hlsl")},
        {"Packages/com.unity.render-pipelines.universal/ShaderLibrary/Lighting.hlsl",
         read_text(stand_ins / "urp_lighting.hlsl")},
        {"UnityCG.cginc", read_text(stand_ins / "unitycg.hlsl")},
        {"Lighting.cginc", read_text(stand_ins / "lighting_cginc.hlsl")},
        {"raywarp_" + stem + ".hlsl", read_text(dir / ("raywarp_" + stem + ".hlsl"))},
        {"RaywarpUnity.hlsl", read_text(dir / "RaywarpUnity.hlsl")},
        {"RaywarpInsideBox.hlsl", read_text(dir / "RaywarpInsideBox.hlsl")},
        {"RaywarpRemainder.hlsl", read_text(dir / "RaywarpRemainder.hlsl")}};
    if (!remainder) {
      // The Shader Graph Custom Function, called as a graph calls it (URP's Core.hlsl first).
      const std::string graph = "RaywarpShaderGraph_" + stem + ".hlsl";
      files[graph] = read_text(dir / graph);
      std::set<std::string> done;
      const std::string hlsl = resolve_includes(
          "#include \"Packages/com.unity.render-pipelines.universal/ShaderLibrary/Core.hlsl\"\n"
          "#include \"" +
              graph +
              "\"\n"
              "float4 graph_frag(float4 position : SV_Position, float3 world : TEXCOORD0) : "
              "SV_Target {\n"
              "  float hit, depth; float3 p, n, albedo;\n"
              "  RaywarpMarch_" +
              identifier(stem) +
              "_float(world, hit, p, n, albedo, depth);\n"
              "  return float4(albedo * hit + n + p, depth);\n}\n",
          files, done);
      try {
        translate::hlsl_to_spirv(hlsl, translate::Stage::Fragment, "graph_frag", graph);
        ++graphs;
      } catch (const Error& error) {
        ADD_FAILURE() << error.what();
      }
    }
    const std::vector<UnityPass> passes = unity_passes(read_text(e.path()));
    EXPECT_EQ(passes.size(), 5u) << e.path();
    for (const UnityPass& p : passes) {
      std::vector<std::string> defines = {""};
      if (!p.keywords.empty()) {
        std::string all;
        for (const std::string& k : p.keywords) all += "#define " + k + "\n";
        defines.push_back(all);
      }
      for (const std::string& d : defines) {
        std::set<std::string> done;
        const std::string hlsl = d + resolve_includes(p.hlsl, files, done);
        for (const auto& [entry, stage] : {std::pair{p.vertex, translate::Stage::Vertex},
                                           std::pair{p.fragment, translate::Stage::Fragment}}) {
          ASSERT_FALSE(entry.empty()) << p.label;
          try {
            translate::hlsl_to_spirv(hlsl, stage, entry,
                                     e.path().filename().string() + " " + p.label);
            ++compiles;
          } catch (const Error& error) {
            ADD_FAILURE() << error.what();
          }
        }
      }
    }
  }
  EXPECT_EQ(shaders, boxes);  // one per box
  EXPECT_EQ(remainders, boxes);
  EXPECT_EQ(graphs, boxes);
  EXPECT_GE(shaders, 25);
  std::printf(
      "[figures] Unity: %d box shaders, %d remainder shaders, %d pass programs and %d Shader Graph "
      "functions compiled against the stand-ins\n",
      shaders, remainders, compiles, graphs);
}

}  // namespace

namespace {

// --engines picks the bundles; a texture over an engine's 3D limit is refused before anything is
// written, naming the box, the texture, the engine, its limit and the resolution that would fit.
TEST(EngineSelection, PicksTheBundlesAndRefusesTexturesOverAnEnginesLimit) {
  const fs::path out = fs::path(RAYWARP_BUILD_DIR) / "test-engine-selection";
  fs::remove_all(out);
  std::string log;
  const std::string scene = std::string(RAYWARP_SOURCE_DIR) + "/examples/bunny_cut_solid.json";
  EXPECT_EQ(raywarp::testing::run_raywarp(
                "bake " + scene + " --out " + out.string() + " --format dds --engines unity,unreal",
                &log),
            0)
      << log;
  const fs::path bundles = out / "bunny_cut_solid_box0.engines";
  EXPECT_TRUE(fs::exists(bundles / "unity/Shaders/Raywarp_bunny_cut_solid_box0.shader"));
  EXPECT_TRUE(fs::exists(bundles / "unreal/RaywarpCustomNode_bunny_cut_solid_box0.hlsl"));
  // The remainder's Custom node compiles as the body of a function of its inputs.
  const std::string remainder =
      "float RaywarpRemainder(float3 PixelWorld, float4 WorldToBoxX, float4 WorldToBoxY, "
      "float4 WorldToBoxZ, float3 HalfExtents) {\n" +
      read_text(bundles / "unreal/RaywarpRemainderNode.hlsl") +
      "\n}\nfloat4 remainder_frag(float4 position : SV_Position, float3 world : TEXCOORD0) : "
      "SV_Target {\n  return RaywarpRemainder(world, float4(1, 0, 0, 0), float4(0, 1, 0, 0), "
      "float4(0, 0, 1, 0), float3(1, 1, 1)).xxxx;\n}\n";
  EXPECT_NO_THROW(translate::hlsl_to_spirv(remainder, translate::Stage::Fragment, "remainder_frag",
                                           "RaywarpRemainderNode.hlsl"));
  // Unreal's script makes the material: the node's inputs, the decode factors the sidecar's scales.
  const std::string py = read_text(bundles / "unreal/import_bunny_cut_solid_box0.py");
  const std::string marker = "INPUTS = json.loads(r" + std::string(3, '\'');
  const std::string inputs_json = py.substr(py.find(marker) + marker.size());
  const nlohmann::json inputs =
      nlohmann::json::parse(inputs_json.substr(0, inputs_json.find(std::string(3, '\''))));
  const nlohmann::json side = nlohmann::json::parse(read_text(out / "bunny_cut_solid_box0.json"));
  int textures = 0;
  for (const auto& in : inputs) {
    textures += in[0] == "texture";
    if (in[1] == "u_alpha_decode") {
      EXPECT_EQ(in[2], side["textures"]["alpha"]["scale"][0]);
    }
  }
  EXPECT_EQ(textures, 2);  // a box cut's distance grid and alpha map
  const std::string compile =
      "python3 -m py_compile " + (bundles / "unreal/import_bunny_cut_solid_box0.py").string();
  EXPECT_EQ(std::system(compile.c_str()), 0) << compile;
  EXPECT_FALSE(fs::exists(bundles / "threejs"));
  EXPECT_FALSE(fs::exists(bundles / "godot"));

  log.clear();
  EXPECT_EQ(raywarp::testing::run_raywarp(
                "bake " + scene + " --out " + out.string() + " --engines unity,vr", &log),
            2);
  EXPECT_NE(log.find("--engines: \"vr\" is no engine"), std::string::npos) << log;
  EXPECT_NE(log.find("threejs, unity, unreal, godot"), std::string::npos) << log;

  // A distance grid of 300 texels a side: over three.js's 256, within the others' 2048.
  nlohmann::json doc = nlohmann::json::parse(read_text(scene));
  doc["mesh"] = std::string(RAYWARP_SOURCE_DIR) + "/examples/meshes/bunny.ply";
  doc["camera"] = std::string(RAYWARP_SOURCE_DIR) + "/examples/cameras/front.json";
  doc["boxes"][0]["implicit"]["resolution"] = 300;
  const fs::path big = out / "big.json";
  std::ofstream(big) << doc.dump(2);
  const fs::path refused = out / "refused";
  log.clear();
  EXPECT_EQ(
      raywarp::testing::run_raywarp("bake " + big.string() + " --out " + refused.string(), &log),
      2);
  for (const char* words : {"boxes[0]: its distance texture is", "over the 256 a side that threejs",
                            "set boxes[0].implicit.resolution to at most", "--engines"})
    EXPECT_NE(log.find(words), std::string::npos) << words << "\n" << log;
  EXPECT_TRUE(!fs::exists(refused) || fs::is_empty(refused)) << "something was written";
  log.clear();
  EXPECT_EQ(raywarp::testing::run_raywarp("bake " + big.string() + " --out " + refused.string() +
                                              " --engines unity,unreal,godot",
                                          &log),
            0)
      << log;
}

}  // namespace

namespace {

// A box whose only deformer is a twist or a peel is exported for animation through M: D's texel
// centres on the lower faces, the sidecar's "animation" rule, and engine shaders whose M rows are
// material properties (the head_twist_at_150_by_m round trip draws such an M); a composition is
// not.
TEST(EngineAnimation, TwistsAndPeelsExportForAnAnimationThroughM) {
  const fs::path out = fs::path(RAYWARP_BUILD_DIR) / "test-engine-animation";
  fs::remove_all(out);
  for (const char* scene : {"bunny_head_twist", "bunny_peel", "bunny_twist_bend"}) {
    std::string log;
    ASSERT_EQ(raywarp::testing::run_raywarp(
                  "bake " + std::string(RAYWARP_SOURCE_DIR) + "/examples/" + scene +
                      ".json --out " + out.string() + " --format dds --engines unity,godot",
                  &log),
              0)
        << log;
    const std::string stem = std::string(scene) + "_box0";
    const nlohmann::json side = nlohmann::json::parse(read_text(out / (stem + ".json")));
    const std::string unity =
        read_text(out / (stem + ".engines/unity/Shaders/Raywarp_" + stem + ".shader"));
    const std::string godot = read_text(out / (stem + ".engines/godot/" + stem + ".gdshader"));
    const bool animated = std::string(scene) != "bunny_twist_bend";
    EXPECT_EQ(side.contains("animation"), animated) << scene;
    EXPECT_EQ(unity.find("u_texture_map_x (") != std::string::npos, animated) << scene;
    EXPECT_EQ(godot.find("uniform vec4 u_texture_map_x") != std::string::npos, animated) << scene;
    if (!animated) continue;
    EXPECT_EQ(side["animation"]["parameter"],
              std::string(scene) == "bunny_peel" ? "hinge" : "angle_deg");
    EXPECT_EQ(side["animation"]["axis"], std::string(scene) == "bunny_peel" ? "x" : "y")
        << side["animation"];
  }
}

}  // namespace
