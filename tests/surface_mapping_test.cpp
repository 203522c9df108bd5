// The object-space mappings of Mosegaard & Sørensen 2006 on the CPU (library/surface_mapping.h):
// boundary extraction of tet and lattice bodies (counts, closed, outward), the rest shape coming
// back exactly, what rigid motions, uniform scales and affine maps do in each basis, the tie rule,
// bad input, and the binding time of a large mesh (a figure for docs/surface_mapping.md).
#include "library/surface_mapping.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>

#include "base/error.h"
#include "library/mesh.h"
#include "tests/mesh_fixtures.h"
#include "tests/surface_mapping_fixtures.h"

using namespace raywarp;
using fixtures::kuhn_box;
using fixtures::TetBody;

namespace {

// Every undirected edge is used by exactly two triangles, once in each direction (closed and
// consistently oriented).
void expect_closed_and_oriented(const std::vector<NodeTriangle>& triangles) {
  std::map<std::pair<int, int>, int> directed;
  for (const NodeTriangle& t : triangles)
    for (int c = 0; c < 3; ++c) ++directed[{t[c], t[(c + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1) << "edge " << edge.first << "-" << edge.second;
    EXPECT_EQ(directed.count({edge.second, edge.first}), 1u)
        << "edge " << edge.first << "-" << edge.second << " has no twin";
  }
}

double enclosed_volume(const std::vector<Eigen::Vector3d>& nodes,
                       const std::vector<NodeTriangle>& triangles) {
  return signed_volume(fixtures::surface_mesh(nodes, triangles));
}

std::vector<Eigen::Vector3d> vertices(const Mesh& mesh) {
  std::vector<Eigen::Vector3d> v;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) v.push_back(mesh.V.row(i).transpose());
  return v;
}

double max_error(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  EXPECT_EQ(a.size(), b.size());
  double e = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) e = std::max(e, (a[i] - b[i]).norm());
  return e;
}

// The test body: a box of 2 x 2 x 3 cubes of side 0.5, and a sphere about its centre that pokes
// out of its side faces and past its vertical edges and stays inside near its top and bottom
// (offsets of both signs, projections outside their triangle).
struct Case {
  TetBody body = kuhn_box(2, 2, 3, 0.5);
  std::vector<NodeTriangle> triangles = boundary_triangles(body.tets);
  Mesh mesh = fixtures::icosphere(0.72, 3, Eigen::Vector3d(0.5, 0.5, 0.75));
};

constexpr SurfaceBasis kBases[] = {SurfaceBasis::Triangle, SurfaceBasis::Interpolated};

TEST(SurfaceBoundary, KuhnBoxCountClosedOutward) {
  for (const Eigen::Vector3i& n : {Eigen::Vector3i(1, 1, 1), Eigen::Vector3i(2, 3, 4)}) {
    const TetBody body = kuhn_box(n.x(), n.y(), n.z(), 0.5);
    const std::vector<NodeTriangle> tris = boundary_triangles(body.tets);
    EXPECT_EQ(tris.size(), size_t(4 * (n.x() * n.y() + n.y() * n.z() + n.z() * n.x())));
    expect_closed_and_oriented(tris);
    EXPECT_NEAR(enclosed_volume(body.nodes, tris), n.prod() * 0.125, 1e-12);
    const MeshStats stats = mesh_stats(fixtures::surface_mesh(body.nodes, tris));
    EXPECT_EQ(stats.boundary_edges, 0);
    EXPECT_EQ(stats.nonmanifold_edges, 0);
  }
}

TEST(SurfaceBoundary, NonConvexKuhnBody) {
  // An L of three cubes: 14 boundary squares, 28 triangles, volume 3.
  const TetBody body = fixtures::kuhn_body({2, 2, 1}, Eigen::Vector3d::Zero(), 1.0,
                                           [](int i, int j, int) { return !(i == 1 && j == 1); });
  const std::vector<NodeTriangle> tris = boundary_triangles(body.tets);
  EXPECT_EQ(tris.size(), 28u);
  expect_closed_and_oriented(tris);
  EXPECT_NEAR(enclosed_volume(body.nodes, tris), 3.0, 1e-12);
}

TEST(SurfaceBoundary, LatticeCells) {
  // The nodes of the same box as a lattice: the grid model's boundary quads.
  const TetBody body = kuhn_box(2, 3, 4, 0.5);
  const std::vector<LatticeCell> cells = lattice_cells(body.sample);
  EXPECT_EQ(cells.size(), 24u);
  const std::vector<NodeTriangle> tris = grid_boundary_triangles(cells);
  EXPECT_EQ(tris.size(), size_t(4 * (6 + 12 + 8)));
  expect_closed_and_oriented(tris);
  EXPECT_NEAR(enclosed_volume(body.nodes, tris), 24 * 0.125, 1e-12);
  // An L of lattice cells, its notch at cell (1, 1, 0).
  const TetBody l = fixtures::kuhn_body({2, 2, 1}, Eigen::Vector3d::Zero(), 1.0,
                                        [](int i, int j, int) { return !(i == 1 && j == 1); });
  std::vector<LatticeCell> l_cells = lattice_cells(l.sample);
  EXPECT_EQ(l_cells.size(), 3u);
  const std::vector<NodeTriangle> l_tris = grid_boundary_triangles(l_cells);
  EXPECT_EQ(l_tris.size(), 28u);
  expect_closed_and_oriented(l_tris);
  EXPECT_NEAR(enclosed_volume(l.nodes, l_tris), 3.0, 1e-12);
}

TEST(SurfaceBoundary, BadInput) {
  EXPECT_THROW(boundary_triangles({{0, 1, 2, 2}}), Error);
  EXPECT_THROW(boundary_triangles({{0, 1, 2, -1}}), Error);
  // Three tets on face {0, 1, 2}.
  EXPECT_THROW(boundary_triangles({{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}}), Error);
  EXPECT_THROW(lattice_cells({Eigen::Vector3i(0, 0, 0), Eigen::Vector3i(0, 0, 0)}), Error);
  EXPECT_TRUE(boundary_triangles({}).empty());
}

TEST(SurfaceBinding, RestShapeComesBack) {
  const Case s;
  for (SurfaceBasis basis : kBases) {
    BindStats stats;
    const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, basis, &stats);
    ASSERT_EQ(b.size(), size_t(s.mesh.V.rows()));
    EXPECT_LE(max_error(deform(b, s.body.nodes, s.body.nodes), vertices(s.mesh)), 1e-12)
        << basis_name(basis);
    // Normals come back too.
    const auto normals = deform_normals(b, s.body.nodes);
    const auto rest = vertex_normals(s.mesh);
    for (size_t i = 0; i < normals.size(); ++i)
      ASSERT_LE((normals[i] - rest.row(i).transpose()).norm(), 1e-12) << i;
    // The sphere crosses the box: vertices on both sides, some beyond their triangle's edges.
    double inside = 0, outside = 0;
    for (const Eigen::Vector3d& o : b.offset) (o.y() < 0 ? inside : outside) += 1;
    EXPECT_GT(inside, 0);
    EXPECT_GT(outside, 0);
    EXPECT_GT(stats.outside, 0);
    EXPECT_GT(stats.ties, 0);
    std::printf(
        "[figures] %s basis, %zu vertices on %zu coarse triangles: max distance %.3g, "
        "mean %.3g, %ld ties, %ld projections outside their triangle\n",
        basis_name(basis), b.size(), s.triangles.size(), stats.max_distance, stats.mean_distance,
        stats.ties, stats.outside);
  }
}

TEST(SurfaceBinding, TriangleBasisOffsetIsAlongTheNormal) {
  const Case s;
  const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, SurfaceBasis::Triangle);
  for (size_t i = 0; i < b.size(); ++i) {
    EXPECT_LE(std::abs(b.offset[i].x()), 1e-14) << i;
    EXPECT_LE(std::abs(b.offset[i].z()), 1e-14) << i;
  }
}

TEST(SurfaceBinding, RigidMotionIsReproduced) {
  const Case s;
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.7, -1.3, 2.1);
  std::vector<Eigen::Vector3d> moved;
  for (const Eigen::Vector3d& p : s.body.nodes) moved.push_back(R * p + t);
  std::vector<Eigen::Vector3d> expected;
  for (const Eigen::Vector3d& v : vertices(s.mesh)) expected.push_back(R * v + t);
  for (SurfaceBasis basis : kBases) {
    const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, basis);
    EXPECT_LE(max_error(deform(b, s.body.nodes, moved), expected), 1e-12) << basis_name(basis);
  }
}

// Vertices left out of the binding stay exactly where they are, with their rest normals; the
// others move as in a full binding, and the figures count them apart.
TEST(SurfaceBinding, LeftOutVerticesStayPut) {
  const Case s;
  std::vector<char> moves(static_cast<size_t>(s.mesh.V.rows()));
  for (Eigen::Index i = 0; i < s.mesh.V.rows(); ++i) moves[i] = s.mesh.V(i, 2) > 0.75 ? 1 : 0;
  const long left_out = std::count(moves.begin(), moves.end(), 0);
  ASSERT_GT(left_out, 10);
  ASSERT_LT(left_out, s.mesh.V.rows() - 10);
  const std::vector<Eigen::Vector3d> moved =
      fixtures::twist_and_bend(s.body.nodes, Eigen::Vector3d(0.5, 0.5, 0.75), 0.9, 0.3);
  const std::vector<Eigen::Vector3d> rest_normals = [&] {
    const SurfaceBinding all = bind_surface(s.mesh, s.body.nodes, s.triangles, kBases[0]);
    return deform_normals(all, s.body.nodes);
  }();
  for (SurfaceBasis basis : kBases) {
    BindStats stats;
    const SurfaceBinding part =
        bind_surface(s.mesh, s.body.nodes, s.triangles, basis, &stats, &moves);
    const SurfaceBinding all = bind_surface(s.mesh, s.body.nodes, s.triangles, basis);
    EXPECT_EQ(stats.fixed, left_out);
    const std::vector<Eigen::Vector3d> a = deform(part, moved), b = deform(all, moved);
    const std::vector<Eigen::Vector3d> na = deform_normals(part, moved);
    const std::vector<Eigen::Vector3d> rest = vertices(s.mesh);
    long moved_far = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      if (moves[i]) {
        EXPECT_EQ(a[i], b[i]) << i;
        EXPECT_EQ(part.triangle[i], all.triangle[i]) << i;
      } else {
        EXPECT_EQ(part.triangle[i], -1) << i;
        EXPECT_EQ(a[i], rest[i]) << i;
        EXPECT_LE((na[i] - rest_normals[i]).norm(), 1e-12) << i;
        moved_far += (b[i] - rest[i]).norm() > 1e-3;  // a full binding would have moved it
      }
    }
    EXPECT_GT(moved_far, 0) << basis_name(basis);
  }
  std::vector<char> short_flags(3, 1);
  EXPECT_THROW(bind_surface(s.mesh, s.body.nodes, s.triangles, kBases[0], nullptr, &short_flags),
               Error);
}

// A uniform scale s moves the reference points by s but keeps the offsets' lengths (§3.3.1:
// only the rotation of the triangle is taken into account): v' = s r + t + o, not s v + t.
TEST(SurfaceBinding, UniformScaleKeepsOffsetLength) {
  const Case s;
  const double scale = 1.7;
  const Eigen::Vector3d t(0.2, 0.1, -0.4);
  std::vector<Eigen::Vector3d> scaled;
  for (const Eigen::Vector3d& p : s.body.nodes) scaled.push_back(scale * p + t);
  for (SurfaceBasis basis : kBases) {
    const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, basis);
    const std::vector<Eigen::Vector3d> normals = node_normals(s.body.nodes, s.triangles);
    std::vector<Eigen::Vector3d> expected, affine;
    for (size_t i = 0; i < b.size(); ++i) {
      const Eigen::Vector3d v = s.mesh.V.row(i).transpose();
      const Eigen::Vector3d r = surface_frame(b, i, s.body.nodes, normals).reference;
      expected.push_back(scale * r + t + (v - r));
      affine.push_back(scale * v + t);
    }
    const std::vector<Eigen::Vector3d> got = deform(b, s.body.nodes, scaled);
    EXPECT_LE(max_error(got, expected), 1e-12) << basis_name(basis);
    // So it differs from the affine map by (s - 1) |o|, up to 0.7 times the largest offset.
    double largest = 0;
    for (const Eigen::Vector3d& o : b.offset) largest = std::max(largest, o.norm());
    EXPECT_NEAR(max_error(got, affine), (scale - 1) * largest, 1e-12) << basis_name(basis);
  }
}

// Vertices on the coarse surface (offset 0) follow any affine map exactly, in both bases.
TEST(SurfaceBinding, SurfacePointsFollowAffineMaps) {
  const Case s;
  const Mesh on_surface = fixtures::subdivide(fixtures::surface_mesh(s.body.nodes, s.triangles));
  Eigen::Matrix3d A;
  A << 1.3, 0.4, -0.2, 0.1, 0.8, 0.5, -0.3, 0.2, 1.6;
  const Eigen::Vector3d t(-0.5, 0.25, 1.0);
  std::vector<Eigen::Vector3d> moved;
  for (const Eigen::Vector3d& p : s.body.nodes) moved.push_back(A * p + t);
  // The body's inner nodes are vertices of no triangle (and not on the surface): left out.
  std::vector<char> used(on_surface.V.rows(), 0);
  for (Eigen::Index k = 0; k < on_surface.F.size(); ++k) used[on_surface.F.data()[k]] = 1;
  for (SurfaceBasis basis : kBases) {
    const SurfaceBinding b = bind_surface(on_surface, s.body.nodes, s.triangles, basis);
    const std::vector<Eigen::Vector3d> got = deform(b, s.body.nodes, moved);
    double worst = 0;
    for (size_t i = 0; i < got.size(); ++i)
      if (used[i])
        worst = std::max(worst, (got[i] - (A * on_surface.V.row(i).transpose() + t)).norm());
    EXPECT_LE(worst, 1e-12) << basis_name(basis);
  }
  // The sphere's off-surface vertices do not (the offset only turns), so the check can fail.
  const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, SurfaceBasis::Triangle);
  std::vector<Eigen::Vector3d> sphere_expected;
  for (const Eigen::Vector3d& v : vertices(s.mesh)) sphere_expected.push_back(A * v + t);
  EXPECT_GT(max_error(deform(b, s.body.nodes, moved), sphere_expected), 1e-3);
}

// Fig. 5 of the paper: in the triangle basis, neighbouring vertices bound to different triangles
// move apart where the triangles turn differently; the interpolated frame (eq. 8) varies
// continuously across an edge (in its normal) and stretches the mesh's edges less. Measured as the
// largest relative change of an edge's length under a twist and bend of the body.
TEST(SurfaceBinding, CurvatureCorrectionStretchesLess) {
  const Case s;
  const std::vector<Eigen::Vector3d> deformed =
      fixtures::twist_and_bend(s.body.nodes, Eigen::Vector3d(0.5, 0.5, 0.75), 0.9, 0.3);
  double stretch[2] = {0, 0}, mean[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, kBases[k]);
    const std::vector<Eigen::Vector3d> v = deform(b, deformed);
    for (Eigen::Index f = 0; f < s.mesh.F.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int i = s.mesh.F(f, c), j = s.mesh.F(f, (c + 1) % 3);
        const double rest = (s.mesh.V.row(i) - s.mesh.V.row(j)).norm();
        const double change = std::abs((v[i] - v[j]).norm() / rest - 1);
        stretch[k] = std::max(stretch[k], change);
        mean[k] += change / double(3 * s.mesh.F.rows());
      }
  }
  std::printf(
      "[figures] twist 0.9 rad/unit and bend: relative edge-length change, triangle "
      "basis max %.3f mean %.4f, interpolated max %.3f mean %.4f\n",
      stretch[0], mean[0], stretch[1], mean[1]);
  EXPECT_LT(stretch[1], stretch[0]);
  EXPECT_LT(mean[1], mean[0]);
}

// A vertex beyond a convex edge of the unit cube is as near to both faces there; the face its
// projection lies deeper inside wins.
TEST(SurfaceBinding, TieRule) {
  const TetBody cube = kuhn_box(1, 1, 1);
  const std::vector<NodeTriangle> tris = boundary_triangles(cube.tets);
  Mesh m;
  m.V.resize(2, 3);
  m.V.row(0) << 1.1, 0.5, 1.05;  // past +x by 0.1, past +z by 0.05: the +x face
  m.V.row(1) << 1.05, 0.5, 1.1;  // the +z face
  m.F.resize(0, 3);
  BindStats stats;
  const SurfaceBinding b = bind_surface(m, cube.nodes, tris, SurfaceBasis::Triangle, &stats);
  auto normal_of = [&](int t) {
    const NodeTriangle& tri = tris[t];
    return Eigen::Vector3d((cube.nodes[tri[1]] - cube.nodes[tri[0]])
                               .cross(cube.nodes[tri[2]] - cube.nodes[tri[0]])
                               .normalized());
  };
  EXPECT_LE((normal_of(b.triangle[0]) - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  EXPECT_LE((normal_of(b.triangle[1]) - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_EQ(stats.ties, 2);
  EXPECT_NEAR(b.offset[0].y(), 0.1, 1e-12);
  EXPECT_NEAR(b.offset[1].y(), 0.1, 1e-12);
  // Deterministic: the same choice every time (and whatever the thread count).
  for (int k = 0; k < 3; ++k) {
    const SurfaceBinding again = bind_surface(m, cube.nodes, tris, SurfaceBasis::Triangle);
    EXPECT_EQ(again.triangle, b.triangle);
  }
}

TEST(SurfaceBinding, BadInput) {
  const Case s;
  EXPECT_THROW(bind_surface(Mesh{}, s.body.nodes, s.triangles, SurfaceBasis::Triangle), Error);
  EXPECT_THROW(bind_surface(s.mesh, s.body.nodes, {}, SurfaceBasis::Triangle), Error);
  EXPECT_THROW(bind_surface(s.mesh, s.body.nodes, {{0, 1, 100000}}, SurfaceBasis::Triangle), Error);
  EXPECT_THROW(bind_surface(s.mesh, s.body.nodes, {{0, 0, 1}}, SurfaceBasis::Triangle), Error);
  const SurfaceBinding b = bind_surface(s.mesh, s.body.nodes, s.triangles, SurfaceBasis::Triangle);
  std::vector<Eigen::Vector3d> fewer(s.body.nodes.begin(), s.body.nodes.end() - 1);
  EXPECT_THROW(deform(b, fewer), Error);
  EXPECT_THROW(deform(b, fewer, s.body.nodes), Error);
  EXPECT_THROW(deform_mesh(b, fixtures::icosphere(1.0, 1), s.body.nodes), Error);
}

// The figure of docs/surface_mapping.md: binding the dragon (100K vertices) and its 1:4
// subdivision (400K) to a Kuhn body of 24 cells along its longest side.
TEST(SurfaceBinding, LargeMeshBindsAndDeformsExactly) {
  const std::string path = std::string(RAYWARP_DATA_DIR) + "/dragon_res2.ply";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is not unpacked";
  const Mesh dragon = load_mesh(path);
  const TetBody body = fixtures::voxel_body(dragon, 24);
  const std::vector<NodeTriangle> tris = boundary_triangles(body.tets);
  const Mesh fine = fixtures::subdivide(dragon);
  for (const Mesh* mesh : {&dragon, &fine})
    for (SurfaceBasis basis : kBases) {
      BindStats stats;
      const SurfaceBinding b = bind_surface(*mesh, body.nodes, tris, basis, &stats);
      const auto start = std::chrono::steady_clock::now();
      const std::vector<Eigen::Vector3d> v = deform(b, body.nodes, body.nodes);
      const double deform_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      EXPECT_LE(max_error(v, vertices(*mesh)), 1e-12);
      std::printf(
          "[figures] bind %s basis: %ld vertices to %zu coarse triangles (%zu nodes, "
          "%zu tets): %.3f s; CPU deform %.1f ms; max distance %.4g, mean %.4g (bounds "
          "diagonal %.4g); %ld ties, %ld outside\n",
          basis_name(basis), long(mesh->V.rows()), tris.size(), body.nodes.size(), body.tets.size(),
          stats.seconds, deform_ms, stats.max_distance, stats.mean_distance,
          mesh_bounds(*mesh).diagonal().norm(), stats.ties, stats.outside);
    }
}

}  // namespace
