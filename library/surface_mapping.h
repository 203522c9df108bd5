// Object-space mappings of a detailed mesh onto a coarse body's boundary surface, after Mosegaard
// & Sørensen 2006, "Real-time deformation of detailed geometry based on mappings to a less
// detailed physical simulation on the GPU", §3.3 (docs/surface_mapping.md). The baseline the
// image-space route (the inverse deformation texture) is compared against.
//
// The coarse body is a set of nodes (rest and deformed positions, any units) and its boundary
// surface, triangles of node indices oriented outwards. Every vertex v of the detailed mesh is
// bound once, at rest, to its nearest boundary triangle (p1, p2, p3):
//  - reference point r = p1 + u (p2 - p1) + v (p3 - p1): the orthogonal projection of the vertex
//    on the triangle's plane (eq. 4 with weights (1 - u - v, u, v); not clamped to the triangle,
//    so a vertex beyond an edge extrapolates);
//  - offset o = vertex - r in an orthonormal frame (T, N, B) of the triangle (eq. 7): its three
//    coordinates (o·T, o·N, o·B). In the triangle basis (eq. 6) o is along N, so the coordinates
//    are (0, h, 0) up to rounding, h the signed distance to the plane;
//  - the rest vertex normal in the same frame (§3.3.4), for shading.
// Deformed: the same (u, v) and coordinates in the deformed triangle's frame (eq. 9),
// vertex' = r' + o_T T' + o_N N' + o_B B'.
//
// Frames (p1, p2, p3 in the triangle's order):
//  - SurfaceBasis::Triangle (eq. 6): T = normalize(p2 - p1), N = normalize(T x normalize(p3 -
//    p1)), B = N x T. (The paper's eq. 6 leaves N unnormalised; it is unit only for a right angle
//    at p1.)
//  - SurfaceBasis::Interpolated (eq. 8, curvature correction): N_c = normalize((1 - u - v) n1 +
//    u n2 + v n3) of the coarse vertex normals n_i (node_normals: area-weighted averages of the
//    adjacent boundary face normals, not the paper's eq. 3 sum of spring directions, which needs
//    the spring neighbourhood and fails on one-node-thin parts, §3.5), B_c = normalize(N_c x T),
//    T_c = B_c x N_c. (Eq. 8 leaves N_c and B_c unnormalised; the frame must be orthonormal for
//    the rest shape to come back.) Where N_c is (nearly) zero or parallel to T, |N_c x T| <=
//    1e-6 |N_c|, the vertex uses the triangle frame instead, at rest and deformed alike.
//
// What holds: at rest every vertex comes back (to rounding, ~1e-15 relative). A rigid motion of
// the nodes moves every vertex rigidly, in both bases. An affine map A moves the reference points
// by A (barycentric weights are affine invariant), but the frame only turns: the offset keeps its
// length (the paper takes "into account only the rotation of the associated triangle", §3.3.1), so
// under a uniform scale s a vertex at offset o from its reference point lands at s r + t + o, not
// at s v + t. A vertex on the coarse surface (o = 0) follows any affine map exactly.
#pragma once
#include <Eigen/Core>
#include <array>
#include <vector>

#include "base/box.h"
#include "deformers/simulation.h"
#include "library/mesh.h"

namespace raywarp {

using NodeTriangle = std::array<int, 3>;

// The faces of a tetrahedral mesh used by exactly one tet, each oriented outwards for tets of
// positive signed volume (n1 - n0)·((n2 - n0) x (n3 - n0)) > 0 (physics::TetMesh's order): tet
// (a, b, c, d) gives (b, c, d), (a, d, c), (a, b, d), (a, c, b). In tet order, then face order.
// Throws Error for a negative node index, a tet with a repeated node, or a face of three or more
// tets.
std::vector<NodeTriangle> boundary_triangles(const std::vector<std::array<int, 4>>& tets);

// Hexahedral cells of a regular lattice: corner k of a cell is the node at lattice offset
// (k & 1, (k >> 1) & 1, (k >> 2) & 1) from its lower corner (x fastest, as a grid's storage).
using LatticeCell = std::array<int, 8>;
// The cells of nodes on a lattice (each node's integer sample (i, j, k), e.g.
// physics::GridModel::sample): one per node all 8 of whose corners are nodes, in node order.
// Throws Error when two nodes share a sample.
std::vector<LatticeCell> lattice_cells(const std::vector<Eigen::Vector3i>& samples);
// The quads of the cells used by exactly one cell, each split into two triangles along the
// diagonal through its corner of least node index (so the split does not depend on the cell that
// lists it), oriented outwards for a lattice of positive axes (a right-handed cell). In cell
// order, then face order -x, +x, -y, +y, -z, +z. Throws Error as boundary_triangles does.
std::vector<NodeTriangle> grid_boundary_triangles(const std::vector<LatticeCell>& cells);

// Unit area-weighted vertex normals of a triangle surface: normalize(sum over the triangles at
// node i of (p2 - p1) x (p3 - p1)); zero for a node on no triangle (or whose sum vanishes).
std::vector<Eigen::Vector3d> node_normals(const std::vector<Eigen::Vector3d>& nodes,
                                          const std::vector<NodeTriangle>& triangles);

enum class SurfaceBasis { Triangle, Interpolated };
const char* basis_name(SurfaceBasis basis);  // "triangle", "interpolated"

struct SurfaceBinding {
  SurfaceBasis basis = SurfaceBasis::Triangle;
  int node_count = 0;                   // nodes of the coarse body it was bound against
  std::vector<NodeTriangle> triangles;  // the coarse boundary surface, node indices
  // Per vertex of the detailed mesh. A vertex left out of the binding (bind_surface's `moves`)
  // has triangle -1 and stays put: its offset is its rest position and its normal the rest
  // normal, in the mesh's frame.
  std::vector<int> triangle;             // index into `triangles`, or -1
  std::vector<Eigen::Vector2d> weights;  // (u, v): r = p1 + u (p2 - p1) + v (p3 - p1)
  std::vector<Eigen::Vector3d> offset;   // (o·T, o·N, o·B) in the basis's frame at rest
  std::vector<Eigen::Vector3d> normal;   // the rest vertex normal in the same frame
  size_t size() const { return triangle.size(); }
};

// Figures of a binding.
struct BindStats {
  double seconds = 0.0;           // wall time of bind_surface
  double max_distance = 0.0;      // the largest distance from a vertex to its triangle, at rest
  double mean_distance = 0.0;     // the mean of those distances
  long ties = 0;                  // vertices with more than one nearest triangle (see bind_surface)
  long outside = 0;               // vertices whose projection lies outside their triangle
  long degenerate_triangles = 0;  // zero-area coarse triangles, never chosen
  long fixed = 0;                 // vertices left out (`moves`), which stay put
};

// Binds every vertex of `mesh` to its nearest triangle of `triangles` (nodes at `rest_nodes`),
// in `basis`. The nearest triangle is found through a TriangleBvh. Ties: the triangles incident
// to a node of the one the tree returns whose distance is within 1e-9 of the coarse surface's
// bounding-box diagonal of the least are tied (a vertex whose nearest point is on an edge or a
// node is as near to all the triangles there); of those, the one whose plane projection lies
// deepest inside it (the largest least barycentric weight) wins, then the lowest index. So the
// choice is deterministic (and independent of threads); a tie with a triangle elsewhere on the
// surface falls to the tree's order. Zero-area triangles (|e1 x e2| <= 1e-12 max|e|^2) are never
// chosen. `moves` (one flag per vertex; null: all) leaves the vertices flagged 0 out: they stay
// put (a mesh only part of which the coarse body holds, as a box's part). The distance figures
// are over the bound vertices. Throws Error for an empty mesh, no usable triangle, a node index
// out of range, or `moves` of another size.
SurfaceBinding bind_surface(const Mesh& mesh, const std::vector<Eigen::Vector3d>& rest_nodes,
                            const std::vector<NodeTriangle>& triangles, SurfaceBasis basis,
                            BindStats* stats = nullptr, const std::vector<char>* moves = nullptr);

// The frame of a vertex's triangle (eq. 6, or eq. 8 with `normals` = node_normals of `nodes`;
// `normals` is not read for the triangle basis) and its reference point. `vertex` must be bound
// (triangle >= 0).
struct SurfaceFrame {
  Eigen::Vector3d reference, T, N, B;
};
SurfaceFrame surface_frame(const SurfaceBinding& binding, size_t vertex,
                           const std::vector<Eigen::Vector3d>& nodes,
                           const std::vector<Eigen::Vector3d>& normals);

// The deformed vertex positions (eq. 9), in double: the reference for the vertex shader
// (gl/surface_mapping_render.h). The binding holds what the rest shape gave; `rest_nodes` is
// only checked to be the body it was bound against (its node count). Throws Error when a node
// count differs from binding.node_count. A deformed triangle of zero area gives NaN positions.
std::vector<Eigen::Vector3d> deform(const SurfaceBinding& binding,
                                    const std::vector<Eigen::Vector3d>& rest_nodes,
                                    const std::vector<Eigen::Vector3d>& deformed_nodes);
std::vector<Eigen::Vector3d> deform(const SurfaceBinding& binding,
                                    const std::vector<Eigen::Vector3d>& deformed_nodes);
// The rest vertex normals carried by the deformed frames (§3.3.4), unit (zero stays zero).
std::vector<Eigen::Vector3d> deform_normals(const SurfaceBinding& binding,
                                            const std::vector<Eigen::Vector3d>& deformed_nodes);
// `mesh` with its vertices deformed (its triangles as they are): for the CPU rasteriser and the
// error figures. Throws Error when the mesh is not the bound one (vertex count).
Mesh deform_mesh(const SurfaceBinding& binding, const Mesh& mesh,
                 const std::vector<Eigen::Vector3d>& deformed_nodes);

// A simulation box's body as the coarse surface of the mappings, in the mesh's (object) frame:
// its nodes at rest and at `state` (box frame, as SimulationBody), the boundary of its tets
// (tets model) or of its lattice cells (grid model), and the flags of the mesh's vertices inside
// the box, the only ones the body moves (bind_surface's `moves`). Throws Error when `state` has
// another node count than the body.
struct BodySurface {
  std::vector<Eigen::Vector3d> rest, moved;
  std::vector<NodeTriangle> triangles;
  std::vector<char> moves;
};
BodySurface simulation_body_surface(const SimulationBody& body,
                                    const std::vector<Eigen::Vector3d>& state, const Box& box,
                                    const Mesh& mesh);

}  // namespace raywarp
