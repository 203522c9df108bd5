#include "library/mesh_pairs.h"

#include <algorithm>

#include "base/error.h"

namespace raywarp {

MeshPairs mesh_pairs(const std::string& mesh_file, const Mesh& mesh, const std::string& target_file,
                     int morph, double weight, const Box& box) {
  const FileVertices rest = load_file_vertices(mesh_file);
  const FileVertices moved = load_file_vertices(target_file, morph, weight);
  if (rest.positions.size() != moved.positions.size())
    throw Error(target_file + ": " + std::to_string(moved.positions.size()) +
                " vertices, the scene's mesh " + mesh_file + " has " +
                std::to_string(rest.positions.size()) +
                ": a deformed copy keeps every vertex of the mesh, in the same order");
  const long n = static_cast<long>(mesh.V.rows());
  MeshPairs out;
  out.file_vertices = static_cast<long>(rest.positions.size());
  out.mesh_vertices = n;
  // Each joined vertex's copies in the target: their sum, count and spread.
  std::vector<Eigen::Vector3d> sum(static_cast<size_t>(n), Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector3d> first(static_cast<size_t>(n), Eigen::Vector3d::Zero());
  std::vector<int> count(static_cast<size_t>(n), 0);
  std::vector<char> torn(static_cast<size_t>(n), 0);
  const double diagonal = 2.0 * box.half_extents.norm();
  const double tolerance = 1e-9 * std::max(diagonal, 1e-300);
  for (size_t r = 0; r < rest.joined.size(); ++r) {
    const int v = rest.joined[r];
    if (v < 0 || v >= n)
      throw Error(mesh_file + ": vertex " + std::to_string(r) +
                  " is not in the mesh as loaded (was it changed since?)");
    const Eigen::Vector3d& t = moved.positions[r];
    if (count[static_cast<size_t>(v)] == 0)
      first[static_cast<size_t>(v)] = t;
    else if ((t - first[static_cast<size_t>(v)]).norm() > tolerance)
      torn[static_cast<size_t>(v)] = 1;
    sum[static_cast<size_t>(v)] += t;
    ++count[static_cast<size_t>(v)];
  }
  for (long v = 0; v < n; ++v) {
    const size_t i = static_cast<size_t>(v);
    if (count[i] == 0) continue;
    const Eigen::Vector3d p = mesh.V.row(v).transpose();
    const Eigen::Vector3d t = sum[i] / count[i];
    const Eigen::Vector3d local = box.to_local(p);
    const bool inside = ((local.cwiseAbs() - box.half_extents).array() <= tolerance).all();
    const double move = (t - p).norm();
    if (!inside) {
      out.moved_outside += move > tolerance;
      continue;
    }
    out.torn += torn[i];
    out.largest_move = std::max(out.largest_move, move);
    out.sources.push_back(local);
    out.targets.push_back(box.to_local(t));
  }
  return out;
}

}  // namespace raywarp
