// `raywarp study --stiffness --out DIR`: the mass-spring integrators (physics/) against spring
// stiffness and step size (docs/physics.md#the-stiffness-study).
//
// Models, all in voxel units (spacing 1, density 1: an interior node weighs 1): a bar of 2 x 1 x 7
// cubes (84 Kuhn tetrahedra, 48 nodes), the tetrahedra of the Stanford bunny's voxel mask
// (examples/meshes/bunny.ply, inside by the generalised winding number, 16 voxels along its
// longest side) and an ellipsoid blob of 155,712 tets (Tejada & Ertl's "Foot" size), each pinned
// on its lowest layer of nodes, no gravity, no damping. Every run starts from rest with a smooth
// bend (displacement 0.01 (t²) across the pinned axis, t the height from the pins over the
// model's length) plus 1e-6 of fixed pseudo-random noise, which puts a little energy in every
// mode.
//
// What it measures and writes (DIR/stiffness.csv, one row per figure; SVG charts; DIR/report.md):
// - stability: per model, integrator and ks (10 to 1e6 in half decades), the largest stable step
//   by bisection to 1 % ("stable": over max(1 s, 1000 steps) no non-finite value and the total
//   energy at most 1.05 E0; position Verlet's energy read with the centred velocity
//   (x_{n+1} - x_{n-1}) / 2h), beside the predicted 2/ω_max (physics/spectrum.h), and the energy
//   drift over that run;
// - amplitude: one linear oscillator, the amplitude factor per period against hω, with the theory
//   (explicit Euler (1 + ω²h²)^{π/ωh}, implicit Euler and local/global (1 + ω²h²)^{-π/ωh}, Verlet
//   and velocity Verlet 1);
// - cg: implicit Euler's CG iterations per step against h ω_max;
// - local_global: local/global's error after k iterations against the converged implicit step;
// - speed: ms per step of every integrator on every model;
// - the seed papers' stability claims replayed on the bar;
// - images: examples/bunny_simulation.json at ks 1e3 to 1e6, its final state rendered in image
//   space (the deformation texture) and in object space (the mappings), both against the exact
//   ground truth of the state (studies/stiffness_images.h; needs a current OpenGL context).
// `quick` runs a reduced set (the bar, two stiffnesses, short runs, one small image run) in a few
// seconds, for tests.
#pragma once
#include <filesystem>
#include <iosfwd>
#include <string>

namespace raywarp {

struct StiffnessOptions {
  std::filesystem::path out;  // folder for stiffness.csv, the charts and report.md
  bool quick = false;
  // The bunny mesh; empty: examples/meshes/bunny.ply under the current folder.
  std::filesystem::path bunny;
  // The scene of the image part; empty: examples/bunny_simulation.json under the current folder.
  std::filesystem::path scene;
};

// The header of stiffness.csv.
extern const char* const kStiffnessCsvHeader;

// Runs the study and writes its files; progress on `progress`, one line per figure. Throws Error
// on bad options (no output folder) or when the bunny mesh cannot be read.
void run_stiffness_study(const StiffnessOptions& options, std::ostream& progress);

}  // namespace raywarp
