// Local/global's sparse LDLᵀ (internal to physics/): a nested-dissection ordering from the node
// positions, Eigen's SimplicialLDLT on the reordered matrix, and triangular solves of three
// right-hand sides at once (x, y and z share the matrix: one pass over the factor for all three).
//
// Ordering: the rows are split at the median of the longest extent of their positions; the rows
// of the lower half that have a neighbour in the upper half form the separator, numbered after
// both halves, which are ordered the same way in turn down to 64 rows. No fill joins the two
// halves, so each half's rows depend on that half only: the forward sweep (rows of L, a gather)
// does the halves in parallel and then the separator; the backward sweep (columns of L, also a
// gather) the separator and then the halves. Each row is computed by the same formula in the same
// order whatever the threads, so the results are the same for any thread count.
#pragma once
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

namespace raywarp::physics::detail {

struct LdltFactor {
  int n = 0;
  std::vector<int> perm;  // perm[k]: the row eliminated k-th
  // L (unit lower triangular, strictly lower part) by rows and by columns, in the new order.
  std::vector<int> row_start, row_col, col_start, col_row;
  std::vector<double> row_val, col_val;
  std::vector<double> inv_d;  // 1 / D
  struct Part {
    int begin = 0, mid = 0, sep = 0, end = 0;  // [begin, mid) and [mid, sep) halves, separator
    int low = -1, high = -1;                   // the halves' parts (-1: a leaf, rows in order)
  };
  std::vector<Part> parts;
  int root = -1;
  long nonzeros() const { return static_cast<long>(row_val.size()); }
};

// Factorises the symmetric positive definite `a` (its lower triangle is read) whose row r has the
// position pos[r] and the neighbours of the matrix's pattern. Throws Error if it fails.
std::shared_ptr<const LdltFactor> ldlt_factor(const Eigen::SparseMatrix<double>& a,
                                              const std::vector<Eigen::Vector3d>& pos);

// Solves A X = B for B with three columns (rows x 3, node-major rows), in place.
void ldlt_solve3(const LdltFactor& f, Eigen::MatrixXd& b, std::vector<double>& scratch);

}  // namespace raywarp::physics::detail
