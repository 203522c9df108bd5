#include "physics/integrators.h"

#include <Eigen/IterativeLinearSolvers>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "base/error.h"

namespace raywarp::physics {

namespace {

std::string where(const MassSpring& s, double h) {
  std::ostringstream o;
  o.precision(9);
  o << "step " << s.steps << " (t = " << s.time << " s to " << s.time + h << " s)";
  return o.str();
}

// The first non-finite entry of x or v, as "position of node 3" or "" when all are finite.
std::string first_non_finite(const Vector& x, const Vector& v) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) return "position of node " + std::to_string(k / 3);
    if (!std::isfinite(v[k])) return "velocity of node " + std::to_string(k / 3);
  }
  return "";
}

// node -> row of the free-node system (-1 when pinned); returns the free count.
int free_rows(const MassSpring& s, std::vector<int>& index) {
  index.assign(s.nodes(), -1);
  int rows = 0;
  for (int i = 0; i < s.nodes(); ++i) {
    if (!s.is_pinned(i)) index[i] = rows++;
  }
  return rows;
}

}  // namespace

Vector accelerations(const MassSpring& s, const Vector& x, const Vector& v) {
  Vector a = s.forces(x, v);
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.is_pinned(i)) {
      a.segment<3>(3 * i).setZero();
    } else {
      a.segment<3>(3 * i) /= s.mass[i];
    }
  }
  return a;
}

StepResult Integrator::step(MassSpring& s, double h) {
  if (!(h > 0) || !std::isfinite(h)) {
    throw Error("physics: " + std::string(name()) + ": step " + std::to_string(h) +
                " s: must be finite and > 0");
  }
  StepResult r;
  r.step = s.steps;
  Vector x0 = s.x, v0 = s.v;
  try {
    advance(s, h, r);
  } catch (const Error& e) {
    s.x = x0;
    s.v = v0;
    reset();
    throw;
  }
  // Pins: whatever the update did, pinned nodes stay and have zero velocity.
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.is_pinned(i)) {
      s.x.segment<3>(3 * i) = x0.segment<3>(3 * i);
      s.v.segment<3>(3 * i).setZero();
    }
  }
  if (r.status == StepStatus::ok) {
    std::string bad = first_non_finite(s.x, s.v);
    if (!bad.empty()) {
      r.status = StepStatus::non_finite;
      r.message = std::string(name()) + ": " + where(s, h) + ": non-finite " + bad;
    } else if (std::isfinite(energy_bound)) {
      double e = s.energy().total();
      if (!(e <= energy_bound)) {
        std::ostringstream o;
        o << name() << ": " << where(s, h) << ": total energy " << e << " above the bound "
          << energy_bound;
        r.status = StepStatus::energy_above_bound;
        r.message = o.str();
      }
    }
  } else if (r.message.empty()) {
    r.message = std::string(name()) + ": " + where(s, h) + ": failed";
  }
  if (r.status != StepStatus::ok) {
    s.x = x0;
    s.v = v0;
    reset();
    return r;
  }
  s.steps += 1;
  s.time += h;
  return r;
}

// Explicit (forward) Euler: both updates from the state at the start of the step.
void ExplicitEuler::advance(MassSpring& s, double h, StepResult&) {
  Vector a = accelerations(s, s.x, s.v);
  s.x += h * s.v;
  s.v += h * a;
}

// Position Verlet: x' = 2x - x_prev + h² a(x, v), v' = (x' - x) / h.
void Verlet::advance(MassSpring& s, double h, StepResult&) {
  bool fresh = !valid_ || h != h_ || x_prev_.size() != s.x.size();
  if (!fresh) {
    for (int i = 0; i < s.nodes() && !fresh; ++i) {
      if (!s.is_pinned(i) && s.x.segment<3>(3 * i) != x_last_.segment<3>(3 * i)) fresh = true;
    }
  }
  Vector a = accelerations(s, s.x, s.v);
  if (fresh) {
    // Second-order Taylor step backwards: x(-h) = x - h v + h²/2 a (zero on pinned nodes).
    x_prev_ = s.x - h * s.v + (0.5 * h * h) * a;
  }
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.is_pinned(i)) x_prev_.segment<3>(3 * i) = s.x.segment<3>(3 * i);
  }
  Vector x_new = 2.0 * s.x - x_prev_ + (h * h) * a;
  s.v = (x_new - s.x) / h;
  x_prev_ = s.x;
  s.x = x_new;
  x_last_ = x_new;
  h_ = h;
  valid_ = true;
}

void VelocityVerlet::advance(MassSpring& s, double h, StepResult&) {
  Vector a = accelerations(s, s.x, s.v);
  Vector v_half = s.v + (0.5 * h) * a;
  s.x += h * v_half;  // = x + h v + h²/2 a
  Vector a_new = accelerations(s, s.x, v_half);
  s.v = v_half + (0.5 * h) * a_new;
}

void ImplicitEuler::advance(MassSpring& s, double h, StepResult& r) {
  std::vector<int> index;
  int rows3 = 3 * free_rows(s, index);
  auto row_of = [&](Eigen::Index k) -> int {
    int f = index[k / 3];
    return f < 0 ? -1 : 3 * f + static_cast<int>(k % 3);
  };
  const Vector x0 = s.x, v0 = s.v;
  Vector mdiag = s.mass_diagonal();
  Vector dv_full = Vector::Zero(s.x.size());  // Δv of the current Newton iterate
  int newton = std::max(1, newton_iterations);
  for (int it = 0; it < newton; ++it) {
    // Linearise f about (x̄, v̄): the start of the step for the first iteration (Baraff & Witkin),
    // then the current iterate x̄ = x0 + h (v0 + Δv), v̄ = v0 + Δv.
    Vector xb = it == 0 ? x0 : Vector(x0 + h * (v0 + dv_full));
    Vector vb = it == 0 ? v0 : Vector(v0 + dv_full);
    SparseMatrix K = s.dfdx(xb, clamp_compressed);
    SparseMatrix D = s.dfdv(xb);
    Vector f = s.forces(xb, vb);
    // rhs h (f̄ + K (x0 + h v0 - x̄) + D (v0 - v̄)): h (f + h K v0) on the first iteration,
    // h (f̄ - (h K + D) Δv) after.
    Vector b = it == 0 ? Vector(h * (f + h * (K * v0)))
                       : Vector(h * (f - (h * (K * dv_full) + D * dv_full)));
    SparseMatrix A = (-h) * D - (h * h) * K;
    SparseMatrix At = A.transpose();
    A = 0.5 * (A + At);
    // The free-node system: M on the diagonal plus A's free-free entries.
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(A.nonZeros() + rows3);
    for (Eigen::Index k = 0; k < mdiag.size(); ++k) {
      int rk = row_of(k);
      if (rk >= 0) t.emplace_back(rk, rk, mdiag[k]);
    }
    for (int c = 0; c < A.outerSize(); ++c) {
      int rc = row_of(c);
      if (rc < 0) continue;
      for (SparseMatrix::InnerIterator e(A, c); e; ++e) {
        int rr = row_of(e.row());
        if (rr >= 0) t.emplace_back(rr, rc, e.value());
      }
    }
    SparseMatrix Af(rows3, rows3);
    Af.setFromTriplets(t.begin(), t.end());
    Vector bf(rows3);
    for (Eigen::Index k = 0; k < b.size(); ++k) {
      int rk = row_of(k);
      if (rk >= 0) bf[rk] = b[k];
    }
    Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper,
                             Eigen::DiagonalPreconditioner<double>>
        cg;
    cg.setTolerance(tolerance);
    cg.setMaxIterations(max_iterations);
    cg.compute(Af);
    Vector dvf = cg.solve(bf);
    // Eigen counts the iterations that did not converge; count matrix-vector products instead
    // (one more when it converged on a non-zero right-hand side).
    bool converged = cg.info() == Eigen::Success;
    int iters = static_cast<int>(cg.iterations());
    if (converged && bf.squaredNorm() > 0) iters += 1;
    double res = bf.norm() > 0 ? (bf - Af * dvf).norm() / bf.norm() : 0.0;
    r.iterations += iters;
    r.residual = std::max(r.residual, res);
    if (!converged) r.hit_cap = true;
    r.newton_iterations = it + 1;
    Vector dv_new = Vector::Zero(s.x.size());
    for (Eigen::Index k = 0; k < dv_new.size(); ++k) {
      int rk = row_of(k);
      if (rk >= 0) dv_new[k] = dvf[rk];
    }
    double change = (dv_new - dv_full).norm();
    dv_full = dv_new;
    if (it > 0 && change <= newton_tolerance * dv_full.norm()) break;
  }
  s.v = v0 + dv_full;
  s.x = x0 + h * s.v;
}

double LocalGlobal::objective(const MassSpring& s, const Vector& x_n, const Vector& v_n,
                              const Vector& x, double h) const {
  double g = 0;
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.is_pinned(i)) continue;
    Eigen::Vector3d y = x_n.segment<3>(3 * i) + h * v_n.segment<3>(3 * i) + (h * h) * s.gravity;
    g += 0.5 * s.mass[i] * (x.segment<3>(3 * i) - y).squaredNorm();
  }
  for (const Spring& sp : s.springs) {
    Eigen::Vector3d e = x.segment<3>(3 * sp.i) - x.segment<3>(3 * sp.j);
    double stretch = e.norm() - sp.rest;
    g += h * h * 0.5 * sp.ks * stretch * stretch;
    if (sp.kd != 0) {
      Eigen::Vector3d en = x_n.segment<3>(3 * sp.i) - x_n.segment<3>(3 * sp.j);
      g += h * 0.5 * sp.kd * (e - en).squaredNorm();
    }
  }
  return g;
}

bool LocalGlobal::key_matches(const MassSpring& s, double h) const {
  if (!have_factor_ || key_.h != h || key_.springs.size() != s.springs.size() ||
      key_.pinned != s.pinned || key_.mass.size() != s.mass.size() || key_.mass != s.mass) {
    return false;
  }
  for (size_t k = 0; k < s.springs.size(); ++k) {
    const Spring &a = key_.springs[k], &b = s.springs[k];
    if (a.i != b.i || a.j != b.j || a.ks != b.ks || a.kd != b.kd) return false;
  }
  return true;
}

// (M + h² L_ks + h L_kd) restricted to the free nodes, one row per node (the same matrix for
// x, y and z), factorised once.
void LocalGlobal::factorise(const MassSpring& s, double h) {
  int rows = free_rows(s, free_index_);
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < s.nodes(); ++i) {
    if (free_index_[i] >= 0) t.emplace_back(free_index_[i], free_index_[i], s.mass[i]);
  }
  for (const Spring& sp : s.springs) {
    double w = h * h * sp.ks + h * sp.kd;
    int a = free_index_[sp.i], b = free_index_[sp.j];
    if (a >= 0) t.emplace_back(a, a, w);
    if (b >= 0) t.emplace_back(b, b, w);
    if (a >= 0 && b >= 0) {
      t.emplace_back(a, b, -w);
      t.emplace_back(b, a, -w);
    }
  }
  SparseMatrix A(rows, rows);
  A.setFromTriplets(t.begin(), t.end());
  factor_ = std::make_unique<Eigen::SimplicialLDLT<SparseMatrix>>();
  factor_->compute(A);
  if (factor_->info() != Eigen::Success) {
    have_factor_ = false;
    throw Error("physics: local/global: the factorisation of M + h² L failed");
  }
  factorizations_ += 1;
  key_ = Key{h, s.springs, s.mass, s.pinned};
  have_factor_ = true;
}

void LocalGlobal::advance(MassSpring& s, double h, StepResult& r) {
  if (s.damping != Damping::relative) {
    for (const Spring& sp : s.springs) {
      if (sp.kd != 0) {
        throw Error(
            "physics: local/global: damping along springs is not supported "
            "(use Damping::relative)");
      }
    }
  }
  if (!key_matches(s, h)) factorise(s, h);
  const Vector x_n = s.x, v_n = s.v;
  int rows = factor_->rows();
  // Inertial prediction y (pinned nodes stay) and the first iterate x = y.
  Vector x = x_n;
  Eigen::MatrixXd my(rows, 3);  // M y on the free rows, plus the damping's h L_kd x_n
  for (int i = 0; i < s.nodes(); ++i) {
    int a = free_index_[i];
    if (a < 0) continue;
    Eigen::Vector3d y = x_n.segment<3>(3 * i) + h * v_n.segment<3>(3 * i) + (h * h) * s.gravity;
    x.segment<3>(3 * i) = y;
    my.row(a) = s.mass[i] * y.transpose();
  }
  for (const Spring& sp : s.springs) {
    int a = free_index_[sp.i], b = free_index_[sp.j];
    if (sp.kd != 0) {
      Eigen::RowVector3d en =
          h * sp.kd * (x_n.segment<3>(3 * sp.i) - x_n.segment<3>(3 * sp.j)).transpose();
      if (a >= 0) my.row(a) += en;
      if (b >= 0) my.row(b) -= en;
    }
    // Springs to a pinned node: its fixed position moves to the right-hand side.
    double w = h * h * sp.ks + h * sp.kd;
    if (a >= 0 && b < 0) my.row(a) += w * x_n.segment<3>(3 * sp.j).transpose();
    if (b >= 0 && a < 0) my.row(b) += w * x_n.segment<3>(3 * sp.i).transpose();
  }
  if (record_objective) r.objective.push_back(objective(s, x_n, v_n, x, h));
  std::vector<Eigen::Vector3d> d(s.springs.size());
  for (size_t k = 0; k < s.springs.size(); ++k) {
    const Spring& sp = s.springs[k];
    Eigen::Vector3d e = x_n.segment<3>(3 * sp.i) - x_n.segment<3>(3 * sp.j);
    double l = e.norm();
    d[k] = l > 0 ? Eigen::Vector3d(sp.rest * e / l) : Eigen::Vector3d(sp.rest, 0, 0);
  }
  Eigen::MatrixXd rhs(rows, 3), sol(rows, 3);
  for (int it = 0; it < iterations; ++it) {
    // Local: the nearest spring vector of length L to each current one (kept if degenerate).
    for (size_t k = 0; k < s.springs.size(); ++k) {
      const Spring& sp = s.springs[k];
      Eigen::Vector3d e = x.segment<3>(3 * sp.i) - x.segment<3>(3 * sp.j);
      double l = e.norm();
      if (l > 0) d[k] = sp.rest * e / l;
    }
    // Global: (M + h² L_ks + h L_kd) x = M y + h L_kd x_n + h² J d (+ pinned neighbours).
    rhs = my;
    for (size_t k = 0; k < s.springs.size(); ++k) {
      const Spring& sp = s.springs[k];
      Eigen::RowVector3d jd = (h * h * sp.ks) * d[k].transpose();
      int a = free_index_[sp.i], b = free_index_[sp.j];
      if (a >= 0) rhs.row(a) += jd;
      if (b >= 0) rhs.row(b) -= jd;
    }
    sol = factor_->solve(rhs);
    double change = 0;
    for (int i = 0; i < s.nodes(); ++i) {
      int a = free_index_[i];
      if (a < 0) continue;
      Eigen::Vector3d p = sol.row(a).transpose();
      change = std::max(change, (p - x.segment<3>(3 * i)).cwiseAbs().maxCoeff());
      x.segment<3>(3 * i) = p;
    }
    r.residual = change;
    r.iterations = it + 1;
    if (record_objective) r.objective.push_back(objective(s, x_n, v_n, x, h));
  }
  s.v = (x - x_n) / h;
  s.x = x;
}

}  // namespace raywarp::physics
