// Exported textures (library/export.h) read back and rendered: every format that holds what the
// ray caster reads (KTX2, DDS, the 16-bit PNG and the EXR atlases) must give the image the
// in-memory textures give (silhouette IoU >= 0.999), the decoded texels must lie within the
// error the sidecar states, and `raywarp bake` must refuse bad input with status 2 and leave no
// file behind.
#include "library/export.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli/engine_bundles.h"
#include "cli/export.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "tests/temp_folder.h"

namespace raywarp {
namespace {

namespace fs = std::filesystem;

constexpr int kSize = 256;

struct CommandResult {
  int code;
  std::string output;
};

CommandResult run(const std::string& args) {
  const std::string cmd = std::string(RAYWARP_BINARY) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), pipe)) out.append(buf.data(), n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

Image render(const Scene& scene, const Mesh& mesh, const std::vector<BoxTextures>& boxes) {
  static auto ctx = gl::create_osmesa_context();
  gl::Renderer renderer;
  renderer.set_mesh(mesh);
  renderer.set_boxes(boxes);
  return renderer.render(*scene.camera, kSize, kSize, scene.render);
}

// The largest |a - b| over two grids of the same layout, per channel group.
double largest_difference(const Grid3<Eigen::Vector4f>& a, const Grid3<Eigen::Vector4f>& b,
                          int channels) {
  EXPECT_EQ(a.dims, b.dims);
  EXPECT_LT((a.origin - b.origin).norm(), 1e-9);
  EXPECT_LT((a.spacing - b.spacing).norm(), 1e-9);
  double worst = 0;
  for (size_t i = 0; i < a.data.size(); ++i)
    for (int c = 0; c < channels; ++c)
      worst = std::max(worst, double(std::abs(a.data[i][c] - b.data[i][c])));
  return worst;
}
double largest_difference(const Grid3<float>& a, const Grid3<float>& b) {
  EXPECT_EQ(a.dims, b.dims);
  double worst = 0;
  for (size_t i = 0; i < a.data.size(); ++i)
    worst = std::max(worst, double(std::abs(a.data[i] - b.data[i])));
  return worst;
}

// The sidecar's stated error of `texture` in `format`.
double stated_error(const nlohmann::json& side, const std::string& texture,
                    const std::string& format) {
  for (const auto& f : side["files"])
    if (f["texture"] == texture && f["format"] == format) return f["max_error"].get<double>();
  ADD_FAILURE() << "no " << format << " file of " << texture;
  return 0;
}

// A scene (its parsed document) baked as `raywarp bake` bakes it, rendered in memory, and
// exported in every format into `dir`.
struct Exported {
  Scene scene;
  MeshPtr mesh;
  BakedBox baked;
  Image reference;  // the in-memory textures' image
  std::string stem;
  nlohmann::json side;
};
Exported bake_and_export(const nlohmann::json& document, const fs::path& scene_file,
                         const fs::path& dir) {
  Exported e;
  e.scene = load_scene_json(document, scene_file);
  BakeSession session;
  e.mesh = session.mesh(e.scene.mesh);
  e.baked = session.bake(export_job(e.scene, 0, e.mesh));
  e.reference = render(e.scene, e.mesh->mesh, {e.baked.textures});
  ExportOptions options;
  options.formats = parse_formats("all", "formats");
  e.stem = export_stem(scene_file, 0);
  e.side = export_box(e.baked, export_source(e.scene, document, 0, *e.mesh), options, dir, e.stem);
  return e;
}

class ExportTest : public TempFolderTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(ExportTest, ReimportedTexturesRenderTheSameImage) {
  const fs::path scene_file = fs::path(RAYWARP_SOURCE_DIR) / "examples" / GetParam();
  const Exported e = bake_and_export(read_scene_document(scene_file), scene_file, dir_);
  const Scene& scene = e.scene;
  const MeshPtr& mesh = e.mesh;
  const BakedBox& baked = e.baked;
  const Image& reference = e.reference;
  const std::string& stem = e.stem;
  const nlohmann::json& side = e.side;
  const double diagonal = 2.0 * baked.textures.box.half_extents.norm();

  for (ExportFormat format :
       {ExportFormat::Ktx2, ExportFormat::Dds, ExportFormat::AtlasExr, ExportFormat::AtlasPng}) {
    SCOPED_TRACE(format_name(format));
    const BoxTextures back = import_box(dir_ / (stem + ".json"), format);
    const BoxTextures& orig = baked.textures;
    // Decoded texels within the stated error (and a little float rounding of the decode).
    const double d_error = largest_difference(back.deformation.grid, orig.deformation.grid, 4);
    EXPECT_LE(d_error, stated_error(side, "deformation", format_name(format)) * 1.001 + 1e-7);
    const double f_error = largest_difference(back.sdf.grid, orig.sdf.grid);
    EXPECT_LE(f_error, stated_error(side, "distance", format_name(format)) * 1.001 + 1e-7);
    if (orig.has_cut) {
      const double a_error = largest_difference(back.alpha.grid, orig.alpha.grid);
      EXPECT_LE(a_error, stated_error(side, "alpha", format_name(format)) * 1.001 + 1e-7);
    }
    if (!orig.step_bounds.empty()) {
      ASSERT_EQ(back.step_bounds.bricks.data.size(), orig.step_bounds.bricks.data.size());
      // Bounds stay bounds (unorm codes may round one down: the sidecar says so).
      for (size_t i = 0; i < orig.step_bounds.bricks.data.size(); ++i) {
        if (format == ExportFormat::AtlasPng) break;
        ASSERT_GE(back.step_bounds.bricks.data[i], orig.step_bounds.bricks.data[i]);
      }
    }
    EXPECT_EQ(back.box.centre, orig.box.centre);
    EXPECT_EQ(back.box.half_extents, orig.box.half_extents);
    EXPECT_EQ(back.texture_map, orig.texture_map);  // exactly: the identity stays the identity
    EXPECT_EQ(back.has_cut, orig.has_cut);
    EXPECT_EQ(back.cylindrical_axis, orig.cylindrical_axis);
    EXPECT_EQ(back.moves_nothing, orig.moves_nothing);
    EXPECT_LT((back.region.min() - orig.region.min()).norm(), 1e-9);
    EXPECT_LT((back.region.max() - orig.region.max()).norm(), 1e-9);

    const Image image = render(scene, mesh->mesh, {back});
    const ImageComparison c = compare_images(image, reference, 0.01 * diagonal);
    std::printf(
        "[figures] %s %s: D decoded within %.3g units (stated %.3g), f within %.3g; image vs "
        "in-memory: IoU %.6f, %.4f %% of pixels over 1 %% of the diagonal, mean depth error "
        "%.3g\n",
        GetParam().c_str(), format_name(format), d_error,
        stated_error(side, "deformation", format_name(format)), f_error, c.iou,
        100 * c.fraction_over, c.mean_depth_error);
    EXPECT_GE(c.iou, 0.999);
    EXPECT_LE(c.fraction_over, 0.001);
  }

  // Every file the sidecar lists exists with the size it states, and nothing else was written.
  std::vector<std::string> listed = {stem + ".json"};
  for (const auto& f : side["files"]) {
    const fs::path p = dir_ / f["file"].get<std::string>();
    ASSERT_TRUE(fs::exists(p)) << p;
    EXPECT_EQ(fs::file_size(p), f["bytes"].get<std::uintmax_t>());
    listed.push_back(f["file"]);
  }
  std::sort(listed.begin(), listed.end());
  EXPECT_EQ(listing(), listed);
}

INSTANTIATE_TEST_SUITE_P(Examples, ExportTest,
                         ::testing::Values("bunny_twist.json", "bunny_cut_solid.json",
                                           "bunny_peel.json", "bunny_twist720_cylindrical.json",
                                           "bunny_groove.json"),
                         [](const auto& info) {
                           std::string n = fs::path(info.param).stem().string();
                           return n;
                         });

// A depth-map cube leaves as its six maps (texture `depth`), not as a distance grid: read back
// from KTX2, DDS and the EXR atlas it renders the image the in-memory cube renders; the 16-bit
// PNG atlas, whose codes could not hold its +-far depths, is left out with a warning.
class DepthCubeExportTest : public TempFolderTest,
                            public ::testing::WithParamInterface<std::string> {};

TEST_P(DepthCubeExportTest, ReimportedMapsRenderTheSameImage) {
  const fs::path scene_file = fs::path(RAYWARP_SOURCE_DIR) / "examples" / GetParam();
  nlohmann::json document = read_scene_document(scene_file);
  document["boxes"][0]["implicit"] = {{"type", "depth_cube"}, {"resolution", 128}};
  const Exported e = bake_and_export(document, scene_file, dir_);
  const Scene& scene = e.scene;
  const MeshPtr& mesh = e.mesh;
  const BakedBox& baked = e.baked;
  const Image& reference = e.reference;
  const std::string& stem = e.stem;
  const nlohmann::json& side = e.side;
  ASSERT_TRUE(baked.textures.uses_depth_cube);
  ASSERT_TRUE(side.contains("depth_cube"));
  EXPECT_FALSE(side["textures"].contains("distance"));
  bool warned = false;
  for (const auto& w : side["warnings"]) warned = warned || w["code"] == "depth_cube_not_in_png";
  EXPECT_TRUE(warned);
  const double diagonal = 2.0 * baked.textures.box.half_extents.norm();
  const DepthCube& orig = baked.textures.depth_cube;
  // The engines' uniforms from the sidecar are the renderer's (gl/renderer.cpp).
  const nlohmann::json u = box_uniform_values(side);
  for (int a = 0; a < 3; ++a) {
    const std::string axis(1, "xyz"[a]);
    const DepthMap& m = orig.maps[2 * a];
    EXPECT_NEAR(u["u_depth_origin_" + axis][0].get<double>(), m.origin.x(), 1e-9);
    EXPECT_NEAR(u["u_depth_origin_" + axis][1].get<double>(), m.origin.y(), 1e-9);
    EXPECT_EQ(u["u_depth_last_" + axis], nlohmann::json({m.nu - 1, m.nv - 1}));
  }
  EXPECT_EQ(u["u_depth_layer"], nlohmann::json({orig.layers().width, orig.layers().height}));
  EXPECT_NEAR(u["u_sdf_spacing"].get<double>(), orig.spacing, 1e-12);
  EXPECT_NEAR(u["u_background"].get<double>(), orig.far_depth, 1e-3);
  for (ExportFormat format : {ExportFormat::Ktx2, ExportFormat::Dds, ExportFormat::AtlasExr}) {
    SCOPED_TRACE(format_name(format));
    const BoxTextures back = import_box(dir_ / (stem + ".json"), format);
    ASSERT_TRUE(back.uses_depth_cube);
    EXPECT_EQ(back.depth_cube.far_depth, orig.far_depth);
    EXPECT_DOUBLE_EQ(back.depth_cube.spacing, orig.spacing);
    double worst = 0;
    for (int k = 0; k < 6; ++k) {
      const DepthMap &a = back.depth_cube.maps[k], &b = orig.maps[k];
      ASSERT_EQ(a.nu, b.nu);
      ASSERT_EQ(a.nv, b.nv);
      EXPECT_LT((a.origin - b.origin).norm(), 1e-12);
      for (size_t i = 0; i < b.depth.size(); ++i)
        worst = std::max(worst, double(std::abs(a.depth[i] - b.depth[i])));
    }
    EXPECT_LE(worst, stated_error(side, "depth", format_name(format)) * 1.001 + 1e-7);
    const Image image = render(scene, mesh->mesh, {back});
    const ImageComparison c = compare_images(image, reference, 0.01 * diagonal);
    std::printf(
        "[figures] %s as a depth cube, %s: maps decoded within %.3g units; image vs in-memory: "
        "IoU %.6f, %.4f %% of pixels over 1 %% of the diagonal\n",
        GetParam().c_str(), format_name(format), worst, c.iou, 100 * c.fraction_over);
    EXPECT_GE(c.iou, 0.999);
    EXPECT_LE(c.fraction_over, 0.001);
  }
  try {
    import_box(dir_ / (stem + ".json"), ExportFormat::AtlasPng);
    ADD_FAILURE() << "a depth cube read from PNG atlases";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no atlas-png file of depth"), std::string::npos)
        << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Examples, DepthCubeExportTest,
                         ::testing::Values("bunny_twist.json", "bunny_cut_solid.json"),
                         [](const auto& info) {
                           std::string n = fs::path(info.param).stem().string();
                           return n;
                         });

class BakeCommand : public TempFolderTest {};

TEST_F(BakeCommand, RefusesBadInputAndWritesNothing) {
  const std::string scene = std::string(RAYWARP_SOURCE_DIR) + "/examples/bunny_twist.json";
  const std::string out = path("out");
  struct Case {
    std::string args, needle;
  };
  const Case cases[] = {
      {scene + " --out " + out + " --format ktx3", "unknown format \"ktx3\"; allowed: ktx2"},
      {scene + " --out " + out + " --box 3", "--box 3: "},
      {scene + " --out " + out + " --atlas-border 2", "--atlas-border"},
      {path("missing.json") + " --out " + out, "missing.json"},
      {"--out " + out, "give a scene file"},
  };
  for (const Case& c : cases) {
    const CommandResult r = run("bake " + c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.needle), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_FALSE(fs::exists(out) && !fs::is_empty(out)) << c.args << " left files behind";
  }
}

TEST_F(BakeCommand, WritesTheOrientationVolume) {
  const CommandResult r = run("bake --orientation-test --out " + path("o") + " --format all");
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream in(path("o/orientation.json"));
  const nlohmann::json side = nlohmann::json::parse(in);
  EXPECT_EQ(side["files"].size(), 5u);
  const TextureVolume v = orientation_volume();
  EXPECT_EQ(v.dims, Eigen::Vector3i(16, 12, 8));
  // R = u, G = v, B = w at texel centres; the marker only at the origin corner.
  EXPECT_FLOAT_EQ(v.at(3, 5, 7, 0), 3.5f / 16);
  EXPECT_FLOAT_EQ(v.at(3, 5, 7, 1), 5.5f / 12);
  EXPECT_FLOAT_EQ(v.at(3, 5, 7, 2), 7.5f / 8);
  EXPECT_EQ(v.at(1, 1, 1, 3), 0.0f);
  EXPECT_EQ(v.at(2, 1, 1, 3), 1.0f);
  EXPECT_EQ(v.at(15, 11, 7, 3), 1.0f);
}

}  // namespace
}  // namespace raywarp
