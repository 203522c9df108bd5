// What the tetrahedral route (render.route "tets") walks for a simulation box: the body's
// lattice refined (refine_body) with its nodes mapped by the box's deformation F, and the scalars
// the two display modes read (docs/tet_render.md#scenes).
//
//  - Positions: every node at F(rest) (box frame, then object space). For the tets model F is
//    linear on the body's tetrahedra and the refined ones lie inside them, so the walked mesh is
//    F's image exactly; for the grid model F is trilinear per cell and the walked mesh is its
//    linear interpolation over the refined tetrahedra.
//  - f: the mesh part's signed distance at the node's rest position (object units, > 0 inside),
//    exact from the triangles within two refined cell diagonals (where f can change sign along a
//    tetrahedron's edge), with the implicit surface's sign; the surface mode shows its zero set,
//    linear in each tetrahedron.
//  - strain: the largest |σ - 1| over the singular values σ of F's Jacobian at the node.
#pragma once
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "base/interrupt.h"
#include "library/bake.h"
#include "library/mesh.h"
#include "library/preintegration.h"
#include "library/scene.h"

namespace raywarp {

struct TetBody {
  int refine = 1;  // each lattice cell split into refine^3 cells
  std::vector<std::array<int, 4>> tets;
  std::vector<Eigen::Vector3d> rest;       // box frame
  std::vector<Eigen::Vector3d> positions;  // object space, the state (F applied)
  std::vector<double> f;                   // per node
  std::vector<double> strain;              // per node; empty unless asked for
  double longest_edge = 0.0;               // over the tetrahedra in the state, object units
  double seconds = 0.0;                    // building it
};

// The automatic refinement: the smallest k in [1, 8] whose refined cells are at most
// kTetAutoCellVoxels voxels on their longest side, lowered until refined_tet_count is within
// kMaxRenderTets.
int choose_tet_refine(const SimulationBody& body, double voxel);

// The mesh for a baked simulation box (its report's lattice and state, its deformer F), `mesh`
// the scene's mesh. Refine: spec.refine, or choose_tet_refine over the box's implicit voxel.
// strain is computed when the spec shows it (mode "volume", scalar "strain"). Throws Error on a
// box with no simulation or a refinement past kMaxRenderTets; polls `interrupter`.
TetBody build_tet_body(const BakedBox& box, const Mesh& mesh, const TetDisplaySpec& spec,
                       Interrupter* interrupter = nullptr);

// The scalar the spec's volume mode shows ("f" or "strain").
const std::vector<double>& shown_scalar(const TetBody& body, const TetDisplaySpec& spec);

// The transfer function the volume mode uses when the scene gives none, over the scalar's values
// v (hi = their 95th percentile, d = the body's diagonal): f: transparent at 0 (the surface) rising
// to 2/d at hi/2 and 8/d at hi, blue to green to red (nothing outside the part); strain: the same
// ramp from 0 to hi with 0.5/d at 0, so the whole body shows faintly.
TransferFunction default_transfer_function(const std::vector<double>& values,
                                           const std::string& scalar, double diagonal);

// The pre-integration table's sizes: the spec's samples, s over the transfer function's control
// points, lengths up to the longest edge (the longest segment a tetrahedron can hold).
PreintegrationSizes tet_table_sizes(const TetBody& body, const TetDisplaySpec& spec,
                                    const TransferFunction& tf);

}  // namespace raywarp
