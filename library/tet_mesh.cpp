#include "library/tet_mesh.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>

#include "base/error.h"

namespace raywarp {

namespace {

using Vec3 = Eigen::Vector3d;

std::string tet_name(size_t t) { return "tetrahedron " + std::to_string(t); }

}  // namespace

TetTopology tet_topology(const std::vector<std::array<int, 4>>& tets, int node_count) {
  if (node_count < 0)
    throw Error("tet_topology: node count " + std::to_string(node_count) + ": must be >= 0");
  if (tets.size() > static_cast<size_t>(1) << 29)
    throw Error("tet_topology: " + std::to_string(tets.size()) +
                " tetrahedra: at most 2^29 are allowed");
  for (size_t t = 0; t < tets.size(); ++t) {
    const std::array<int, 4>& v = tets[t];
    for (int k = 0; k < 4; ++k) {
      if (v[k] < 0 || v[k] >= node_count)
        throw Error("tet_topology: " + tet_name(t) + " vertex " + std::to_string(k) + " = node " +
                    std::to_string(v[k]) + ": must be in [0, " + std::to_string(node_count) + ")");
      for (int j = 0; j < k; ++j)
        if (v[j] == v[k])
          throw Error("tet_topology: " + tet_name(t) + " repeats node " + std::to_string(v[k]) +
                      " (vertices " + std::to_string(j) + " and " + std::to_string(k) + ")");
    }
  }

  // Every face as its sorted node triple, with the face it came from; equal triples end up next
  // to each other after sorting.
  struct Key {
    std::array<int, 3> nodes;
    int tet;
    int face;
  };
  std::vector<Key> keys;
  keys.reserve(tets.size() * 4);
  for (size_t t = 0; t < tets.size(); ++t)
    for (int k = 0; k < 4; ++k) {
      std::array<int, 3> n;
      for (int i = 0; i < 3; ++i) n[i] = tets[t][kTetFaceVertices[k][i]];
      std::sort(n.begin(), n.end());
      keys.push_back({n, static_cast<int>(t), k});
    }
  std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
    if (a.nodes != b.nodes) return a.nodes < b.nodes;
    if (a.tet != b.tet) return a.tet < b.tet;
    return a.face < b.face;
  });

  TetTopology topo;
  topo.node_count = node_count;
  topo.neighbour.assign(tets.size(), {-1, -1, -1, -1});
  topo.neighbour_face.assign(tets.size(), {-1, -1, -1, -1});
  for (size_t i = 0; i < keys.size();) {
    size_t j = i + 1;
    while (j < keys.size() && keys[j].nodes == keys[i].nodes) ++j;
    if (j - i >= 3) {
      const std::array<int, 3>& n = keys[i].nodes;
      throw Error("tet_topology: the face of nodes (" + std::to_string(n[0]) + ", " +
                  std::to_string(n[1]) + ", " + std::to_string(n[2]) + ") is shared by " +
                  std::to_string(j - i) + " tetrahedra (" + std::to_string(keys[i].tet) + ", " +
                  std::to_string(keys[i + 1].tet) + ", " + std::to_string(keys[i + 2].tet) +
                  (j - i > 3 ? ", ..." : "") + "): at most 2 may share a face");
    }
    if (j - i == 2) {
      const Key& a = keys[i];
      const Key& b = keys[i + 1];
      topo.neighbour[a.tet][a.face] = b.tet;
      topo.neighbour_face[a.tet][a.face] = static_cast<std::int8_t>(b.face);
      topo.neighbour[b.tet][b.face] = a.tet;
      topo.neighbour_face[b.tet][b.face] = static_cast<std::int8_t>(a.face);
    }
    i = j;
  }
  for (size_t t = 0; t < tets.size(); ++t)
    for (int k = 0; k < 4; ++k)
      if (topo.neighbour[t][k] < 0) topo.boundary.push_back({static_cast<int>(t), k});
  return topo;
}

TetGeometry tet_geometry(const TetTopology& topology, const std::vector<std::array<int, 4>>& tets,
                         const std::vector<Eigen::Vector3d>& positions,
                         const std::vector<double>& scalar) {
  const size_t count = tets.size();
  if (static_cast<int>(count) != topology.tet_count())
    throw Error("tet_geometry: " + std::to_string(count) + " tetrahedra, but the topology has " +
                std::to_string(topology.tet_count()));
  if (static_cast<int>(positions.size()) != topology.node_count)
    throw Error("tet_geometry: " + std::to_string(positions.size()) +
                " positions, but the topology has " + std::to_string(topology.node_count) +
                " nodes");
  if (!scalar.empty() && scalar.size() != positions.size())
    throw Error("tet_geometry: " + std::to_string(scalar.size()) + " scalar values for " +
                std::to_string(positions.size()) + " nodes: give one per node, or none");

  TetGeometry g;
  g.normal.resize(count);
  g.offset.resize(count);
  g.gradient.resize(count);
  g.gradient_offset.resize(count);
  g.volume.resize(count);
  g.flag.assign(count, kTetValid);
  for (size_t t = 0; t < count; ++t) {
    std::array<Vec3, 4> v;
    std::array<double, 4> s{};
    for (int k = 0; k < 4; ++k) {
      const int n = tets[t][k];
      if (n < 0 || n >= static_cast<int>(positions.size()))
        throw Error("tet_geometry: " + tet_name(t) + " vertex " + std::to_string(k) + " = node " +
                    std::to_string(n) + ": must be in [0, " + std::to_string(positions.size()) +
                    ")");
      v[k] = positions[n];
      s[k] = scalar.empty() ? 0.0 : scalar[n];
    }
    const double six_volume = (v[1] - v[0]).dot((v[2] - v[0]).cross(v[3] - v[0]));
    g.volume[t] = six_volume / 6.0;
    double longest = 0.0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) longest = std::max(longest, (v[a] - v[b]).norm());
    const bool degenerate =
        !(std::abs(six_volume) > kTetDegenerateRelative * longest * longest * longest) ||
        !std::isfinite(six_volume);
    if (degenerate) {
      g.flag[t] = kTetDegenerate;
      ++g.degenerate;
      for (int k = 0; k < 4; ++k) {
        g.normal[t][k] = Vec3::Zero();
        g.offset[t][k] = 0.0;
      }
      g.gradient[t] = Vec3::Zero();
      g.gradient_offset[t] = s[0];
      continue;
    }
    if (six_volume < 0.0) {
      g.flag[t] = kTetInverted;
      ++g.inverted;
    }
    // Each face's normal, turned away from the vertex it is opposite.
    Vec3 gradient = Vec3::Zero();
    for (int k = 0; k < 4; ++k) {
      const Vec3& a = v[kTetFaceVertices[k][0]];
      const Vec3& b = v[kTetFaceVertices[k][1]];
      const Vec3& c = v[kTetFaceVertices[k][2]];
      Vec3 n = (b - a).cross(c - a);
      if (n.dot(v[k] - a) > 0.0) n = -n;
      n.normalize();
      g.normal[t][k] = n;
      g.offset[t][k] = n.dot(v[3 - k]);
      // The barycentric coordinate of vertex k has gradient n_k / (n_k · (v_k - v_{3-k}))
      // (Tejada & Ertl 2005, section 5.2); the coordinates sum to one, so s0 is taken out of
      // every term (no cancellation from a large constant part of s).
      if (k > 0) gradient += (s[k] - s[0]) * n / n.dot(v[k] - v[3 - k]);
    }
    g.gradient[t] = gradient;
    g.gradient_offset[t] = -gradient.dot(v[0]) + s[0];
  }
  return g;
}

Mesh tet_boundary_mesh(const TetTopology& topology, const std::vector<std::array<int, 4>>& tets,
                       const std::vector<Eigen::Vector3d>& positions) {
  Mesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(positions.size()), 3);
  for (size_t i = 0; i < positions.size(); ++i)
    mesh.V.row(static_cast<Eigen::Index>(i)) = positions[i].transpose();
  mesh.F.resize(static_cast<Eigen::Index>(topology.boundary.size()), 3);
  for (size_t f = 0; f < topology.boundary.size(); ++f) {
    const TetFace& b = topology.boundary[f];
    for (int c = 0; c < 3; ++c)
      mesh.F(static_cast<Eigen::Index>(f), c) = tets.at(b.tet)[kTetFaceVertices[b.face][c]];
  }
  return mesh;
}

Eigen::Vector4d tet_barycentric(const Eigen::Vector3d& x, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                const Eigen::Vector3d& d) {
  Eigen::Matrix3d m;
  m.col(0) = b - a;
  m.col(1) = c - a;
  m.col(2) = d - a;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(m);
  if (!lu.isInvertible()) return Eigen::Vector4d::Constant(std::nan(""));
  const Vec3 w = lu.solve(x - a);
  return Eigen::Vector4d(1.0 - w.sum(), w[0], w[1], w[2]);
}

}  // namespace raywarp
