// Triangle meshes: loading through assimp and the figures raywarp reports about them.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <string>
#include <vector>

namespace raywarp {

struct Mesh {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> V;  // vertices, object units
  Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>
      F;  // triangles, counter-clockwise seen from outside
  // load_mesh turned every triangle: the file's closed surface faced inwards (negative volume).
  bool reoriented = false;
  Eigen::Vector3d vertex(int f, int c) const { return V.row(F(f, c)).transpose(); }
};

struct MeshStats {
  long vertices = 0, faces = 0;
  Eigen::AlignedBox3d bounds;
  long boundary_edges = 0;     // edges used by one triangle
  long nonmanifold_edges = 0;  // edges used by three or more triangles
  long degenerate_faces = 0;   // zero-area triangles
  bool reoriented = false;     // Mesh::reoriented
  bool closed() const { return boundary_edges == 0 && nonmanifold_edges == 0; }
};

// Loads OBJ, PLY, STL, OFF, glTF and whatever else assimp reads; all meshes of the file are
// merged into one, identical vertices joined, polygons triangulated. A closed surface whose
// triangles face inwards (an inside-out file: negative enclosed volume, so the winding number is
// -1 inside) has every triangle turned, and says so in `reoriented`. Throws Error naming the file.
Mesh load_mesh(const std::string& path);
// load_mesh of a file already in memory: `bytes` in `format` (a lower-case extension such as
// "ply"), checked by check_mesh_bytes (library/mesh_file.h) before assimp parses them; `path`
// names it in messages. Empty `bytes` make assimp open `path` itself.
Mesh load_mesh_bytes(const std::string& bytes, const std::string& format, const std::string& path);

// A mesh file's vertices in the file's own order, before identical ones are joined: their
// positions and, for each, the row of load_mesh's V it was joined into. With morph >= 0 (a file
// with morph targets: glTF through assimp's aiAnimMesh), the positions are each mesh's morph
// target `morph` blended by `weight`, base + weight (target - base), while `joined` stays that of
// the base shape. Throws Error naming the file (as load_mesh, or a morph target it lacks).
struct FileVertices {
  std::vector<Eigen::Vector3d> positions;
  std::vector<int> joined;
  int morph_targets = 0;  // the most morph targets one of the file's meshes has
};
FileVertices load_file_vertices(const std::string& path, int morph = -1, double weight = 1.0);

MeshStats mesh_stats(const Mesh& mesh);
// Calls use(u, w, faces) once per distinct edge {u, w} (u < w) of non-collapsed triangle sides,
// with the number of triangles using it: 1 is a boundary edge, 3 or more a non-manifold one.
void for_each_edge_use(const Mesh& mesh, const std::function<void(int, int, int)>& use);
Eigen::AlignedBox3d mesh_bounds(const Mesh& mesh);  // of the vertices
// The volume the triangles enclose, by the divergence theorem: > 0 when they face outwards.
double signed_volume(const Mesh& mesh);
std::string describe(const MeshStats& stats);  // one line for the terminal
// Per-vertex normals, area-weighted face normals (unit; zero for isolated vertices).
Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> vertex_normals(const Mesh& mesh);

}  // namespace raywarp
