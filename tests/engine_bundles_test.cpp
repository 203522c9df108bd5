// Engine bundles (cli/engine_bundles.h): for a small baked box exported in every format, every
// file listed exists, the three.js module and the Unreal script parse, the Unity scripts compile
// against stand-ins of the UnityEngine/UnityEditor types (where mcs is installed), the numbers in
// the bundles are the sidecar's, and an export without atlases names the format to add.
#include "cli/engine_bundles.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "base/error.h"
#include "cli/export.h"
#include "library/export.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool on_path(const std::string& tool) {
  return std::system(("command -v " + tool + " >/dev/null 2>&1").c_str()) == 0;
}

// Runs a shell command; returns its exit status and output.
int shell(const std::string& command, std::string& output) {
  output.clear();
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return -1;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The JSON after `marker` up to the end of its line (less a trailing ';' or "''')").
json embedded(const std::string& text, const std::string& marker) {
  const size_t at = text.find(marker);
  if (at == std::string::npos) {
    ADD_FAILURE() << "missing " << marker;
    return nullptr;
  }
  const size_t start = at + marker.size();
  std::string line = text.substr(start, text.find('\n', start) - start);
  for (const std::string tail : {"''')", ";"})
    if (line.size() >= tail.size() &&
        line.compare(line.size() - tail.size(), tail.size(), tail) == 0)
      line.resize(line.size() - tail.size());
  return json::parse(line);
}

// One baked box shared by the tests: an octahedron twisted in a box, resolution 16, exported in
// every format.
class EngineBundleTest : public TempFolderTest {
 protected:
  static void SetUpTestSuite() {
    folder_ = fs::temp_directory_path() / ("raywarp_engine_bundles_" + std::to_string(::getpid()));
    fs::create_directories(folder_);
    std::ofstream(folder_ / "m.obj")
        << "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
           "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
    std::ofstream(folder_ / "oct.json")
        << R"({"mesh": "m.obj", "boxes": [{"min": [-0.6, -0.5, -0.6], "max": [0.6, 0.5, 0.6],
              "deformer": {"type": "twist", "axis": "y", "angle_deg": 90},
              "implicit": {"type": "sdf", "resolution": 16},
              "deformation": {"resolution": 16}}]})";
    const fs::path scene_file = folder_ / "oct.json";
    const json document = read_scene_document(scene_file);
    const Scene scene = load_scene_json(document, scene_file);
    BakeSession session;
    MeshPtr mesh = session.mesh(scene.mesh);
    baked_ = new BakedBox(session.bake(export_job(scene, 0, mesh)));
    source_ = new ExportSource(export_source(scene, document, 0, *mesh));
  }
  static void TearDownTestSuite() {
    delete baked_;
    delete source_;
    fs::remove_all(folder_);
  }

  json export_in(const std::string& formats, const fs::path& dir) {
    ExportOptions options;
    options.formats = parse_formats(formats, "formats");
    return export_box(*baked_, *source_, options, dir, "oct_box0");
  }

  static fs::path folder_;
  static BakedBox* baked_;
  static ExportSource* source_;
};
fs::path EngineBundleTest::folder_;
BakedBox* EngineBundleTest::baked_ = nullptr;
ExportSource* EngineBundleTest::source_ = nullptr;

TEST_F(EngineBundleTest, EveryListedFileExistsAndTheNumbersAreTheSidecars) {
  const json side = export_in("all", dir_);
  const json r = write_engine_bundles(side, dir_, "oct_box0");
  EXPECT_EQ(r["folder"], "oct_box0.engines");
  for (const char* engine : {"threejs", "unity", "unreal", "godot"}) {
    SCOPED_TRACE(engine);
    ASSERT_TRUE(r["engines"].contains(engine));
    const json& e = r["engines"][engine];
    EXPECT_TRUE(e["missing"].empty()) << e["missing"];
    EXPECT_FALSE(e["formats"].empty());
    bool checklist = false;
    for (const auto& f : e["files"]) {
      EXPECT_TRUE(fs::is_regular_file(dir_ / f.get<std::string>())) << f;
      checklist |= f.get<std::string>().ends_with("/CHECKLIST.md");
    }
    EXPECT_TRUE(checklist);
    // Every checklist names the settings and the decode.
    const std::string md = slurp(dir_ / "oct_box0.engines" / engine / "CHECKLIST.md");
    for (const char* needle : {"sRGB off", "Clamp to edge", "No mipmaps", "object = stored * scale",
                               "--orientation-test", "No resize, no compression"})
      EXPECT_NE(md.find(needle), std::string::npos) << needle;
  }
  EXPECT_EQ(r["engines"]["threejs"]["formats"], json::array({"ktx2"}));
  EXPECT_EQ(r["engines"]["unity"]["formats"], json::array({"dds", "atlas-exr"}));
  EXPECT_EQ(r["engines"]["unreal"]["formats"], json::array({"atlas-exr"}));

  // three.js: the module's tables are the sidecar's.
  const std::string js = slurp(dir_ / "oct_box0.engines/threejs/raywarp_oct_box0.js");
  const json textures = embedded(js, "export const TEXTURES = ");
  const json files = embedded(js, "export const FILES = ");
  const json uniforms = embedded(js, "export const BOX_UNIFORMS = ");
  EXPECT_EQ(embedded(js, "export const BOX = "), side["box"]);
  ASSERT_EQ(textures.size(), side["textures"].size());
  for (auto it = side["textures"].begin(); it != side["textures"].end(); ++it) {
    SCOPED_TRACE(it.key());
    EXPECT_EQ(textures[it.key()]["dims"], it.value()["dims"]);
    EXPECT_EQ(textures[it.key()]["scale"], it.value()["scale"]);
    EXPECT_EQ(textures[it.key()]["region"], it.value()["region"]);
    EXPECT_TRUE(fs::exists(dir_ / files[it.key()].get<std::string>()));
  }
  const std::vector<double> h = side["box"]["half_extents"];
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(uniforms["u_half_extents"][a].get<double>(), h[a]);
    EXPECT_DOUBLE_EQ(uniforms["u_region_lower"][a].get<double>(),
                     side["render"]["ray_cast_region"]["min"][a].get<double>() * h[a]);
    EXPECT_DOUBLE_EQ(uniforms["u_def_origin"][a].get<double>(),
                     side["textures"]["deformation"]["region"]["min"][a].get<double>() * h[a]);
  }
  EXPECT_NEAR(uniforms["u_sdf_spacing"].get<double>(), side["figures"]["voxel"].get<double>(),
              1e-9);
  EXPECT_NE(js.find("import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';"),
            std::string::npos);
  for (const char* needle : {"ClampToEdgeWrapping", "LinearFilter", "NoColorSpace",
                             "generateMipmaps = false", "RawShaderMaterial"})
    EXPECT_NE(js.find(needle), std::string::npos) << needle;

  // Unreal: the atlases, tiles and tile sizes are the sidecar's.
  const std::string py = slurp(dir_ / "oct_box0.engines/unreal/import_oct_box0.py");
  const json atlases = embedded(py, "ATLASES = json.loads(r'''");
  size_t exr_files = 0;
  for (const auto& f : side["files"]) {
    if (f["format"] != "atlas-exr") continue;
    ++exr_files;
    bool found = false;
    for (const auto& a : atlases)
      if (a["file"] == f["file"]) {
        found = true;
        EXPECT_EQ(a["tiles"], f["tiles"]);
        EXPECT_EQ(a["tile_size"][0].get<int>() * f["tiles"][0].get<int>(), f["size"][0]);
        EXPECT_EQ(a["tile_size"][1].get<int>() * f["tiles"][1].get<int>(), f["size"][1]);
        EXPECT_EQ(a["dims"], side["textures"][f["texture"].get<std::string>()]["dims"]);
        EXPECT_EQ(a["scale"], side["textures"][f["texture"].get<std::string>()]["scale"]);
      }
    EXPECT_TRUE(found) << f["file"];
  }
  EXPECT_EQ(atlases.size(), exr_files);
  for (const char* needle : {"TC_HDR", "TMGS_NO_MIPMAPS", "\"srgb\": False", "source2d_texture",
                             "source2d_tile_size_x", "unreal.VolumeTexture"})
    EXPECT_NE(py.find(needle), std::string::npos) << needle;

  // Godot: one .import per EXR atlas with its slice counts and no mipmaps.
  size_t imports = 0;
  for (const auto& f : side["files"]) {
    if (f["format"] != "atlas-exr") continue;
    const fs::path p = dir_ / "oct_box0.engines/godot" / (f["file"].get<std::string>() + ".import");
    ASSERT_TRUE(fs::exists(p)) << p;
    ++imports;
    const std::string ini = slurp(p);
    EXPECT_NE(ini.find("importer=\"3d_texture\""), std::string::npos);
    EXPECT_NE(ini.find("\nmipmaps/generate=false\n"), std::string::npos);
    EXPECT_NE(ini.find("\nslices/horizontal=" + f["tiles"][0].dump() + "\n"), std::string::npos);
    EXPECT_NE(ini.find("\nslices/vertical=" + f["tiles"][1].dump() + "\n"), std::string::npos);
  }
  EXPECT_GT(imports, 0u);

  // Unity: the flipbook columns and rows.
  const std::string atlas_cs =
      slurp(dir_ / "oct_box0.engines/unity/Editor/RaywarpAtlasImport_oct_box0.cs");
  for (const auto& f : side["files"]) {
    if (f["format"] == "atlas-exr") {
      EXPECT_NE(atlas_cs.find("\"" + f["file"].get<std::string>() + "\""), std::string::npos);
    }
  }
}

TEST_F(EngineBundleTest, TheScriptsParse) {
  const json side = export_in("all", dir_);
  write_engine_bundles(side, dir_, "oct_box0");
  const fs::path root = dir_ / "oct_box0.engines";
  std::string out;
  if (on_path("node")) {
    // A copy with the .mjs extension, so that node parses it as a module.
    fs::copy_file(root / "threejs/raywarp_oct_box0.js", dir_ / "check.mjs");
    EXPECT_EQ(shell("node --check " + (dir_ / "check.mjs").string(), out), 0) << out;
  } else {
    std::cout << "[  SKIPPED ] node --check: node is not installed\n";
  }
  if (fs::exists("/usr/bin/python3")) {
    EXPECT_EQ(
        shell("/usr/bin/python3 -m py_compile " + (root / "unreal/import_oct_box0.py").string(),
              out),
        0)
        << out;
  } else {
    std::cout << "[  SKIPPED ] py_compile: no /usr/bin/python3\n";
  }
  if (!on_path("mcs")) {
    std::cout << "[  SKIPPED ] C#: mcs (mono-mcs) is not installed\n";
    return;
  }
  // Stand-ins for the UnityEngine and UnityEditor members the scripts use.
  std::ofstream(dir_ / "Stubs.cs") << R"CS(
namespace UnityEngine {
  public enum TextureFormat { RHalf, RGHalf, RGBAHalf, RFloat, RGFloat, RGBAFloat }
  public enum TextureWrapMode { Repeat, Clamp }
  public enum FilterMode { Point, Bilinear, Trilinear }
  public class Object { public string name; public static void DestroyImmediate(Object o) {} }
  public struct Vector3 { public Vector3(float x, float y, float z) {} }
  public struct Bounds { public Bounds(Vector3 centre, Vector3 size) {} }
  public static class Mathf { public static float HalfToFloat(ushort h) { return 0; } }
  public class Shader : Object { public static Shader Find(string name) { return null; } }
  public class Material : Object {
    public Material(Shader s) {}
    public void SetTexture(string name, Texture t) {}
    public void CopyPropertiesFromMaterial(Material m) {}
  }
  public class Component : Object {
    public T GetComponent<T>() { return default(T); }
    public Transform transform;
  }
  public class Transform : Component { public void SetParent(Transform p, bool keep) {} }
  public class Collider : Component {}
  public class Renderer : Component { public Material sharedMaterial; public Bounds localBounds; }
  public class MeshRenderer : Renderer {}
  public enum PrimitiveType { Sphere, Capsule, Cylinder, Cube, Plane, Quad }
  public class GameObject : Object {
    public GameObject(string name) {}
    public Transform transform;
    public T GetComponent<T>() { return default(T); }
    public static GameObject CreatePrimitive(PrimitiveType t) { return null; }
  }
  public class Texture : Object {
    public int width, height; public TextureWrapMode wrapMode; public FilterMode filterMode;
    public int anisoLevel;
  }
  public class Texture3D : Texture {
    public int depth; public TextureFormat format;
    public Texture3D(int w, int h, int d, TextureFormat f, bool mipChain) {}
    public void SetPixelData<T>(T[] data, int mipLevel, int sourceDataStartIndex = 0) {}
    public void Apply(bool updateMipmaps, bool makeNoLongerReadable) {}
  }
  public static class Debug {
    public static void Log(object m) {}
    public static void LogError(object m) {}
  }
}
namespace UnityEditor {
  public class MenuItem : System.Attribute { public MenuItem(string p) {} }
  public static class PrefabUtility {
    public static UnityEngine.GameObject SaveAsPrefabAsset(UnityEngine.GameObject o, string p) { return o; }
  }
  public static class AssetDatabase {
    public static void CreateAsset(UnityEngine.Object o, string p) {}
    public static void SaveAssets() {}
    public static T LoadAssetAtPath<T>(string p) where T : UnityEngine.Object { return null; }
  }
  public static class Selection { public static UnityEngine.Object activeObject; }
  public static class EditorUtility { public static void SetDirty(UnityEngine.Object o) {} }
  public enum TextureImporterShape { Texture2D, TextureCube, Texture2DArray, Texture3D }
  public enum TextureImporterNPOTScale { None, ToNearest, ToLarger, ToSmaller }
  public enum TextureImporterCompression { Uncompressed, Compressed, CompressedHQ, CompressedLQ }
  public class TextureImporterSettings {
    public TextureImporterShape textureShape; public int flipbookColumns, flipbookRows;
    public bool sRGBTexture, mipmapEnabled, readable; public TextureImporterNPOTScale npotScale;
    public UnityEngine.TextureWrapMode wrapMode; public UnityEngine.FilterMode filterMode;
  }
  public class AssetImporter { }
  public class TextureImporter : AssetImporter {
    public void ReadTextureSettings(TextureImporterSettings s) {}
    public void SetTextureSettings(TextureImporterSettings s) {}
    public TextureImporterCompression textureCompression; public int maxTextureSize;
    public bool mipmapEnabled, sRGBTexture;
  }
  public class AssetPostprocessor { public string assetPath; public AssetImporter assetImporter; }
}
)CS";
  const std::string cs = "mcs -target:library -warnaserror -out:" + (dir_ / "check.dll").string() +
                         " " + (dir_ / "Stubs.cs").string() + " " +
                         (root / "unity/Editor/RaywarpImport_oct_box0.cs").string() + " " +
                         (root / "unity/Editor/RaywarpAtlasImport_oct_box0.cs").string();
  EXPECT_EQ(shell(cs, out), 0) << out;
}

TEST_F(EngineBundleTest, WithoutAtlasesTheChecklistsNameTheFormatToAdd) {
  const json side = export_in("ktx2", dir_);
  const json r = write_engine_bundles(side, dir_, "oct_box0");
  for (const auto& f : r["engines"].items())
    for (const auto& file : f.value()["files"])
      EXPECT_TRUE(fs::exists(dir_ / file.get<std::string>())) << file;
  EXPECT_TRUE(r["engines"]["threejs"]["missing"].empty());
  for (const char* engine : {"unreal", "godot", "unity"}) {
    SCOPED_TRACE(engine);
    EXPECT_NE(r["engines"][engine]["missing"].dump().find("--format atlas-exr"), std::string::npos);
    const std::string md = slurp(dir_ / "oct_box0.engines" / engine / "CHECKLIST.md");
    EXPECT_NE(md.find("`--format atlas-exr`"), std::string::npos);
  }
  // Unity's exact route falls back to KTX2.
  EXPECT_EQ(r["engines"]["unity"]["formats"], json::array({"ktx2"}));
  EXPECT_TRUE(fs::exists(dir_ / "oct_box0.engines/unity/Editor/RaywarpImport_oct_box0.cs"));
  EXPECT_FALSE(fs::exists(dir_ / "oct_box0.engines/unity/Editor/RaywarpAtlasImport_oct_box0.cs"));
}

TEST_F(EngineBundleTest, RefusesWhatIsNotASidecar) {
  EXPECT_THROW(write_engine_bundles(json{{"schema", "other"}}, dir_, "x"), Error);
}

}  // namespace
}  // namespace raywarp
