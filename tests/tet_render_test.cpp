// The tetrahedral walk on the GPU (gl/tet_render.h) through OSMesa, against its CPU mirror in
// double (verify/tet_walk.h):
//  - the per-state planes and gradients of the GPU update pass equal tet_geometry's to float
//    precision;
//  - surface and volume images of a convex Kuhn box and of two non-convex bodies (a U, the Kuhn
//    tetrahedra of the bunny's voxel mask), at rest and twisted: IoU, depth and colour against the
//    CPU mirror, and the depth-peeling pass count against the CPU's largest section count;
//  - a comb whose rays enter and leave four times, and the pass cap;
//  - the rest pose of a sphere's Kuhn tetrahedra with f = R - |x| against the rasterised
//    icosphere of radius R;
//  - frame times at 512 x 512 on the bunny's tetrahedra and a ~156K-tetrahedron blob (figures for
//    docs/tet_render.md, not asserted).
#include "gl/tet_render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "base/error.h"
#include "gl/context.h"
#include "library/image.h"
#include "library/mesh.h"
#include "library/tet_mesh.h"
#include "library/winding.h"
#include "physics/models.h"
#include "tests/mesh_fixtures.h"
#include "tests/surface_mapping_fixtures.h"
#include "verify/reference.h"
#include "verify/tet_walk.h"

namespace raywarp {
namespace {

using Vec3 = Eigen::Vector3d;
using Box3 = Eigen::AlignedBox3d;

gl::Context& context() {
  static auto ctx = gl::create_osmesa_context();
  return *ctx;
}

struct Body {
  std::string name;
  std::vector<std::array<int, 4>> tets;
  std::vector<Vec3> nodes;
};

Box3 bounds_of(const std::vector<Vec3>& nodes) {
  Box3 b;
  for (const Vec3& p : nodes) b.extend(p);
  return b;
}

// A twist about the axis through the bounds' centre along `axis`: rate radians per unit of
// height along it.
std::vector<Vec3> twisted(const std::vector<Vec3>& nodes, int axis, double rate) {
  const Vec3 c = bounds_of(nodes).center();
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  std::vector<Vec3> out;
  for (const Vec3& p : nodes) {
    const Vec3 q = p - c;
    const double a = rate * q[axis], cs = std::cos(a), sn = std::sin(a);
    Vec3 r = q;
    r[u] = cs * q[u] - sn * q[v];
    r[v] = sn * q[u] + cs * q[v];
    out.push_back(c + r);
  }
  return out;
}

// f = radius - |x - centre| per node (> 0 inside the ball).
std::vector<double> ball_scalar(const std::vector<Vec3>& nodes, const Vec3& centre, double radius) {
  std::vector<double> f;
  for (const Vec3& p : nodes) f.push_back(radius - (p - centre).norm());
  return f;
}

// The height along `axis`, 0 at the bounds' bottom, 1 at the top.
std::vector<double> height_scalar(const std::vector<Vec3>& nodes, int axis) {
  const Box3 b = bounds_of(nodes);
  std::vector<double> s;
  for (const Vec3& p : nodes) s.push_back((p[axis] - b.min()[axis]) / b.sizes()[axis]);
  return s;
}

TransferFunction transfer(double tau) {
  TransferFunction tf;
  tf.points = {{0.0, Vec3(0.9, 0.3, 0.1), 0.6 * tau},
               {0.5, Vec3(0.2, 0.8, 0.3), 0.2 * tau},
               {1.0, Vec3(0.1, 0.3, 0.9), 1.2 * tau}};
  return tf;
}

// A camera looking at the body's bounds from `direction`, from 2.2 diagonals away.
Camera camera_for(const std::vector<Vec3>& nodes, const Vec3& direction) {
  const Box3 b = bounds_of(nodes);
  Camera c;
  c.target = b.center();
  c.eye = b.center() + 2.2 * b.diagonal().norm() * direction.normalized();
  c.fov_y_deg = 30;
  return c;
}

int max_colour_difference(const Image& a, const Image& b) {
  int off = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i)
    off = std::max(off, std::abs(int(a.rgba[i]) - int(b.rgba[i])));
  return off;
}

// The largest colour difference over pixels both images cover.
int max_common_colour_difference(const Image& a, const Image& b) {
  int off = 0;
  for (size_t p = 0; p < a.depth.size(); ++p) {
    if (!std::isfinite(a.depth[p]) || !std::isfinite(b.depth[p])) continue;
    for (int c = 0; c < 3; ++c)
      off = std::max(off, std::abs(int(a.rgba[4 * p + c]) - int(b.rgba[4 * p + c])));
  }
  return off;
}

// Pixels with a colour channel off by more than `by`.
long pixels_over(const Image& a, const Image& b, int by) {
  long n = 0;
  for (size_t p = 0; p < a.depth.size(); ++p) {
    int off = 0;
    for (int c = 0; c < 3; ++c)
      off = std::max(off, std::abs(int(a.rgba[4 * p + c]) - int(b.rgba[4 * p + c])));
    n += off > by;
  }
  return n;
}

// The Kuhn tetrahedra of the bunny's inside sampled `voxels` along its longest side (spacing 1),
// as the stiffness study builds its bunny model.
Body bunny_body(int voxels) {
  const Mesh mesh = load_mesh(std::string(RAYWARP_SOURCE_DIR) + "/examples/meshes/bunny.ply");
  const Vec3 lo = mesh.V.colwise().minCoeff().transpose();
  const Vec3 hi = mesh.V.colwise().maxCoeff().transpose();
  const double voxel = (hi - lo).maxCoeff() / voxels;
  const Eigen::Vector3i dims = (((hi - lo) / voxel).array().ceil().cast<int>() + 2).matrix();
  const WindingNumber wn(mesh);
  Grid3<std::uint8_t> mask(Vec3::Zero(), 1.0, dims, 0);
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i)
        mask.at(i, j, k) = wn(lo + voxel * Vec3(i - 0.5, j - 0.5, k - 0.5)) > 0.5 ? 1 : 0;
  const physics::TetMesh t = physics::tetrahedralize(mask);
  return {"bunny tets", t.tets, t.nodes};
}

Body kuhn_box_body() {
  const fixtures::TetBody b = fixtures::kuhn_box(6, 5, 4, 0.25);
  return {"Kuhn box 6x5x4", b.tets, b.nodes};
}

// A U of 5 x 3 x 2 unit cubes (two arms on a bar), as tests/tet_walk_test.cpp.
Body u_body() {
  const fixtures::TetBody b = fixtures::kuhn_body(
      {5, 3, 2}, Vec3::Zero(), 1.0, [](int i, int j, int) { return j == 0 || i != 2; });
  return {"U body", b.tets, b.nodes};
}

struct Figures {
  ImageComparison surface;
  int surface_colour = 0;  // over common pixels
  int volume_colour = 0;
  long surface_pixels_over = 0, volume_pixels_over = 0;  // pixels off by more than 2/255
  long pixels = 0;
  ImageComparison volume;
  int cpu_sections_surface = 0, cpu_sections_volume = 0;
  std::vector<long> cpu_volume_histogram;
  gl::TetWalkStats gpu_surface, gpu_volume;
};

// The GL walk against the CPU mirror on one state: surface mode of f = ball_scalar, volume mode
// of the height through transfer(tau) and a 65^3 table.
Figures against_cpu(gl::TetRenderer& renderer, const Body& body, const std::vector<Vec3>& positions,
                    const std::vector<double>& f, const std::vector<double>& s,
                    const Camera& camera, int size, double tau, const char* label) {
  Figures out;
  out.pixels = long(size) * size;
  const double diagonal = bounds_of(positions).diagonal().norm();
  RenderSettings settings;
  settings.colour = Vec3(0.8, 0.7, 0.5);
  settings.background = Vec3(0.1, 0.1, 0.15);

  renderer.set_mesh(body.tets, static_cast<int>(body.nodes.size()));
  renderer.set_state(positions, f);
  gl::FrameStats frame;
  const Image gpu_surface =
      renderer.render_surface(camera, size, size, settings, &frame, &out.gpu_surface);
  const TetWalkMesh cpu_f(body.tets, positions, f);
  TetRenderStats cpu_stats;
  const Image cpu_surface = render_tet_surface(cpu_f, camera, size, size, settings, {}, &cpu_stats);
  out.surface = compare_images(gpu_surface, cpu_surface, 1e-4 * diagonal);
  out.surface_colour = max_common_colour_difference(gpu_surface, cpu_surface);
  out.surface_pixels_over = pixels_over(gpu_surface, cpu_surface, 2);
  out.cpu_sections_surface = cpu_stats.max_sections;
  std::printf(
      "[figures] %s, %s, surface at %d^2: IoU %.6f, depth max %.2e (%.2e of the diagonal), "
      "colour max %d/255 on common pixels (%ld pixels off by more than 2/255); passes %d, CPU max "
      "sections %d; hits GPU %ld CPU "
      "%ld; steps max %ld (CPU %ld), capped %ld; GPU %.1f ms, CPU %.3f s\n",
      body.name.c_str(), label, size, out.surface.iou, out.surface.max_depth_error,
      out.surface.max_depth_error / diagonal, out.surface_colour, out.surface_pixels_over,
      out.gpu_surface.passes, cpu_stats.max_sections, out.gpu_surface.hits, cpu_stats.hits,
      out.gpu_surface.max_steps, cpu_stats.max_steps, out.gpu_surface.capped, frame.milliseconds,
      cpu_stats.seconds);

  const TransferFunction tf = transfer(tau);
  PreintegrationSizes sizes;
  sizes.scalar_samples = 65;
  sizes.length_samples = 65;
  sizes.max_length = 0.5 * diagonal;
  const PreintegrationTable table(tf, sizes);
  const Vec3 background(1.0, 1.0, 1.0);
  renderer.set_state(positions, s);
  const Image gpu_volume =
      renderer.render_volume(camera, size, size, table, background, &frame, &out.gpu_volume);
  const TetWalkMesh cpu_s(body.tets, positions, s);
  VolumeOptions options;
  options.table = &table;
  const Image cpu_volume =
      render_tet_volume(cpu_s, tf, camera, size, size, background, options, &cpu_stats);
  out.volume = compare_images(gpu_volume, cpu_volume, 1e-4 * diagonal);
  out.volume_colour = max_colour_difference(gpu_volume, cpu_volume);
  out.volume_pixels_over = pixels_over(gpu_volume, cpu_volume, 2);
  out.cpu_sections_volume = cpu_stats.max_sections;
  out.cpu_volume_histogram = cpu_stats.sections_histogram;
  long differing = 0;
  for (size_t i = 0; i < gpu_volume.rgba.size(); ++i)
    differing += std::abs(int(gpu_volume.rgba[i]) - int(cpu_volume.rgba[i])) > 1;
  std::printf(
      "[figures] %s, %s, volume at %d^2: colour max %d/255 (%ld channels off by more than 1, %ld "
      "pixels by more than 2), "
      "first-entry depth IoU %.6f, max %.2e; passes %d, CPU max sections %d; sections GPU",
      body.name.c_str(), label, size, out.volume_colour, differing, out.volume_pixels_over,
      out.volume.iou, out.volume.max_depth_error, out.gpu_volume.passes, cpu_stats.max_sections);
  for (size_t n = 0; n < out.gpu_volume.sections_histogram.size(); ++n)
    std::printf(" %zu:%ld", n, out.gpu_volume.sections_histogram[n]);
  std::printf(" CPU");
  for (size_t n = 0; n < cpu_stats.sections_histogram.size(); ++n)
    std::printf(" %zu:%ld", n, cpu_stats.sections_histogram[n]);
  std::printf("; GPU %.1f ms, CPU %.3f s\n", frame.milliseconds, cpu_stats.seconds);
  return out;
}

// Rays within the rasteriser's sub-pixel snapping of a boundary edge, or whose candidate faces
// are closer than float resolves, may enter through the neighbouring face: a few pixels in 10^4
// are allowed to differ by more than 2/255 (their count is printed).
void expect_matches(const Figures& f) {
  const double allowed = std::max(2.0, 1e-4 * f.pixels);
  EXPECT_GE(f.surface.iou, 0.9999);
  EXPECT_LE(f.surface.fraction_over, 0.0);
  EXPECT_LE(f.surface_pixels_over, allowed);
  EXPECT_LE(f.volume_pixels_over, allowed);
  EXPECT_GE(f.volume.iou, 0.9995);
  EXPECT_EQ(f.gpu_surface.passes, f.cpu_sections_surface);
  EXPECT_EQ(f.gpu_volume.passes, f.cpu_sections_volume);
  EXPECT_EQ(f.gpu_surface.capped, 0);
  EXPECT_EQ(f.gpu_volume.capped, 0);
  EXPECT_FALSE(f.gpu_surface.pass_cap_reached);
  EXPECT_FALSE(f.gpu_volume.pass_cap_reached);
}

TEST(TetRender, GpuGeometryMatchesCpu) {
  context();
  const Body body = kuhn_box_body();
  const std::vector<Vec3> moved = twisted(body.nodes, 0, 0.8);
  std::vector<double> s;
  for (const Vec3& p : moved) s.push_back(3.0 + 0.7 * p.x() - 1.3 * p.y() + p.z() * p.z());
  gl::TetRenderer renderer;
  renderer.set_mesh(body.tets, static_cast<int>(body.nodes.size()));
  renderer.set_state(moved, s);
  const gl::TetGpuGeometry gpu = renderer.geometry();
  const TetTopology topo = tet_topology(body.tets, static_cast<int>(body.nodes.size()));
  const TetGeometry cpu = tet_geometry(topo, body.tets, moved, s);
  const double diagonal = bounds_of(moved).diagonal().norm();
  double normal = 0, offset = 0, gradient = 0, gradient_offset = 0, largest = 0;
  for (int t = 0; t < topo.tet_count(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const Vec3 n = gpu.plane[t][k].head<3>().cast<double>();
      normal = std::max(normal, (n - cpu.normal[t][k]).norm());
      // The GPU's planes are in the frame centred on gpu.centre.
      offset =
          std::max(offset, std::abs(gpu.plane[t][k].w() + n.dot(gpu.centre) - cpu.offset[t][k]));
    }
    const Vec3 g = gpu.gradient[t].head<3>().cast<double>();
    largest = std::max(largest, cpu.gradient[t].norm());
    gradient = std::max(gradient, (g - cpu.gradient[t]).norm());
    gradient_offset = std::max(gradient_offset, std::abs(gpu.gradient[t].w() - g.dot(gpu.centre) -
                                                         cpu.gradient_offset[t]));
  }
  std::printf(
      "[figures] GPU update pass against tet_geometry, %d tets: normals max %.2e, offsets max "
      "%.2e (%.2e of the diagonal), gradient max %.2e (%.2e of the largest), gradient offset "
      "max %.2e; update %.3f ms\n",
      topo.tet_count(), normal, offset, offset / diagonal, gradient, gradient / largest,
      gradient_offset, renderer.update_milliseconds());
  EXPECT_LT(normal, 1e-5);
  EXPECT_LT(offset, 1e-5 * diagonal);
  EXPECT_LT(gradient, 1e-4 * largest);
  EXPECT_LT(gradient_offset, 1e-4 * (1.0 + largest * diagonal));
}

TEST(TetRender, ConvexBoxMatchesCpuMirror) {
  context();
  const Body body = kuhn_box_body();
  gl::TetRenderer renderer;
  const Vec3 c = bounds_of(body.nodes).center();
  for (const bool deformed : {false, true}) {
    const std::vector<Vec3> p = deformed ? twisted(body.nodes, 0, 1.2) : body.nodes;
    const Camera camera = camera_for(p, Vec3(0.7, 0.8, 1.6));
    const Figures f = against_cpu(renderer, body, p, ball_scalar(p, c, 0.55), height_scalar(p, 1),
                                  camera, 256, 1.5, deformed ? "twisted" : "at rest");
    expect_matches(f);
    if (!deformed) {
      EXPECT_EQ(f.gpu_volume.passes, 1);  // convex; the twist makes it concave
    }
  }
}

TEST(TetRender, NonConvexBodiesMatchCpuMirror) {
  context();
  gl::TetRenderer renderer;
  for (const Body& body : {u_body(), bunny_body(16)}) {
    const Box3 b = bounds_of(body.nodes);
    const int axis = body.name == "U body" ? 0 : 1;
    for (const bool deformed : {false, true}) {
      const std::vector<Vec3> p =
          deformed ? twisted(body.nodes, axis, 0.6 / b.sizes()[axis] * 3) : body.nodes;
      // A ball through part of the body, so some rays hit f = 0 inside it, others its boundary.
      const std::vector<double> f =
          ball_scalar(p, b.center() + 0.2 * b.sizes(), 0.45 * b.sizes().minCoeff());
      const Camera camera = camera_for(p, Vec3(-0.6, 0.7, 1.5));
      const Figures fig = against_cpu(renderer, body, p, f, height_scalar(p, 1), camera, 256,
                                      3.0 / b.diagonal().norm(), deformed ? "twisted" : "at rest");
      expect_matches(fig);
      EXPECT_GE(fig.gpu_volume.passes, 2) << body.name;
    }
  }
}

TEST(TetRender, RaysThatEnterFourTimesTakeFourPasses) {
  context();
  // Four slabs of 1 x 2 x 2 cubes along x, a unit apart.
  const fixtures::TetBody comb =
      fixtures::kuhn_body({7, 2, 2}, Vec3::Zero(), 1.0, [](int i, int, int) { return i % 2 == 0; });
  const Body body{"comb", comb.tets, comb.nodes};
  Camera camera = camera_for(comb.nodes, Vec3(1.0, 0.12, 0.1));
  camera.fov_y_deg = 12;
  gl::TetRenderer renderer;
  const Figures f =
      against_cpu(renderer, body, comb.nodes, std::vector<double>(comb.nodes.size(), -1.0),
                  height_scalar(comb.nodes, 2), camera, 128, 0.2, "at rest");
  expect_matches(f);
  EXPECT_EQ(f.cpu_sections_volume, 4);
  EXPECT_EQ(f.gpu_volume.passes, 4);
  EXPECT_EQ(f.gpu_surface.passes, 4);  // f < 0 everywhere: every section is walked, no hit
  EXPECT_EQ(f.gpu_surface.hits, 0);
  // Rays by their section count: the same on both sides, but for rays through an edge.
  auto count = [](const std::vector<long>& h, size_t k) { return k < h.size() ? h[k] : 0L; };
  long differing = 0;
  for (size_t k = 0; k < 8; ++k)
    differing +=
        std::abs(count(f.gpu_volume.sections_histogram, k) - count(f.cpu_volume_histogram, k));
  EXPECT_LE(differing, 0.001 * f.gpu_volume.rays);
  EXPECT_GT(count(f.cpu_volume_histogram, 4), 0);

  // The pass cap stops the peeling and says so.
  renderer.set_pass_cap(2);
  gl::TetWalkStats stats;
  const PreintegrationTable table(transfer(0.2), PreintegrationSizes{});
  renderer.render_volume(camera, 64, 64, table, Vec3::Ones(), nullptr, &stats);
  EXPECT_EQ(stats.passes, 2);
  EXPECT_TRUE(stats.pass_cap_reached);
  EXPECT_EQ(stats.max_sections, 2);
  std::printf("[figures] comb with pass cap 2: %d passes, cap reached %d\n", stats.passes,
              int(stats.pass_cap_reached));
}

TEST(TetRender, RestPoseMatchesTheRasterisedSphere) {
  context();
  // Kuhn tetrahedra of the lattice cells within R + 2h of the centre; f = R - |x| per node.
  const double radius = 1.0, h = 0.1;
  const int cells = 26;
  const Vec3 origin = Vec3::Constant(-h * cells / 2);
  const fixtures::TetBody ball =
      fixtures::kuhn_body({cells, cells, cells}, origin, h, [&](int i, int j, int k) {
        const Vec3 centre = origin + h * Vec3(i + 0.5, j + 0.5, k + 0.5);
        return centre.norm() < radius + 2 * h;
      });
  gl::TetRenderer renderer;
  renderer.set_mesh(ball.tets, static_cast<int>(ball.nodes.size()));
  renderer.set_state(ball.nodes, ball_scalar(ball.nodes, Vec3::Zero(), radius));
  const Mesh sphere = fixtures::icosphere(radius, 5);
  Camera camera;
  camera.eye = Vec3(1.2, 2.0, 4.5);
  camera.target = Vec3::Zero();
  camera.fov_y_deg = 35;
  const int size = 256;
  RenderSettings settings;
  gl::FrameStats frame;
  gl::TetWalkStats walk;
  const Image walked = renderer.render_surface(camera, size, size, settings, &frame, &walk);
  const Image raster = rasterize(sphere, camera, size, size, settings);
  const double diagonal = mesh_bounds(sphere).diagonal().norm();
  const ImageComparison cmp = compare_images(walked, raster, 0.01 * diagonal);
  std::printf(
      "[figures] sphere of %zu tets (f = R - |x|, h = R/10) against the rasterised icosphere at "
      "%d^2: IoU %.5f, %.3f %% of common pixels off by more than 1 %% of the diagonal, depth "
      "max %.2e (%.2e of the diagonal), mean %.2e; %d passes, %.1f ms\n",
      ball.tets.size(), size, cmp.iou, 100 * cmp.fraction_over, cmp.max_depth_error,
      cmp.max_depth_error / diagonal, cmp.mean_depth_error, walk.passes, frame.milliseconds);
  EXPECT_GE(cmp.iou, 0.98);
  EXPECT_LE(cmp.fraction_over, 0.02);
}

// Frame times at 512^2 (figures only): the bunny's tetrahedra and the blob, each at rest and
// twisted; surface mode of a ball level set inside the body, volume mode of the height.
TEST(TetRender, FrameTimes) {
  std::printf("[figures] context: %s\n", context().description().c_str());
  const physics::TetMesh blob_mesh =
      physics::tetrahedralize(physics::ellipsoid_mask(Vec3(33, 14, 15.3)));
  const Body blob{"blob", blob_mesh.tets, blob_mesh.nodes};
  gl::TetRenderer renderer;
  for (const Body& body : {bunny_body(16), blob}) {
    const Box3 b = bounds_of(body.nodes);
    const int axis = body.name == "blob" ? 0 : 1;
    for (const bool deformed : {false, true}) {
      const std::vector<Vec3> p =
          deformed ? twisted(body.nodes, axis, 1.5 / b.sizes()[axis]) : body.nodes;
      const Camera camera = camera_for(p, Vec3(-0.6, 0.7, 1.5));
      const auto upload_start = std::chrono::steady_clock::now();
      renderer.set_mesh(body.tets, static_cast<int>(body.nodes.size()));
      const double mesh_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - upload_start)
              .count();
      const std::vector<double> f = ball_scalar(p, b.center(), 0.4 * b.sizes().minCoeff());
      renderer.set_state(p, f);
      RenderSettings settings;
      gl::FrameStats frame;
      gl::TetWalkStats walk;
      std::vector<double> ms;
      for (int i = 0; i < 3; ++i) {
        renderer.render_surface(camera, 512, 512, settings, &frame, &walk);
        ms.push_back(frame.milliseconds);
      }
      std::sort(ms.begin(), ms.end());
      std::printf(
          "[figures] %s (%zu tets), %s, surface at 512^2: %.1f ms (median of 3; %.2f fps), %d "
          "passes, steps max %ld, mean %.1f per entering ray, capped %ld; set_mesh %.1f ms, "
          "update pass %.2f ms\n",
          body.name.c_str(), body.tets.size(), deformed ? "twisted" : "at rest", ms[1],
          1000.0 / ms[1], walk.passes, walk.max_steps,
          walk.entered ? double(walk.total_steps) / walk.entered : 0.0, walk.capped, mesh_ms,
          renderer.update_milliseconds());
      const TransferFunction tf = transfer(1.0 / b.sizes().minCoeff());
      PreintegrationSizes sizes;
      sizes.scalar_samples = 65;
      sizes.length_samples = 65;
      sizes.max_length = 4.0;
      const PreintegrationTable table(tf, sizes);
      renderer.set_state(p, height_scalar(p, 1));
      ms.clear();
      for (int i = 0; i < 3; ++i) {
        renderer.render_volume(camera, 512, 512, table, Vec3::Ones(), &frame, &walk);
        ms.push_back(frame.milliseconds);
      }
      std::sort(ms.begin(), ms.end());
      std::printf(
          "[figures] %s (%zu tets), %s, volume at 512^2: %.1f ms (median of 3; %.2f fps), %d "
          "passes, steps max %ld, mean %.1f per entering ray, capped %ld\n",
          body.name.c_str(), body.tets.size(), deformed ? "twisted" : "at rest", ms[1],
          1000.0 / ms[1], walk.passes, walk.max_steps,
          walk.entered ? double(walk.total_steps) / walk.entered : 0.0, walk.capped);
      EXPECT_EQ(walk.capped, 0);
    }
  }
}

TEST(TetRender, BadInputsAreRefused) {
  context();
  gl::TetRenderer renderer;
  Camera camera;
  EXPECT_THROW(renderer.render_surface(camera, 8, 8, RenderSettings{}), Error);  // no mesh
  EXPECT_THROW(renderer.set_state({Vec3::Zero()}, {}), Error);                   // no mesh
  EXPECT_THROW(renderer.set_mesh({{0, 1, 2, 4}}, 4), Error);  // node out of range
  renderer.set_mesh({{0, 1, 2, 3}}, 4);
  EXPECT_THROW(renderer.render_surface(camera, 8, 8, RenderSettings{}), Error);  // no state
  const std::vector<Vec3> p = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  EXPECT_THROW(renderer.set_state({p[0], p[1]}, {}), Error);
  EXPECT_THROW(renderer.set_state(p, {1.0}), Error);
  renderer.set_state(p, {});
  EXPECT_THROW(renderer.render_surface(camera, 0, 8, RenderSettings{}), Error);
  EXPECT_THROW(renderer.set_pass_cap(0), Error);
}

}  // namespace
}  // namespace raywarp
