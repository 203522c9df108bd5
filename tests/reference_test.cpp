// The CPU references: the ray cast against an analytic sphere, the rasteriser against the ray
// cast, and the ground-truth mesh (splitting at the box faces, subdivision, forward map).
#include "verify/reference.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <utility>

#include "base/error.h"
#include "tests/mesh_fixtures.h"

namespace raywarp {
namespace {

using Vec3 = Eigen::Vector3d;

// ---------------------------------------------------------------------------------------------
// Fixtures: an icosphere, its analytic distance grid and an identity or translating texture.

struct Sphere {
  Vec3 centre;  // object space
  double radius;
};

Box make_box(const Vec3& centre, const Vec3& half, const Eigen::AngleAxisd& rotation) {
  Box b;
  b.centre = centre;
  b.half_extents = half;
  b.rotation = rotation.toRotationMatrix();
  return b;
}

// The textures of `box` holding the part of `sphere` inside it: the exact signed distance
// f = r - |q - c| (f > 0 inside) sampled at texel centres over the box plus two texels, clamped
// to +-background beyond a 3-voxel band like a baked grid; D(p') = -shift (so the sphere
// appears moved by `shift`, local frame) with validity 1 over the box and the moved box plus one
// texel.
BoxTextures sphere_textures(const Box& box, const Sphere& sphere, int sdf_resolution,
                            const Vec3& shift = Vec3::Zero()) {
  BoxTextures t;
  t.box = box;
  const Vec3 c = box.to_local(sphere.centre);
  double h = 2.0 * box.half_extents.maxCoeff() / sdf_resolution;
  t.sdf.grid = make_grid_over<float>(box.lower() - Vec3::Constant(2 * h),
                                     box.upper() + Vec3::Constant(2 * h), sdf_resolution + 4);
  t.sdf.band_voxels = 3.0;
  t.sdf.background = static_cast<float>(3.0 * t.sdf.grid.voxel());
  auto& g = t.sdf.grid;
  for (int k = 0; k < g.dims.z(); ++k)
    for (int j = 0; j < g.dims.y(); ++j)
      for (int i = 0; i < g.dims.x(); ++i) {
        double f = sphere.radius - (g.texel_centre(i, j, k) - c).norm();
        g.at(i, j, k) =
            static_cast<float>(std::clamp(f, -1.0 * t.sdf.background, 1.0 * t.sdf.background));
      }
  Vec3 lower = box.lower().cwiseMin(box.lower() + shift),
       upper = box.upper().cwiseMax(box.upper() + shift);
  double hd = 2.0 * box.half_extents.maxCoeff() / 48;
  t.deformation.grid = make_grid_over<Eigen::Vector4f>(
      lower - Vec3::Constant(hd), upper + Vec3::Constant(hd),
      static_cast<int>(std::ceil((upper - lower).maxCoeff() / hd)) + 2,
      Eigen::Vector4f(-shift.x(), -shift.y(), -shift.z(), 1.0f));
  return t;
}

// Smallest t >= 0 with |o + t d - c| = r, if any.
std::optional<double> sphere_hit(const Vec3& o, const Vec3& d, const Vec3& c, double r) {
  Vec3 oc = o - c;
  double b = oc.dot(d), disc = b * b - (oc.squaredNorm() - r * r);
  if (disc < 0) return std::nullopt;
  double s = std::sqrt(disc);
  if (-b - s >= 0) return -b - s;
  if (-b + s >= 0) return -b + s;
  return std::nullopt;
}

// The local-frame parameter range of the deformation grid, as reference_render computes it.
std::pair<double, double> slab(const BoxTextures& t, const Vec3& o, const Vec3& d) {
  double t0 = 0.0, t1 = 1e9;
  Vec3 lo = t.deformation.grid.origin, hi = t.deformation.grid.upper();
  for (int a = 0; a < 3; ++a) {
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return {t0, t1};
}

Camera perspective_camera(const Vec3& target) {
  Camera c;
  c.eye = target + Vec3(1.2, 1.5, 3.6);
  c.target = target;
  c.fov_y_deg = 40.0;
  c.near_plane = 0.1;
  c.far_plane = 100.0;
  return c;
}

Camera orthographic_camera(const Vec3& target) {
  Camera c;
  c.projection = Camera::Projection::Orthographic;
  c.eye = target + Vec3(-2.5, 1.0, 3.0);
  c.target = target;
  c.ortho_height = 2.6;
  c.near_plane = 0.1;
  c.far_plane = 100.0;
  return c;
}

double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * (b - a).cross(c - a).norm();
}

double mesh_area(const Mesh& m) {
  double area = 0.0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    area += triangle_area(m.vertex(f, 0), m.vertex(f, 1), m.vertex(f, 2));
  return area;
}

// ---------------------------------------------------------------------------------------------
// ray_cast_box

const Sphere kUnitSphere{Vec3(0.1, 0.0, -0.05), 1.0};
const Box kAxisBox = make_box(Vec3::Zero(), Vec3::Constant(1.2), Eigen::AngleAxisd::Identity());

// Bound on |t - t_true| for a hit with incidence cosine `cos_incidence` on a sphere of radius r
// sampled at spacing h: half the last bracket of the binary refinement, plus the trilinear
// interpolation error of f = r - |p| (h^2/8 times the sum of its second derivatives, each
// <= 1/|p| ~ 1/r), turned into a distance along the ray by dividing by |d . grad f|, plus the
// float rounding of the stored values.
double hit_tolerance(const BoxTextures& t, const RenderSettings& s, double r,
                     double cos_incidence) {
  double h = t.sdf.grid.voxel();
  double bracket = s.step_voxels * h / std::pow(2.0, s.refine_steps);
  return 0.5 * bracket + (3.0 * h * h / (8.0 * r)) / cos_incidence + 1e-6;
}

TEST(ReferenceRayCast, HitsAnalyticSphere) {
  BoxTextures tex = sphere_textures(kAxisBox, kUnitSphere, 64);
  RenderSettings settings;
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst_ratio = 0.0, worst_normal = 0.0;
  for (int trial = 0; trial < 200; ++trial) {
    Vec3 dir_out = Vec3(u(rng), u(rng), u(rng)).normalized();
    Vec3 o = kUnitSphere.centre + 4.0 * dir_out;
    // Aim within 0.8 r of the centre: incidence cosine >= 0.6.
    Vec3 aim = kUnitSphere.centre + 0.8 * Vec3(u(rng), u(rng), u(rng)) / std::sqrt(3.0);
    Vec3 d = (aim - o).normalized();
    auto [t0, t1] = slab(tex, o, d);
    auto hit = ray_cast_box(tex, o, d, t0, t1, settings);
    auto truth = sphere_hit(o, d, kUnitSphere.centre, kUnitSphere.radius);
    ASSERT_TRUE(truth);
    ASSERT_TRUE(hit) << "trial " << trial;
    Vec3 n_true = (o + *truth * d - kUnitSphere.centre).normalized();
    double cos_incidence = -n_true.dot(d);
    double tol = hit_tolerance(tex, settings, kUnitSphere.radius, cos_incidence);
    EXPECT_NEAR(hit->t, *truth, tol) << "trial " << trial;
    worst_ratio = std::max(worst_ratio, std::abs(hit->t - *truth) / tol);
    EXPECT_NEAR((hit->point - (o + hit->t * d)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(hit->normal.norm(), 1.0, 1e-12);
    // Central differences at step h of the trilinear interpolant average two cells' slopes:
    // for f = r - |p| the gradient is off by O(h^2 |f'''|) = O(h^2 / r^2).
    double angle = std::acos(std::clamp(hit->normal.dot(n_true), -1.0, 1.0));
    double h_over_r = tex.sdf.grid.voxel() / kUnitSphere.radius;
    EXPECT_LT(angle, h_over_r * h_over_r) << "trial " << trial;
    worst_normal = std::max(worst_normal, angle);
  }
  RecordProperty("worst_error_over_tolerance", std::to_string(worst_ratio));
  RecordProperty("worst_normal_angle_rad", std::to_string(worst_normal));
}

TEST(ReferenceRayCast, ConstantInverseDisplacementMovesTheSphere) {
  const Vec3 shift(0.3, -0.2, 0.1);  // local frame; F(p) = p + shift, D = -shift
  const Box box = make_box(Vec3(0.2, 0.1, 0), Vec3(1.2, 1.3, 1.25),
                           Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized()));
  BoxTextures tex = sphere_textures(box, kUnitSphere, 64, shift);
  RenderSettings settings;
  const Vec3 moved = box.to_local(kUnitSphere.centre) + shift;  // local frame
  std::mt19937 rng(777);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 100; ++trial) {
    Vec3 o = moved + 4.0 * Vec3(u(rng), u(rng), u(rng)).normalized();
    Vec3 aim = moved + 0.8 * Vec3(u(rng), u(rng), u(rng)) / std::sqrt(3.0);
    Vec3 d = (aim - o).normalized();
    auto [t0, t1] = slab(tex, o, d);
    auto hit = ray_cast_box(tex, o, d, t0, t1, settings);
    auto truth = sphere_hit(o, d, moved, kUnitSphere.radius);
    ASSERT_TRUE(hit && truth) << "trial " << trial;
    double cos_incidence = -(o + *truth * d - moved).normalized().dot(d);
    double tolerance = hit_tolerance(tex, settings, kUnitSphere.radius, cos_incidence);
    // The sphere pokes out of the box: a hit just before a box face plane (crossed by the ray in
    // the deformed space) may be kSeamVoxels from the surface.
    bool on_face =
        ((box.half_extents - hit->point.cwiseAbs()).array().abs() < tex.sdf.grid.voxel()).any();
    if (on_face) tolerance += kSeamVoxels * tex.sdf.grid.voxel() / cos_incidence;
    EXPECT_NEAR(hit->t, *truth, tolerance) << "trial " << trial;
  }
}

TEST(ReferenceRayCast, MissesInvalidTexelsAndPassingRays) {
  BoxTextures tex = sphere_textures(kAxisBox, kUnitSphere, 32);
  RenderSettings settings;
  const Vec3 o(-3.0, 0.0, -0.05), d(1, 0, 0);
  auto [t0, t1] = slab(tex, o, d);
  ASSERT_TRUE(ray_cast_box(tex, o, d, t0, t1, settings));
  // A ray passing the sphere at 1.1 r.
  const Vec3 o_pass(-3.0, 1.1, -0.05);
  auto [p0, p1] = slab(tex, o_pass, d);
  EXPECT_FALSE(ray_cast_box(tex, o_pass, d, p0, p1, settings));
  // No texel valid: nothing has a preimage in the box.
  BoxTextures invalid = tex;
  for (auto& texel : invalid.deformation.grid.data) texel.w() = 0.0f;
  EXPECT_FALSE(ray_cast_box(invalid, o, d, t0, t1, settings));
  // An empty range.
  EXPECT_FALSE(ray_cast_box(tex, o, d, t1, t0, settings));
}

TEST(ReferenceRayCast, StartInsideHitsAtStartAndStepsAreBounded) {
  BoxTextures tex = sphere_textures(kAxisBox, kUnitSphere, 32);
  RenderSettings settings;
  const Vec3 d = Vec3(1, 1, 0).normalized();
  auto inside = ray_cast_box(tex, kUnitSphere.centre, d, 0.0, 2.0, settings);
  ASSERT_TRUE(inside);
  EXPECT_EQ(inside->t, 0.0);
  // Two steps of half a voxel cannot reach a sphere 2 units away (without skipping, which
  // would jump up to the narrow band's width).
  settings.max_steps = 2;
  settings.skipping = false;
  settings.sampling = Sampling::Linear;
  settings.step_voxels = kFineStepVoxels;
  const Vec3 o(-3.0, 0.0, -0.05);
  auto [t0, t1] = slab(tex, o, Vec3(1, 0, 0));
  EXPECT_FALSE(ray_cast_box(tex, o, Vec3(1, 0, 0), t0, t1, settings));
}

// ---------------------------------------------------------------------------------------------
// rasterize against reference_render: with D = 0 the ray cast shows the undeformed sphere, so
// both renders see the same surface (the icosphere is inscribed, within its sagitta
// ~ edge^2 / 6r = 2e-4 r at level 5).

struct RenderCase {
  const char* name;
  Camera camera;
};

// `seam`: the box cuts the mesh, and a few pixels along the cut see through it in both the
// shader and reference_render: where the mesh point lies just inside the box (so the raster
// pass culls it) while the sphere's chord inside the box is shorter than one step, the linear
// search misses it. There only the fraction of such pixels is bounded.
void expect_same_render(const Image& raster, const Image& reference, double diameter,
                        const char* name, bool seam) {
  ImageComparison c = compare_images(raster, reference, 0.01 * diameter);
  const std::string key = std::string(name) + "_";
  ::testing::Test::RecordProperty(key + "iou", std::to_string(c.iou));
  ::testing::Test::RecordProperty(key + "mean_depth_error", std::to_string(c.mean_depth_error));
  ::testing::Test::RecordProperty(key + "max_depth_error", std::to_string(c.max_depth_error));
  ::testing::Test::RecordProperty(key + "fraction_over", std::to_string(c.fraction_over));
  // The silhouettes differ only where a pixel centre falls between the polygon and the sphere.
  EXPECT_GE(c.iou, 0.99) << name;
  EXPECT_GT(c.common, 2000) << name;
  // Depth: grazing rays on the rim magnify the icosphere's sagitta s ~ 1.8e-4 r (level 5) to at
  // most sqrt(2 r s) ~ 0.019 r, under 1% of the diameter; elsewhere the error is ~ s.
  // With a seam, a sample just before a box face within kSeamVoxels of the surface counts as a
  // hit (it closes the crack between the passes): along the cut that moves the hit by up to
  // one voxel / cos(incidence), over 1 % of the diameter on this coarse grid. Those pixels lie
  // on one line of the image: 2 % bounds them.
  EXPECT_LT(c.fraction_over, seam ? 0.02 : 0.01) << name;
  if (seam) return;
  EXPECT_LT(c.mean_depth_error, 0.001 * diameter) << name;
  EXPECT_LT(c.max_depth_error, 0.01 * diameter) << name;
}

TEST(RasterVsReference, SphereInsideBoxIdentityDeformation) {
  const Sphere sphere{Vec3(0.1, -0.2, 0.05), 1.0};
  const Mesh mesh = fixtures::icosphere(sphere.radius, 5, sphere.centre);
  const Box box = make_box(Vec3(0.05, -0.1, 0.0), Vec3(1.3, 1.2, 1.25),
                           Eigen::AngleAxisd(0.5, Vec3(0.3, 1, -0.2).normalized()));
  for (int c = 0; c < mesh.V.rows(); ++c) ASSERT_TRUE(box.contains(mesh.V.row(c).transpose()));
  const std::vector<BoxTextures> boxes = {sphere_textures(box, sphere, 64)};
  RenderSettings settings;
  for (const RenderCase& rc : {RenderCase{"perspective", perspective_camera(sphere.centre)},
                               RenderCase{"orthographic", orthographic_camera(sphere.centre)}}) {
    Image raster = rasterize(mesh, rc.camera, 96, 80, settings);
    Image reference = reference_render(mesh, boxes, rc.camera, 96, 80, settings);
    expect_same_render(raster, reference, 2.0 * sphere.radius, rc.name, false);
    // Background and alpha.
    for (int ch = 0; ch < 4; ++ch) EXPECT_EQ(reference.rgba[ch], 255) << rc.name;
    EXPECT_FALSE(reference.covered(0, 0));
  }
}

// Half the sphere in the box: reference_render composites the mesh outside the box with the
// ray cast inside; with D = 0 the result is the whole sphere again.
TEST(RasterVsReference, HalfInBoxCompositesToWholeSphere) {
  const Sphere sphere{Vec3(0.0, 0.0, 0.0), 1.0};
  const Mesh mesh = fixtures::icosphere(sphere.radius, 5, sphere.centre);
  const Box box =
      make_box(Vec3(0.0, 0.6, 0.0), Vec3(1.3, 0.7, 1.3), Eigen::AngleAxisd(0.3, Vec3(0, 0, 1)));
  const std::vector<BoxTextures> boxes = {sphere_textures(box, sphere, 64)};
  RenderSettings settings;
  const Camera camera = perspective_camera(sphere.centre);
  Image raster = rasterize(mesh, camera, 96, 80, settings);
  Image reference = reference_render(mesh, boxes, camera, 96, 80, settings);
  expect_same_render(raster, reference, 2.0 * sphere.radius, "half_in_box", true);
  // Without the ray cast the box part is missing.
  BoxTextures empty = boxes[0];
  for (auto& texel : empty.deformation.grid.data) texel.w() = 0.0f;
  Image culled = reference_render(mesh, {empty}, camera, 96, 80, settings);
  EXPECT_LT(compare_images(raster, culled, 0.02).iou, 0.9);
}

TEST(RasterVsReference, RasterDepthIsExactOnAPlane) {
  // Two triangles spanning the square [-1, 1]^2 at z = 0, seen obliquely: depth is linear in
  // the object position, so perspective-correct interpolation is exact up to rounding.
  Mesh quad;
  quad.V.resize(4, 3);
  quad.V << -1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0;
  quad.F.resize(2, 3);
  quad.F << 0, 1, 2, 0, 2, 3;
  Camera camera = perspective_camera(Vec3::Zero());
  const int w = 64, h = 48;
  Image im = rasterize(quad, camera, w, h, RenderSettings{});
  long covered = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      Ray ray = camera.pixel_ray(x, y, w, h);
      double t = -ray.origin.z() / ray.direction.z();
      Vec3 p = ray.origin + t * ray.direction;
      bool inside = std::abs(p.x()) < 1.0 - 1e-9 && std::abs(p.y()) < 1.0 - 1e-9;
      bool outside = std::abs(p.x()) > 1.0 + 1e-9 || std::abs(p.y()) > 1.0 + 1e-9;
      if (inside) {
        ASSERT_TRUE(im.covered(x, y)) << x << ", " << y;
        EXPECT_NEAR(im.depth_at(x, y), camera.depth_of(p), 1e-5 * camera.depth_of(p));
        ++covered;
      } else if (outside) {
        EXPECT_FALSE(im.covered(x, y)) << x << ", " << y;
      }
    }
  EXPECT_GT(covered, 200);
}

TEST(RasterVsReference, NearPlaneClipsTrianglesThroughTheEye) {
  // A large floor under an eye looking along it: the triangles cross the near plane and
  // behind the eye; the clipped part must still cover the lower half of the image.
  Mesh floor;
  floor.V.resize(4, 3);
  floor.V << -50, -1, -50, 50, -1, -50, 50, -1, 50, -50, -1, 50;
  floor.F.resize(2, 3);
  floor.F << 0, 2, 1, 0, 3, 2;
  Camera camera;
  camera.eye = Vec3(0, 0, 0);
  camera.target = Vec3(0, 0, -1);
  camera.near_plane = 0.1;
  camera.far_plane = 1000.0;
  const int w = 32, h = 32;
  Image im = rasterize(floor, camera, w, h, RenderSettings{});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      Ray ray = camera.pixel_ray(x, y, w, h);
      double t = ray.direction.y() < 0 ? -1.0 / ray.direction.y() : -1.0;
      bool hit = t >= ray.t_min && std::abs(ray.direction.x() * t) < 50 &&
                 std::abs(ray.direction.z() * t) < 50;
      EXPECT_EQ(im.covered(x, y), hit) << x << ", " << y;
      if (hit && im.covered(x, y)) {
        EXPECT_NEAR(im.depth_at(x, y), camera.depth_of(ray.origin + t * ray.direction), 1e-3);
      }
    }
}

// ---------------------------------------------------------------------------------------------
// ground_truth_mesh

// Every triangle of `out` lies in the box or wholly beyond one of its face planes.
void expect_no_straddling(const Mesh& out, const Box& box, double tol) {
  for (Eigen::Index f = 0; f < out.F.rows(); ++f) {
    Vec3 q[3];
    for (int c = 0; c < 3; ++c) q[c] = box.to_local(out.vertex(f, c));
    bool inside = true, beyond = false;
    for (int a = 0; a < 3; ++a) {
      double h = box.half_extents[a];
      for (int c = 0; c < 3; ++c) inside = inside && std::abs(q[c][a]) <= h + tol;
      beyond = beyond || (q[0][a] >= h - tol && q[1][a] >= h - tol && q[2][a] >= h - tol) ||
               (q[0][a] <= -h + tol && q[1][a] <= -h + tol && q[2][a] <= -h + tol);
    }
    EXPECT_TRUE(inside || beyond) << "face " << f;
  }
}

TEST(ReferenceGroundTruth, SplitKeepsAreaAndOrientationAndNoPieceStraddles) {
  const Box box = make_box(Vec3(0.1, -0.2, 0.3), Vec3(0.5, 0.7, 0.4),
                           Eigen::AngleAxisd(0.7, Vec3(1, -1, 2).normalized()));
  auto identity = [](const Vec3& q) { return q; };
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int trial = 0; trial < 300; ++trial) {
    Mesh tri;
    tri.V.resize(3, 3);
    for (int c = 0; c < 3; ++c)
      tri.V.row(c) = (box.centre + Vec3(u(rng), u(rng), u(rng))).transpose();
    tri.F.resize(1, 3);
    tri.F << 0, 1, 2;
    const Vec3 normal =
        (tri.vertex(0, 1) - tri.vertex(0, 0)).cross(tri.vertex(0, 2) - tri.vertex(0, 0));
    // No subdivision, then subdivision to edges of 0.1.
    for (double max_edge : {1e9, 0.1}) {
      Mesh out = ground_truth_mesh(tri, box, identity, max_edge);
      ASSERT_GE(out.F.rows(), 1);
      EXPECT_NEAR(mesh_area(out), mesh_area(tri), 1e-12 * (1.0 + mesh_area(tri))) << trial;
      expect_no_straddling(out, box, 1e-12);
      for (Eigen::Index f = 0; f < out.F.rows(); ++f) {
        Vec3 a = out.vertex(f, 0), b = out.vertex(f, 1), c = out.vertex(f, 2);
        Vec3 n = (b - a).cross(c - a);
        if (n.norm() > 1e-9 * normal.norm()) {
          EXPECT_GT(n.dot(normal), 0.0) << trial;
        }
        bool in_box = box.contains(a) && box.contains(b) && box.contains(c);
        if (max_edge < 1.0 && in_box) {
          double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
          EXPECT_LE(longest, max_edge * (1.0 + 1e-9)) << trial;
        }
      }
    }
  }
}

TEST(ReferenceGroundTruth, TrianglesClearOfTheBoxAreKeptAsTheyAre) {
  const Box box = make_box(Vec3::Zero(), Vec3::Ones(), Eigen::AngleAxisd::Identity());
  Mesh tri;
  tri.V.resize(3, 3);
  tri.V << 2, 0, 0, 3, 0, 0, 2, 5, 0;  // x > 1 everywhere though it spans y
  tri.F.resize(1, 3);
  tri.F << 0, 1, 2;
  Mesh out = ground_truth_mesh(
      tri, box, [](const Vec3& q) { return Vec3(q + Vec3(9, 9, 9)); }, 0.01);
  ASSERT_EQ(out.F.rows(), 1);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(out.vertex(0, c), tri.vertex(0, c));
  EXPECT_THROW(ground_truth_mesh(
                   tri, box, [](const Vec3& q) { return q; }, 0.0),
               Error);
}

// Identity F: the split and subdivided mesh renders as the original, pixel for pixel and to
// rounding in depth (every piece lies in its source triangle's plane).
TEST(ReferenceGroundTruth, IdentityReproducesTheRender) {
  const Mesh mesh = fixtures::icosphere(1.0, 3, Vec3::Zero());
  const Box box = make_box(Vec3(0.3, 0.2, -0.1), Vec3(0.6, 0.5, 0.7),
                           Eigen::AngleAxisd(0.6, Vec3(2, 1, 1).normalized()));
  Mesh truth = ground_truth_mesh(
      mesh, box, [](const Vec3& q) { return q; }, 0.05);
  EXPECT_GT(truth.F.rows(), 2 * mesh.F.rows());
  EXPECT_NEAR(mesh_area(truth), mesh_area(mesh), 1e-9 * mesh_area(mesh));
  for (const Camera& camera :
       {perspective_camera(Vec3::Zero()), orthographic_camera(Vec3::Zero())}) {
    Image a = rasterize(mesh, camera, 128, 128, RenderSettings{});
    Image b = rasterize(truth, camera, 128, 128, RenderSettings{});
    ImageComparison c = compare_images(a, b, 1e-5);
    EXPECT_GT(c.iou, 0.995);
    EXPECT_LT(c.fraction_over, 0.002);
    EXPECT_LT(c.mean_depth_error, 1e-4);
  }
}

// A translation F inside a box that holds the whole sphere moves the whole sphere.
TEST(ReferenceGroundTruth, TranslationMovesTheSilhouette) {
  const Mesh mesh = fixtures::icosphere(1.0, 3, Vec3::Zero());
  const Box box = make_box(Vec3(0.05, 0, 0), Vec3(1.2, 1.1, 1.3),
                           Eigen::AngleAxisd(0.8, Vec3(0, 1, 1).normalized()));
  const Vec3 shift_local(0.4, -0.1, 0.2);
  Mesh truth = ground_truth_mesh(
      mesh, box, [&](const Vec3& q) { return Vec3(q + shift_local); }, 0.2);
  Mesh moved = mesh;
  moved.V.rowwise() += box.direction_to_object(shift_local).transpose();
  const Camera camera = orthographic_camera(Vec3::Zero());
  Image original = rasterize(mesh, camera, 128, 128, RenderSettings{});
  Image expected = rasterize(moved, camera, 128, 128, RenderSettings{});
  Image actual = rasterize(truth, camera, 128, 128, RenderSettings{});
  ImageComparison c = compare_images(expected, actual, 1e-5);
  EXPECT_GT(c.iou, 0.995);
  EXPECT_LT(c.fraction_over, 0.002);
  EXPECT_LT(compare_images(original, actual, 1e-5).iou, 0.9);
}

}  // namespace
}  // namespace raywarp
