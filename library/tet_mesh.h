// Tetrahedral meshes for ray casting by walking from tetrahedron to tetrahedron (Tejada & Ertl
// 2005, section 5; docs/tet_walk.md): the topology (the neighbour across each face, the boundary
// faces), built once, and the geometry of a state (outward face normals, plane offsets, the
// constant gradient of a per-vertex scalar, signed volumes), recomputed after every simulation
// step.
//
// Conventions (those of physics::TetMesh and SimulationBody::tets): a tetrahedron is four node
// indices (v0, v1, v2, v3) with positive signed volume (v1 - v0)·((v2 - v0) × (v3 - v0)) > 0 at
// rest. Face k (k = 0..3) is the face opposite vertex k; kTetFaceVertices[k] lists its local
// vertices counter-clockwise seen from outside a positively oriented tetrahedron, so
// (b - a) × (c - a) of those vertices points out of it.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "library/mesh.h"

namespace raywarp {

// The local vertices of face k, counter-clockwise seen from outside (positive volume).
inline constexpr int kTetFaceVertices[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

// A face of a tetrahedron: face `face` (opposite its vertex `face`) of tetrahedron `tet`.
struct TetFace {
  int tet = -1;
  int face = -1;
};

struct TetTopology {
  int node_count = 0;
  // neighbour[t][k]: the tetrahedron across face k of t, or -1 when face k is on the boundary.
  std::vector<std::array<int, 4>> neighbour;
  // neighbour_face[t][k]: the local index of that shared face in neighbour[t][k], -1 on the
  // boundary. Always neighbour[neighbour[t][k]][neighbour_face[t][k]] == t.
  std::vector<std::array<std::int8_t, 4>> neighbour_face;
  // The faces with no neighbour, by increasing (tet, face).
  std::vector<TetFace> boundary;
  int tet_count() const { return static_cast<int>(neighbour.size()); }
};

// The topology of `tets` over nodes [0, node_count). Faces are matched by their sorted node
// triples (sorted, O(T log T)). Throws Error on a node index out of range, a node repeated within
// a tetrahedron, or a face shared by three or more tetrahedra (non-manifold). Orientation is not
// checked here (it belongs to a state: tet_geometry).
TetTopology tet_topology(const std::vector<std::array<int, 4>>& tets, int node_count);

// Per-tetrahedron flags of a state.
enum TetFlag : std::uint8_t {
  kTetValid = 0,
  kTetInverted = 1,    // signed volume < 0: the state turned it inside out
  kTetDegenerate = 2,  // |6 V| <= kTetDegenerateRelative · (longest edge)³, or non-finite
};
// A tetrahedron is degenerate when |6 V| is at most this fraction of its longest edge cubed
// (a regular tetrahedron has 6 V / e³ = 0.118; the Kuhn tetrahedron of a cube, 1 / (√3)³ = 0.19).
inline constexpr double kTetDegenerateRelative = 1e-10;

// The geometry of one state, in the frame and units of the positions. For tetrahedron t with
// vertex positions v0..v3 and per-vertex scalar s0..s3:
//  - normal[t][k]: the unit normal of face k pointing away from vertex k (outward for a valid
//    tetrahedron, and for an inverted one too: the geometric simplex's outside);
//    offset[t][k] = normal[t][k] · v_{3-k} (v_{3-k} lies on face k), so a point x is on the inner
//    side of face k when normal · x < offset;
//  - gradient[t] = g_t, the constant gradient of the barycentric interpolant of s, and
//    gradient_offset[t] = ĝ_t = -g_t · v0 + s0, so that s(x) = g_t · x + ĝ_t inside t
//    (Tejada & Ertl 2005, section 5.1);
//  - volume[t] = (v1 - v0)·((v2 - v0) × (v3 - v0)) / 6, signed.
// Degenerate tetrahedra get zero normals, offsets and gradient (gradient_offset = s0).
struct TetGeometry {
  std::vector<std::array<Eigen::Vector3d, 4>> normal;
  std::vector<std::array<double, 4>> offset;
  std::vector<Eigen::Vector3d> gradient;
  std::vector<double> gradient_offset;
  std::vector<double> volume;
  std::vector<std::uint8_t> flag;  // TetFlag
  int inverted = 0, degenerate = 0;
  // s(x) = g_t · x + ĝ_t in tetrahedron t.
  double scalar_at(int t, const Eigen::Vector3d& x) const {
    return gradient[t].dot(x) + gradient_offset[t];
  }
};

// The geometry of the state `positions` (one per node) with the per-vertex `scalar` (one per
// node; pass an empty vector for a zero scalar). Throws Error when a size disagrees with the
// topology or a tetrahedron's node is out of range. Non-finite positions make the tetrahedron
// degenerate.
TetGeometry tet_geometry(const TetTopology& topology, const std::vector<std::array<int, 4>>& tets,
                         const std::vector<Eigen::Vector3d>& positions,
                         const std::vector<double>& scalar);

// The boundary faces as a triangle mesh over all the nodes (V = positions, unused nodes
// included), face f = topology.boundary[f], its vertices in kTetFaceVertices order: outward and
// counter-clockwise for positively oriented tetrahedra (what a rasteriser draws as front faces).
Mesh tet_boundary_mesh(const TetTopology& topology, const std::vector<std::array<int, 4>>& tets,
                       const std::vector<Eigen::Vector3d>& positions);

// The barycentric coordinates of x in the tetrahedron (a, b, c, d): w with
// x = w0 a + w1 b + w2 c + w3 d, w0 + w1 + w2 + w3 = 1 (a 3 × 3 solve; NaN when degenerate).
Eigen::Vector4d tet_barycentric(const Eigen::Vector3d& x, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                const Eigen::Vector3d& d);

}  // namespace raywarp
