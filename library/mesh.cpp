// Mesh loading through assimp, and the figures raywarp reports about a mesh (see mesh.h).
#include "library/mesh.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <assimp/Importer.hpp>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <sstream>
#include <unordered_map>
#include <utility>
#include <vector>

#include "base/error.h"

namespace raywarp {
namespace {

using Vertex = std::array<double, 3>;

struct VertexHash {
  size_t operator()(const Vertex& v) const {
    size_t h = 0;
    for (double x : v) {
      // +0.0 and -0.0 compare equal, so they must hash equally.
      h = h * 1000003u ^ std::hash<double>()(x == 0.0 ? 0.0 : x);
    }
    return h;
  }
};

// Triangles of every mesh the node tree instantiates, vertices in the scene's root frame.
struct MergedMesh {
  std::vector<Vertex> vertices;
  std::vector<std::array<int, 3>> faces;
};

void merge_node(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent,
                const std::string& path, MergedMesh& out) {
  const aiMatrix4x4 transform = parent * node.mTransformation;
  // A mirroring transform turns counter-clockwise triangles clockwise: swap two corners back.
  const bool mirrored = transform.Determinant() < 0;
  for (unsigned m = 0; m < node.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
    const int base = static_cast<int>(out.vertices.size());
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D p = transform * mesh.mVertices[v];
      out.vertices.push_back({double(p.x), double(p.y), double(p.z)});
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines have no surface
      std::array<int, 3> t;
      for (int c = 0; c < 3; ++c) {
        if (face.mIndices[c] >= mesh.mNumVertices) {
          throw Error(path + ": cannot read mesh: mesh " + std::to_string(node.mMeshes[m]) +
                      " face " + std::to_string(f) + " uses vertex " +
                      std::to_string(face.mIndices[c]) + ", allowed [0, " +
                      std::to_string(mesh.mNumVertices) + ")");
        }
        t[c] = base + static_cast<int>(face.mIndices[c]);
      }
      if (mirrored) std::swap(t[1], t[2]);
      out.faces.push_back(t);
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) {
    merge_node(scene, *node.mChildren[c], transform, path, out);
  }
}

// Joins vertices with identical positions. assimp's JoinIdenticalVertices also compares
// normals and texture coordinates, so it leaves STL corners (one normal per facet) and the
// seams between the meshes of one file split; the surface's topology needs positions only.
Mesh weld(const MergedMesh& merged) {
  std::unordered_map<Vertex, int, VertexHash> index;
  index.reserve(merged.vertices.size());
  std::vector<int> remap(merged.vertices.size());
  std::vector<Vertex> unique;
  for (size_t v = 0; v < merged.vertices.size(); ++v) {
    auto [it, inserted] = index.try_emplace(merged.vertices[v], static_cast<int>(unique.size()));
    if (inserted) unique.push_back(merged.vertices[v]);
    remap[v] = it->second;
  }
  Mesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(unique.size()), 3);
  for (size_t v = 0; v < unique.size(); ++v) {
    for (int a = 0; a < 3; ++a) mesh.V(static_cast<Eigen::Index>(v), a) = unique[v][a];
  }
  mesh.F.resize(static_cast<Eigen::Index>(merged.faces.size()), 3);
  for (size_t f = 0; f < merged.faces.size(); ++f) {
    for (int c = 0; c < 3; ++c) mesh.F(static_cast<Eigen::Index>(f), c) = remap[merged.faces[f][c]];
  }
  return mesh;
}

std::string format_point(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s.precision(4);
  s << '[' << p.x() << ", " << p.y() << ", " << p.z() << ']';
  return s.str();
}

}  // namespace

Mesh load_mesh(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw Error(path + ": cannot read mesh: no such file");
  }
  Assimp::Importer importer;
  // No normals are generated: vertex_normals() computes them where needed.
  const aiScene* scene =
      importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    throw Error(path + ": cannot read mesh: " + importer.GetErrorString());
  }
  MergedMesh merged;
  merge_node(*scene, *scene->mRootNode, aiMatrix4x4(), path, merged);
  if (merged.faces.empty()) {
    throw Error(path + ": cannot read mesh: no triangles (" + std::to_string(scene->mNumMeshes) +
                " meshes, " + std::to_string(merged.vertices.size()) +
                " vertices); a mesh needs at least one triangle");
  }
  Mesh mesh = weld(merged);
  const MeshStats stats = mesh_stats(mesh);
  if (stats.closed() && signed_volume(mesh) < 0.0) {
    mesh.F.col(1).swap(mesh.F.col(2));
    mesh.reoriented = true;
  }
  return mesh;
}

double signed_volume(const Mesh& mesh) {
  double six_volume = 0.0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    six_volume += mesh.vertex(f, 0).dot(mesh.vertex(f, 1).cross(mesh.vertex(f, 2)));
  return six_volume / 6.0;
}

Eigen::AlignedBox3d mesh_bounds(const Mesh& mesh) {
  Eigen::AlignedBox3d bounds;
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) bounds.extend(mesh.V.row(v).transpose());
  return bounds;
}

void for_each_edge_use(const Mesh& mesh, const std::function<void(int, int, int)>& use) {
  std::vector<std::pair<int, int>> edges;
  edges.reserve(3 * static_cast<size_t>(mesh.F.rows()));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int c0 = 0; c0 < 3; ++c0) {
      const int u = mesh.F(f, c0), w = mesh.F(f, (c0 + 1) % 3);
      if (u != w) edges.emplace_back(std::min(u, w), std::max(u, w));
    }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    use(edges[i].first, edges[i].second, static_cast<int>(j - i));
    i = j;
  }
}

MeshStats mesh_stats(const Mesh& mesh) {
  MeshStats stats;
  stats.vertices = mesh.V.rows();
  stats.faces = mesh.F.rows();
  stats.bounds = mesh_bounds(mesh);
  stats.reoriented = mesh.reoriented;

  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector3d a = mesh.vertex(f, 0), b = mesh.vertex(f, 1), c = mesh.vertex(f, 2);
    const double longest2 =
        std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
    // Zero area up to rounding: |(b - a) x (c - a)| is computed to ~1e-16 of longest^2.
    if ((b - a).cross(c - a).norm() <= 1e-12 * longest2) ++stats.degenerate_faces;
  }
  for_each_edge_use(mesh, [&](int, int, int faces) {
    if (faces == 1) ++stats.boundary_edges;
    if (faces >= 3) ++stats.nonmanifold_edges;
  });
  return stats;
}

std::string describe(const MeshStats& stats) {
  std::ostringstream s;
  s << stats.vertices << " vertices, " << stats.faces << " triangles";
  if (!stats.bounds.isEmpty()) {
    s << ", bounds " << format_point(stats.bounds.min()) << " - "
      << format_point(stats.bounds.max());
  }
  if (stats.closed()) {
    s << ", closed";
    if (stats.reoriented) s << " (its triangles faced inwards: turned outwards)";
  } else {
    s << ", open (" << stats.boundary_edges << " boundary edges, " << stats.nonmanifold_edges
      << " non-manifold)";
  }
  if (stats.degenerate_faces > 0) s << ", " << stats.degenerate_faces << " degenerate triangles";
  return s.str();
}

Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> vertex_normals(const Mesh& mesh) {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> N =
      Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>::Zero(mesh.V.rows(), 3);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector3d a = mesh.vertex(f, 0), b = mesh.vertex(f, 1), c = mesh.vertex(f, 2);
    // |(b - a) x (c - a)| is twice the area: the sum weighs each face normal by its area.
    const Eigen::Vector3d n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) N.row(mesh.F(f, k)) += n.transpose();
  }
  for (Eigen::Index v = 0; v < N.rows(); ++v) {
    const double length = N.row(v).norm();
    if (length > 0) N.row(v) /= length;
  }
  return N;
}

}  // namespace raywarp
