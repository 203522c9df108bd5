#include "physics/block_system.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "physics/parallel.h"

namespace raywarp::physics::detail {

namespace {

inline Eigen::Vector3d times(const Sym3& a, const double* p) {
  return Eigen::Vector3d(a.xx * p[0] + a.xy * p[1] + a.xz * p[2],
                         a.xy * p[0] + a.yy * p[1] + a.yz * p[2],
                         a.xz * p[0] + a.yz * p[1] + a.zz * p[2]);
}

inline void add(Sym3& a, const Sym3& b, double sign) {
  a.xx += sign * b.xx;
  a.xy += sign * b.xy;
  a.xz += sign * b.xz;
  a.yy += sign * b.yy;
  a.yz += sign * b.yz;
  a.zz += sign * b.zz;
}

}  // namespace

double dot(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const double* pa = a.data();
  const double* pb = b.data();
  return chunked_sum(a.size(), [&](std::ptrdiff_t s, std::ptrdiff_t e) {
    double sum = 0;
    for (std::ptrdiff_t k = s; k < e; ++k) sum += pa[k] * pb[k];
    return sum;
  });
}

void BlockSystem::prepare(const MassSpring& s, const std::shared_ptr<const SpringAdjacency>& a) {
  if (adjacency_ == a && pinned_ == s.pinned) return;
  adjacency_ = a;
  pinned_ = s.pinned;
  const int n = s.nodes();
  row_of_.assign(n, -1);
  node_.clear();
  for (int i = 0; i < n; ++i) {
    if (!s.is_pinned(i)) {
      row_of_[i] = static_cast<int>(node_.size());
      node_.push_back(i);
    }
  }
  rows_ = static_cast<int>(node_.size());
  start_.assign(static_cast<size_t>(rows_) + 1, 0);
  col_.clear();
  slot_.assign(a->spring.size(), -1);
  std::vector<int> block_of(rows_, -1);  // column -> block in the current row
  for (int r = 0; r < rows_; ++r) {
    const int i = node_[r];
    start_[r] = static_cast<int>(col_.size());
    col_.push_back(r);
    for (int k = a->start[i]; k < a->start[i + 1]; ++k) {
      const int c = row_of_[a->other[k]];
      if (c < 0 || c == r) continue;  // pinned neighbour (Δv = 0), or a spring to itself
      if (block_of[c] < 0) {
        block_of[c] = static_cast<int>(col_.size());
        col_.push_back(c);
      }
      slot_[k] = block_of[c];
    }
    for (int b = start_[r] + 1; b < static_cast<int>(col_.size()); ++b) block_of[col_[b]] = -1;
  }
  start_[rows_] = static_cast<int>(col_.size());
  value_.assign(col_.size(), Sym3{});
  inv_diag_.resize(3 * rows_);
}

void BlockSystem::fill(const MassSpring& s, const std::vector<Sym3>& c) {
  const SpringAdjacency& a = *adjacency_;
  for_each_index(rows_, 128, [&](std::ptrdiff_t r0, std::ptrdiff_t r1) {
    for (std::ptrdiff_t r = r0; r < r1; ++r) {
      const int i = node_[r];
      Sym3& d = value_[start_[r]];
      d = Sym3{};
      d.xx = d.yy = d.zz = s.mass[i];
      for (int b = start_[r] + 1; b < start_[r + 1]; ++b) value_[b] = Sym3{};
      for (int k = a.start[i]; k < a.start[i + 1]; ++k) {
        const Sym3& cs = c[a.spring[k]];
        add(d, cs, 1.0);
        if (slot_[k] >= 0) add(value_[slot_[k]], cs, -1.0);
      }
      // Eigen's DiagonalPreconditioner: 1 / a_kk, or 1 where a_kk = 0.
      const double diag[3] = {d.xx, d.yy, d.zz};
      for (int e = 0; e < 3; ++e) inv_diag_[3 * r + e] = diag[e] != 0 ? 1.0 / diag[e] : 1.0;
    }
  });
}

void BlockSystem::multiply(const Eigen::VectorXd& p, Eigen::VectorXd& y) const {
  y.resize(3 * rows_);
  const double* pp = p.data();
  double* py = y.data();
  for_each_index(rows_, 256, [&](std::ptrdiff_t r0, std::ptrdiff_t r1) {
    for (std::ptrdiff_t r = r0; r < r1; ++r) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int b = start_[r]; b < start_[r + 1]; ++b) sum += times(value_[b], pp + 3 * col_[b]);
      py[3 * r] = sum[0];
      py[3 * r + 1] = sum[1];
      py[3 * r + 2] = sum[2];
    }
  });
}

BlockSystem::CgResult BlockSystem::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x,
                                         double tolerance, int max_iterations) {
  const std::ptrdiff_t n = 3 * static_cast<std::ptrdiff_t>(rows_);
  CgResult res;
  x.setZero(n);
  const double rhs_norm2 = dot(b, b);
  if (rhs_norm2 == 0) return res;
  const double threshold =
      std::max(tolerance * tolerance * rhs_norm2, std::numeric_limits<double>::min());
  r_ = b;  // x = 0
  p_ = r_.cwiseProduct(inv_diag_);
  double residual2 = rhs_norm2;
  double abs_new = dot(r_, p_);
  const double* id = inv_diag_.data();
  while (res.products < max_iterations) {
    multiply(p_, q_);
    res.products += 1;
    const double alpha = abs_new / dot(p_, q_);
    double* px = x.data();
    double* pr = r_.data();
    const double* pp = p_.data();
    const double* pq = q_.data();
    // x += α p, r -= α q; then |r|² and r·M⁻¹r, in fixed chunks.
    residual2 = chunked_sum(n, [&](std::ptrdiff_t s, std::ptrdiff_t e) {
      double rr = 0;
      for (std::ptrdiff_t k = s; k < e; ++k) {
        px[k] += alpha * pp[k];
        pr[k] -= alpha * pq[k];
        rr += pr[k] * pr[k];
      }
      return rr;
    });
    if (residual2 < threshold) break;
    const double rz_sum = chunked_sum(n, [&](std::ptrdiff_t s, std::ptrdiff_t e) {
      double z = 0;
      for (std::ptrdiff_t k = s; k < e; ++k) z += pr[k] * (id[k] * pr[k]);
      return z;
    });
    const double abs_old = abs_new;
    abs_new = rz_sum;
    const double beta = abs_new / abs_old;
    double* pw = p_.data();
    for_each_index(n, 4096, [&](std::ptrdiff_t s, std::ptrdiff_t e) {
      for (std::ptrdiff_t k = s; k < e; ++k) pw[k] = id[k] * pr[k] + beta * pw[k];
    });
  }
  res.residual = std::sqrt(residual2 / rhs_norm2);
  res.converged = res.residual <= tolerance;
  return res;
}

}  // namespace raywarp::physics::detail
