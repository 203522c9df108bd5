// Ray casting a tetrahedral mesh by walking its tetrahedra (Tejada & Ertl 2005, section 5): the
// topology and geometry (library/tet_mesh.h) and the CPU walk (verify/tet_walk.h) on Kuhn
// lattices, against analytic intersections, closed-form opacities and the CPU rasteriser.
#include "verify/tet_walk.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <utility>

#include "base/error.h"
#include "library/tet_mesh.h"
#include "library/triangle_bvh.h"
#include "physics/models.h"
#include "tests/surface_mapping_fixtures.h"
#include "verify/reference.h"

namespace raywarp {
namespace {

using Vec3 = Eigen::Vector3d;
using Box3 = Eigen::AlignedBox3d;
constexpr double kInf = std::numeric_limits<double>::infinity();

Vec3 random_direction(std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Vec3 d(g(rng), g(rng), g(rng));
  return d.normalized();
}

// A ray from a point on a sphere of `radius` around `centre` towards a random point of `aim`.
std::pair<Vec3, Vec3> random_ray(std::mt19937& rng, const Vec3& centre, double radius,
                                 const Box3& aim) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Vec3 o = centre + radius * random_direction(rng);
  const Vec3 target = aim.min() + Vec3(u(rng), u(rng), u(rng)).cwiseProduct(aim.sizes());
  return {o, (target - o).normalized()};
}

// The parameters where the ray lies in the union of boxes, as merged intervals.
std::vector<std::pair<double, double>> union_intervals(const Vec3& o, const Vec3& d,
                                                       const std::vector<Box3>& boxes) {
  std::vector<std::pair<double, double>> in;
  for (const Box3& b : boxes) {
    double t0 = 0.0, t1 = kInf;
    if (clip_ray_to_box(o, d, b.min(), b.max(), t0, t1)) in.push_back({t0, t1});
  }
  std::sort(in.begin(), in.end());
  std::vector<std::pair<double, double>> out;
  for (const auto& i : in) {
    if (!out.empty() && i.first <= out.back().second + 1e-9)
      out.back().second = std::max(out.back().second, i.second);
    else
      out.push_back(i);
  }
  return out;
}

// A U of 5 x 3 x 2 unit cubes: a bar along x at y in [0, 1], and two arms up to y = 3 at x in
// [0, 2] and [3, 5].
fixtures::TetBody u_body() {
  return fixtures::kuhn_body({5, 3, 2}, Vec3::Zero(), 1.0,
                             [](int i, int j, int) { return j == 0 || i != 2; });
}
std::vector<Box3> u_boxes() {
  return {Box3(Vec3(0, 0, 0), Vec3(5, 1, 2)), Box3(Vec3(0, 1, 0), Vec3(2, 3, 2)),
          Box3(Vec3(3, 1, 0), Vec3(5, 3, 2))};
}

double interpolated(const TetWalkMesh& mesh, int tet, const Vec3& x) {
  const auto& v = mesh.tets()[tet];
  const auto& p = mesh.positions();
  const Eigen::Vector4d w = tet_barycentric(x, p[v[0]], p[v[1]], p[v[2]], p[v[3]]);
  double f = 0.0;
  for (int k = 0; k < 4; ++k) f += w[k] * mesh.scalar()[v[k]];
  return f;
}

TEST(TetWalk, TopologyOfAKuhnBox) {
  for (const Eigen::Vector3i& n : {Eigen::Vector3i(1, 1, 1), Eigen::Vector3i(3, 4, 5)}) {
    const physics::TetMesh box = physics::bar(n.x(), n.y(), n.z(), 0.5);
    const TetTopology topo = tet_topology(box.tets, static_cast<int>(box.nodes.size()));
    const int tets = topo.tet_count();
    EXPECT_EQ(tets, 6 * n.prod());
    // 2 triangles a boundary square, 2 (nx ny + ny nz + nx nz) squares.
    EXPECT_EQ(static_cast<int>(topo.boundary.size()),
              2 * 2 * (n.x() * n.y() + n.y() * n.z() + n.x() * n.z()));
    int interior = 0;
    for (int t = 0; t < tets; ++t)
      for (int k = 0; k < 4; ++k) {
        const int m = topo.neighbour[t][k];
        if (m < 0) continue;
        ++interior;
        const int f = topo.neighbour_face[t][k];
        ASSERT_EQ(topo.neighbour[m][f], t);
        ASSERT_EQ(topo.neighbour_face[m][f], k);
        std::array<int, 3> a, b;
        for (int c = 0; c < 3; ++c) {
          a[c] = box.tets[t][kTetFaceVertices[k][c]];
          b[c] = box.tets[m][kTetFaceVertices[f][c]];
        }
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        ASSERT_EQ(a, b);
      }
    EXPECT_EQ(interior + static_cast<int>(topo.boundary.size()), 4 * tets);
    // Every boundary face lies on the box's surface, its outward normal along the box's face.
    const TetGeometry geo = tet_geometry(topo, box.tets, box.nodes, {});
    EXPECT_EQ(geo.inverted, 0);
    EXPECT_EQ(geo.degenerate, 0);
    const Vec3 hi = 0.5 * n.cast<double>();
    for (const TetFace& b : topo.boundary) {
      const Vec3& normal = geo.normal[b.tet][b.face];
      Vec3 centroid = Vec3::Zero();
      for (int c = 0; c < 3; ++c)
        centroid += box.nodes[box.tets[b.tet][kTetFaceVertices[b.face][c]]] / 3;
      int axis;
      normal.cwiseAbs().maxCoeff(&axis);
      ASSERT_NEAR(std::abs(normal[axis]), 1.0, 1e-15);
      const double plane = normal[axis] > 0 ? hi[axis] : 0.0;
      ASSERT_NEAR(centroid[axis], plane, 1e-15);
    }
    std::printf(
        "[figures] Kuhn box %d x %d x %d: %d tets, %zu boundary faces, %d interior face "
        "pairs\n",
        n.x(), n.y(), n.z(), tets, topo.boundary.size(), interior / 2);
  }
  // The boundary as a mesh: closed, outward (positive enclosed volume).
  const physics::TetMesh box = physics::bar(3, 4, 5, 0.5);
  const TetTopology topo = tet_topology(box.tets, static_cast<int>(box.nodes.size()));
  const Mesh surface = tet_boundary_mesh(topo, box.tets, box.nodes);
  EXPECT_TRUE(mesh_stats(surface).closed());
  EXPECT_NEAR(signed_volume(surface), 1.5 * 2.0 * 2.5, 1e-12);
}

TEST(TetWalk, GradientsAreExactForALinearScalar) {
  const physics::TetMesh box = physics::bar(4, 3, 5, 0.3);
  const TetTopology topo = tet_topology(box.tets, static_cast<int>(box.nodes.size()));
  // A deformed state: a non-affine map (so every tetrahedron differs), mildly.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.04, 0.04);
  std::vector<Vec3> moved;
  for (const Vec3& p : box.nodes)
    moved.push_back(Vec3(p.x() + 0.1 * std::sin(p.z()), p.y() + 0.2 * p.x() * p.z(), 1.3 * p.z()) +
                    Vec3(jitter(rng), jitter(rng), jitter(rng)));
  const Vec3 a(0.7, -1.9, 2.6);
  const double b = 3.25;
  std::vector<double> s;
  for (const Vec3& p : moved) s.push_back(a.dot(p) + b);
  const TetGeometry geo = tet_geometry(topo, box.tets, moved, s);
  EXPECT_EQ(geo.inverted, 0);
  EXPECT_EQ(geo.degenerate, 0);
  double worst_g = 0.0, worst_b = 0.0, worst_unit = 0.0, volume = 0.0;
  for (int t = 0; t < topo.tet_count(); ++t) {
    worst_g = std::max(worst_g, (geo.gradient[t] - a).norm() / a.norm());
    worst_b = std::max(worst_b, std::abs(geo.gradient_offset[t] - b));
    volume += geo.volume[t];
    for (int k = 0; k < 4; ++k) {
      const Vec3& n = geo.normal[t][k];
      worst_unit = std::max(worst_unit, std::abs(n.norm() - 1.0));
      const Vec3& vk = moved[box.tets[t][k]];
      // Outward: vertex k lies on the inner side of face k.
      ASSERT_LT(n.dot(vk), geo.offset[t][k]);
      for (int c = 0; c < 3; ++c)
        ASSERT_NEAR(n.dot(moved[box.tets[t][kTetFaceVertices[k][c]]]), geo.offset[t][k], 1e-14);
    }
  }
  // The boundary mesh's enclosed volume equals the tetrahedra's total.
  EXPECT_NEAR(volume, signed_volume(tet_boundary_mesh(topo, box.tets, moved)), 1e-12);
  std::printf(
      "[figures] linear scalar on %d deformed tets: gradient relative error %.2e, "
      "offset error %.2e, |n| - 1 %.2e\n",
      topo.tet_count(), worst_g, worst_b, worst_unit);
  EXPECT_LT(worst_g, 1e-12);
  EXPECT_LT(worst_b, 1e-12);

  // Mirrored, every tetrahedron is inverted; a collapsed node makes its tetrahedra degenerate.
  std::vector<Vec3> mirrored = box.nodes;
  for (Vec3& p : mirrored) p.x() = -p.x();
  EXPECT_EQ(tet_geometry(topo, box.tets, mirrored, {}).inverted, topo.tet_count());
  std::vector<Vec3> collapsed = box.nodes;
  const auto& t0 = box.tets[0];
  collapsed[t0[1]] = collapsed[t0[0]];
  const TetGeometry flat = tet_geometry(topo, box.tets, collapsed, {});
  int sharing = 0;
  for (const auto& t : box.tets)
    sharing += (std::count(t.begin(), t.end(), t0[0]) && std::count(t.begin(), t.end(), t0[1]));
  // Those with both nodes, and perhaps others made flat by the move.
  EXPECT_GE(flat.degenerate, sharing);
  for (size_t t = 0; t < box.tets.size(); ++t)
    if (std::count(box.tets[t].begin(), box.tets[t].end(), t0[0]) &&
        std::count(box.tets[t].begin(), box.tets[t].end(), t0[1])) {
      EXPECT_TRUE(flat.flag[t] & kTetDegenerate);
    }
}

TEST(TetWalk, ConvexBoxIsOneSectionAtTheSlabDistances) {
  const physics::TetMesh box = physics::bar(3, 4, 5, 1.0);
  const TetWalkMesh mesh(box.tets, box.nodes, {});
  const Box3 bounds(Vec3::Zero(), Vec3(3, 4, 5));
  std::mt19937 rng(17);
  double worst = 0.0, worst_chain = 0.0;
  long steps = 0, max_steps = 0;
  int rays = 0;
  for (int q = 0; q < 400; ++q) {
    const auto [o, d] = random_ray(rng, bounds.center(), 12.0, bounds);
    double t0 = 0.0, t1 = kInf;
    ASSERT_TRUE(clip_ray_to_box(o, d, bounds.min(), bounds.max(), t0, t1));
    double previous = -1.0, length = 0.0;
    const TetWalkResult walk = walk_ray(mesh, o, d, 0.0, kInf, [&](const TetSegment& s) {
      if (previous >= 0.0) worst_chain = std::max(worst_chain, std::abs(s.t_in - previous));
      previous = s.t_out;
      length += s.t_out - s.t_in;
      return true;
    });
    ASSERT_EQ(walk.sections, 1);
    ASSERT_FALSE(walk.capped);
    EXPECT_EQ(walk.lost, 0);
    worst = std::max({worst, std::abs(walk.section_list[0].t_in - t0),
                      std::abs(walk.section_list[0].t_out - t1), std::abs(length - (t1 - t0))});
    steps += walk.steps;
    max_steps = std::max(max_steps, walk.steps);
    ++rays;
  }
  // A ray that misses, and one that starts inside (no front face ahead: no section).
  EXPECT_EQ(walk_ray(mesh, Vec3(-1, -1, -1), Vec3(-1, 0, 0), 0.0, kInf,
                     [](const TetSegment&) { return true; })
                .sections,
            0);
  EXPECT_EQ(walk_ray(mesh, Vec3(1.5, 2, 2.5), Vec3(0, 0, 1), 0.0, kInf,
                     [](const TetSegment&) { return true; })
                .sections,
            0);
  std::printf(
      "[figures] convex 3 x 4 x 5 box (%d tets): %d rays, one section each, entry/exit "
      "against the slab method %.2e, segment chaining %.2e, steps mean %.1f max %ld "
      "(cap %ld)\n",
      mesh.tet_count(), rays, worst, worst_chain, double(steps) / rays, max_steps, mesh.step_cap());
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(worst_chain, 0.0);
}

TEST(TetWalk, NonConvexBodyIsWalkedInSections) {
  const fixtures::TetBody u = u_body();
  const TetWalkMesh mesh(u.tets, u.nodes, {});
  // Along x through both arms: in at 0, out at 2, in at 3, out at 5.
  const TetWalkResult across = walk_ray(mesh, Vec3(-2, 2.3, 0.7), Vec3(1, 0, 0), 0.0, kInf,
                                        [](const TetSegment&) { return true; });
  ASSERT_EQ(across.sections, 2);
  EXPECT_NEAR(across.section_list[0].t_in, 2.0, 1e-12);
  EXPECT_NEAR(across.section_list[0].t_out, 4.0, 1e-12);
  EXPECT_NEAR(across.section_list[1].t_in, 5.0, 1e-12);
  EXPECT_NEAR(across.section_list[1].t_out, 7.0, 1e-12);
  // Through the bar: one section.
  EXPECT_EQ(walk_ray(mesh, Vec3(-2, 0.4, 0.7), Vec3(1, 0, 0), 0.0, kInf,
                     [](const TetSegment&) { return true; })
                .sections,
            1);
  // Random rays: the sections are the merged intervals of the three boxes.
  const std::vector<Box3> boxes = u_boxes();
  std::mt19937 rng(23);
  std::vector<int> histogram(4, 0);
  double worst = 0.0;
  for (int q = 0; q < 2000; ++q) {
    const auto [o, d] =
        random_ray(rng, Vec3(2.5, 1.5, 1.0), 10.0, Box3(Vec3(0, 0, 0), Vec3(5, 3, 2)));
    const auto expected = union_intervals(o, d, boxes);
    const TetWalkResult walk =
        walk_ray(mesh, o, d, 0.0, kInf, [](const TetSegment&) { return true; });
    ASSERT_FALSE(walk.capped);
    ASSERT_EQ(walk.lost, 0);
    ASSERT_EQ(walk.sections, static_cast<int>(expected.size())) << "ray " << q;
    for (size_t i = 0; i < expected.size(); ++i)
      worst = std::max({worst, std::abs(walk.section_list[i].t_in - expected[i].first),
                        std::abs(walk.section_list[i].t_out - expected[i].second)});
    ++histogram[std::min(3, walk.sections)];
  }
  std::printf(
      "[figures] U of 5 x 3 x 2 cubes (%d tets): 2000 random rays, sections 0/1/2: "
      "%d/%d/%d, entry/exit against the boxes' intervals %.2e\n",
      mesh.tet_count(), histogram[0], histogram[1], histogram[2], worst);
  EXPECT_GT(histogram[2], 50);
  EXPECT_EQ(histogram[3], 0);
  EXPECT_LT(worst, 1e-12);

  // Two separate blocks, four times along one ray: 4 sections.
  const fixtures::TetBody blocks =
      fixtures::kuhn_body({7, 1, 1}, Vec3::Zero(), 1.0, [](int i, int, int) { return i % 2 == 0; });
  const TetWalkMesh apart(blocks.tets, blocks.nodes, {});
  const TetWalkResult four = walk_ray(apart, Vec3(-1, 0.5, 0.5), Vec3(1, 0, 0), 0.0, kInf,
                                      [](const TetSegment&) { return true; });
  ASSERT_EQ(four.sections, 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(four.section_list[i].t_in, 1.0 + 2 * i, 1e-12);
    EXPECT_NEAR(four.section_list[i].t_out, 2.0 + 2 * i, 1e-12);
  }
}

TEST(TetWalk, SurfaceModeFindsThePlane) {
  const physics::TetMesh box = physics::bar(4, 4, 4, 0.5);
  const Vec3 a = Vec3(0.3, -0.5, 0.8).normalized();
  const double b = -a.dot(Vec3(1.0, 1.1, 0.9));  // the plane through (1, 1.1, 0.9)
  std::vector<double> f;
  for (const Vec3& p : box.nodes) f.push_back(a.dot(p) + b);
  const TetWalkMesh mesh(box.tets, box.nodes, f);
  const Box3 bounds(Vec3::Zero(), Vec3(2, 2, 2));
  std::mt19937 rng(29);
  double worst_t = 0.0, worst_f = 0.0, worst_n = 0.0;
  int hits = 0;
  SurfaceOptions options;
  options.hit_where_entering_inside = false;
  for (int q = 0; q < 500; ++q) {
    const auto [o, d] = random_ray(rng, bounds.center(), 8.0, bounds);
    double t0 = 0.0, t1 = kInf;
    ASSERT_TRUE(clip_ray_to_box(o, d, bounds.min(), bounds.max(), t0, t1));
    // Analytic: the first t in [t0, t1] where a · x + b crosses from <= 0 to > 0.
    const double f0 = a.dot(o + t0 * d) + b;
    const double t_plane = -(a.dot(o) + b) / a.dot(d);
    const bool expect_hit = f0 <= 0.0 && a.dot(d) > 0.0 && t_plane <= t1;
    const auto hit = surface_hit(mesh, o, d, 0.0, kInf, options);
    ASSERT_EQ(hit.has_value(), expect_hit) << "ray " << q;
    if (!hit) continue;
    ++hits;
    worst_t = std::max(worst_t, std::abs(hit->t - t_plane));
    worst_f = std::max(worst_f, std::abs(interpolated(mesh, hit->tet, hit->point)));
    worst_n = std::max(worst_n, (hit->normal + a).norm());
  }
  std::printf(
      "[figures] plane: %d hits of 500 rays, t against the analytic plane %.2e, f at the "
      "hit %.2e, normal %.2e\n",
      hits, worst_t, worst_f, worst_n);
  EXPECT_GT(hits, 100);
  EXPECT_LT(worst_t, 1e-12);
  EXPECT_LT(worst_f, 1e-12);
  EXPECT_LT(worst_n, 1e-12);
}

TEST(TetWalk, SurfaceModeFindsTheSphereShell) {
  // f = R - |x - c| on the nodes of a 16³ lattice over [-1, 1]³: f is concave, so its linear
  // interpolant is below it and the piecewise-linear surface lies within the sphere, at most
  // h² / (2 (R - h)) inside it (h the longest tetrahedron edge, the cube's diagonal).
  const double side = 0.125, radius = 0.7;
  const fixtures::TetBody body = fixtures::kuhn_box(16, 16, 16, side, Vec3(-1, -1, -1));
  std::vector<double> f;
  for (const Vec3& p : body.nodes) f.push_back(radius - p.norm());
  const TetWalkMesh mesh(body.tets, body.nodes, f);
  const double h = side * std::sqrt(3.0);
  const double shell = h * h / (2.0 * (radius - h));
  std::mt19937 rng(31);
  double worst_f = 0.0, r_min = kInf, r_max = 0.0, worst_normal = 0.0;
  int hits = 0, misses = 0;
  for (int q = 0; q < 600; ++q) {
    const auto [o, d] =
        random_ray(rng, Vec3::Zero(), 5.0, Box3(Vec3(-0.6, -0.6, -0.6), Vec3(0.6, 0.6, 0.6)));
    const auto hit = surface_hit(mesh, o, d, 0.0, kInf);
    // The analytic sphere: hit when the ray passes within R - shell of the centre.
    const double miss_distance = (o - o.dot(d) * d).norm();
    if (!hit) {
      ++misses;
      EXPECT_GT(miss_distance, radius - shell);
      continue;
    }
    ++hits;
    EXPECT_FALSE(hit->at_entry);
    worst_f = std::max(worst_f, std::abs(interpolated(mesh, hit->tet, hit->point)));
    r_min = std::min(r_min, hit->point.norm());
    r_max = std::max(r_max, hit->point.norm());
    worst_normal = std::max(worst_normal, (hit->normal - hit->point.normalized()).norm());
  }
  std::printf(
      "[figures] sphere R = %.2f on %d tets: %d hits, %d misses; f at the hit %.2e; hit "
      "radius in [%.4f, %.4f] (shell [%.4f, %.4f]); normal against the sphere's %.3f\n",
      radius, mesh.tet_count(), hits, misses, worst_f, r_min, r_max, radius - shell, radius,
      worst_normal);
  EXPECT_LT(worst_f, 1e-12);
  EXPECT_GE(r_min, radius - shell);
  EXPECT_LE(r_max, radius + 1e-12);
  EXPECT_GT(hits, 300);
}

TEST(TetWalk, ConstantScalarTetrahedronHasTheClosedFormOpacity) {
  const std::vector<std::array<int, 4>> tets = {{0, 1, 2, 3}};
  const std::vector<Vec3> nodes = {Vec3(0, 0, 0), Vec3(1.2, 0.1, 0), Vec3(0.2, 0.9, 0.1),
                                   Vec3(0.3, 0.2, 1.1)};
  const double s = 0.4;
  const TetWalkMesh mesh(tets, nodes, std::vector<double>(4, s));
  TransferFunction tf;
  tf.points = {{0.0, Vec3(0.1, 0.2, 0.3), 0.5}, {1.0, Vec3(0.9, 0.7, 0.2), 4.5}};
  const Eigen::Vector4d v = tf.at(s);  // τ = 2.1
  PreintegrationSizes sizes;
  sizes.scalar_samples = 65;
  sizes.length_samples = 257;
  sizes.max_length = 2.0;
  const PreintegrationTable table(tf, sizes);
  VolumeOptions exact, tabled;
  exact.termination = 1.0;
  tabled.termination = 1.0;
  tabled.table = &table;
  const Vec3 centroid = (nodes[0] + nodes[1] + nodes[2] + nodes[3]) / 4;
  std::mt19937 rng(37);
  double worst_exact = 0.0, worst_table = 0.0, worst_length = 0.0;
  for (int q = 0; q < 300; ++q) {
    const Vec3 d = random_direction(rng);
    const Vec3 o = centroid - 4.0 * d + 0.05 * random_direction(rng);
    // The ray's length through the tetrahedron by its four half-spaces.
    double t0 = -kInf, t1 = kInf;
    for (int k = 0; k < 4; ++k) {
      const Vec3& n = mesh.geometry().normal[0][k];
      const double rn = d.dot(n), dist = mesh.geometry().offset[0][k] - n.dot(o);
      if (rn > 0) t1 = std::min(t1, dist / rn);
      if (rn < 0) t0 = std::max(t0, dist / rn);
    }
    const double l = t1 - t0;
    TetWalkResult walk;
    const TetVolumeSample e = volume_integral(mesh, tf, o, d, 0.0, kInf, exact, &walk);
    ASSERT_EQ(walk.sections, 1);
    worst_length = std::max(worst_length,
                            std::abs(walk.section_list[0].t_out - walk.section_list[0].t_in - l));
    const double alpha = 1.0 - std::exp(-v[3] * l);
    worst_exact = std::max({worst_exact, std::abs(e.colour.alpha - alpha),
                            (e.colour.colour - v.head<3>() * alpha).cwiseAbs().maxCoeff()});
    const TetVolumeSample t = volume_integral(mesh, tf, o, d, 0.0, kInf, tabled);
    worst_table = std::max({worst_table, std::abs(t.colour.alpha - alpha),
                            (t.colour.colour - v.head<3>() * alpha).cwiseAbs().maxCoeff()});
  }
  std::printf(
      "[figures] constant-scalar tetrahedron (tau %.2f): length %.2e, opacity against "
      "1 - exp(-tau l): exact %.2e, table 65 x 65 x 257 %.2e\n",
      v[3], worst_length, worst_exact, worst_table);
  EXPECT_LT(worst_length, 1e-12);
  EXPECT_LT(worst_exact, 1e-12);
  EXPECT_LT(worst_table, 1e-4);
}

TEST(TetWalk, StepCapStopsACorruptedTopology) {
  const physics::TetMesh box = physics::bar(2, 2, 2, 1.0);
  TetTopology topo = tet_topology(box.tets, static_cast<int>(box.nodes.size()));
  // Every interior face leads back into its own tetrahedron, through another face: the ray
  // leaves through face k and comes back in through face k + 1, so face k is its exit again.
  for (int t = 0; t < topo.tet_count(); ++t)
    for (int k = 0; k < 4; ++k)
      if (topo.neighbour[t][k] >= 0) {
        topo.neighbour[t][k] = t;
        topo.neighbour_face[t][k] = static_cast<std::int8_t>((k + 1) % 4);
      }
  const TetWalkMesh mesh(topo, box.tets, box.nodes, {});
  const TetWalkResult walk = walk_ray(mesh, Vec3(-1, 0.7, 1.3), Vec3(1, 0.05, 0.02).normalized(),
                                      0.0, kInf, [](const TetSegment&) { return true; });
  std::printf("[figures] corrupted topology: capped %d after %ld steps (cap %ld = 4 x %d + 1000)\n",
              walk.capped, walk.steps, mesh.step_cap(), mesh.tet_count());
  EXPECT_TRUE(walk.capped);
  EXPECT_EQ(walk.steps, mesh.step_cap());
  // A whole image: every ray that enters is capped, and the image still comes back.
  Camera camera;
  camera.eye = Vec3(-4, 1, 1);
  camera.target = Vec3(1, 1, 1);
  TetRenderStats stats;
  RenderSettings settings;
  render_tet_surface(mesh, camera, 24, 24, settings, {}, &stats);
  std::printf("[figures] corrupted topology, 24^2 image: %ld of %ld entering rays capped\n",
              stats.capped, stats.entered);
  EXPECT_GT(stats.capped, stats.entered / 2);
  EXPECT_EQ(stats.max_steps, mesh.step_cap());
}

TEST(TetWalk, DegenerateAndInvertedTetrahedraEndTheWalk) {
  const physics::TetMesh box = physics::bar(3, 3, 3, 1.0);
  std::vector<Vec3> moved = box.nodes;
  // Squash an interior node onto a neighbour (degenerate tetrahedra) and push another through
  // its neighbours (inverted ones).
  auto node_at = [&](const Vec3& p) {
    for (size_t i = 0; i < box.nodes.size(); ++i)
      if ((box.nodes[i] - p).norm() < 1e-12) return static_cast<int>(i);
    return -1;
  };
  moved[node_at(Vec3(1, 1, 1))] = box.nodes[node_at(Vec3(2, 1, 1))];
  moved[node_at(Vec3(2, 2, 2))] = Vec3(0.6, 0.5, 0.7);
  const TetWalkMesh mesh(box.tets, moved, std::vector<double>(box.nodes.size(), 0.5));
  EXPECT_GT(mesh.geometry().degenerate, 0);
  EXPECT_GT(mesh.geometry().inverted, 0);
  std::mt19937 rng(41);
  const Box3 bounds(Vec3::Zero(), Vec3(3, 3, 3));
  long lost = 0, max_steps = 0;
  int rays = 0;
  for (int q = 0; q < 3000; ++q) {
    const auto [o, d] = random_ray(rng, bounds.center(), 8.0, bounds);
    double last = -kInf;
    bool monotonic = true;
    const TetWalkResult walk = walk_ray(mesh, o, d, 0.0, kInf, [&](const TetSegment& s) {
      monotonic = monotonic && s.t_in >= last && s.t_out >= s.t_in;
      last = s.t_out;
      return true;
    });
    ASSERT_TRUE(monotonic);
    ASSERT_LE(walk.steps, mesh.step_cap());
    lost += walk.lost;
    max_steps = std::max(max_steps, walk.steps);
    ++rays;
  }
  std::printf(
      "[figures] %d degenerate and %d inverted of %d tets: %d rays, %ld sections lost, "
      "max %ld steps (cap %ld)\n",
      mesh.geometry().degenerate, mesh.geometry().inverted, mesh.tet_count(), rays, lost, max_steps,
      mesh.step_cap());
}

TEST(TetWalk, RendersMatchTheRasterisedBoundary) {
  const fixtures::TetBody u = u_body();
  // f = 1 everywhere: the surface is the mesh's boundary, hit where each ray enters.
  const TetWalkMesh solid(u.tets, u.nodes, std::vector<double>(u.nodes.size(), 1.0));
  Camera camera;
  camera.eye = Vec3(-3.5, 4.5, 6.0);
  camera.target = Vec3(2.5, 1.5, 1.0);
  camera.fov_y_deg = 50;
  const int size = 96;
  RenderSettings settings;
  TetRenderStats stats;
  const Image walked = render_tet_surface(solid, camera, size, size, settings, {}, &stats);
  const Image raster =
      rasterize(tet_boundary_mesh(solid.topology(), solid.tets(), solid.positions()), camera, size,
                size, settings);
  const ImageComparison cmp = compare_images(walked, raster, 1e-6);
  int colour_off = 0;
  for (size_t i = 0; i < walked.rgba.size(); ++i)
    colour_off = std::max(colour_off, std::abs(int(walked.rgba[i]) - int(raster.rgba[i])));
  std::printf(
      "[figures] U body surface at %d^2 against the rasterised boundary: IoU %.6f, depth "
      "max %.2e, colour max %d/255; %ld rays, %ld entered, max %d sections, max %ld "
      "steps, %.3f s\n",
      size, cmp.iou, cmp.max_depth_error, colour_off, stats.rays, stats.entered, stats.max_sections,
      stats.max_steps, stats.seconds);
  EXPECT_GE(cmp.iou, 0.9999);
  EXPECT_LT(cmp.max_depth_error, 1e-5);
  EXPECT_EQ(stats.capped, 0);
  EXPECT_EQ(stats.rays, long(size) * size);

  // Volume mode: the height y through a transfer function, exact against the table.
  std::vector<double> height;
  for (const Vec3& p : u.nodes) height.push_back(p.y() / 3.0);
  const TetWalkMesh volume(u.tets, u.nodes, height);
  TransferFunction tf;
  tf.points = {{0.0, Vec3(0.9, 0.3, 0.1), 0.6},
               {0.5, Vec3(0.2, 0.8, 0.3), 0.2},
               {1.0, Vec3(0.1, 0.3, 0.9), 1.2}};
  PreintegrationSizes sizes;
  sizes.scalar_samples = 65;
  sizes.length_samples = 65;
  sizes.max_length = 2.0;
  const PreintegrationTable table(tf, sizes);
  VolumeOptions exact, tabled;
  tabled.table = &table;
  TetRenderStats exact_stats, table_stats;
  const Vec3 background(1, 1, 1);
  const Image a =
      render_tet_volume(volume, tf, camera, size, size, background, exact, &exact_stats);
  const Image b =
      render_tet_volume(volume, tf, camera, size, size, background, tabled, &table_stats);
  int off = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i)
    off = std::max(off, std::abs(int(a.rgba[i]) - int(b.rgba[i])));
  std::printf(
      "[figures] U body volume at %d^2: table against exact quadrature max %d/255; "
      "sections histogram",
      size, off);
  for (size_t n = 0; n < exact_stats.sections_histogram.size(); ++n)
    std::printf(" %zu:%ld", n, exact_stats.sections_histogram[n]);
  std::printf("; exact %.3f s, table %.3f s\n", exact_stats.seconds, table_stats.seconds);
  EXPECT_LE(off, 1);
  EXPECT_EQ(exact_stats.max_sections, 2);
  EXPECT_EQ(exact_stats.entered, stats.entered);
  // The depth is the first entry's: the same as the surface of f = 1.
  const ImageComparison depth = compare_images(a, walked, 1e-6);
  EXPECT_EQ(depth.iou, 1.0);
  EXPECT_LT(depth.max_depth_error, 1e-9);
}

TEST(TetWalk, BadInputsAreRefused) {
  EXPECT_THROW(tet_topology({{0, 1, 2, 4}}, 4), Error);   // node out of range
  EXPECT_THROW(tet_topology({{0, 1, 2, -1}}, 4), Error);  // negative
  EXPECT_THROW(tet_topology({{0, 1, 1, 3}}, 4), Error);   // repeated node
  // Three tetrahedra on the face (0, 1, 2).
  EXPECT_THROW(tet_topology({{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}}, 6), Error);
  const TetTopology one = tet_topology({{0, 1, 2, 3}}, 4);
  EXPECT_EQ(one.boundary.size(), 4u);
  const std::vector<Vec3> p = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  EXPECT_THROW(tet_geometry(one, {{0, 1, 2, 3}}, {p[0], p[1], p[2]}, {}), Error);
  EXPECT_THROW(tet_geometry(one, {{0, 1, 2, 3}}, p, {1.0, 2.0}), Error);
  EXPECT_THROW(tet_geometry(one, {{0, 1, 2, 3}, {0, 1, 2, 3}}, p, {}), Error);
  TetTopology broken = one;
  broken.neighbour[0][2] = 7;
  broken.neighbour_face[0][2] = 1;
  EXPECT_THROW(TetWalkMesh(broken, {{0, 1, 2, 3}}, p, {}), Error);
  const TetWalkMesh mesh({{0, 1, 2, 3}}, p, {});
  Camera camera;
  EXPECT_THROW(render_tet_surface(mesh, camera, 0, 10, RenderSettings{}), Error);
  TransferFunction empty;
  EXPECT_THROW(render_tet_volume(mesh, empty, camera, 8, 8, Vec3::Ones()), Error);
  // Non-finite positions make degenerate tetrahedra, which no ray enters.
  const TetWalkMesh nan_mesh({{0, 1, 2, 3}}, {p[0], p[1], p[2], Vec3(NAN, 0, 1)}, {});
  EXPECT_EQ(nan_mesh.geometry().degenerate, 1);
  EXPECT_EQ(walk_ray(nan_mesh, Vec3(0.2, 0.2, -1), Vec3(0, 0, 1), 0.0, kInf,
                     [](const TetSegment&) { return true; })
                .sections,
            0);
}

}  // namespace
}  // namespace raywarp
