#include "physics/models.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "base/error.h"

namespace raywarp::physics {

namespace {

Eigen::Vector3d sample_position(const Grid3<std::uint8_t>& mask, int i, int j, int k) {
  return mask.texel_centre(i, j, k);
}

void check_mask(const Grid3<std::uint8_t>& mask) {
  if ((mask.dims.array() < 0).any() ||
      mask.data.size() != static_cast<size_t>(mask.dims.x()) * mask.dims.y() * mask.dims.z()) {
    throw Error("physics: mask: dims and data size disagree");
  }
  if (!(mask.spacing.array() > 0).all() || !mask.spacing.allFinite() || !mask.origin.allFinite()) {
    throw Error("physics: mask: spacing must be finite and > 0");
  }
}

double signed_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     const Eigen::Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

}  // namespace

TetMesh tetrahedralize(const Grid3<std::uint8_t>& mask) {
  check_mask(mask);
  const Eigen::Vector3i& n = mask.dims;
  auto inside = [&](int i, int j, int k) { return mask.at(i, j, k) != 0; };
  auto cell_inside = [&](int i, int j, int k) {
    for (int c = 0; c < 8; ++c) {
      if (!inside(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))) return false;
    }
    return true;
  };
  // Samples used by an inside cell get node numbers in storage order.
  std::vector<int> node_of(mask.size(), -1);
  for (int k = 0; k + 1 < n.z(); ++k) {
    for (int j = 0; j + 1 < n.y(); ++j) {
      for (int i = 0; i + 1 < n.x(); ++i) {
        if (!cell_inside(i, j, k)) continue;
        for (int c = 0; c < 8; ++c) {
          node_of[mask.index(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))] = 0;
        }
      }
    }
  }
  TetMesh mesh;
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        int& id = node_of[mask.index(i, j, k)];
        if (id < 0) continue;
        id = static_cast<int>(mesh.nodes.size());
        mesh.nodes.push_back(sample_position(mask, i, j, k));
        mesh.sample.emplace_back(i, j, k);
      }
    }
  }
  // The 6 axis orders (a, b, c); corner bit a is axis a.
  static constexpr int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                        {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k + 1 < n.z(); ++k) {
    for (int j = 0; j + 1 < n.y(); ++j) {
      for (int i = 0; i + 1 < n.x(); ++i) {
        if (!cell_inside(i, j, k)) continue;
        auto corner = [&](int bits) {
          return node_of[mask.index(i + (bits & 1), j + ((bits >> 1) & 1), k + ((bits >> 2) & 1))];
        };
        for (const auto& o : kOrders) {
          int b1 = 1 << o[0], b2 = b1 | (1 << o[1]);
          std::array<int, 4> t = {corner(0), corner(b1), corner(b2), corner(7)};
          if (signed_volume(mesh.nodes[t[0]], mesh.nodes[t[1]], mesh.nodes[t[2]],
                            mesh.nodes[t[3]]) < 0) {
            std::swap(t[2], t[3]);
          }
          mesh.tets.push_back(t);
        }
      }
    }
  }
  return mesh;
}

TetMesh bar(int nx, int ny, int nz, double side) {
  if (nx < 1 || ny < 1 || nz < 1 || !(side > 0)) {
    throw Error("physics: bar: counts must be >= 1 and side > 0");
  }
  // Samples at texel centres: origin -side/2 puts sample (0, 0, 0) at the origin.
  Grid3<std::uint8_t> mask(Eigen::Vector3d::Constant(-0.5 * side), side,
                           Eigen::Vector3i(nx + 1, ny + 1, nz + 1), 1);
  return tetrahedralize(mask);
}

double tet_volume(const TetMesh& m, int t) {
  const auto& v = m.tets[t];
  return signed_volume(m.nodes[v[0]], m.nodes[v[1]], m.nodes[v[2]], m.nodes[v[3]]);
}

TetQuality tet_quality(const TetMesh& m) {
  TetQuality q;
  q.min_volume = std::numeric_limits<double>::infinity();
  q.max_volume = -std::numeric_limits<double>::infinity();
  q.min_dihedral_deg = 180;
  q.max_dihedral_deg = 0;
  static constexpr int kEdges[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                       {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  for (int t = 0; t < static_cast<int>(m.tets.size()); ++t) {
    const auto& v = m.tets[t];
    double vol = tet_volume(m, t);
    q.min_volume = std::min(q.min_volume, vol);
    q.max_volume = std::max(q.max_volume, vol);
    double longest = 0;
    for (const auto& e : kEdges) {
      Eigen::Vector3d a = m.nodes[v[e[0]]], b = m.nodes[v[e[1]]];
      Eigen::Vector3d dir = (b - a).normalized();
      Eigen::Vector3d pc = m.nodes[v[e[2]]] - a, pd = m.nodes[v[e[3]]] - a;
      pc -= pc.dot(dir) * dir;
      pd -= pd.dot(dir) * dir;
      double c = std::clamp(pc.dot(pd) / (pc.norm() * pd.norm()), -1.0, 1.0);
      double angle = std::acos(c) * 180.0 / std::numbers::pi;
      q.min_dihedral_deg = std::min(q.min_dihedral_deg, angle);
      q.max_dihedral_deg = std::max(q.max_dihedral_deg, angle);
      longest = std::max(longest, (b - a).norm());
    }
    double area = 0;
    for (const auto& f : kFaces) {
      area +=
          0.5 *
          (m.nodes[v[f[1]]] - m.nodes[v[f[0]]]).cross(m.nodes[v[f[2]]] - m.nodes[v[f[0]]]).norm();
    }
    double inradius = 3.0 * std::abs(vol) / area;
    q.max_aspect_ratio = std::max(q.max_aspect_ratio, longest / (2.0 * std::sqrt(6.0) * inradius));
  }
  return q;
}

std::vector<std::array<int, 2>> tet_edges(const TetMesh& m) {
  std::vector<std::array<int, 2>> edges;
  edges.reserve(m.tets.size() * 6);
  for (const auto& t : m.tets) {
    for (int a = 0; a < 4; ++a) {
      for (int b = a + 1; b < 4; ++b) {
        edges.push_back({std::min(t[a], t[b]), std::max(t[a], t[b])});
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

MassSpring mass_spring(const TetMesh& m, double density, double ks, double kd) {
  if (!(density > 0)) throw Error("physics: density must be > 0");
  std::vector<double> mass(m.nodes.size(), 0.0);
  for (int t = 0; t < static_cast<int>(m.tets.size()); ++t) {
    double quarter = density * std::abs(tet_volume(m, t)) / 4.0;
    for (int v : m.tets[t]) mass[v] += quarter;
  }
  MassSpring s;
  for (size_t i = 0; i < m.nodes.size(); ++i) {
    if (!(mass[i] > 0)) {
      throw Error("physics: node " + std::to_string(i) + " belongs to no tetrahedron");
    }
    s.add_node(m.nodes[i], mass[i]);
  }
  for (const auto& e : tet_edges(m)) s.add_spring(e[0], e[1], ks, kd);
  return s;
}

GridModel grid_model(const Grid3<std::uint8_t>& mask, double density, double ks, double kd) {
  check_mask(mask);
  if (!(density > 0)) throw Error("physics: density must be > 0");
  const Eigen::Vector3i& n = mask.dims;
  double cell_mass = density * mask.spacing.prod();
  GridModel g;
  std::vector<int> node_of(mask.size(), -1);
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        if (!mask.at(i, j, k)) continue;
        node_of[mask.index(i, j, k)] = g.system.add_node(sample_position(mask, i, j, k), cell_mass);
        g.sample.emplace_back(i, j, k);
      }
    }
  }
  // The 9 of the 18 neighbour offsets (6 face, 12 edge) that come later in storage order, so
  // each spring is made once: 3 face, 6 edge.
  std::vector<Eigen::Vector3i> offsets;
  for (int dz = -1; dz <= 1; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        int nonzero = (dx != 0) + (dy != 0) + (dz != 0);
        if (nonzero < 1 || nonzero > 2) continue;
        bool later = dz > 0 || (dz == 0 && (dy > 0 || (dy == 0 && dx > 0)));
        if (later) offsets.emplace_back(dx, dy, dz);
      }
    }
  }
  for (int node = 0; node < g.system.nodes(); ++node) {
    Eigen::Vector3i p = g.sample[node];
    for (const auto& o : offsets) {
      Eigen::Vector3i q = p + o;
      if ((q.array() < 0).any() || (q.array() >= n.array()).any()) continue;
      int other = node_of[mask.index(q.x(), q.y(), q.z())];
      if (other >= 0) g.system.add_spring(node, other, ks, kd);
    }
  }
  return g;
}

Grid3<std::uint8_t> ellipsoid_mask(const Eigen::Vector3d& semi_axes, double spacing) {
  if (!(semi_axes.array() > 0).all() || !semi_axes.allFinite() || !(spacing > 0) ||
      !std::isfinite(spacing)) {
    throw Error("physics: ellipsoid_mask: semi-axes and spacing must be finite and > 0");
  }
  // Samples at (i - (n - 1)/2) spacing, symmetric about the origin; n odd, one sample past the
  // ellipsoid on each side.
  Eigen::Vector3i dims;
  for (int a = 0; a < 3; ++a) dims[a] = 2 * static_cast<int>(std::ceil(semi_axes[a] / spacing)) + 3;
  Eigen::Vector3d origin = -0.5 * spacing * dims.cast<double>();
  Grid3<std::uint8_t> mask(origin, spacing, dims, 0);
  for (int k = 0; k < dims.z(); ++k) {
    for (int j = 0; j < dims.y(); ++j) {
      for (int i = 0; i < dims.x(); ++i) {
        Eigen::Vector3d p = mask.texel_centre(i, j, k).cwiseQuotient(semi_axes);
        mask.at(i, j, k) = p.squaredNorm() <= 1.0 ? 1 : 0;
      }
    }
  }
  return mask;
}

}  // namespace raywarp::physics
