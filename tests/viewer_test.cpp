// Named after no one source: the viewer/ folder in a browser, with its assets from cli/.
// The browser viewer (viewer/) and what it reads (cli/viewer_assets.h): a small library folder is
// built (the exported KTX2 textures, the mesh binary, the shader bundle, index.json, the viewer),
// every shader of the bundle must pass glslangValidator (GLSL 4.50 and ES 3.00), and headless
// chromium (SwiftShader's WebGL2) must draw each entry as `raywarp render` draws the scene:
// silhouette IoU >= 0.99 over the pixels that differ from the background colour.
#include <gtest/gtest.h>
#include <stb/stb_image.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "base/atomic_file.h"
#include "base/error.h"
#include "cli/export.h"
#include "cli/viewer_assets.h"
#include "cli/viewer_files.h"
#include "gl/glsl_es.h"
#include "library/bake.h"
#include "library/camera.h"
#include "library/export.h"
#include "library/image.h"
#include "library/scene.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int code;
  std::string output;
};

CommandResult shell(const std::string& cmd) {
  FILE* pipe = popen((cmd + " 2>&1").c_str(), "r");
  if (!pipe) return {-1, "popen failed"};
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

bool have(const std::string& program) {
  return shell("command -v " + program + " >/dev/null").code == 0;
}

// The scenes of the library: examples/, and one written by the test (a bend sphere traced with
// bounded steps, under an orthographic camera, 320 x 240, with a hollow cut's colours).
struct SceneCase {
  std::string name;
  fs::path file;
};
std::vector<SceneCase> scene_cases(const fs::path& out) {
  const fs::path examples = fs::path(RAYWARP_SOURCE_DIR) / "examples";
  return {{"twist", examples / "bunny_twist.json"},
          {"cut_solid", examples / "bunny_cut_solid.json"},
          {"cut_hollow", examples / "bunny_cut_hollow.json"},
          {"two_boxes", examples / "bunny_two_boxes.json"},
          {"bend_bounded_ortho", out / "scenes" / "bend_bounded_ortho.json"}};
}

void write_generated_scenes(const fs::path& out) {
  const fs::path examples = fs::path(RAYWARP_SOURCE_DIR) / "examples";
  std::ifstream in(examples / "bunny_bend.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["mesh"] = (examples / "meshes" / "bunny.ply").string();
  std::ifstream camera_file(examples / "cameras" / "side_ortho.json");
  nlohmann::json camera = nlohmann::json::parse(camera_file);
  camera.erase("width");  // the scene's size, not the camera's
  camera.erase("height");
  scene["camera"] = camera;
  scene["render"] = {{"width", 320},
                     {"height", 240},
                     {"sampling", "bounded"},
                     {"background", {0.9, 0.95, 1.0}},
                     {"colour", {0.5, 0.7, 0.4}}};
  fs::create_directories(out / "scenes");
  write_file_atomic((out / "scenes" / "bend_bounded_ortho.json").string(), scene.dump(2));
}

// The library of the scene cases, built by `raywarp library` (KTX2) from copies of the scenes named
// after their entries (mesh and camera paths made absolute), in a folder of this process's own:
// ctest runs the tests of this file in parallel processes. Bakes come from the tests' cache.
nlohmann::json build_library(const fs::path& out) {
  fs::remove_all(out);
  write_generated_scenes(out);
  const fs::path scenes = out / "library_scenes";
  fs::create_directories(scenes);
  for (const SceneCase& c : scene_cases(out)) {
    std::ifstream in(c.file);
    nlohmann::json scene = nlohmann::json::parse(in);
    const fs::path base = c.file.parent_path();
    scene["mesh"] = (base / scene["mesh"].get<std::string>()).lexically_normal().string();
    if (scene["camera"].is_string())
      scene["camera"] = (base / scene["camera"].get<std::string>()).lexically_normal().string();
    write_file_atomic((scenes / (c.name + ".json")).string(), scene.dump(2));
  }
  const CommandResult r = shell(std::string(RAYWARP_BINARY) + " library " + scenes.string() +
                                " --out " + out.string() + " --format ktx2");
  if (r.code != 0) throw Error("raywarp library failed:\n" + r.output);
  std::ifstream in(out / "index.json");
  return nlohmann::json::parse(in);
}

class ViewerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(RAYWARP_BUILD_DIR) / ("viewer_test_library_" + std::to_string(::getpid()));
    index_ = build_library(dir_);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static fs::path dir_;
  static nlohmann::json index_;
};
fs::path ViewerTest::dir_;
nlohmann::json ViewerTest::index_;

struct Png {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;
};
Png read_png(const fs::path& file) {
  Png p;
  int n = 0;
  unsigned char* data = stbi_load(file.string().c_str(), &p.width, &p.height, &n, 4);
  if (!data) return p;
  p.rgba.assign(data, data + static_cast<size_t>(p.width) * p.height * 4);
  stbi_image_free(data);
  return p;
}

struct Agreement {
  double iou = 0.0;             // of the pixels that differ from the background in each image
  double within_8 = 0.0;        // share of all pixels whose channels differ by at most 8/255
  double within_8_union = 0.0;  // the same over the union of the two silhouettes
  long covered_a = 0, covered_b = 0;
};
Agreement compare(const Png& a, const Png& b, const std::array<uint8_t, 3>& background) {
  Agreement r;
  long both = 0, either = 0, close = 0, close_union = 0;
  const size_t n = static_cast<size_t>(a.width) * a.height;
  auto covered = [&](const Png& p, size_t i) {
    for (int c = 0; c < 3; ++c)
      if (std::abs(int(p.rgba[4 * i + c]) - int(background[c])) > 2) return true;
    return false;
  };
  for (size_t i = 0; i < n; ++i) {
    const bool in_a = covered(a, i), in_b = covered(b, i);
    r.covered_a += in_a;
    r.covered_b += in_b;
    both += in_a && in_b;
    either += in_a || in_b;
    int worst = 0;
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, std::abs(int(a.rgba[4 * i + c]) - int(b.rgba[4 * i + c])));
    close += worst <= 8;
    close_union += (in_a || in_b) && worst <= 8;
  }
  r.iou = either ? double(both) / either : 1.0;
  r.within_8 = n ? double(close) / n : 0.0;
  r.within_8_union = either ? double(close_union) / either : 1.0;
  return r;
}

std::string chromium_command(const fs::path& page, const std::string& query, int w, int h,
                             const std::string& action) {
  return "chromium --headless --no-sandbox --enable-unsafe-swiftshader --use-gl=angle "
         "--use-angle=swiftshader --allow-file-access-from-files --disable-gpu-sandbox "
         "--hide-scrollbars --force-device-scale-factor=1 --window-size=" +
         std::to_string(w) + "," + std::to_string(h) + " --virtual-time-budget=20000 " + action +
         " 'file://" + page.string() + "?" + query + "'";
}

TEST(GlslEs, VersionAndPrecisions) {
  const std::string es =
      gl::glsl_es_300("#version 450 core\n#define A\nuniform float u_x;\nvoid main() {}\n");
  EXPECT_EQ(es.rfind("#version 300 es\n", 0), 0u) << es;
  EXPECT_NE(es.find("precision highp float;"), std::string::npos);
  EXPECT_NE(es.find("precision highp sampler3D;"), std::string::npos);
  EXPECT_NE(es.find("precision highp sampler2DArray;"), std::string::npos);
  // The lines after the preamble keep their numbers.
  EXPECT_NE(es.find("#line 2 0\n#define A\nuniform float u_x;"), std::string::npos) << es;
  EXPECT_THROW(gl::glsl_es_300("#version 330 core\nvoid main() {}\n"), Error);
  EXPECT_THROW(gl::glsl_es_300("#version 450 core\ndouble x;\nvoid main() {}\n"), Error);
}

TEST(ViewerAssets, MeshBinLayout) {
  Mesh mesh;
  mesh.V.resize(4, 3);
  mesh.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  mesh.F.resize(4, 3);
  mesh.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  const fs::path file = fs::temp_directory_path() / "raywarp_viewer_test_mesh.bin";
  write_mesh_bin(mesh, file);
  std::ifstream in(file, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
  fs::remove(file);
  ASSERT_EQ(bytes.size(), 12u + 4 * 24 + 4 * 12);
  EXPECT_EQ(std::string(bytes.data(), 4), "RWM1");
  auto u32 = [&](size_t o) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(uint8_t(bytes[o + i])) << (8 * i);
    return v;
  };
  auto f32 = [&](size_t o) {
    uint32_t v = u32(o);
    float f;
    std::memcpy(&f, &v, 4);
    return f;
  };
  EXPECT_EQ(u32(4), 4u);
  EXPECT_EQ(u32(8), 4u);
  EXPECT_EQ(f32(12 + 3 * 4), 1.0f);  // vertex 1's x
  const auto normals = vertex_normals(mesh);
  for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(f32(12 + 48 + c * 4), float(normals(0, c)));
  EXPECT_EQ(u32(12 + 96 + 4), 2u);  // triangle 0's second index
}

TEST(ViewerAssets, RenderSettingsJsonReadsBack) {
  RenderSettings s;
  s.sampling = Sampling::Linear;
  s.step_voxels = 0.5;
  s.skipping = false;
  s.background = {0.1, 0.2, 0.3};
  const nlohmann::json j = render_settings_to_json(s);
  for (const char* key :
       {"width", "height", "step_voxels", "max_steps", "refine_steps", "background", "colour",
        "cut_colour", "inside_colour", "skipping", "sampling", "threshold_voxels", "fine_factor",
        "hit_epsilon_voxels", "texture_bits"})
    EXPECT_TRUE(j.contains(key)) << key;
  // The scene reader takes it back unchanged.
  const nlohmann::json doc = {
      {"mesh", "meshes/bunny.ply"},
      {"boxes",
       {{{"min", {-1, -1, -1}},
         {"max", {1, 1, 1}},
         {"deformer", {{"type", "twist"}, {"axis", "y"}, {"angle_deg", 90}}}}}},
      {"render", j}};
  const Scene scene =
      load_scene_json(doc, fs::path(RAYWARP_SOURCE_DIR) / "examples" / "viewer_test.json");
  EXPECT_EQ(render_settings_to_json(scene.render), j);
}

TEST(ViewerAssets, WriteViewerWritesEveryFile) {
  const fs::path dir = fs::temp_directory_path() / "raywarp_viewer_test_files";
  fs::remove_all(dir);
  write_viewer(dir);
  ASSERT_FALSE(embedded_viewer_files().empty());
  for (const char* name : {"index.html", "viewer.js"}) EXPECT_TRUE(fs::exists(dir / name)) << name;
  for (const auto& [name, text] : embedded_viewer_files()) {
    std::ifstream in(dir / name, std::ios::binary);
    std::string got((std::istreambuf_iterator<char>(in)), {});
    EXPECT_EQ(got, text) << name;
  }
  fs::remove_all(dir);
}

TEST_F(ViewerTest, EveryShaderPassesGlslang) {
  if (!have("glslangValidator"))
    GTEST_SKIP() << "glslangValidator is missing: install the Debian package glslang-tools";
  int checked = 0;
  for (const auto& entry : index_["entries"]) {
    const fs::path folder = dir_ / entry["folder"].get<std::string>();
    const nlohmann::json& sh = entry["shaders"];
    auto check = [&](const std::string& file, const char* stage) {
      const CommandResult r =
          shell("glslangValidator -S " + std::string(stage) + " " + quoted(folder / file));
      EXPECT_EQ(r.code, 0) << file << ":\n" << r.output;
      ++checked;
    };
    for (const char* dialect : {"glsl450", "glsl_es300"}) {
      check(sh["raster"][dialect]["vertex"], "vert");
      check(sh["raster"][dialect]["fragment"], "frag");
      for (const auto& box : sh["boxes"]) {
        check(box[dialect]["vertex"], "vert");
        check(box[dialect]["fragment"], "frag");
      }
    }
    // The 4.50 fragment shaders are exactly what raywarp compiles; the ES ones say so.
    for (const auto& box : sh["boxes"]) {
      std::ifstream in(folder / box["glsl_es300"]["fragment"].get<std::string>());
      std::string first;
      std::getline(in, first);
      EXPECT_EQ(first, "#version 300 es");
    }
    EXPECT_TRUE(fs::exists(folder / sh["uniforms"].get<std::string>()));
  }
  std::printf("[figures] glslangValidator: %d shader files pass\n", checked);
}

TEST_F(ViewerTest, UniformPageNamesEveryUniform) {
  const auto& entry = index_["entries"][0];
  const fs::path folder = dir_ / entry["folder"].get<std::string>();
  std::ifstream in(folder / entry["shaders"]["uniforms"].get<std::string>());
  const std::string md((std::istreambuf_iterator<char>(in)), {});
  for (const char* name : {"u_view_proj", "u_inv_view_proj", "u_object_to_box", "u_region_lower",
                           "u_sdf_origin", "u_deformation", "u_step", "u_seam", "u_background"})
    EXPECT_NE(md.find(std::string("`") + name), std::string::npos) << name;
  EXPECT_EQ(md.find("(undocumented)"), std::string::npos) << md;
}

TEST_F(ViewerTest, ChromiumMatchesRaywarpRender) {
  if (!have("chromium"))
    GTEST_SKIP() << "chromium is missing: install the Debian package chromium "
                    "(apt-get install --no-install-recommends chromium)";
  const fs::path page = dir_ / "viewer" / "index.html";
  const fs::path work = dir_ / "shots";
  fs::create_directories(work);
  // Every entry, and the first again with its textures uploaded as half floats (the path for
  // GPUs without OES_texture_float_linear).
  std::vector<std::pair<nlohmann::json, std::string>> runs;
  for (const auto& entry : index_["entries"]) runs.push_back({entry, ""});
  runs.push_back({index_["entries"][0], "&textures=half"});
  for (const auto& [entry, extra] : runs) {
    const std::string name = entry["name"];
    const std::string label = name + (extra.empty() ? "" : " (half)");
    fs::path scene_file;
    for (const SceneCase& c : scene_cases(dir_))
      if (c.name == name) scene_file = c.file;
    const int w = entry["width"], h = entry["height"];
    const std::string query =
        "entry=" + name + "&width=" + std::to_string(w) + "&height=" + std::to_string(h) + extra;
    SCOPED_TRACE(label);

    // One run: the screenshot, and the DOM after the page has drawn (its status).
    const fs::path shot = work / (name + (extra.empty() ? "" : "_half") + ".viewer.png");
    fs::remove(shot);
    const auto start = std::chrono::steady_clock::now();
    const CommandResult dom =
        shell(chromium_command(page, query, w, h, "--dump-dom --screenshot=" + shot.string()));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::smatch status;
    const bool found =
        std::regex_search(dom.output, status, std::regex(R"re(data-status="([^"]*)")re"));
    ASSERT_TRUE(found) << dom.output.substr(0, 4000);
    EXPECT_EQ(status[1].str().rfind("ready", 0), 0u) << status[1].str();
    EXPECT_NE(dom.output.find("<title>raywarp viewer: ready</title>"), std::string::npos);
    std::printf("[figures] %s: viewer status: %s (chromium run %.1f s)\n", label.c_str(),
                status[1].str().c_str(), seconds);
    ASSERT_TRUE(fs::exists(shot)) << dom.output;

    const fs::path reference = work / (name + ".raywarp.png");
    const CommandResult rr = shell(std::string(RAYWARP_BINARY) + " render " + quoted(scene_file) +
                                   " -o " + quoted(reference) + " --width " + std::to_string(w) +
                                   " --height " + std::to_string(h) + " --cache-dir " +
                                   quoted(fs::path(RAYWARP_BUILD_DIR) / "test-cache"));
    ASSERT_EQ(rr.code, 0) << rr.output;

    const Png a = read_png(shot), b = read_png(reference);
    ASSERT_EQ(a.width, w);
    ASSERT_EQ(a.height, h);
    ASSERT_EQ(b.width, w);
    ASSERT_EQ(b.height, h);
    const auto& bg = entry["render"]["background"];
    const std::array<uint8_t, 3> background = {srgb_byte(bg[0].get<double>()),
                                               srgb_byte(bg[1].get<double>()),
                                               srgb_byte(bg[2].get<double>())};
    const Agreement g = compare(a, b, background);
    std::printf(
        "[figures] %s %dx%d: silhouette IoU %.4f (viewer %ld, raywarp %ld pixels), within 8/255: "
        "%.2f %% of all pixels, %.2f %% of the silhouettes' union\n",
        label.c_str(), w, h, g.iou, g.covered_a, g.covered_b, 100.0 * g.within_8,
        100.0 * g.within_8_union);
    EXPECT_GE(g.iou, 0.99);
    EXPECT_GT(g.covered_a, w * h / 50);  // the bunny is there, not an empty frame
  }
}

}  // namespace
}  // namespace raywarp
