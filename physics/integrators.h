// Time integrators for a MassSpring (physics/mass_spring.h), one step of size h (seconds) each
// (docs/physics.md writes every update out).
//
// - ExplicitEuler: x' = x + h v, v' = v + h a(x, v).
// - Verlet (position Verlet, Störmer): x' = 2x - x_prev + h² a(x, v), v' = (x' - x) / h. It keeps
//   x_prev between steps; on the first step, after a failed step, after a change of h or when
//   the caller changed a free node's position, it starts again from x_prev = x - h v + h²/2 a.
// - VelocityVerlet: x' = x + h v + h²/2 a(x, v), v_half = v + h/2 a(x, v),
//   v' = v_half + h/2 a(x', v_half) (the damping force is evaluated at v_half).
// - ImplicitEuler (Baraff & Witkin; Tejada & Ertl 2005 eq. 9 with eq. 4-5):
//   (M - h ∂f/∂v - h² ∂f/∂x) Δv = h (f + h (∂f/∂x) v), the matrix symmetrised ((A + Aᵀ)/2) with
//   ∂f/∂x clamped (compressed springs' transverse term dropped), restricted to the free nodes,
//   solved by Eigen's ConjugateGradient with the Jacobi (DiagonalPreconditioner) to a relative
//   residual `tolerance` within `max_iterations`; then v' = v + Δv, x' = x + h v'. With
//   newton_iterations > 1 it re-linearises at the new state (a Newton iteration towards the
//   fully implicit step M (v' - v) = h f(x + h v', v')), stopping early when the change of Δv is
//   below newton_tolerance times |Δv|.
// - LocalGlobal (Liu, Bargteil, O'Brien, Kavan 2013, "Fast simulation of mass-spring systems"):
//   minimises g(x) = ½ (x - y)ᵀ M (x - y) + h² Σ ks/2 (|x_i - x_j| - L)²
//                    + h Σ kd/2 |(x_i - x_j) - (x_n,i - x_n,j)|²,   y = x_n + h v_n + h² g,
//   by alternating a local step (each spring's d_s = L (x_i - x_j)/|x_i - x_j|) and a global
//   step ((M + h² L_ks + h L_kd) x = M y + h² J d + h L_kd x_n, one sparse LDLᵀ per set of
//   (h, springs, masses, pins), cached). Its minimiser is the fully implicit Euler step with
//   Damping::relative; v' = (x' - x_n) / h. Damping::along_spring with kd != 0 is refused.
//
// Every integrator: pinned nodes keep their position and get zero velocity. Work is spread over
// TBB's threads (systems of 4096 nodes or more) only as gathers by node or block row and sums in
// fixed chunks (physics/parallel.h), so two runs give identical bytes for any thread count.
// Implicit Euler keeps its matrix pattern (3 x 3 blocks over the free nodes) between steps and
// refills it; local/global orders its matrix by nested dissection, factorises it once per setting
// and solves x, y and z together in one pass over the factor. Integrator::step checks the new
// state: a non-finite value or a total energy above `energy_bound` leaves the system as it was
// before the step and returns a status naming the step; a solve that stops at its iteration cap
// is reported in StepResult (hit_cap), never silently.
#pragma once
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "physics/mass_spring.h"

namespace raywarp::physics {

namespace detail {
struct ImplicitWork;
struct LocalGlobalWork;
struct LdltFactor;
// Scratch and cached structure an integrator keeps between steps. A copy of the integrator starts
// without (its first step builds its own), so copies never share buffers.
template <class T>
class Scratch {
 public:
  Scratch() = default;
  Scratch(const Scratch&) {}
  Scratch& operator=(const Scratch&) {
    p_.reset();
    return *this;
  }
  T& get();  // creates it on first use (defined where T is complete)
  bool empty() const { return !p_; }

 private:
  std::shared_ptr<T> p_;
};
}  // namespace detail

enum class StepStatus { ok, non_finite, energy_above_bound, solver_failed };

struct StepResult {
  StepStatus status = StepStatus::ok;
  long step = 0;        // the index of this step (MassSpring::steps before it)
  std::string message;  // empty when ok: what failed, at which step and time
  // ImplicitEuler: CG iterations summed over its Newton iterations; LocalGlobal: local/global
  // iterations. Zero for the explicit integrators.
  int iterations = 0;
  int newton_iterations = 0;  // ImplicitEuler only
  // ImplicitEuler: the largest relative CG residual |b - A Δv| / |b| of the step's solves.
  // LocalGlobal: the largest position change of its last iteration (units).
  double residual = 0;
  bool hit_cap = false;  // a CG solve stopped at max_iterations above its tolerance
  // LocalGlobal with record_objective: g before the first iteration, then after each one.
  std::vector<double> objective;
  bool ok() const { return status == StepStatus::ok; }
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual const char* name() const = 0;
  // Advances `system` by h > 0 seconds. On failure the system keeps its state from before the
  // step (time and steps unchanged) and the result says why.
  StepResult step(MassSpring& system, double h);
  // Forgets state kept between steps (Verlet's previous positions).
  virtual void reset() {}

  double energy_bound = std::numeric_limits<double>::infinity();  // total energy, see Energy

 protected:
  virtual void advance(MassSpring& system, double h, StepResult& result) = 0;

 private:
  Vector x0_, v0_;  // the state before the step, restored on failure
};

// a = M⁻¹ f(x, v), zero on pinned nodes.
Vector accelerations(const MassSpring& system, const Vector& x, const Vector& v);
// The same into `a` (no allocation when it has the size already).
void accelerations(const MassSpring& system, const Vector& x, const Vector& v, Vector& a);

class ExplicitEuler : public Integrator {
 public:
  const char* name() const override { return "explicit Euler"; }

 protected:
  void advance(MassSpring& system, double h, StepResult& result) override;

 private:
  Vector a_;
};

class Verlet : public Integrator {
 public:
  const char* name() const override { return "Verlet"; }
  void reset() override { valid_ = false; }

 protected:
  void advance(MassSpring& system, double h, StepResult& result) override;

 private:
  bool valid_ = false;
  double h_ = 0;
  Vector x_prev_;
  Vector x_last_;  // the positions this integrator left, to notice a caller's change
  Vector a_, x_new_;
};

class VelocityVerlet : public Integrator {
 public:
  const char* name() const override { return "velocity Verlet"; }

 protected:
  void advance(MassSpring& system, double h, StepResult& result) override;

 private:
  Vector a_, v_half_;
};

class ImplicitEuler : public Integrator {
 public:
  const char* name() const override { return "implicit Euler"; }

  double tolerance = 1e-8;      // CG: relative residual |b - A Δv| / |b|
  int max_iterations = 1000;    // CG iteration cap per solve
  int newton_iterations = 1;    // 1: Baraff & Witkin's single linearised solve
  double newton_tolerance = 0;  // stop Newton when |Δv_k+1 - Δv_k| <= this · |Δv_k+1|
  bool clamp_compressed = true;

 protected:
  void advance(MassSpring& system, double h, StepResult& result) override;

 private:
  detail::Scratch<detail::ImplicitWork> work_;
};

class LocalGlobal : public Integrator {
 public:
  const char* name() const override { return "local/global"; }

  int iterations = 10;  // local/global iterations per step
  bool record_objective = false;

  // Sparse LDLᵀ factorisations done so far (one per new set of h, springs, masses, pins).
  long factorizations() const { return factorizations_; }
  // Factorises for `system` and h now if the next step would (a new set of h, springs, masses or
  // pins), so that a caller can time or schedule it apart; returns whether it factorised.
  bool prepare(const MassSpring& system, double h);
  // Entries of the factor's L below the diagonal (its fill); 0 before the first factorisation.
  long factor_nonzeros() const;
  // g(x) for the step from (x_n, v_n) of `system`'s masses, springs, pins and gravity (see
  // above; pinned nodes' inertia, a constant, left out).
  double objective(const MassSpring& system, const Vector& x_n, const Vector& v_n, const Vector& x,
                   double h) const;

 protected:
  void advance(MassSpring& system, double h, StepResult& result) override;

 private:
  struct Key {
    double h = 0;
    std::vector<Spring> springs;
    Eigen::VectorXd mass;
    std::vector<std::uint8_t> pinned;
  };
  bool key_matches(const MassSpring& system, double h) const;
  void factorise(const MassSpring& system, double h);

  long factorizations_ = 0;
  bool have_factor_ = false;
  Key key_;
  std::vector<int> free_index_;  // node -> row of the reduced system, -1 if pinned
  std::shared_ptr<const detail::LdltFactor> factor_;  // immutable once built; copies share it
  detail::Scratch<detail::LocalGlobalWork> work_;
};

}  // namespace raywarp::physics
