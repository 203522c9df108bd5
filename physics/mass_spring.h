// A mass-spring system: nodes with lumped masses, linear springs between pairs of nodes, pinned
// nodes and gravity (docs/physics.md). The state the integrators (physics/integrators.h) advance.
//
// Conventions (every one of them, stated once here; docs/physics.md repeats them):
// - Units: object units for lengths, seconds for time, a caller's unit of mass. Stiffness ks is
//   force per object unit, damping kd force per (object unit / s); energies come out in
//   mass · unit² / s².
// - Storage: node i's position is x.segment<3>(3 i), velocity v.segment<3>(3 i); the 3n vectors
//   and the 3n x 3n matrices use that order (node-major, then x, y, z).
// - Spring s = (i, j), with d = x_i - x_j, l = |d|, u = d / l (Tejada & Ertl 2005, eq. 1-2, whose
//   x_ij = x_j - x_i is our -d):
//     energy    E_s = ks/2 (l - L)²
//     elastic   f_i = -ks (l - L) u,  f_j = -f_i          (a stretched spring pulls i towards j)
//     damping   Damping::relative (their eq. 3):  f_i = -kd (v_i - v_j),  f_j = -f_i
//               Damping::along_spring:            f_i = -kd (u·(v_i - v_j)) u,  f_j = -f_i
//   A spring of zero length (l = 0) exerts no elastic force (its direction is undefined).
// - Gravity: f_i += m_i g (g in units / s², e.g. (0, -9.81, 0) for metres); its potential is
//   -Σ m_i g·x_i (zero at the origin).
// - Total energy = kinetic Σ m_i |v_i|²/2 + spring Σ E_s + gravity potential. Damping is not
//   an energy; it only removes it.
// - Jacobians (their eq. 4-5), 3x3 blocks for a spring, K = ∂f_i/∂x_j:
//     K = ks u uᵀ + ks (1 - L/l) (I - u uᵀ),   ∂f_i/∂x_i = ∂f_j/∂x_j = -K,  ∂f_i/∂x_j = ∂f_j/∂x_i =
//     K
//   With `clamp_compressed`, the term ks (1 - L/l)(I - u uᵀ) is dropped where it is negative
//   (l < L, a compressed spring), which keeps -∂f/∂x positive semi-definite (Baraff & Witkin's
//   usual fix; the implicit integrator uses it). ∂f/∂v: D = kd I (relative) or kd u uᵀ
//   (along_spring) in the same block pattern. The derivative of along_spring damping with
//   respect to x is left out of ∂f/∂x (the usual approximation; it is not symmetric).
// - Pinned nodes: their forces are computed like any other's, but every integrator keeps their
//   position and gives them zero velocity. A scripted drag moves them between steps
//   (move_pinned); within a step they are fixed.
//
// Speed and threads: forces and energy gather per node over a node-to-spring adjacency that the
// system builds on first use and keeps (shared by copies, rebuilt when the springs' ends change),
// and run on TBB's threads for systems of 4096 nodes or more. Every sum is taken in a fixed
// order (a node's springs in increasing index; energies in fixed chunks), so the results do not
// depend on the thread count and are the bits a serial loop over the springs gives for forces.
#pragma once
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace raywarp::physics {

using Vector = Eigen::VectorXd;                    // 3n, node-major
using SparseMatrix = Eigen::SparseMatrix<double>;  // column-major, 3n x 3n

struct Spring {
  int i = 0;
  int j = 0;
  double rest = 0;  // L, object units
  double ks = 0;    // stiffness (force / unit)
  double kd = 0;    // damping (force / (unit / s))
};

enum class Damping { relative, along_spring };

// Each node's springs, in increasing spring index (CSR): node n's entries are
// [start[n], start[n + 1]) of `spring` (the spring's index), `other` (its other end) and
// `first` (1 when n is the spring's i, 0 when its j). `ends` keeps each spring's (i, j), to tell
// when the springs changed.
struct SpringAdjacency {
  int nodes = 0;
  std::vector<int> start;
  std::vector<int> spring;
  std::vector<int> other;
  std::vector<std::uint8_t> first;
  std::vector<std::array<int, 2>> ends;
};
SpringAdjacency spring_adjacency(int nodes, const std::vector<Spring>& springs);

namespace detail {
// The adjacency a MassSpring keeps: copies share it (it is immutable); safe to read from several
// threads.
class AdjacencyCache {
 public:
  AdjacencyCache() = default;
  AdjacencyCache(const AdjacencyCache& o) : ptr_(o.get()) {}
  AdjacencyCache& operator=(const AdjacencyCache& o) {
    if (this != &o) set(o.get());
    return *this;
  }
  std::shared_ptr<const SpringAdjacency> get() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return ptr_;
  }
  void set(std::shared_ptr<const SpringAdjacency> p) const {
    std::lock_guard<std::mutex> lock(mutex_);
    ptr_ = std::move(p);
  }

 private:
  mutable std::mutex mutex_;
  mutable std::shared_ptr<const SpringAdjacency> ptr_;
};
}  // namespace detail

struct Energy {
  double kinetic = 0;
  double spring = 0;
  double gravity = 0;
  double total() const { return kinetic + spring + gravity; }
};

class MassSpring {
 public:
  // Adds a node at `position` (units) with lumped mass `mass` (> 0); returns its index.
  int add_node(const Eigen::Vector3d& position, double mass);
  // Adds a spring between nodes i and j with rest length = their current distance (rest < 0)
  // or `rest`; returns its index.
  int add_spring(int i, int j, double ks, double kd = 0, double rest = -1);
  void pin(int node, bool pinned = true);
  // Moves pinned nodes to `positions` (a scripted drag, applied between steps); throws
  // raywarp::Error if a node is not pinned.
  void move_pinned(const std::vector<int>& nodes, const std::vector<Eigen::Vector3d>& positions);

  int nodes() const { return static_cast<int>(mass.size()); }
  bool is_pinned(int node) const { return pinned[node] != 0; }
  Eigen::Vector3d position(int node) const { return x.segment<3>(3 * node); }
  Eigen::Vector3d velocity(int node) const { return v.segment<3>(3 * node); }

  // f(x, v): springs, damping and gravity (pinned nodes included).
  Vector forces(const Vector& x, const Vector& v) const;
  Vector forces() const { return forces(x, v); }
  // The same into `f` (resized to 3n), without allocating when it has the size already; with
  // `per_mass`, M⁻¹ f and zero on pinned nodes (the accelerations).
  void forces(const Vector& x, const Vector& v, Vector& f, bool per_mass = false) const;
  // The adjacency of the current springs (built now if there is none or the springs' ends or the
  // node count changed).
  std::shared_ptr<const SpringAdjacency> adjacency() const;
  Energy energy(const Vector& x, const Vector& v) const;
  Energy energy() const { return energy(x, v); }
  // Σ m_i v_i (pinned nodes included; they have zero velocity).
  Eigen::Vector3d momentum() const;
  // ∂f/∂x at x (3n x 3n, symmetric), with the compressed-spring term dropped if asked.
  SparseMatrix dfdx(const Vector& x, bool clamp_compressed) const;
  // ∂f/∂v at x (3n x 3n, symmetric, constant in v).
  SparseMatrix dfdv(const Vector& x) const;
  // The diagonal of M (3n: m_i three times).
  Vector mass_diagonal() const;

  // State, public so that callers can read and set it; sizes are kept consistent by add_node.
  Vector x;                          // positions, 3n
  Vector v;                          // velocities, 3n
  Eigen::VectorXd mass;              // n
  std::vector<std::uint8_t> pinned;  // n, nonzero = pinned
  std::vector<Spring> springs;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  // units / s²
  Damping damping = Damping::relative;
  double time = 0;  // seconds simulated (advanced by the integrators)
  long steps = 0;   // steps taken (advanced by the integrators)

 private:
  // Whether `a` describes the current springs and node count (a full check, O(springs)).
  bool adjacency_matches(const SpringAdjacency& a) const;
  detail::AdjacencyCache adjacency_;
};

// Mosegaard & Sørensen 2006 write the grid's spring force (their eq. 2) as k/2 times the
// stretch: their k is 2 ks.
inline double ks_from_mosegaard_k(double k) { return 0.5 * k; }

}  // namespace raywarp::physics
