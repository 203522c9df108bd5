// Mesh loading through assimp, and the figures raywarp reports about a mesh (see mesh.h).
#include "library/mesh.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <assimp/Importer.hpp>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <sstream>
#include <unordered_map>
#include <utility>
#include <vector>

#include "base/error.h"
#include "library/mesh_file.h"

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

// Triangles of one polygon (corners as indices into `vertices`), counter-clockwise as the polygon
// runs: a triangle as it is, a quad split along the diagonal that keeps both halves facing the
// polygon's normal (so a concave quad stays inside its outline), a larger polygon by ear
// clipping in the plane of its Newell normal; past kMaxEarClipCorners, or where clipping finds
// no ear (a self-intersecting outline), a fan. assimp's own triangulation is not used: it
// asserts (and aborts) on PLY faces of one or two corners mixed with polygons.
constexpr size_t kMaxEarClipCorners = 256;

void triangulate(const std::vector<Vertex>& vertices, const std::vector<int>& polygon,
                 std::vector<std::array<int, 3>>& out) {
  const size_t n = polygon.size();
  if (n < 3) return;  // points and lines have no surface
  if (n == 3) {
    out.push_back({polygon[0], polygon[1], polygon[2]});
    return;
  }
  auto at = [&](size_t i) {
    const Vertex& v = vertices[static_cast<size_t>(polygon[i])];
    return Eigen::Vector3d(v[0], v[1], v[2]);
  };
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // Newell's method
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = at(i), q = at((i + 1) % n);
    normal += Eigen::Vector3d((p.y() - q.y()) * (p.z() + q.z()), (p.z() - q.z()) * (p.x() + q.x()),
                              (p.x() - q.x()) * (p.y() + q.y()));
  }
  auto fan = [&](const std::vector<size_t>& corners) {
    for (size_t i = 1; i + 1 < corners.size(); ++i)
      out.push_back({polygon[corners[0]], polygon[corners[i]], polygon[corners[i + 1]]});
  };
  std::vector<size_t> corners(n);
  for (size_t i = 0; i < n; ++i) corners[i] = i;
  if (n == 4) {
    auto facing = [&](size_t a, size_t b, size_t c) {
      return (at(b) - at(a)).cross(at(c) - at(a)).dot(normal) > 0;
    };
    if (facing(0, 1, 2) && facing(0, 2, 3))
      fan({0, 1, 2, 3});
    else
      fan({1, 2, 3, 0});
    return;
  }
  if (n > kMaxEarClipCorners || !(normal.norm() > 0)) {
    fan(corners);
    return;
  }
  // Project onto the plane across the normal's largest component, counter-clockwise.
  int drop = 0;
  normal.cwiseAbs().maxCoeff(&drop);
  const int u = (drop + 1) % 3, w = (drop + 2) % 3;
  const double sign = normal[drop] > 0 ? 1.0 : -1.0;
  std::vector<Eigen::Vector2d> flat(n);
  for (size_t i = 0; i < n; ++i) flat[i] = Eigen::Vector2d(at(i)[u], sign * at(i)[w]);
  auto cross = [&](size_t a, size_t b, size_t c) {
    const Eigen::Vector2d e = flat[b] - flat[a], f = flat[c] - flat[a];
    return e.x() * f.y() - e.y() * f.x();
  };
  while (corners.size() > 3) {
    bool clipped = false;
    for (size_t k = 0; k < corners.size() && !clipped; ++k) {
      const size_t a = corners[(k + corners.size() - 1) % corners.size()], b = corners[k],
                   c = corners[(k + 1) % corners.size()];
      if (cross(a, b, c) <= 0) continue;  // reflex or flat corner
      bool empty = true;
      for (size_t m : corners) {
        if (m == a || m == b || m == c) continue;
        if (cross(a, b, m) >= 0 && cross(b, c, m) >= 0 && cross(c, a, m) >= 0) {
          empty = false;
          break;
        }
      }
      if (!empty) continue;
      out.push_back({polygon[a], polygon[b], polygon[c]});
      corners.erase(corners.begin() + static_cast<std::ptrdiff_t>(k));
      clipped = true;
    }
    if (!clipped) break;
  }
  fan(corners);
}

// Every mesh the node tree instantiates, merged, vertices in the scene's root frame. The tree is
// walked with an explicit stack: no file's nesting depth reaches the C++ stack.
// With morph >= 0, each mesh's vertices are its morph target `morph` (assimp's aiAnimMesh, absolute
// positions) blended by `weight`: base + weight (target - base).
void merge_nodes(const aiScene& scene, const std::string& path, MergedMesh& out, int morph = -1,
                 double weight = 1.0) {
  std::vector<std::pair<const aiNode*, aiMatrix4x4>> todo = {{scene.mRootNode, aiMatrix4x4()}};
  std::vector<int> polygon;
  while (!todo.empty()) {
    const auto [node_ptr, parent] = todo.back();
    todo.pop_back();
    const aiNode& node = *node_ptr;
    const aiMatrix4x4 transform = parent * node.mTransformation;
    // A mirroring transform turns counter-clockwise polygons clockwise: reverse them back.
    const bool mirrored = transform.Determinant() < 0;
    for (unsigned m = 0; m < node.mNumMeshes; ++m) {
      const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
      const int base = static_cast<int>(out.vertices.size());
      const aiAnimMesh* target = nullptr;
      if (morph >= 0) {
        if (static_cast<unsigned>(morph) >= mesh.mNumAnimMeshes ||
            mesh.mAnimMeshes[morph] == nullptr || mesh.mAnimMeshes[morph]->mVertices == nullptr ||
            mesh.mAnimMeshes[morph]->mNumVertices != mesh.mNumVertices)
          throw Error(path + ": mesh " + std::to_string(node.mMeshes[m]) + " has " +
                      std::to_string(mesh.mNumAnimMeshes) + " morph targets with positions: no " +
                      "morph " + std::to_string(morph) + " (allowed [0, " +
                      std::to_string(mesh.mNumAnimMeshes) + "))");
        target = mesh.mAnimMeshes[morph];
      }
      for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
        aiVector3D local = mesh.mVertices[v];
        if (target) local = local + (target->mVertices[v] - local) * static_cast<ai_real>(weight);
        const aiVector3D p = transform * local;
        for (int a = 0; a < 3; ++a)
          if (!std::isfinite(p[a]))
            throw Error(path + ": cannot read mesh: mesh " + std::to_string(node.mMeshes[m]) +
                        " vertex " + std::to_string(v) + " has " + char('x' + a) + " = " +
                        std::to_string(p[a]) + " (after the file's node transforms): " +
                        "coordinates must be finite numbers within float range");
        out.vertices.push_back({double(p.x), double(p.y), double(p.z)});
      }
      for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        polygon.clear();
        for (unsigned c = 0; c < face.mNumIndices; ++c) {
          if (face.mIndices[c] >= mesh.mNumVertices) {
            throw Error(path + ": cannot read mesh: mesh " + std::to_string(node.mMeshes[m]) +
                        " face " + std::to_string(f) + " uses vertex " +
                        std::to_string(face.mIndices[c]) + ", allowed [0, " +
                        std::to_string(mesh.mNumVertices) + ")");
          }
          polygon.push_back(base + static_cast<int>(face.mIndices[c]));
        }
        if (mirrored) std::reverse(polygon.begin(), polygon.end());
        triangulate(out.vertices, polygon, out.faces);
      }
    }
    for (unsigned c = 0; c < node.mNumChildren; ++c)
      todo.emplace_back(node.mChildren[c], transform);
  }
}

// Joins vertices with identical positions. assimp's JoinIdenticalVertices also compares
// normals and texture coordinates, so it leaves STL corners (one normal per facet) and the
// seams between the meshes of one file split; the surface's topology needs positions only.
Mesh weld(const MergedMesh& merged, std::vector<int>* joined = nullptr) {
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
  if (joined) *joined = std::move(remap);
  return mesh;
}

std::string format_point(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s.precision(4);
  s << '[' << p.x() << ", " << p.y() << ", " << p.z() << ']';
  return s.str();
}

}  // namespace

namespace {

// The file's meshes merged (vertices in the file's order); with morph >= 0 the morph target's
// positions (merge_nodes). `morph_targets`: the most morph targets one of its meshes has.
MergedMesh read_merged(const std::string& bytes, const std::string& format, const std::string& path,
                       int morph = -1, double weight = 1.0, int* morph_targets = nullptr) {
  MergedMesh merged;
  size_t meshes = 1;
  if (morph >= 0 && format == "ply")
    throw Error(path + ": a PLY file holds no morph targets (glTF does)");
  if (format == "ply") {
    PolygonSoup soup = read_ply(bytes, path);
    merged.vertices = std::move(soup.vertices);
    std::vector<int> polygon;
    size_t next = 0;
    for (int size : soup.sizes) {
      polygon.assign(soup.corners.begin() + static_cast<std::ptrdiff_t>(next),
                     soup.corners.begin() + static_cast<std::ptrdiff_t>(next + size_t(size)));
      next += size_t(size);
      triangulate(merged.vertices, polygon, merged.faces);
    }
  } else {
    check_mesh_bytes(bytes, format, path);
    Assimp::Importer importer;
    // ValidateDataStructure refuses faces with indices out of range. No other post-processing
    // step runs: polygons are triangulated by triangulate(), identical vertices joined by
    // weld(), and normals computed by vertex_normals() where needed.
    const unsigned flags = aiProcess_ValidateDataStructure;
    const aiScene* scene = bytes.empty() ? importer.ReadFile(path, flags)
                                         : importer.ReadFileFromMemory(bytes.data(), bytes.size(),
                                                                       flags, format.c_str());
    if (scene == nullptr || scene->mRootNode == nullptr) {
      throw Error(path + ": cannot read mesh: " + importer.GetErrorString());
    }
    merge_nodes(*scene, path, merged, morph, weight);
    meshes = scene->mNumMeshes;
    if (morph_targets)
      for (unsigned m = 0; m < scene->mNumMeshes; ++m)
        *morph_targets =
            std::max(*morph_targets, static_cast<int>(scene->mMeshes[m]->mNumAnimMeshes));
  }
  if (merged.faces.empty()) {
    throw Error(path + ": cannot read mesh: no triangles (" + std::to_string(meshes) + " meshes, " +
                std::to_string(merged.vertices.size()) +
                " vertices); a mesh needs at least one triangle");
  }
  return merged;
}

// The bytes of `path` as load_mesh reads them (empty: assimp opens the file itself).
MeshFileBytes mesh_bytes_for(const std::string& path) {
  MeshFileBytes file = read_mesh_file(path);
  const bool compressed = path.size() > 3 && path.compare(path.size() - 3, 3, ".xz") == 0;
  // A file of a checked format (or a compressed one) is parsed from the bytes just checked; other
  // formats may name files beside them (glTF buffers, OBJ materials), so assimp opens them.
  if (!mesh_format_is_checked(file.format) && !compressed) file.bytes.clear();
  return file;
}

}  // namespace

FileVertices load_file_vertices(const std::string& path, int morph, double weight) {
  if (!std::isfinite(weight))
    throw Error(path + ": morph weight " + std::to_string(weight) + ": must be finite");
  const MeshFileBytes file = mesh_bytes_for(path);
  FileVertices out;
  const MergedMesh base = read_merged(file.bytes, file.format, path, -1, 1.0, &out.morph_targets);
  weld(base, &out.joined);
  const MergedMesh moved =
      morph >= 0 ? read_merged(file.bytes, file.format, path, morph, weight) : base;
  out.positions.reserve(moved.vertices.size());
  for (const Vertex& v : moved.vertices) out.positions.emplace_back(v[0], v[1], v[2]);
  return out;
}

Mesh load_mesh_bytes(const std::string& bytes, const std::string& format, const std::string& path) {
  const MergedMesh merged = read_merged(bytes, format, path);
  Mesh mesh = weld(merged);
  const MeshStats stats = mesh_stats(mesh);
  if (stats.degenerate_faces == stats.faces) {
    throw Error(path + ": cannot read mesh: all " + std::to_string(stats.faces) +
                " triangles are degenerate (zero area); a mesh needs at least one triangle with "
                "an area");
  }
  if (stats.closed() && signed_volume(mesh) < 0.0) {
    mesh.F.col(1).swap(mesh.F.col(2));
    mesh.reoriented = true;
  }
  return mesh;
}

Mesh load_mesh(const std::string& path) {
  const MeshFileBytes file = mesh_bytes_for(path);
  return load_mesh_bytes(file.bytes, file.format, path);
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
