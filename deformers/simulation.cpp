#include "deformers/simulation.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>

#include "base/error.h"
#include "base/parallel.h"
#include "physics/integrators.h"
#include "physics/mass_spring.h"
#include "physics/models.h"

namespace raywarp {

const std::vector<std::string>& sim_model_names() {
  static const std::vector<std::string> names = {"grid", "tets"};
  return names;
}

const std::vector<std::string>& sim_integrator_names() {
  static const std::vector<std::string> names = {"explicit_euler", "verlet", "velocity_verlet",
                                                 "implicit_euler", "local_global"};
  return names;
}

Eigen::Vector3d Drag::offset_at(double t) const {
  if (path.empty()) return Eigen::Vector3d::Zero();
  DragKey previous{0.0, Eigen::Vector3d::Zero()};
  for (const DragKey& key : path) {
    if (t <= key.t) {
      if (key.t <= previous.t) return key.offset;
      const double s = std::clamp((t - previous.t) / (key.t - previous.t), 0.0, 1.0);
      return (1.0 - s) * previous.offset + s * key.offset;
    }
    previous = key;
  }
  return path.back().offset;
}

namespace {

constexpr double kNewtonTolerance = 1e-9;  // of the cell diagonal
constexpr int kNewtonIterations = 60;
constexpr double kInside = 1e-9;  // slack of a barycentric or trilinear coordinate

// The 6 Kuhn tetrahedra of a cell: for the axis order (a, b, c), corners 0, e_a, e_a + e_b, 1 as
// bit masks (bit a set: the corner's offset along axis a is 1).
constexpr int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
std::array<int, 4> kuhn_corners(int order) {
  const int a = kOrders[order][0], b = kOrders[order][1];
  return {0, 1 << a, (1 << a) | (1 << b), 7};
}

// The deformation of a lattice body (see simulation.h).
class LatticeDeformer final : public Deformer {
 public:
  LatticeDeformer(SimModel model, const Eigen::Vector3d& h, const Eigen::Vector3i& cells,
                  const std::vector<int>& node_of_sample, const std::vector<Eigen::Vector3d>& nodes,
                  const std::array<bool, 6>& pinned, std::string description)
      : model_(model),
        h_(h),
        cells_(cells),
        spacing_((2.0 * h).cwiseQuotient(cells.cast<double>())),
        description_(std::move(description)) {
    check_half_extents("simulation", h);
    samples_ = cells_ + Eigen::Vector3i::Ones();
    const long count = static_cast<long>(samples_.prod());
    if (node_of_sample.size() != static_cast<size_t>(count))
      throw Error("simulation: the node map has " + std::to_string(node_of_sample.size()) +
                  " samples, the lattice " + std::to_string(count));
    for (int node : node_of_sample)
      if (node >= static_cast<int>(nodes.size()))
        throw Error("simulation: a sample names node " + std::to_string(node) + " of " +
                    std::to_string(nodes.size()));
    for (const Eigen::Vector3d& p : nodes)
      if (!p.allFinite()) throw Error("simulation: a node position is not finite");
    diagonal_ = spacing_.norm();
    body_.assign(static_cast<size_t>(cells_.prod()), 0);
    for (int k = 0; k < cells_.z(); ++k)
      for (int j = 0; j < cells_.y(); ++j)
        for (int i = 0; i < cells_.x(); ++i) {
          bool all = true;
          for (int c = 0; c < 8 && all; ++c)
            all = node_of_sample[corner_sample(Eigen::Vector3i(i, j, k), c)] >= 0;
          body_[cell_index(Eigen::Vector3i(i, j, k))] = all ? 1 : 0;
        }
    extend(node_of_sample, nodes, pinned);
    build_buckets();
    for (int f = 0; f < 6; ++f) {
      const int axis = f / 2, plane = (f % 2) ? cells_[axis] : 0;
      bool identity = true;
      for (long s = 0; s < count && identity; ++s) {
        const Eigen::Vector3i q = sample_of(s);
        if (q[axis] == plane && x_[s] != rest(q)) identity = false;
      }
      identity_[f] = identity;
    }
  }

  std::string describe() const override { return description_; }

  Eigen::Vector3d forward(const Eigen::Vector3d& p) const override {
    Eigen::Vector3i cell;
    Eigen::Vector3d f;
    if (!locate(p, cell, f)) return p;
    return clamp_finite(interpolate(cell, f));
  }

  Eigen::Matrix3d jacobian(const Eigen::Vector3d& p) const override {
    Eigen::Vector3i cell;
    Eigen::Vector3d f;
    if (!locate(p, cell, f)) return Eigen::Matrix3d::Identity();
    return clamp_finite(cell_jacobian(cell, f));
  }

  Eigen::Vector3d inverse(const Eigen::Vector3d& q) const override {
    if (!q.allFinite()) return Eigen::Vector3d::Zero();
    // The body's preimages first, then the extension's; of several, the nearest to q. Trilinear
    // cells are first tried from their centre alone, then from 8 more starts.
    Eigen::Vector3d p;
    if (search(q, false, p) || (model_ == SimModel::grid && search(q, true, p))) return p;
    // Outside F(box): within two cells of it, the continuation of the nearest deformed cell's
    // map, so D stays close to its valid neighbours' and their interpolation does not reach
    // across the box; farther, the identity. A preimage inside the box is moved half a cell
    // beyond its nearest face: these texels are invalid (w = 0).
    // Beyond a face that stays the identity (a pinned face), F is the identity: D = 0 there, as
    // for the closed-form deformers, which keeps the seam where the mesh crosses that face whole.
    for (int a = 0; a < 3; ++a)
      if (std::abs(q[a]) > h_[a] && identity_[2 * a + (q[a] > 0 ? 1 : 0)]) return q;
    if (!extrapolate(q, p)) p = q;
    if ((p.cwiseAbs().array() > h_.array()).any()) return p;
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (h_[a] - std::abs(p[a]) < h_[axis] - std::abs(p[axis])) axis = a;
    p[axis] = (p[axis] < 0 ? -1.0 : 1.0) * (h_[axis] + 0.5 * spacing_[axis]);
    return p;
  }

  std::array<bool, 6> identity_faces() const override { return identity_; }

  void extend_image_bounds(Eigen::AlignedBox3d& bounds) const override {
    if (!bucket_bounds_.isEmpty()) bounds.extend(bucket_bounds_);
  }

 private:
  long sample_index(const Eigen::Vector3i& s) const {
    return s.x() +
           static_cast<long>(samples_.x()) * (s.y() + static_cast<long>(samples_.y()) * s.z());
  }
  Eigen::Vector3i sample_of(long s) const {
    return Eigen::Vector3i(static_cast<int>(s % samples_.x()),
                           static_cast<int>((s / samples_.x()) % samples_.y()),
                           static_cast<int>(s / (static_cast<long>(samples_.x()) * samples_.y())));
  }
  long corner_sample(const Eigen::Vector3i& cell, int corner) const {
    return sample_index(cell + Eigen::Vector3i(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1));
  }
  long cell_index(const Eigen::Vector3i& c) const {
    return c.x() + static_cast<long>(cells_.x()) * (c.y() + static_cast<long>(cells_.y()) * c.z());
  }
  Eigen::Vector3i cell_of(long ci) const {
    return Eigen::Vector3i(static_cast<int>(ci % cells_.x()),
                           static_cast<int>((ci / cells_.x()) % cells_.y()),
                           static_cast<int>(ci / (static_cast<long>(cells_.x()) * cells_.y())));
  }
  Eigen::Vector3d rest(const Eigen::Vector3i& s) const {
    return -h_ + spacing_.cwiseProduct(s.cast<double>());
  }
  const Eigen::Vector3d& corner_position(const Eigen::Vector3i& cell, int corner) const {
    return x_[corner_sample(cell, corner)];
  }

  // Every lattice sample's position: a node's, or the harmonic extension of the nodes'
  // displacements (zero on the pinned faces) over the samples outside the body: the discrete
  // Laplace equation on the lattice (6 neighbours, weights 1 / spacing²), by Jacobi-preconditioned
  // CG to 1e-10, so F is continuous over the whole box and moves the empty space around the body
  // along with it.
  void extend(const std::vector<int>& node_of_sample, const std::vector<Eigen::Vector3d>& nodes,
              const std::array<bool, 6>& pinned) {
    const long count = static_cast<long>(samples_.prod());
    x_.resize(count);
    std::vector<int> unknown(count, -1);
    int unknowns = 0;
    for (long s = 0; s < count; ++s) {
      const Eigen::Vector3i q = sample_of(s);
      x_[s] = node_of_sample[s] >= 0 ? nodes[node_of_sample[s]] : rest(q);
      if (node_of_sample[s] >= 0) continue;
      bool on_pinned = false;
      for (int f = 0; f < 6; ++f)
        on_pinned = on_pinned || (pinned[f] && q[f / 2] == ((f % 2) ? cells_[f / 2] : 0));
      if (!on_pinned) unknown[s] = unknowns++;
    }
    if (unknowns == 0) return;
    const Eigen::Vector3d w = spacing_.cwiseProduct(spacing_).cwiseInverse();
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(static_cast<size_t>(unknowns) * 7);
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(unknowns, 3);
    for (long s = 0; s < count; ++s) {
      const int row = unknown[s];
      if (row < 0) continue;
      const Eigen::Vector3i q = sample_of(s);
      // A small pull towards rest keeps a region that touches no node or pin well posed.
      double diagonal = 1e-9 * w.maxCoeff();
      for (int a = 0; a < 3; ++a)
        for (int side = -1; side <= 1; side += 2) {
          Eigen::Vector3i n = q;
          n[a] += side;
          if (n[a] < 0 || n[a] > cells_[a]) continue;  // the lattice's edge: no flux
          const long ns = sample_index(n);
          diagonal += w[a];
          if (unknown[ns] >= 0)
            triplets.emplace_back(row, unknown[ns], -w[a]);
          else
            rhs.row(row) += w[a] * (x_[ns] - rest(n)).transpose();
        }
      triplets.emplace_back(row, row, diagonal);
    }
    Eigen::SparseMatrix<double> a(unknowns, unknowns);
    a.setFromTriplets(triplets.begin(), triplets.end());
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper,
                             Eigen::DiagonalPreconditioner<double>>
        cg;
    cg.setTolerance(1e-10);
    cg.setMaxIterations(4 * (cells_.maxCoeff() + 1) * 50);
    cg.compute(a);
    for (int c = 0; c < 3; ++c) {
      const Eigen::VectorXd u = cg.solve(rhs.col(c));
      for (long s = 0; s < count; ++s)
        if (unknown[s] >= 0 && std::isfinite(u[unknown[s]])) x_[s][c] += u[unknown[s]];
    }
  }

  // The cell holding rest point p (in the box) and p's coordinates in it, in [0, 1]; false
  // outside the box. A point on a face between cells belongs to the cell above it, except on the
  // box's upper faces.
  bool locate(const Eigen::Vector3d& p, Eigen::Vector3i& cell, Eigen::Vector3d& f) const {
    if (!p.allFinite()) return false;
    const Eigen::Vector3d u = (p + h_).cwiseQuotient(spacing_);
    for (int a = 0; a < 3; ++a) {
      if (!(u[a] >= 0.0 && u[a] <= cells_[a])) return false;
      cell[a] = std::min(static_cast<int>(std::floor(u[a])), cells_[a] - 1);
      f[a] = u[a] - cell[a];
    }
    return true;
  }

  // The Kuhn tetrahedron of a cell holding coordinates f: the order of f's components, largest
  // first.
  static int kuhn_order(const Eigen::Vector3d& f) {
    for (int o = 0; o < 6; ++o) {
      const int a = kOrders[o][0], b = kOrders[o][1], c = kOrders[o][2];
      if (f[a] >= f[b] && f[b] >= f[c]) return o;
    }
    return 0;
  }

  Eigen::Vector3d interpolate(const Eigen::Vector3i& cell, const Eigen::Vector3d& f) const {
    if (model_ == SimModel::tets) {
      const int o = kuhn_order(f);
      const int a = kOrders[o][0], b = kOrders[o][1], c = kOrders[o][2];
      const std::array<int, 4> k = kuhn_corners(o);
      return (1.0 - f[a]) * corner_position(cell, k[0]) +
             (f[a] - f[b]) * corner_position(cell, k[1]) +
             (f[b] - f[c]) * corner_position(cell, k[2]) + f[c] * corner_position(cell, k[3]);
    }
    Eigen::Vector3d out = Eigen::Vector3d::Zero();
    for (int c = 0; c < 8; ++c) {
      const double w = ((c & 1) ? f.x() : 1.0 - f.x()) * ((c & 2) ? f.y() : 1.0 - f.y()) *
                       ((c & 4) ? f.z() : 1.0 - f.z());
      out += w * corner_position(cell, c);
    }
    return out;
  }

  // dX/df (columns: derivatives along the cell's coordinates), trilinear.
  Eigen::Matrix3d trilinear_derivative(const Eigen::Vector3i& cell,
                                       const Eigen::Vector3d& f) const {
    Eigen::Matrix3d d = Eigen::Matrix3d::Zero();
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d w((c & 1) ? f.x() : 1.0 - f.x(), (c & 2) ? f.y() : 1.0 - f.y(),
                              (c & 4) ? f.z() : 1.0 - f.z());
      const Eigen::Vector3d s((c & 1) ? 1.0 : -1.0, (c & 2) ? 1.0 : -1.0, (c & 4) ? 1.0 : -1.0);
      const Eigen::Vector3d& x = corner_position(cell, c);
      d.col(0) += s.x() * w.y() * w.z() * x;
      d.col(1) += w.x() * s.y() * w.z() * x;
      d.col(2) += w.x() * w.y() * s.z() * x;
    }
    return d;
  }

  Eigen::Matrix3d cell_jacobian(const Eigen::Vector3i& cell, const Eigen::Vector3d& f) const {
    Eigen::Matrix3d d;  // dX/df
    if (model_ == SimModel::tets) {
      const int o = kuhn_order(f);
      const std::array<int, 4> k = kuhn_corners(o);
      for (int m = 0; m < 3; ++m)
        d.col(kOrders[o][m]) = corner_position(cell, k[m + 1]) - corner_position(cell, k[m]);
    } else {
      d = trilinear_derivative(cell, f);
    }
    return d * spacing_.cwiseInverse().asDiagonal();
  }

  // The linear continuation (over the Kuhn tetrahedron q is least outside of) of the deformed
  // cell nearest to q, among those within two cells of it; false when there is none.
  bool extrapolate(const Eigen::Vector3d& q, Eigen::Vector3d& out) const {
    const double radius = 2.0 * spacing_.maxCoeff();
    Eigen::AlignedBox3d reach(q - Eigen::Vector3d::Constant(radius),
                              q + Eigen::Vector3d::Constant(radius));
    if (!reach.intersects(bucket_bounds_)) return false;
    const Eigen::Vector3i lo = bucket_of(reach.min()), hi = bucket_of(reach.max());
    const Eigen::Vector3f qf = q.cast<float>();
    double best = radius;
    long best_cell = -1;
    // Rings of buckets about q's: past ring r every bucket lies at least r bucket sides from q,
    // so once the best is nearer than that the rest cannot beat it.
    const Eigen::Vector3i centre = bucket_of(q);
    const double side = bucket_size_.minCoeff();
    const int rings = (hi - centre).cwiseMax(centre - lo).maxCoeff();
    for (int r = 0; r <= rings && !(static_cast<double>(r - 1) * side > best); ++r)
      for (int k = std::max(lo.z(), centre.z() - r); k <= std::min(hi.z(), centre.z() + r); ++k)
        for (int j = std::max(lo.y(), centre.y() - r); j <= std::min(hi.y(), centre.y() + r); ++j)
          for (int i = std::max(lo.x(), centre.x() - r); i <= std::min(hi.x(), centre.x() + r);
               ++i) {
            const Eigen::Vector3i at(i, j, k);
            if ((at - centre).cwiseAbs().maxCoeff() != r) continue;  // an inner ring's
            const long bi = i + static_cast<long>(bucket_dims_.x()) *
                                    (j + static_cast<long>(bucket_dims_.y()) * k);
            for (long e = bucket_start_[bi]; e < bucket_start_[bi + 1]; ++e) {
              const long ci = bucket_cells_[e];
              // The cell's bounds rounded outwards are no farther: a cell they put past the best
              // is past it (a sheared lattice lists each cell in many of the buckets searched).
              if (!(static_cast<double>(cell_bounds_[ci].exteriorDistance(qf)) <= best)) continue;
              Eigen::AlignedBox3d bounds;
              for (int c = 0; c < 8; ++c) bounds.extend(corner_position(cell_of(ci), c));
              const double d = bounds.exteriorDistance(q);
              if (d < best || (d == best && ci < best_cell)) {
                best = d;
                best_cell = ci;
              }
            }
          }
    if (best_cell < 0) return false;
    const Eigen::Vector3i cell = cell_of(best_cell);
    double least = std::numeric_limits<double>::infinity();
    for (int o = 0; o < 6; ++o) {
      Eigen::Vector3d l;
      if (!kuhn_coordinates(cell, o, q, l)) continue;
      const double outside = std::max({-l.minCoeff(), l.sum() - 1.0, 0.0});
      if (!(outside < least)) continue;
      least = outside;
      out = -h_ + spacing_.cwiseProduct(cell.cast<double>() + kuhn_cell_point(o, l));  // unclamped
    }
    return std::isfinite(least) && out.allFinite();
  }

  // The nearest preimage of q in the body's cells, else in the empty cells.
  bool search(const Eigen::Vector3d& q, bool more_starts, Eigen::Vector3d& out) const {
    if (!bucket_bounds_.contains(q)) return false;
    const Eigen::Vector3i b = bucket_of(q);
    const long bi = b.x() + static_cast<long>(bucket_dims_.x()) *
                                (b.y() + static_cast<long>(bucket_dims_.y()) * b.z());
    const Eigen::Vector3f qf = q.cast<float>();
    const Eigen::Vector3d slack = Eigen::Vector3d::Constant(1e-9 * diagonal_);
    for (int which = 0; which < 2; ++which) {  // the body's cells, then the empty ones
      double best = std::numeric_limits<double>::infinity();
      for (long e = bucket_start_[bi]; e < bucket_start_[bi + 1]; ++e) {
        const long ci = bucket_cells_[e];
        if ((body_[ci] ? 0 : 1) != which) continue;
        if (!cell_bounds_[ci].contains(qf)) continue;  // rounded outwards: holds every bound below
        const Eigen::Vector3i cell = cell_of(ci);
        // A preimage in the cell lies in its rest box: one no nearer than the best is no better.
        const Eigen::AlignedBox3d rest_box(rest(cell) - slack,
                                           rest(cell + Eigen::Vector3i::Ones()) + slack);
        if (rest_box.squaredExteriorDistance(q) >= best) continue;
        Eigen::AlignedBox3d bounds;
        for (int c = 0; c < 8; ++c) bounds.extend(corner_position(cell, c));
        bounds.min().array() -= 1e-9 * diagonal_;
        bounds.max().array() += 1e-9 * diagonal_;
        if (!bounds.contains(q)) continue;
        Eigen::Vector3d p;
        if (!cell_preimage(cell, q, more_starts, p)) continue;
        const double d2 = (p - q).squaredNorm();
        if (d2 < best) {  // ties keep the lowest cell (cells are listed in order)
          best = d2;
          out = p;
        }
      }
      if (std::isfinite(best)) return true;
    }
    return false;
  }

  // q's coordinates l in deformed Kuhn tetrahedron `order` of `cell`: q = x0 + sum_m l_m (x_{m+1}
  // - x0) over its corners x0..x3; false for a flattened tetrahedron (no volume to invert).
  bool kuhn_coordinates(const Eigen::Vector3i& cell, int order, const Eigen::Vector3d& q,
                        Eigen::Vector3d& l) const {
    const std::array<int, 4> k = kuhn_corners(order);
    const Eigen::Vector3d& x0 = corner_position(cell, k[0]);
    Eigen::Matrix3d e;
    for (int m = 0; m < 3; ++m) e.col(m) = corner_position(cell, k[m + 1]) - x0;
    Eigen::Matrix3d inv;
    bool invertible = false;
    double det = 0;
    e.computeInverseAndDetWithCheck(inv, det, invertible, 1e-14 * std::pow(diagonal_, 3.0));
    if (!invertible) return false;
    l = inv * (q - x0);
    return true;
  }

  // The cell coordinates of the point with Kuhn coordinates l in tetrahedron `order` at rest:
  // corner m + 1 is corner m plus e_{order[m]}.
  static Eigen::Vector3d kuhn_cell_point(int order, const Eigen::Vector3d& l) {
    Eigen::Vector3d f;
    double along = l.sum();
    for (int m = 0; m < 3; ++m) {
      f[kOrders[order][m]] = along;
      along -= l[m];
    }
    return f;
  }

  // The rest point of `cell` that F maps to q, when q lies in the deformed cell: per Kuhn
  // tetrahedron exactly (the first that holds q), or by damped Newton on the trilinear map.
  bool cell_preimage(const Eigen::Vector3i& cell, const Eigen::Vector3d& q, bool more_starts,
                     Eigen::Vector3d& p) const {
    if (model_ == SimModel::tets) {
      for (int o = 0; o < 6; ++o) {
        Eigen::Vector3d l;
        if (!kuhn_coordinates(cell, o, q, l)) continue;
        if (l.minCoeff() < -kInside || l.sum() > 1.0 + kInside) continue;
        const Eigen::Vector3d f = kuhn_cell_point(o, l.cwiseMax(0.0)).cwiseMin(1.0);
        p = -h_ + spacing_.cwiseProduct(cell.cast<double>() + f);
        return true;
      }
      return false;
    }
    // Damped Newton from the cell's centre, or (a cell squashed until it folds can send that
    // start astray) from 8 points near its corners.
    for (int start = more_starts ? 1 : 0; start < (more_starts ? 9 : 1); ++start) {
      Eigen::Vector3d f = Eigen::Vector3d::Constant(0.5);
      if (start > 0)
        for (int a = 0; a < 3; ++a) f[a] = ((start - 1) >> a) & 1 ? 0.85 : 0.15;
      if (newton(cell, q, f)) {
        p = -h_ + spacing_.cwiseProduct(cell.cast<double>() + f.cwiseMax(0.0).cwiseMin(1.0));
        return true;
      }
    }
    return false;
  }

  // Newton's method for the trilinear map of `cell` from coordinates f; true with f in the cell
  // when it reaches q within 1e-9 of the cell diagonal.
  bool newton(const Eigen::Vector3i& cell, const Eigen::Vector3d& q, Eigen::Vector3d& f) const {
    Eigen::Vector3d r = interpolate(cell, f) - q;
    double rn = r.norm();
    const double tol = kNewtonTolerance * diagonal_;
    for (int it = 0; it < kNewtonIterations && rn > tol; ++it) {
      const Eigen::Matrix3d d = trilinear_derivative(cell, f);
      Eigen::Matrix3d inv;
      bool invertible = false;
      double det = 0;
      d.computeInverseAndDetWithCheck(inv, det, invertible, 1e-300);
      if (!invertible) return false;
      const Eigen::Vector3d step = inv * r;
      double s = 1.0;
      bool improved = false;
      for (int halving = 0; halving < 30; ++halving, s *= 0.5) {
        const Eigen::Vector3d g = f - s * step;
        const Eigen::Vector3d rg = interpolate(cell, g) - q;
        if (rg.norm() < rn) {
          f = g;
          r = rg;
          rn = rg.norm();
          improved = true;
          break;
        }
      }
      if (!improved) break;
      if ((f.array().abs() > 4.0).any()) return false;  // running away from the cell
    }
    return rn <= tol && f.minCoeff() >= -kInside && f.maxCoeff() <= 1.0 + kInside;
  }

  Eigen::Vector3i bucket_of(const Eigen::Vector3d& q) const {
    return ((q - bucket_bounds_.min()).cwiseQuotient(bucket_size_))
        .array()
        .floor()
        .cast<int>()
        .matrix()
        .cwiseMax(0)
        .cwiseMin(bucket_dims_ - Eigen::Vector3i::Ones());
  }

  // Buckets of about a cell's side over the deformed lattice (at most ~8 per cell), each listing
  // the cells whose deformed bounds meet it, in cell order.
  void build_buckets() {
    const long count = static_cast<long>(cells_.prod());
    bucket_bounds_.setEmpty();
    for (const Eigen::Vector3d& x : x_) bucket_bounds_.extend(x);
    const double pad = 1e-9 * diagonal_;
    bucket_bounds_.min().array() -= pad;
    bucket_bounds_.max().array() += pad;
    const Eigen::Vector3d extent = bucket_bounds_.sizes();
    double side = spacing_.maxCoeff();
    const double max_buckets = 8.0 * static_cast<double>(count) + 64.0;
    while ((extent / side).array().ceil().prod() > max_buckets) side *= 1.25;
    for (int a = 0; a < 3; ++a)
      bucket_dims_[a] = std::max(1, static_cast<int>(std::ceil(extent[a] / side)));
    bucket_size_ = extent.cwiseQuotient(bucket_dims_.cast<double>()).cwiseMax(1e-300);
    const long buckets = static_cast<long>(bucket_dims_.prod());
    auto for_each_bucket = [&](long ci, const auto& visit) {
      const Eigen::Vector3i cell = cell_of(ci);
      Eigen::AlignedBox3d b;
      for (int c = 0; c < 8; ++c) b.extend(corner_position(cell, c));
      const Eigen::Vector3i lo = bucket_of(b.min() - Eigen::Vector3d::Constant(pad));
      const Eigen::Vector3i hi = bucket_of(b.max() + Eigen::Vector3d::Constant(pad));
      for (int k = lo.z(); k <= hi.z(); ++k)
        for (int j = lo.y(); j <= hi.y(); ++j)
          for (int i = lo.x(); i <= hi.x(); ++i)
            visit(i + static_cast<long>(bucket_dims_.x()) *
                          (j + static_cast<long>(bucket_dims_.y()) * k));
    };
    // Each cell's deformed bounds in float, rounded outwards and padded by 1e-6 of the diagonal
    // (past float's rounding of a query point, and the 1e-9 that search() allows): a quick first
    // test of both searches, which then test the cell exactly.
    cell_bounds_.resize(count);
    const float inf = std::numeric_limits<float>::infinity();
    for (long ci = 0; ci < count; ++ci) {
      Eigen::AlignedBox3d b;
      for (int c = 0; c < 8; ++c) b.extend(corner_position(cell_of(ci), c));
      b.min().array() -= 1e-6 * diagonal_;
      b.max().array() += 1e-6 * diagonal_;
      for (int a = 0; a < 3; ++a) {
        cell_bounds_[ci].min()[a] = std::nextafter(static_cast<float>(b.min()[a]), -inf);
        cell_bounds_[ci].max()[a] = std::nextafter(static_cast<float>(b.max()[a]), inf);
      }
    }
    std::vector<long> counts(buckets, 0);
    for (long ci = 0; ci < count; ++ci) for_each_bucket(ci, [&](long b) { ++counts[b]; });
    bucket_start_.assign(buckets + 1, 0);
    for (long b = 0; b < buckets; ++b) bucket_start_[b + 1] = bucket_start_[b] + counts[b];
    bucket_cells_.assign(bucket_start_[buckets], 0);
    std::vector<long> fill(bucket_start_.begin(), bucket_start_.end() - 1);
    for (long ci = 0; ci < count; ++ci)
      for_each_bucket(ci, [&](long b) { bucket_cells_[fill[b]++] = ci; });
  }

  SimModel model_;
  Eigen::Vector3d h_;
  Eigen::Vector3i cells_, samples_;
  Eigen::Vector3d spacing_;
  double diagonal_ = 0;
  std::string description_;
  std::vector<Eigen::Vector3d> x_;  // every lattice sample's position
  std::vector<std::uint8_t> body_;  // per cell: its 8 corners are nodes
  Eigen::AlignedBox3d bucket_bounds_;
  Eigen::Vector3i bucket_dims_ = Eigen::Vector3i::Ones();
  Eigen::Vector3d bucket_size_ = Eigen::Vector3d::Ones();
  std::vector<long> bucket_start_, bucket_cells_;
  std::vector<Eigen::AlignedBox3f> cell_bounds_;  // per cell: its deformed bounds, rounded outwards
  std::array<bool, 6> identity_{};
};

std::unique_ptr<physics::Integrator> make_integrator(SimIntegrator which) {
  switch (which) {
    case SimIntegrator::explicit_euler:
      return std::make_unique<physics::ExplicitEuler>();
    case SimIntegrator::verlet:
      return std::make_unique<physics::Verlet>();
    case SimIntegrator::velocity_verlet:
      return std::make_unique<physics::VelocityVerlet>();
    case SimIntegrator::implicit_euler:
      return std::make_unique<physics::ImplicitEuler>();
    case SimIntegrator::local_global:
      return std::make_unique<physics::LocalGlobal>();
  }
  throw Error("simulation: unknown integrator");
}

}  // namespace

std::unique_ptr<Deformer> make_lattice_deformer(SimModel model, const Eigen::Vector3d& half_extents,
                                                const Eigen::Vector3i& cells,
                                                const std::vector<int>& node_of_sample,
                                                const std::vector<Eigen::Vector3d>& positions,
                                                const std::array<bool, 6>& pinned) {
  if ((cells.array() < 1).any()) throw Error("simulation: the lattice needs a cell per axis");
  return std::make_unique<LatticeDeformer>(
      model, half_extents, cells, node_of_sample, positions, pinned,
      std::string("lattice body (") + sim_model_names()[static_cast<int>(model)] + ")");
}

struct Simulation::Impl {
  SimulationParams params;
  Eigen::Vector3d h;
  Eigen::Vector3i cells;
  Eigen::Vector3d spacing;
  std::vector<int> node_of_sample;
  SimulationBody body;  // its rest positions are the rest state
  physics::MassSpring system;
  std::unique_ptr<physics::Integrator> integrator;
  std::vector<std::vector<int>> drag_nodes;  // per drag
  std::array<bool, 6> pinned_faces{};
  SimulationStats stats;
  std::string description;
};

Simulation::~Simulation() = default;
Simulation::Simulation(Simulation&&) noexcept = default;

Simulation::Simulation(const SimulationParams& params, const Eigen::Vector3d& half_extents,
                       const SimulationInput& input, std::vector<std::string>* warnings,
                       Interrupter* interrupter)
    : impl_(std::make_unique<Impl>()) {
  const auto start = std::chrono::steady_clock::now();
  check_half_extents("simulation", half_extents);
  if (!input.signed_distance) throw Error("simulation: needs the mesh part's signed distance");
  if (params.resolution < 1) throw Error("resolution: must be >= 1");
  Impl& m = *impl_;
  m.params = params;
  m.h = half_extents;
  const double target = 2.0 * half_extents.maxCoeff() / params.resolution;
  for (int a = 0; a < 3; ++a)
    m.cells[a] = std::max(1, static_cast<int>(std::lround(2.0 * half_extents[a] / target)));
  m.spacing = (2.0 * half_extents).cwiseQuotient(m.cells.cast<double>());
  const double margin = params.margin < 0 ? m.spacing.norm() : params.margin;
  if (warnings && params.margin >= 0 && margin < m.spacing.norm())
    warnings->push_back("simulation: margin " + shortest_text(margin) +
                        " is below the cell diagonal " + shortest_text(m.spacing.norm()) +
                        ": parts of the mesh near its surface may lie outside the body and not "
                        "show");
  const Eigen::Vector3i samples = m.cells + Eigen::Vector3i::Ones();
  Grid3<std::uint8_t> mask(-half_extents - 0.5 * m.spacing, m.spacing, samples, 0);
  std::vector<double> distance(mask.size());
  parallel_for(
      samples.z(),
      [&](long k) {
        for (int j = 0; j < samples.y(); ++j)
          for (int i = 0; i < samples.x(); ++i) {
            const size_t at = mask.index(i, j, static_cast<int>(k));
            distance[at] =
                input.signed_distance(-half_extents + m.spacing.cwiseProduct(Eigen::Vector3d(
                                                          i, j, static_cast<double>(k))));
            mask.data[at] = distance[at] > -margin ? 1 : 0;
          }
      },
      interrupter, "simulation body");
  long inside = 0;
  for (std::uint8_t v : mask.data) inside += v;
  if (inside > kMaxSimulationNodes)
    throw Error("resolution: the body would have " + std::to_string(inside) +
                " nodes, more than the " + std::to_string(kMaxSimulationNodes) +
                " allowed; lower it");

  std::vector<Eigen::Vector3i> sample_of;
  if (params.model == SimModel::grid) {
    physics::GridModel g = physics::grid_model(mask, params.density, params.ks, params.kd);
    m.system = std::move(g.system);
    sample_of = std::move(g.sample);
  } else {
    physics::TetMesh tets = physics::tetrahedralize(mask);
    m.system = physics::mass_spring(tets, params.density, params.ks, params.kd);
    sample_of = tets.sample;
    m.body.tets = tets.tets;
    m.stats.tets = static_cast<int>(tets.tets.size());
    if (!tets.tets.empty()) {
      const physics::TetQuality q = physics::tet_quality(tets);
      m.stats.min_dihedral_deg = q.min_dihedral_deg;
      m.stats.max_aspect_ratio = q.max_aspect_ratio;
    }
  }
  m.body.model = params.model;
  m.body.half_extents = half_extents;
  m.body.cells = m.cells;
  m.body.spacing = m.spacing;
  m.body.sample = sample_of;
  m.node_of_sample.assign(mask.size(), -1);
  m.body.rest.resize(sample_of.size());
  for (size_t n = 0; n < sample_of.size(); ++n) {
    const Eigen::Vector3i& s = sample_of[n];
    m.node_of_sample[mask.index(s.x(), s.y(), s.z())] = static_cast<int>(n);
    m.body.rest[n] = -half_extents + m.spacing.cwiseProduct(s.cast<double>());
    m.system.x.segment<3>(3 * n) = m.body.rest[n];  // exactly on the lattice
  }
  m.system.gravity = params.gravity;

  // Cells of the body.
  int body_cells = 0;
  for (int k = 0; k < m.cells.z(); ++k)
    for (int j = 0; j < m.cells.y(); ++j)
      for (int i = 0; i < m.cells.x(); ++i) {
        bool all = true;
        for (int c = 0; c < 8 && all; ++c)
          all = m.node_of_sample[mask.index(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))] >=
                0;
        body_cells += all;
      }
  if (body_cells == 0)
    throw Error("resolution: the mesh part holds no cell of the body at " +
                std::to_string(params.resolution) +
                " cells along the box (it is thinner than a cell): raise resolution or margin");

  // Pins: the faces given, or those the mesh crosses.
  std::array<bool, 6> faces = params.pinned;
  if (!params.pins_given) {
    faces.fill(false);
    for (int f = 0; f < 6; ++f) {
      const int axis = f / 2, plane = (f % 2) ? m.cells[axis] : 0;
      for (int k = 0; k < samples.z() && !faces[f]; ++k)
        for (int j = 0; j < samples.y() && !faces[f]; ++j)
          for (int i = 0; i < samples.x() && !faces[f]; ++i)
            if (Eigen::Vector3i(i, j, k)[axis] == plane && distance[mask.index(i, j, k)] > 0)
              faces[f] = true;
    }
  }
  m.pinned_faces = faces;
  for (int f = 0; f < 6; ++f)
    if (faces[f])
      m.stats.pinned_faces += (m.stats.pinned_faces.empty() ? "" : ", ") + face_name(face_of(f));
  for (size_t n = 0; n < sample_of.size(); ++n)
    for (int f = 0; f < 6; ++f)
      if (faces[f] && sample_of[n][f / 2] == ((f % 2) ? m.cells[f / 2] : 0))
        m.system.pin(static_cast<int>(n));
  for (const Drag& drag : params.drags) {
    std::vector<int> nodes;
    const Eigen::Vector3d lo = -half_extents + 2.0 * half_extents.cwiseProduct(drag.sub_min);
    const Eigen::Vector3d hi = -half_extents + 2.0 * half_extents.cwiseProduct(drag.sub_max);
    for (size_t n = 0; n < m.body.rest.size(); ++n)
      if ((m.body.rest[n].array() >= lo.array() - 1e-12).all() &&
          (m.body.rest[n].array() <= hi.array() + 1e-12).all()) {
        nodes.push_back(static_cast<int>(n));
        m.system.pin(static_cast<int>(n));
      }
    if (nodes.empty() && warnings)
      warnings->push_back(
          "simulation: a drag's sub-box holds no node of the body; it drags nothing");
    m.stats.dragged += static_cast<int>(nodes.size());
    m.drag_nodes.push_back(std::move(nodes));
  }
  m.integrator = make_integrator(params.integrator);

  m.stats.cells = m.cells;
  m.stats.spacing = m.spacing;
  m.stats.margin = margin;
  m.stats.nodes = m.system.nodes();
  m.stats.springs = static_cast<int>(m.system.springs.size());
  m.stats.body_cells = body_cells;
  for (int n = 0; n < m.system.nodes(); ++n) m.stats.pinned += m.system.is_pinned(n);
  m.stats.total_mass = m.system.mass.sum();
  m.description = "simulation: " + sim_model_names()[static_cast<int>(params.model)] + " of " +
                  std::to_string(m.stats.nodes) + " nodes, " +
                  sim_integrator_names()[static_cast<int>(params.integrator)] + ", " +
                  std::to_string(params.steps) + " steps of " + shortest_text(params.dt) + " s";
  m.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void Simulation::run(long every, const Keep& keep, Interrupter* interrupter) {
  Impl& m = *impl_;
  const auto start = std::chrono::steady_clock::now();
  const double limit = 100.0 * 2.0 * m.h.norm();
  std::vector<Eigen::Vector3d> targets;
  while (m.system.steps < m.params.steps) {
    const long step = m.system.steps;
    const double t_next = static_cast<double>(step + 1) * m.params.dt;
    for (size_t d = 0; d < m.drag_nodes.size(); ++d) {
      if (m.drag_nodes[d].empty()) continue;
      const Eigen::Vector3d offset = m.params.drags[d].offset_at(t_next);
      targets.clear();
      for (int n : m.drag_nodes[d]) targets.push_back(m.body.rest[n] + offset);
      m.system.move_pinned(m.drag_nodes[d], targets);
    }
    const physics::StepResult r = m.integrator->step(m.system, m.params.dt);
    if (!r.ok())
      throw Error("simulation: " + r.message + ": the run is unstable; lower dt (now " +
                  shortest_text(m.params.dt) + " s) or ks, or use implicit_euler");
    m.stats.cg_iterations += r.iterations;
    m.stats.cg_capped += r.hit_cap;
    for (int n = 0; n < m.system.nodes(); ++n) {
      const double moved = (m.system.position(n) - m.body.rest[n]).norm();
      if (!(moved <= limit))
        throw Error("simulation: " + std::string(m.integrator->name()) + ": step " +
                    std::to_string(step) + " (t = " + shortest_text(step * m.params.dt) +
                    " s): node " + std::to_string(n) + " moved " + shortest_text(moved) +
                    " units from rest, beyond 100 box diagonals: the run is unstable; lower dt "
                    "(now " +
                    shortest_text(m.params.dt) + " s) or ks, or use implicit_euler");
    }
    m.stats.steps = m.system.steps;
    if (interrupter)
      interrupter->poll("simulation",
                        static_cast<double>(m.system.steps) / static_cast<double>(m.params.steps));
    const bool last = m.system.steps == m.params.steps;
    if (keep && (last || (every > 0 && m.system.steps % every == 0)))
      keep(m.system.steps, positions());
  }
  m.stats.seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<Eigen::Vector3d> Simulation::positions() const {
  std::vector<Eigen::Vector3d> out(impl_->system.nodes());
  for (int n = 0; n < impl_->system.nodes(); ++n) out[n] = impl_->system.position(n);
  return out;
}

const std::vector<Eigen::Vector3d>& Simulation::rest() const { return impl_->body.rest; }
const SimulationBody& Simulation::body() const { return impl_->body; }

std::unique_ptr<Deformer> Simulation::deformer(std::vector<Eigen::Vector3d> positions) const {
  if (positions.size() != impl_->body.rest.size())
    throw Error("simulation: a state of " + std::to_string(positions.size()) +
                " nodes for a body of " + std::to_string(impl_->body.rest.size()));
  return std::make_unique<LatticeDeformer>(impl_->params.model, impl_->h, impl_->cells,
                                           impl_->node_of_sample, positions, impl_->pinned_faces,
                                           impl_->description);
}

const SimulationStats& Simulation::stats() const { return impl_->stats; }
const SimulationParams& Simulation::params() const { return impl_->params; }

namespace {

// The cells (lower corner samples) whose 8 corners are nodes of the body.
std::vector<Eigen::Vector3i> body_cells(const SimulationBody& body) {
  const Eigen::Vector3i samples = body.cells + Eigen::Vector3i::Ones();
  std::vector<std::uint8_t> node(static_cast<size_t>(samples.prod()), 0);
  auto index = [&](const Eigen::Vector3i& s) {
    return static_cast<size_t>(s.x()) +
           static_cast<size_t>(samples.x()) *
               (static_cast<size_t>(s.y()) + static_cast<size_t>(samples.y()) * s.z());
  };
  for (const Eigen::Vector3i& s : body.sample) node[index(s)] = 1;
  std::vector<Eigen::Vector3i> cells;
  for (int k = 0; k < body.cells.z(); ++k)
    for (int j = 0; j < body.cells.y(); ++j)
      for (int i = 0; i < body.cells.x(); ++i) {
        bool all = true;
        for (int c = 0; c < 8 && all; ++c)
          all = node[index({i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)})] != 0;
        if (all) cells.emplace_back(i, j, k);
      }
  return cells;
}

}  // namespace

long refined_tet_count(const SimulationBody& body, int k) {
  return 6L * k * k * k * static_cast<long>(body_cells(body).size());
}

SimulationBody refine_body(const SimulationBody& body, int k, long max_tets) {
  if (k < 1 || k > 8) throw Error("refine: " + std::to_string(k) + ": must be in [1, 8]");
  const std::vector<Eigen::Vector3i> cells = body_cells(body);
  const long count = 6L * k * k * k * static_cast<long>(cells.size());
  if (count > max_tets)
    throw Error("refine: " + std::to_string(k) + " gives " + std::to_string(count) +
                " tetrahedra, more than the " + std::to_string(max_tets) +
                " allowed: lower it (or the simulation's resolution)");
  const Eigen::Vector3i fine_cells = body.cells * k;
  const Eigen::Vector3d fine_spacing = body.spacing / k;
  Grid3<std::uint8_t> mask(-body.half_extents - 0.5 * fine_spacing, fine_spacing,
                           fine_cells + Eigen::Vector3i::Ones(), 0);
  for (const Eigen::Vector3i& c : cells)
    for (int dk = 0; dk <= k; ++dk)
      for (int dj = 0; dj <= k; ++dj)
        for (int di = 0; di <= k; ++di) mask.at(c.x() * k + di, c.y() * k + dj, c.z() * k + dk) = 1;
  // Every finer cell of a cell that is not the body's has a corner strictly inside that cell
  // (k >= 2), which stays unmarked, so tetrahedralize splits exactly the body's cells.
  physics::TetMesh tets = physics::tetrahedralize(mask);
  SimulationBody out;
  out.model = body.model;
  out.half_extents = body.half_extents;
  out.cells = fine_cells;
  out.spacing = fine_spacing;
  out.sample = std::move(tets.sample);
  out.rest.reserve(out.sample.size());
  for (const Eigen::Vector3i& s : out.sample)
    out.rest.push_back(-body.half_extents + fine_spacing.cwiseProduct(s.cast<double>()));
  out.tets = std::move(tets.tets);
  return out;
}

}  // namespace raywarp
