// Mass-spring models (docs/physics.md): tetrahedral meshes of a voxel inside-mask and a bar,
// their springs and lumped masses, and the regular-grid model of Mosegaard & Sørensen 2006
// (§3.1: 6 face and 12 edge neighbours).
//
// The mask is the caller's Grid3<std::uint8_t> (base/grid.h), nonzero = inside. Its samples are
// the texel centres origin + (i + 0.5, j + 0.5, k + 0.5) spacing; the nodes of both models are
// those sample points, so node positions are in the mask's frame and units. A cell is the cube
// between 8 neighbouring samples (the interpolation cell whose lower corner is sample (i, j, k));
// it is inside when all 8 samples are.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "base/grid.h"
#include "physics/mass_spring.h"

namespace raywarp::physics {

struct TetMesh {
  std::vector<Eigen::Vector3d> nodes;
  std::vector<Eigen::Vector3i> sample;  // each node's mask sample (i, j, k)
  // Four node indices each, ordered so that the signed volume
  // (n1 - n0)·((n2 - n0) × (n3 - n0)) / 6 is positive.
  std::vector<std::array<int, 4>> tets;
};

struct TetQuality {
  double min_volume = 0;
  double max_volume = 0;
  double min_dihedral_deg = 0;  // the smallest dihedral angle over all tets, degrees
  double max_dihedral_deg = 0;
  // The largest aspect ratio: longest edge / (2 √6 inradius), 1 for a regular tetrahedron.
  double max_aspect_ratio = 0;
};

// The Kuhn (Freudenthal) split of every inside cell into 6 tetrahedra around the cell's diagonal
// from its lowest to its highest corner, one for each order of the axes: corners 0, e_a,
// e_a + e_b, e_a + e_b + e_c. Every cell is split the same way, so the faces of neighbouring
// cells match (each face diagonal runs from its lowest to its highest corner). Nodes are numbered
// in the mask's storage order (x fastest) among the samples some inside cell uses; tets in cell
// order, then axis order. Deterministic.
TetMesh tetrahedralize(const Grid3<std::uint8_t>& mask);

// A bar of nx x ny x nz cubes of side `side` (default 2 x 2 x 5 unit cubes: 120 tets, 54 nodes),
// its lower corner at the origin, z along the bar.
TetMesh bar(int nx = 2, int ny = 2, int nz = 5, double side = 1.0);

double tet_volume(const TetMesh& mesh, int tet);
TetQuality tet_quality(const TetMesh& mesh);
// The unique edges of the tets, each (a, b) with a < b, sorted.
std::vector<std::array<int, 2>> tet_edges(const TetMesh& mesh);

// A MassSpring with the mesh's nodes, one spring per unique edge (rest length its length at
// rest) and lumped masses m_i = Σ density · V_t / 4 over the tets t at node i.
MassSpring mass_spring(const TetMesh& mesh, double density, double ks, double kd = 0);

// The grid model of Mosegaard & Sørensen 2006 §3.1: a node on every inside sample, springs to the
// inside ones of its 6 face neighbours (rest length one spacing) and 12 edge neighbours (√2
// spacings; per-axis spacing gives the actual distances), mass density × cell volume per node.
// Their k is 2 ks (ks_from_mosegaard_k).
struct GridModel {
  MassSpring system;
  std::vector<Eigen::Vector3i> sample;  // each node's mask sample
};
GridModel grid_model(const Grid3<std::uint8_t>& mask, double density, double ks, double kd = 0);

// A solid ellipsoid as a mask: samples `spacing` apart (texel centres), inside where
// (x/a)² + (y/b)² + (z/c)² <= 1 for semi_axes (a, b, c), centred on the origin, with at least one
// outside sample on every side. The benchmarks' and the stiffness study's large models are such
// blobs: semi-axes (33, 14, 15.3) at spacing 1 give a 155,712-tet mesh, Tejada & Ertl's "Foot"
// size (156,612), and (28, 13, 13) a grid model of 19,721 nodes.
Grid3<std::uint8_t> ellipsoid_mask(const Eigen::Vector3d& semi_axes, double spacing = 1.0);

}  // namespace raywarp::physics
