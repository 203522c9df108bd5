// Sheets (library/sheets.h): faces with no inside of their own are drawn as thin shells instead of
// vanishing from the distance grid. A sheet beside a closed cube: exactly the sheet's faces are
// found, the field is > 0 all over the sheet (no hole) and < 0 beyond the shell, the cube keeps its
// signed field. A card twisted 180 degrees in a box (a cloth or a hair card) renders against the
// exact twisted mesh at 512 x 512 within the shell's thickness.
#include "library/sheets.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <sstream>

#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/implicit.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "tests/mesh_files.h"
#include "tests/temp_folder.h"
#include "verify/ground_truth.h"

using namespace raywarp;
namespace fs = std::filesystem;

namespace {

// A sheet of nu x nv quads over origin + a u + b v, a and b in [0, 1], appended to `soup`.
void add_sheet(PolygonSoup& soup, const Eigen::Vector3d& origin, const Eigen::Vector3d& u,
               const Eigen::Vector3d& v, int nu, int nv) {
  const int base = static_cast<int>(soup.vertices.size());
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      const Eigen::Vector3d p = origin + u * (double(i) / nu) + v * (double(j) / nv);
      soup.vertices.push_back({p.x(), p.y(), p.z()});
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = base + j * (nu + 1) + i;
      soup.sizes.insert(soup.sizes.end(), {3, 3});
      soup.corners.insert(soup.corners.end(), {a, a + nu + 2, a + 1, a, a + nu + 1, a + nu + 2});
    }
}

// A level sheet of nx x nz quads over [x0, x0 + w] x [z0, z0 + d] at height y.
void add_sheet(PolygonSoup& soup, double x0, double w, double y, double z0, double d, int nx,
               int nz) {
  add_sheet(soup, {x0, y, z0}, {w, 0, 0}, {0, 0, d}, nx, nz);
}

// A closed cube [-s, s]^3 (outward faces), appended to `soup`.
void add_cube(PolygonSoup& soup, double s) {
  const int base = static_cast<int>(soup.vertices.size());
  for (int k = 0; k < 8; ++k)
    soup.vertices.push_back({(k & 1) ? s : -s, (k & 2) ? s : -s, (k & 4) ? s : -s});
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    soup.sizes.insert(soup.sizes.end(), {3, 3});
    soup.corners.insert(soup.corners.end(), {base + q[0], base + q[1], base + q[2], base + q[0],
                                             base + q[2], base + q[3]});
  }
}

class Sheets : public TempFolderTest {};

TEST_F(Sheets, SheetFacesBecomeShellsAndClosedPartsKeepTheirField) {
  PolygonSoup soup;
  add_cube(soup, 1.0);
  add_sheet(soup, -2.0, 4.0, 1.6, -0.75, 1.5, 40, 15);
  // A second sheet tilted against every grid axis, a unit from the cube (nearer, the winding
  // number of the cube and the sheet's own +1/2 on its back sum past 1/2 there).
  const Eigen::Vector3d tilted_origin(-2.9, -1.6, -1.3), tilted_u(0.95, 0.5, 0.3),
      tilted_v(-0.2, 0.4, 1.1);
  add_sheet(soup, tilted_origin, tilted_u, tilted_v, 12, 11);
  raywarp::testing::write_ply(path("mesh.ply"), soup);
  const Mesh mesh = load_mesh(path("mesh.ply"));
  Box box;
  box.centre = Eigen::Vector3d(0, 0.2, 0);
  box.half_extents = Eigen::Vector3d(3.2, 2.1, 1.5);
  ImplicitSpec spec;
  spec.resolution = 80;
  const DistanceGrid g = bake_distance_grid(mesh, box, spec);
  // The sheets' faces, none of the cube's. On a sheet's back w is about +1/2, the sign's
  // threshold, and the other parts' winding numbers add to it: a face or two where they push it
  // past 1/2 has a slab of the signed field behind it and is in the field, not a shell.
  EXPECT_LE(g.sheet_faces, 2 * 40 * 15 + 2 * 12 * 11);
  EXPECT_GE(g.sheet_faces, 2 * 40 * 15 + 2 * 12 * 11 - 3);
  const double voxel = g.grid.voxel();
  EXPECT_DOUBLE_EQ(g.sheet_half_thickness, kSheetHalfVoxels * voxel);
  auto f = [&](const Eigen::Vector3d& p) { return double(g.grid.sample(box.to_local(p)).value()); };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // On each sheet, a voxel or more from its open edges (where the shell ends), f is at least the
  // half thickness less the most the trilinear interpolation of a plane's distance can reach at
  // the plane, half a voxel.
  double lowest = 1e30, highest_beyond = -1e30, highest_past_edge = -1e30;
  for (int n = 0; n < 4000; ++n) {
    const Eigen::Vector3d on(-2.0 + voxel + (4.0 - 2 * voxel) * u(rng), 1.6,
                             -0.75 + voxel + (1.5 - 2 * voxel) * u(rng));
    lowest = std::min(lowest, f(on));
    const Eigen::Vector3d off = on + Eigen::Vector3d(0, (n % 2 ? 1 : -1) * 2.5 * voxel, 0);
    highest_beyond = std::max(highest_beyond, f(off));
    const double ea = voxel / tilted_u.norm(), eb = voxel / tilted_v.norm();
    const double a = ea + (1 - 2 * ea) * u(rng), b = eb + (1 - 2 * eb) * u(rng);
    lowest = std::min(lowest, f(tilted_origin + a * tilted_u + b * tilted_v));
    // A voxel past the level sheet's rim, in its plane: no overhang.
    const Eigen::Vector3d past(n % 2 ? 2.0 + voxel : -2.0 - voxel, 1.6, -0.75 + 1.5 * u(rng));
    highest_past_edge = std::max(highest_past_edge, f(past));
  }
  std::printf(
      "[figures] sheet shell, half thickness %.3g voxel: f on the sheets >= %.3g voxel, "
      "2.5 voxels off it <= %.3g voxel, a voxel past its open edge <= %.3g voxel\n",
      kSheetHalfVoxels, lowest / voxel, highest_beyond / voxel, highest_past_edge / voxel);
  EXPECT_GE(lowest, (kSheetHalfVoxels - 0.5) * voxel * 0.999);  // no hole anywhere on the sheets
  EXPECT_LT(highest_beyond, 0.0);                               // nothing beyond the shell
  EXPECT_LT(highest_past_edge, 0.0);                            // the shell ends at the open edge
  EXPECT_GT(f(Eigen::Vector3d(0, 0, 0)), 0.0);                  // cube inside
  EXPECT_LT(f(Eigen::Vector3d(0, 1.3, 0)), 0.0);                // between
}

// The card seen from afar beside a cube below it, and filling the view, at the sizes people
// render.
struct CardView {
  const char* name;
  Eigen::Vector3d eye, target;
  int width, height;
};
void PrintTo(const CardView& v, std::ostream* os) { *os << v.name; }

class TwistedCard : public TempFolderTest, public ::testing::WithParamInterface<CardView> {};

TEST_P(TwistedCard, RendersAsTheExactTwistedMesh) {
  const CardView& view = GetParam();
  PolygonSoup soup;
  add_sheet(soup, -1.5, 4.0, 11.0, -0.75, 1.5, 160, 60);  // a card (4 x 1.5 units)
  add_cube(soup, 1.0);                                    // and a closed part outside the box
  raywarp::testing::write_ply(path("card.ply"), soup);
  const nlohmann::json doc = {
      {"mesh", "card.ply"},
      {"boxes",
       {{{"centre", {0.5, 11.0, 0.0}},
         {"half_extents", {2.2, 1.0, 1.0}},
         {"deformer", {{"type", "twist"}, {"axis", "x"}, {"angle_deg", 180}}}}}},
      {"camera",
       {{"projection", "perspective"},
        {"eye", {view.eye.x(), view.eye.y(), view.eye.z()}},
        {"target", {view.target.x(), view.target.y(), view.target.z()}},
        {"up", {0, 1, 0}},
        {"fov_y_deg", 36},
        {"near", 0.5},
        {"far", 100}}}};
  const Scene scene = load_scene_json(doc, path("card.json"));
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(scene, log);
  EXPECT_NE(log.str().find("faces with no inside drawn as shells"), std::string::npos) << log.str();
  EXPECT_NE(log.str().find("raised from 128 for the sheets"), std::string::npos) << log.str();
  static auto ctx = gl::create_osmesa_context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  const Image image = renderer.render(*scene.camera, view.width, view.height, scene.render);
  const Truth truth = ground_truth(scene, prepared, *scene.camera, view.width, view.height);
  const ImageComparison c = compare_images(image, truth.image, 0.01 * truth.diagonal);
  fs::create_directories("sheets_test_images");
  const std::string stem = std::string("sheets_test_images/card_") + view.name;
  write_png(stem + "_gl.png", image);
  write_png(stem + "_truth.png", truth.image);
  write_png(stem + "_difference.png", difference_image(image, truth.image, 0.01 * truth.diagonal));
  std::printf(
      "[figures] card twisted 180 degrees, %s view, %d x %d, vs %s: IoU %.4f, %.2f %% of "
      "pixels over 1 %% of the diagonal, outline bias %.3f px\n",
      view.name, view.width, view.height, truth.kind.c_str(), c.iou, 100 * c.fraction_over,
      c.outline_bias());
  // The shell is 1.2 voxels of the 288 grid thick where the exact sheet has none, and ends flat
  // at the card's rim (a sheet not drawn at all scored 0; a shell 2 voxels of the 128 grid
  // thick and round at the rim, 0.926 in the close view).
  EXPECT_GE(c.iou, 0.99);
  EXPECT_LE(c.fraction_over, 0.01);
  EXPECT_LE(c.outline_bias(), 0.5);
}

INSTANTIATE_TEST_SUITE_P(
    Views, TwistedCard,
    ::testing::Values(CardView{"far", {6, 9, 26}, {0, 4.8, 0}, 512, 512},
                      CardView{"close", {0.5, 14.5, 7}, {0.5, 11, 0}, 512, 512},
                      CardView{"close1080", {0.5, 14.5, 7}, {0.5, 11, 0}, 1920, 1080}),
    [](const ::testing::TestParamInfo<CardView>& info) { return std::string(info.param.name); });

}  // namespace
