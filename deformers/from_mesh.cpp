#include "deformers/from_mesh.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>

#include "base/error.h"
#include "base/parallel.h"
#include "deformers/registry.h"
#include "deformers/simulation.h"
#include "deformers/turn_paths.h"

namespace raywarp {

namespace {

constexpr const char* kStage = "from mesh fit";
constexpr int kCoarsest = 4;         // cells along every side of the coarsest lattice, at most
constexpr int kMaxIterations = 200;  // conjugate gradient iterations
constexpr double kSourceTolerance = 1e-9;  // of the box diagonal: a source that far out is moved in
constexpr double kEpsilon = 1e-10;         // eps, of R's largest diagonal entry
// Below this least spread of the sources (the smallest eigenvalue of their scatter, over the
// lattice's nodes and the box diagonal squared) the cycle runs in double (see make_from_mesh).
constexpr double kFlatSpread = 1e-9;
// Pairs that turn more than this (radians, about the line they turn about: deformers/turn_paths.h)
// are fitted in steps of at most kTurnStep (fit_pairs).
constexpr double kTurnThreshold = 1.75;
constexpr double kTurnStep = 0.75;

std::string mib_text(std::size_t bytes) {
  return std::to_string((bytes + (std::size_t(1) << 19)) >> 20) + " MiB";
}

// The trilinear weight of corner c of a point's cell (corner c at offset (c & 1, c >> 1 & 1,
// c >> 2)), f the point's coordinates in the cell.
double corner_weight(const Eigen::Vector3d& f, int c) {
  return ((c & 1) ? f.x() : 1.0 - f.x()) * ((c & 2) ? f.y() : 1.0 - f.y()) *
         ((c & 4) ? f.z() : 1.0 - f.z());
}
Eigen::Vector3i corner_offset(int c) { return Eigen::Vector3i(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

// A lattice of the multigrid hierarchy: level 0 is the deformer's; each next one has half the
// cells (rounded up, so that it covers the one below: it may reach one cell of that one beyond
// the box) and twice the spacing.
struct Grid {
  Eigen::Vector3i cells = Eigen::Vector3i::Ones(), nodes = Eigen::Vector3i::Ones();
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();
  long count = 0;  // nodes

  long index(int i, int j, int k) const {
    return i + static_cast<long>(nodes.x()) * (j + static_cast<long>(nodes.y()) * k);
  }
  long index(const Eigen::Vector3i& q) const { return index(q.x(), q.y(), q.z()); }
  Eigen::Vector3i node_of(long n) const {
    return Eigen::Vector3i(static_cast<int>(n % nodes.x()),
                           static_cast<int>((n / nodes.x()) % nodes.y()),
                           static_cast<int>(n / (static_cast<long>(nodes.x()) * nodes.y())));
  }
  // The cell holding p (box frame, in the box) and p's coordinates in it:
  // LatticeDeformer::locate's rule, so that the fit weighs the pairs as the deformer reads u.
  void locate(const Eigen::Vector3d& h, const Eigen::Vector3d& p, Eigen::Vector3i& cell,
              Eigen::Vector3d& f) const {
    const Eigen::Vector3d u = (p + h).cwiseQuotient(spacing);
    for (int a = 0; a < 3; ++a) {
      cell[a] = std::clamp(static_cast<int>(std::floor(u[a])), 0, cells[a] - 1);
      f[a] = u[a] - cell[a];
    }
  }
};

// The lattice of `cells` cells of side `spacing`.
Grid lattice_grid(const Eigen::Vector3i& cells, const Eigen::Vector3d& spacing) {
  Grid g;
  g.cells = cells;
  g.spacing = spacing;
  g.nodes = cells + Eigen::Vector3i::Ones();
  g.count = static_cast<long>(g.nodes.prod());
  return g;
}

// The multigrid's lattices, the finest first, each halving the last's cells, down to kCoarsest.
std::vector<Grid> hierarchy(const Eigen::Vector3i& cells, const Eigen::Vector3d& spacing) {
  std::vector<Grid> grids{lattice_grid(cells, spacing)};
  while (grids.back().cells.maxCoeff() > kCoarsest) {
    Eigen::Vector3i coarser;
    for (int a = 0; a < 3; ++a) coarser[a] = (grids.back().cells[a] + 1) / 2;
    grids.push_back(lattice_grid(coarser, 2.0 * grids.back().spacing));
  }
  return grids;
}

// The weight of node `at` in row q of the smoothness energy's matrix on grid g (before R's
// factor): the sum, over the difference terms that hold both, of the term's weight times their
// coefficients. `pure` weighs the second differences along an axis (thin plate).
double smoothness_coefficient(FromMeshSmoothing smoothing, const Grid& g, const Eigen::Vector3i& q,
                              const Eigen::Vector3i& at, double pure) {
  const Eigen::Vector3d& s = g.spacing;
  const double volume = s.prod();
  auto value = [&](const Eigen::Vector3i& n) { return n == at ? 1.0 : 0.0; };
  double out = 0.0;
  if (smoothing == FromMeshSmoothing::membrane) {
    // Over the lattice edges: V ((u_j - u_i) / s_a)^2.
    for (int a = 0; a < 3; ++a)
      for (int side = -1; side <= 1; side += 2) {
        Eigen::Vector3i n = q;
        n[a] += side;
        if (n[a] < 0 || n[a] > g.cells[a]) continue;
        out += volume / (s[a] * s[a]) * (value(q) - value(n));
      }
    return out;
  }
  // Second differences along a at the nodes j with both neighbours: V ((u_{j+a} - 2 u_j +
  // u_{j-a}) / s_a^2)^2.
  for (int a = 0; a < 3; ++a) {
    const double inv = 1.0 / (s[a] * s[a]);
    for (int dj = -1; dj <= 1; ++dj) {
      Eigen::Vector3i j = q;
      j[a] += dj;
      if (j[a] < 1 || j[a] > g.cells[a] - 1) continue;
      Eigen::Vector3i lo = j, hi = j;
      --lo[a];
      ++hi[a];
      const double d = inv * (value(hi) - 2.0 * value(j) + value(lo));
      out += pure * volume * (dj == 0 ? -2.0 * inv : inv) * d;
    }
  }
  // Mixed differences over the lattice squares in the plane (a, b), lower corner j: 2 V ((u_j -
  // u_{j+a} - u_{j+b} + u_{j+a+b}) / (s_a s_b))^2.
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b) {
      const double inv = 1.0 / (s[a] * s[b]);
      for (int da = -1; da <= 0; ++da)
        for (int db = -1; db <= 0; ++db) {
          Eigen::Vector3i j = q;
          j[a] += da;
          j[b] += db;
          if (j[a] < 0 || j[a] > g.cells[a] - 1 || j[b] < 0 || j[b] > g.cells[b] - 1) continue;
          Eigen::Vector3i ja = j, jb = j, jab = j;
          ++ja[a];
          ++jb[b];
          ++jab[a];
          ++jab[b];
          const double d = inv * (value(j) - value(ja) - value(jb) + value(jab));
          const double sign = da == db ? 1.0 : -1.0;  // q is the corner (0, 0) or (1, 1)
          out += 2.0 * volume * sign * inv * d;
        }
    }
  return out;
}

// What a fit solves for.
struct Problem {
  Eigen::Vector3d h;
  FromMeshParams params;
  const std::vector<Eigen::Vector3d>* sources;  // in the box
  const std::vector<Eigen::Vector3d>* displacements;
  std::vector<Grid> grids;
  std::vector<long> touched;  // per grid: the nodes of the cells that hold sources
  // The pairs' affine fit a(p) = mean_d + gradient (p - mean_s).
  Eigen::Vector3d mean_s, mean_d;
  Eigen::Matrix3d gradient;
};

// The solver's memory: per node, its flags, data row slot, Jacobi's diagonal and the cycle's four
// vectors on every level, with conjugate gradients' five (double) on level 0; per touched node a
// data row in double (level 0 keeps it) and one in the cycle's precision; the sources and
// displacements; 4 MiB and 2 % for the rest (measured: 443 MiB for an estimate of 437 before).
std::size_t solver_bytes(const Problem& p, std::size_t real) {
  std::size_t bytes = (std::size_t(4) << 20) + p.sources->size() * 2 * sizeof(Eigen::Vector3d);
  for (size_t li = 0; li < p.grids.size(); ++li) {
    bytes += static_cast<std::size_t>(p.grids[li].count) *
             (1 + sizeof(int) + real + 4 * 3 * real + (li == 0 ? 5 * 3 * sizeof(double) : 0));
    if (li < p.touched.size())
      bytes += static_cast<std::size_t>(p.touched[li]) * 27 * (sizeof(double) + real);
  }
  return bytes + bytes / 50;
}

// The normal equations A u = B^T d + eps a, A = B^T B + R + eps I, on level 0 of the hierarchy,
// by conjugate gradients in double preconditioned by a multigrid W-cycle in `Real`. Each level
// has its own rows of A in `Real` (level 0 also in double). Every level is stored whole, the
// pinned nodes included (held at 0, their rows zero), three values per node, x fastest.
template <typename Real>
class Solver {
 public:
  Solver(const Problem& problem, Interrupter* interrupter)
      : p_(problem), interrupter_(interrupter) {
    build();
  }

  struct Result {
    std::vector<double> u;  // 3 per node of level 0
    int iterations = 0;
    double relative_residual = 0;
  };
  Result solve();

 private:
  struct Level : Grid {
    double eps = 0;                   // the identity's weight
    double lambda_max = 1;            // Gershgorin's bound of the eigenvalues of D^-1 A
    std::vector<std::uint8_t> fixed;  // per node: held at u = 0
    // The rows of R by class. A node's class along an axis is its distance to either end of the
    // lattice, each capped at `reach` (no difference term reaches farther), so the nodes of a
    // class share their row: its entries (node index offset, weight).
    int reach = 2;
    std::array<std::vector<int>, 3> axis_class;  // per axis, per node coordinate
    std::vector<long> class_start;               // per class, its first entry; one more at the end
    std::vector<long> entry_offset;
    std::vector<double> weight;
    std::vector<Real> weight_r;
    // B^T B: the nodes of the cells that hold sources have a row over their 27 neighbours,
    // (dx + 1) + 3 (dy + 1) + 9 (dz + 1).
    std::vector<int> slot;  // per node: its row, or -1
    std::vector<std::array<double, 27>> data;
    std::vector<std::array<Real, 27>> data_r;
    std::vector<Real> inv_diag;          // per node: 1 / A_nn, 0 on a fixed node
    std::vector<Real> x, b, r, d;        // the cycle's vectors
    Eigen::LDLT<Eigen::MatrixXd> dense;  // the coarsest: A over its free nodes
    std::vector<long> free_nodes;

    int axis_classes() const { return (reach + 1) * (reach + 1); }
    int class_of(int i, int j, int k) const {
      return axis_class[0][i] +
             axis_classes() * (axis_class[1][j] + axis_classes() * axis_class[2][k]);
    }
    long offset27(int o) const {
      return (o % 3 - 1) + static_cast<long>(nodes.x()) * ((o / 3) % 3 - 1) +
             static_cast<long>(nodes.x()) * nodes.y() * (o / 9 - 1);
    }
    // The rows in double (conjugate gradients) or in the cycle's precision.
    template <bool exact>
    const auto& weights() const {
      if constexpr (exact)
        return weight;
      else
        return weight_r;
    }
    template <bool exact>
    const auto& data_rows() const {
      if constexpr (exact)
        return data;
      else
        return data_r;
    }
  };

  // parallel_for over the slices of a level, polling the interrupter (without a report: the
  // fit reports its progress by conjugate gradients' residual).
  template <typename Body>
  void slices(long count, const Body& body) const {
    parallel_for(count, [&](long k) {
      poll(interrupter_);
      body(k);
    });
  }

  void build();
  void build_level(size_t li, std::array<std::vector<std::uint8_t>, 3>& fixed_planes);

  template <typename Body>
  void for_nodes(const Level& l, const Body& body) const {
    const long slice = static_cast<long>(l.nodes.x()) * l.nodes.y();
    slices(l.nodes.z(), [&](long k) {
      for (long n = k * slice; n < (k + 1) * slice; ++n) body(n);
    });
  }
  // Per component sums of term(n) over the nodes, in a fixed order (the same on any number of
  // threads).
  template <typename Term>
  Eigen::Vector3d sum_nodes(const Level& l, const Term& term) const {
    const long slice = static_cast<long>(l.nodes.x()) * l.nodes.y();
    std::vector<Eigen::Vector3d> partial(l.nodes.z(), Eigen::Vector3d::Zero());
    slices(l.nodes.z(), [&](long k) {
      Eigen::Vector3d s = Eigen::Vector3d::Zero();
      for (long n = k * slice; n < (k + 1) * slice; ++n) s += term(n);
      partial[k] = s;
    });
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& s : partial) total += s;
    return total;
  }

  // Calls out(n, (A x)_n) for every node, a row of nodes along x at a time (slices in parallel):
  // the run of interior nodes entry by entry (loops the compiler vectorises), the others node by
  // node with their class's entries, then the data rows.
  template <bool exact, typename T, typename Out>
  void rows(const Level& l, const T* x, const Out& out) const {
    const auto& weight = l.template weights<exact>();
    const auto& data = l.template data_rows<exact>();
    const int middle = l.reach * (l.reach + 1) + l.reach;  // the axis class of an interior node
    const T eps = static_cast<T>(l.eps);
    slices(l.nodes.z(), [&](long kk) {
      const int k = static_cast<int>(kk), nx = l.nodes.x();
      std::vector<T> acc(static_cast<size_t>(3 * nx));
      for (int j = 0; j < l.nodes.y(); ++j) {
        const long first = l.index(0, j, k);
        const T* xr = x + 3 * first;
        for (int t = 0; t < 3 * nx; ++t) acc[t] = eps * xr[t];
        const int cls_jk = l.class_of(0, j, k) - l.axis_class[0][0];
        int lo = nx, hi = nx;
        if (nx > 2 * l.reach) {
          lo = l.reach;
          hi = nx - l.reach;
          const int cls = cls_jk + middle;
          for (long e = l.class_start[cls]; e < l.class_start[cls + 1]; ++e) {
            const T w = weight[e];
            const T* src = xr + 3 * l.entry_offset[e];
            T* dst = acc.data();
            for (int t = 3 * lo; t < 3 * hi; ++t) dst[t] += w * src[t];
          }
        }
        for (int i = 0; i < nx; ++i) {
          if (i == lo) i = hi;
          if (i >= nx) break;
          const int cls = cls_jk + l.axis_class[0][i];
          T* a = acc.data() + 3 * i;
          for (long e = l.class_start[cls]; e < l.class_start[cls + 1]; ++e) {
            const T w = weight[e];
            const T* v = xr + 3 * (i + l.entry_offset[e]);
            a[0] += w * v[0];
            a[1] += w * v[1];
            a[2] += w * v[2];
          }
        }
        for (int i = 0; i < nx; ++i) {
          const long n = first + i;
          T* a = acc.data() + 3 * i;
          if (l.fixed[n]) {
            a[0] = a[1] = a[2] = T(0);
          } else if (l.slot[n] >= 0) {
            const auto& row = data[l.slot[n]];
            for (int o = 0; o < 27; ++o)
              if (row[o] != T(0)) {
                const T* v = x + 3 * (n + l.offset27(o));
                a[0] += row[o] * v[0];
                a[1] += row[o] * v[1];
                a[2] += row[o] * v[2];
              }
          }
          out(n, a);
        }
      }
    });
  }
  // y = A x, in double (exact) or in the cycle's precision.
  template <bool exact, typename T>
  void apply(const Level& l, const T* x, T* y) const {
    rows<exact>(l, x, [&](long n, const T* ax) {
      for (int c = 0; c < 3; ++c) y[3 * n + c] = ax[c];
    });
  }
  // r = b - A x, in the cycle's precision.
  void residual(const Level& l, const Real* b, const Real* x, Real* r) const {
    rows<false>(l, x, [&](long n, const Real* ax) {
      for (int c = 0; c < 3; ++c) r[3 * n + c] = b[3 * n + c] - ax[c];
    });
  }

  // x = M b from level li: pre-smoothing, two visits of the level above (a W-cycle; one when it
  // is the coarsest, which is solved), post-smoothing.
  void cycle(size_t li, const Real* b, Real* x) {
    Level& l = levels_[li];
    const long m = 3 * l.count;
    std::fill(x, x + m, Real(0));
    if (li + 1 == levels_.size()) {
      const long f = static_cast<long>(l.free_nodes.size());
      if (f == 0) return;
      Eigen::MatrixXd rhs(f, 3);
      for (long i = 0; i < f; ++i)
        for (int c = 0; c < 3; ++c) rhs(i, c) = b[3 * l.free_nodes[i] + c];
      const Eigen::MatrixXd sol = l.dense.solve(rhs);
      for (long i = 0; i < f; ++i)
        for (int c = 0; c < 3; ++c) x[3 * l.free_nodes[i] + c] = static_cast<Real>(sol(i, c));
      return;
    }
    smooth(l, b, x, true);
    Level& coarse = levels_[li + 1];
    const int visits = li + 2 < levels_.size() ? 2 : 1;
    for (int visit = 0; visit < visits; ++visit) {
      residual(l, b, x, l.r.data());
      restrict_to(l, l.r.data(), coarse);
      cycle(li + 1, coarse.b.data(), coarse.x.data());
      prolong_add(coarse, l, x);
    }
    smooth(l, b, x, false);
  }

  // Two steps of Chebyshev's iteration for D^-1 A over [lambda_max / 30, lambda_max]: a fixed
  // polynomial in D^-1 A, so the cycle stays symmetric. `zero`: x = 0 on entry.
  void smooth(Level& l, const Real* b, Real* x, bool zero) {
    constexpr int kDegree = 2;
    constexpr double kRatio = 30.0;
    Real* r = l.r.data();
    Real* d = l.d.data();
    if (zero)
      std::copy(b, b + 3 * l.count, r);
    else
      residual(l, b, x, r);
    const double upper = l.lambda_max, lower = upper / kRatio;
    const double theta = 0.5 * (upper + lower), delta = 0.5 * (upper - lower);
    const double sigma = theta / delta;
    double rho = 1.0 / sigma;
    const Real first = static_cast<Real>(1.0 / theta);
    for_nodes(l, [&](long n) {
      for (int c = 0; c < 3; ++c) {
        d[3 * n + c] = first * l.inv_diag[n] * r[3 * n + c];
        x[3 * n + c] += d[3 * n + c];
      }
    });
    for (int k = 1; k < kDegree; ++k) {
      residual(l, b, x, r);
      const double rho_next = 1.0 / (2.0 * sigma - rho);
      const Real keep = static_cast<Real>(rho_next * rho);
      const Real push = static_cast<Real>(2.0 * rho_next / delta);
      for_nodes(l, [&](long n) {
        for (int c = 0; c < 3; ++c) {
          d[3 * n + c] = keep * d[3 * n + c] + push * l.inv_diag[n] * r[3 * n + c];
          x[3 * n + c] += d[3 * n + c];
        }
      });
      rho = rho_next;
    }
  }

  // coarse.b = P^T r, P the trilinear prolongation from the coarse lattice; 0 on fixed nodes.
  void restrict_to(const Level& fine, const Real* r, Level& coarse) const {
    Real* b = coarse.b.data();
    slices(coarse.nodes.z(), [&](long kk) {
      const int k = static_cast<int>(kk);
      for (int j = 0; j < coarse.nodes.y(); ++j)
        for (int i = 0; i < coarse.nodes.x(); ++i) {
          const long n = coarse.index(i, j, k);
          Real acc[3] = {Real(0), Real(0), Real(0)};
          if (!coarse.fixed[n])
            for (int dz = -1; dz <= 1; ++dz) {
              const int fz = 2 * k + dz;
              if (fz < 0 || fz > fine.cells.z()) continue;
              const Real wz = dz == 0 ? Real(1) : Real(0.5);
              for (int dy = -1; dy <= 1; ++dy) {
                const int fy = 2 * j + dy;
                if (fy < 0 || fy > fine.cells.y()) continue;
                const Real wy = wz * (dy == 0 ? Real(1) : Real(0.5));
                for (int dx = -1; dx <= 1; ++dx) {
                  const int fx = 2 * i + dx;
                  if (fx < 0 || fx > fine.cells.x()) continue;
                  const Real w = wy * (dx == 0 ? Real(1) : Real(0.5));
                  const Real* v = r + 3 * fine.index(fx, fy, fz);
                  for (int c = 0; c < 3; ++c) acc[c] += w * v[c];
                }
              }
            }
          for (int c = 0; c < 3; ++c) b[3 * n + c] = acc[c];
        }
    });
  }

  // x += P coarse.x, except on fixed nodes.
  void prolong_add(const Level& coarse, const Level& fine, Real* x) const {
    const Real* cx = coarse.x.data();
    slices(fine.nodes.z(), [&](long kk) {
      const int k = static_cast<int>(kk);
      for (int j = 0; j < fine.nodes.y(); ++j)
        for (int i = 0; i < fine.nodes.x(); ++i) {
          const long n = fine.index(i, j, k);
          if (fine.fixed[n]) continue;
          const Eigen::Vector3i q(i, j, k);
          Real acc[3] = {Real(0), Real(0), Real(0)};
          for (int c = 0; c < 8; ++c) {
            Eigen::Vector3i at;
            for (int a = 0; a < 3; ++a) at[a] = (q[a] + ((c >> a) & 1)) / 2;
            const Real* v = cx + 3 * coarse.index(at);
            for (int t = 0; t < 3; ++t) acc[t] += v[t];
          }
          for (int t = 0; t < 3; ++t) x[3 * n + t] += Real(0.125) * acc[t];
        }
    });
  }

  const Problem& p_;
  Interrupter* interrupter_;
  std::vector<Level> levels_;
  double eps0_ = 0;  // eps on level 0
};

template <typename Real>
void Solver<Real>::build() {
  levels_.resize(p_.grids.size());
  std::array<std::vector<std::uint8_t>, 3> fixed_planes;
  for (size_t li = 0; li < levels_.size(); ++li) {
    static_cast<Grid&>(levels_[li]) = p_.grids[li];
    build_level(li, fixed_planes);
    poll(interrupter_, kStage, 0.0);
  }
  // The coarsest: A over its free nodes, dense, factored.
  Level& l = levels_.back();
  for (long n = 0; n < l.count; ++n)
    if (!l.fixed[n]) l.free_nodes.push_back(n);
  const long m = static_cast<long>(l.free_nodes.size());
  Eigen::MatrixXd a(m, m);
  std::vector<double> e(static_cast<size_t>(3 * l.count), 0.0), col(e.size());
  for (long j = 0; j < m; ++j) {
    e[3 * l.free_nodes[j]] = 1.0;
    apply<true>(l, e.data(), col.data());
    e[3 * l.free_nodes[j]] = 0.0;
    for (long i = 0; i < m; ++i) a(i, j) = col[3 * l.free_nodes[i]];
  }
  l.dense.compute(0.5 * (a + a.transpose()));
}

template <typename Real>
void Solver<Real>::build_level(size_t li, std::array<std::vector<std::uint8_t>, 3>& fixed_planes) {
  Level& l = levels_[li];
  const FromMeshParams& params = p_.params;
  const bool thin_plate = params.smoothing == FromMeshSmoothing::thin_plate;
  l.reach = thin_plate ? 2 : 1;
  // R's factor: the data term is a mean over the pairs; R is made dimensionless by the box's
  // diagonal and volume.
  const double l2 = 4.0 * p_.h.squaredNorm();
  const double reg = params.smoothness * static_cast<double>(p_.sources->size()) *
                     (thin_plate ? l2 * l2 : l2) / (8.0 * p_.h.prod());
  // A coarse level's rows stand for the fine energy of the prolonged (trilinear) fields: for a
  // smooth field the fine second differences along an axis count twice the coarse ones (they
  // gather at every other node, twice as large), the mixed differences and the membrane's
  // first differences once. A coarse energy below the fine one makes the cycle over-correct and
  // lose definiteness (conjugate gradients broke down for a few pairs), one above it
  // under-correct.
  const double pure = std::pow(2.0, static_cast<double>(li));

  // The fixed nodes: on level 0 those of the pinned faces; on a coarser level each node whose
  // prolongation reaches a fixed node of the level below, so that the pins cut off no coarse
  // field (a cut one has more energy than the coarse rows say: conjugate gradients stalled on
  // lattices with an odd number of cells pinned on their upper face).
  for (int a = 0; a < 3; ++a) {
    std::vector<std::uint8_t> planes(l.cells[a] + 1, 0);
    if (li == 0) {
      planes[0] = params.pinned[2 * a];
      planes[l.cells[a]] = planes[l.cells[a]] || params.pinned[2 * a + 1];
    } else {
      const std::vector<std::uint8_t>& below = fixed_planes[a];
      for (int i = 0; i <= l.cells[a]; ++i)
        for (int d = -1; d <= 1; ++d) {
          const int fine = 2 * i + d;
          if (fine >= 0 && fine < static_cast<int>(below.size()) && below[fine]) planes[i] = 1;
        }
    }
    fixed_planes[a] = std::move(planes);
  }
  l.fixed.assign(static_cast<size_t>(l.count), 0);
  for (long n = 0; n < l.count; ++n) {
    const Eigen::Vector3i q = l.node_of(n);
    l.fixed[n] = fixed_planes[0][q.x()] || fixed_planes[1][q.y()] || fixed_planes[2][q.z()];
  }

  // R's rows by class, probed at the first node of each class.
  const int per_axis = l.axis_classes();
  std::array<std::vector<int>, 3> first;
  for (int a = 0; a < 3; ++a) {
    l.axis_class[a].resize(l.nodes[a]);
    first[a].assign(per_axis, -1);
    for (int i = 0; i <= l.cells[a]; ++i) {
      const int c = std::min(i, l.reach) * (l.reach + 1) + std::min(l.cells[a] - i, l.reach);
      l.axis_class[a][i] = c;
      if (first[a][c] < 0) first[a][c] = i;
    }
  }
  const int classes = per_axis * per_axis * per_axis;
  l.class_start.assign(classes + 1, 0);
  std::vector<double> centre(classes, 0.0), row_sum(classes, 0.0);
  for (int cls = 0; cls < classes; ++cls) {
    l.class_start[cls] = static_cast<long>(l.entry_offset.size());
    const Eigen::Vector3i q(first[0][cls % per_axis], first[1][(cls / per_axis) % per_axis],
                            first[2][cls / (per_axis * per_axis)]);
    if ((q.array() < 0).any()) continue;
    for (int dz = -l.reach; dz <= l.reach; ++dz)
      for (int dy = -l.reach; dy <= l.reach; ++dy)
        for (int dx = -l.reach; dx <= l.reach; ++dx) {
          const Eigen::Vector3i at = q + Eigen::Vector3i(dx, dy, dz);
          if ((at.array() < 0).any() || (at.array() > l.cells.array()).any()) continue;
          const double w = reg * smoothness_coefficient(params.smoothing, l, q, at, pure);
          if (w == 0.0) continue;
          l.entry_offset.push_back(l.index(at) - l.index(q));
          l.weight.push_back(w);
          l.weight_r.push_back(static_cast<Real>(w));
          row_sum[cls] += std::abs(w);
          if (at == q) centre[cls] = w;
        }
  }
  l.class_start[classes] = static_cast<long>(l.entry_offset.size());
  // eps: a weight per unit volume (kEpsilon of R's largest diagonal entry, over a cell of level
  // 0), as R and the data term are integrals: a coarse level's eps is then the fine one's on the
  // smooth fields it stands for (8 times per level). The same eps on every level undercounted
  // it on the coarse ones, and the cycle over-corrected the fields only eps holds (the affine
  // fields that a few pairs, or pairs on a plane, leave free) a thousandfold.
  if (li == 0) eps0_ = kEpsilon * *std::max_element(centre.begin(), centre.end());
  l.eps = eps0_ * std::pow(8.0, static_cast<double>(li));

  // B^T B's rows: the trilinear weights of the sources on this level.
  l.slot.assign(static_cast<size_t>(l.count), -1);
  l.data.reserve(static_cast<size_t>(p_.touched[li]));
  for (const Eigen::Vector3d& s : *p_.sources) {
    Eigen::Vector3i cell;
    Eigen::Vector3d f;
    l.locate(p_.h, s, cell, f);
    long node[8];
    double w[8];
    for (int c = 0; c < 8; ++c) {
      node[c] = l.index(cell + corner_offset(c));
      w[c] = corner_weight(f, c);
      if (l.slot[node[c]] < 0) {
        l.slot[node[c]] = static_cast<int>(l.data.size());
        l.data.emplace_back();
        l.data.back().fill(0.0);
      }
    }
    for (int c1 = 0; c1 < 8; ++c1) {
      std::array<double, 27>& row = l.data[l.slot[node[c1]]];
      for (int c2 = 0; c2 < 8; ++c2) {
        const Eigen::Vector3i o = corner_offset(c2) - corner_offset(c1);
        row[(o.x() + 1) + 3 * (o.y() + 1) + 9 * (o.z() + 1)] += w[c1] * w[c2];
      }
    }
  }
  l.data_r.resize(l.data.size());
  for (size_t s = 0; s < l.data.size(); ++s)
    for (int o = 0; o < 27; ++o) l.data_r[s][o] = static_cast<Real>(l.data[s][o]);

  // Jacobi's diagonal, and Gershgorin's bound of D^-1 A's eigenvalues (the largest row sum of
  // |A| over its diagonal entry).
  l.inv_diag.assign(static_cast<size_t>(l.count), Real(0));
  std::vector<double> bound(l.nodes.z(), 0.0);
  slices(l.nodes.z(), [&](long kk) {
    const int k = static_cast<int>(kk);
    for (int j = 0; j < l.nodes.y(); ++j)
      for (int i = 0; i < l.nodes.x(); ++i) {
        const long n = l.index(i, j, k);
        if (l.fixed[n]) continue;
        const int cls = l.class_of(i, j, k);
        double diag = centre[cls] + l.eps, sum = row_sum[cls] + l.eps;
        if (l.slot[n] >= 0) {
          diag += l.data[l.slot[n]][13];
          for (double w : l.data[l.slot[n]]) sum += std::abs(w);
        }
        l.inv_diag[n] = static_cast<Real>(1.0 / diag);
        bound[k] = std::max(bound[k], sum / diag);
      }
  });
  l.lambda_max = *std::max_element(bound.begin(), bound.end());

  // The cycle reads data_r; the coarsest's rows in double make its dense matrix.
  if (li > 0 && li + 1 < levels_.size()) std::vector<std::array<double, 27>>().swap(l.data);
  const size_t m = static_cast<size_t>(3 * l.count);
  l.x.assign(m, Real(0));
  l.b.assign(m, Real(0));
  if (li + 1 < levels_.size()) {
    l.r.assign(m, Real(0));
    l.d.assign(m, Real(0));
  }
}

template <typename Real>
typename Solver<Real>::Result Solver<Real>::solve() {
  Level& l0 = levels_[0];
  const long m = 3 * l0.count;
  std::vector<double> x(m, 0.0), r(m, 0.0), z(m, 0.0), p(m, 0.0), q(m, 0.0);
  // b = B^T d + eps a, a the pairs' affine fit: eps pulls u towards it, so that an affine map is
  // met exactly, and u is that fit along what nothing else holds (a pair: a translation; pairs
  // on a plane: no change across them). Conjugate gradients start from u = a (0 on the fixed
  // nodes): they are then left the fit's remainder, and the fields only eps holds, where a
  // residual is no measure of the error, start right (one pair: no iteration at all).
  for_nodes(l0, [&](long n) {
    if (l0.fixed[n]) return;
    const Eigen::Vector3d rest =
        -p_.h + l0.spacing.cwiseProduct(l0.node_of(n).template cast<double>());
    const Eigen::Vector3d a = p_.mean_d + p_.gradient * (rest - p_.mean_s);
    for (int k = 0; k < 3; ++k) {
      x[3 * n + k] = a[k];
      r[3 * n + k] = l0.eps * a[k];
    }
  });
  for (size_t i = 0; i < p_.sources->size(); ++i) {
    Eigen::Vector3i cell;
    Eigen::Vector3d f;
    l0.locate(p_.h, (*p_.sources)[i], cell, f);
    for (int c = 0; c < 8; ++c) {
      const long n = l0.index(cell + corner_offset(c));
      if (l0.fixed[n]) continue;
      const double w = corner_weight(f, c);
      for (int k = 0; k < 3; ++k) r[3 * n + k] += w * (*p_.displacements)[i][k];
    }
  }
  auto dot = [&](const std::vector<double>& a, const std::vector<double>& b) {
    return sum_nodes(l0, [&](long n) {
      return Eigen::Vector3d(a[3 * n] * b[3 * n], a[3 * n + 1] * b[3 * n + 1],
                             a[3 * n + 2] * b[3 * n + 2]);
    });
  };
  auto precondition = [&]() {
    for_nodes(l0, [&](long n) {
      for (int c = 0; c < 3; ++c) l0.b[3 * n + c] = static_cast<Real>(r[3 * n + c]);
    });
    cycle(0, l0.b.data(), l0.x.data());
    for_nodes(l0, [&](long n) {
      for (int c = 0; c < 3; ++c) z[3 * n + c] = l0.x[3 * n + c];
    });
  };
  Result result;
  const double b_norm = dot(r, r).cwiseSqrt().maxCoeff();
  apply<true>(l0, x.data(), q.data());  // r = b - A a
  for_nodes(l0, [&](long n) {
    for (int c = 0; c < 3; ++c) r[3 * n + c] -= q[3 * n + c];
  });
  result.relative_residual = b_norm > 0.0 ? dot(r, r).cwiseSqrt().maxCoeff() / b_norm : 0.0;
  if (result.relative_residual > p_.params.tolerance) {
    precondition();
    p = z;
    Eigen::Vector3d rz = dot(r, z);
    for (;;) {
      apply<true>(l0, p.data(), q.data());
      const Eigen::Vector3d pq = dot(p, q);
      Eigen::Vector3d alpha;
      for (int c = 0; c < 3; ++c) alpha[c] = pq[c] > 0.0 ? rz[c] / pq[c] : 0.0;
      for_nodes(l0, [&](long n) {
        for (int c = 0; c < 3; ++c) {
          x[3 * n + c] += alpha[c] * p[3 * n + c];
          r[3 * n + c] -= alpha[c] * q[3 * n + c];
        }
      });
      ++result.iterations;
      result.relative_residual = dot(r, r).cwiseSqrt().maxCoeff() / b_norm;
      poll(interrupter_, kStage,
           std::log(result.relative_residual) / std::log(p_.params.tolerance));
      if (result.relative_residual <= p_.params.tolerance || result.iterations >= kMaxIterations)
        break;
      precondition();
      const Eigen::Vector3d rz_next = dot(r, z);
      Eigen::Vector3d beta;
      for (int c = 0; c < 3; ++c) beta[c] = rz[c] > 0.0 ? rz_next[c] / rz[c] : 0.0;
      rz = rz_next;
      for_nodes(l0, [&](long n) {
        for (int c = 0; c < 3; ++c) p[3 * n + c] = z[3 * n + c] + beta[c] * p[3 * n + c];
      });
    }
  }
  result.u = std::move(x);
  return result;
}

// The memory make_lattice_deformer takes to build the deformation of a lattice (as LatticeDeformer
// in simulation.cpp lays it out): the node map and the positions it is given and its own copy,
// its cell flags, and its search buckets: cubes of a cell's side over the bounds of the positions
// (grown by 1.25 until there are at most 8 per cell), each with a start, a count and a fill, and
// for every cell an entry in each bucket its deformed bounds meet.
class LatticeBytes {
 public:
  LatticeBytes(const Eigen::Vector3i& cells, const Eigen::Vector3d& spacing,
               const Eigen::AlignedBox3d& positions)
      : cells_(cells), pad_(1e-9 * spacing.norm()), bounds_(positions) {
    bounds_.min().array() -= pad_;
    bounds_.max().array() += pad_;
    const Eigen::Vector3d extent = bounds_.sizes();
    double side = spacing.maxCoeff();
    const double max_buckets = 8.0 * static_cast<double>(cells.prod()) + 64.0;
    while ((extent / side).array().ceil().prod() > max_buckets) side *= 1.25;
    for (int a = 0; a < 3; ++a)
      dims_[a] = std::max(1, static_cast<int>(std::ceil(extent[a] / side)));
    size_ = extent.cwiseQuotient(dims_.cast<double>()).cwiseMax(1e-300);
  }
  // The buckets a cell's bounds meet, along each axis.
  Eigen::Vector3i reach(const Eigen::AlignedBox3d& cell) const {
    return bucket(cell.max() + Eigen::Vector3d::Constant(pad_)) -
           bucket(cell.min() - Eigen::Vector3d::Constant(pad_)) + Eigen::Vector3i::Ones();
  }
  std::size_t bytes(long entries) const {
    const long nodes = static_cast<long>((cells_ + Eigen::Vector3i::Ones()).prod());
    return static_cast<std::size_t>(nodes) * (sizeof(int) + 2 * sizeof(Eigen::Vector3d)) +
           static_cast<std::size_t>(cells_.prod()) +
           static_cast<std::size_t>(3 * dims_.prod() + 1) * sizeof(long) +
           static_cast<std::size_t>(entries) * sizeof(long);
  }

 private:
  Eigen::Vector3i bucket(const Eigen::Vector3d& q) const {
    return ((q - bounds_.min()).cwiseQuotient(size_))
        .array()
        .floor()
        .cast<int>()
        .matrix()
        .cwiseMax(0)
        .cwiseMin(dims_ - Eigen::Vector3i::Ones());
  }
  Eigen::Vector3i cells_, dims_ = Eigen::Vector3i::Ones();
  double pad_;
  Eigen::AlignedBox3d bounds_;
  Eigen::Vector3d size_ = Eigen::Vector3d::Ones();
};

// At rest: the cells are boxes, so their bucket counts multiply axis by axis.
std::size_t lattice_bytes_at_rest(const Eigen::Vector3i& cells, const Eigen::Vector3d& spacing,
                                  const Eigen::Vector3d& h) {
  const LatticeBytes buckets(cells, spacing, Eigen::AlignedBox3d(-h, h));
  long entries = 1;
  for (int a = 0; a < 3; ++a) {
    long along = 0;
    for (int i = 0; i < cells[a]; ++i) {
      Eigen::AlignedBox3d cell(-h, h);
      cell.min()[a] = -h[a] + spacing[a] * i;
      cell.max()[a] = -h[a] + spacing[a] * (i + 1);
      along += buckets.reach(cell)[a];
    }
    entries *= along;
  }
  return buckets.bytes(entries);
}

// With the fitted positions (sample n at positions[n], x fastest).
std::size_t lattice_bytes_fitted(const Grid& g, const std::vector<Eigen::Vector3d>& positions,
                                 Interrupter* interrupter) {
  const long slice = static_cast<long>(g.nodes.x()) * g.nodes.y();
  std::vector<Eigen::AlignedBox3d> slab(g.nodes.z());
  parallel_for(
      g.nodes.z(),
      [&](long k) {
        for (long n = k * slice; n < (k + 1) * slice; ++n) slab[k].extend(positions[n]);
      },
      interrupter, kStage);
  Eigen::AlignedBox3d bounds;
  for (const Eigen::AlignedBox3d& b : slab) bounds.extend(b);
  const LatticeBytes buckets(g.cells, g.spacing, bounds);
  std::vector<long> entries(g.cells.z(), 0);
  parallel_for(
      g.cells.z(),
      [&](long kk) {
        const int k = static_cast<int>(kk);
        for (int j = 0; j < g.cells.y(); ++j)
          for (int i = 0; i < g.cells.x(); ++i) {
            Eigen::AlignedBox3d cell;
            for (int c = 0; c < 8; ++c)
              cell.extend(positions[g.index(Eigen::Vector3i(i, j, k) + corner_offset(c))]);
            entries[k] += static_cast<long>(buckets.reach(cell).prod());
          }
      },
      interrupter, kStage);
  long total = 0;
  for (long e : entries) total += e;
  return buckets.bytes(total);
}

// The deformer: the lattice deformer, described as what it was made from.
class FromMesh final : public Deformer {
 public:
  FromMesh(std::unique_ptr<Deformer> lattice, std::string description)
      : lattice_(std::move(lattice)), description_(std::move(description)) {}
  std::string describe() const override { return description_; }
  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override { return lattice_->forward(p); }
  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    return lattice_->jacobian(p);
  }
  Eigen::Vector3d inverse(const Eigen::Vector3d& p_def) const override {
    return lattice_->inverse(p_def);
  }
  std::array<bool, 6> identity_faces() const override { return lattice_->identity_faces(); }
  void extend_image_bounds(Eigen::AlignedBox3d& bounds) const override {
    lattice_->extend_image_bounds(bounds);
  }

 private:
  std::unique_ptr<Deformer> lattice_;
  std::string description_;
};

// The lattice of `resolution` cells along the box's longest side: the simulation's, a whole
// number of cells per axis, as near cubic as that allows.
Eigen::Vector3i lattice_cells(const Eigen::Vector3d& h, int resolution) {
  const double target = 2.0 * h.maxCoeff() / resolution;
  Eigen::Vector3i cells;
  for (int a = 0; a < 3; ++a)
    cells[a] = std::max(1, static_cast<int>(std::lround(2.0 * h[a] / target)));
  return cells;
}

std::string describe_fit(long n_pairs, const Eigen::Vector3i& cells, const FromMeshParams& params) {
  std::string text =
      "from mesh (" + std::to_string(n_pairs) + (n_pairs == 1 ? " pair, " : " pairs, ") +
      std::to_string(cells.x()) + " x " + std::to_string(cells.y()) + " x " +
      std::to_string(cells.z()) + " cells, " +
      (params.smoothing == FromMeshSmoothing::thin_plate ? "thin plate " : "membrane ") +
      shortest_text(params.smoothness);
  std::string faces;
  for (int f = 0; f < 6; ++f)
    if (params.pinned[f]) faces += " " + face_name(face_of(f));
  if (!faces.empty()) text += ", pinned" + faces;
  return text + ")";
}

void check_params(const Eigen::Vector3d& h, const FromMeshParams& params) {
  check_half_extents("from mesh", h);
  if (params.resolution < kFromMeshMinResolution || params.resolution > kFromMeshMaxResolution)
    throw Error("resolution = " + std::to_string(params.resolution) + ": must be an integer in [" +
                std::to_string(kFromMeshMinResolution) + ", " +
                std::to_string(kFromMeshMaxResolution) + "]");
  if (params.smoothing != FromMeshSmoothing::thin_plate &&
      params.smoothing != FromMeshSmoothing::membrane)
    throw Error("smoothing: must be thin_plate or membrane");
  if (!(params.smoothness >= 1e-10 && params.smoothness <= 1.0))
    throw Error("smoothness = " + shortest_text(params.smoothness) + ": must be in [1e-10, 1]");
  if (!(params.tolerance >= 1e-10 && params.tolerance <= 1e-2))
    throw Error("tolerance = " + shortest_text(params.tolerance) + ": must be in [1e-10, 0.01]");
}

// The rest position of lattice sample n as LatticeDeformer::rest computes it, so that u = 0
// leaves it exact.
Eigen::Vector3d rest_position(const Eigen::Vector3d& h, const Eigen::Vector3d& spacing,
                              const Grid& grid, long n) {
  return -h + spacing.cwiseProduct(grid.node_of(n).cast<double>());
}

// A fitted lattice: every sample at rest + u.
struct LatticeFit {
  Grid grid;  // its cells and spacing
  std::vector<Eigen::Vector3d> positions;
  int iterations = 0;
  double relative_residual = 0;
  std::size_t bytes = 0;  // the estimate of the solver's and the deformer's memory, the larger
};

// The fit of u to the displacements d_i at the sources s_i (in the box [-h, h]) on the lattice of
// params.resolution, u = 0 on params.pinned (the header's E(u)).
LatticeFit fit_lattice(const Eigen::Vector3d& h, const std::vector<Eigen::Vector3d>& sources,
                       const std::vector<Eigen::Vector3d>& displacements,
                       const FromMeshParams& params, Interrupter* interrupter) {
  const double diagonal = 2.0 * h.norm();
  const long n_pairs = static_cast<long>(sources.size());
  const Eigen::Vector3i cells = lattice_cells(h, params.resolution);
  const Eigen::Vector3d spacing = (2.0 * h).cwiseQuotient(cells.cast<double>());

  Problem problem;
  problem.h = h;
  problem.params = params;
  problem.sources = &sources;
  problem.displacements = &displacements;
  problem.grids = hierarchy(cells, spacing);
  const Grid& grid = problem.grids[0];

  // The pairs' affine fit, by least squares; the least gradient along the directions the
  // sources do not spread in (one pair: none; pairs on a plane: across it).
  problem.mean_s.setZero();
  problem.mean_d.setZero();
  for (size_t i = 0; i < sources.size(); ++i) {
    problem.mean_s += sources[i];
    problem.mean_d += displacements[i];
  }
  problem.mean_s /= static_cast<double>(n_pairs);
  problem.mean_d /= static_cast<double>(n_pairs);
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero(), cross = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < sources.size(); ++i) {
    const Eigen::Vector3d s = sources[i] - problem.mean_s;
    scatter += s * s.transpose();
    cross += s * (displacements[i] - problem.mean_d).transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> spread(scatter);
  const double l2 = diagonal * diagonal;
  Eigen::Vector3d inverse_spread = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k)
    if (spread.eigenvalues()[k] > 1e-14 * l2 * static_cast<double>(n_pairs))
      inverse_spread[k] = 1.0 / spread.eigenvalues()[k];
  problem.gradient = (spread.eigenvectors() * inverse_spread.asDiagonal() *
                      spread.eigenvectors().transpose() * cross)
                         .transpose();
  // Sources that barely spread along some direction leave affine fields that only eps holds,
  // some ten orders of magnitude below the rest of A: rounding in float, magnified that much by
  // the coarsest solve, breaks the cycle (a few pairs, or a flat part, did). The cycle then runs
  // in double, at about 1.8 times the cost.
  const bool flat = spread.eigenvalues()[0] < kFlatSpread * static_cast<double>(grid.count) * l2;
  const std::size_t real = flat ? sizeof(double) : sizeof(float);

  // Memory, estimated before anything large is allocated: the solver's (then again once the
  // data rows are counted) and the deformer's at rest (again with the fitted positions).
  // The sources and displacements.
  const std::size_t shared = sources.size() * 2 * sizeof(Eigen::Vector3d);
  std::size_t deformer_bytes = shared + lattice_bytes_at_rest(cells, spacing, h);
  auto check_memory = [&](std::size_t bytes, const char* advice) {
    if (bytes > kFromMeshMaxBytes)
      throw Error("resolution = " + std::to_string(params.resolution) + ": the fit needs about " +
                  mib_text(bytes) + " for its lattice of " + std::to_string(cells.x()) + " x " +
                  std::to_string(cells.y()) + " x " + std::to_string(cells.z()) +
                  " cells, more than the " + mib_text(kFromMeshMaxBytes) + " allowed: " + advice);
  };
  const char* const lower = "lower the resolution";
  check_memory(std::max(solver_bytes(problem, real), deformer_bytes), lower);
  for (const Grid& g : problem.grids) {
    std::vector<std::uint8_t> mark(static_cast<size_t>(g.count), 0);
    for (const Eigen::Vector3d& s : sources) {
      Eigen::Vector3i cell;
      Eigen::Vector3d f;
      g.locate(h, s, cell, f);
      for (int c = 0; c < 8; ++c) mark[g.index(cell + corner_offset(c))] = 1;
    }
    long touched = 0;
    for (std::uint8_t m : mark) touched += m;
    problem.touched.push_back(touched);
    poll(interrupter, kStage, 0.0);
  }
  const std::size_t fit_bytes = solver_bytes(problem, real);
  check_memory(std::max(fit_bytes, deformer_bytes), lower);

  // The fit.
  int iterations = 0;
  double relative = 0.0;
  std::vector<double> u;
  {
    auto run = [&](auto solver) {
      auto result = solver.solve();
      iterations = result.iterations;
      relative = result.relative_residual;
      u = std::move(result.u);
    };
    if (flat)
      run(Solver<double>(problem, interrupter));
    else
      run(Solver<float>(problem, interrupter));
  }
  for (double v : u)
    if (!std::isfinite(v))
      throw Error("smoothness = " + shortest_text(params.smoothness) +
                  ": the fit's solution is not finite: raise it");

  // Every lattice sample at rest + u.
  LatticeFit out;
  out.grid = grid;
  out.positions.resize(static_cast<size_t>(grid.count));
  for (long n = 0; n < grid.count; ++n)
    out.positions[n] =
        rest_position(h, spacing, grid, n) + Eigen::Vector3d(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
  out.iterations = iterations;
  out.relative_residual = relative;
  out.bytes = std::max(fit_bytes, deformer_bytes);
  return out;
}

// The trilinear interpolation of a fitted lattice at p (box [-h, h]; beyond it, the outer cells'
// extension).
Eigen::Vector3d lattice_at(const LatticeFit& lattice, const Eigen::Vector3d& h,
                           const Eigen::Vector3d& p) {
  Eigen::Vector3i cell;
  Eigen::Vector3d f;
  lattice.grid.locate(h, p, cell, f);
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  for (int c = 0; c < 8; ++c)
    q += corner_weight(f, c) * lattice.positions[lattice.grid.index(cell + corner_offset(c))];
  return q;
}

// The fit of the pairs (sources in the box, their displacements). Where the pairs turn more than
// kTurnThreshold, they follow turn_paths' poses (deformers/turn_paths.h) in steps of at most
// kTurnStep: each step's pairs, and the pinned faces' samples (which turn whole turns and come
// back), are fitted with no pinned face on a lattice of cells of the same size over a box that
// holds every pose; the steps are composed at the box lattice's samples (the pinned faces' then
// set at rest), and what the composition leaves of the pairs' displacements is fitted on the
// box's lattice, with u = 0 on the pinned faces, and added.
LatticeFit fit_pairs(const Eigen::Vector3d& h, const std::vector<Eigen::Vector3d>& sources,
                     const std::vector<Eigen::Vector3d>& displacements,
                     const FromMeshParams& params, Interrupter* interrupter, TurnPaths* turns) {
  const Eigen::Vector3i cells = lattice_cells(h, params.resolution);
  const Eigen::Vector3d spacing = (2.0 * h).cwiseQuotient(cells.cast<double>());
  std::vector<Eigen::Vector3d> targets(sources.size());
  for (size_t i = 0; i < sources.size(); ++i) targets[i] = sources[i] + displacements[i];
  // The pinned faces' samples, which the paths hold at rest at both ends.
  const Grid grid = lattice_grid(cells, spacing);
  std::vector<char> on_pin(static_cast<size_t>(grid.count), 0);
  std::vector<Eigen::Vector3d> held;
  for (long n = 0; n < grid.count; ++n) {
    for (int f = 0; f < 6; ++f)
      if (params.pinned[static_cast<size_t>(f)] &&
          grid.node_of(n)[f / 2] == ((f % 2) ? cells[f / 2] : 0))
        on_pin[n] = 1;
    if (on_pin[n]) held.push_back(rest_position(h, spacing, grid, n));
  }
  *turns = turn_paths(sources, targets, held, h, params.pinned, 0.5 * spacing.minCoeff(), kTurnStep,
                      kTurnThreshold, interrupter);
  if (turns->steps <= 1) return fit_lattice(h, sources, displacements, params, interrupter);

  // The box of the steps: every pose within it.
  Eigen::Vector3d reach = h;
  for (const auto& pose : turns->poses)
    for (const Eigen::Vector3d& p : pose) reach = reach.cwiseMax(p.cwiseAbs());
  reach += spacing;
  FromMeshParams step = params;
  step.pinned = {};
  step.resolution =
      std::clamp(static_cast<int>(std::ceil(params.resolution * reach.maxCoeff() / h.maxCoeff())),
                 kFromMeshMinResolution, kFromMeshMaxResolution);
  // The steps, composed at the box lattice's samples.
  std::vector<Eigen::Vector3d> composed(static_cast<size_t>(grid.count));
  for (long n = 0; n < grid.count; ++n) composed[n] = rest_position(h, spacing, grid, n);
  int iterations = 0;
  std::size_t bytes = 0;
  for (int k = 1; k <= turns->steps; ++k) {
    const auto& from = turns->poses[static_cast<size_t>(k - 1)];
    const auto& to = turns->poses[static_cast<size_t>(k)];
    std::vector<Eigen::Vector3d> d(from.size());
    for (size_t i = 0; i < from.size(); ++i) d[i] = to[i] - from[i];
    const LatticeFit fitted = fit_lattice(reach, from, d, step, interrupter);
    iterations += fitted.iterations;
    bytes = std::max(bytes, fitted.bytes);
    parallel_for(
        grid.count, [&](long n) { composed[n] = lattice_at(fitted, reach, composed[n]); },
        interrupter, kStage);
  }
  for (long n = 0; n < grid.count; ++n)
    if (on_pin[n]) composed[n] = rest_position(h, spacing, grid, n);

  // What the composition leaves, fitted on the box's lattice and added.
  LatticeFit base;
  base.grid = grid;
  base.positions = std::move(composed);
  std::vector<Eigen::Vector3d> left(sources.size());
  parallel_for(
      static_cast<long>(sources.size()),
      [&](long i) { left[i] = targets[i] - lattice_at(base, h, sources[i]); }, interrupter, kStage);
  LatticeFit out = fit_lattice(h, sources, left, params, interrupter);
  for (long n = 0; n < grid.count; ++n)
    out.positions[n] += base.positions[n] - rest_position(h, spacing, grid, n);
  out.iterations += iterations;
  out.bytes = std::max(out.bytes, bytes);
  return out;
}

}  // namespace

std::unique_ptr<Deformer> from_mesh_fitted(const Eigen::Vector3d& half_extents,
                                           const FromMeshParams& params,
                                           const std::vector<Eigen::Vector3d>& positions,
                                           long pairs, Interrupter* interrupter) {
  const Eigen::Vector3d& h = half_extents;
  check_params(h, params);
  const Eigen::Vector3i cells = lattice_cells(h, params.resolution);
  const Eigen::Vector3d spacing = (2.0 * h).cwiseQuotient(cells.cast<double>());
  const std::vector<Grid> grids = hierarchy(cells, spacing);
  const Grid& grid = grids[0];
  if (static_cast<long>(positions.size()) != grid.count)
    throw Error("fitted positions: " + std::to_string(positions.size()) +
                " given, the lattice of " + std::to_string(cells.x()) + " x " +
                std::to_string(cells.y()) + " x " + std::to_string(cells.z()) + " cells has " +
                std::to_string(grid.count) + " samples");
  for (const Eigen::Vector3d& p : positions)
    if (!p.allFinite()) throw Error("fitted positions: not finite");
  const std::size_t bytes = lattice_bytes_fitted(grid, positions, interrupter);
  if (bytes > kFromMeshMaxBytes)
    throw Error("resolution = " + std::to_string(params.resolution) +
                ": the fitted lattice needs " + mib_text(bytes) + ", more than the " +
                mib_text(kFromMeshMaxBytes) + " allowed");
  std::vector<int> node_of_sample(static_cast<size_t>(grid.count));
  for (long n = 0; n < grid.count; ++n)
    node_of_sample[static_cast<size_t>(n)] = static_cast<int>(n);
  return std::make_unique<FromMesh>(
      make_lattice_deformer(SimModel::grid, h, cells, node_of_sample, positions, params.pinned),
      describe_fit(pairs, cells, params));
}

std::unique_ptr<Deformer> make_from_mesh(const Eigen::Vector3d& half_extents,
                                         const std::vector<PointPair>& pairs,
                                         const FromMeshParams& params, FromMeshFit* fit,
                                         Interrupter* interrupter,
                                         std::vector<Eigen::Vector3d>* positions_out) {
  const auto start = std::chrono::steady_clock::now();
  const Eigen::Vector3d& h = half_extents;
  check_params(h, params);
  if (pairs.empty())
    throw Error(
        "pairs: none given: the fit needs at least one vertex of the mesh inside the box, with "
        "its place in the deformed copy");
  const double diagonal = 2.0 * h.norm();
  const double slack = kSourceTolerance * diagonal;
  for (size_t i = 0; i < pairs.size(); ++i) {
    auto name = [&] { return "pairs[" + std::to_string(i) + "]"; };
    if (!pairs[i].source.allFinite())
      throw Error(name() + ".source = " + vector_text(pairs[i].source) +
                  ": coordinates must be finite");
    if (!pairs[i].target.allFinite())
      throw Error(name() + ".target = " + vector_text(pairs[i].target) +
                  ": coordinates must be finite");
    if (((pairs[i].source.cwiseAbs() - h).array() > slack).any())
      throw Error(name() + ".source = " + vector_text(pairs[i].source) + ": must lie in the box " +
                  vector_text(-h) + " to " + vector_text(h) + " (box frame)");
  }
  const long n_pairs = static_cast<long>(pairs.size());
  // The sources (moved onto the box within the slack) and their displacements.
  std::vector<Eigen::Vector3d> sources(pairs.size()), displacements(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    sources[i] = pairs[i].source.cwiseMax(-h).cwiseMin(h);
    displacements[i] = pairs[i].target - pairs[i].source;
  }
  TurnPaths turns;
  LatticeFit fitted = fit_pairs(h, sources, displacements, params, interrupter, &turns);
  const Grid& grid = fitted.grid;
  const Eigen::Vector3i cells = grid.cells;
  std::vector<Eigen::Vector3d>& positions = fitted.positions;
  std::vector<int> node_of_sample(static_cast<size_t>(grid.count));
  for (long n = 0; n < grid.count; ++n) node_of_sample[n] = static_cast<int>(n);
  const std::size_t shared = pairs.size() * 2 * sizeof(Eigen::Vector3d);
  const std::size_t deformer_bytes = shared + lattice_bytes_fitted(grid, positions, interrupter);
  if (deformer_bytes > kFromMeshMaxBytes)
    throw Error("resolution = " + std::to_string(params.resolution) + ": the fit needs about " +
                mib_text(deformer_bytes) + " for its lattice of " + std::to_string(cells.x()) +
                " x " + std::to_string(cells.y()) + " x " + std::to_string(cells.z()) +
                " cells, more than the " + mib_text(kFromMeshMaxBytes) +
                " allowed: the fitted cells spread far (targets far from their sources, or "
                "conflicting): lower the resolution or raise the smoothness");
  std::unique_ptr<Deformer> lattice =
      make_lattice_deformer(SimModel::grid, h, cells, node_of_sample, positions, params.pinned);
  std::vector<int>().swap(node_of_sample);
  if (positions_out)
    *positions_out = std::move(positions);
  else
    std::vector<Eigen::Vector3d>().swap(positions);
  auto deformer =
      std::make_unique<FromMesh>(std::move(lattice), describe_fit(n_pairs, cells, params));

  if (fit) {
    // The fit's error, through the deformer itself.
    constexpr long kChunk = 4096;
    const long chunks = (n_pairs + kChunk - 1) / kChunk;
    std::vector<double> worst(chunks, 0.0), squares(chunks, 0.0);
    parallel_for(
        chunks,
        [&](long c) {
          for (long i = c * kChunk; i < std::min(n_pairs, (c + 1) * kChunk); ++i) {
            const double e = (deformer->forward(sources[i]) - pairs[i].target).norm();
            worst[c] = std::max(worst[c], e);
            squares[c] += e * e;
          }
        },
        interrupter, kStage);
    fit->pairs = n_pairs;
    fit->cells = cells;
    fit->max_error = *std::max_element(worst.begin(), worst.end());
    double total = 0.0;
    for (double s : squares) total += s;
    fit->rms_error = std::sqrt(total / static_cast<double>(n_pairs));
    fit->iterations = fitted.iterations;
    fit->largest_turn_deg = turns.largest_angle * (180.0 / 3.14159265358979323846);
    fit->steps = turns.steps;
    fit->relative_residual = fitted.relative_residual;
    fit->bytes = std::max(fitted.bytes, deformer_bytes);
    fit->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return deformer;
}

}  // namespace raywarp
