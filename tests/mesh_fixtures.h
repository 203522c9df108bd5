// Meshes made in the tests: an icosphere, a cube, and cutting holes, all counter-clockwise
// seen from outside. Header only; shared by the mesh, winding, implicit and reference tests.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <utility>
#include <vector>

#include "library/mesh.h"

namespace raywarp::fixtures {

// A sphere of `radius` about `centre`: the icosahedron subdivided `subdivisions` times (each
// triangle into four), vertices projected onto the sphere; 20 * 4^subdivisions triangles, all
// vertices exactly on the sphere (up to rounding), so the mesh is inscribed.
inline Mesh icosphere(double radius, int subdivisions,
                      const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> V = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Eigen::Vector3i> F = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& v : V) v.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> midpoints;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      V.push_back((V[a] + V[b]).normalized());
      return midpoints[key] = static_cast<int>(V.size()) - 1;
    };
    std::vector<Eigen::Vector3i> next;
    for (const auto& f : F) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      next.insert(next.end(), {{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}});
    }
    F = std::move(next);
  }
  Mesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(V.size()), 3);
  for (size_t v = 0; v < V.size(); ++v) mesh.V.row(v) = (centre + radius * V[v]).transpose();
  mesh.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t f = 0; f < F.size(); ++f) mesh.F.row(f) = F[f].transpose();
  return mesh;
}

// The cube [centre - half, centre + half]^3: 8 vertices, 12 triangles.
inline Mesh cube(double half, const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  Mesh mesh;
  mesh.V.resize(8, 3);
  for (int v = 0; v < 8; ++v) {
    const Eigen::Vector3d corner(v & 1 ? 1 : -1, v & 2 ? 1 : -1, v & 4 ? 1 : -1);
    mesh.V.row(v) = (centre + half * corner).transpose();
  }
  mesh.F.resize(12, 3);
  mesh.F << 0, 2, 3, 0, 3, 1,  // z = -1
      4, 5, 7, 4, 7, 6,        // z = +1
      0, 1, 5, 0, 5, 4,        // y = -1
      2, 6, 7, 2, 7, 3,        // y = +1
      0, 4, 6, 0, 6, 2,        // x = -1
      1, 3, 7, 1, 7, 5;        // x = +1
  return mesh;
}

// The mesh without the triangles for which `drop(face)` holds (vertices kept).
inline Mesh without_faces(const Mesh& mesh, const std::function<bool(int)>& drop) {
  Mesh out;
  out.V = mesh.V;
  std::vector<int> kept;
  for (int f = 0; f < mesh.F.rows(); ++f) {
    if (!drop(f)) kept.push_back(f);
  }
  out.F.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (size_t n = 0; n < kept.size(); ++n) out.F.row(n) = mesh.F.row(kept[n]);
  return out;
}

// The mesh without the triangles whose centroid lies within `radius` of `point`.
inline Mesh with_hole(const Mesh& mesh, const Eigen::Vector3d& point, double radius) {
  return without_faces(mesh, [&](int f) {
    const Eigen::Vector3d c = (mesh.vertex(f, 0) + mesh.vertex(f, 1) + mesh.vertex(f, 2)) / 3.0;
    return (c - point).norm() < radius;
  });
}

// Signed volume (divergence theorem); positive for a closed mesh oriented outwards.
inline double signed_volume(const Mesh& mesh) {
  double volume = 0;
  for (int f = 0; f < mesh.F.rows(); ++f) {
    volume += mesh.vertex(f, 0).dot(mesh.vertex(f, 1).cross(mesh.vertex(f, 2))) / 6.0;
  }
  return volume;
}

// Largest gap between a triangle and the sphere it is inscribed in: r - sqrt(r^2 - rho^2), rho
// the triangle's circumradius. Every point of the mesh is within this of the sphere.
inline double max_sagitta(const Mesh& mesh, double radius) {
  double sag = 0;
  for (int f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector3d a = mesh.vertex(f, 0), b = mesh.vertex(f, 1), c = mesh.vertex(f, 2);
    const double la = (b - c).norm(), lb = (c - a).norm(), lc = (a - b).norm();
    const double area2 = (b - a).cross(c - a).norm();  // twice the area
    const double rho = la * lb * lc / (2.0 * area2);
    sag = std::max(sag, radius - std::sqrt(std::max(0.0, radius * radius - rho * rho)));
  }
  return sag;
}

}  // namespace raywarp::fixtures
