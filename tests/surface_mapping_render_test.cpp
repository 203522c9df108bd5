// The vertex-shader path of the surface mappings (gl/surface_mapping_render.h) through OSMesa:
//  - the positions and normals the shader computes, read back, equal the CPU deform() in double
//    to float precision, in both bases, for a deformation that is not affine (and differ from the
//    other basis's, so the check can fail);
//  - its image has the depth of the CPU-deformed mesh drawn by gl::Renderer (same camera
//    conventions) and of the CPU rasteriser of verify/reference.h;
//  - the frame time at 512 x 512 (figures for docs/surface_mapping.md).
#include "gl/surface_mapping_render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "gl/context.h"
#include "gl/renderer.h"
#include "library/image.h"
#include "tests/mesh_fixtures.h"
#include "tests/surface_mapping_fixtures.h"
#include "verify/reference.h"

using namespace raywarp;

namespace {

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

constexpr SurfaceBasis kBases[] = {SurfaceBasis::Triangle, SurfaceBasis::Interpolated};

struct Case {
  fixtures::TetBody body = fixtures::kuhn_box(2, 2, 3, 0.5);
  std::vector<NodeTriangle> triangles = boundary_triangles(body.tets);
  Mesh mesh = fixtures::icosphere(0.58, 4, Eigen::Vector3d(0.5, 0.5, 0.75));
  std::vector<Eigen::Vector3d> deformed =
      fixtures::twist_and_bend(body.nodes, Eigen::Vector3d(0.5, 0.5, 0.75), 0.9, 0.3);
};

Camera front_camera() {
  Camera c;
  c.eye = Eigen::Vector3d(0.6, 1.9, 2.6);
  c.target = Eigen::Vector3d(0.5, 0.5, 0.75);
  c.fov_y_deg = 40;
  return c;
}

TEST(SurfaceMappingRender, ShaderMatchesCpu) {
  context();
  const Case s;
  const double diagonal = mesh_bounds(s.mesh).diagonal().norm();
  gl::SurfaceMappingRenderer renderer;
  std::vector<std::vector<Eigen::Vector3d>> cpu_of_basis;
  for (SurfaceBasis basis : kBases) {
    const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, basis);
    renderer.set_binding(b, s.mesh);
    renderer.set_nodes(s.deformed);
    EXPECT_EQ(renderer.surface_nodes(), 36 - 2);  // the 3 x 3 x 4 lattice less its 2 inner nodes
    const gl::SurfaceMappingRenderer::Mapped gpu = renderer.mapped_vertices();
    const std::vector<Eigen::Vector3d> cpu = deform(b, s.body.nodes, s.deformed);
    const std::vector<Eigen::Vector3d> cpu_normals = deform_normals(b, s.deformed);
    ASSERT_EQ(gpu.positions.size(), cpu.size());
    double worst = 0, worst_angle = 0;
    for (size_t i = 0; i < cpu.size(); ++i) {
      worst = std::max(worst, (gpu.positions[i].cast<double>() - cpu[i]).norm());
      const Eigen::Vector3d n = gpu.normals[i].cast<double>().normalized();
      worst_angle = std::max(worst_angle, (n - cpu_normals[i]).norm());
    }
    std::printf(
        "[figures] %s basis: %zu vertices, GPU vs CPU positions max %.3g (%.3g of the "
        "diagonal), normals max %.3g\n",
        basis_name(basis), cpu.size(), worst, worst / diagonal, worst_angle);
    EXPECT_LE(worst, 2e-6 * diagonal) << basis_name(basis);
    EXPECT_LE(worst_angle, 1e-5) << basis_name(basis);
    cpu_of_basis.push_back(cpu);
  }
  // The bases differ by far more than float rounding under this deformation, so a shader that
  // ignored u_interpolated would fail above.
  double between = 0;
  for (size_t i = 0; i < cpu_of_basis[0].size(); ++i)
    between = std::max(between, (cpu_of_basis[0][i] - cpu_of_basis[1][i]).norm());
  std::printf("[figures] triangle vs interpolated basis under the twist: max %.3g\n", between);
  EXPECT_GT(between, 1e-3 * diagonal);
}

// Left-out vertices (triangle -1) keep their rest position in the shader as on the CPU.
TEST(SurfaceMappingRender, LeftOutVerticesStayPutInTheShader) {
  context();
  const Case s;
  const double diagonal = mesh_bounds(s.mesh).diagonal().norm();
  std::vector<char> moves(static_cast<size_t>(s.mesh.V.rows()));
  for (Eigen::Index i = 0; i < s.mesh.V.rows(); ++i) moves[i] = s.mesh.V(i, 0) > 0.5 ? 1 : 0;
  gl::SurfaceMappingRenderer renderer;
  for (SurfaceBasis basis : kBases) {
    const SurfaceBinding b =
        bind_surface(s.mesh, s.body.nodes, s.triangles, basis, nullptr, &moves);
    renderer.set_binding(b, s.mesh);
    renderer.set_nodes(s.deformed);
    const gl::SurfaceMappingRenderer::Mapped gpu = renderer.mapped_vertices();
    const std::vector<Eigen::Vector3d> cpu = deform(b, s.deformed);
    ASSERT_EQ(gpu.positions.size(), cpu.size());
    double worst_fixed = 0, worst_moved = 0;
    for (size_t i = 0; i < cpu.size(); ++i) {
      const double e = (gpu.positions[i].cast<double>() - cpu[i]).norm();
      (moves[i] ? worst_moved : worst_fixed) = std::max(moves[i] ? worst_moved : worst_fixed, e);
    }
    EXPECT_LE(worst_fixed, 1e-6 * diagonal) << basis_name(basis);
    EXPECT_LE(worst_moved, 2e-6 * diagonal) << basis_name(basis);
  }
}

TEST(SurfaceMappingRender, ImageMatchesCpuDeformedMesh) {
  context();
  const Case s;
  const Camera camera = front_camera();
  constexpr int kSize = 256;
  RenderSettings settings;
  for (SurfaceBasis basis : kBases) {
    const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, basis);
    gl::SurfaceMappingRenderer mapping;
    mapping.set_binding(b, s.mesh);
    mapping.set_nodes(s.deformed);
    gl::FrameStats stats;
    const Image image = mapping.render(camera, kSize, kSize, settings, &stats);
    EXPECT_EQ(stats.nonfinite_pixels, 0);

    const Mesh deformed = deform_mesh(b, s.mesh, s.deformed);
    const double diagonal = mesh_bounds(deformed).diagonal().norm();
    gl::Renderer plain;
    plain.set_mesh(deformed);
    plain.set_boxes(std::vector<BoxTextures>{});
    const Image reference = plain.render(camera, kSize, kSize, settings);
    const Image cpu = rasterize(deformed, camera, kSize, kSize, settings);
    const ImageComparison vs_gl = compare_images(image, reference, 1e-4 * diagonal);
    const ImageComparison vs_cpu = compare_images(image, cpu, 1e-3 * diagonal);
    std::printf(
        "[figures] %s basis at %d^2: vs gl::Renderer of the CPU-deformed mesh IoU %.5f, "
        "max depth err %.3g (diag %.3g); vs CPU rasteriser IoU %.5f, over 0.1%% %.4f%%\n",
        basis_name(basis), kSize, vs_gl.iou, vs_gl.max_depth_error, diagonal, vs_cpu.iou,
        100 * vs_cpu.fraction_over);
    std::filesystem::create_directories("surface_mapping_images");
    write_png(std::string("surface_mapping_images/") + basis_name(basis) + ".png", image);
    EXPECT_GE(vs_gl.iou, 0.999);
    EXPECT_LE(vs_gl.fraction_over, 0.001);
    EXPECT_GE(vs_cpu.iou, 0.99);
    EXPECT_LE(vs_cpu.fraction_over, 0.01);
    EXPECT_GT(vs_gl.common, kSize * kSize / 20);
  }
}

TEST(SurfaceMappingRender, BadInput) {
  context();
  const Case s;
  const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, SurfaceBasis::Triangle);
  gl::SurfaceMappingRenderer renderer;
  EXPECT_THROW(renderer.render(front_camera(), 8, 8, RenderSettings{}), Error);
  EXPECT_THROW(renderer.set_binding(b, fixtures::icosphere(1.0, 1)), Error);
  renderer.set_binding(b, s.mesh);
  EXPECT_THROW(renderer.mapped_vertices(), Error);
  EXPECT_THROW(renderer.set_nodes({Eigen::Vector3d::Zero()}), Error);
}

// Frame times of the mapping at 512^2: the dragon (100K vertices) when unpacked, else the test
// sphere, bound to a Kuhn body.
TEST(SurfaceMappingRender, FrameTime) {
  context();
  const std::string path = std::string(RAYWARP_DATA_DIR) + "/dragon_res2.ply";
  const bool dragon = std::filesystem::exists(path);
  const Mesh mesh = dragon ? load_mesh(path) : Case{}.mesh;
  const fixtures::TetBody body = fixtures::voxel_body(mesh, 24);
  const std::vector<NodeTriangle> tris = boundary_triangles(body.tets);
  const Eigen::AlignedBox3d bounds = mesh_bounds(mesh);
  const Eigen::Vector3d centre = bounds.center();
  const double size = bounds.sizes().maxCoeff();
  const std::vector<Eigen::Vector3d> deformed =
      fixtures::twist_and_bend(body.nodes, centre, 1.0 / size, 0.2 / size);
  Camera camera;
  camera.target = centre;
  camera.eye = centre + Eigen::Vector3d(0.3, 0.4, 2.2) * size;
  camera.fov_y_deg = 35;
  RenderSettings settings;
  constexpr int kSize = 512, kFrames = 15;
  for (SurfaceBasis basis : kBases) {
    const SurfaceBinding b = bind_surface(mesh, body.nodes, tris, basis);
    gl::SurfaceMappingRenderer renderer;
    renderer.set_binding(b, mesh);
    std::vector<double> frame, upload;
    for (int k = 0; k < kFrames; ++k) {
      const auto start = std::chrono::steady_clock::now();
      renderer.set_nodes(deformed);
      upload.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count());
      gl::FrameStats stats;
      renderer.render(camera, kSize, kSize, settings, &stats);
      frame.push_back(stats.milliseconds);
    }
    std::sort(frame.begin(), frame.end());
    std::sort(upload.begin(), upload.end());
    // The plain raster pass of the same (CPU-deformed) mesh, for scale.
    gl::Renderer plain;
    plain.set_mesh(deform_mesh(b, mesh, deformed));
    plain.set_boxes(std::vector<BoxTextures>{});
    std::vector<double> plain_ms;
    for (int k = 0; k < kFrames; ++k) {
      gl::FrameStats stats;
      plain.render(camera, kSize, kSize, settings, &stats);
      plain_ms.push_back(stats.milliseconds);
    }
    std::sort(plain_ms.begin(), plain_ms.end());
    std::printf(
        "[figures] %s: %s basis, %ld vertices, %ld triangles, %d surface nodes of %zu, "
        "%zu coarse triangles, %d^2 on %s: median frame %.2f ms (min %.2f), node upload "
        "%.3f ms; plain raster pass of the CPU-deformed mesh %.2f ms\n",
        dragon ? "dragon_res2" : "sphere", basis_name(basis), long(mesh.V.rows()),
        long(mesh.F.rows()), renderer.surface_nodes(), body.nodes.size(), tris.size(), kSize,
        context().description().c_str(), frame[kFrames / 2], frame[0], upload[kFrames / 2],
        plain_ms[kFrames / 2]);
    const Image image = renderer.render(camera, kSize, kSize, settings);
    std::filesystem::create_directories("surface_mapping_images");
    write_png(std::string("surface_mapping_images/frame_") + basis_name(basis) + ".png", image);
  }
}

}  // namespace
