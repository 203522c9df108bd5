// The simulation deformer: a mass-spring body (physics/) built over the part of the mesh inside
// the box, run from rest, and its state turned into a deformation (docs/simulation.md).
//
// The body lives on a lattice over the box: `resolution` cells along the box's longest side and
// a whole number of cells along the others (cells are boxes with a side per axis), so lattice
// samples lie on the box faces: sample (i, j, k) sits at -h + (i, j, k) * spacing. A sample is
// a node when the mesh part's signed distance there is above -margin (inside the mesh, or within
// the margin outside it); a cell belongs to the body when its 8 corners are nodes. Models:
//   grid  Mosegaard & Sørensen 2006 §3.1: springs to the 6 face and 12 edge neighbours; F is the
//         trilinear interpolation of the 8 corners' positions in each cell.
//   tets  every body cell split into 6 Kuhn tetrahedra (physics::tetrahedralize), springs on
//         their edges, lumped masses; F is the barycentric (piecewise linear) interpolation.
// The margin defaults to the cell diagonal, which puts every surface point's cell in the body
// (the distance is 1-Lipschitz), so the whole mesh part moves with it.
//
// F on the body cells is that interpolation of the state. The lattice samples outside the body
// (empty space: more than the margin outside the mesh) move by the harmonic extension of the
// nodes' displacements (zero on the pinned faces), so F is continuous over the whole box and D
// has no jump at the body's edge; beyond the box F is the identity.
// The inverse of a deformed point p' is, in order: its preimage in a deformed body cell (exact
// per Kuhn tetrahedron; per trilinear cell by damped Newton to 1e-9 of the cell diagonal), of
// several (the body folds over itself) the one nearest to p' (the smallest |D|), ties to the
// lowest cell; else its preimage in an empty cell, by the same rule (trilinear cells are searched
// from their centres first, then from 8 starts near their corners). Outside F(box) there is no
// preimage and the texel is invalid (w = 0): within two cells of F(box) the preimage given is the
// linear continuation of the nearest deformed cell's map, farther p' itself, and either is moved
// half a cell beyond the nearest box face if it falls inside the box; so D stays close to its
// valid neighbours' values and their interpolation does not reach into the part.
//
// Pins: the nodes on the pinned faces keep their rest positions, so F is the identity on those
// faces and the mesh stays whole where it crosses them. By default the pinned faces are the ones
// the mesh crosses (where a sample on the face is inside the mesh). A drag pins the nodes whose
// rest positions lie in its sub-box and moves them by its path's offset, linear between keys.
#pragma once
#include <Eigen/Core>
#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "base/interrupt.h"
#include "deformers/deformer.h"

namespace raywarp {

enum class SimModel { grid = 0, tets = 1 };
enum class SimIntegrator {
  explicit_euler = 0,
  verlet = 1,
  velocity_verlet = 2,
  implicit_euler = 3,
  local_global = 4
};
// Scene names, in enum order: "grid", "tets"; "explicit_euler", ..., "local_global".
const std::vector<std::string>& sim_model_names();
const std::vector<std::string>& sim_integrator_names();

// A key of a drag's path: at time t (seconds) the dragged nodes are offset by `offset` (box frame,
// object units) from their rest positions.
struct DragKey {
  double t = 0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};
struct Drag {
  // The dragged nodes: rest positions in the sub-box, fractions of the box (0 = min face).
  Eigen::Vector3d sub_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d sub_max = Eigen::Vector3d::Ones();
  // Keys by increasing t. The offset is linear between keys, zero at t = 0 when the first key is
  // later, and held after the last key.
  std::vector<DragKey> path;
  Eigen::Vector3d offset_at(double t) const;
};

struct SimulationParams {
  SimModel model = SimModel::grid;
  int resolution = 16;    // cells along the box's longest side
  double margin = -1;     // object units; < 0: the cell diagonal
  double density = 1000;  // mass per object unit cubed
  double ks = 0;          // spring stiffness, force per object unit (Tejada & Ertl's ks)
  double kd = 0;          // relative damping, force per (object unit / s)
  SimIntegrator integrator = SimIntegrator::implicit_euler;
  double dt = 0.01;  // seconds per step
  long steps = 100;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  // box frame, object units / s²
  std::array<bool, 6> pinned{};                       // faces in the order -x, +x, -y, +y, -z, +z
  bool pins_given = false;                            // false: pin the faces the mesh crosses
  std::vector<Drag> drags;
};

// What the body is built from: the signed distance to the mesh part (box frame, object units,
// > 0 inside), exact within the margin of the surface.
struct SimulationInput {
  std::function<double(const Eigen::Vector3d&)> signed_distance;
  // from_mesh: the mesh's vertices in the box and where the deformed copy puts them (box frame,
  // one target per source).
  std::vector<Eigen::Vector3d> sources, targets;
};

struct SimulationStats {
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();  // lattice cells per axis
  Eigen::Vector3d spacing = Eigen::Vector3d::Zero();
  double margin = 0;
  int nodes = 0, springs = 0, body_cells = 0, tets = 0, pinned = 0, dragged = 0;
  double total_mass = 0;
  std::string pinned_faces;                           // "-y, +y"
  double min_dihedral_deg = 0, max_aspect_ratio = 0;  // tets only
  long steps = 0;                                     // steps run so far
  long cg_iterations = 0;  // implicit Euler: CG iterations over all steps
  long cg_capped = 0;      // implicit Euler: solves that stopped at the cap
  double seconds = 0;      // building and running
};

// The body's lattice: what the object-space mappings bind to and what a tetrahedral renderer
// walks. Box frame, object units.
struct SimulationBody {
  SimModel model = SimModel::grid;
  Eigen::Vector3d half_extents = Eigen::Vector3d::Zero();
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();  // lattice cells per axis
  Eigen::Vector3d spacing = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> rest;    // each node's rest position: -h + sample * spacing
  std::vector<Eigen::Vector3i> sample;  // each node's lattice sample (i, j, k)
  // tets: the Kuhn tetrahedra, four node indices each of positive signed volume
  // (n1 - n0)·((n2 - n0) × (n3 - n0)) > 0 at rest; empty for the grid model.
  std::vector<std::array<int, 4>> tets;
};

class Simulation {
 public:
  // Builds the body. Throws Error on a body with no cell (the mesh part is thinner than the
  // lattice can hold: raise resolution or margin) or beyond kMaxSimulationNodes nodes.
  Simulation(const SimulationParams& params, const Eigen::Vector3d& half_extents,
             const SimulationInput& input, std::vector<std::string>* warnings = nullptr,
             Interrupter* interrupter = nullptr);
  ~Simulation();
  Simulation(Simulation&&) noexcept;

  // Runs from the current state to step `params.steps`, calling keep(step, positions) after every
  // `every`-th step and after the last (every <= 0: only after the last). Polls `interrupter`
  // each step (stage "simulation"). A step that fails (non-finite state, a node flung beyond
  // 100 box diagonals) throws Error naming the step and the integrator, with advice.
  using Keep = std::function<void(long step, const std::vector<Eigen::Vector3d>& positions)>;
  void run(long every, const Keep& keep, Interrupter* interrupter = nullptr);
  // The node positions (box frame) now, and at rest.
  std::vector<Eigen::Vector3d> positions() const;
  const std::vector<Eigen::Vector3d>& rest() const;
  const SimulationBody& body() const;
  // The deformation the node positions give (one position per node, box frame).
  std::unique_ptr<Deformer> deformer(std::vector<Eigen::Vector3d> positions) const;
  const SimulationStats& stats() const;
  const SimulationParams& params() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The most nodes a body may have (about 0.4 GiB of state and matrices for implicit Euler).
constexpr int kMaxSimulationNodes = 400000;

// The body's lattice with every cell split into k^3 cells (k in [1, 8]): the finer lattice's
// rest nodes, samples (in units of spacing / k) and Kuhn tetrahedra, split as `tets` is (the same
// six axis orders), so each finer tetrahedron lies inside one of the body's and a map linear on
// those is linear on these. The cells split are the body's: those whose 8 corners are nodes (for
// the tets model, the cells of its tetrahedra). Throws Error when the result would have more
// than `max_tets` tetrahedra, naming the count.
SimulationBody refine_body(const SimulationBody& body, int k, long max_tets);
// How many tetrahedra refine_body(body, k, ...) makes: 6 k^3 per cell of the body.
long refined_tet_count(const SimulationBody& body, int k);

// The deformation of a lattice body at given node positions (what Simulation::deformer returns),
// for callers that place nodes themselves (tests: an affine map, a twist). `node_of_sample` maps
// each lattice sample (x fastest over cells + 1 samples per axis) to its node, or -1; the samples
// on `pinned` faces that are not nodes stay at rest.
std::unique_ptr<Deformer> make_lattice_deformer(SimModel model, const Eigen::Vector3d& half_extents,
                                                const Eigen::Vector3i& cells,
                                                const std::vector<int>& node_of_sample,
                                                const std::vector<Eigen::Vector3d>& positions,
                                                const std::array<bool, 6>& pinned = {});

}  // namespace raywarp
