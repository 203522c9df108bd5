#include "physics/integrators.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "base/error.h"
#include "physics/block_system.h"
#include "physics/ldlt.h"
#include "physics/parallel.h"

namespace raywarp::physics {

namespace detail {

struct ImplicitWork {
  BlockSystem a;
  std::vector<Sym3> k, d, c;  // per spring: ∂f_i/∂x_j, ∂f_i/∂v_j and h² k + h d
  Vector x0, v0, xb, vb, f, bf, dvf, dv, q;
};

struct LocalGlobalWork {
  Eigen::MatrixXd my, rhs;
  std::vector<Eigen::Vector3d> d;
  std::vector<double> y;
};

template <class T>
T& Scratch<T>::get() {
  if (!p_) p_ = std::make_shared<T>();
  return *p_;
}
template class Scratch<ImplicitWork>;
template class Scratch<LocalGlobalWork>;

}  // namespace detail

namespace {

std::string where(const MassSpring& s, double h) {
  std::ostringstream o;
  o.precision(9);
  o << "step " << s.steps << " (t = " << s.time << " s to " << s.time + h << " s)";
  return o.str();
}

// The first non-finite entry of x or v, as "position of node 3" or "" when all are finite.
std::string first_non_finite(const Vector& x, const Vector& v) {
  if (x.allFinite() && v.allFinite()) return "";
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
  Vector a;
  s.forces(x, v, a, true);
  return a;
}

void accelerations(const MassSpring& s, const Vector& x, const Vector& v, Vector& a) {
  s.forces(x, v, a, true);
}

StepResult Integrator::step(MassSpring& s, double h) {
  if (!(h > 0) || !std::isfinite(h)) {
    throw Error("physics: " + std::string(name()) + ": step " + std::to_string(h) +
                " s: must be finite and > 0");
  }
  StepResult r;
  r.step = s.steps;
  x0_ = s.x;
  v0_ = s.v;
  const Vector& x0 = x0_;
  const Vector& v0 = v0_;
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
  accelerations(s, s.x, s.v, a_);
  s.x += h * s.v;
  s.v += h * a_;
}

// Position Verlet: x' = 2x - x_prev + h² a(x, v), v' = (x' - x) / h.
void Verlet::advance(MassSpring& s, double h, StepResult&) {
  bool fresh = !valid_ || h != h_ || x_prev_.size() != s.x.size();
  if (!fresh) {
    for (int i = 0; i < s.nodes() && !fresh; ++i) {
      if (!s.is_pinned(i) && s.x.segment<3>(3 * i) != x_last_.segment<3>(3 * i)) fresh = true;
    }
  }
  accelerations(s, s.x, s.v, a_);
  if (fresh) {
    // Second-order Taylor step backwards: x(-h) = x - h v + h²/2 a (zero on pinned nodes).
    x_prev_ = s.x - h * s.v + (0.5 * h * h) * a_;
  }
  for (int i = 0; i < s.nodes(); ++i) {
    if (s.is_pinned(i)) x_prev_.segment<3>(3 * i) = s.x.segment<3>(3 * i);
  }
  x_new_ = 2.0 * s.x - x_prev_ + (h * h) * a_;
  s.v = (x_new_ - s.x) / h;
  x_prev_.swap(s.x);  // x_prev = x, x = x_new
  s.x = x_new_;
  x_last_ = x_new_;
  h_ = h;
  valid_ = true;
}

void VelocityVerlet::advance(MassSpring& s, double h, StepResult&) {
  accelerations(s, s.x, s.v, a_);
  v_half_ = s.v + (0.5 * h) * a_;
  s.x += h * v_half_;  // = x + h v + h²/2 a
  accelerations(s, s.x, v_half_, a_);
  s.v = v_half_ + (0.5 * h) * a_;
}

namespace {

// Per spring at positions x: k = ∂f_i/∂x_j (the block K of mass_spring.h, its transverse term
// clamped if asked; zero for a spring of zero length), d = ∂f_i/∂v_j (when `damped`), and
// c = h² k + h d, the spring's share of M - h ∂f/∂v - h² ∂f/∂x.
void spring_blocks(const MassSpring& s, const Vector& x, bool clamp, bool damped, double h,
                   detail::ImplicitWork& w) {
  const std::ptrdiff_t m = static_cast<std::ptrdiff_t>(s.springs.size());
  w.k.resize(m);
  w.c.resize(m);
  if (damped) w.d.resize(m);
  detail::for_each_index(m, 1024, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
    for (std::ptrdiff_t q = b; q < e; ++q) {
      const Spring& sp = s.springs[q];
      Eigen::Vector3d dx = x.segment<3>(3 * sp.i) - x.segment<3>(3 * sp.j);
      const double l = dx.norm();
      Eigen::Matrix3d kb = Eigen::Matrix3d::Zero(), db = Eigen::Matrix3d::Zero();
      Eigen::Vector3d u = Eigen::Vector3d::Zero();
      if (l > 0) {
        u = dx / l;
        Eigen::Matrix3d uu = u * u.transpose();
        double transverse = 1.0 - sp.rest / l;
        if (clamp && transverse < 0) transverse = 0;
        kb = sp.ks * uu + sp.ks * transverse * (Eigen::Matrix3d::Identity() - uu);
      }
      if (damped && sp.kd != 0) {
        if (s.damping == Damping::relative) {
          db = sp.kd * Eigen::Matrix3d::Identity();
        } else if (l > 0) {
          db = sp.kd * u * u.transpose();
        }
      }
      auto sym = [](const Eigen::Matrix3d& a) {
        return detail::Sym3{a(0, 0), a(0, 1), a(0, 2), a(1, 1), a(1, 2), a(2, 2)};
      };
      w.k[q] = sym(kb);
      if (damped) w.d[q] = sym(db);
      w.c[q] = sym((h * h) * kb + h * db);
    }
  });
}

// Σ over node i's springs of B_s (w_o - w_i): the i rows of the full matrix (∂f/∂x or ∂f/∂v)
// times w.
Eigen::Vector3d spring_product(const SpringAdjacency& a, const std::vector<detail::Sym3>& blocks,
                               const Vector& w, int i) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const Eigen::Vector3d wi = w.segment<3>(3 * i);
  for (int k = a.start[i]; k < a.start[i + 1]; ++k) {
    const detail::Sym3& b = blocks[a.spring[k]];
    const Eigen::Vector3d dw = w.segment<3>(3 * a.other[k]) - wi;
    sum += Eigen::Vector3d(b.xx * dw[0] + b.xy * dw[1] + b.xz * dw[2],
                           b.xy * dw[0] + b.yy * dw[1] + b.yz * dw[2],
                           b.xz * dw[0] + b.yz * dw[1] + b.zz * dw[2]);
  }
  return sum;
}

double norm(const Vector& v) { return std::sqrt(detail::dot(v, v)); }

}  // namespace

void ImplicitEuler::advance(MassSpring& s, double h, StepResult& r) {
  detail::ImplicitWork& w = work_.get();
  const std::shared_ptr<const SpringAdjacency> adj = s.adjacency();
  w.a.prepare(s, adj);
  const int rows = w.a.rows();
  bool damped = false;
  for (const Spring& sp : s.springs) damped = damped || sp.kd != 0;
  w.x0 = s.x;
  w.v0 = s.v;
  const Vector &x0 = w.x0, &v0 = w.v0;
  w.dv.setZero(s.x.size());  // Δv of the current Newton iterate
  w.bf.resize(3 * rows);
  int newton = std::max(1, newton_iterations);
  for (int it = 0; it < newton; ++it) {
    // Linearise f about (x̄, v̄): the start of the step for the first iteration (Baraff & Witkin),
    // then the current iterate x̄ = x0 + h (v0 + Δv), v̄ = v0 + Δv.
    if (it > 0) {
      w.vb = v0 + w.dv;
      w.xb = x0 + h * w.vb;
    }
    const Vector& xb = it == 0 ? x0 : w.xb;
    const Vector& vb = it == 0 ? v0 : w.vb;
    spring_blocks(s, xb, clamp_compressed, damped, h, w);
    s.forces(xb, vb, w.f);
    // rhs h (f̄ + K (x0 + h v0 - x̄) + D (v0 - v̄)): h (f + h K v0) on the first iteration,
    // h (f̄ - (h K + D) Δv) after; on the free rows.
    detail::for_each_index(rows, 256, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      for (std::ptrdiff_t row = b; row < e; ++row) {
        const int i = w.a.node(static_cast<int>(row));
        Eigen::Vector3d fi = w.f.segment<3>(3 * i), out;
        if (it == 0) {
          out = h * (fi + h * spring_product(*adj, w.k, v0, i));
        } else {
          Eigen::Vector3d kd = h * spring_product(*adj, w.k, w.dv, i);
          if (damped) kd += spring_product(*adj, w.d, w.dv, i);
          out = h * (fi - kd);
        }
        w.bf.segment<3>(3 * row) = out;
      }
    });
    w.a.fill(s, w.c);
    detail::BlockSystem::CgResult cg = w.a.solve(w.bf, w.dvf, tolerance, max_iterations);
    double bnorm = norm(w.bf), res = 0;
    if (bnorm > 0) {
      w.a.multiply(w.dvf, w.q);
      w.q = w.bf - w.q;
      res = norm(w.q) / bnorm;
    }
    r.iterations += cg.products;
    r.residual = std::max(r.residual, res);
    if (!cg.converged) r.hit_cap = true;
    r.newton_iterations = it + 1;
    // Δv on every node (zero on pinned ones) and its change.
    w.q.setZero(s.x.size());
    for (int row = 0; row < rows; ++row)
      w.q.segment<3>(3 * w.a.node(row)) = w.dvf.segment<3>(3 * row);
    w.q.swap(w.dv);  // dv = the new Δv, q = the old one
    w.q -= w.dv;
    double change = norm(w.q);
    if (it > 0 && change <= newton_tolerance * norm(w.dv)) break;
  }
  s.v = v0 + w.dv;
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
// x, y and z), ordered by nested dissection of the nodes' current positions and factorised once.
void LocalGlobal::factorise(const MassSpring& s, double h) {
  int rows = free_rows(s, free_index_);
  std::vector<Eigen::Triplet<double>> t;
  std::vector<Eigen::Vector3d> pos(rows);
  for (int i = 0; i < s.nodes(); ++i) {
    if (free_index_[i] >= 0) {
      t.emplace_back(free_index_[i], free_index_[i], s.mass[i]);
      pos[free_index_[i]] = s.position(i);
    }
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
  have_factor_ = false;
  factor_ = detail::ldlt_factor(A, pos);
  factorizations_ += 1;
  key_ = Key{h, s.springs, s.mass, s.pinned};
  have_factor_ = true;
}

bool LocalGlobal::prepare(const MassSpring& s, double h) {
  if (key_matches(s, h)) return false;
  factorise(s, h);
  return true;
}

long LocalGlobal::factor_nonzeros() const { return factor_ ? factor_->nonzeros() : 0; }

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
  detail::LocalGlobalWork& w = work_.get();
  const std::shared_ptr<const SpringAdjacency> adj = s.adjacency();
  const Vector x_n = s.x, v_n = s.v;
  const int rows = factor_->n;
  std::vector<int> node_of_row(rows);
  for (int i = 0; i < s.nodes(); ++i) {
    if (free_index_[i] >= 0) node_of_row[free_index_[i]] = i;
  }
  // Inertial prediction y (pinned nodes stay) and the first iterate x = y; M y on the free rows
  // plus the damping's h L_kd x_n and the pinned neighbours' terms, gathered per node in spring
  // order (the bits of a serial loop over the springs).
  Vector x = x_n;
  w.my.resize(rows, 3);
  detail::for_each_index(rows, 256, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
    for (std::ptrdiff_t a = b; a < e; ++a) {
      const int i = node_of_row[a];
      Eigen::Vector3d y = x_n.segment<3>(3 * i) + h * v_n.segment<3>(3 * i) + (h * h) * s.gravity;
      x.segment<3>(3 * i) = y;
      Eigen::RowVector3d row = s.mass[i] * y.transpose();
      for (int k = adj->start[i]; k < adj->start[i + 1]; ++k) {
        const Spring& sp = s.springs[adj->spring[k]];
        const int o = adj->other[k];
        if (sp.kd != 0) {
          Eigen::RowVector3d en =
              h * sp.kd * (x_n.segment<3>(3 * sp.i) - x_n.segment<3>(3 * sp.j)).transpose();
          if (sp.i == i) {
            row += en;
          } else {
            row -= en;
          }
        }
        if (free_index_[o] < 0) {
          double wk = h * h * sp.ks + h * sp.kd;
          row += wk * x_n.segment<3>(3 * o).transpose();
        }
      }
      w.my.row(a) = row;
    }
  });
  if (record_objective) r.objective.push_back(objective(s, x_n, v_n, x, h));
  const std::ptrdiff_t m = static_cast<std::ptrdiff_t>(s.springs.size());
  w.d.resize(m);
  detail::for_each_index(m, 1024, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
    for (std::ptrdiff_t k = b; k < e; ++k) {
      const Spring& sp = s.springs[k];
      Eigen::Vector3d v = x_n.segment<3>(3 * sp.i) - x_n.segment<3>(3 * sp.j);
      double l = v.norm();
      w.d[k] = l > 0 ? Eigen::Vector3d(sp.rest * v / l) : Eigen::Vector3d(sp.rest, 0, 0);
    }
  });
  w.rhs.resize(rows, 3);
  for (int it = 0; it < iterations; ++it) {
    // Local: the nearest spring vector of length L to each current one (kept if degenerate).
    detail::for_each_index(m, 1024, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      for (std::ptrdiff_t k = b; k < e; ++k) {
        const Spring& sp = s.springs[k];
        Eigen::Vector3d v = x.segment<3>(3 * sp.i) - x.segment<3>(3 * sp.j);
        double l = v.norm();
        if (l > 0) w.d[k] = sp.rest * v / l;
      }
    });
    // Global: (M + h² L_ks + h L_kd) x = M y + h L_kd x_n + h² J d (+ pinned neighbours),
    // J d gathered per node in spring order.
    detail::for_each_index(rows, 256, [&](std::ptrdiff_t b, std::ptrdiff_t e) {
      for (std::ptrdiff_t a = b; a < e; ++a) {
        const int i = node_of_row[a];
        Eigen::RowVector3d row = w.my.row(a);
        for (int k = adj->start[i]; k < adj->start[i + 1]; ++k) {
          const int q = adj->spring[k];
          const Spring& sp = s.springs[q];
          Eigen::RowVector3d jd = (h * h * sp.ks) * w.d[q].transpose();
          if (sp.i == i) {
            row += jd;
          } else {
            row -= jd;
          }
        }
        w.rhs.row(a) = row;
      }
    });
    detail::ldlt_solve3(*factor_, w.rhs, w.y);
    double change = 0;
    for (int a = 0; a < rows; ++a) {
      const int i = node_of_row[a];
      Eigen::Vector3d p = w.rhs.row(a).transpose();
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
