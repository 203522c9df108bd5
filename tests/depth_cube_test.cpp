// The depth-map cube (library/depth_cube.h, Correa & Silver 2007 section 6.1):
//  - its layout and memory (the paper's 6 x 64 KB at 128),
//  - exact depths and the inside test on meshes every face sees (cubes, a sphere), including
//    rays through shared edges and the winding-number fallback on an open mesh,
//  - where it fails: a pocket hidden from all six faces counts as inside,
//  - the GL render of the bunny twist with a depth cube against the CPU reference (the same
//    textures: checks the shader's RAYWARP_IMPLICIT 1 against depth_cube_value) and against the
//    exact ground truth,
//  - the scene file's implicit.type and its errors.
#include "library/depth_cube.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <tuple>

#include "base/error.h"
#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "library/prepare.h"
#include "library/scene.h"
#include "library/winding.h"
#include "tests/mesh_fixtures.h"
#include "verify/reference.h"

namespace raywarp {
namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kInf = std::numeric_limits<double>::infinity();

Box box_of(const Vec3& half, const Vec3& centre = Vec3::Zero()) {
  Box b;
  b.centre = centre;
  b.half_extents = half;
  return b;
}

// A closed mesh of unit cubes (cells (i, j, k) of side `cell` with lower corner origin + cell *
// (i, j, k)): one quad per face between a filled and an empty cell, outward.
Mesh voxel_mesh(const std::set<std::tuple<int, int, int>>& cells, double cell, const Vec3& origin) {
  std::vector<Vec3> V;
  std::vector<Eigen::Vector3i> F;
  std::map<std::tuple<int, int, int>, int> index;  // corners shared by their integer coordinates
  auto corner = [&](const Eigen::Vector3i& x) {
    auto [it, added] = index.emplace(std::make_tuple(x[0], x[1], x[2]), static_cast<int>(V.size()));
    if (added) V.push_back(origin + cell * x.cast<double>());
    return it->second;
  };
  for (const auto& [i, j, k] : cells) {
    const int c[3] = {i, j, k};
    for (int a = 0; a < 3; ++a)
      for (int side : {-1, 1}) {
        int n[3] = {i, j, k};
        n[a] += side;
        if (cells.count({n[0], n[1], n[2]})) continue;
        const int b = (a + 1) % 3, d = (a + 2) % 3;
        // Corners of the face at c[a] + (side > 0), counter-clockwise seen from outside.
        int q[4];
        for (int m = 0; m < 4; ++m) {
          Eigen::Vector3i x;
          x[a] = c[a] + (side > 0 ? 1 : 0);
          x[b] = c[b] + (m == 1 || m == 2);
          x[d] = c[d] + (m >= 2);
          q[m] = corner(x);
        }
        // (b, d) is right-handed about a: counter-clockwise seen from +a.
        if (side > 0)
          F.insert(F.end(), {{q[0], q[1], q[2]}, {q[0], q[2], q[3]}});
        else
          F.insert(F.end(), {{q[0], q[2], q[1]}, {q[0], q[3], q[2]}});
      }
  }
  Mesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t v = 0; v < V.size(); ++v) mesh.V.row(v) = V[v].transpose();
  mesh.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t f = 0; f < F.size(); ++f) mesh.F.row(f) = F[f].transpose();
  return mesh;
}

TEST(DepthCube, LayoutAndMemory) {
  // The paper's example: a cube at 128 takes 6 x 64 KB.
  EXPECT_EQ(depth_cube_bytes(Vec3(1, 1, 1), 128), 8u * 128 * 128 * 4);  // 8 slices
  const Vec3 half(5.2, 2.895, 4.0);                                     // the bunny twist's box
  const DepthCube cube = bake_depth_cube(fixtures::cube(1.0), box_of(half), 128);
  const Eigen::Vector3i n = depth_cube_dims(half, 128);
  EXPECT_EQ(n, Eigen::Vector3i(128, 72, 99));
  EXPECT_DOUBLE_EQ(cube.spacing, 10.4 / 128);
  EXPECT_EQ(cube.maps[0].nu, n.y());
  EXPECT_EQ(cube.maps[0].nv, n.z());
  EXPECT_EQ(cube.maps[3].nu, n.x());
  EXPECT_EQ(cube.maps[3].nv, n.z());
  EXPECT_EQ(cube.maps[5].nu, n.x());
  EXPECT_EQ(cube.maps[5].nv, n.y());
  EXPECT_EQ(cube.texture_bytes(), depth_cube_bytes(half, 128));
  EXPECT_EQ(cube.map_texels(), 2L * (72 * 99 + 128 * 99 + 128 * 72));
  EXPECT_GT(cube.far_depth, 2.0 * half.maxCoeff());
  for (const DepthMap& m : cube.maps) {
    EXPECT_EQ(m.depth.size(), static_cast<size_t>(m.nu) * m.nv);
    EXPECT_NEAR(m.origin.x(), -0.5 * m.nu * cube.spacing, 1e-12);  // centred on the box
  }
  std::printf("[figures] %s\n", describe(cube).c_str());
}

TEST(DepthCube, CubeDepthsAreExact) {
  // A cube of half 0.5 in a box of half 1 (texel 0.25): texel centres lie on the diagonals of
  // its faces' triangles, which the top-left rule must count once.
  const DepthCube cube = bake_depth_cube(fixtures::cube(0.5), box_of(Vec3(1, 1, 1)), 8);
  for (const DepthMap& m : cube.maps)
    for (int j = 0; j < m.nv; ++j)
      for (int i = 0; i < m.nu; ++i) {
        const double u = m.origin.x() + (i + 0.5) * m.spacing,
                     v = m.origin.y() + (j + 0.5) * m.spacing;
        // Covered (|u|, |v| < 0.5), or next to a covered texel: dilated to the same depth.
        const bool near = std::max(std::abs(u), std::abs(v)) < 0.75;
        EXPECT_FLOAT_EQ(m.at(i, j), near ? 0.5f : cube.far_depth)
            << "map " << m.axis << (m.side > 0 ? "+" : "-") << " texel " << i << ", " << j;
      }
  EXPECT_EQ(cube.texels.inside, 0);
  EXPECT_EQ(cube.texels.surface, 6 * 16);
  EXPECT_EQ(cube.texels.dilated, 6 * 20);
  // The dilated ring of the z maps votes inside beyond the cube's +x face; the x maps, which see
  // that face, vote outside.
  EXPECT_LT(depth_cube_value(cube, Vec3(0.6, 0.0, 0.0)), 0.0);
  EXPECT_NEAR(depth_cube_value(cube, Vec3::Zero()), 0.5, 1e-12);  // at the centre, f = 1 - 0.5
  EXPECT_LT(depth_cube_value(cube, Vec3(0.75, 0, 0)), 0.0);
  EXPECT_GT(depth_cube_value(cube, Vec3(0.3, -0.3, 0.3)), 0.0);

  // A cube that encloses the box: no surface inside, every ray starts inside (by the crossings
  // before each face, which again pass through texel centres on shared edges).
  const DepthCube inside = bake_depth_cube(fixtures::cube(2.0), box_of(Vec3(1, 1, 1)), 8);
  for (const DepthMap& m : inside.maps)
    for (float h : m.depth) EXPECT_EQ(h, -inside.far_depth);
  EXPECT_EQ(inside.texels.winding_fallbacks, 0);
  EXPECT_EQ(inside.texels.inside, 6 * 64);
  // Inside everywhere, and no face is a surface: |f| is far_depth plus the depth.
  EXPECT_NEAR(depth_cube_value(inside, Vec3(0.2, 0.5, -0.1)), inside.far_depth + 0.5, 1e-3);
  // ... also a little beyond the box (where a box cut looks for its caps).
  EXPECT_GT(depth_cube_value(inside, Vec3(1.05, 0.0, 0.0)), 0.0);

  // A cube crossing the +x face: the rays from +x start inside (H = -far_depth), the others see
  // its faces.
  const DepthCube crossing =
      bake_depth_cube(fixtures::cube(0.5, Vec3(1, 0, 0)), box_of(Vec3(1, 1, 1)), 8);
  EXPECT_EQ(crossing.maps[1].at(4, 4), -crossing.far_depth);  // +x: inside at the face
  EXPECT_FLOAT_EQ(crossing.maps[0].at(4, 4), 1.5f);           // -x: the cube's face at x = 0.5
  EXPECT_GT(depth_cube_value(crossing, Vec3(0.8, 0.1, 0.1)), 0.0);
  EXPECT_LT(depth_cube_value(crossing, Vec3(0.3, 0.1, 0.1)), 0.0);
  // Near the +x face |f| is the distance to the cube's faces seen from -x, +-y and +-z, not to the
  // box face.
  EXPECT_NEAR(depth_cube_value(crossing, Vec3(0.95, 0.1, 0.1)), 0.4, 1e-6);
}

// The true signed distance of the inscribed icosphere's sphere, > 0 inside.
double sphere_distance(const Vec3& p, double radius) { return radius - p.norm(); }

TEST(DepthCube, SphereInsideTestAndDistance) {
  const double radius = 1.0;
  const Mesh sphere = fixtures::icosphere(radius, 4);
  const double sag = fixtures::max_sagitta(sphere, radius);
  const Box box = box_of(Vec3(1.2, 1.2, 1.2), Vec3(0.01, -0.02, 0.03));
  const DepthCube cube = bake_depth_cube(sphere, box, 64);
  const double s = cube.spacing;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-1.2, 1.2);
  long far_points = 0, wrong_far = 0, near_points = 0;
  double worst_near = 0.0, worst_over = -kInf, worst_under = -kInf;
  long band_points = 0, under = 0;
  for (int n = 0; n < 40000; ++n) {
    const Vec3 q(coord(rng), coord(rng), coord(rng));  // box frame
    const double f = depth_cube_value(cube, q);
    const double d = sphere_distance(box.to_object(q), radius);
    // Away from the surface the sign is exact: each map's silhouette is dilated by up to a
    // texel's diagonal, and the maps that see the surface there face-on trim it.
    if (std::abs(d) > s + sag) {
      ++far_points;
      wrong_far += (f > 0.0) != (d > 0.0);
    }
    if (std::abs(d) < s) {  // within a texel: |f| is an axis distance, within a texel of |d|
      ++near_points;
      worst_near = std::max(worst_near, std::abs(std::abs(f) - std::abs(d)));
    }
    // Within 3 texels: |f| is an axis distance to the surface, so no less than |d| and, to first
    // order, at most sqrt(3) |d| (some axis is within 55 degrees of the normal), up to the
    // interpolation of H; except in a map's dilated texels, whose depth is the rim's, where |f|
    // may fall short of |d| by up to the dilation, a texel's diagonal. (With far_depth near the
    // box, H's blend towards it beyond a silhouette would make f_k = 0 on a sheet all the way
    // behind the rim, and |f| ~ 0 far from the surface.)
    if (std::abs(d) < 3.0 * s) {
      worst_over = std::max(worst_over, std::abs(f) - std::sqrt(3.0) * std::abs(d));
      worst_under = std::max(worst_under, std::abs(d) - std::abs(f));
      ++band_points;
      under += std::abs(d) - std::abs(f) > 0.5 * s;
    }
  }
  std::printf(
      "[figures] sphere r = 1, texel %.4g, sagitta %.2g: %ld points beyond a texel, %ld on the "
      "wrong side; within a texel (%ld points) ||f| - |d|| <= %.3g texel; within 3 texels |f| - "
      "sqrt(3) |d| <= %.3g texel, |d| - |f| <= %.3g texel (> 0.5 texel at %.2f%% of them)\n",
      s, sag, far_points, wrong_far, near_points, worst_near / s, worst_over / s, worst_under / s,
      100.0 * under / band_points);
  EXPECT_GT(far_points, 30000);
  EXPECT_EQ(wrong_far, 0);
  EXPECT_GT(near_points, 100);
  EXPECT_LE(worst_near, 1.0 * s);
  EXPECT_LE(worst_over, 0.75 * s);
  EXPECT_LE(worst_under, 1.5 * s);  // the dilation, up to interpolation
  EXPECT_LT(under, band_points / 100);
}

TEST(DepthCube, OpenMeshFallsBackToTheWindingNumber) {
  // A sphere with a hole at -x, and a box well inside it: no ray meets a surface inside the box;
  // along the x lines through the hole the crossings before the -x face miss the sphere, those
  // before the +x face do not, and the winding number decides: inside.
  const Mesh open = fixtures::with_hole(fixtures::icosphere(1.0, 3), Vec3(-1, 0, 0), 0.4);
  const DepthCube cube = bake_depth_cube(open, box_of(Vec3(0.3, 0.3, 0.3)), 16);
  EXPECT_GT(cube.texels.winding_fallbacks, 0);
  for (const DepthMap& m : cube.maps)
    for (float h : m.depth) EXPECT_EQ(h, -cube.far_depth);
  EXPECT_GT(depth_cube_value(cube, Vec3(0.1, 0.0, 0.0)), 0.0);
}

TEST(DepthCube, PocketHiddenFromAllFacesCountsInside) {
  // A 5^3 block of unit cells with a pocket: the cell at the centre, reached from outside by a
  // bent tunnel (one cell along +x, then along +y up to the top). Every axis ray from a face to
  // the pocket first meets the block, so all six maps put it behind the first surface: the depth
  // cube counts the pocket as inside, while it is outside the mesh. The tunnel is seen from +y,
  // and a notch on an edge from +z: those are outside, as they should be.
  std::set<std::tuple<int, int, int>> cells;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      for (int k = 0; k < 5; ++k) cells.insert({i, j, k});
  for (auto c : {std::make_tuple(2, 2, 2), std::make_tuple(3, 2, 2), std::make_tuple(3, 3, 2),
                 std::make_tuple(3, 4, 2),                               // the pocket and tunnel
                 std::make_tuple(0, 0, 4), std::make_tuple(1, 0, 4)}) {  // the notch
    cells.erase(c);
  }
  const Mesh block = voxel_mesh(cells, 1.0, Vec3(-2.5, -2.5, -2.5));
  ASSERT_TRUE(mesh_stats(block).closed());
  const Box box = box_of(Vec3(3, 3, 3));
  const DepthCube cube = bake_depth_cube(block, box, 24);  // texel 0.25: centres off the edges
  const WindingNumber winding(block);
  auto cell_centre = [](int i, int j, int k) { return Vec3(i - 2.0, j - 2.0, k - 2.0); };
  const Vec3 pocket = cell_centre(2, 2, 2), bend = cell_centre(3, 2, 2), top = cell_centre(3, 4, 2);
  const Vec3 notch = cell_centre(0, 0, 4), solid = cell_centre(1, 1, 1);
  EXPECT_LT(winding.exact(pocket), 0.5);  // outside the mesh ...
  EXPECT_GT(depth_cube_value(cube, pocket), 0.0) << "the pocket is seen by no face";  // inside
  EXPECT_LT(depth_cube_value(cube, bend), 0.0);  // the tunnel is seen from +y: outside
  EXPECT_LT(depth_cube_value(cube, top), 0.0);
  EXPECT_LT(depth_cube_value(cube, notch), 0.0);  // the notch is seen from +z: outside
  EXPECT_GT(depth_cube_value(cube, solid), 0.0);
  std::printf(
      "[figures] hidden pocket: f = %.3g at its centre (true: outside, 0.5 from the walls)\n",
      depth_cube_value(cube, pocket));
}

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

// The bunny twist of examples/ with its implicit swapped to a depth cube of the same resolution.
TEST(DepthCubeRender, BunnyTwistMatchesReferenceAndGroundTruth) {
  constexpr int kSize = 256;
  const std::string root = RAYWARP_SOURCE_DIR;
  Scene scene = load_scene(root + "/examples/bunny_twist.json");
  scene.boxes[0].implicit.type = "depth_cube";
  const Camera camera = load_camera(root + "/examples/cameras/front.json");
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(scene, log);
  ASSERT_EQ(prepared.boxes.size(), 1u);
  const BakedBox& box = prepared.boxes[0];
  ASSERT_TRUE(box.textures.uses_depth_cube) << log.str();
  EXPECT_TRUE(box.textures.sdf.grid.data.empty());
  EXPECT_NE(log.str().find("depth cube: 6 maps"), std::string::npos) << log.str();

  context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  const size_t deformation_bytes = box.textures.deformation.grid.size() * 16;
  EXPECT_EQ(renderer.texture_bytes(), box.textures.depth_cube.texture_bytes() + deformation_bytes);
  gl::FrameStats stats;
  const Image gl_image = renderer.render(camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);

  const double voxel = implicit_spacing(box.textures);
  auto F = [&](const Vec3& p) { return box.deformer->forward(p); };
  const Mesh truth_mesh = ground_truth_mesh(prepared.mesh(), box.textures.box, F, 0.25 * voxel);
  const Image truth = rasterize(truth_mesh, camera, kSize, kSize, scene.render);
  const double diagonal = mesh_bounds(truth_mesh).diagonal().norm();
  const ImageComparison vs_truth = compare_images(gl_image, truth, 0.01 * diagonal);
  const Image cpu =
      reference_render(prepared.mesh(), prepared.textures(), camera, kSize, kSize, scene.render);
  const ImageComparison vs_cpu = compare_images(gl_image, cpu, 0.01 * diagonal);
  std::printf(
      "[figures] bunny twist, depth cube 128: GL vs ground truth: IoU %.4f, over 1%% of diag "
      "%.2f%%, mean depth err %.4g; GL vs CPU reference: IoU %.4f, over %.2f%%; frame %.1f ms\n",
      vs_truth.iou, 100 * vs_truth.fraction_over, vs_truth.mean_depth_error, vs_cpu.iou,
      100 * vs_cpu.fraction_over, stats.milliseconds);
  std::filesystem::create_directories("depth_cube_test_images");
  write_png("depth_cube_test_images/bunny_twist_gl.png", gl_image);
  write_png("depth_cube_test_images/bunny_twist_truth.png", truth);
  write_png("depth_cube_test_images/bunny_twist_cpu.png", cpu);

  // The shader and its CPU mirror read the same maps.
  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
  // The project's thresholds against the exact surface.
  EXPECT_GE(vs_truth.iou, 0.98);
  EXPECT_LE(vs_truth.fraction_over, 0.02);
}

// Other variants of the depth-cube shader against its CPU mirror, small images: 16-bit maps (an
// R16F array), cuts (skipping inside the cut only), a box cut (no deformation texture).
struct Variant {
  std::string scene;
  int texture_bits;
  bool skipping;
};

class DepthCubeVariant : public ::testing::TestWithParam<Variant> {};

TEST_P(DepthCubeVariant, MatchesCpuReference) {
  constexpr int kSize = 128;
  const std::string root = RAYWARP_SOURCE_DIR;
  Scene scene = load_scene(root + "/examples/" + GetParam().scene);
  scene.boxes[0].implicit.type = "depth_cube";
  scene.boxes[0].implicit.resolution = 96;
  scene.render.texture_bits = GetParam().texture_bits;
  scene.render.skipping = GetParam().skipping;
  std::ostringstream log;
  const PreparedScene prepared = prepare_scene(scene, log);
  context();
  gl::Renderer renderer;
  renderer.set_mesh(prepared.mesh());
  renderer.set_boxes(prepared.textures());
  const size_t per_texel = GetParam().texture_bits == 16 ? 2 : 4;
  EXPECT_GE(renderer.texture_bytes(),
            prepared.boxes[0].textures.depth_cube.texture_bytes(static_cast<int>(per_texel)));
  gl::FrameStats stats;
  const Image gl_image = renderer.render(*scene.camera, kSize, kSize, scene.render, &stats);
  EXPECT_EQ(stats.nonfinite_pixels, 0);
  const Image cpu = reference_render(prepared.mesh(), prepared.textures(), *scene.camera, kSize,
                                     kSize, scene.render);
  const double diagonal = mesh_bounds(prepared.mesh()).diagonal().norm();
  const ImageComparison vs_cpu = compare_images(gl_image, cpu, 0.01 * diagonal);
  std::printf("[figures] %s, depth cube 96, %d-bit%s: GL vs CPU reference IoU %.4f, over %.2f%%\n",
              GetParam().scene.c_str(), GetParam().texture_bits,
              GetParam().skipping ? ", skipping" : "", vs_cpu.iou, 100 * vs_cpu.fraction_over);
  EXPECT_GE(vs_cpu.iou, 0.99);
  EXPECT_LE(vs_cpu.fraction_over, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Scenes, DepthCubeVariant,
                         ::testing::Values(Variant{"bunny_bend.json", 16, true},
                                           Variant{"bunny_peel.json", 32, true},
                                           Variant{"bunny_cut_solid.json", 32, true},
                                           Variant{"bunny_cut_hollow.json", 32, false}),
                         [](const auto& info) {
                           std::string s = info.param.scene.substr(0, info.param.scene.size() - 5) +
                                           "_" + std::to_string(info.param.texture_bits);
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

// The depth-cube variants compile, link and hit (each cut mode, each sampling method, a box cut),
// and hold no distance-grid code (nor the distance grid's variants depth-cube code).
TEST(DepthCubeShader, VariantsCompileAndHit) {
  context();
  const Mesh mesh = fixtures::cube(0.5);
  BoxTextures b;
  b.box.half_extents = Vec3(1, 1, 1);
  b.depth_cube = bake_depth_cube(mesh, b.box, 8);
  b.uses_depth_cube = true;
  b.lipschitz = 1.0;
  b.region = Eigen::AlignedBox3d(Vec3(-1, -1, -1), Vec3(1, 1, 1));
  RenderSettings linear;
  linear.sampling = Sampling::Linear;
  const std::string text = gl::raycast_fragment_source(b, linear);
  EXPECT_NE(text.find("u_depth"), std::string::npos);
  EXPECT_EQ(text.find("u_sdf_origin"), std::string::npos);
  BoxTextures grid = b;
  grid.uses_depth_cube = false;
  EXPECT_EQ(gl::raycast_fragment_source(grid, linear).find("u_depth"), std::string::npos);
  // Each cut mode (the skip inside the cut differs), each sampling method, D = 0 (a box cut).
  struct Case {
    int cut;
    bool moves_nothing;
    Sampling sampling;
  };
  const Case cases[] = {{0, false, Sampling::Linear},
                        {1, false, Sampling::Threshold},
                        {2, false, Sampling::Jacobian},
                        {3, false, Sampling::Threshold},
                        {2, true, Sampling::Linear}};
  for (const Case& c : cases) {
    BoxTextures v = b;
    v.has_cut = c.cut > 0;
    v.cut_mode = CutMode(std::max(c.cut - 1, 0));
    v.shell_thickness = 0.2;
    v.moves_nothing = c.moves_nothing;
    if (!c.moves_nothing)
      v.deformation.grid = Grid3<Eigen::Vector4f>(Vec3(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4),
                                                  Eigen::Vector4f(0, 0, 0, 1));
    if (c.cut) v.alpha.grid = Grid3<float>(Vec3(-1, -1, -1), 0.5, Eigen::Vector3i(4, 4, 4), -1.f);
    RenderSettings settings;  // skipping on: inside a cut it applies
    settings.sampling = c.sampling;
    gl::Renderer renderer;
    renderer.set_mesh(mesh);
    renderer.set_boxes({v});
    const Camera camera;  // at (0, 0, 5), looking at the box
    Image image;
    EXPECT_NO_THROW(image = renderer.render(camera, 8, 8, settings))
        << "cut " << c.cut << ", moves nothing " << c.moves_nothing << ", "
        << sampling_name(c.sampling);
    EXPECT_TRUE(image.covered(4, 4)) << "cut " << c.cut << ": the cube is in the box";
  }
}

// Scene files: a scene in a temporary folder naming the bunny by its absolute path.
class DepthCubeScene : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = std::filesystem::temp_directory_path() /
              ("raywarp_depth_cube_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(folder_);
  }
  void TearDown() override { std::filesystem::remove_all(folder_); }

  Scene load(const nlohmann::json& implicit, const nlohmann::json& render = nullptr) {
    nlohmann::json j = {{"mesh", std::string(RAYWARP_SOURCE_DIR) + "/examples/meshes/bunny.ply"},
                        {"boxes",
                         {{{"min", {-5.2, 1.93, -4.0}},
                           {"max", {5.2, 7.72, 4.0}},
                           {"deformer", {{"type", "twist"}, {"axis", "y"}, {"angle_deg", 360}}},
                           {"implicit", implicit}}}}};
    if (!render.is_null()) j["render"] = render;
    const std::filesystem::path path = folder_ / "scene.json";
    std::ofstream(path) << j.dump(2);
    return load_scene(path);
  }
  std::string error(const nlohmann::json& implicit, const nlohmann::json& render = nullptr) {
    try {
      load(implicit, render);
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  }

  std::filesystem::path folder_;
};

TEST_F(DepthCubeScene, TypeAndResolution) {
  const Scene s = load({{"type", "depth_cube"}, {"resolution", 4096}});
  EXPECT_EQ(s.boxes[0].implicit.type, "depth_cube");
  EXPECT_EQ(s.boxes[0].implicit.resolution, 4096);  // beyond the distance grid's 1024
  EXPECT_EQ(load({{"type", "depth_cube"}}).boxes[0].implicit.resolution, kAutoResolution);
  EXPECT_EQ(load({{"resolution", 64}}).boxes[0].implicit.type, "sdf");
}

TEST_F(DepthCubeScene, Errors) {
  auto has = [](const std::string& message, const std::string& part) {
    return message.find(part) != std::string::npos;
  };
  std::string e = error({{"type", "depth_map"}});
  EXPECT_TRUE(has(e, "boxes[0].implicit.type = \"depth_map\": must be one of sdf, depth_cube"))
      << e;
  e = error({{"type", "depth_cube"}, {"resolution", 5000}});
  EXPECT_TRUE(has(e, "boxes[0].implicit.resolution = 5000: must be an integer in [8, 4096]")) << e;
  e = error({{"type", "sdf"}, {"resolution", 2048}});
  EXPECT_TRUE(has(e, "boxes[0].implicit.resolution = 2048: must be an integer in [8, 1024]")) << e;
  e = error({{"type", "depth_cube"}, {"band_voxels", 3}});
  EXPECT_TRUE(has(e,
                  "boxes[0].implicit.band_voxels = 3: band_voxels applies to the distance "
                  "grid (type sdf)"))
      << e;
  e = error({{"type", "depth_cube"}}, {{"sampling", "bounded"}});
  EXPECT_TRUE(has(e, "render.sampling = \"bounded\": boxes[0].implicit.type is \"depth_cube\""))
      << e;
  EXPECT_TRUE(has(e, "scene.json")) << e;
  // The distance grid still takes bounded tracing.
  EXPECT_EQ(load({{"type", "sdf"}}, {{"sampling", "bounded"}}).render.sampling, Sampling::Bounded);
}

}  // namespace
}  // namespace raywarp
