#include "physics/ldlt.h"

#include <tbb/parallel_invoke.h>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <numeric>

#include "base/error.h"
#include "physics/parallel.h"

namespace raywarp::physics::detail {

namespace {

constexpr int kLeafRows = 64;
constexpr int kParallelDepth = 4;  // tasks down to 16 parts; below, each part runs alone

struct Dissection {
  const std::vector<int>& start;  // the graph (CSR, the matrix's off-diagonal pattern)
  const std::vector<int>& nbr;
  const std::vector<Eigen::Vector3d>& pos;
  std::vector<int> order;
  std::vector<int> tag;
  int next_tag = 0;
  std::vector<LdltFactor::Part> parts;

  // Orders `rows` (any order on entry) from order.size() on; returns the part.
  int dissect(std::vector<int> rows) {
    LdltFactor::Part part;
    part.begin = static_cast<int>(order.size());
    if (static_cast<int>(rows.size()) <= kLeafRows) {
      std::sort(rows.begin(), rows.end());
      order.insert(order.end(), rows.begin(), rows.end());
      part.mid = part.sep = part.begin;
      part.end = static_cast<int>(order.size());
      parts.push_back(part);
      return static_cast<int>(parts.size()) - 1;
    }
    Eigen::Vector3d lo = pos[rows[0]], hi = lo;
    for (int r : rows) {
      lo = lo.cwiseMin(pos[r]);
      hi = hi.cwiseMax(pos[r]);
    }
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    auto less = [&](int a, int b) {
      return pos[a][axis] != pos[b][axis] ? pos[a][axis] < pos[b][axis] : a < b;
    };
    const size_t half = rows.size() / 2;
    std::nth_element(rows.begin(), rows.begin() + half, rows.end(), less);
    const int low_tag = next_tag++, high_tag = next_tag++;
    for (size_t k = 0; k < rows.size(); ++k) tag[rows[k]] = k < half ? low_tag : high_tag;
    std::vector<int> low, high(rows.begin() + half, rows.end()), sep;
    for (size_t k = 0; k < half; ++k) {
      const int r = rows[k];
      bool touches = false;
      for (int e = start[r]; e < start[r + 1] && !touches; ++e) touches = tag[nbr[e]] == high_tag;
      (touches ? sep : low).push_back(r);
    }
    rows.clear();
    rows.shrink_to_fit();
    const int lo_part = dissect(std::move(low));
    part.mid = static_cast<int>(order.size());
    const int hi_part = dissect(std::move(high));
    part.sep = static_cast<int>(order.size());
    std::sort(sep.begin(), sep.end());
    order.insert(order.end(), sep.begin(), sep.end());
    part.end = static_cast<int>(order.size());
    part.low = lo_part;
    part.high = hi_part;
    parts.push_back(part);
    return static_cast<int>(parts.size()) - 1;
  }
};

// Forward sweep of rows [b, e): y_i -= Σ_j L_ij y_j.
void forward_rows(const LdltFactor& f, double* y, int b, int e) {
  for (int i = b; i < e; ++i) {
    double s0 = y[3 * i], s1 = y[3 * i + 1], s2 = y[3 * i + 2];
    for (int p = f.row_start[i]; p < f.row_start[i + 1]; ++p) {
      const double l = f.row_val[p];
      const double* yj = y + 3 * f.row_col[p];
      s0 -= l * yj[0];
      s1 -= l * yj[1];
      s2 -= l * yj[2];
    }
    y[3 * i] = s0;
    y[3 * i + 1] = s1;
    y[3 * i + 2] = s2;
  }
}

// Backward sweep of columns [b, e), last first: y_j -= Σ_i L_ij y_i.
void backward_cols(const LdltFactor& f, double* y, int b, int e) {
  for (int j = e - 1; j >= b; --j) {
    double s0 = y[3 * j], s1 = y[3 * j + 1], s2 = y[3 * j + 2];
    for (int p = f.col_start[j]; p < f.col_start[j + 1]; ++p) {
      const double l = f.col_val[p];
      const double* yi = y + 3 * f.col_row[p];
      s0 -= l * yi[0];
      s1 -= l * yi[1];
      s2 -= l * yi[2];
    }
    y[3 * j] = s0;
    y[3 * j + 1] = s1;
    y[3 * j + 2] = s2;
  }
}

void forward(const LdltFactor& f, double* y, int part, int depth) {
  const LdltFactor::Part& p = f.parts[part];
  if (p.low < 0 || depth >= kParallelDepth) {
    forward_rows(f, y, p.begin, p.end);
    return;
  }
  tbb::parallel_invoke([&] { forward(f, y, p.low, depth + 1); },
                       [&] { forward(f, y, p.high, depth + 1); });
  forward_rows(f, y, p.sep, p.end);
}

void backward(const LdltFactor& f, double* y, int part, int depth) {
  const LdltFactor::Part& p = f.parts[part];
  if (p.low < 0 || depth >= kParallelDepth) {
    backward_cols(f, y, p.begin, p.end);
    return;
  }
  backward_cols(f, y, p.sep, p.end);
  tbb::parallel_invoke([&] { backward(f, y, p.low, depth + 1); },
                       [&] { backward(f, y, p.high, depth + 1); });
}

}  // namespace

std::shared_ptr<const LdltFactor> ldlt_factor(const Eigen::SparseMatrix<double>& a,
                                              const std::vector<Eigen::Vector3d>& pos) {
  const int n = static_cast<int>(a.rows());
  auto f = std::make_shared<LdltFactor>();
  f->n = n;
  // The graph of the pattern (both triangles, no diagonal).
  std::vector<int> start(n + 1, 0), nbr;
  {
    std::vector<std::vector<int>> lists(n);
    for (int c = 0; c < a.outerSize(); ++c) {
      for (Eigen::SparseMatrix<double>::InnerIterator e(a, c); e; ++e) {
        const int r = static_cast<int>(e.row());
        if (r == c) continue;
        lists[r].push_back(c);
        lists[c].push_back(r);
      }
    }
    for (int r = 0; r < n; ++r) {
      std::sort(lists[r].begin(), lists[r].end());
      lists[r].erase(std::unique(lists[r].begin(), lists[r].end()), lists[r].end());
      start[r + 1] = start[r] + static_cast<int>(lists[r].size());
      nbr.insert(nbr.end(), lists[r].begin(), lists[r].end());
    }
  }
  Dissection d{start, nbr, pos, {}, std::vector<int>(n, -1), 0, {}};
  d.order.reserve(n);
  if (n > 0) {
    std::vector<int> all(n);
    std::iota(all.begin(), all.end(), 0);
    f->root = d.dissect(std::move(all));
  }
  f->perm = std::move(d.order);
  f->parts = std::move(d.parts);
  std::vector<int> inv(n);
  for (int k = 0; k < n; ++k) inv[f->perm[k]] = k;
  // P A Pᵀ, lower triangle, factorised in that order.
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(a.nonZeros());
  for (int c = 0; c < a.outerSize(); ++c) {
    for (Eigen::SparseMatrix<double>::InnerIterator e(a, c); e; ++e) {
      if (e.row() < c) continue;
      const int r = inv[e.row()], cc = inv[c];
      t.emplace_back(std::max(r, cc), std::min(r, cc), e.value());
    }
  }
  Eigen::SparseMatrix<double> b(n, n);
  b.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>>
      ldlt;
  ldlt.compute(b);
  if (ldlt.info() != Eigen::Success) {
    throw Error("physics: local/global: the factorisation of M + h² L failed");
  }
  const Eigen::SparseMatrix<double>& l = ldlt.matrixL().nestedExpression();
  // By columns (Eigen's storage), then by rows.
  f->col_start.assign(n + 1, 0);
  std::vector<int> row_count(n, 0);
  for (int c = 0; c < n; ++c) {
    for (Eigen::SparseMatrix<double>::InnerIterator e(l, c); e; ++e) {
      if (e.row() <= c) continue;
      f->col_row.push_back(static_cast<int>(e.row()));
      f->col_val.push_back(e.value());
      row_count[e.row()] += 1;
    }
    f->col_start[c + 1] = static_cast<int>(f->col_row.size());
  }
  f->row_start.assign(n + 1, 0);
  for (int r = 0; r < n; ++r) f->row_start[r + 1] = f->row_start[r] + row_count[r];
  f->row_col.resize(f->col_row.size());
  f->row_val.resize(f->col_val.size());
  std::vector<int> fill(f->row_start.begin(), f->row_start.end() - 1);
  for (int c = 0; c < n; ++c) {  // columns in increasing order: each row's entries increasing
    for (int p = f->col_start[c]; p < f->col_start[c + 1]; ++p) {
      const int r = f->col_row[p];
      f->row_col[fill[r]] = c;
      f->row_val[fill[r]++] = f->col_val[p];
    }
  }
  f->inv_d.resize(n);
  const Eigen::VectorXd& dv = ldlt.vectorD();
  for (int k = 0; k < n; ++k) f->inv_d[k] = 1.0 / dv[k];
  return f;
}

void ldlt_solve3(const LdltFactor& f, Eigen::MatrixXd& b, std::vector<double>& y) {
  const int n = f.n;
  y.resize(3 * static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c) y[3 * k + c] = b(f.perm[k], c);
  }
  if (n == 0) return;
  const bool parallel = n >= kParallelMin;
  if (parallel) {
    forward(f, y.data(), f.root, 0);
  } else {
    forward_rows(f, y.data(), 0, n);
  }
  for (int k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c) y[3 * k + c] *= f.inv_d[k];
  }
  if (parallel) {
    backward(f, y.data(), f.root, 0);
  } else {
    backward_cols(f, y.data(), 0, n);
  }
  for (int k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c) b(f.perm[k], c) = y[3 * k + c];
  }
}

}  // namespace raywarp::physics::detail
