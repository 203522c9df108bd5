// Coarse bodies for the surface-mapping tests (tests/surface_mapping_test.cpp,
// tests/surface_mapping_render_test.cpp): Kuhn tetrahedra of lattice cells, made here rather
// than by physics/ so the tests see the library alone; deformations of their nodes; a 1:4
// subdivision for large meshes. Header only.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <utility>
#include <vector>

#include "library/mesh.h"
#include "library/surface_mapping.h"
#include "library/winding.h"

namespace raywarp::fixtures {

struct TetBody {
  std::vector<Eigen::Vector3d> nodes;
  std::vector<Eigen::Vector3i> sample;   // each node's lattice point
  std::vector<std::array<int, 4>> tets;  // positive volume
};

// The cells (i, j, k) in [0, dims) for which inside(i, j, k) holds, each split into the 6 Kuhn
// tetrahedra 0, e_a, e_a + e_b, e_a + e_b + e_c (one per order of the axes), oriented to positive
// volume; lattice point (i, j, k) at origin + side (i, j, k). Nodes in order of first use.
inline TetBody kuhn_body(const Eigen::Vector3i& dims, const Eigen::Vector3d& origin, double side,
                         const std::function<bool(int, int, int)>& inside) {
  TetBody body;
  std::map<std::array<int, 3>, int> node_at;
  auto node = [&](const Eigen::Vector3i& s) {
    auto [it, added] = node_at.emplace(std::array<int, 3>{s.x(), s.y(), s.z()},
                                       static_cast<int>(body.nodes.size()));
    if (added) {
      body.nodes.push_back(origin + side * s.cast<double>());
      body.sample.push_back(s);
    }
    return it->second;
  };
  static constexpr int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                        {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < dims.z(); ++k)
    for (int j = 0; j < dims.y(); ++j)
      for (int i = 0; i < dims.x(); ++i) {
        if (!inside(i, j, k)) continue;
        for (const auto& order : kOrders) {
          Eigen::Vector3i s(i, j, k);
          std::array<int, 4> tet;
          tet[0] = node(s);
          for (int a = 0; a < 3; ++a) {
            s[order[a]] += 1;
            tet[a + 1] = node(s);
          }
          const Eigen::Vector3d& p0 = body.nodes[tet[0]];
          const double volume = (body.nodes[tet[1]] - p0)
                                    .dot((body.nodes[tet[2]] - p0).cross(body.nodes[tet[3]] - p0));
          if (volume < 0) std::swap(tet[2], tet[3]);
          body.tets.push_back(tet);
        }
      }
  return body;
}

// A box of nx x ny x nz cubes of side `side`, its lower corner at `origin`.
inline TetBody kuhn_box(int nx, int ny, int nz, double side = 1.0,
                        const Eigen::Vector3d& origin = Eigen::Vector3d::Zero()) {
  return kuhn_body({nx, ny, nz}, origin, side, [](int, int, int) { return true; });
}

// The coarse body of a closed mesh: the cells of a lattice of `cells` along the longest side of
// its bounds (one cell of margin) whose centre is inside (winding number > 0.5).
inline TetBody voxel_body(const Mesh& mesh, int cells) {
  const Eigen::AlignedBox3d bounds = mesh_bounds(mesh);
  const double side = bounds.sizes().maxCoeff() / cells;
  const Eigen::Vector3d origin = bounds.min() - Eigen::Vector3d::Constant(side);
  const Eigen::Vector3i dims = ((bounds.sizes() / side).array().ceil().cast<int>() + 2).matrix();
  const WindingNumber winding(mesh);
  return kuhn_body(dims, origin, side, [&](int i, int j, int k) {
    return winding(origin + side * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5)) > 0.5;
  });
}

// The nodes twisted about the line through `centre` along z by `rate` radians per unit of z, and
// bent: x moves by bend (z - centre.z)^2. Not affine: every triangle's frame turns differently.
inline std::vector<Eigen::Vector3d> twist_and_bend(const std::vector<Eigen::Vector3d>& nodes,
                                                   const Eigen::Vector3d& centre, double rate,
                                                   double bend) {
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector3d& p : nodes) {
    const Eigen::Vector3d q = p - centre;
    const double angle = rate * q.z(), c = std::cos(angle), s = std::sin(angle);
    out.push_back(centre + Eigen::Vector3d(c * q.x() - s * q.y() + bend * q.z() * q.z(),
                                           s * q.x() + c * q.y(), q.z()));
  }
  return out;
}

// The triangles of a coarse surface as a mesh of all the nodes.
inline Mesh surface_mesh(const std::vector<Eigen::Vector3d>& nodes,
                         const std::vector<NodeTriangle>& triangles) {
  Mesh m;
  m.V.resize(static_cast<Eigen::Index>(nodes.size()), 3);
  for (size_t i = 0; i < nodes.size(); ++i) m.V.row(static_cast<Eigen::Index>(i)) = nodes[i];
  m.F.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (size_t t = 0; t < triangles.size(); ++t)
    m.F.row(static_cast<Eigen::Index>(t)) << triangles[t][0], triangles[t][1], triangles[t][2];
  return m;
}

// Each triangle into four, the edge midpoints shared.
inline Mesh subdivide(const Mesh& mesh) {
  std::map<std::pair<int, int>, int> midpoints;
  std::vector<Eigen::Vector3d> v;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) v.push_back(mesh.V.row(i).transpose());
  auto midpoint = [&](int a, int b) {
    auto [it, added] = midpoints.emplace(std::minmax(a, b), static_cast<int>(v.size()));
    if (added) v.push_back(0.5 * (v[a] + v[b]));
    return it->second;
  };
  Mesh out;
  out.F.resize(4 * mesh.F.rows(), 3);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int a = mesh.F(f, 0), b = mesh.F(f, 1), c = mesh.F(f, 2);
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    out.F.row(4 * f) << a, ab, ca;
    out.F.row(4 * f + 1) << ab, b, bc;
    out.F.row(4 * f + 2) << ca, bc, c;
    out.F.row(4 * f + 3) << ab, bc, ca;
  }
  out.V.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) out.V.row(static_cast<Eigen::Index>(i)) = v[i];
  return out;
}

}  // namespace raywarp::fixtures
