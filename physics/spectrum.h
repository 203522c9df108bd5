// The highest angular frequency of a mass-spring system, ω_max, and the step it allows.
//
// ω_max² is the largest eigenvalue of M⁻¹K with K = -∂f/∂x (mass_spring.h, transverse term not
// clamped) at the system's positions, restricted to the free nodes (pinned nodes removed: their
// rows and columns dropped). Call it on the system at rest for the stiffness at rest. The
// eigenvalue is found by Lanczos on the symmetric M^{-1/2} K M^{-1/2} (same eigenvalues), from a
// fixed pseudo-random start vector, without reorthogonalisation (the largest Ritz value is not
// spoilt by the loss of orthogonality; ghosts only repeat it), until the Ritz pair's residual
// |A s - θ s| is at most `tolerance` θ. Products gather per node and dot products sum in fixed
// chunks (physics/parallel.h): the result does not depend on the thread count.
//
// Stability on the linearised system, per mode of frequency ω, step h:
// - Verlet and velocity Verlet: stable for h ω <= 2, so the whole system for h <= 2 / ω_max
//   (amplitude kept, the period stretched to 2π / ((2/h) asin(ωh/2))).
// - explicit Euler: energy × (1 + ω²h²) every step, for every h > 0: unstable on an undamped
//   oscillator whatever the step; no step limit comes from ω_max (stiffness study: measure it).
// - implicit Euler: energy × 1/(1 + ω²h²) every step: stable for every h.
#pragma once
#include "physics/mass_spring.h"

namespace raywarp::physics {

struct OmegaMax {
  double omega = 0;       // ω_max, rad/s
  double eigenvalue = 0;  // ω_max², 1/s²
  int iterations = 0;     // Lanczos steps (matrix-vector products)
  double residual = 0;    // |A s - θ s| of the final Ritz pair, 1/s²
  bool converged = false;
  int dimension = 0;  // 3 × free nodes
};

// Throws raywarp::Error if the system has no free node or a node's mass is not > 0.
OmegaMax omega_max(const MassSpring& system, double tolerance = 1e-9, int max_iterations = 2000);

// Verlet's and velocity Verlet's predicted largest stable step, 2 / ω_max (s).
inline double verlet_step_limit(const OmegaMax& w) { return 2.0 / w.omega; }

}  // namespace raywarp::physics
